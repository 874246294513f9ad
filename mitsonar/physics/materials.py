"""Acoustic materials at 40 kHz: impedance or absorption, scattering, and named presets.

A surface reflects the pressure amplitude r = (Z2 cos(theta) - Z1) / (Z2 cos(theta) + Z1)
(locally reacting surface; at normal incidence r = (Z2 - Z1)/(Z2 + Z1), whose square is the
paper's energy coefficient (4)). Z1 is the air's rho*c. Porous materials (foam, curtains) are
given by their normal-incidence energy absorption coefficient alpha instead; they get the real
impedance with the same normal-incidence |r| = sqrt(1 - alpha). Of the reflected energy, the
fraction ``scattering`` leaves diffusely (Lambert), the rest specularly.

Preset values. Impedances are rho*c of the bulk material (longitudinal wave speed), from Kinsler,
Frey, Coppens & Sanders, "Fundamentals of Acoustics", 4th ed., Appendix A10, and Kuttruff,
"Room Acoustics", 6th ed., Table 2.1 where the former has no entry:
  concrete rho 2300 kg/m^3, c 3700 m/s; glass 2500, 5600; steel 7700, 6100; gypsum board
  (drywall, plaster) 800, 2000 (Kuttruff gives 1.6e6 Rayl for gypsum); wood (pine, across the
  grain) 500, 3300.
Absorption at 40 kHz: open-cell polyurethane foam absorbs 0.9-0.95 above 4 kHz (manufacturers'
impedance-tube data, extrapolated flat); a heavy curtain hung in folds 0.6-0.7 above 2 kHz
(Kuttruff Table 6.1). Scattering coefficients are estimates from surface roughness against the
8.6 mm wavelength (smooth glass and metal 0.02; painted drywall 0.05; concrete, wood 0.1; foam
and fabric, rough on the wavelength scale, 0.5).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from mitsonar.validation import check_finite


@dataclass(frozen=True)
class AcousticMaterial:
    """Acoustic properties of a surface.

    Attributes:
        name: preset or material id.
        impedance: normal specific acoustic impedance Z2 [Rayl = Pa s/m], or None.
        absorption: normal-incidence energy absorption coefficient in [0, 1), or None.
            Exactly one of ``impedance`` and ``absorption`` is given.
        scattering: fraction of the reflected energy scattered diffusely, in [0, 1].
        transparent: acoustically transparent (rays pass through; e.g. the ``air`` preset).
        source: where the values come from.
    """

    name: str
    impedance: float | None = None
    absorption: float | None = None
    scattering: float = 0.05
    transparent: bool = False
    source: str = ""

    def __post_init__(self):
        where = f"acoustic material '{self.name}'"
        if (self.impedance is None) == (self.absorption is None) and not self.transparent:
            raise ValueError(f"{where}: give exactly one of 'impedance' [Rayl] or 'absorption'")
        if self.impedance is not None:
            check_finite(f"{where}: impedance [Rayl]", self.impedance)
            if self.impedance <= 0:
                raise ValueError(f"{where}: impedance must be > 0 Rayl, got {self.impedance}")
        if self.absorption is not None:
            check_finite(f"{where}: absorption", self.absorption)
            if not 0.0 <= self.absorption < 1.0:
                raise ValueError(f"{where}: absorption must lie in [0, 1), got {self.absorption}")
        check_finite(f"{where}: scattering", self.scattering)
        if not 0.0 <= self.scattering <= 1.0:
            raise ValueError(f"{where}: scattering must lie in [0, 1], got {self.scattering}")

    def with_changes(self, **changes) -> "AcousticMaterial":
        """Validated copy with some fields replaced."""
        if "impedance" in changes and "absorption" not in changes:
            changes["absorption"] = None
        if "absorption" in changes and "impedance" not in changes:
            changes["impedance"] = None
        return replace(self, **changes)

    def normal_impedance(self, air_impedance: float) -> float:
        """Z2 [Rayl]; for absorption-defined materials the real Z2 with |r| = sqrt(1 - alpha)."""
        if self.impedance is not None:
            return float(self.impedance)
        if self.absorption is None:  # transparent
            return float(air_impedance)
        r0 = np.sqrt(1.0 - self.absorption)
        return float(air_impedance * (1 + r0) / (1 - r0))

    def reflection_coefficient(self, cos_incidence, air_impedance: float) -> np.ndarray:
        """Pressure reflection coefficient r(theta) for cos of the incidence angle (any shape)."""
        z2 = self.normal_impedance(air_impedance) * np.asarray(cos_incidence, dtype=float)
        return (z2 - air_impedance) / (z2 + air_impedance)


def _solid(name, rho, c, scattering, note):
    return AcousticMaterial(name, impedance=rho * c, scattering=scattering,
                            source=f"rho={rho} kg/m^3, c={c} m/s ({note})")


#: Named presets; keys are the names accepted by ``<string name="preset">`` in scene files.
PRESETS: dict[str, AcousticMaterial] = {m.name: m for m in [
    AcousticMaterial("air", transparent=True, scattering=0.0,
                     source="acoustically transparent: rays pass through"),
    _solid("concrete", 2300, 3700, 0.10, "Kinsler et al. App. A10"),
    _solid("drywall", 800, 2000, 0.05, "gypsum board, Kuttruff Table 2.1"),
    _solid("plaster", 800, 2000, 0.05, "gypsum plaster, Kuttruff Table 2.1"),
    _solid("glass", 2500, 5600, 0.02, "Kinsler et al. App. A10"),
    _solid("wood", 500, 3300, 0.10, "pine across the grain, Kinsler et al. App. A10"),
    _solid("metal", 7700, 6100, 0.02, "steel, Kinsler et al. App. A10"),
    AcousticMaterial("foam", absorption=0.93, scattering=0.5,
                     source="open-cell PU foam, alpha 0.9-0.95 above 4 kHz"),
    AcousticMaterial("fabric", absorption=0.65, scattering=0.5,
                     source="heavy curtain in folds, Kuttruff Table 6.1"),
]}

#: Material given to shapes whose BSDF carries no acoustic properties.
DEFAULT_MATERIAL_NAME = "drywall"


def preset(name: str) -> AcousticMaterial:
    """The named preset; ValueError listing the known names otherwise."""
    try:
        return PRESETS[name]
    except KeyError:
        raise ValueError(f"unknown acoustic preset '{name}'; known presets: "
                         f"{', '.join(sorted(PRESETS))}") from None
