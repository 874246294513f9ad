"""Frames and poses: round trips and the mounting convention."""

import numpy as np
import pytest

from mitsonar import Pose
from mitsonar.frames import (angles_from_direction, direction_from_angles, direction_from_fov_angles,
                             fov_angles)


def test_pose_round_trips():
    rng = np.random.default_rng(3)
    pose = Pose.planar(1.5, -2.0, 0.7) @ Pose.sensor_mount()
    pts = rng.normal(size=(50, 3))
    np.testing.assert_allclose(pose.inverse().transform_points(pose.transform_points(pts)), pts,
                               atol=1e-12)
    np.testing.assert_allclose((pose @ pose.inverse()).matrix(), np.eye(4), atol=1e-12)


def test_sensor_mount_convention():
    sensor = Pose.sensor_on_robot(0.0, 0.0, 0.0)
    np.testing.assert_allclose(sensor.translation, [0.1, 0.0, 0.5])
    forward, right, down = sensor.transform_vectors(np.eye(3)[[2, 0, 1]])
    np.testing.assert_allclose(forward, [1, 0, 0], atol=1e-12)  # sensor +z = robot +x
    np.testing.assert_allclose(right, [0, -1, 0], atol=1e-12)  # sensor +x = robot -y
    np.testing.assert_allclose(down, [0, 0, -1], atol=1e-12)  # sensor +y = robot -z
    turned = Pose.sensor_on_robot(2.0, 1.0, np.pi / 2)
    np.testing.assert_allclose(turned.transform_points([0, 0, 1.0]), [2.0, 2.1, 0.5], atol=1e-12)


def test_direction_round_trips():
    theta = np.radians([0.5, 10, 25, 40])
    phi = np.radians([0, 90, 200, 359])
    t2, p2 = angles_from_direction(direction_from_angles(theta, phi))
    np.testing.assert_allclose(t2, theta, atol=1e-12)
    np.testing.assert_allclose(p2, phi, atol=1e-12)
    h, v = np.radians([-30, 0, 12]), np.radians([20, -5, 0])
    h2, v2 = fov_angles(direction_from_fov_angles(h, v))
    np.testing.assert_allclose(h2, h, atol=1e-12)
    np.testing.assert_allclose(v2, v, atol=1e-12)


@pytest.mark.parametrize("bad", [(np.nan, 0, 0), (0, np.inf, 0), (0, 0, np.nan)])
def test_nan_pose_is_rejected(bad):
    with pytest.raises(ValueError, match="finite"):
        Pose.planar(*bad)


def test_non_rotation_is_rejected():
    with pytest.raises(ValueError, match="rotation"):
        Pose(np.diag([1.0, 1.0, -1.0]), np.zeros(3))
