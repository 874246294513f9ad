"""Echo processing: matched filter (6), delay-and-sum (5), envelope, time of arrival, depth (7).

Order and choices:

* Delay-and-sum (5) with the plane-wave delays t_j^B(psi) = -(p_j - o_R) . u / c relative to
  the receive origin o_R, applied exactly as phase ramps exp(j 2 pi f t_j^B) in the frequency
  domain (fractional delays without interpolation error).
* Matched filter (6) with the expected echo shape (drive pulse through both transducer
  responses), normalised so that an echo of path gain A gives an envelope peak of |A| [Pa].
  Beamforming and filtering share one FFT per channel and one inverse FFT, and are computed on
  the signal band only (:attr:`Band.bins <mitsonar.signal.band.Band.bins>`; the matched filter
  is zero elsewhere). Real and complex baseband recordings go through the same chain: their
  spectra on the band are the same (:meth:`Band.band_spectra
  <mitsonar.signal.band.Band.band_spectra>`); envelopes are sampled at the recording's rate.
* Envelope = |analytic output|; time of arrival at its strongest peak, refined by a parabola
  through the three samples around it.
* Detection: candidates are the envelope's local maxima beyond ``min_range`` that exceed
  ``detection_snr`` times the RMS noise envelope (known from the receiver noise), an absolute
  ``detection_floor``, and ``blanking_margin`` times the envelope of the direct
  transmitter->receiver path alone (direct-path blanking). Strongest first, a candidate is
  accepted unless it arrives from elsewhere: receive beams formed from the same recording at that
  instant over +-50 deg show it ``ghost_margin`` stronger outside the main lobe than
  along the beam (a side-lobe echo, e.g. the specular return of a tilted wall, which would give a
  wrong depth). Waveforms made of parts (OFDM codes: two tones, :class:`~mitsonar.signal.ofdm.Code`)
  are also matched-filtered part by part: a candidate is accepted only if every part is there
  with at least ``part_balance`` of the strongest part's envelope. Another code that shares one
  tone leaks into one part only (the paper's codes correlate at 1/2 through a shared half), so
  this rejects it where a threshold on the whole-code envelope could not.
  No accepted candidate gives "no detection": NaN depth and ``detected = False``.
* Arrival direction (``arrival_step`` > 0; beyond the paper, which places every point on the beam
  axis): the transmit beam lights everything within its main lobe, and at 3 m a reflector 3 deg
  off the axis is 16 cm from it. Where along the lobe the echo at the detected instant comes
  from is read from the receive array: the narrow-band delay-and-sum power at that instant over
  directions within ``ghost_exclusion`` of the beam (``arrival_step`` apart, refined by a
  parabola through the strongest and its neighbours along each axis), summed over the looks.
  Its maximum is the arrival direction u_a, seen from the receive origin o_R. A surface seen
  obliquely (a floor, a wall at 50 deg) returns first from the near edge of the lobe, not from
  its axis; that is where u_a points.
* Depth by the bistatic (7): d = (l^2 - b^2) / (2 (l - b cos theta_b)), with theta_b the angle
  between the beam and the baseline vector (TX -> RX origin); point = d * u in the sensor frame.
  With an arrival direction, (7) is solved from the receive side instead (range r from o_R along
  u_a, theta_b measured from the RX -> TX vector): point = o_R + r u_a, and the depth is the
  point's distance from the transmit origin.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse

from mitsonar.physics.array import ArrayGeometry
from mitsonar.frames import direction_from_fov_angles, fov_angles
from mitsonar.physics.waveforms import phasor
from mitsonar.signal.band import Band, Recording
from mitsonar.validation import check_positive


@dataclass(frozen=True)
class DetectionSettings:
    """Receiver decision parameters.

    Attributes:
        detection_snr: threshold over the RMS noise envelope (5 gives a false-alarm probability
            of exp(-25) per sample).
        detection_floor: absolute threshold on the envelope [Pa] (matters without noise).
        blanking_margin: factor over the direct-path envelope a detection must exceed.
        min_range: nearest depth reported [m].
        ghost_margin: factor by which an off-beam receive direction must beat the beam for a
            candidate to be rejected as a side-lobe arrival (0 disables the check).
        ghost_exclusion: half-angle around the beam treated as its main lobe [rad].
        ghost_grid_step: spacing of the receive directions checked [rad].
        ghost_half_span: the checked directions cover +-this horizontally and vertically [rad]
            (wider than the field of view: side-lobe echoes come from anywhere in front).
        max_candidates: envelope peaks examined, strongest first.
        part_balance: for waveforms with ``parts``, the weakest part's envelope over the
            strongest's that a candidate needs (in (0, 1]; an echo carries both equally).
        arrival_step: grid step of the arrival-direction estimate within the main lobe [rad]
            (module docstring; 0: every point on the beam axis, as the paper).
    """

    detection_snr: float = 5.0
    detection_floor: float = 1e-3
    blanking_margin: float = 2.0
    min_range: float = 0.2
    ghost_margin: float = 1.2
    ghost_exclusion: float = np.radians(6.0)
    ghost_grid_step: float = np.radians(2.0)
    ghost_half_span: float = np.radians(50.0)
    max_candidates: int = 8
    part_balance: float = 0.3
    arrival_step: float = np.radians(0.5)

    def __post_init__(self):
        for name in ("detection_snr", "detection_floor", "blanking_margin", "min_range",
                     "ghost_exclusion", "ghost_grid_step", "ghost_half_span"):
            check_positive(f"DetectionSettings.{name}", getattr(self, name))
        if not (np.isfinite(self.ghost_margin) and self.ghost_margin >= 0):
            raise ValueError(f"DetectionSettings.ghost_margin must be >= 0, got {self.ghost_margin}")
        if not (np.isfinite(self.arrival_step) and self.arrival_step >= 0):
            raise ValueError(f"DetectionSettings.arrival_step [rad] must be >= 0, got {self.arrival_step}")
        if not 0 < self.part_balance <= 1:
            raise ValueError(f"DetectionSettings.part_balance must be in (0, 1], got {self.part_balance}")
        if int(self.max_candidates) != self.max_candidates or self.max_candidates < 1:
            raise ValueError(f"DetectionSettings.max_candidates must be an integer >= 1, "
                             f"got {self.max_candidates}")


@dataclass(frozen=True)
class Detection:
    """Result of processing one beam.

    Attributes:
        detected: True when an echo passed every test.
        time_of_arrival: [s] from the virtual firing of the transmit origin (NaN if none).
        path_length: l = c * time_of_arrival [m] (NaN if none).
        depth: distance of the point from the transmit origin, (7) [m] (NaN if none); along the
            beam unless the arrival direction is estimated.
        point: (3,) reflector in the sensor frame [m] (NaN if none).
        direction: (3,) unit vector the echo arrived from, the beam's own direction without an
            arrival-direction estimate (NaN if none).
        amplitude: strongest envelope value beyond the minimum range [Pa] (finite even when not
            detected: what the receiver saw).
        threshold: envelope level that amplitude had to exceed there [Pa].
    """

    detected: bool
    time_of_arrival: float
    path_length: float
    depth: float
    point: np.ndarray
    direction: np.ndarray
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
        band: the recordings' band: sample grid, expected echo spectra, spectra of samples.
        speed_of_sound: c [m/s].
        settings: detection parameters.
        noise_rms: receiver noise per sample [Pa] (sets the noise threshold).
    """

    def __init__(self, geometry: ArrayGeometry, band: Band, speed_of_sound: float,
                 settings: DetectionSettings, noise_rms: float):
        self.geometry = geometry
        self.band = band
        self.c = float(speed_of_sound)
        self.settings = settings
        self.noise_rms = float(noise_rms)
        self._filters = {}
        # Side-lobe check: a ``ghost_grid_step`` grid over +-``ghost_half_span`` in both
        # field-of-view angles, the same for every beam, and its delay-and-sum per carrier [Hz].
        h = np.arange(-settings.ghost_half_span, settings.ghost_half_span + 1e-9,
                      settings.ghost_grid_step)
        hh, vv = np.meshgrid(h, h, indexing="ij")
        self._ghost_grid = direction_from_fov_angles(hh, vv).reshape(-1, 3)
        self._ghost_operators = {}
        # Of the last recording processed: its channel spectra and demodulated looks per
        # waveform (an OFDM cycle decodes every beam from one recording, and beams
        # whose codes share a tone share that tone's look).
        self._recording_cache = (None, {})
        self._steering = (None, None)  # (direction, (N_rx, nb) phasors) of the last beam formed
        # W [samples] of :meth:`_delay_and_sum`: the largest receive delay (5), rounded up, + 1.
        self._window_lag = int(np.ceil(
            np.linalg.norm(geometry.rx_positions - geometry.rx_origin, axis=1).max()
            / self.c * band.sample_rate)) + 1

    def _matched_filter(self, waveform=None):
        """(filter spectrum on the band (nb,), template energy) of a waveform: conj(W) / E,
        E = sum |w_a|^2 over the samples of a real recording at the reference rate."""
        key = self.band.pulse if waveform is None else waveform
        if key not in self._filters:
            w = self.band.system_spectrum(key)
            energy = float(np.sum(np.abs(w) ** 2)) / self.band.n_fft  # Parseval
            self._filters[key] = (np.conj(w[self.band.bins]) / energy, energy)
        return self._filters[key]

    def noise_envelope_rms(self, waveform=None) -> float:
        """RMS of the beamformed matched-filter envelope of receiver noise alone [Pa]."""
        energy = self._matched_filter(waveform)[1]
        return 2.0 * self.noise_rms / np.sqrt(energy * self.geometry.rx.count)

    def receive_delays(self, directions) -> np.ndarray:
        """Plane-wave delays t_j^B(psi) of (5) [s]: (N_rx,) for one direction (3,), (D, N_rx) for
        (D, 3). Channel j is read at t + t_j^B."""
        g = self.geometry
        return -(np.asarray(directions, dtype=float) @ (g.rx_positions - g.rx_origin).T) / self.c

    def _cached(self, recording: Recording, key, compute):
        """``compute()`` for ``key``, kept while ``recording`` is the last one processed."""
        if self._recording_cache[0] is not recording:
            self._recording_cache = (recording, {})
        cache = self._recording_cache[1]
        if key not in cache:
            cache[key] = compute()
        return cache[key]

    def compressed_spectra(self, recording: Recording, waveform=None) -> np.ndarray:
        """Matched-filtered analytic spectra of all channels on the band, (N_rx, nb)."""
        spectra = self._cached(recording, "spectra",
                               lambda: self.band.band_spectra(recording.samples))
        return spectra * self._matched_filter(waveform)[0]

    def look(self, recording: Recording, waveform=None) -> tuple[np.ndarray, float]:
        """(analytic channels (N_rx, N) matched-filtered for ``waveform`` and demodulated at its
        carrier, carrier [Hz]): one look of the side-lobe check and the arrival direction."""
        carrier = (self.band.pulse if waveform is None else waveform).frequency
        return self._cached(recording, ("look", waveform), lambda: (self._demodulated(
            self.compressed_spectra(recording, waveform), recording.samples.shape[1],
            recording.start_time, carrier), carrier))

    def beamform(self, spectra: np.ndarray, n_samples: int, direction) -> np.ndarray:
        """Delay-and-sum of compressed spectra (N_rx, nb) towards ``direction`` (3,): analytic
        (N,) [Pa]."""
        key = tuple(np.asarray(direction, dtype=float))
        if self._steering[0] != key:  # a beam is formed several times (code, tones, blanking)
            delays = self.receive_delays(direction)
            self._steering = (key, phasor(2 * np.pi * self.band.frequencies[None, :]
                                          * delays[:, None]))
        return self.band.to_analytic((spectra * self._steering[1]).mean(axis=0))[:n_samples]

    def envelope(self, recording: Recording, direction, waveform=None) -> np.ndarray:
        """Envelope (N,) [Pa] of the beamformed, matched-filtered recording."""
        n = recording.samples.shape[1]
        return np.abs(self.beamform(self.compressed_spectra(recording, waveform), n, direction))

    def noiseless_envelope(self, spectrum: np.ndarray, direction, waveform=None) -> np.ndarray:
        """Envelope (n_samples,) [Pa] of echoes given by their summed analytic spectrum on the
        band (N_rx, nb) (as the synthesizer's ``groups_spectrum`` gives them): :meth:`envelope`
        of their noiseless recording, except that echoes are not cut at the recording's end."""
        return np.abs(self.beamform(spectrum * self._matched_filter(waveform)[0],
                                    self.band.n_samples, direction))

    def _demodulated(self, spectra, n: int, start_time: float, carrier: float) -> np.ndarray:
        """(N_rx, n) analytic channels of compressed ``spectra`` (N_rx, nb) demodulated at
        ``carrier`` [Hz]; their first sample is at ``start_time`` [s]."""
        t = start_time + np.arange(n) / self.band.sample_rate
        # The band's analytic signals are already demodulated by its own carrier.
        shift = np.exp(-2j * np.pi * (carrier - self.band.carrier) * t)
        return self.band.to_analytic(spectra)[:, :n] * shift

    def _delay_and_sum(self, directions, carrier: float, fraction: float = 0.0):
        """Narrow-band delay-and-sum towards directions (D, 3) as a sparse (D, N_rx x L) matrix
        acting on windows of L = 2 W + 2 samples per channel of channels demodulated at
        ``carrier`` [Hz] (:meth:`_demodulated`): the window starting W samples before sample k
        gives the beams at sample k + ``fraction``, each channel read at its delay (5) by linear
        interpolation and phase-aligned at the carrier. W covers the largest delay."""
        fs = self.band.sample_rate
        delays = self.receive_delays(directions)  # (D, N_rx) [s]
        q = fraction + delays * fs
        lag = self._window_lag
        i0 = np.floor(q).astype(np.int64)
        frac = q - i0
        n_rx = delays.shape[1]
        cols = np.arange(n_rx)[None, :] * (2 * lag + 2) + lag + i0
        phase = phasor(2 * np.pi * carrier * delays)  # < 30 rad: phase error < 2e-6 rad
        # Built directly in CSR form: row d holds (1 - frac) and frac at columns c, c + 1 per channel.
        data = np.stack([(1 - frac) * phase, frac * phase], axis=-1).reshape(len(delays), -1)
        columns = np.stack([cols, cols + 1], axis=-1).reshape(len(delays), -1)
        return sparse.csr_matrix((data.ravel(), columns.ravel(),
                                  np.arange(len(delays) + 1) * 2 * n_rx),
                                 shape=(len(delays), n_rx * (2 * lag + 2)))

    def _windows(self, baseband, samples) -> np.ndarray:
        """(N_rx x L, C) windows of the channels (N_rx, N) around integer samples (C,) for
        :meth:`_delay_and_sum` (zeros beyond the recording)."""
        lag = self._window_lag
        padded = np.pad(baseband, ((0, 0), (lag + 1, lag + 1)))
        offsets = np.asarray(samples, dtype=np.int64)[:, None] + np.arange(2 * lag + 2)[None, :] + 1
        return padded[:, offsets].transpose(0, 2, 1).reshape(-1, len(offsets))

    def _arrives_off_beam(self, looks, candidates, direction) -> np.ndarray:
        """(C,) True where, at candidate sample k, in any look (baseband, carrier), some receive
        direction outside the main lobe is ``ghost_margin`` times stronger than the beam."""
        grid = self._ghost_grid
        outside = grid @ direction < np.cos(self.settings.ghost_exclusion)
        off_beam = np.zeros(len(candidates), bool)
        for baseband, carrier in looks:
            if carrier not in self._ghost_operators:  # the grid is the same for every beam
                self._ghost_operators[carrier] = self._delay_and_sum(grid, carrier)
            windows = self._windows(baseband, candidates)
            beam = np.abs(self._delay_and_sum(direction[None], carrier) @ windows)[0]
            ghosts = np.abs(self._ghost_operators[carrier] @ windows)[outside]
            off_beam |= ghosts.max(axis=0, initial=0.0) > self.settings.ghost_margin * beam
        return off_beam

    def _arrival_direction(self, looks, sample: float, direction) -> np.ndarray:
        """Unit vector (3,) of the strongest arrival at (fractional) ``sample`` within
        ``ghost_exclusion`` of the beam ``direction`` (3,): narrow-band delay-and-sum power summed
        over the looks on an ``arrival_step`` grid of field-of-view angles, the maximum refined
        by a parabola along each axis."""
        s = self.settings
        h0, v0 = fov_angles(direction)
        half = int(np.floor(s.ghost_exclusion / s.arrival_step))
        offsets = np.arange(-half, half + 1) * s.arrival_step
        hh, vv = np.meshgrid(h0 + offsets, v0 + offsets, indexing="ij")
        grid = direction_from_fov_angles(hh, vv)  # (G, G, 3)
        k = int(np.floor(sample))
        power = sum(np.abs(self._delay_and_sum(grid.reshape(-1, 3), carrier, sample - k)
                           @ self._windows(baseband, [k]))[:, 0] ** 2 for baseband, carrier in looks)
        power = np.where(grid.reshape(-1, 3) @ direction >= np.cos(s.ghost_exclusion), power, 0.0)
        power = power.reshape(hh.shape)
        i, j = np.unravel_index(int(np.argmax(power)), power.shape)
        along_h = power[i - 1: i + 2, j] if 0 < i < 2 * half else None
        along_v = power[i, j - 1: j + 2] if 0 < j < 2 * half else None
        return direction_from_fov_angles(h0 + offsets[i] + s.arrival_step * _vertex(along_h),
                                         v0 + offsets[j] + s.arrival_step * _vertex(along_v))

    def process(self, recording: Recording, direction, direct_envelope: np.ndarray | None = None,
                waveform=None, transmit_time: float = 0.0, max_path_length: float | None = None):
        """Envelope (N,) [Pa] and :class:`Detection` of one beam from its recording.

        Args:
            recording: the per-channel echoes.
            direction: (3,) beam direction in the sensor frame.
            direct_envelope: (N,) envelope of the direct path alone, for blanking (optional).
            waveform: the beam's drive waveform (default: the pulse); selects the matched filter.
            transmit_time: when the beam was fired, on the recording's clock [s].
            max_path_length: ignore echoes with a longer path [m] (e.g. the listening window).
        """
        n = recording.samples.shape[1]
        u = np.asarray(direction, dtype=float)
        envelope = np.abs(self.beamform(self.compressed_spectra(recording, waveform), n, u))
        # Each part of a code is a tone: its own envelope and an exact carrier for the check.
        parts = getattr(waveform, "parts", ())
        part_envelopes = [np.abs(self.beamform(self.compressed_spectra(recording, p), n, u))
                          for p in parts]
        s = self.settings
        looks = [self.look(recording, p) for p in (parts or [waveform])] \
            if s.ghost_margin > 0 or s.arrival_step > 0 else []
        return envelope, self.detect(envelope, recording.start_time, u, direct_envelope, looks,
                                     waveform, transmit_time, max_path_length, part_envelopes)

    def detect(self, envelope: np.ndarray, start_time: float, direction,
               direct_envelope: np.ndarray | None = None, looks=(),
               waveform=None, transmit_time: float = 0.0,
               max_path_length: float | None = None, part_envelopes=()) -> Detection:
        """Time of arrival, depth and point from an envelope (N,) [Pa], or no detection.

        Args:
            envelope: processed envelope.
            start_time: time of its first sample [s].
            direction: (3,) beam direction in the sensor frame.
            direct_envelope: (N,) envelope of the direct path alone, for blanking (optional).
            looks: (demodulated channels (N_rx, N), carrier [Hz]) pairs (:meth:`look`) for the
                side-lobe check, which a candidate must pass in every look, and the arrival
                direction (optional; without them every candidate is taken to arrive along the
                beam).
            waveform: the beam's drive waveform (sets the noise level).
            transmit_time: when the beam was fired [s]; times of arrival are counted from it.
            max_path_length: ignore echoes with a longer path [m].
            part_envelopes: envelopes (N,) of the waveform's parts, for the part-balance test.
        """
        s = self.settings
        fs = self.band.sample_rate
        g = self.geometry
        u = np.asarray(direction, dtype=float)
        n = len(envelope)
        t = start_time + np.arange(n) / fs - transmit_time  # time since this beam's firing
        cos_b = float(u @ g.rx_origin) / g.baseline
        # Path length of the nearest reportable depth, from (7) solved for l.
        r_min = s.min_range
        l_min = r_min + np.sqrt(r_min**2 + g.baseline**2 - 2 * r_min * g.baseline * cos_b)
        threshold = np.full(n, max(s.detection_snr * self.noise_envelope_rms(waveform),
                                   s.detection_floor))
        if direct_envelope is not None:
            threshold = np.maximum(threshold, s.blanking_margin * direct_envelope)
        window = self.c * t >= l_min
        if max_path_length is not None:
            window &= self.c * t <= max_path_length
        if not np.any(window):
            raise ValueError("the recording ends before the minimum range")
        k_max = int(np.argmax(np.where(window, envelope, -np.inf)))
        amplitude, level = float(envelope[k_max]), float(threshold[k_max])
        peaks = np.zeros(n, bool)
        peaks[1:-1] = (envelope[1:-1] >= envelope[:-2]) & (envelope[1:-1] > envelope[2:])
        candidates = np.nonzero(peaks & window & (envelope > threshold))[0]
        if len(part_envelopes):
            parts = np.asarray(part_envelopes)[:, candidates]
            candidates = candidates[parts.min(axis=0) >= s.part_balance * parts.max(axis=0)]
        candidates = candidates[np.argsort(envelope[candidates])[::-1][: s.max_candidates]]
        nan3 = np.full(3, np.nan)
        if len(candidates) == 0:
            return Detection(False, np.nan, np.nan, np.nan, nan3, nan3, amplitude, level)
        check, locate = s.ghost_margin > 0, s.arrival_step > 0
        if looks and check:  # a candidate must pass in every look
            candidates = candidates[~self._arrives_off_beam(looks, candidates, u)][:1]
        if len(candidates) == 0:
            return Detection(False, np.nan, np.nan, np.nan, nan3, nan3, amplitude, level)
        k = int(candidates[0])
        sample = k + _vertex(envelope[k - 1: k + 2])
        toa = float(t[0] + sample / fs)
        l = self.c * toa
        if looks and locate:  # (7) seen from the receive origin
            arrival = self._arrival_direction(looks, sample, u)
            receive_range = bistatic_depth(l, g.baseline, -float(arrival @ g.rx_origin) / g.baseline)
            point = g.rx_origin + receive_range * arrival
        else:
            arrival, point = u, bistatic_depth(l, g.baseline, cos_b) * u
        return Detection(True, toa, l, float(np.linalg.norm(point)), point, arrival,
                         float(envelope[k]), float(threshold[k]))


def _vertex(values) -> float:
    """Offset [samples] of the vertex of the parabola through three equally spaced values (3,)
    from the middle one; 0 for None or where they do not peak in the middle."""
    if values is None:
        return 0.0
    y0, y1, y2 = values
    denom = y0 - 2 * y1 + y2
    return float(0.5 * (y0 - y2) / denom) if denom < 0 else 0.0
