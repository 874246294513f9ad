"""Coordinate frames, poses and beam directions. Every transform of mitsonar is written here once.

Frames (all right-handed, metres):

* world: z up (Mitsuba scene coordinates).
* robot: x forward, y left, z up; origin at the chassis centre on the floor.
* sensor: the transmit array's origin; x right, y down, z forward (the array lies in the XY plane
  and looks along +z, like a camera's optical frame). Mounted forward, sensor +z = robot +x,
  sensor +x = robot -y, sensor +y = robot -z.

Beam directions in the sensor frame: theta is the angle from +z (elevation in the paper's
wording, 0..90 deg), phi the azimuth in the XY plane from +x towards +y (0..360 deg), so
u = (sin theta cos phi, sin theta sin phi, cos theta). The field of view is a rectangle of
horizontal angle atan2(u_x, u_z) and vertical angle atan2(u_y, u_z).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mitsonar.validation import check_finite

#: Sensor mount on the robot (Scout Mini class): (0.1, 0, 0.5) m from the chassis centre.
SENSOR_MOUNT_TRANSLATION = np.array([0.1, 0.0, 0.5])
#: Columns are the sensor axes expressed in the robot frame.
SENSOR_MOUNT_ROTATION = np.array([[0.0, 0.0, 1.0],
                                  [-1.0, 0.0, 0.0],
                                  [0.0, -1.0, 0.0]])


@dataclass(frozen=True)
class Pose:
    """Rigid transform ``target_from_source``: p_target = R p_source + t (equation (12)).

    Attributes:
        rotation: (3, 3) rotation matrix.
        translation: (3,) translation [m].
    """

    rotation: np.ndarray
    translation: np.ndarray

    def __post_init__(self):
        r = np.asarray(self.rotation, dtype=float)
        t = np.asarray(self.translation, dtype=float)
        if r.shape != (3, 3) or t.shape != (3,):
            raise ValueError(f"Pose needs a (3, 3) rotation and a (3,) translation, got "
                             f"{r.shape} and {t.shape}")
        check_finite("Pose.rotation", r)
        check_finite("Pose.translation [m]", t)
        if not np.allclose(r @ r.T, np.eye(3), atol=1e-6) or np.linalg.det(r) < 0:
            raise ValueError(f"Pose.rotation is not a proper rotation matrix:\n{r}")
        object.__setattr__(self, "rotation", r)
        object.__setattr__(self, "translation", t)

    @classmethod
    def identity(cls) -> "Pose":
        return cls(np.eye(3), np.zeros(3))

    @classmethod
    def planar(cls, x: float, y: float, yaw: float, z: float = 0.0) -> "Pose":
        """World-from-robot pose of a robot on the floor at (x, y, z) [m] heading ``yaw`` [rad]."""
        check_finite("robot pose (x, y, yaw, z)", [x, y, yaw, z])
        c, s = np.cos(yaw), np.sin(yaw)
        return cls(np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]), np.array([x, y, z]))

    @classmethod
    def sensor_mount(cls) -> "Pose":
        """Robot-from-sensor pose of the forward-looking sensor head."""
        return cls(SENSOR_MOUNT_ROTATION, SENSOR_MOUNT_TRANSLATION)

    @classmethod
    def sensor_on_robot(cls, x: float, y: float, yaw: float) -> "Pose":
        """World-from-sensor pose of the sensor head on a robot at (x, y) [m], heading yaw [rad]."""
        return cls.planar(x, y, yaw) @ cls.sensor_mount()

    def __matmul__(self, other: "Pose") -> "Pose":
        """Composition: (A @ B) maps B's source frame into A's target frame."""
        return Pose(self.rotation @ other.rotation, self.rotation @ other.translation + self.translation)

    def inverse(self) -> "Pose":
        return Pose(self.rotation.T, -self.rotation.T @ self.translation)

    def transform_points(self, points) -> np.ndarray:
        """Apply to points (..., 3) [m]."""
        return np.asarray(points, dtype=float) @ self.rotation.T + self.translation

    def transform_vectors(self, vectors) -> np.ndarray:
        """Apply the rotation only to direction vectors (..., 3)."""
        return np.asarray(vectors, dtype=float) @ self.rotation.T

    def matrix(self) -> np.ndarray:
        """4x4 homogeneous matrix."""
        m = np.eye(4)
        m[:3, :3] = self.rotation
        m[:3, 3] = self.translation
        return m


def direction_from_angles(theta, phi) -> np.ndarray:
    """Unit vectors (..., 3) in the sensor frame from theta (from +z) and azimuth phi [rad]."""
    theta = np.asarray(theta, dtype=float)
    phi = np.asarray(phi, dtype=float)
    check_finite("beam direction (theta, phi) [rad]", np.stack(np.broadcast_arrays(theta, phi)))
    st = np.sin(theta)
    return np.stack([st * np.cos(phi), st * np.sin(phi), np.cos(theta)], axis=-1)


def angles_from_direction(u) -> tuple[np.ndarray, np.ndarray]:
    """(theta, phi) [rad] of unit vectors (..., 3); phi in [0, 2 pi) as in the paper's (11)."""
    u = np.asarray(u, dtype=float)
    theta = np.arccos(np.clip(u[..., 2], -1.0, 1.0))
    phi = np.mod(np.arctan2(u[..., 1], u[..., 0]), 2 * np.pi)
    return theta, phi


def direction_from_fov_angles(horizontal, vertical) -> np.ndarray:
    """Unit vectors (..., 3) with horizontal angle atan2(u_x, u_z) and vertical atan2(u_y, u_z) [rad]."""
    h = np.asarray(horizontal, dtype=float)
    v = np.asarray(vertical, dtype=float)
    check_finite("field-of-view angles [rad]", np.stack(np.broadcast_arrays(h, v)))
    if np.any(np.abs(h) >= np.pi / 2) or np.any(np.abs(v) >= np.pi / 2):
        raise ValueError("field-of-view angles must lie strictly within (-90, 90) degrees")
    u = np.stack(np.broadcast_arrays(np.tan(h), np.tan(v), np.ones_like(h + v)), axis=-1)
    return u / np.linalg.norm(u, axis=-1, keepdims=True)


def fov_angles(u) -> tuple[np.ndarray, np.ndarray]:
    """Horizontal and vertical field-of-view angles [rad] of directions (..., 3)."""
    u = np.asarray(u, dtype=float)
    return np.arctan2(u[..., 0], u[..., 2]), np.arctan2(u[..., 1], u[..., 2])


def orthonormal_basis(u) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors (3,) completing unit vector ``u`` (3,) to a right-handed basis (e1, e2, u)."""
    u = np.asarray(u, dtype=float)
    helper = np.array([0.0, 1.0, 0.0]) if abs(u[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(helper, u)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(u, e1)
