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
  transmitter->receiver path alone and that envelope plus the noise threshold (direct-path
  blanking, :func:`~mitsonar.signal.detection.blanking_level`). Strongest first, a candidate is
  accepted unless it arrives from elsewhere: receive beams formed from the same recording at that
  instant over +-50 deg show it ``ghost_margin`` stronger outside the main lobe than
  along the beam (a side-lobe echo, e.g. the specular return of a tilted wall, which would give a
  wrong depth). Waveforms made of parts (OFDM codes: two tones, :class:`~mitsonar.signal.ofdm.Code`)
  are also matched-filtered part by part: a candidate is accepted only if every part is there
  with at least ``part_balance`` of the strongest part's envelope, each relative to what the
  code's own echo leaves in that part's filter (:meth:`EchoProcessor.part_gain`). Another code
  that shares one tone leaks into one part only (the paper's codes correlate at 1/2 through a
  shared half), so this rejects it where a threshold on the whole-code envelope could not.
  No accepted candidate gives "no detection": NaN depth and ``detected = False``.
* Arrival direction (``arrival_step`` > 0; beyond the paper, which places every point on the beam
  axis): the transmit beam lights everything within its main lobe, and at 3 m a reflector 3 deg
  off the axis is 16 cm from it. Where along the lobe the echo at the detected instant comes
  from is read from the receive array: the narrow-band delay-and-sum power at that instant over
  directions within ``ghost_exclusion`` of the beam (``arrival_step`` apart, refined by a
  quadratic through the log-power of the strongest and its 8 neighbours), summed over the looks.
  Its maximum is the direction of the plane wave that best explains the channels; corrected for
  the receive array's near field it is the arrival direction u_a seen from the receive origin
  o_R. A surface seen obliquely (a floor, a wall at 50 deg) returns first from the near edge of
  the lobe, not from its axis; that is where u_a points.
* Depth by the bistatic (7): d = (l^2 - b^2) / (2 (l - b cos theta_b)), with theta_b the angle
  between the beam and the baseline vector (TX -> RX origin); point = d * u in the sensor frame.
  With an arrival direction, (7) is solved from the receive side instead (range r from o_R along
  u_a, theta_b measured from the RX -> TX vector, the arrays' curvature delays taken off the
  path): point = o_R + r u_a, and the depth is the point's distance from the transmit origin.
  Every echo of every setting (first, all, cells, image, off-beam) is placed so, by
  :func:`mitsonar.signal.placement.place`.
* Every echo (``echoes`` = "all" or "cells", :mod:`mitsonar.signal.multiecho`): instead of the
  strongest candidate, every echo over the local clutter and every independent range cell
  across extended echoes, each through the same part balance and side-lobe check, each with
  its own arrival direction, kept where that direction is trustworthy (``min_coherence``).
  The strongest echo of each beam is its :class:`~mitsonar.signal.detection.Detections` entry;
  all are in :class:`~mitsonar.signal.detection.Echoes`.
* Receive images over each beam's lit cone (``echoes`` = "image", :mod:`mitsonar.signal.cone`):
  echoes and range cells chosen on where each beam's cone image peaks, checked and placed at
  that direction; reported as "cells" are.
* Off-beam echoes (``off_beam``, "first" or "all"): a beam without an accepted echo gets its
  strongest candidate re-placed where it arrives from, flagged (:mod:`mitsonar.signal.offbeam`).

This module orchestrates the chain (envelopes, part balance, thresholds and window, the choice
of echoes by ``echoes``, clutter); the steps live by concept: :mod:`~mitsonar.signal.looks`
(waveforms, matched filters and looks), :mod:`~mitsonar.signal.beamforming` (delay-and-sum),
:mod:`~mitsonar.signal.sidelobe` (the side-lobe check, "first"'s strongest echo),
:mod:`~mitsonar.signal.multiecho` (every echo, range cells, clutter), :mod:`~mitsonar.signal.cone`
("image"), :mod:`~mitsonar.signal.offbeam` and :mod:`~mitsonar.signal.placement` (time of
arrival, arrival direction, depth, the tables).
"""

from __future__ import annotations

import numpy as np

from mitsonar.caching import kept
from mitsonar.physics.array import ArrayGeometry
from mitsonar.signal.band import Band, Recording
from mitsonar.signal.beamforming import Beamformer, dot
from mitsonar.signal import cone, crosstalk, multiecho, offbeam, placement, sidelobe
from mitsonar.signal.detection import (Detection, Detections, DetectionSettings, blanking_level,
                                       candidates, local_maxima)
from mitsonar.signal.looks import Looks, Waveforms

#: Cross-talk between the waveforms of one recording is followed out to the lags where their
#: range profiles fall below this (:meth:`EchoProcessor._crosstalk`).
CROSS_FLOOR = 1e-4
#: Cross-talk tables (:meth:`EchoProcessor._crosstalk`) kept, one per distinct list of a
#: recording's waveforms (an OFDM schedule's cycles; 1.4 MB each for the paper preset's
#: 25 codes, 4.6 MB behind resonant transducers).
CROSS_TABLES_KEPT = 16


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
        self._part_gains = {}
        self._profiles = {}
        self._crosstalks = {}
        self._crosstalk_tables = {}  # the kinds of a recording's beams -> their table
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

    def part_gain(self, waveform, part) -> float:
        """The envelope peak [Pa] that an echo of ``waveform`` of unit amplitude leaves through
        the matched filter of its ``part`` (one of its :attr:`parts
        <mitsonar.signal.ofdm.Code.parts>`), computed once. Near 1 behind broadband transducers
        (the two tones of a code are orthogonal over their halves); behind the TCT40, whose
        ringing carries a code's 40 kHz half into its other half's filter, up to 3.4 for a tone
        the transducers attenuate (e.g. 36 kHz of the code (36, 40) kHz): its parts must be
        compared relative to these, or the part balance rejects the code's own echoes (measured
        on a wall facing the broadside beam: its mirror echo, the frame's strongest, 0.295 of
        balance against 0.3 needed, and a cross-talk echo 1.1 m behind the wall taken instead)."""
        key = (waveform, part)
        if key not in self._part_gains:
            band = self.band
            echo = band.system_spectrum(waveform)[band.bins] * self.matched_filter(part)[0]
            self._part_gains[key] = float(np.abs(band.to_analytic(echo)).max())
        return self._part_gains[key]

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
        waves = Waveforms(self, waveforms, len(u))
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
        waves = Waveforms(self, waveforms, len(u))
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
        weakest[beams, look] = strongest[beams, look] = \
            rows[len(u):] / waves.part_gains[beams, look][:, None]
        s = self.settings
        balanced = weakest.min(axis=1) >= s.part_balance * strongest.max(axis=1)
        image = None
        if s.echoes == "image":
            if self._cone is None:
                self._cone = cone.ConeImager(self.geometry, self.band, self.c, s)
            image = self._cone.envelopes(self.beamformer, spectra, u, waves.filters[waves.kind], n)
        looks = Looks(self.band, spectra, waves, start_time, n, beamformed) \
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
                            Waveforms(self, [waveform], 1), transmit_time, max_path_length,
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
            threshold = blanking_level(threshold, direct_envelopes, s.blanking_margin)
        window = path >= l_min[:, None]
        if max_path_length is not None:
            window &= path <= max_path_length
        if not np.all(np.any(window, axis=1)):
            raise ValueError("the recording ends before the minimum range")
        loud = envelopes > threshold
        apparent = moved = None
        if s.echoes == "image" and (image is None or looks is None):
            raise ValueError("DetectionSettings.echoes = 'image' needs the channels")
        if s.echoes == "first":
            owned = self._owner(u, waves, transmit, looks, envelopes) \
                if shared and looks is not None else None
            beams, samples, strongest = sidelobe.strongest_echoes(
                self.beamformer, looks, envelopes, window & loud & balanced, u, owned)
            cells = (np.zeros(0, np.int64),) * 2
        else:
            clutter, resolution = self._clutter(u, waves, transmit if shared else None)
            if s.echoes == "image":
                envelopes, beams, samples, cells, apparent = self._cone_echoes(
                    image, threshold, window, u, looks, clutter, resolution)
            else:
                beams, samples, cells = self._every_echo(envelopes, loud, window, balanced, u,
                                                         looks, clutter, resolution)
        if s.off_beam and looks is not None:
            if s.echoes == "all":  # each beam's strongest candidate, before any check
                strongest = candidates(envelopes, window & loud & balanced, 1)[:2]
            crosstalk = self._crosstalk(u, waves, transmit)[0] if shared else None
            moved = offbeam.recover(self, window & balanced, threshold, u, looks, beams, strongest,
                                    envelopes, crosstalk)
        return placement.report(self, envelopes, threshold, window, start_time, transmit, u,
                                waves, looks, beams, samples, cells, apparent, moved)

    def _owner(self, u, waves, transmit, looks, envelopes):
        """The test (beams, samples) (E,) -> (E,) whether candidates on B beams' envelopes
        (B, N) [Pa] of one recording (directions ``u`` (B, 3), firing times ``transmit`` (B,)
        [s]) are their own codes' echoes rather than other codes' of the cycle
        (:func:`~mitsonar.signal.crosstalk.own_code`)."""
        table = self._crosstalk(u, waves, transmit)[0]
        rho = crosstalk.separation(table)
        codes = np.zeros((len(u), len(waves.kinds), envelopes.shape[1]))  # (B, K, N) [Pa]
        steered = np.zeros(len(u), bool)

        def owned(beams, samples):
            new = np.unique(beams[~steered[beams]])  # each beam's codes steered once
            if len(new):
                kind = waves.kind[new]
                needed = crosstalk.told_apart(rho, kind, self.settings.clutter_margin) \
                    & (np.arange(len(waves.kinds)) != kind[:, None])  # what own_code reads
                codes[new] = crosstalk.steered_codes(self, looks, looks.beamformed[new],
                                                     envelopes.shape[1], needed)
                steered[new] = True
            kind = waves.kind[beams]
            leaked = crosstalk.leaks(codes, table, kind, beams, samples)
            return crosstalk.own_code(envelopes[beams, samples], leaked, rho, kind,
                                      self.settings.clutter_margin)
        return owned

    def _every_echo(self, envelopes, loud, window, balanced, u, looks, clutter, resolution):
        """(beams, samples) of every echo of B beams and (beams, samples) of their range cells
        (``echoes`` = "all": none), each that arrives along its beam
        (:mod:`mitsonar.signal.multiecho`). Masks (B, N): ``loud`` the envelope over the
        threshold, ``window`` the listening window, ``balanced`` the parts balanced; the
        echoes outside the window count as clutter too (a far wall's echo leaks into the window
        of other codes). ``clutter``, ``resolution`` (B,): :meth:`_clutter`."""
        s = self.settings
        found, resolved = multiecho.echo_peaks(envelopes, local_maxima(envelopes) & loud,
                                               window & balanced, resolution, clutter,
                                               s.clutter_margin)
        found = sidelobe.along_beam(self.beamformer, looks, u, *found)
        cells = (np.zeros(0, np.int64),) * 2
        if s.echoes == "cells":
            cells = multiecho.range_cells(envelopes, window & loud, balanced, resolved, found,
                                          resolution, clutter, s.clutter_margin)
            cells = sidelobe.along_beam(self.beamformer, looks, u, *cells)
        return found[0], found[1], cells

    def _cone_echoes(self, image, threshold, window, u, looks, clutter, resolution):
        """(profile M (B, N) [Pa], beams, samples of the echoes, (beams, samples) of the range
        cells, (E, 2) direction cosines where each row's image peaks) of B beams' cone images
        (``echoes`` = "image", :mod:`mitsonar.signal.cone`): rows kept where every part of the
        code is there at that direction and it passes the side-lobe check there. ``clutter``,
        ``resolution`` (B,): :meth:`_clutter`."""
        s = self.settings
        profile, found, cells, best = cone.cone_echoes(self._cone, image, threshold, window,
                                                       resolution, clutter, s.clutter_margin)
        beams, samples = (np.concatenate(x) for x in zip(found, cells))
        apparent = cone.apparent_directions(self._cone, image, u, beams, samples, best)
        directions = placement.unit_direction(apparent)
        passed = cone.parts_balanced(self.beamformer, looks, beams, samples, directions,
                                     s.part_balance)
        if s.ghost_margin > 0:
            todo = np.flatnonzero(passed)
            passed[todo] = sidelobe.passes(self.beamformer, looks, directions[todo],
                                           beams[todo], samples[todo], np.arange(len(todo)))
        echo = passed & (np.arange(len(beams)) < len(found[0]))
        cell = passed & ~echo
        return (profile, beams[echo], samples[echo], (beams[cell], samples[cell]),
                np.concatenate([apparent[echo], apparent[cell]]))

    def _clutter(self, u, waves, transmit=None):
        """(:class:`~mitsonar.signal.multiecho.Clutter`, tau_r (B,) [samples]) of B beams: each
        kind's range side lobes and, in one recording shared by all (their firing times
        ``transmit`` (B,) [s] given), their cross-talk (:meth:`_crosstalk`)."""
        lobes, resolution = waves.range_profiles(self)
        crosstalk = None if transmit is None else self._crosstalk(u, waves, transmit)
        return multiecho.Clutter(lobes, waves.kind, crosstalk), resolution[waves.kind]

    def _crosstalk(self, u, waves, transmit):
        """(|X| (K, K, 2 S + 1), transmit and receive gains (B, B), firing times (B,) [samples])
        of B beams in one recording (:class:`~mitsonar.signal.multiecho.Clutter`): the envelope
        an echo of kind k' leaves decoded for kind k at lags -S..S, S the longest range profile
        above ``CROSS_FLOOR``, each computed once per pair of kinds; the array factors at each
        beam's own frequency."""
        kinds = tuple(waves.kinds)

        def crosstalk_table():  # each OFDM schedule cycle's once
            span = max(int(np.flatnonzero(self.range_profile(w)[0] >= CROSS_FLOOR).max())
                       for w in kinds)
            missing = [(a, b) for a in kinds for b in kinds
                       if (a, b, span) not in self._crosstalks]
            if missing:
                band = self.band
                # An echo of kind b, decoded for kind a, delayed by S samples (lag -S at 0).
                delay = np.exp(-2j * np.pi * band.frequencies * span / band.sample_rate)
                spectra = np.stack([band.system_spectrum(b)[band.bins]
                                    * self.matched_filter(a)[0] for a, b in missing]) * delay
                lobes = np.abs(band.to_analytic(spectra)[:, : 2 * span + 1])
                self._crosstalks.update(((a, b, span), x) for (a, b), x in zip(missing, lobes))
            return np.stack([[self._crosstalks[a, b, span] for b in kinds] for a in kinds])
        table = kept(self._crosstalk_tables, kinds, CROSS_TABLES_KEPT, crosstalk_table)
        frequencies = np.array([float(w.frequency) for w in waves.kinds])[waves.kind]
        g = self.geometry
        return (table, multiecho.array_gains(g.tx_positions, u, frequencies, self.c),
                multiecho.array_gains(g.rx_positions, u, frequencies, self.c).T,
                transmit * self.band.sample_rate)
