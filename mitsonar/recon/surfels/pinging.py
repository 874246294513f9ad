"""Who fires a pose's pings and when: :class:`StillPinger` fires them all from the pose the image
was taken from (the robot stands while its surfels are pinged), :class:`MovingPinger` one after
another, a listening time apart, from wherever the driving robot is when each leaves.

Both take beams aimed in the sensor frame of the image's pose and return what they measured in
that frame, so the surfel pipeline does not need to know which fired them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mitsonar.frames import Pose
from mitsonar.physics.beampattern import in_fov
from mitsonar.sensors.sonar import Sonar
from mitsonar.sensors.trajectory import Trajectory


@dataclass
class StillPinger:
    """Every beam fired from ``pose`` (world-from-sensor, the image's).

    Attributes:
        sonar: the sonar that fires.
        pose: where the image was taken and every beam is fired from.
        pings: beams fired so far.
    """

    sonar: Sonar
    pose: Pose
    pings: int = 0

    def fire(self, directions, seed: int, targets=None) -> np.ndarray:
        """Measured points (n, 3) [m], sensor frame of ``pose``, NaN where no echo, of beams
        along ``directions`` (n, 3) (``targets``: ignored, the beams leave from ``pose``)."""
        directions = np.asarray(directions, dtype=float).reshape(-1, 3)
        if not len(directions):
            return np.zeros((0, 3))
        self.pings += len(directions)
        return self.sonar.scan(self.pose, directions, seed=seed).points_sensor


@dataclass
class MovingPinger:
    """Beams fired one after another by a sonar on a robot driving a trajectory, each
    ``period`` after the last (the listening time: a ping's echoes must have come back before
    the next leaves), each from the robot's pose when it leaves and its echo placed with that
    pose (no odometry drift).

    A beam with a target point is aimed at it from where it leaves; one without (the four scan
    pings of a surfel, aimed through pixels) keeps its direction in the world: the robot's turn
    since the image is compensated, its drive (0.2 m/s x 30 ms = 6 mm a ping) is not. A beam the
    turn has carried outside the field of view is not fired and takes no time.

    Attributes:
        sonar: the sonar that fires.
        trajectory: what the robot drives.
        image_time: when the image the beams were aimed in was taken [s]; ``pose`` is the sensor
            pose then (world-from-sensor).
        time: when the next beam leaves [s].
        period: time between two beams [s] (default: the sonar's recording length,
            ``SonarConfig.record_duration``).
        pings: beams fired so far.
    """

    sonar: Sonar
    trajectory: Trajectory
    image_time: float
    time: float
    period: float | None = None
    pings: int = 0

    def __post_init__(self):
        if self.period is None:
            self.period = self.sonar.config.record_duration
        self.pose = self._sensor_pose(self.image_time)

    def _sensor_pose(self, t: float) -> Pose:
        x, y, yaw = self.trajectory.poses_at([t])[0]
        return Pose.sensor_on_robot(x, y, yaw)

    def fire(self, directions, seed: int, targets=None) -> np.ndarray:
        """Measured points (n, 3) [m], sensor frame of the image's pose, NaN where no echo (or
        not fired), of beams along ``directions`` (n, 3) in that frame, or towards ``targets``
        (n, 3) [m] in that frame where given and finite."""
        directions = np.asarray(directions, dtype=float).reshape(-1, 3)
        aim = np.full(directions.shape, np.nan) if targets is None else \
            np.asarray(targets, dtype=float).reshape(-1, 3)
        out = np.full(directions.shape, np.nan)
        geometry = self.sonar.config.geometry
        for k, (d, target) in enumerate(zip(directions, aim)):  # pings follow each other
            pose = self._sensor_pose(self.time)
            if np.all(np.isfinite(target)):
                local = pose.inverse().transform_points(self.pose.transform_points(target))
            else:
                local = pose.inverse().transform_vectors(self.pose.transform_vectors(d))
            local = local / np.linalg.norm(local)
            if not in_fov(local[None], geometry.fov_horizontal, geometry.fov_vertical)[0]:
                continue
            scan = self.sonar.scan(pose, local[None], seed=int(
                np.random.SeedSequence([seed, k]).generate_state(1)[0]))
            out[k] = self.pose.inverse().transform_points(
                pose.transform_points(scan.points_sensor))[0]
            self.time += self.period
            self.pings += 1
        return out
