"""Propagation medium: air. Speed of sound, density and ISO 9613-1 atmospheric absorption."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mitsonar.validation import check_finite, check_range

#: Reference conditions of ISO 9613-1.
_T0 = 293.15  # K
_T01 = 273.16  # K, triple point of water
_P_REF = 101_325.0  # Pa
_R_DRY_AIR = 287.058  # J/(kg K)


@dataclass(frozen=True)
class Medium:
    """Still air.

    Attributes:
        temperature: air temperature [K].
        relative_humidity: relative humidity [%], 0..100.
        pressure: static pressure [Pa].
    """

    temperature: float = 293.15
    relative_humidity: float = 50.0
    pressure: float = 101_325.0

    def __post_init__(self):
        check_range("Medium.temperature [K]", self.temperature, 200.0, 350.0)
        check_range("Medium.relative_humidity [%]", self.relative_humidity, 0.0, 100.0)
        check_range("Medium.pressure [Pa]", self.pressure, 5e4, 1.2e5)

    @property
    def speed_of_sound(self) -> float:
        """Speed of sound [m/s], c = 331.3 sqrt(1 + T/273.15) with T in degrees Celsius."""
        return 331.3 * float(np.sqrt(self.temperature / 273.15))

    @property
    def density(self) -> float:
        """Density of dry air from the ideal gas law [kg/m^3]."""
        return self.pressure / (_R_DRY_AIR * self.temperature)

    @property
    def impedance(self) -> float:
        """Characteristic acoustic impedance rho*c [Rayl = Pa s/m]."""
        return self.density * self.speed_of_sound

    def wavenumber(self, frequency) -> np.ndarray:
        """Wavenumber k = 2 pi f / c [rad/m] for frequency [Hz]."""
        return 2.0 * np.pi * np.asarray(frequency, dtype=float) / self.speed_of_sound

    def absorption_db_per_m(self, frequency) -> np.ndarray:
        """Pure-tone atmospheric absorption coefficient [dB/m] of ISO 9613-1:1993, eq. (3)-(5).

        Args:
            frequency: frequency [Hz], any shape.
        """
        f = np.asarray(frequency, dtype=float)
        check_finite("frequency [Hz]", f)
        t = self.temperature
        pa = self.pressure / _P_REF
        c_sat = -6.8346 * (_T01 / t) ** 1.261 + 4.6151
        h = self.relative_humidity * 10.0 ** c_sat / pa  # molar concentration of water vapour [%]
        fr_o = pa * (24.0 + 4.04e4 * h * (0.02 + h) / (0.391 + h))
        fr_n = pa * (t / _T0) ** -0.5 * (9.0 + 280.0 * h * np.exp(-4.170 * ((t / _T0) ** (-1 / 3) - 1)))
        return 8.686 * f**2 * (
            1.84e-11 / pa * (t / _T0) ** 0.5
            + (t / _T0) ** -2.5 * (0.01275 * np.exp(-2239.1 / t) / (fr_o + f**2 / fr_o)
                                   + 0.1068 * np.exp(-3352.0 / t) / (fr_n + f**2 / fr_n)))

    def amplitude_attenuation(self, distance, frequency) -> np.ndarray:
        """Pressure amplitude factor 10^(-alpha d / 20) over ``distance`` [m] at ``frequency`` [Hz]."""
        return 10.0 ** (-self.absorption_db_per_m(frequency) * np.asarray(distance) / 20.0)
