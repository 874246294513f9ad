"""Repeated-scanning maps (paper III-E): OFDM frames along a trajectory -> points coloured by the
camera -> world frame by (12) -> outlier removal -> coloured voxel map (PLY + PNG).

Scans (``RepeatedMapSpec.scan``): "ofdm" (default), the paper's 117-beam OFDM frames back to
back; "imaging", single-ping receive images back to back (:class:`~mitsonar.sensors.
imaging_sonar.ImagingSonar`, one per listening cycle), grouped under one camera image every
``IMAGE_FRAME`` (docs/imaging.md: driven by a frequency sweep they give the most points per
second).

Registration. The beams of a 208.5 ms frame leave from poses up to v x 0.2 m apart (and up to
6 deg apart while the robot turns at 30 deg/s). ``registration="beam"`` (default) registers
each beam with its own pose at firing (motion compensation; it needs odometry at the cycle
rate, 43 Hz, which wheel odometry exceeds). The paper registers a whole frame with the
odometry pose q_i of its start (``registration="frame"``, also when its image is taken), so a
moving robot smears surfaces (the paper's Fig. 8b failure case; ``experiments/ofdm_motion.py``
measures it).

Echoes. Every echo each beam reports is a point (``echoes``, ``DetectionSettings.echoes``):
"first" (default) the strongest of each beam, one point per beam as the paper; "all" every echo
over the range profile, each at the arrival direction the receive array measures for it;
"cells" those and every range cell across extended echoes; "image" a point per range cell at the
peak of each beam's cone image (fewer than "cells"). ``experiments/imaging.py`` compares
them (docs/imaging.md): with the ``paper`` preset "all" and "cells" give ~2x the points at the
same accuracy; with broadband transducers on a rough wall the direction-trust test drops
speckle echoes that the first-echo path keeps (tests/recon/test_voxelmap.py), so the default
stays "first".

Off-beam echoes (``off_beam``, on by default with "first" and "all"): a beam whose every echo
fails the side-lobe check gets its strongest one where it arrives from, e.g. a smooth wall's
mirror echo seen a few degrees off its normal, which the physical sonar otherwise loses
(docs/incidence.md; :mod:`mitsonar.signal.offbeam`, which also rejects the other codes'
cross-talk of an OFDM cycle).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import partial

import numpy as np

from mitsonar.sensors.camera import CameraModel, CameraRenderer
from mitsonar.frames import Pose
from mitsonar.parallel import ordered_map
from mitsonar.physics.array import dither_offsets
from mitsonar.sensors.imaging_sonar import ImagingSonar, TransmitSettings
from mitsonar.sensors.ofdm_sonar import Frame, OfdmSonar, pose_along
from mitsonar.sensors.sonar import Sonar, beam_seed
from mitsonar.sensors.trajectory import Trajectory
from mitsonar.signal.detection import ECHO_MODES, OFF_BEAM_MODES, DetectionSettings
from mitsonar.signal.imaging_settings import ImagingSettings
from mitsonar.validation import check_image_width, check_positive, check_positive_integer
from mitsonar.recon.voxelmap import VoxelMap, VoxelMapSettings, colourise


REGISTRATIONS = ("frame", "beam")
SCANS = ("ofdm", "imaging")
#: Images of the "imaging" scan share one camera image per this much time [s] (5 Hz, about the
#: OFDM frames' rate): a repeated-mode frame of ``ceil(IMAGE_FRAME / cycle)`` images.
IMAGE_FRAME = 0.2


@dataclass(frozen=True)
class RepeatedMapSpec:
    """What to map.

    Attributes:
        frames: number of OFDM frames, fired from the trajectory's start; None: every frame
            that starts while the robot drives the first ``duration`` of the trajectory (the
            sensor's own rate: back to back, 4.8 frames/s at the paper's settings).
        duration: how long the robot drives [s] when ``frames`` is None; None: the whole
            trajectory.
        interval: time between the starts of consecutive frames [s]; None: back to back (the
            frame duration, 208.5 ms at the paper's settings). A longer interval keeps every
            n-th frame of a continuous run (frames spread along the trajectory; the ones in
            between are not simulated).
        scan_step: beam grid step over the field of view [rad] (5 deg: the paper's 13 x 9).
        dither: the beam grid is shifted from frame to frame through ``dither`` x ``dither``
            offsets of ``scan_step / dither`` (:func:`~mitsonar.physics.array.dither_offsets`),
            so that consecutive frames steer between each other's beams; 1: the paper's fixed
            grid. Steering is electronic: the sensor fires any grid at no cost. Each grid's
            direct-path references are computed once and kept (about 6 MB a grid with the
            ``paper`` preset).
        image_width: camera image width [pixels]; spp: camera samples per pixel.
        voxels: voxel size, outlier removal.
        registration: "beam" (each beam's pose at firing) or "frame" (one odometry pose per
            frame, as the paper).
        echoes: the echoes of each beam that become points (``DetectionSettings.echoes``:
            "first", "all", "cells" or "image"; module docstring); it replaces the sonar's own setting.
        off_beam: re-place echoes that the side-lobe check rejects where they arrive from
            (``DetectionSettings.off_beam``; module docstring); None: on where ``echoes`` and
            the sonar's side-lobe check and arrival directions allow it ("first", "all").
        shared_hits: trace each OFDM cycle's hits once over the union of its beams' cones,
            every beam with its transmit side lobes over that union (the default); False: each
            beam traced in its own 20 deg cone (``OfdmSonar``'s ``shared_hits``,
            docs/performance.md).
        seed: seeds every frame's noise and diffuse phases.
        scan: "ofdm" or "imaging" (module docstring); ``scan_step``, ``echoes``, ``off_beam``
            and ``shared_hits`` concern OFDM frames only, ``transmit`` and ``imaging`` images
            only.
        transmit: the images' wide transmission and its trace.
        imaging: the images' grid and points rule
            (:class:`~mitsonar.signal.imaging_settings.ImagingSettings`); None: the rule for
            the sonar's drive (:func:`~mitsonar.signal.imaging_settings.imaging_settings_for`:
            the trust rule read in sub-bands for a sweep over an octave, as 20-80 kHz).
    """

    frames: int | None = None
    duration: float | None = None
    interval: float | None = None
    scan_step: float = np.radians(5.0)
    dither: int = 1
    image_width: int = 320
    spp: int = 8
    voxels: VoxelMapSettings = VoxelMapSettings()
    registration: str = "beam"
    echoes: str = "first"
    off_beam: bool | None = None
    shared_hits: bool = True
    seed: int = 0
    scan: str = "ofdm"
    transmit: TransmitSettings = TransmitSettings()
    imaging: ImagingSettings | None = None

    def __post_init__(self):
        if self.frames is not None:
            check_positive_integer("RepeatedMapSpec.frames", self.frames)
        if self.duration is not None:
            check_positive("RepeatedMapSpec.duration [s]", self.duration)
        check_positive("RepeatedMapSpec.scan_step [rad]", self.scan_step)
        check_positive_integer("RepeatedMapSpec.dither", self.dither)
        check_image_width("RepeatedMapSpec.image_width", self.image_width)
        if self.interval is not None:
            check_positive("RepeatedMapSpec.interval [s]", self.interval)
        if self.scan not in SCANS:
            raise ValueError(f"RepeatedMapSpec.scan must be one of {SCANS}, got {self.scan!r}")
        if self.registration not in REGISTRATIONS:
            raise ValueError(f"RepeatedMapSpec.registration must be one of {REGISTRATIONS}, got "
                             f"{self.registration!r}")
        if self.echoes not in ECHO_MODES:
            raise ValueError(f"RepeatedMapSpec.echoes must be one of {', '.join(ECHO_MODES)}, "
                             f"got {self.echoes!r}")
        if self.off_beam and self.echoes not in OFF_BEAM_MODES:
            raise ValueError(f"RepeatedMapSpec.off_beam needs echoes in {OFF_BEAM_MODES}, got "
                             f"{self.echoes!r}")

    def detection(self, settings: DetectionSettings) -> DetectionSettings:
        """The sonar's detection ``settings`` with this map's ``echoes`` and ``off_beam``."""
        usable = self.echoes in OFF_BEAM_MODES and settings.ghost_margin > 0 \
            and settings.arrival_step > 0
        off_beam = usable if self.off_beam is None else self.off_beam
        return replace(settings, echoes=self.echoes, off_beam=off_beam)


@dataclass(frozen=True)
class ScannedFrame:
    """One OFDM frame, or the images of one camera period, and the camera image taken at its
    start.

    Attributes:
        points: (N, 3) every point in the sensor frame [m].
        world_from_sensor: (N, 4, 4) the pose each point was measured from.
        start_time: the frame's start on the trajectory's clock [s].
        image: (H, W, 3) linear RGB.
        pose: world-from-sensor pose of the head at the frame's start (odometry stamp, image).
        frame: the decoded OFDM frame (None for images).
        images: the single-ping images (empty for an OFDM frame).
        image_times: when each image was fired on the trajectory's clock [s].
        image_tables: each image's points as an echo table
            (:meth:`~mitsonar.sensors.imaging_sonar.ImagingSonar.echo_table`, for recordings).
    """

    points: np.ndarray
    world_from_sensor: np.ndarray
    start_time: float
    image: np.ndarray
    pose: Pose
    frame: Frame | None = None
    images: tuple = ()
    image_times: tuple = ()
    image_tables: tuple = ()


class _RepeatedFrames:
    """What fires the frames of :func:`scan_repeated` (its sonar, schedules, camera): frame k
    is a pure function of k, the spec and the scene (seeds ``spec.seed + k``)."""

    def __init__(self, sonar: Sonar, trajectory: Trajectory, spec: RepeatedMapSpec):
        self.spec = spec
        self.pose_at = pose_along(trajectory)
        if spec.scan == "ofdm":
            detection = spec.detection(sonar.config.detection)
            self.ofdm = OfdmSonar(Sonar(sonar.scene, replace(sonar.config, detection=detection)),
                                  shared_hits=spec.shared_hits)
            geometry = sonar.config.geometry
            schedule = self.ofdm.schedule(geometry.fov_grid(spec.scan_step))
            shifted = [geometry.fov_grid(spec.scan_step, offset)
                       for offset in dither_offsets(spec.scan_step, spec.dither)]
            # a shifted grid keeps its beams' firing order and codes (tuned to the grid's spacing)
            self.schedules = [replace(schedule, directions=d) for d in shifted]
            self.duration = schedule.frame_duration
        else:
            self.imaging = ImagingSonar(sonar, spec.imaging, spec.transmit)
            self.per_frame = int(np.ceil(IMAGE_FRAME / self.imaging.cycle_time - 1e-9))
            self.duration = self.per_frame * self.imaging.cycle_time
        self.interval = self.duration if spec.interval is None else spec.interval
        if self.interval < self.duration:
            raise ValueError(f"RepeatedMapSpec.interval [s] must be at least the frame duration "
                             f"({self.duration:.4f} s), got {spec.interval}")
        self.camera = CameraRenderer(sonar.scene,
                                     CameraModel(spp=spec.spp).at_resolution(spec.image_width))

    @classmethod
    def load(cls, scene_path, config, trajectory: Trajectory, spec: RepeatedMapSpec):
        """In a worker process: the sonar made anew from its scene file and configuration."""
        return cls(Sonar(scene_path, config), trajectory, spec)

    def frame(self, k: int) -> ScannedFrame:
        """Frame k, fired at k x ``interval`` on the trajectory's clock, and its camera image."""
        spec, pose_at = self.spec, self.pose_at
        start = k * self.interval
        pose = pose_at(start)
        image = self.camera.render(pose, seed=spec.seed + k).rgb
        if spec.scan == "ofdm":
            frame = self.ofdm.frame(self.schedules[k % len(self.schedules)], pose_at,
                                    start_time=start, seed=spec.seed + k)
            return ScannedFrame(frame.echo_table.point, frame.echo_world_from_sensor, start,
                                image, pose, frame=frame)
        cycle = self.imaging.cycle_time
        times = tuple(start + i * cycle for i in range(self.per_frame))
        images = tuple(self.imaging.image(pose_at(t), seed=beam_seed(spec.seed + k, i))
                       for i, t in enumerate(times))
        poses = [np.broadcast_to(im.pose.matrix(), (len(im), 4, 4)) for im in images]
        return ScannedFrame(np.concatenate([im.points_sensor for im in images]),
                            np.concatenate(poses), start, image, pose, images=images,
                            image_times=times,
                            image_tables=tuple(self.imaging.echo_table(im) for im in images))


def _frame(frames: _RepeatedFrames, k: int) -> ScannedFrame:
    return frames.frame(k)


def scan_repeated(sonar: Sonar, trajectory: Trajectory, spec: RepeatedMapSpec = RepeatedMapSpec(),
                  progress=None, workers: int = 1) -> tuple[list[ScannedFrame], CameraModel]:
    """Fire OFDM frames (or groups of images, ``spec.scan``) along the trajectory,
    ``spec.interval`` apart (default: back to back), with a camera image each: ``spec.frames``
    of them, or every frame that starts within the first ``spec.duration`` [s] (default: the
    whole trajectory). ``progress`` is called with (frame index, number of frames) after each.
    ``workers`` > 1: the frames are simulated by that many processes, each loading the scene
    from its file (:func:`~mitsonar.parallel.ordered_map`; the same frames)."""
    frames = _RepeatedFrames(sonar, trajectory, spec)
    count = spec.frames if spec.frames is not None else \
        max(int(np.floor(trajectory.driven(spec.duration) / frames.interval + 1e-9)), 1)
    workers = min(workers, count)
    make = (lambda: frames) if workers <= 1 else \
        partial(_RepeatedFrames.load, sonar.scene.path, sonar.config, trajectory, spec)
    scanned = []
    for k, scanned_frame in enumerate(ordered_map(make, _frame, range(count), workers)):
        scanned.append(scanned_frame)  # frames follow each other in time
        if progress is not None:
            progress(k, count)
    return scanned, frames.camera.model


def build_voxel_map(scanned, camera_model: CameraModel, spec: RepeatedMapSpec = RepeatedMapSpec()):
    """Colour, register (``spec.registration``) and voxelise every point of scanned frames ->
    VoxelCloud."""
    voxel_map = VoxelMap()
    for s in scanned:
        poses = s.world_from_sensor if spec.registration == "beam" else s.pose.matrix()
        voxel_map.add_frame(colourise(s.points, poses, s.image, camera_model, s.pose.matrix()))
    return voxel_map.voxelise(spec.voxels)


def map_repeated(sonar: Sonar, trajectory: Trajectory, spec: RepeatedMapSpec = RepeatedMapSpec(),
                 progress=None, workers: int = 1):
    """Build a coloured voxel map; returns (VoxelCloud, sensor positions (F, 3), scanned frames)
    (``workers``: :func:`scan_repeated`)."""
    scanned, camera_model = scan_repeated(sonar, trajectory, spec, progress, workers)
    positions = np.array([s.pose.translation for s in scanned])
    return build_voxel_map(scanned, camera_model, spec), positions, scanned
