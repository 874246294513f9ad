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
Forming the beams before gridding (a path per hit and beam) would not save work in a frame: a
cycle fires up to 25 beams into one recording, as many beams as receive channels, so the grids
and transforms keep their size.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mitsonar.frames import Pose
from mitsonar.sensors.sonar import PRE_ROLL, TRACE_BATCH, Sonar
from mitsonar.signal.band import Band
from mitsonar.signal.detection import Echoes
from mitsonar.signal.ofdm import PAPER_LISTEN, Schedule, code_set
from mitsonar.signal.receiver import EchoProcessor
from mitsonar.signal.synthesis import EchoSynthesizer


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
        world_from_sensor: (B, 4, 4) sensor pose when each beam was fired.
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
    """

    def __init__(self, sonar: Sonar, codes=None, listen: float = PAPER_LISTEN):
        self.sonar = sonar
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
        for c in range(len(schedule.cycle_start)):  # cycles follow each other in time
            beams = np.nonzero(schedule.cycle == c)[0]
            result = self._cycle(schedule, beams, pose_at, start_time, seed, crosstalk,
                                 channels)
            for key, target in (("detected", detected), ("depth", depth), ("amplitude", amplitude),
                                ("crosstalk", crosstalk_db)):
                target[beams] = result[key]
            points[beams] = result["points"]
            poses[beams] = result["poses"]
            tables.append(result["echoes"])
            cycle_beams.append(beams)
        return Frame(schedule, detected, depth, amplitude, points,
                     Echoes.gather(tables, cycle_beams), poses, crosstalk_db, start_time)

    def _cycle(self, schedule: Schedule, beams, pose_at, start_time: float, seed: int,
               crosstalk: bool, channels: bool) -> dict:
        sonar = self.sonar
        n_rx = sonar.config.geometry.rx.count
        t0 = schedule.cycle_start[schedule.cycle[beams[0]]]
        offsets = schedule.transmit_time[beams] - t0  # firing times within the cycle
        codes = [schedule.codes[k] for k in schedule.code_index[beams]]
        directions = schedule.directions[beams]
        poses = [pose_at(start_time + schedule.transmit_time[b]) for b in beams]
        beam_groups = []  # per beam: its (paths, waveform) groups, fired at its offset
        for first in range(0, len(beams), TRACE_BATCH):  # beams traced a batch at a time
            batch = slice(first, first + TRACE_BATCH)
            traces = sonar.tracer.trace_many(poses[batch], directions[batch],
                                             [_seed(seed, b) for b in beams[batch]])
            beam_groups += [[(p.delayed(offset), w)
                             for p, w in sonar.echo_groups(trace.paths, code, self.synth)]
                            for trace, offset, code in zip(traces, offsets[batch], codes[batch])]
        if crosstalk:  # each beam's echoes apart, to measure what the others leave in its code
            echo_spectra = [self.synth.groups_spectrum(groups, n_rx) for groups in beam_groups]
            echoes = np.sum(echo_spectra, axis=0)
        else:  # the cycle's echoes on one grid, one FFT per distinct waveform and channel
            echoes = self.synth.groups_spectrum([g for groups in beam_groups for g in groups], n_rx)
        direct_total = self.synth.groups_spectrum(
            [(sonar.tracer.direct_paths(u).delayed(offset), code)
             for u, offset, code in zip(directions, offsets, codes)], n_rx)
        total = echoes + direct_total
        band, noise_rms = self.band, sonar.config.noise_rms
        noise_seed = _seed(seed, int(beams[0]), _NOISE_STREAM)
        processor = self.processor
        blank = processor.noiseless_envelopes(direct_total, directions, codes)
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


def _seed(seed: int, *parts) -> int:
    return int(np.random.SeedSequence([seed, *map(int, parts)]).generate_state(1)[0])


def pose_along(trajectory, mount=None):
    """``pose_at`` function of a :class:`~mitsonar.sensors.trajectory.Trajectory`: time -> sensor pose."""
    mount = mount or Pose.sensor_mount()

    def pose_at(t: float) -> Pose:
        x, y, yaw = trajectory.poses_at([t])[0]
        return Pose.planar(x, y, yaw) @ mount

    return pose_at
