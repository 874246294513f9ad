"""Detection decisions of the receiver: settings, results, envelope peaks, bistatic depth (7).

What the decisions are and why: :mod:`mitsonar.signal.receiver` (one echo per beam) and
:mod:`mitsonar.signal.multiecho` (every echo). Everything here works on B beams at once, as
arrays with a leading beam axis.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from mitsonar.validation import check_positive


#: The settings of :attr:`DetectionSettings.echoes`.
ECHO_MODES = ("first", "all", "cells", "image")
#: The ``echoes`` modes that can re-place off-beam echoes (``DetectionSettings.off_beam``).
OFF_BEAM_MODES = ("first", "all")


@dataclass(frozen=True)
class DetectionSettings:
    """Receiver decision parameters.

    Attributes:
        echoes: which echoes of a beam are reported (:class:`Echoes`): "first" (the default:
            the strongest accepted one, the single detection of :mod:`~mitsonar.signal.receiver`,
            unchanged), "all" (every echo over the range profile, each at its own arrival
            direction and bistatic depth) or "cells" ("all", plus a point for every independent
            range cell across extended echoes); :mod:`mitsonar.signal.multiecho`; or "image"
            (receive beams over each beam's lit cone, a point per echo and range cell where the
            image peaks inside it; :mod:`mitsonar.signal.cone`).
        detection_snr: threshold over the RMS noise envelope, eta (a ratio): noise alone
            exceeds it with probability exp(-eta^2) per sample and gives N eta exp(-eta^2)
            false echoes per beam, N = 2 sqrt(pi) b T the independent cells of a window of T
            [s] (b: the rms bandwidth of the matched-filter output; 5: 3e-9 per beam for the
            TCT40 pulse; :func:`~mitsonar.signal.multiecho.expected_false_alarms`).
        detection_floor: absolute threshold on the envelope [Pa] (matters without noise).
        blanking_margin: factor over the direct-path envelope a detection must exceed; it must
            also exceed that envelope plus the noise threshold (:func:`blanking_level`).
        min_range: nearest depth reported [m].
        ghost_margin: factor by which an off-beam receive direction must beat the beam for a
            candidate to be rejected as a side-lobe arrival (0 disables the check).
        ghost_exclusion: half-angle around the beam treated as its main lobe [rad].
        ghost_grid_step: spacing of the receive directions checked [rad].
        ghost_half_span: the checked directions cover +-this horizontally and vertically [rad]
            (wider than the field of view: side-lobe echoes come from anywhere in front).
        max_candidates: envelope peaks examined, strongest first ("first"; the other settings of
            ``echoes`` examine every peak).
        part_balance: for waveforms with ``parts``, the weakest part's envelope over the
            strongest's that a candidate needs, each relative to what the waveform's own echo
            leaves in that part's filter (in (0, 1]; an echo carries both equally).
        arrival_step: grid step of the arrival-direction estimate within the main lobe [rad]
            (:mod:`mitsonar.signal.receiver`; 0: every point on the beam axis, as the paper).
        clutter_margin: factor by which every echo ("all", "cells") must exceed what the
            stronger echoes of the recording leave there: their range side lobes and ringing
            (amplitude times the waveform's normalised autocorrelation envelope at the lag) and,
            in an OFDM cycle, the other codes' cross-talk
            (:class:`~mitsonar.signal.multiecho.Clutter`).
        min_coherence: "all" and "cells" keep an echo only where this fraction (in [0, 1]) of
            the receive channels' power at its instant is explained by one plane wave from its
            arrival direction (:class:`Echoes` ``coherence``; echoes without an arrival-direction
            estimate are kept, range cells are not).
        arrival_cone: "all", "cells" and "image" keep an echo only where its arrival direction
            lies within this angle of its beam's axis [rad], inside the cone its transmit beam
            lights (None: anywhere the estimate reaches, ``ghost_exclusion``). An arrival
            direction beyond it is the main lobe of an echo lit by the transmit side lobes, or
            pulled there by one (measured, docs/imaging.md).
        image_step: "image": spacing of the receive directions across a beam's cone at
            broadside [rad] (sin(image_step) in direction cosines).
        image_half_angle: "image": half-angle of the cone imaged around each beam's axis [rad]
            (default 3 deg: the steered transmit beam's -6 dB half-width at 40 kHz is 3.1 deg).
        off_beam: "first" or "all": a beam without an accepted echo (every candidate failed
            the side-lobe check, or with "all" the clutter test) gets its strongest candidate
            re-placed where it arrives from, when that is inside the field of view, passes the
            side-lobe check there and is trusted (``min_coherence``), flagged in
            :class:`Echoes` (e.g. a smooth wall's specular echo from the foot of the
            perpendicular; :mod:`mitsonar.signal.offbeam`). Off by default; repeated-mode
            maps turn it on (:class:`~mitsonar.recon.repeated.RepeatedMapSpec`).
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
    echoes: str = "first"
    clutter_margin: float = 2.0
    min_coherence: float = 0.6
    arrival_cone: float | None = None
    image_step: float = np.radians(2.0)
    image_half_angle: float = np.radians(3.0)
    off_beam: bool = False

    def __post_init__(self):
        if self.echoes not in ECHO_MODES:
            raise ValueError(f"DetectionSettings.echoes must be one of {', '.join(ECHO_MODES)}, "
                             f"got {self.echoes!r}")
        if self.echoes == "cells" and not self.arrival_step > 0:
            raise ValueError("DetectionSettings.echoes = 'cells' needs arrival directions "
                             "(arrival_step [rad] > 0)")
        if self.off_beam and not (self.echoes in OFF_BEAM_MODES and self.ghost_margin > 0
                                  and self.arrival_step > 0):
            raise ValueError("DetectionSettings.off_beam needs echoes = 'first' or 'all', the "
                             "side-lobe check (ghost_margin > 0) and arrival directions "
                             "(arrival_step > 0)")
        if not 0 <= self.min_coherence <= 1:
            raise ValueError(f"DetectionSettings.min_coherence must be in [0, 1], "
                             f"got {self.min_coherence}")
        for name in ("detection_snr", "detection_floor", "blanking_margin", "min_range",
                     "ghost_exclusion", "ghost_grid_step", "ghost_half_span", "clutter_margin",
                     "image_step", "image_half_angle"):
            check_positive(f"DetectionSettings.{name}", getattr(self, name))
        if not (np.isfinite(self.ghost_margin) and self.ghost_margin >= 0):
            raise ValueError(f"DetectionSettings.ghost_margin must be >= 0, "
                             f"got {self.ghost_margin}")
        if not (np.isfinite(self.arrival_step) and self.arrival_step >= 0):
            raise ValueError(f"DetectionSettings.arrival_step [rad] must be >= 0, "
                             f"got {self.arrival_step}")
        if not 0 < self.part_balance <= 1:
            raise ValueError(f"DetectionSettings.part_balance must be in (0, 1], "
                             f"got {self.part_balance}")
        if self.arrival_cone is not None:
            check_positive("DetectionSettings.arrival_cone", self.arrival_cone)
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


@dataclass(frozen=True)
class Echoes:
    """Every echo reported for a set of beams, one row each (E rows), sorted by beam and rank
    (:attr:`DetectionSettings.echoes` says which echoes). Points are in the sensor frame of the
    beam's pose.

    Attributes:
        beam: (E,) index of the row's beam.
        rank: (E,) 0 for the beam's strongest echo (its :class:`Detections` entry), then its
            other echoes by decreasing amplitude, then its range cells by decreasing amplitude.
        peak: (E,) True for an echo (its envelope peak, refined by a parabola), False for a
            range cell across an extended echo (read at its sample).
        amplitude: (E,) envelope [Pa].
        snr: (E,) amplitude over the beam's RMS noise envelope (a ratio, not dB).
        time_of_arrival: (E,) [s] from the beam's firing.
        path_length: (E,) c * time_of_arrival [m].
        depth: (E,) distance of the point from the transmit origin, (7) [m].
        point: (E, 3) reflector [m].
        direction: (E, 3) unit vector the echo arrived from (the beam's direction without an
            arrival-direction estimate).
        coherence: (E,) fraction of the receive channels' power at that instant explained by one
            plane wave from ``direction``, summed over the looks (1: a single arrival; about
            1 / N_rx for noise; NaN without an arrival-direction estimate).
        off_beam: (E,) True for an echo that failed its beam's side-lobe check and was re-placed
            where it arrives from (:attr:`DetectionSettings.off_beam`; its amplitude and SNR are
            those along the beam, its time read at the sample where the envelope steered there
            peaks).
    """

    beam: np.ndarray
    rank: np.ndarray
    peak: np.ndarray
    amplitude: np.ndarray
    snr: np.ndarray
    time_of_arrival: np.ndarray
    path_length: np.ndarray
    depth: np.ndarray
    point: np.ndarray
    direction: np.ndarray
    coherence: np.ndarray
    off_beam: np.ndarray

    def __len__(self) -> int:
        return len(self.beam)

    def arrays(self, prefix: str = "") -> dict:
        """The columns as named arrays, each name preceded by ``prefix``."""
        return {prefix + f.name: getattr(self, f.name) for f in fields(self)}

    def take(self, rows) -> Echoes:
        """The rows ``rows`` (indices or a boolean mask), in that order."""
        return Echoes(**{name: value[rows] for name, value in self.arrays().items()})

    @classmethod
    def gather(cls, tables, beams) -> Echoes:
        """One table of several: table i's beam indices mapped through ``beams[i]`` (e.g. a
        batch's or a cycle's beams among all of a scan's or frame's), sorted by beam and rank."""
        joined = {f.name: np.concatenate([getattr(t, f.name) for t in tables])
                  for f in fields(cls)}
        joined["beam"] = np.concatenate([np.asarray(b)[t.beam] for t, b in zip(tables, beams)])
        return cls(**joined).take(np.lexsort((joined["rank"], joined["beam"])))


@dataclass(frozen=True)
class Detections:
    """Results of processing B beams: the fields of :class:`Detection` stacked along a leading
    beam axis, (B,) or (B, 3); ``detections[b]`` is beam b's :class:`Detection`: its strongest
    echo, rank 0 of :attr:`echoes` (every accepted echo, one row each)."""

    detected: np.ndarray
    time_of_arrival: np.ndarray
    path_length: np.ndarray
    depth: np.ndarray
    point: np.ndarray
    direction: np.ndarray
    amplitude: np.ndarray
    threshold: np.ndarray
    echoes: Echoes

    def __len__(self) -> int:
        return len(self.detected)

    def __getitem__(self, b: int) -> Detection:
        return Detection(bool(self.detected[b]), float(self.time_of_arrival[b]),
                         float(self.path_length[b]), float(self.depth[b]), self.point[b].copy(),
                         self.direction[b].copy(), float(self.amplitude[b]),
                         float(self.threshold[b]))


def bistatic_depth(path_length, baseline: float, cos_beam_baseline) -> np.ndarray:
    """Equation (7): depth [m] from path length l [m], baseline b [m] and cos(theta_b)."""
    l = np.asarray(path_length, dtype=float)
    return (l**2 - baseline**2) / (2.0 * (l - baseline * np.asarray(cos_beam_baseline)))


def blanking_level(threshold, direct, margin: float) -> np.ndarray:
    """What an envelope must exceed where the direct transmitter -> receiver path's noiseless
    envelope is ``direct`` [Pa] (any shape broadcasting with ``threshold`` [Pa], the noise
    threshold): ``margin`` times it, and at least it plus ``threshold``. The recording holds
    the direct path plus noise, |D + n| <= D + |n|, so a cell passes only where the noise alone
    would pass the threshold: the design false-alarm rate holds where the direct path's tail
    is as weak as the noise (a wide sweep's, traced at frequency nodes, stays 1-4 times the
    noise envelope for ms), where ``margin`` times it alone let noise through."""
    return np.maximum(margin * direct, threshold + direct)


def vertex(y0, y1, y2) -> np.ndarray:
    """Offsets [samples] of the vertices of the parabolas through equally spaced values y0, y1,
    y2 (broadcast arrays) from the middle ones; 0 where they do not peak in the middle."""
    y0, y1, y2 = np.broadcast_arrays(*(np.asarray(y, dtype=float) for y in (y0, y1, y2)))
    denom = y0 - 2 * y1 + y2
    return np.divide(0.5 * (y0 - y2), denom, out=np.zeros(denom.shape), where=denom < 0)


def candidates(envelopes: np.ndarray, accepted: np.ndarray, max_candidates: int):
    """Envelope peaks worth examining: local maxima (B, N) of ``envelopes`` where ``accepted``
    (B, N) (above threshold, inside the window, parts balanced), strongest first, at most
    ``max_candidates`` per beam. Returns (beam, sample, rank) arrays, sorted by beam then rank
    (0: the beam's strongest)."""
    e = envelopes
    beams, samples = np.nonzero(local_maxima(e) & accepted)
    order = np.lexsort((-e[beams, samples], beams))
    beams, samples = beams[order], samples[order]
    ranks = np.arange(len(beams)) - np.searchsorted(beams, beams)
    keep = ranks < max_candidates
    return beams[keep], samples[keep], ranks[keep]


def local_maxima(envelopes: np.ndarray) -> np.ndarray:
    """(B, N) where envelopes (B, N) have a local maximum along N (the first sample of a flat
    top; never the first or last sample)."""
    e = envelopes
    peaks = np.zeros(e.shape, bool)
    peaks[:, 1:-1] = (e[:, 1:-1] >= e[:, :-2]) & (e[:, 1:-1] > e[:, 2:])
    return peaks
