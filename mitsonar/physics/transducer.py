"""Air-coupled 40 kHz piezo transducer (TCT40-10T/R, 400PT120 class): directivity and response.

Datasheet values of this class (Pro-Wave 400PT120 transceiver, the same 10 mm can as TCT40-10):
centre frequency 40.0 +- 1.0 kHz; bandwidth (-6 dB) 2.0 kHz; transmitting SPL >= 115 dB re 20 uPa
per 10 Vrms at 30 cm; receiving sensitivity >= -68 dB re 1 V/ubar; total beam angle (-6 dB) 85
degrees; ringing <= 1.2 ms.

* Directivity: baffled circular piston, D(theta) = 2 J1(k a sin theta) / (k a sin theta). The
  effective radius a is chosen so that D = 1/2 at half the datasheet beam angle (42.5 degrees) at
  40 kHz and 343.2 m/s: k a sin(42.5 deg) = 2.2151 gives a = 4.48 mm (the can is 10 mm across).
* Frequency response: a second-order resonator H(f) = 1 / (1 + j Q (f/f0 - f0/f)), one for the
  transmitter and one for the receiver. |H| = 1/2 at Q |f/f0 - f0/f| = sqrt(3), so the datasheet's
  2 kHz (-6 dB) bandwidth gives Q = sqrt(3) f0 / 2 kHz = 34.6 (time constant Q/(pi f0) = 0.28 ms,
  which matches the <= 1.2 ms ringing).
* Level: 115 dB SPL at 0.3 m is 11.2 Pa rms, i.e. a peak amplitude of 4.8 Pa at 1 m on axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import j1

from mitsonar.validation import check_positive

#: -6 dB bandwidth [Hz] of the broadband elements the experiments and ``--broadband`` use
#: (:meth:`Transducer.broadband`): wide enough for the OFDM codes' tones (32-48 kHz).
BROADBAND_BANDWIDTH = 20e3


@dataclass(frozen=True)
class Transducer:
    """One array element.

    Attributes:
        radius: effective piston radius a [m].
        resonance_frequency: f0 [Hz].
        bandwidth_6db: full width of |H| >= 1/2 around f0 [Hz] (sets Q).
        source_amplitude: peak pressure on axis at 1 m for a drive at f0 [Pa].
    """

    radius: float = 4.48e-3
    resonance_frequency: float = 40_000.0
    bandwidth_6db: float = 2_000.0
    source_amplitude: float = 4.8

    def __post_init__(self):
        for name in ("radius", "resonance_frequency", "bandwidth_6db", "source_amplitude"):
            check_positive(f"Transducer.{name}", getattr(self, name))

    @classmethod
    def broadband(cls) -> "Transducer":
        """The same element with a :data:`BROADBAND_BANDWIDTH` (20 kHz) -6 dB bandwidth, Q 3.5."""
        return cls(bandwidth_6db=BROADBAND_BANDWIDTH)

    @property
    def quality_factor(self) -> float:
        """Q of the resonator, sqrt(3) f0 / bandwidth_6db."""
        return float(np.sqrt(3.0) * self.resonance_frequency / self.bandwidth_6db)

    @property
    def decay_time(self) -> float:
        """Amplitude decay time constant of the ringing, Q / (pi f0) [s]."""
        return self.quality_factor / (np.pi * self.resonance_frequency)

    def directivity(self, cos_theta, wavenumber) -> np.ndarray:
        """Piston directivity D for angle theta off the element normal (valid up to 90 deg; 0 behind).

        Args:
            cos_theta: cosine of the angle to the normal, any shape.
            wavenumber: k [rad/m], broadcastable.
        """
        cos_theta = np.asarray(cos_theta, dtype=float)
        sin_theta = np.sqrt(np.clip(1.0 - cos_theta**2, 0.0, 1.0))
        x = np.asarray(wavenumber) * self.radius * sin_theta
        small = x < 1e-6
        safe = np.where(small, 1.0, x)
        d = np.where(small, 1.0 - x**2 / 8.0, 2.0 * j1(safe) / safe)
        return np.where(cos_theta >= 0.0, d, 0.0)

    def frequency_response(self, frequency) -> np.ndarray:
        """Complex response H(f) of one transducer (unity at f0); 0 at f = 0.

        Args:
            frequency: frequency [Hz], any shape (>= 0).
        """
        f = np.asarray(frequency, dtype=float)
        f0 = self.resonance_frequency
        safe = np.where(f > 0, f, 1.0)
        h = 1.0 / (1.0 + 1j * self.quality_factor * (safe / f0 - f0 / safe))
        return np.where(f > 0, h, 0.0)
