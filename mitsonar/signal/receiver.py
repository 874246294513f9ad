"""Echo processing: matched filter (6), delay-and-sum (5), envelope, time of arrival, depth (7).

Order and choices:

* Delay-and-sum (5) with the plane-wave delays t_j^B(psi) = -(p_j - o_R) . u / c relative to
  the receive origin o_R, applied exactly as phase ramps exp(j 2 pi f t_j^B) in the frequency
  domain (fractional delays without interpolation error; :mod:`mitsonar.signal.beamforming`).
* Batched: B beams are processed together (:meth:`EchoProcessor.process_beams`), from B
  recordings (a scan) or from one recording shared by all (an OFDM cycle, each beam with its
  own code, firing time and listening window): one FFT of all channels, one delay-and-sum over
  (B, N_rx, nb) on the band, one inverse FFT of every envelope, candidates found on (B, N), the
  side-lobe check in one sparse product per carrier for the strongest candidate of every beam
  and one for the other candidates of the beams whose strongest was rejected (look after look:
  a candidate rejected in one look is not checked in the next), the arrival directions of
  every detected beam in one more. One beam is the case B = 1. Everything after the channels'
  FFT also runs from channel spectra on the band handed in directly
  (:meth:`EchoProcessor.process_spectra`: the detection-only path of OFDM frames).
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
* Every echo (``echoes`` = "all" or "cells", :mod:`mitsonar.signal.multiecho`): instead of the
  strongest candidate, every echo over the local clutter and every independent range cell
  across extended echoes, each through the same part balance and side-lobe check, each with
  its own arrival direction, kept where that direction is trustworthy (``min_coherence``).
  These are placed from the receive array's phase centre c (its element centroid, where the
  delay-and-sum measures the arrival): point = c + r u_a with r from (7) for the path from the
  transmit origin to the point and back to o_R. (The single-detection path above places from
  o_R, as it always has; at 1-4 m that puts its points about 8 mm aside, along c - o_R.) The
  strongest echo of each beam is its :class:`~mitsonar.signal.detection.Detections` entry; all
  are in :class:`~mitsonar.signal.detection.Echoes`.
* Receive images over each beam's lit cone (``echoes`` = "image", :mod:`mitsonar.signal.cone`):
  echoes and range cells chosen on where each beam's cone image peaks, checked and placed at
  that direction; reported as "cells" are.
* Off-beam echoes (``off_beam``, "first"): a beam's echo rejected by the side-lobe check is
  re-placed where it arrives from, flagged (:mod:`mitsonar.signal.offbeam`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from mitsonar.physics.array import ArrayGeometry
from mitsonar.signal.band import Band, Recording
from mitsonar.signal.beamforming import Beamformer, dot
from mitsonar.signal import cone, multiecho, offbeam
from mitsonar.signal.detection import (Detection, Detections, DetectionSettings, Echoes,
                                       bistatic_depth, bistatic_point, candidates,
                                       local_maxima, vertex)

#: Cross-talk between the waveforms of one recording is followed out to the lags where their
#: range profiles fall below this (:meth:`EchoProcessor._crosstalk`).
CROSS_FLOOR = 1e-4
#: Channel sets of the looks transformed together (bounds the memory of an OFDM cycle's looks:
#: ~10 MB per set of 25 channels).
LOOK_BATCH = 4


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
        self.beamformer = Beamformer(geometry, band, speed_of_sound, settings)
        self._filters = {}
        self._profiles = {}
        self._crosstalks = {}
        self._cone = None

    def matched_filter(self, waveform=None):
        """(filter spectrum on the band (nb,), template energy) of a waveform: conj(W) / E,
        E = sum |w_a|^2 over the samples of a real recording at the reference rate."""
        key = self.band.pulse if waveform is None else waveform
        if key not in self._filters:
            w = self.band.system_spectrum(key)
            energy = float(np.sum(np.abs(w) ** 2)) / self.band.n_fft  # Parseval
            self._filters[key] = (np.conj(w[self.band.bins]) / energy, energy)
        return self._filters[key]

    def range_profile(self, waveform=None) -> tuple[np.ndarray, float]:
        """:func:`~mitsonar.signal.multiecho.range_profile` of a waveform on the band (|R| by lag
        (N,), tau_r [samples]), computed once."""
        key = self.band.pulse if waveform is None else waveform
        if key not in self._profiles:
            self._profiles[key] = multiecho.range_profile(self.band, key)
        return self._profiles[key]

    def noise_envelope_rms(self, waveform=None) -> float:
        """RMS of the beamformed matched-filter envelope of receiver noise alone [Pa]."""
        energy = self.matched_filter(waveform)[1]
        return 2.0 * self.noise_rms / np.sqrt(energy * self.geometry.rx.count)

    def envelope(self, recording: Recording, direction, waveform=None) -> np.ndarray:
        """Envelope (N,) [Pa] of the beamformed, matched-filtered recording."""
        beamformed = self.beamformer.beamformed(self.band.band_spectra(recording.samples),
                                                np.reshape(direction, (1, 3)))
        return self.band.envelopes(beamformed, self.matched_filter(waveform)[0],
                                   recording.samples.shape[-1])[0]

    def noiseless_envelopes(self, spectra: np.ndarray, directions, waveforms=None) -> np.ndarray:
        """Envelopes (B, n_samples) [Pa] of echoes given by their summed analytic spectra on the
        band, (N_rx, nb) shared by every beam or (B, N_rx, nb) one per beam (as the synthesizer's
        ``groups_spectrum`` gives them), towards directions (B, 3), each matched-filtered for its
        waveform (B,) (default: the pulse): :meth:`envelope` of their noiseless recordings,
        except that echoes are not cut at the recording's end."""
        u = np.reshape(directions, (-1, 3))
        waves = _Waveforms(self, waveforms, len(u))
        return self.band.envelopes(self.beamformer.beamformed(spectra, u),
                                   waves.filters[waves.kind])

    def noiseless_envelope(self, spectrum: np.ndarray, direction, waveform=None) -> np.ndarray:
        """:meth:`noiseless_envelopes` (n_samples,) of one beam, spectrum (N_rx, nb)."""
        return self.noiseless_envelopes(spectrum, np.reshape(direction, (1, 3)), [waveform])[0]

    def process(self, recording: Recording, direction, direct_envelope: np.ndarray | None = None,
                waveform=None, transmit_time: float = 0.0, max_path_length: float | None = None):
        """Envelope (N,) [Pa] and :class:`Detection` of one beam from its recording:
        :meth:`process_beams` of B = 1 beam (arguments as there, for that beam)."""
        envelopes, detections = self.process_beams(
            recording, np.reshape(direction, (1, 3)),
            None if direct_envelope is None else np.asarray(direct_envelope)[None], [waveform],
            transmit_time, max_path_length)
        return envelopes[0], detections[0]

    def process_beams(self, recordings, directions, direct_envelopes: np.ndarray | None = None,
                      waveforms=None, transmit_times=0.0,
                      max_path_length: float | None = None) -> tuple[np.ndarray, Detections]:
        """Envelopes (B, N) [Pa] and :class:`Detections` of B beams, all in one pass (module
        docstring).

        Args:
            recordings: one :class:`Recording` shared by every beam (an OFDM cycle), or a
                sequence of B recordings, one per beam (a scan), all with the same timing.
            directions: (B, 3) beam directions in the sensor frame.
            direct_envelopes: (B, N) envelopes of the direct path alone, for blanking (optional).
            waveforms: the beams' drive waveforms (B,) (default: the pulse for every beam); each
                selects its matched filter.
            transmit_times: when each beam was fired, (B,) or one for all, on the recordings'
                clock [s].
            max_path_length: ignore echoes with a longer path [m] (e.g. the listening window).
        """
        shared = isinstance(recordings, Recording)
        start_time = (recordings if shared else recordings[0]).start_time
        samples = recordings.samples if shared else np.stack([r.samples for r in recordings])
        return self.process_spectra(self.band.band_spectra(samples), start_time,
                                    samples.shape[-1], directions, direct_envelopes, waveforms,
                                    transmit_times, max_path_length)

    def process_spectra(self, spectra: np.ndarray, start_time: float, n: int, directions,
                        direct_envelopes: np.ndarray | None = None, waveforms=None,
                        transmit_times=0.0,
                        max_path_length: float | None = None) -> tuple[np.ndarray, Detections]:
        """:meth:`process_beams` of the channels' spectra on the band, (N_rx, nb) shared by
        every beam or (B, N_rx, nb) one set per beam, whose recordings start at ``start_time``
        [s] with ``n`` samples (other arguments as there). The detection-only path of an OFDM
        frame hands its synthesised spectra and band noise here, without recordings
        (:meth:`~mitsonar.sensors.ofdm_sonar.OfdmSonar.frame`); both paths share every decision
        from here on."""
        shared = spectra.ndim == 2
        u = np.asarray(directions, dtype=float).reshape(-1, 3)
        waves = _Waveforms(self, waveforms, len(u))
        beamformed = self.beamformer.beamformed(spectra, u)
        # Each part of a code is a tone: its own envelope, and an exact carrier for the looks.
        beams, look = np.nonzero((waves.looks >= 0) & waves.has_parts[:, None])
        rows = self.band.envelopes(np.concatenate([beamformed, beamformed[beams]]),
                                   np.concatenate([waves.filters[waves.kind],
                                                   waves.look_filters[waves.looks[beams, look]]]),
                                   n)
        envelopes = rows[: len(u)]
        # Part envelopes (B, P, N) for the part balance; a beam without parts passes (inf >= 0).
        weakest = np.full(waves.looks.shape + (n,), np.inf)
        strongest = np.zeros(weakest.shape)
        weakest[beams, look] = strongest[beams, look] = rows[len(u):]
        s = self.settings
        balanced = weakest.min(axis=1) >= s.part_balance * strongest.max(axis=1)
        image = None
        if s.echoes == "image":
            if self._cone is None:
                self._cone = cone.ConeImager(self.geometry, self.band, self.c, s)
            image = self._cone.envelopes(self.beamformer, spectra, u, waves.filters[waves.kind], n)
        looks = _Looks(self, spectra, waves, start_time, n) \
            if s.ghost_margin > 0 or s.arrival_step > 0 or image is not None else None
        return envelopes, self._decide(envelopes, start_time, u, direct_envelopes, waves,
                                       transmit_times, max_path_length, balanced, looks, shared,
                                       image)

    def detect(self, envelope: np.ndarray, start_time: float, direction,
               direct_envelope: np.ndarray | None = None, waveform=None,
               transmit_time: float = 0.0, max_path_length: float | None = None) -> Detection:
        """Time of arrival, depth and point from an envelope (N,) [Pa] alone, or no detection:
        every candidate is taken to arrive along the beam (the side-lobe check and the arrival
        direction need the channels: :meth:`process`).

        Args:
            envelope: processed envelope.
            start_time: time of its first sample [s].
            direction: (3,) beam direction in the sensor frame.
            direct_envelope: (N,) envelope of the direct path alone, for blanking (optional).
            waveform: the beam's drive waveform (sets the noise level).
            transmit_time: when the beam was fired [s]; times of arrival are counted from it.
            max_path_length: ignore echoes with a longer path [m].
        """
        envelopes = np.asarray(envelope)[None]
        return self._decide(envelopes, start_time, np.reshape(direction, (1, 3)),
                            None if direct_envelope is None else np.asarray(direct_envelope)[None],
                            _Waveforms(self, [waveform], 1), transmit_time, max_path_length,
                            np.ones(envelopes.shape, bool))[0]

    def _decide(self, envelopes, start_time, u, direct_envelopes, waves, transmit_times,
                max_path_length, balanced, looks=None, shared=False, image=None) -> Detections:
        """:class:`Detections` of B beams from their envelopes (B, N) [Pa] (arguments as in
        :meth:`process_beams`; ``balanced`` (B, N): where the parts are balanced; ``shared``:
        one recording for all; ``image`` (B, G, N): their cones' images, for "image"). With the
        beams' looks, the side-lobe check and the arrival direction; without, every candidate
        is taken to arrive along its beam."""
        s, g = self.settings, self.geometry
        fs = self.band.sample_rate
        count, n = envelopes.shape
        transmit = np.broadcast_to(np.asarray(transmit_times, dtype=float), (count,))
        path = self.c * (start_time + np.arange(n) / fs - transmit[:, None])  # since firing [m]
        cos_b = dot(u, g.rx_origin) / g.baseline
        # Path length of the nearest reportable depth, from (7) solved for l.
        r_min = s.min_range
        l_min = r_min + np.sqrt(r_min**2 + g.baseline**2 - 2 * r_min * g.baseline * cos_b)
        level = np.maximum(s.detection_snr * waves.noise[waves.kind], s.detection_floor)
        threshold = np.broadcast_to(level[:, None], envelopes.shape)
        if direct_envelopes is not None:
            threshold = np.maximum(threshold, s.blanking_margin * direct_envelopes)
        window = path >= l_min[:, None]
        if max_path_length is not None:
            window &= path <= max_path_length
        if not np.all(np.any(window, axis=1)):
            raise ValueError("the recording ends before the minimum range")
        loud = envelopes > threshold
        apparent = moved = None
        if s.echoes == "image":
            if image is None or looks is None:
                raise ValueError("DetectionSettings.echoes = 'image' needs the channels")
            crosstalk = self._crosstalk(u, waves, transmit) if shared else None
            envelopes, beams, samples, cells, apparent = self._cone_echoes(
                image, threshold, window, u, waves, looks, crosstalk)
        elif s.echoes == "first":
            beams, samples = self._strongest_echoes(envelopes, window & loud & balanced, u,
                                                    looks)
            cells = (np.zeros(0, np.int64),) * 2
            if s.off_beam and looks is not None:
                moved = offbeam.recover(self, envelopes, window & balanced, threshold, u, looks,
                                        beams)
        else:
            crosstalk = self._crosstalk(u, waves, transmit) if shared else None
            beams, samples, cells = self._every_echo(envelopes, loud, window, balanced, u, waves,
                                                     looks, crosstalk)
        return self._report(envelopes, threshold, window, start_time, transmit, u, waves, looks,
                            beams, samples, cells, apparent, moved)

    def _strongest_echoes(self, envelopes, accepted, u, looks):
        """(beams, samples) of each beam's strongest candidate that arrives along it, by beam
        (``echoes`` = "first"); ``accepted`` (B, N): where a candidate may be."""
        s = self.settings
        beams, samples, ranks = candidates(envelopes, accepted, s.max_candidates)
        if looks is not None and s.ghost_margin > 0:
            # Each beam's strongest candidate first; the others where it arrives off the beam.
            strongest = ranks == 0
            passed = strongest.copy()
            passed[strongest] = self._pass_side_lobe_check(looks, u, beams[strongest],
                                                           samples[strongest])
            done = np.zeros(len(envelopes), bool)
            done[beams[passed]] = True
            retry = (ranks > 0) & ~done[beams]
            passed[retry] = self._pass_side_lobe_check(looks, u, beams[retry], samples[retry])
            beams, samples = beams[passed], samples[passed]
        found, first = np.unique(beams, return_index=True)  # each beam's strongest left
        return found, samples[first]

    def _every_echo(self, envelopes, loud, window, balanced, u, waves, looks, crosstalk):
        """(beams, samples) of every echo of B beams and (beams, samples) of their range cells
        (``echoes`` = "all": none), each that arrives along its beam
        (:mod:`mitsonar.signal.multiecho`). Masks (B, N): ``loud`` the envelope over the
        threshold, ``window`` the listening window, ``balanced`` the parts balanced; the
        echoes outside the window count as clutter too (a far wall's echo leaks into the window
        of other codes). ``crosstalk``: the beams' cross-talk in a shared recording
        (:meth:`_crosstalk`) or None."""
        s = self.settings
        lobes, resolution = waves.range_profiles(self)
        resolution = resolution[waves.kind]
        clutter = multiecho.Clutter(lobes, waves.kind, crosstalk)
        found, resolved = multiecho.echo_peaks(envelopes, local_maxima(envelopes) & loud, window & balanced,
                                               resolution, clutter, s.clutter_margin)
        found = self._along_beam(looks, u, *found)
        cells = (np.zeros(0, np.int64),) * 2
        if s.echoes == "cells":
            cells = multiecho.range_cells(envelopes, window & loud, balanced, resolved, found,
                                          resolution, clutter, s.clutter_margin)
            cells = self._along_beam(looks, u, *cells)
        return found[0], found[1], cells

    def _cone_echoes(self, image, threshold, window, u, waves, looks, crosstalk):
        """(profile M (B, N) [Pa], beams, samples of the echoes, (beams, samples) of the range
        cells, (E, 2) direction cosines where each row's image peaks) of B beams' cone images
        (``echoes`` = "image", :mod:`mitsonar.signal.cone`): rows kept where every part of the
        code is there at that direction and it passes the side-lobe check there."""
        s = self.settings
        lobes, resolution = waves.range_profiles(self)
        profile, found, cells, best = cone.cone_echoes(
            self._cone, image, threshold, window, resolution[waves.kind],
            multiecho.Clutter(lobes, waves.kind, crosstalk), s.clutter_margin)
        beams, samples = (np.concatenate(x) for x in zip(found, cells))
        apparent = cone.apparent_directions(self._cone, image, u, beams, samples, best)
        directions = cone.unit_direction(apparent)
        passed = cone.parts_balanced(self.beamformer, looks, beams, samples, directions,
                                     s.part_balance)
        if s.ghost_margin > 0:
            todo = np.flatnonzero(passed)
            passed[todo] = self._pass_side_lobe_check(looks, directions[todo], beams[todo],
                                                      samples[todo], np.arange(len(todo)))
        echo = passed & (np.arange(len(beams)) < len(found[0]))
        return (profile, beams[echo], samples[echo], (beams[passed & ~echo],
                samples[passed & ~echo]), np.concatenate([apparent[echo], apparent[passed & ~echo]]))

    def _crosstalk(self, u, waves, transmit):
        """(|X| (K, K, 2 S + 1), transmit and receive gains (B, B), firing times (B,) [samples])
        of B beams in one recording (:class:`~mitsonar.signal.multiecho.Clutter`): the envelope
        an echo of kind k' leaves decoded for kind k at lags -S..S, S the longest range profile
        above ``CROSS_FLOOR``, each computed once per pair of kinds; the array factors at each
        beam's own frequency."""
        span = max(int(np.flatnonzero(self.range_profile(w)[0] >= CROSS_FLOOR).max())
                   for w in waves.kinds)
        missing = [(a, b) for a in waves.kinds for b in waves.kinds
                   if (a, b, span) not in self._crosstalks]
        if missing:
            band = self.band
            # An echo of kind b, decoded for kind a, delayed by S samples (lag -S at sample 0).
            delay = np.exp(-2j * np.pi * band.frequencies * span / band.sample_rate)
            spectra = np.stack([band.system_spectrum(b)[band.bins] * self.matched_filter(a)[0]
                                for a, b in missing]) * delay
            lobes = np.abs(band.to_analytic(spectra)[:, : 2 * span + 1])
            self._crosstalks.update(((a, b, span), x) for (a, b), x in zip(missing, lobes))
        table = np.stack([[self._crosstalks[a, b, span] for b in waves.kinds] for a in waves.kinds])
        frequencies = np.array([float(w.frequency) for w in waves.kinds])[waves.kind]
        g = self.geometry
        return (table, multiecho.array_gains(g.tx_positions, u, frequencies, self.c),
                multiecho.array_gains(g.rx_positions, u, frequencies, self.c).T,
                transmit * self.band.sample_rate)

    def _along_beam(self, looks, u, beams, samples):
        """The (beams, samples) that pass the side-lobe check (all without looks or with
        ``ghost_margin`` = 0)."""
        if looks is None or self.settings.ghost_margin <= 0:
            return beams, samples
        passed = self._pass_side_lobe_check(looks, u, beams, samples)
        return beams[passed], samples[passed]

    def _report(self, envelopes, threshold, window, start_time, transmit, u, waves, looks,
                beams, samples, cells, apparent=None, moved=None) -> Detections:
        """:class:`Detections` and :class:`Echoes` of B beams from their echoes (beams,
        samples), by beam and then by decreasing amplitude, and their range cells (beams,
        samples): each placed (time of arrival, arrival direction, bistatic depth (7)); with
        ``echoes`` = "all", "cells" or "image", kept where their direction is trustworthy
        (``min_coherence``). ``apparent`` (E, 2): "image"'s directions, echoes then cells
        (:func:`~mitsonar.signal.cone.place`); ``moved``: off-beam echoes (:mod:`.offbeam`)."""
        s, g = self.settings, self.geometry
        fs = self.band.sample_rate
        count = len(envelopes)
        beams, k, peak, centre, off_beam = offbeam.rows(beams, samples, cells, u, moved)
        refined = np.where(peak & ~off_beam, vertex(envelopes[beams, k - 1], envelopes[beams, k],
                                        envelopes[beams, k + 1]), 0.0)
        sample = k + refined
        toa = start_time - transmit[beams] + sample / fs
        l = self.c * toa
        coherence = np.full(len(beams), np.nan)
        if looks is not None and (s.arrival_step > 0 or apparent is not None) and len(beams):
            look, row = np.nonzero(waves.looks[beams].T >= 0)  # every row's first look first
            sets = looks.sets(beams[row], look)
            carriers = waves.carriers[waves.looks[beams[row], look]]
            arrival = self.beamformer.arrival_directions(
                looks.channels, sets, carriers, row, sample, centre) if apparent is None \
                else cone.unit_direction(apparent)  # where the plane-wave beams peak
            coherence = self.beamformer.coherence(looks.channels, sets, carriers, row, sample,
                                                  arrival)
            if apparent is not None:  # (7) from the receive origin, near field corrected
                point, arrival = cone.place(g, np.zeros(3), l, apparent)
            elif s.echoes == "first":  # placed from the receive origin, as ever
                receive_range = bistatic_depth(l, g.baseline,
                                               -dot(arrival, g.rx_origin) / g.baseline)
                point = g.rx_origin + receive_range[:, None] * arrival
            else:  # from the receive array's phase centre, where the arrival is measured
                point = bistatic_point(l, arrival, g.rx_positions.mean(axis=0), np.zeros(3),
                                       g.rx_origin)
        else:
            arrival = u[beams]
            cos_b = dot(u, g.rx_origin) / g.baseline
            point = bistatic_depth(l, g.baseline, cos_b[beams])[:, None] * arrival
        # The single-detection path trusts every direction; the others those that one plane wave
        # explains, and echoes without a measured direction (on the beam axis, as the paper).
        trusted = np.where(off_beam, offbeam.trusted(coherence, arrival, g, s),
                           (s.echoes == "first") | (coherence >= s.min_coherence)
                           | (peak & np.isnan(coherence)))
        noise = waves.noise[waves.kind[beams]]
        with np.errstate(divide="ignore"):  # no receiver noise: infinite SNR
            snr = envelopes[beams, k] / noise
        table = Echoes(beam=beams, rank=np.zeros(len(beams), np.int64), peak=peak,
                       amplitude=envelopes[beams, k], snr=snr, time_of_arrival=toa,
                       path_length=l, depth=np.linalg.norm(point, axis=-1), point=point,
                       direction=arrival, coherence=coherence, off_beam=off_beam)
        rows = np.flatnonzero(trusted)
        rows = rows[np.lexsort((-table.amplitude[rows], ~peak[rows], beams[rows]))]
        table, k = table.take(rows), k[rows]
        rank = np.arange(len(rows)) - np.searchsorted(table.beam, table.beam)
        table = replace(table, rank=rank)
        every = np.arange(count)
        k_max = np.argmax(np.where(window, envelopes, -np.inf), axis=1)
        out = dict(detected=np.zeros(count, bool), time_of_arrival=np.full(count, np.nan),
                   path_length=np.full(count, np.nan), depth=np.full(count, np.nan),
                   point=np.full((count, 3), np.nan), direction=np.full((count, 3), np.nan),
                   amplitude=envelopes[every, k_max], threshold=threshold[every, k_max])
        first = rank == 0
        found = table.beam[first]
        for name, value in (("detected", True), ("time_of_arrival", table.time_of_arrival),
                            ("path_length", table.path_length), ("depth", table.depth),
                            ("point", table.point), ("direction", table.direction),
                            ("amplitude", table.amplitude),
                            ("threshold", threshold[table.beam, k])):
            out[name][found] = value if np.ndim(value) == 0 else value[first]
        return Detections(**out, echoes=table)

    def _pass_side_lobe_check(self, looks, u, beams, samples, rows=None) -> np.ndarray:
        """(E,) True where candidate sample ``samples[e]`` of beam ``beams[e]`` arrives along
        ``u[beams[e]]`` (the beam's direction), or ``u[rows[e]]`` if ``rows`` are given, in every
        look (:meth:`Beamformer.off_beam <mitsonar.signal.beamforming.Beamformer.off_beam>`),
        looks checked one after another: a candidate rejected in one is not checked in the
        next."""
        rows = beams if rows is None else rows
        table = looks.waves.looks
        passed = np.ones(len(beams), bool)
        for look in range(table.shape[1]):
            todo = np.flatnonzero(passed & (table[beams, look] >= 0))
            if len(todo):
                b = beams[todo]
                sets = looks.sets(b, look)
                passed[todo] = ~self.beamformer.off_beam(looks.channels, sets, samples[todo],
                                                         looks.waves.carriers[table[b, look]],
                                                         u[rows[todo]])
        return passed


class _Looks:
    """The looks of B beams for the side-lobe check and the arrival direction: channels
    (N_rx, N) matched-filtered for a look waveform (a code's part, or the waveform itself) and
    demodulated at its carrier; each distinct (recording, look waveform) computed once, when
    first asked for.

    Args:
        processor: the receiver.
        spectra: channel spectra on the band, (N_rx, nb) shared or (B, N_rx, nb) per beam.
        waves: the beams' waveforms.
        start_time: time of sample 0 [s].
        n: samples per channel.
    """

    def __init__(self, processor: EchoProcessor, spectra: np.ndarray, waves: _Waveforms,
                 start_time: float, n: int):
        self.band = processor.band
        self.waves = waves
        self.per_beam = spectra.ndim == 3
        self.spectra = spectra.reshape((-1,) + spectra.shape[-2:])
        #: (sets, N_rx, n): set r x T + t is recording r's look waveform t (T of them); filled
        #: when first asked for by :meth:`sets`.
        self.channels = np.empty((len(self.spectra) * len(waves.carriers),) + spectra.shape[-2:-1]
                                 + (n,), dtype=complex)
        self._ready = np.zeros(len(self.channels), bool)
        self._times = start_time + np.arange(n) / self.band.sample_rate

    def sets(self, beams, look) -> np.ndarray:
        """Sets (E,) in :attr:`channels` of looks ``look`` ((E,) or one for all) of ``beams``
        (E,), computed where new: an inverse FFT for every ``LOOK_BATCH`` of them."""
        n_looks = len(self.waves.carriers)
        keys = (beams if self.per_beam else 0) * n_looks + self.waves.looks[beams, look]
        new = np.unique(keys[~self._ready[keys]])
        for first in range(0, len(new), LOOK_BATCH):
            batch = new[first: first + LOOK_BATCH]
            recording, waveform = np.divmod(batch, n_looks)
            # The band's analytic signals are already demodulated by its own carrier.
            offset = (self.waves.carriers[waveform] - self.band.carrier)[:, None]  # [Hz]
            shift = np.exp(-2j * np.pi * offset * self._times)
            analytic = self.band.to_analytic(self.spectra[recording]
                                             * self.waves.look_filters[waveform][:, None])
            self.channels[batch] = analytic[..., : len(self._times)] * shift[:, None, :]
            self._ready[batch] = True
        return keys


class _Waveforms:
    """The drive waveforms of B beams, by kind (distinct waveform, :attr:`kinds`): matched
    filters (K, nb) and noise envelope levels (K,) [Pa]; and their looks (the parts of a code,
    or the waveform itself): matched filters (T, nb) and carriers (T,) [Hz].

    Attributes:
        kind: (B,) each beam's kind.
        looks: (B, P) each beam's looks (-1: none).
        has_parts: (B,) whether a beam's looks are parts of its waveform (with envelopes of their
            own, for the part balance).
    """

    def __init__(self, processor: EchoProcessor, waveforms, count: int):
        pulse = processor.band.pulse
        if waveforms is None:
            kinds, self.kind = [pulse], np.zeros(count, np.int64)
        else:
            kinds, self.kind = _distinct([pulse if w is None else w for w in waveforms])
        self.kinds = kinds
        self.filters = np.stack([processor.matched_filter(w)[0] for w in kinds])
        self.noise = np.array([processor.noise_envelope_rms(w) for w in kinds])
        parts = [tuple(getattr(w, "parts", ())) for w in kinds]
        looks = [p or (w,) for p, w in zip(parts, kinds)]
        tones = list(dict.fromkeys(t for look in looks for t in look))
        table = np.full((len(kinds), max(map(len, looks))), -1)
        for k, look in enumerate(looks):
            table[k, : len(look)] = [tones.index(t) for t in look]
        self.looks = table[self.kind]
        self.has_parts = np.array([len(p) > 0 for p in parts])[self.kind]
        self.look_filters = np.stack([processor.matched_filter(t)[0] for t in tones])
        self.carriers = np.array([float(t.frequency) for t in tones])

    def range_profiles(self, processor: EchoProcessor) -> tuple[np.ndarray, np.ndarray]:
        """(|R| by lag (K, N), tau_r (K,) [samples]) of each kind
        (:meth:`EchoProcessor.range_profile`)."""
        lobes, resolution = zip(*map(processor.range_profile, self.kinds))
        return np.stack(lobes), np.array(resolution)


def _distinct(items) -> tuple[list, np.ndarray]:
    """(the distinct items in order of first appearance, index (len(items),) of each among them)."""
    index: dict = {}
    which = np.array([index.setdefault(w, len(index)) for w in items], np.int64)
    return list(index), which
