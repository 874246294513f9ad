"""Transmitted waveforms and their spectra."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import czt

from mitsonar.validation import check_positive, check_range

#: Oversampling used to evaluate a pulse's continuous-time spectrum by direct summation [Hz].
_SPECTRUM_RATE = 4.0e6
#: The frequency sweeps a sonar configuration can be driven by for single-ping imaging, by name
#: ([kHz] from - to; :meth:`~mitsonar.sensors.sonar.SonarConfig.with_drive`).
SWEEPS = ("30-50", "20-80")


@dataclass(frozen=True)
class Pulse:
    """Sinusoidal tone burst s(t) = e(t) sin(2 pi f t), 0 <= t <= cycles / f.

    The envelope e is 1 with raised-cosine ramps of ``ramp_cycles`` periods at both ends (0 gives
    the hard-gated burst of the paper's equation (1)).

    Attributes:
        frequency: carrier frequency f [Hz].
        cycles: number of carrier periods.
        ramp_cycles: length of each raised-cosine ramp [periods].
    """

    frequency: float = 40_000.0
    cycles: float = 20.0
    ramp_cycles: float = 1.0

    def __post_init__(self):
        check_positive("Pulse.frequency [Hz]", self.frequency)
        check_positive("Pulse.cycles", self.cycles)
        check_range("Pulse.ramp_cycles", self.ramp_cycles, 0.0, self.cycles / 2)

    @property
    def duration(self) -> float:
        """Length of the burst [s]."""
        return self.cycles / self.frequency

    def envelope(self, t) -> np.ndarray:
        """Envelope e(t) at times t [s] (0 outside the burst)."""
        return ramped(t, self.duration, self.ramp_cycles / self.frequency)

    def analytic(self, t) -> np.ndarray:
        """Analytic signal e(t) exp(j(2 pi f t - pi/2)); its real part is s(t)."""
        t = np.asarray(t, dtype=float)
        return self.envelope(t) * np.exp(1j * (2 * np.pi * self.frequency * t - np.pi / 2))

    def waveform(self, t) -> np.ndarray:
        """The real drive s(t) at times t [s]."""
        t = np.asarray(t, dtype=float)
        return self.envelope(t) * np.sin(2 * np.pi * self.frequency * t)

    @property
    def bandwidth(self) -> float:
        """Width of the burst's main spectral lobe about the carrier [Hz] (1 / duration)."""
        return 1.0 / self.duration

    def spectrum(self, frequency) -> np.ndarray:
        """Continuous-time Fourier transform S(f) = int s(t) exp(-j 2 pi f t) dt [s] of the burst."""
        return spectrum_of(self, frequency)


@dataclass(frozen=True)
class Chirp:
    """Linear frequency sweep s(t) = e(t) sin(2 pi (f0 t + (f1 - f0) t^2 / (2 T))), 0 <= t <= T,
    the broadband drive of in-air imaging sonars (RTIS sweeps 20-80 kHz): after the matched
    filter its echo is ~1 / (f1 - f0) long (50 us, 1.7 cm of range for 30-50 kHz) whatever T, so
    a long sweep gains energy without losing range resolution, and a receive beam's side lobes,
    which move with frequency, average over the band (docs/imaging.md).

    The envelope e is 1 with raised-cosine ramps over ``taper`` / 2 of T at both ends (a Tukey
    window), which keeps the spectrum's ripple and range side lobes low.

    The trace evaluates element patterns, patch integrals and air absorption at the centre
    frequency ``frequency``, as for every waveform: over 30-50 kHz (the broadband transducers'
    band, the same approximation as their tone bursts) a TCT40-sized piston's pattern at the
    field of view's corner (34 deg) runs from +1.8 to -2.6 dB of its 40 kHz value; a sweep as
    wide as RTIS's (20-80 kHz) would be far off (-24 dB at 80 kHz against 50 kHz there).

    Attributes:
        start: f0, the sweep's first frequency [Hz].
        stop: f1, its last frequency [Hz] (above or below ``start``).
        duration: T [s].
        taper: share of T ramped, half at each end (0: hard gate, 1: Hann window).
    """

    start: float = 30_000.0
    stop: float = 50_000.0
    duration: float = 4e-3
    taper: float = 0.1

    def __post_init__(self):
        check_positive("Chirp.start [Hz]", self.start)
        check_positive("Chirp.stop [Hz]", self.stop)
        check_positive("Chirp.duration [s]", self.duration)
        check_range("Chirp.taper", self.taper, 0.0, 1.0)
        if self.start == self.stop:
            raise ValueError(f"Chirp.start and Chirp.stop [Hz] must differ, both {self.start}")

    @property
    def frequency(self) -> float:
        """Centre of the sweep [Hz]: where the trace evaluates frequency-dependent factors."""
        return 0.5 * (self.start + self.stop)

    @property
    def bandwidth(self) -> float:
        """Swept band |f1 - f0| [Hz]."""
        return abs(self.stop - self.start)

    def envelope(self, t) -> np.ndarray:
        """Envelope e(t) at times t [s] (0 outside the sweep)."""
        return ramped(t, self.duration, 0.5 * self.taper * self.duration)

    def phase(self, t) -> np.ndarray:
        """Instantaneous phase 2 pi (f0 t + (f1 - f0) t^2 / (2 T)) [rad] at times t [s]."""
        t = np.asarray(t, dtype=float)
        return 2 * np.pi * (self.start + 0.5 * (self.stop - self.start) / self.duration * t) * t

    def analytic(self, t) -> np.ndarray:
        """e(t) exp(j(phase(t) - pi/2)); its real part is s(t) (analytic to within the taper's
        spectral spread below 0 Hz, far below the band)."""
        return self.envelope(t) * np.exp(1j * (self.phase(t) - np.pi / 2))

    def waveform(self, t) -> np.ndarray:
        """The real drive s(t) at times t [s]."""
        return self.envelope(t) * np.sin(self.phase(t))

    def spectrum(self, frequency) -> np.ndarray:
        """Continuous-time Fourier transform S(f) [s] of the sweep."""
        return spectrum_of(self, frequency)


def ramped(t, duration: float, ramp: float) -> np.ndarray:
    """1 on [0, ``duration``] [s] with raised-cosine ramps of ``ramp`` [s] at both ends, 0
    outside, at times t [s]."""
    t = np.asarray(t, dtype=float)
    inside = (t >= 0) & (t <= duration)
    if ramp == 0:
        return inside.astype(float)
    edge = np.clip(np.minimum(t, duration - t) / ramp, 0.0, 1.0)
    return np.where(inside, 0.5 - 0.5 * np.cos(np.pi * edge), 0.0)


def spectrum_of(signal, frequency) -> np.ndarray:
    """Fourier transform [s] of a finite real waveform (``waveform(t)`` on [0, ``duration``]),
    by direct summation at 4 MHz: exact for the band-limited signals used here."""
    f = np.asarray(frequency, dtype=float)
    dt = 1.0 / _SPECTRUM_RATE
    t = np.arange(0.0, signal.duration + dt / 2, dt)
    x = signal.waveform(t)
    flat = f.ravel()
    order = np.argsort(flat, kind="stable")  # FFT bins about a centre come in wrapped order
    ascending = flat[order]
    step = ascending[1] - ascending[0] if flat.size > 1 else 0.0
    if flat.size > 64 and step > 0 and np.allclose(np.diff(ascending), step, rtol=1e-9,
                                                   atol=0.0):
        # A uniform frequency grid (e.g. FFT bins): the same sums by the chirp z-transform.
        out = np.empty(flat.size, dtype=complex)
        out[order] = czt(x, flat.size, np.exp(-2j * np.pi * step * dt),
                         np.exp(2j * np.pi * ascending[0] * dt))
        return out.reshape(f.shape) * dt
    return (np.exp(-2j * np.pi * f[..., None] * t) @ x) * dt


def phasor(angle) -> np.ndarray:
    """exp(j angle), complex64, from single-precision cosine and sine: ~10x faster than np.exp;
    phase error ~6e-8 |angle| [rad], so meant for angles up to ~1e3 rad."""
    angle = np.asarray(angle, dtype=np.float32)
    return np.cos(angle) + 1j * np.sin(angle)
