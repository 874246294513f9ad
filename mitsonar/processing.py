"""Echo processing: matched filter (6), delay-and-sum (5), envelope, time of arrival, depth (7).

Order and choices:

* Delay-and-sum (5) with the plane-wave delays t_j^B(psi) = -(p_j - o_R) . u / c relative to
  the receive origin o_R, applied exactly as phase ramps exp(j 2 pi f t_j^B) in the frequency
  domain (fractional delays without interpolation error).
* Matched filter (6) with the expected echo shape (drive pulse through both transducer
  responses), normalised so that an echo of path gain A gives an envelope peak of |A| [Pa].
  Beamforming and filtering share one FFT per channel and one inverse FFT.
* Envelope = |analytic output|; time of arrival at its strongest peak, refined by a parabola
  through the three samples around it.
* Detection: the peak must exceed ``detection_snr`` times the RMS noise envelope (known from the
  receiver noise), an absolute ``detection_floor``, ``blanking_margin`` times the envelope of the
  direct transmitter->receiver path alone (direct-path blanking), and lie beyond ``min_range``.
  Otherwise the result is "no detection": NaN depth and ``detected = False``.
* Depth by the bistatic (7): d = (l^2 - b^2) / (2 (l - b cos theta_b)), with theta_b the angle
  between the beam and the baseline vector (TX -> RX origin); point = d * u in the sensor frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.fft as sfft

from .array import ArrayGeometry
from .synthesis import EchoSynthesizer, Recording
from .validation import check_positive


@dataclass(frozen=True)
class DetectionSettings:
    """Receiver decision parameters.

    Attributes:
        detection_snr: threshold over the RMS noise envelope (5 gives a false-alarm probability
            of exp(-25) per sample).
        detection_floor: absolute threshold on the envelope [Pa] (matters without noise).
        blanking_margin: factor over the direct-path envelope a detection must exceed.
        min_range: nearest depth reported [m].
    """

    detection_snr: float = 5.0
    detection_floor: float = 1e-3
    blanking_margin: float = 2.0
    min_range: float = 0.2

    def __post_init__(self):
        for name in ("detection_snr", "detection_floor", "blanking_margin", "min_range"):
            check_positive(f"DetectionSettings.{name}", getattr(self, name))


@dataclass(frozen=True)
class Detection:
    """Result of processing one beam.

    Attributes:
        detected: True when an echo passed every test.
        time_of_arrival: [s] from the virtual firing of the transmit origin (NaN if none).
        path_length: l = c * time_of_arrival [m] (NaN if none).
        depth: distance from the transmit origin along the beam, (7) [m] (NaN if none).
        point: (3,) reflector in the sensor frame [m] (NaN if none).
        amplitude: strongest envelope value beyond the minimum range [Pa] (finite even when not
            detected: what the receiver saw).
        threshold: envelope level that amplitude had to exceed there [Pa].
    """

    detected: bool
    time_of_arrival: float
    path_length: float
    depth: float
    point: np.ndarray
    amplitude: float
    threshold: float


def bistatic_depth(path_length, baseline: float, cos_beam_baseline) -> np.ndarray:
    """Equation (7): depth [m] from path length l [m], baseline b [m] and cos(theta_b)."""
    l = np.asarray(path_length, dtype=float)
    return (l**2 - baseline**2) / (2.0 * (l - baseline * np.asarray(cos_beam_baseline)))


class EchoProcessor:
    """Turns recordings into detections; built once per sensor configuration and reused.

    Args:
        geometry: the arrays.
        synthesizer: supplies the expected echo spectrum and FFT size of the recordings.
        speed_of_sound: c [m/s].
        settings: detection parameters.
        noise_rms: receiver noise per sample [Pa] (sets the noise threshold).
    """

    def __init__(self, geometry: ArrayGeometry, synthesizer: EchoSynthesizer, speed_of_sound: float,
                 settings: DetectionSettings, noise_rms: float):
        self.geometry = geometry
        self.synth = synthesizer
        self.c = float(speed_of_sound)
        self.settings = settings
        w = synthesizer.system_spectrum
        energy = float(np.sum(np.abs(w) ** 2)) / synthesizer.n_fft  # sum |w_a[m]|^2 (Parseval)
        self._mf = 2.0 * np.conj(w) / energy  # 2: analytic spectrum of the real recording
        self.noise_envelope_rms = 2.0 * noise_rms / np.sqrt(energy * geometry.rx.count)
        self.carrier = synthesizer.pulse.frequency

    def receive_delays(self, direction) -> np.ndarray:
        """Plane-wave delays t_j^B(psi) of (5) [s], (N_rx,): channel j is read at t + t_j^B."""
        g = self.geometry
        return -((g.rx_positions - g.rx_origin) @ np.asarray(direction, dtype=float)) / self.c

    def beamform(self, recording: Recording, direction) -> np.ndarray:
        """Matched-filtered delay-and-sum output towards ``direction`` (3,): analytic (N,) [Pa]."""
        n = recording.samples.shape[1]
        x = sfft.fft(recording.samples, n=self.synth.n_fft, axis=-1)
        f = sfft.fftfreq(self.synth.n_fft, 1.0 / self.synth.sample_rate)
        steer = np.exp(2j * np.pi * f[None, :] * self.receive_delays(direction)[:, None])
        y = (x * steer).mean(axis=0) * self._mf
        return sfft.ifft(y)[:n]

    def envelope(self, recording: Recording, direction) -> np.ndarray:
        """Envelope (N,) [Pa] of the beamformed, matched-filtered recording."""
        return np.abs(self.beamform(recording, direction))

    def detect(self, envelope: np.ndarray, start_time: float, direction,
               direct_envelope: np.ndarray | None = None) -> Detection:
        """Time of arrival, depth and point from an envelope (N,) [Pa], or no detection.

        Args:
            envelope: processed envelope.
            start_time: time of its first sample [s].
            direction: (3,) beam direction in the sensor frame.
            direct_envelope: (N,) envelope of the direct path alone, for blanking (optional).
        """
        s = self.settings
        fs = self.synth.sample_rate
        g = self.geometry
        u = np.asarray(direction, dtype=float)
        t = start_time + np.arange(len(envelope)) / fs
        cos_b = float(u @ g.rx_origin) / g.baseline
        # Path length of the nearest reportable depth, from (7) solved for l.
        r_min = s.min_range
        l_min = r_min + np.sqrt(r_min**2 + g.baseline**2 - 2 * r_min * g.baseline * cos_b)
        threshold = np.full(len(envelope), max(s.detection_snr * self.noise_envelope_rms,
                                               s.detection_floor))
        if direct_envelope is not None:
            threshold = np.maximum(threshold, s.blanking_margin * direct_envelope)
        window = self.c * t >= l_min
        if not np.any(window):
            raise ValueError("the recording ends before the minimum range")
        masked = np.where(window, envelope, -np.inf)
        k = int(np.argmax(masked))
        amplitude = float(envelope[k])
        nan3 = np.full(3, np.nan)
        if amplitude <= threshold[k]:
            # The strongest sample fails; a weaker one may still pass where the threshold is lower.
            passing = window & (envelope > threshold)
            if not np.any(passing):
                return Detection(False, np.nan, np.nan, np.nan, nan3, amplitude, float(threshold[k]))
            k = int(np.argmax(np.where(passing, envelope, -np.inf)))
            amplitude = float(envelope[k])
        offset = 0.0
        if 0 < k < len(envelope) - 1:
            y0, y1, y2 = envelope[k - 1: k + 2]
            denom = y0 - 2 * y1 + y2
            if denom < 0:
                offset = 0.5 * (y0 - y2) / denom
        toa = float(t[k] + offset / fs)
        l = self.c * toa
        depth = float(bistatic_depth(l, g.baseline, cos_b))
        return Detection(True, toa, l, depth, depth * u, amplitude, float(threshold[k]))
