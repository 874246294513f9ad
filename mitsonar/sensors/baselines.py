"""Baseline sensors of the paper's comparison (Fig. 7): a VLP-16 class LiDAR and a Kinect v2 class
depth camera, ray traced by Mitsuba on the same loaded scene and from the same robot poses as the
sonar, both at the sensor mount (``frames.SENSOR_MOUNT_TRANSLATION``, 0.1 m ahead of and 0.5 m
above the chassis centre, as in the paper's section IV).

Both see the first *optically opaque* surface along each ray: rays step through surfaces whose
optical BSDF transmits light (glass; :func:`mitsonar.scene.loading.optically_transparent`), up to
``max_crossings`` of them, as real LiDARs and time-of-flight cameras largely do with clear glass.
Simplifications: glass returns nothing at all (real sensors get occasional specular returns at
normal incidence); a frame is taken at one instant (no motion during the 0.1 s LiDAR revolution);
one ray per beam or pixel (no beam divergence, mixed pixels, multipath or intensity dropouts).

Noise is Gaussian, drawn from ``numpy.random.default_rng(seed)``: the same seed gives the same
frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mitsonar.frames import SENSOR_MOUNT_TRANSLATION, Pose
from mitsonar.scene.loading import AcousticScene, load_scene, optically_transparent
from mitsonar.validation import check_finite, check_positive, check_range


@dataclass(frozen=True)
class SensorFrame:
    """One frame of a baseline sensor.

    Attributes:
        image: LiDAR: (channels, columns) range along each beam [m]; depth camera: (H, W) z-depth
            [m]. NaN where there is no valid return.
        image_index: (N,) flat index into ``image`` of every valid return.
        points_sensor: (N, 3) the valid returns in the sensor frame [m].
        shape_index: (N,) shape each return lies on (into ``AcousticScene.shape_ids``).
        world_from_sensor: the pose the frame was taken from.
    """

    image: np.ndarray
    image_index: np.ndarray
    points_sensor: np.ndarray
    shape_index: np.ndarray
    world_from_sensor: Pose

    @property
    def points_world(self) -> np.ndarray:
        """(N, 3) the valid returns in the world frame [m]."""
        return self.world_from_sensor.transform_points(self.points_sensor)


class _OpaqueCaster:
    """First hit of rays on an optically opaque surface, stepping through transparent ones."""

    #: Step past a transparent surface before the ray continues [m].
    STEP = 1e-4

    def __init__(self, scene: AcousticScene, max_crossings: int):
        self.scene = scene
        self.max_crossings = max_crossings
        self._transparent = np.array([optically_transparent(s.bsdf())
                                      for s in scene.scene.shapes()], dtype=bool)

    def cast(self, origin, directions):
        """Distance t (N,) [m] (inf: no opaque hit), geometric normal (N, 3) and shape index
        (N,) (-1: none) of rays from ``origin`` ((3,), or (N, 3): one per ray) along unit
        ``directions`` (N, 3), world frame; a :meth:`SceneHits.first
        <mitsonar.scene.hits.SceneHits.first>` per layer.
        """
        d = np.asarray(directions, dtype=float)
        origin = np.broadcast_to(np.asarray(origin, dtype=float), d.shape)
        o = origin.copy()
        t = np.full(len(d), np.inf)
        normal = np.zeros_like(d)
        shape = np.full(len(d), -1)
        active = np.arange(len(d))
        for _ in range(self.max_crossings + 1):  # one vectorised intersection per layer
            _, p, n, index = self.scene.hits.first(o[active], d[active])
            through = (index >= 0) & self._transparent[index]
            hit = (index >= 0) & ~through
            rows = active[hit]
            t[rows] = np.einsum("ij,ij->i", p[hit] - origin[rows], d[rows])
            normal[rows] = n[hit]
            shape[rows] = index[hit]
            active = active[through]
            o[active] = p[through] + self.STEP * d[active]
            if len(active) == 0:
                break
        return t, normal, shape


def _as_scene(scene) -> AcousticScene:
    return scene if isinstance(scene, AcousticScene) else load_scene(scene)


def _robot_pose(robot_pose) -> Pose:
    """World-from-robot pose from a :class:`Pose` or (x [m], y [m], yaw [rad])."""
    if isinstance(robot_pose, Pose):
        return robot_pose
    p = np.asarray(robot_pose, dtype=float)
    if p.shape != (3,):
        raise ValueError(f"robot pose must be a Pose or (x, y, yaw), got shape {p.shape}")
    return Pose.planar(*p)


def _check_count(name: str, value, minimum: int = 1) -> None:
    if int(value) != value or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value}")


@dataclass(frozen=True)
class LidarModel:
    """Velodyne VLP-16 class spinning LiDAR (Velodyne VLP-16 User Manual rev. D and datasheet
    63-9229: 16 channels over -15..+15 deg, 360 deg at 0.1-0.4 deg (5-20 Hz), 100 m range,
    range accuracy +-3 cm typical).

    Attributes:
        channels: number of lasers, spread evenly over the elevation range (16: 2 deg apart).
        elevation_min, elevation_max: lowest and highest beam elevation [rad] (-15, +15 deg).
        azimuth_step: horizontal resolution [rad] (0.2 deg: the VLP-16 at 10 Hz).
        rate: revolutions per second [Hz] (10: the VLP-16's default 600 rpm); the columns of a
            revolution are fired one after another, evenly over its 1 / rate.
        min_range: returns closer than this are dropped [m] (0.4 m: the ROS velodyne driver's
            VLP-16 default, ``velodyne_pointcloud/launch/VLP16_points.launch``).
        max_range: datasheet range [m].
        range_sigma: standard deviation of the Gaussian range noise [m]. The datasheet's
            "+-3 cm typical" is read as a two-sigma (95 %) bound: 1.5 cm. (The Gazebo model
            ``velodyne_simulator`` defaults to 0.008 m.)
        max_crossings: transparent surfaces a beam may pass before it counts as lost.
    """

    channels: int = 16
    elevation_min: float = np.radians(-15.0)
    elevation_max: float = np.radians(15.0)
    azimuth_step: float = np.radians(0.2)
    rate: float = 10.0
    min_range: float = 0.4
    max_range: float = 100.0
    range_sigma: float = 0.015
    max_crossings: int = 4

    def __post_init__(self):
        _check_count("LidarModel.channels", self.channels)
        check_range("LidarModel.elevation_min [rad]", self.elevation_min, -np.pi / 2, np.pi / 2)
        check_range("LidarModel.elevation_max [rad]", self.elevation_max, self.elevation_min,
                    np.pi / 2)
        check_range("LidarModel.azimuth_step [rad]", self.azimuth_step, 1e-6, 2 * np.pi)
        check_positive("LidarModel.rate [Hz]", self.rate)
        check_range("LidarModel.min_range [m]", self.min_range, 0.0, np.inf)
        check_range("LidarModel.max_range [m]", self.max_range, self.min_range, np.inf)
        check_range("LidarModel.range_sigma [m]", self.range_sigma, 0.0, np.inf)
        _check_count("LidarModel.max_crossings", self.max_crossings, minimum=0)

    def elevations(self) -> np.ndarray:
        """(channels,) beam elevations [rad], lowest first."""
        return np.linspace(self.elevation_min, self.elevation_max, self.channels)

    def azimuths(self) -> np.ndarray:
        """(columns,) azimuths [rad] from +x (forward) towards +y (left), starting at 0."""
        return np.arange(int(np.round(2 * np.pi / self.azimuth_step))) * self.azimuth_step

    def directions(self) -> np.ndarray:
        """(channels, columns, 3) unit beam directions in the LiDAR frame (x fwd, y left, z up)."""
        el = self.elevations()[:, None]
        az = self.azimuths()[None, :]
        return np.stack(np.broadcast_arrays(np.cos(el) * np.cos(az), np.cos(el) * np.sin(az),
                                            np.sin(el)), axis=-1)


@dataclass(frozen=True)
class DepthCameraModel:
    """Kinect v2 class time-of-flight depth camera: 512 x 424 pixels, 70.6 x 60 deg field of
    view, 0.5-4.5 m depth range (Microsoft's Kinect for Windows v2 specification).

    Pinhole with focal lengths from the fields of view (361 and 367 pixels; calibrated Kinect v2
    units are near 365). Axial (depth) noise after Fankhauser et al., "Kinect v2 for Mobile Robot
    Navigation: Evaluation and Modeling", ICAR 2015, fitted indoors:

        sigma_z(z, theta) = 1.5 - 0.5 z + 0.3 z^2 + 0.1 z^(3/2) theta^2 / (pi/2 - theta)^2  [mm]

    with z the depth [m] and theta the angle between the ray and the surface normal [rad]. The
    paper itself could not be consulted here: formula and coefficients are as reproduced
    identically by two independent open implementations of that model (a Kinect v2 denoising
    filter and a depth-noise augmentation, both citing the paper). ``noise`` holds them in SI.
    Lateral noise is not modelled (the same sources disagree on its unit, pixels or mm).

    Attributes:
        width, height: image size [pixels].
        horizontal_fov, vertical_fov: full fields of view [rad].
        min_depth, max_depth: z-depths outside this range [m] give no return.
        rate: frames per second [Hz] (30: the Kinect v2's depth stream); each frame is taken at
            one instant.
        noise: (a0 [m], a1 [-], a2 [1/m], a3 [1/m^0.5]): sigma_z = a0 + a1 z + a2 z^2
            + a3 z^1.5 theta^2 / (pi/2 - theta)^2 [m].
        max_noise_angle: theta is clipped to this [rad] in sigma_z, which diverges at 90 deg
            (80 deg: sigma_z = 3.6 cm at 3 m).
        max_crossings: transparent surfaces a ray may pass before it counts as lost.
    """

    width: int = 512
    height: int = 424
    horizontal_fov: float = np.radians(70.6)
    vertical_fov: float = np.radians(60.0)
    min_depth: float = 0.5
    max_depth: float = 4.5
    rate: float = 30.0
    noise: tuple = (1.5e-3, -0.5e-3, 0.3e-3, 0.1e-3)
    max_noise_angle: float = np.radians(80.0)
    max_crossings: int = 4

    def __post_init__(self):
        _check_count("DepthCameraModel.width", self.width)
        _check_count("DepthCameraModel.height", self.height)
        check_range("DepthCameraModel.horizontal_fov [rad]", self.horizontal_fov, 1e-6, np.pi - 1e-6)
        check_range("DepthCameraModel.vertical_fov [rad]", self.vertical_fov, 1e-6, np.pi - 1e-6)
        check_positive("DepthCameraModel.min_depth [m]", self.min_depth)
        check_range("DepthCameraModel.max_depth [m]", self.max_depth, self.min_depth, np.inf)
        check_positive("DepthCameraModel.rate [Hz]", self.rate)
        check_finite("DepthCameraModel.noise", self.noise)
        if len(self.noise) != 4:
            raise ValueError(f"DepthCameraModel.noise needs 4 coefficients, got {self.noise}")
        check_range("DepthCameraModel.max_noise_angle [rad]", self.max_noise_angle, 0.0,
                    np.pi / 2 - 1e-3)
        _check_count("DepthCameraModel.max_crossings", self.max_crossings, minimum=0)

    def axial_sigma(self, depth, incidence) -> np.ndarray:
        """Depth noise standard deviation [m] at z-depth [m] and incidence angle [rad]."""
        z = np.asarray(depth, dtype=float)
        theta = np.minimum(np.abs(np.asarray(incidence, dtype=float)), self.max_noise_angle)
        a0, a1, a2, a3 = self.noise
        return a0 + a1 * z + a2 * z**2 + a3 * z**1.5 * theta**2 / (np.pi / 2 - theta) ** 2

    def pixel_rays(self) -> np.ndarray:
        """(H, W, 3) unit directions through the pixel centres, sensor frame (x right, y down,
        z forward)."""
        fx = self.width / 2 / np.tan(self.horizontal_fov / 2)
        fy = self.height / 2 / np.tan(self.vertical_fov / 2)
        u = (np.arange(self.width) + 0.5 - self.width / 2) / fx
        v = (np.arange(self.height) + 0.5 - self.height / 2) / fy
        uu, vv = np.meshgrid(u, v)
        d = np.stack([uu, vv, np.ones_like(uu)], axis=-1)
        return d / np.linalg.norm(d, axis=-1, keepdims=True)


class Lidar:
    """A :class:`LidarModel` at the sensor mount, level with the chassis, in a loaded scene."""

    def __init__(self, scene, model: LidarModel = LidarModel()):
        self.scene = _as_scene(scene)
        self.model = model
        self._caster = _OpaqueCaster(self.scene, model.max_crossings)
        self._dirs = model.directions()

    @staticmethod
    def mount() -> Pose:
        """Robot-from-LiDAR pose: the LiDAR frame is the robot's (x fwd, y left, z up) at the mount."""
        return Pose(np.eye(3), SENSOR_MOUNT_TRANSLATION)

    def _returns(self, origins, world_directions, seed):
        """Measured ranges (N,) [m] (NaN: no return) and shape index (N,) of the beams from
        ``origins`` (N, 3) or (3,) along ``world_directions`` (N, 3)."""
        m = self.model
        t, _, shape = self._caster.cast(origins, world_directions)
        rng = np.random.default_rng(seed)
        measured = t + m.range_sigma * rng.standard_normal(len(t))
        ok = np.isfinite(t) & (measured >= m.min_range) & (measured <= m.max_range)
        return np.where(ok, measured, np.nan), shape

    def measure(self, robot_pose, seed=0) -> SensorFrame:
        """One revolution from a robot standing at ``robot_pose`` (world-from-robot
        :class:`Pose` or (x, y, yaw)); ``seed`` (int or ``SeedSequence``) drives the range
        noise."""
        pose = _robot_pose(robot_pose) @ self.mount()
        d = self._dirs.reshape(-1, 3)
        measured, shape = self._returns(pose.translation, pose.transform_vectors(d), seed)
        index = np.flatnonzero(np.isfinite(measured))
        return SensorFrame(measured.reshape(self._dirs.shape[:2]), index,
                           d[index] * measured[index, None], shape[index], pose)

    def measure_moving(self, trajectory, start: float, seed=0) -> np.ndarray:
        """World points (N, 3) [m] of the revolution that starts at ``start`` [s] on a robot
        driving ``trajectory`` (a :class:`~mitsonar.sensors.trajectory.Trajectory`): each column
        fired at its own time, from the robot's pose then, and placed with that pose."""
        m = self.model
        columns = self._dirs.shape[1]
        x, y, yaw = trajectory.poses_at(start + np.arange(columns) / (columns * m.rate)).T
        c, s = np.cos(yaw), np.sin(yaw)
        mount = self.mount().translation
        origin = np.stack([x + c * mount[0] - s * mount[1], y + s * mount[0] + c * mount[1],
                           np.full(columns, mount[2])], axis=-1)
        d = self._dirs  # (channels, columns, 3), turned by each column's yaw
        world = np.stack([c * d[..., 0] - s * d[..., 1], s * d[..., 0] + c * d[..., 1],
                          d[..., 2]], axis=-1).reshape(-1, 3)
        origins = np.broadcast_to(origin, d.shape).reshape(-1, 3)
        measured, _ = self._returns(origins, world, seed)
        ok = np.isfinite(measured)
        return origins[ok] + world[ok] * measured[ok, None]


class DepthCamera:
    """A :class:`DepthCameraModel` at the sensor mount, looking forward, in a loaded scene."""

    def __init__(self, scene, model: DepthCameraModel = DepthCameraModel()):
        self.scene = _as_scene(scene)
        self.model = model
        self._caster = _OpaqueCaster(self.scene, model.max_crossings)
        self._rays = model.pixel_rays().reshape(-1, 3)

    @staticmethod
    def mount() -> Pose:
        """Robot-from-camera pose: the sensor head's (x right, y down, z forward)."""
        return Pose.sensor_mount()

    def measure(self, robot_pose, seed=0) -> SensorFrame:
        """One depth image from a robot at ``robot_pose`` (world-from-robot :class:`Pose` or
        (x, y, yaw)); ``seed`` (int or ``SeedSequence``) drives the depth noise."""
        m = self.model
        pose = _robot_pose(robot_pose) @ self.mount()
        d_world = pose.transform_vectors(self._rays)
        t, normal, shape = self._caster.cast(pose.translation, d_world)
        hit = np.isfinite(t)
        depth = np.where(hit, t, 0.0) * self._rays[:, 2]
        incidence = np.arccos(np.clip(np.abs(np.einsum("ij,ij->i", normal, d_world)), 0.0, 1.0))
        rng = np.random.default_rng(seed)
        measured = depth + m.axial_sigma(depth, incidence) * rng.standard_normal(len(depth))
        ok = hit & (measured >= m.min_depth) & (measured <= m.max_depth)
        image = np.where(ok, measured, np.nan).reshape(m.height, m.width)
        index = np.flatnonzero(ok)
        points = self._rays[index] * (measured[index] / self._rays[index, 2])[:, None]
        return SensorFrame(image, index, points, shape[index], pose)

    def measure_moving(self, trajectory, start: float, seed=0) -> np.ndarray:
        """World points (N, 3) [m] of the frame taken at ``start`` [s] on a robot driving
        ``trajectory``, placed with the pose it was taken from (one instant)."""
        return self.measure(trajectory.poses_at([start])[0], seed=seed).points_world


def sweep(sensor, trajectory, duration: float | None = None, seed: int = 0):
    """A :class:`Lidar` or :class:`DepthCamera` driven along ``trajectory`` at its own rate
    (``sensor.model.rate``) for its first ``duration`` [s] (None: all of it): yields, frame by
    frame, (start time [s], world points (N, 3) [m]) with every beam placed by the pose it was
    fired from (no odometry drift). Frame k's noise uses ``SeedSequence([seed, k])``; frames
    are yielded one at a time, so a consumer can thin the points as they come (a Kinect v2
    along a two-minute trajectory returns some 10^9)."""
    for k, start in enumerate(trajectory.times_at_rate(sensor.model.rate, duration)):
        yield float(start), sensor.measure_moving(trajectory, float(start),
                                                  seed=np.random.SeedSequence([seed, k]))


def map_trajectory(sensor, robot_poses, odometry_poses=None, seed: int = 0):
    """World point cloud of a :class:`Lidar` or :class:`DepthCamera` along a trajectory.

    Every frame is measured at its ground-truth robot pose and placed in the world by the
    matching odometry pose (default: the ground truth), as a map built from wheel odometry is;
    per-frame odometry errors then show as steps between frames.

    Args:
        robot_poses: (T, 3) ground-truth x [m], y [m], yaw [rad] of the chassis.
        odometry_poses: (T, 3) the poses the frames are placed with, or None.
        seed: frame k uses ``SeedSequence([seed, k])``.

    Returns:
        points (N, 3) [m], world frame, and frame (N,) index of each point's frame.
    """
    truth = np.asarray(robot_poses, dtype=float)
    placed = truth if odometry_poses is None else np.asarray(odometry_poses, dtype=float)
    for name, p in (("robot_poses", truth), ("odometry_poses", placed)):
        if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] != len(truth):
            raise ValueError(f"{name} must be (T, 3) [x, y, yaw] with T = {len(truth)}, "
                             f"got shape {p.shape}")
        check_finite(f"{name} [m, m, rad]", p)
    clouds, frames = [], []
    for k, (true_pose, odo) in enumerate(zip(truth, placed)):  # frames, not rays
        frame = sensor.measure(true_pose, seed=np.random.SeedSequence([seed, k]))
        placement = Pose.planar(*odo) @ sensor.mount()
        clouds.append(placement.transform_points(frame.points_sensor))
        frames.append(np.full(len(frame.points_sensor), k))
    if not clouds:
        return np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
    return np.concatenate(clouds), np.concatenate(frames)
