"""Robot trajectories: waypoints and speeds sampled into timed poses, and odometry with drift.

A trajectory is a list of waypoints (x [m], y [m], yaw [rad]) of the chassis centre in the world
frame (Scout Mini class, driving on the floor). Between two waypoints the robot moves at
``speed`` and turns at ``yaw_rate``, whichever takes longer, with x, y and yaw varying linearly
in time (a waypoint pair at one position is a turn on the spot).

Odometry is the ground truth plus a seeded drift: every step's travelled distance and turned
angle get a relative Gaussian error, and the errors are integrated, so the drift grows with the
distance driven, as wheel odometry does.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mitsonar.frames import Pose
from mitsonar.scene.catalog import resolve_scene
from mitsonar.validation import check_finite, check_positive


@dataclass(frozen=True)
class Trajectory:
    """Waypoints and speeds.

    Attributes:
        waypoints: (K, 3) x [m], y [m], yaw [rad] (yaw unwrapped: 0 -> 2 pi is a full turn).
        speed: linear speed [m/s].
        yaw_rate: turning speed [rad/s].
    """

    waypoints: np.ndarray
    speed: float = 0.2
    yaw_rate: float = np.radians(30.0)

    def __post_init__(self):
        w = np.asarray(self.waypoints, dtype=float)
        if w.ndim != 2 or w.shape[1] != 3 or len(w) < 1:
            raise ValueError(f"trajectory waypoints must be (K, 3) [x, y, yaw], got shape {w.shape}")
        bad = ~np.all(np.isfinite(w), axis=1)
        if np.any(bad):
            raise ValueError(f"trajectory waypoint {int(np.argmax(bad))} is not finite: {w[bad][0]}")
        check_positive("Trajectory.speed [m/s]", self.speed)
        check_positive("Trajectory.yaw_rate [rad/s]", self.yaw_rate)
        object.__setattr__(self, "waypoints", w)

    @classmethod
    def from_scene(cls, scene_path) -> "Trajectory":
        """The default trajectory in the ``ground_truth.json`` beside a shipped scene (its path
        or name)."""
        return cls.from_file(resolve_scene(scene_path).with_name("ground_truth.json"))

    @classmethod
    def from_file(cls, path) -> "Trajectory":
        """A trajectory from JSON: {"waypoints": [[x_m, y_m, yaw_deg], ...], "speed_m_s": ...,
        "yaw_rate_deg_s": ...}, at the top level or under a "trajectory" key (as in the scenes'
        ``ground_truth.json``)."""
        path = Path(path)
        try:
            data = json.loads(path.read_text())
            data = data.get("trajectory", data)
            w = np.array(data["waypoints"], dtype=float)
            speed, yaw_rate = float(data["speed_m_s"]), np.radians(float(data["yaw_rate_deg_s"]))
        except (OSError, KeyError, TypeError, ValueError) as err:
            raise ValueError(f"{path}: no trajectory ({type(err).__name__}: {err})") from None
        if w.ndim != 2 or w.shape[1] != 3:
            raise ValueError(f"{path}: trajectory waypoints must be [[x_m, y_m, yaw_deg], ...], "
                             f"got shape {w.shape}")
        w[:, 2] = np.radians(w[:, 2])
        try:
            return cls(w, speed, yaw_rate)
        except ValueError as err:
            raise ValueError(f"{path}: {err}") from None

    def segment_times(self) -> np.ndarray:
        """(K,) time [s] at which each waypoint is reached."""
        d = np.diff(self.waypoints, axis=0)
        duration = np.maximum(np.hypot(d[:, 0], d[:, 1]) / self.speed, np.abs(d[:, 2]) / self.yaw_rate)
        return np.concatenate([[0.0], np.cumsum(duration)])

    @property
    def duration(self) -> float:
        """Total time [s]."""
        return float(self.segment_times()[-1])

    def poses_at(self, times) -> np.ndarray:
        """Ground-truth (x, y, yaw) at times [s], shape (T, 3); times are clipped to the ends."""
        t = np.asarray(times, dtype=float)
        check_finite("trajectory times [s]", t)
        knots = self.segment_times()
        return np.stack([np.interp(t, knots, self.waypoints[:, k]) for k in range(3)], axis=-1)

    def sample(self, period: float) -> tuple[np.ndarray, np.ndarray]:
        """Times (T,) every ``period`` [s] from start to end, and their poses (T, 3)."""
        check_positive("sampling period [s]", period)
        times = np.arange(0.0, self.duration + 1e-9, period)
        return times, self.poses_at(times)

    def driven(self, duration: float | None = None) -> float:
        """Time driven [s]: ``duration`` (the first part of the trajectory), checked to lie in
        (0, :attr:`duration`]; None: the whole trajectory."""
        if duration is None:
            return self.duration
        check_positive("driven duration [s]", duration)
        if duration > self.duration + 1e-9:
            raise ValueError(f"driven duration [s] must be at most the trajectory's "
                             f"{self.duration:.1f} s, got {duration}")
        return float(duration)

    def times_at_rate(self, rate: float, duration: float | None = None) -> np.ndarray:
        """Start times (n,) [s] of a sensor's frames at ``rate`` [Hz] while the robot drives the
        first ``duration`` [s] (None: the whole trajectory): k / rate for the n = floor(duration
        x rate) frames that start within it (at least one, at t = 0)."""
        check_positive("sensor rate [Hz]", rate)
        count = max(int(np.floor(self.driven(duration) * rate + 1e-9)), 1)
        return np.arange(count) / rate


@dataclass(frozen=True)
class OdometryDrift:
    """Relative errors of wheel odometry.

    Attributes:
        distance_std: standard deviation of the relative error of each step's distance.
        yaw_std: standard deviation of the relative error of each step's turn.
        yaw_per_metre_std: heading error per metre driven [rad/m] (wheel slip on straight runs).
    """

    distance_std: float = 0.01
    yaw_std: float = 0.02
    yaw_per_metre_std: float = np.radians(0.5)

    def apply(self, poses, seed: int) -> np.ndarray:
        """Odometry poses (T, 3) from ground-truth poses (T, 3): integrated noisy increments."""
        p = np.asarray(poses, dtype=float)
        rng = np.random.default_rng(seed)
        d = np.diff(p, axis=0)
        yaw0 = p[:-1, 2]
        forward = d[:, 0] * np.cos(yaw0) + d[:, 1] * np.sin(yaw0)  # body-frame increments
        lateral = -d[:, 0] * np.sin(yaw0) + d[:, 1] * np.cos(yaw0)
        dist = np.hypot(forward, lateral)
        n = len(d)
        turn = d[:, 2] * (1 + rng.normal(0, self.yaw_std, n)) \
            + dist * rng.normal(0, self.yaw_per_metre_std, n)
        scale = 1 + rng.normal(0, self.distance_std, n)
        yaw = p[0, 2] + np.concatenate([[0.0], np.cumsum(turn)])
        heading = yaw[:-1]
        dx = scale * (forward * np.cos(heading) - lateral * np.sin(heading))
        dy = scale * (forward * np.sin(heading) + lateral * np.cos(heading))
        x = p[0, 0] + np.concatenate([[0.0], np.cumsum(dx)])
        y = p[0, 1] + np.concatenate([[0.0], np.cumsum(dy)])
        return np.stack([x, y, yaw], axis=-1)


def sensor_poses(robot_poses) -> list[Pose]:
    """World-from-sensor poses of the sensor head for robot poses (T, 3)."""
    return [Pose.sensor_on_robot(x, y, yaw) for x, y, yaw in np.asarray(robot_poses, dtype=float)]
