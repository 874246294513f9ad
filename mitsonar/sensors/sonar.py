"""The user-facing sonar: configuration, one ping, and scans over the field of view.

    import mitsonar
    sonar = mitsonar.Sonar("scenes/room_glass/scene.xml")
    pose = mitsonar.Pose.sensor_on_robot(x=0.0, y=0.0, yaw=0.0)
    ping = sonar.ping(pose, mitsonar.direction_from_fov_angles(0.0, 0.0))
    print(ping.detection.depth)                      # metres, NaN if no detection
    scan = sonar.scan(pose, sonar.fov_grid(np.radians(5)))
    scan.points_world                                # (n_detected, 3)
    scan.echo_points_world                           # every echo (DetectionSettings.echoes)
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field, fields, replace
from pathlib import Path

import numpy as np

from mitsonar.physics.array import ArrayGeometry
from mitsonar.frames import Pose
from mitsonar.trace.hitpaths import HitPaths
from mitsonar.physics.medium import Medium
from mitsonar.signal.detection import Detection, DetectionSettings, Echoes
from mitsonar.signal.receiver import EchoProcessor
from mitsonar.scene.loading import AcousticScene, load_scene
from mitsonar.physics.waveforms import SWEEPS, Chirp, Pulse
from mitsonar.signal.band import BAND_TOP, Band, Recording
from mitsonar.signal.synthesis import EchoSynthesizer
from mitsonar.trace.paths import Paths
from mitsonar.trace.subbands import nodes_needed
from mitsonar.trace.settings import TraceSettings
from mitsonar.trace.tracer import AcousticTracer, TraceResult, band_half_width, frequency_gains
from mitsonar.physics.transducer import Transducer
from mitsonar.validation import check_positive

#: Time recorded before the virtual firing of the transmit origin [s] (steering delays are
#: negative for half the elements).
PRE_ROLL = 0.5e-3
#: Beams traced together by scans and OFDM cycles: enough to pay the per-call costs of the ray
#: casts once for several beams, few enough to bound memory (~20 MB of patch factors and
#: temporaries per beam).
TRACE_BATCH = 8
#: Rays cast together at most when more beams than ``TRACE_BATCH`` fit (beams of few rays: the
#: paper model's 25 reflectors): a batch of ``TRACE_BATCH`` beams of the default 32 x 32 grid.
#: Each cast of the scene costs ~10 ms whatever its size (the surface interaction's dispatch
#: over the scene's shapes), so an OFDM cycle of such beams is traced in one.
TRACE_RAYS = TRACE_BATCH * 32 * 32


@dataclass(frozen=True)
class SonarConfig:
    """Everything that defines a simulated sensor; SI units throughout.

    Attributes:
        medium: air.
        transducer: element model.
        geometry: arrays and field of view.
        pulse: drive waveform: a tone burst (:class:`~mitsonar.physics.waveforms.Pulse`) or a
            frequency sweep (:class:`~mitsonar.physics.waveforms.Chirp`, for imaging).
        trace: ray-tracing fidelity and scattering model.
        detection: receiver decisions.
        sample_rate: sample rate of real recordings [Hz]; it also sets the frequency grid and
            the noise reference of baseband ones.
        max_range: farthest depth recorded [m].
        noise_rms: receiver noise per sample of a real recording at ``sample_rate`` [Pa]
            (baseband recordings carry the same noise density on their band).
        transducer_response: apply the resonant transmit and receive responses.
        narrowband_bandwidth: when the transducers' -6 dB bandwidth is at most this [Hz], each
            hit's transmit elements are merged into one path per receive channel before synthesis
            (:meth:`~mitsonar.signal.synthesis.Paths.narrowband`, N_tx / 2 times fewer paths): the
            resonance then confines every echo, whatever the drive, to a narrow band around it.
            The error is second order in bandwidth x delay spread; measured for the TCT40 class
            on steered beams: < 1 % of the peak for the pulse, < 5 % for 36/44 kHz OFDM tones, up
            to 16 % for the 32/48 kHz tones (48 dB down). 0 (or ideal transducers) synthesises
            every element pair exactly.
        baseband: record complex baseband (I/Q about the band centre, at twice the band's width;
            :mod:`mitsonar.signal.synthesis`) instead of real pressure at ``sample_rate``: the same
            echoes on the band with a few times fewer samples to synthesise, add noise to and
            process. None (default): whenever the band is at most 0.35 ``sample_rate`` wide
            (resonant transducers: yes; the paper's ideal ones: no).
        band_floor: the recorded band keeps the echo spectrum down to this fraction of its peak
            (leaving out the rest changes the echoes by 2-4 times this, relative to the peak echo).
    """

    medium: Medium = field(default_factory=Medium)
    transducer: Transducer = field(default_factory=Transducer)
    geometry: ArrayGeometry = field(default_factory=ArrayGeometry)
    pulse: Pulse | Chirp = field(default_factory=Pulse)
    trace: TraceSettings = field(default_factory=TraceSettings)
    detection: DetectionSettings = field(default_factory=DetectionSettings)
    sample_rate: float = 200_000.0
    max_range: float = 5.0
    noise_rms: float = 1e-3
    transducer_response: bool = True
    narrowband_bandwidth: float = 5000.0
    baseband: bool | None = None
    band_floor: float = 3e-4

    def __post_init__(self):
        check_positive("SonarConfig.sample_rate [Hz]", self.sample_rate)
        check_positive("SonarConfig.max_range [m]", self.max_range)
        if not self.narrowband_bandwidth >= 0:
            raise ValueError(f"SonarConfig.narrowband_bandwidth [Hz] must be >= 0, "
                             f"got {self.narrowband_bandwidth}")
        if not 0 < self.band_floor < 1:
            raise ValueError(f"SonarConfig.band_floor must be in (0, 1), got {self.band_floor}")
        if not (np.isfinite(self.noise_rms) and self.noise_rms >= 0):
            raise ValueError(f"SonarConfig.noise_rms [Pa] must be >= 0, got {self.noise_rms}")
        if self.sample_rate < 4 * self.pulse.frequency:
            raise ValueError(f"SonarConfig.sample_rate must be >= 4x the carrier "
                             f"({4 * self.pulse.frequency:.0f} Hz), got {self.sample_rate}")
        top = self.pulse.frequency + 0.5 * self.pulse.bandwidth
        if top >= BAND_TOP * self.sample_rate:
            raise ValueError(f"SonarConfig.sample_rate [Hz] must be above {1 / BAND_TOP:g}x the "
                             f"drive's top frequency ({top:.0f} Hz), got {self.sample_rate}")

    @classmethod
    def preset(cls, name: str) -> "SonarConfig":
        """Named configurations: 'default' (physical model) and 'paper' (the paper's choices:
        25 point reflectors, ideal transducers, no air absorption, 340 m/s)."""
        if name == "default":
            return cls()
        if name == "paper":
            return cls(medium=Medium(temperature=288.15),  # 15 degC: c = 340.3 m/s
                       trace=TraceSettings(model="paper", air_absorption=False),
                       pulse=Pulse(ramp_cycles=0.0), transducer_response=False)
        raise ValueError(f"unknown sonar preset '{name}'; known: default, paper")

    @classmethod
    def from_toml(cls, path) -> "SonarConfig":
        """Load a config: optional ``preset`` key, then tables [medium], [transducer], [pulse],
        [trace], [detection] and top-level scalars overriding it; a [chirp] table (the fields of
        :class:`~mitsonar.physics.waveforms.Chirp`) drives a frequency sweep instead of the
        pulse. Unknown keys are errors."""
        path = Path(path)
        try:
            data = tomllib.loads(path.read_text())
        except (OSError, tomllib.TOMLDecodeError) as err:
            raise ValueError(f"{path}: {err}") from None
        config = cls.preset(data.pop("preset", "default"))
        changes = {}
        if "chirp" in data:
            if "pulse" in data:
                raise ValueError(f"{path}: give [pulse] or [chirp], not both")
            sweep, known = data.pop("chirp"), [f.name for f in fields(Chirp)]
            bad = set(sweep) - set(known) if isinstance(sweep, dict) else set()
            if not isinstance(sweep, dict) or bad:
                raise ValueError(f"{path}: [chirp] must be a table of {known}"
                                 + (f"; unknown keys {sorted(bad)}" if bad else ""))
            try:
                changes["pulse"] = Chirp(**sweep)
            except (TypeError, ValueError) as err:
                raise ValueError(f"{path}: [chirp] {err}") from None
        for f in fields(cls):
            if f.name not in data:
                continue
            value = data.pop(f.name)
            if isinstance(value, dict):
                current = getattr(config, f.name)
                known = {g.name for g in fields(current)}
                bad = set(value) - known
                if bad:
                    raise ValueError(f"{path}: unknown keys {sorted(bad)} in [{f.name}]")
                try:
                    changes[f.name] = replace(current, **value)
                except (TypeError, ValueError) as err:
                    raise ValueError(f"{path}: [{f.name}] {err}") from None
            else:
                changes[f.name] = value
        if data:
            raise ValueError(f"{path}: unknown keys {sorted(data)}")
        try:
            return replace(config, **changes)
        except (TypeError, ValueError) as err:
            raise ValueError(f"{path}: {err}") from None

    def with_drive(self, broadband: bool = False,
                   chirp: bool | str | None = None) -> "SonarConfig":
        """This configuration with broadband transducers (``Transducer.broadband()``, 20 kHz
        at -6 dB) and/or driven by a frequency sweep for single-ping imaging (``chirp``, one of
        :data:`SWEEPS`; True: "30-50"): "30-50" the default sweep (``Chirp()``), "20-80"
        RTIS's (:meth:`with_wide_sweep`). A sweep needs transducers that pass it: broadband
        ones pass 30-50 kHz, the ideal ones of ``paper`` pass either (ValueError otherwise)."""
        config = replace(self, transducer=Transducer.broadband()) if broadband else self
        sweep = "30-50" if chirp is True else chirp or None
        if sweep is not None and sweep not in SWEEPS:
            raise ValueError(f"chirp must be one of {', '.join(SWEEPS)}, got {chirp!r}")
        if sweep == "20-80":
            return config.with_wide_sweep()
        if sweep == "30-50":
            config._check_passes(Chirp())
            config = replace(config, pulse=Chirp())
        return config

    def with_wide_sweep(self) -> "SonarConfig":
        """This configuration driven by RTIS's sweep, 4 ms over 20-80 kHz, sampled at 250 kHz
        (the band's top needs more than 200 kHz) and traced at five frequency nodes 15 kHz
        apart (docs/imaging.md, "Frequency sweeps"). Its transducers must pass the sweep: the
        ``paper`` preset's ideal ones (ValueError otherwise)."""
        sweep = Chirp(20e3, 80e3, 4e-3)
        self._check_passes(sweep)
        return replace(self, pulse=sweep, sample_rate=250e3,
                       trace=replace(self.trace, subbands=5))

    def _check_passes(self, sweep: Chirp) -> None:
        """ValueError naming the sweep's band where the transducers pass less than it."""
        if self.transducer_response and self.transducer.bandwidth_6db < sweep.bandwidth:
            raise ValueError(f"a {min(sweep.start, sweep.stop) / 1e3:g}-"
                             f"{max(sweep.start, sweep.stop) / 1e3:g} kHz sweep needs transducers "
                             f"that pass it: these pass {self.transducer.bandwidth_6db / 1e3:g} kHz")

    def resolved_trace(self, trace: TraceSettings | None = None,
                       max_angle: float | None = None) -> TraceSettings:
        """``trace`` (default: this configuration's) with ``subbands="auto"`` resolved for this
        drive, its transducers, air and listening window (:func:`~mitsonar.trace.subbands.
        nodes_needed`); ``max_angle``: the widest angle off broadside a traced patch lies at
        [rad] (default: the field of view's half-diagonal plus the traced cone)."""
        trace = self.trace if trace is None else trace
        if trace.subbands != "auto":
            return trace
        if max_angle is None:
            max_angle = min(self.geometry.fov_half_diagonal + trace.traced_half_angle,
                            np.radians(80))
        half = band_half_width(self.transducer, self.pulse)
        f = np.linspace(max(self.pulse.frequency - 4 * half, 1.0),
                        self.pulse.frequency + 4 * half, 1601)
        weight = np.abs(self.pulse.spectrum(f))
        if self.transducer_response:
            weight = weight * np.abs(self.transducer.frequency_response(f)) ** 2
        gain = frequency_gains(self.transducer, self.medium, trace, max_angle,
                               self.medium.speed_of_sound * self.record_duration)
        return replace(trace, subbands=nodes_needed(gain, self.pulse.frequency, half, f, weight,
                                                    trace.subband_tolerance))

    def with_detection(self, **changes) -> "SonarConfig":
        """This configuration with ``changes`` to its :class:`DetectionSettings` (checked as
        there), e.g. ``config.with_detection(echoes="cells")``."""
        return replace(self, detection=replace(self.detection, **changes))

    @property
    def record_duration(self) -> float:
        """Recording length [s]: pre-roll, the round trip to ``max_range``, and a whole echo
        (pulse plus the ringing of both transducers down to e^-7) after it."""
        ringing = 14 * self.transducer.decay_time if self.transducer_response else 0.0
        return PRE_ROLL + 2 * self.max_range / self.medium.speed_of_sound + self.pulse.duration \
            + ringing


@dataclass(frozen=True)
class Ping:
    """One beam: paths, recording, processed envelope and the detection.

    Attributes:
        direction: (3,) beam direction in the sensor frame.
        trace: the traced paths and reflectors.
        recording: the per-channel echoes.
        envelope: (N,) beamformed matched-filter envelope [Pa].
        direct_envelope: (N,) the same for the direct path alone (blanking reference) [Pa].
        detection: the decision.
    """

    direction: np.ndarray
    trace: TraceResult
    recording: Recording
    envelope: np.ndarray
    direct_envelope: np.ndarray
    detection: Detection


@dataclass(frozen=True)
class Scan:
    """Many beams from one pose.

    Attributes:
        pose: world-from-sensor pose.
        directions: (B, 3) beam directions, sensor frame.
        detected: (B,) bool.
        depth: (B,) [m], NaN where nothing was detected.
        amplitude: (B,) strongest envelope value [Pa].
        points_sensor: (B, 3) reflectors, sensor frame, NaN where nothing was detected.
        echo_table: every echo reported (``DetectionSettings.echoes``), one row each, points in
            the sensor frame; its rank-0 rows are ``detected``, ``depth`` and ``points_sensor``.
        echoes: (B, N_rx, N) recordings [Pa]: float32 pressure, or complex64 baseband when
            ``carrier`` > 0 (pressure = Re(echoes exp(j 2 pi carrier t))).
        sample_rate: [Hz]; start_time: time of sample 0 [s]; carrier: [Hz] (0: real pressure).
    """

    pose: Pose
    directions: np.ndarray
    detected: np.ndarray
    depth: np.ndarray
    amplitude: np.ndarray
    points_sensor: np.ndarray
    echo_table: Echoes
    echoes: np.ndarray
    sample_rate: float
    start_time: float
    carrier: float = 0.0

    def arrays(self) -> dict:
        """The scan as named arrays (the ``echoes.npz`` format of docs/datasets.md): the echo
        table's columns are named ``echo_`` + column."""
        from mitsonar.frames import fov_angles

        h, v = fov_angles(self.directions)
        return dict(echoes=self.echoes, sample_rate=self.sample_rate, start_time=self.start_time,
                    carrier_frequency=self.carrier,
                    directions=self.directions, horizontal_deg=np.degrees(h),
                    vertical_deg=np.degrees(v), detected=self.detected, depth=self.depth,
                    amplitude=self.amplitude, points_sensor=self.points_sensor,
                    **self.echo_table.arrays("echo_"))

    @property
    def points_world(self) -> np.ndarray:
        """(n_detected, 3) detected reflectors in the world frame, equation (12)."""
        return self.pose.transform_points(self.points_sensor[self.detected])

    @property
    def echo_points_world(self) -> np.ndarray:
        """(E, 3) the points of every echo of :attr:`echo_table` in the world frame, (12)."""
        return self.pose.transform_points(self.echo_table.point)


class Sonar:
    """A simulated phased-array sonar in one loaded scene; reuses the scene and all precomputation.

    Args:
        scene: an :class:`AcousticScene` or the path of a scene file.
        config: sensor configuration.
    """

    def __init__(self, scene, config: SonarConfig | None = None):
        self.config = config or SonarConfig()
        self.scene = scene if isinstance(scene, AcousticScene) else load_scene(scene)
        cfg = self.config
        self.tracer = AcousticTracer(self.scene, cfg.geometry, cfg.transducer, cfg.medium,
                                     cfg.pulse, cfg.resolved_trace())
        self.band = Band(cfg.pulse, cfg.transducer, cfg.sample_rate, -PRE_ROLL,
                         cfg.record_duration, cfg.transducer_response, floor=cfg.band_floor,
                         baseband=cfg.baseband)
        self.synthesizer = EchoSynthesizer(self.band)
        self.processor = EchoProcessor(cfg.geometry, self.band, cfg.medium.speed_of_sound,
                                       cfg.detection, cfg.noise_rms)
        self._direct_envelopes: dict = {}

    def trace_batch(self) -> int:
        """Beams traced together (:meth:`AcousticTracer.trace_many
        <mitsonar.trace.tracer.AcousticTracer.trace_many>`): ``TRACE_BATCH``, or as many as
        ``TRACE_RAYS`` rays allow where a beam casts fewer (its grid before refinement)."""
        return max(TRACE_BATCH, TRACE_RAYS // self.tracer.grid_rays)

    def fov_grid(self, step: float) -> np.ndarray:
        """Beam directions on a ``step`` [rad] grid over the field of view (see
        :meth:`~mitsonar.physics.array.ArrayGeometry.fov_grid`)."""
        return self.config.geometry.fov_grid(step)

    def ping(self, pose: Pose, direction, seed: int = 0) -> Ping:
        """Transmit one beam towards ``direction`` (3,) (sensor frame) from ``pose`` and detect.

        The beam is traced in its own cone (``TraceSettings.cone_half_angle``), without its
        transmit side lobes beyond it (a scan with ``shared_hits`` carries them over the field of
        view).

        Args:
            pose: world-from-sensor pose.
            direction: beam direction, inside the field of view.
            seed: seeds the diffuse phases and the receiver noise (same seed, same echoes).
        """
        u = np.asarray(direction, dtype=float)
        if u.shape != (3,):
            raise ValueError(f"direction must be a (3,) vector, got shape {u.shape}")
        self.config.geometry.check_in_fov(u)
        u = u / np.linalg.norm(u)
        trace = self.tracer.trace(pose, u, seed=seed)
        recording = self._record(u, trace, seed)
        direct_envelope = self._direct_envelopes_towards(u[None])[0]
        envelope, detection = self.processor.process(recording, u, direct_envelope)
        return Ping(u, trace, recording, envelope, direct_envelope, detection)

    def _record(self, u: np.ndarray, trace: TraceResult, seed: int) -> Recording:
        """The noisy recording of a traced beam (unit direction ``u``) and its direct paths."""
        groups = self.echo_groups(trace.paths, self.config.pulse) \
            + [(self.tracer.direct_paths(u), self.config.pulse)]
        synth = self.synthesizer
        spectrum = synth.groups_spectrum(groups, self.config.geometry.rx.count)
        return synth.recording(self.band.to_samples(spectrum), self.config.noise_rms,
                               seed=[seed, 1])

    def _direct_envelopes_towards(self, directions: np.ndarray) -> np.ndarray:
        """Envelopes (B, N) of the direct paths alone towards unit directions (B, 3), the
        blanking references; they depend on the direction only: each computed once."""
        keys = [tuple(np.round(u, 12)) for u in directions]
        missing = dict((key, u) for key, u in zip(keys, directions)
                       if key not in self._direct_envelopes)
        if missing:
            n_rx = self.config.geometry.rx.count
            todo = np.array(list(missing.values()))
            spectra = np.stack([self.synthesizer.group_spectrum(self.tracer.direct_paths(u), None,
                                                                n_rx) for u in todo])
            self._direct_envelopes.update(zip(missing,
                                              self.processor.noiseless_envelopes(spectra, todo)))
        return np.stack([self._direct_envelopes[key] for key in keys])

    def echo_groups(self, paths: Paths | HitPaths, waveform,
                    synthesizer: EchoSynthesizer | None = None) -> list:
        """(paths, waveform) groups to synthesise the traced ``paths`` driven by ``waveform`` with
        ``synthesizer`` (default: this sonar's), transmit elements merged behind narrow-band
        transducers (see ``config.narrowband_bandwidth``)."""
        cfg = self.config
        if cfg.transducer_response and cfg.transducer.bandwidth_6db <= cfg.narrowband_bandwidth:
            return (synthesizer or self.synthesizer).narrowband_groups(paths, waveform)
        return [(paths, waveform)]

    def scan(self, pose: Pose, directions, seed: int = 0, progress=None,
             shared_hits: bool = False) -> Scan:
        """Ping every direction (B, 3) from one pose; ``progress`` is called with each index.

        Beam b uses seed ``[seed, b]`` and gives the same ping as :meth:`ping` with that seed;
        beams are traced ``TRACE_BATCH`` at a time (:meth:`AcousticTracer.trace_many
        <mitsonar.trace.tracer.AcousticTracer.trace_many>`) and each batch's recordings decoded
        together (:meth:`EchoProcessor.process_beams
        <mitsonar.signal.receiver.EchoProcessor.process_beams>`).

        With ``shared_hits`` the beam-independent work is done once for the scan: the union of
        the beams' cones traced once (:meth:`AcousticTracer.trace_union
        <mitsonar.trace.tracer.AcousticTracer.trace_union>`, seed ``[seed, 0, HITS_STREAM]``),
        every element pair gridded and transformed once, each ping's recording the channels
        driven by its steering (:meth:`EchoSynthesizer.driven_samples
        <mitsonar.signal.synthesis.EchoSynthesizer.driven_samples>`; noise seeded as without).
        Each beam then carries its transmit pattern over the union, side lobes beyond its own
        20 deg cone included, as an OFDM frame's beams do (docs/performance.md); where the
        tracer cannot share hits (:meth:`AcousticTracer.shares_hits
        <mitsonar.trace.tracer.AcousticTracer.shares_hits>`: the paper model) every beam is
        traced in its own cone, as without.
        """
        dirs = np.asarray(directions, dtype=float).reshape(-1, 3)
        if not len(dirs):
            raise ValueError("Sonar.scan needs at least one beam direction, got none")
        self.config.geometry.check_in_fov(dirs)
        dirs = dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
        n_rx = self.config.geometry.rx.count
        band = self.band
        echoes = np.empty((len(dirs), n_rx, band.n_samples),
                          dtype=np.complex64 if band.baseband else np.float32)
        shared = self._shared_samples(pose, dirs, seed) \
            if shared_hits and self.tracer.shares_hits() else None
        found = []
        for first in range(0, len(dirs), TRACE_BATCH):
            beams = range(first, min(first + TRACE_BATCH, len(dirs)))
            seeds = [beam_seed(seed, b) for b in beams]
            batch = dirs[first:beams.stop]
            if shared is None:
                traces = self.tracer.trace_many([pose] * len(beams), batch, seeds)
                recordings = [self._record(u, trace, one)  # each beam's echoes, vectorised
                              for u, trace, one in zip(batch, traces, seeds)]
            else:
                recordings = [self.synthesizer.recording(samples, self.config.noise_rms,
                                                         seed=[one, 1])
                              for samples, one in zip(next(shared), seeds)]
            found.append(self.processor.process_beams(recordings, batch,
                                                      self._direct_envelopes_towards(batch))[1])
            for b, recording in zip(beams, recordings):  # keep the echoes, not the paths
                echoes[b] = recording.samples
                if progress is not None:
                    progress(b)
        joined = {name: np.concatenate([getattr(d, name) for d in found])
                  for name in ("detected", "depth", "amplitude", "point")}
        table = Echoes.gather([d.echoes for d in found],
                              [np.arange(first, first + len(d)) for first, d in
                               zip(range(0, len(dirs), TRACE_BATCH), found)])
        return Scan(pose=pose, directions=dirs, detected=joined["detected"],
                    depth=joined["depth"], amplitude=joined["amplitude"],
                    points_sensor=joined["point"].reshape(-1, 3), echo_table=table, echoes=echoes,
                    sample_rate=band.sample_rate, start_time=band.start_time,
                    carrier=band.carrier)

    def _shared_samples(self, pose: Pose, directions: np.ndarray, seed: int):
        """Noiseless recordings of pings towards unit ``directions`` (B, 3) from ``pose`` with
        shared hits (:meth:`scan`), ``TRACE_BATCH`` beams at a time: an iterator of
        (TRACE_BATCH, N_rx, n_samples) arrays, the echoes and the direct paths of each."""
        tracer = self.tracer
        patches = tracer.trace_union(pose, directions, beam_seed(seed, 0, HITS_STREAM))
        delays = self.config.geometry.steering_delays(directions, tracer.c)[:, None, :]
        return self.synthesizer.driven_samples(
            [tracer.patch_paths(patches, pose), tracer.direct_paths()], [self.config.pulse],
            delays, TRACE_BATCH)


#: Seed stream of the hits that beams share (an OFDM cycle's, a scan's), apart from the per-beam
#: trace seeds.
HITS_STREAM = 1_000_033


def beam_seed(seed: int, beam: int, *streams: int) -> int:
    """Independent, reproducible seed of beam ``beam`` within a scan or frame seeded with
    ``seed`` (or of one of its ``streams``: e.g. a cycle's hits or noise, named by its first
    beam)."""
    return int(np.random.SeedSequence([seed, *map(int, (beam, *streams))]).generate_state(1)[0])
