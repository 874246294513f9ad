"""The OFDM sonar: frames of many coded beams simulated and decoded (paper III-E).

All beams of a cycle are superposed in one per-channel recording: each beam is traced from the
sensor pose at its own transmit time (the robot moves during a frame), driven by its code through
the transducer response, and the direct cross-talk of every code is included. Decoding: for each
code, matched filter with its own waveform, delay-and-sum toward its direction, detection relative
to its transmit time inside the listening window, depth by (7); all beams of a cycle are decoded
together (:meth:`~mitsonar.signal.receiver.EchoProcessor.process_beams`). Codes and schedules:
:mod:`mitsonar.signal.ofdm`.

Two paths, one decoder. Per-channel (the default, what datasets keep): the cycle's channel
spectra on the band become recordings (inverse transform, white receiver noise per sample), which
are transformed back onto the band. Detection-only (``frame(..., channels=False)``, for mapping):
the synthesised spectra and receiver noise drawn on the band
(:meth:`~mitsonar.signal.synthesis.EchoSynthesizer.band_noise`) go straight to the receiver,
which forms the beams and reads the channels at the candidates' instants from them exactly as it
does from the recordings' spectra. Without noise they differ only in the recording's end
(echoes cut there) and its single-precision samples: the same decisions, depths within 3e-5 mm
on room_glass. With noise, each path draws its own realisation, of the same statistics.
Shared hits (the default; ``OfdmSonar(..., shared_hits=False)`` traces every beam in its own
cone instead): a cycle's hits depend on the pose and the scene, not on the steering, so the
union of its beams' cones is traced once, the element factors computed once per pose group, and
every element pair gridded once; each transmit element is driven by the sum of the cycle's
codes with their steering delays and firing times
(:meth:`~mitsonar.signal.synthesis.EchoSynthesizer.element_spectrum`). Every beam then carries
its transmit pattern over the union of the cycle's cones, side lobes beyond its own 20 deg cone
included: a smooth wall's mirror echo reaches every beam of the cycle through them and hides
the diffuse echoes of walls seen obliquely, so the physical model detects far fewer beams than
with per-beam cones (docs/performance.md).
Forming the beams before gridding (a path per hit and beam) would not save work in a frame: a
cycle fires up to 25 beams into one recording, as many beams as receive channels, so the grids
and transforms keep their size.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mitsonar.caching import kept
from mitsonar.frames import Pose
from mitsonar.sensors.sonar import HITS_STREAM, PRE_ROLL, Sonar, beam_seed
from mitsonar.signal.band import Band
from mitsonar.signal.detection import Echoes
from mitsonar.signal.ofdm import PAPER_LISTEN, Schedule, code_set
from mitsonar.signal.receiver import EchoProcessor
from mitsonar.signal.synthesis import EchoSynthesizer

#: Beams of a cycle fired within (distance [m], angle [rad]) of their pose group's first pose
#: are simulated from that pose, with shared hits: 1 cm is 20 ms at 0.5 m/s, more than a
#: cycle's 12.5 ms of firing, and below what the echoes' own flight time moves the robot (a 2 m
#: echo returns 12 ms after its firing, which no simulated pose follows).
POSE_TOLERANCE = (0.01, np.radians(0.5))
#: A pose group within (distance [m], angle [rad]) of the pose the hits were traced from reuses
#: them with the array moved; farther, the hits are traced again
#: (tests/sensors/test_shared_hits.py: reuse over 3 cm against re-tracing).
RETRACE_TOLERANCE = (0.05, np.radians(2.0))
#: Schedule cycles whose direct paths (spectrum and blanking envelopes, ~3 MB each) an
#: :class:`OfdmSonar` keeps: a 117-beam frame has 5, repeated every frame.
DIRECT_KEPT = 16


@dataclass(frozen=True)
class Frame:
    """Decoded frame.

    Attributes:
        schedule: the schedule it followed.
        detected: (B,) bool.
        depth: (B,) [m], NaN where nothing was detected.
        amplitude: (B,) strongest decoded envelope value [Pa].
        points_sensor: (B, 3) reflectors in the sensor frame of each beam's pose (NaN if none).
        echo_table: every echo reported (``DetectionSettings.echoes``), one row each, points in
            the sensor frame of its beam's pose; its rank-0 rows are ``detected``, ``depth`` and
            ``points_sensor``.
        world_from_sensor: (B, 4, 4) sensor pose when each beam was fired (with shared hits:
            its pose group's, within ``pose_tolerance`` of it).
        crosstalk_db: (B,) level that the other codes of the cycle leave in this code's decoded
            envelope, relative to this beam's own echo [dB] (NaN where nothing was detected, and
            everywhere unless asked for: it needs every beam's echoes apart).
        start_time: frame start on the trajectory's clock [s].
    """

    schedule: Schedule
    detected: np.ndarray
    depth: np.ndarray
    amplitude: np.ndarray
    points_sensor: np.ndarray
    echo_table: Echoes
    world_from_sensor: np.ndarray
    crosstalk_db: np.ndarray
    start_time: float

    @property
    def echo_world_from_sensor(self) -> np.ndarray:
        """(E, 4, 4) the sensor pose of every echo of :attr:`echo_table` (its beam's)."""
        return self.world_from_sensor[self.echo_table.beam]

    @property
    def echo_points_world(self) -> np.ndarray:
        """(E, 3) the points of every echo of :attr:`echo_table` in the world frame, (12)."""
        m = self.echo_world_from_sensor
        return np.einsum("eij,ej->ei", m[:, :3, :3], self.echo_table.point) + m[:, :3, 3]


class OfdmSonar:
    """Simulates and decodes OFDM frames with a :class:`~mitsonar.sensors.sonar.Sonar`'s scene and config.

    Args:
        sonar: the scene and sensor configuration (its tracer, processor settings and noise).
        codes: code set (default: the paper's 25).
        listen: listening time after each cycle [s].
        shared_hits: trace each cycle's hits once and synthesise its recording once from the
            transmit elements' drives (the default; module docstring); False: trace and
            synthesise every beam in its own 20 deg cone, without its transmit side lobes
            beyond it (the reference; also whenever the tracer cannot share hits,
            :meth:`AcousticTracer.shares_hits <mitsonar.trace.tracer.AcousticTracer.shares_hits>`,
            e.g. the paper's point reflectors, and for the cross-talk measurement).
        pose_tolerance: (distance [m], angle [rad]) within which beams fired from moving poses
            are simulated from their pose group's.
        retrace_tolerance: (distance [m], angle [rad]) within which a pose group reuses hits
            traced from another pose.
    """

    def __init__(self, sonar: Sonar, codes=None, listen: float = PAPER_LISTEN,
                 shared_hits: bool = True, pose_tolerance=POSE_TOLERANCE,
                 retrace_tolerance=RETRACE_TOLERANCE):
        self.pose_tolerance = _tolerance("pose_tolerance", pose_tolerance)
        self.retrace_tolerance = _tolerance("retrace_tolerance", retrace_tolerance)
        self.sonar = sonar
        self.shared_hits = bool(shared_hits)
        self.codes = tuple(codes or code_set())
        self.listen = listen
        cfg = sonar.config
        duration = PRE_ROLL + len(self.codes) * self.codes[0].slot + listen
        self.band = Band(cfg.pulse, cfg.transducer, cfg.sample_rate, -PRE_ROLL, duration,
                         cfg.transducer_response, floor=cfg.band_floor, baseband=cfg.baseband,
                         waveforms=self.codes + tuple(t for c in self.codes for t in c.parts))
        self.synth = EchoSynthesizer(self.band)
        self.processor = EchoProcessor(cfg.geometry, self.band, cfg.medium.speed_of_sound,
                                       cfg.detection, cfg.noise_rms)
        self._directs: dict = {}  # schedule cycle -> direct paths' spectrum and envelopes

    def schedule(self, directions) -> Schedule:
        """Schedule of beams towards ``directions`` (B, 3), checked against the field of view."""
        self.sonar.config.geometry.check_in_fov(directions)
        return Schedule.build(directions, self.codes, self.listen)

    def frame(self, schedule: Schedule, pose_at, start_time: float = 0.0, seed: int = 0,
              crosstalk: bool = False, channels: bool = True) -> Frame:
        """Simulate and decode one frame.

        Args:
            schedule: beams, codes and firing times.
            pose_at: function time [s] -> world-from-sensor :class:`Pose` (the robot's motion).
            start_time: frame start on ``pose_at``'s clock [s].
            seed: seeds noise and diffuse phases (same seed, same frame).
            crosstalk: measure the codes' cross-talk (``Frame.crosstalk_db``, NaN otherwise):
                synthesises every beam's echoes apart instead of a cycle's at once.
            channels: record every receive channel (the per-channel path, what datasets keep).
                False: the detection-only path (mapping), decoded from the channels' spectra on
                the band with the receiver noise drawn there
                (:meth:`~mitsonar.signal.synthesis.EchoSynthesizer.band_noise`): no recording,
                noise or channel transform in the time domain, the same decisions (module
                docstring).
        """
        n = len(schedule.directions)
        detected = np.zeros(n, bool)
        depth = np.full(n, np.nan)
        amplitude = np.zeros(n)
        points = np.full((n, 3), np.nan)
        poses = np.zeros((n, 4, 4))
        crosstalk_db = np.full(n, np.nan)
        tables, cycle_beams = [], []
        fired = [pose_at(start_time + t) for t in schedule.transmit_time]  # each beam's pose
        traced = {}  # beams traced for the whole frame at once: where one batch holds them all
        if not self._shares(crosstalk) and n <= self.sonar.trace_batch():
            every = np.arange(n)
            traced = dict(zip(every, self._trace(every, fired, schedule.directions, seed)))
        for c in range(len(schedule.cycle_start)):  # cycles follow each other in time
            beams = np.nonzero(schedule.cycle == c)[0]
            result = self._cycle(schedule, beams, [fired[b] for b in beams], traced, seed,
                                 crosstalk, channels)
            for key, target in (("detected", detected), ("depth", depth), ("amplitude", amplitude),
                                ("crosstalk", crosstalk_db)):
                target[beams] = result[key]
            points[beams] = result["points"]
            poses[beams] = result["poses"]
            tables.append(result["echoes"])
            cycle_beams.append(beams)
        return Frame(schedule, detected, depth, amplitude, points,
                     Echoes.gather(tables, cycle_beams), poses, crosstalk_db, start_time)

    def _shares(self, crosstalk: bool) -> bool:
        """Whether a frame's cycles share their hits (``shared_hits``, module docstring)."""
        return self.shared_hits and not crosstalk and self.sonar.tracer.shares_hits()

    def _trace(self, beams, poses, directions, seed: int) -> list:
        """Traces of ``beams`` (B,) fired from ``poses`` (B) towards ``directions`` (B, 3),
        each in its own cone, :meth:`Sonar.trace_batch
        <mitsonar.sensors.sonar.Sonar.trace_batch>` at a time."""
        size = self.sonar.trace_batch()
        return [trace for first in range(0, len(beams), size)  # a batch at a time
                for trace in self.sonar.tracer.trace_many(
                    poses[first:first + size], directions[first:first + size],
                    [beam_seed(seed, b) for b in beams[first:first + size]])]

    def _beam_echoes(self, beams, poses, directions, offsets, codes, seed: int,
                     apart: bool, traced: dict | None = None) -> np.ndarray:
        """Echo spectra on the band of a cycle's beams, each beam traced in its own cone from
        its own pose (the reference of the shared path; ``traced``: beams traced already):
        (B, N_rx, nb), or (1, N_rx, nb) with every beam's echoes on one grid per distinct
        waveform, one FFT per waveform and channel, unless they are asked for ``apart`` (the
        cross-talk measurement)."""
        sonar = self.sonar
        traces = [traced[b] for b in beams] if traced else \
            self._trace(beams, poses, directions, seed)
        beam_groups = [[(p.delayed(offset), w)  # per beam: its groups, fired at its offset
                        for p, w in sonar.echo_groups(trace.paths, code, self.synth)]
                       for trace, offset, code in zip(traces, offsets, codes)]
        n_rx = sonar.config.geometry.rx.count
        if apart:
            return np.stack([self.synth.groups_spectrum(groups, n_rx) for groups in beam_groups])
        return self.synth.groups_spectrum([g for groups in beam_groups for g in groups],
                                          n_rx)[None]

    def _shared_echoes(self, beams, poses, directions, offsets, codes, seed: int):
        """Echo spectrum on the band (N_rx, nb) of a cycle whose beams share their hits, and the
        pose each beam was simulated from.

        The union of the beams' cones is traced once (:meth:`AcousticTracer.trace_union
        <mitsonar.trace.tracer.AcousticTracer.trace_union>`). Beams fired within
        ``pose_tolerance`` of a pose group's first pose (firing order) are simulated from it:
        one set of element factors and one gridding of every element pair per group, each
        transmit element driven by the sum of the group's codes with their steering delays and
        firing times (:meth:`EchoSynthesizer.element_spectrum
        <mitsonar.signal.synthesis.EchoSynthesizer.element_spectrum>`). A group within
        ``retrace_tolerance`` of the pose the hits were traced from reuses them with the array
        moved (element factors and visibility recomputed); farther, the union is traced again
        from it.
        """
        sonar, synth = self.sonar, self.synth
        tracer = sonar.tracer
        delays = sonar.config.geometry.steering_delays(directions, tracer.c) + offsets[:, None]
        patches, total, simulated = None, 0.0, list(poses)
        for group in _pose_groups(poses, self.pose_tolerance):  # one group at rest
            pose = poses[group[0]]
            if patches is None or not _within(patches.pose, pose, self.retrace_tolerance):
                patches = tracer.trace_union(pose, directions,
                                             beam_seed(seed, int(beams[0]), HITS_STREAM))
            total = total + synth.element_spectrum(tracer.patch_paths(patches, pose),
                                                   [codes[i] for i in group], delays[group])
            for i in group:
                simulated[i] = pose
        return total, simulated

    def _direct(self, directions, offsets, codes) -> tuple[np.ndarray, np.ndarray]:
        """The direct transmitter -> receiver paths of a cycle's beams (directions (B, 3),
        firing times ``offsets`` (B,) [s] within the cycle, codes (B,)): their summed spectrum
        on the band (N_rx, nb) and each beam's envelope of them (B, n_samples) [Pa], for
        blanking. They depend on the schedule alone, not on the pose: computed once per
        schedule cycle and receiver, kept for later frames (``DIRECT_KEPT`` cycles)."""
        key = (np.ascontiguousarray(directions, dtype=float).tobytes(),
               np.ascontiguousarray(offsets, dtype=float).tobytes(), tuple(codes),
               self.processor)

        def direct():
            tracer = self.sonar.tracer
            spectrum = self.synth.groups_spectrum(
                [(tracer.direct_paths(u).delayed(offset), code)
                 for u, offset, code in zip(directions, offsets, codes)],
                self.sonar.config.geometry.rx.count)
            tables = (spectrum, self.processor.noiseless_envelopes(spectrum, directions, codes))
            for array in tables:  # shared by later frames: read only
                array.setflags(write=False)
            return tables
        return kept(self._directs, key, DIRECT_KEPT, direct)

    def _cycle(self, schedule: Schedule, beams, poses, traced: dict, seed: int,
               crosstalk: bool, channels: bool) -> dict:
        sonar = self.sonar
        n_rx = sonar.config.geometry.rx.count
        t0 = schedule.cycle_start[schedule.cycle[beams[0]]]
        offsets = schedule.transmit_time[beams] - t0  # firing times within the cycle
        codes = [schedule.codes[k] for k in schedule.code_index[beams]]
        directions = schedule.directions[beams]
        if self._shares(crosstalk):
            echoes, poses = self._shared_echoes(beams, poses, directions, offsets, codes, seed)
        else:
            echo_spectra = self._beam_echoes(beams, poses, directions, offsets, codes, seed,
                                             crosstalk, traced)
            echoes = np.sum(echo_spectra, axis=0)
        direct_total, blank = self._direct(directions, offsets, codes)
        total = echoes + direct_total
        band, noise_rms = self.band, sonar.config.noise_rms
        noise_seed = beam_seed(seed, int(beams[0]), _NOISE_STREAM)
        processor = self.processor
        listening = dict(transmit_times=offsets,
                         max_path_length=2.0 * sonar.config.max_range)  # every code's window
        if channels:  # the recording, as a dataset keeps it
            rec = self.synth.recording(band.to_samples(total), noise_rms, seed=noise_seed)
            _, det = processor.process_beams(rec, directions, blank, codes, **listening)
        else:  # straight on the band
            _, det = processor.process_spectra(
                total + self.synth.band_noise(n_rx, noise_rms, noise_seed), band.start_time,
                band.n_samples, directions, blank, codes, **listening)
        leaks = np.full(len(beams), np.nan)
        if crosstalk and det.detected.any():  # what the other beams (and direct paths) leave
            found = np.flatnonzero(det.detected)
            leak = processor.noiseless_envelopes(total - np.stack([echo_spectra[i] for i in found]),
                                                 directions[found], [codes[i] for i in found])
            slot = np.array([codes[i].slot for i in found])[:, None]
            times = band.start_time + np.arange(band.n_samples) / band.sample_rate
            window = np.abs(times - offsets[found, None]
                            - det.time_of_arrival[found, None]) < 2 * slot
            strongest = np.where(window, leak, 0.0).max(axis=1)
            leaks[found] = 20 * np.log10(np.maximum(strongest, 1e-30) / det.amplitude[found])
        return {"detected": det.detected, "depth": det.depth, "amplitude": det.amplitude,
                "points": det.point, "echoes": det.echoes, "crosstalk": leaks,
                "poses": np.array([pose.matrix() for pose in poses])}


_NOISE_STREAM = 1_000_003  # separates the noise seeds from the per-beam trace seeds


def _tolerance(name: str, value) -> tuple[float, float]:
    distance, angle = (float(v) for v in value)
    if not (distance >= 0 and angle >= 0):
        raise ValueError(f"OfdmSonar.{name} must be (distance [m], angle [rad]) >= 0, "
                         f"got {value}")
    return distance, angle


def _within(first: Pose, second: Pose, tolerance) -> bool:
    """Whether two poses are within (distance [m], angle [rad]) of each other."""
    turn = (np.trace(first.rotation.T @ second.rotation) - 1.0) / 2.0
    return bool(np.linalg.norm(second.translation - first.translation) <= tolerance[0]
                and np.arccos(np.clip(turn, -1.0, 1.0)) <= tolerance[1])


def _pose_groups(poses, tolerance) -> list[list[int]]:
    """Consecutive runs of ``poses`` (firing order) within ``tolerance`` of each run's first."""
    groups = [[0]]
    for i in range(1, len(poses)):  # bookkeeping over a cycle's poses
        if _within(poses[groups[-1][0]], poses[i], tolerance):
            groups[-1].append(i)
        else:
            groups.append([i])
    return groups


def pose_along(trajectory, mount=None):
    """``pose_at`` function of a :class:`~mitsonar.sensors.trajectory.Trajectory`: time -> sensor pose."""
    mount = mount or Pose.sensor_mount()

    def pose_at(t: float) -> Pose:
        x, y, yaw = trajectory.poses_at([t])[0]
        return Pose.planar(x, y, yaw) @ mount

    return pose_at
