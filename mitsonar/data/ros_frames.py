"""mitsonar's coordinate frames as a ROS frame tree (REP-103 axes, REP-105 names).

Tree: ``world -> odom -> base_link -> sonar -> camera``, with ``sonar_optical`` below ``sonar``
and ``camera_optical`` below ``camera``:

* ``world``: mitsonar's world frame (z up, floor at z = 0); REP-105's fixed ``map`` role.
* ``odom``: where the drifting wheel odometry starts. ``odom -> base_link`` is the odometry pose
  and ``world -> odom`` = truth x odometry^-1 absorbs its drift, so that ``world -> base_link``
  is the ground truth (as a localiser's ``map -> odom`` would).
* ``base_link``: mitsonar's robot frame, REP-103 body axes (x forward, y left, z up), at the
  chassis centre on the floor.
* ``sonar``: the transmit array's origin with body axes; ``sonar_optical``: the same origin with
  mitsonar's sensor axes (x right, y down, z forward: REP-103's ``_optical`` convention; the
  array looks along +z). Sonar detections and echoes are in ``sonar_optical``.
* ``camera``: the camera's optical centre with body axes; ``camera_optical``: with image axes
  (x right, y down, z forward), the frame of images and ``CameraInfo``.

Body and optical frames differ by :data:`BODY_FROM_OPTICAL` (optical x = body -y, optical y =
body -z, optical z = body x), so ``base_link -> sonar -> sonar_optical`` composes to
:meth:`Pose.sensor_mount <mitsonar.frames.Pose.sensor_mount>`.
"""

from __future__ import annotations

import numpy as np

from mitsonar.frames import Pose

WORLD, ODOM, BASE_LINK = "world", "odom", "base_link"
SONAR, SONAR_OPTICAL, CAMERA, CAMERA_OPTICAL = "sonar", "sonar_optical", "camera", "camera_optical"

#: Columns: the optical frame's axes expressed in the body frame.
BODY_FROM_OPTICAL = np.array([[0.0, 0.0, 1.0],
                              [-1.0, 0.0, 0.0],
                              [0.0, -1.0, 0.0]])
_OPTICAL = Pose(BODY_FROM_OPTICAL, np.zeros(3))


def _body(parent_from_optical: Pose) -> Pose:
    """Pose of the body frame that shares an optical frame's origin."""
    return parent_from_optical @ _OPTICAL.inverse()


def static_transforms(robot_from_sensor: Pose, camera_from_sensor: Pose) -> list:
    """(parent, child, parent_from_child) of the fixed part of the tree, from the sensor mount
    (robot-from-sensor, mitsonar's sensor frame = ``sonar_optical``) and the camera extrinsic
    (camera-from-sensor, camera frame = ``camera_optical``)."""
    sonar_from_camera_optical = _OPTICAL @ camera_from_sensor.inverse()
    return [(BASE_LINK, SONAR, _body(robot_from_sensor)),
            (SONAR, SONAR_OPTICAL, _OPTICAL),
            (SONAR, CAMERA, _body(sonar_from_camera_optical)),
            (CAMERA, CAMERA_OPTICAL, _OPTICAL)]


def robot_transforms(truth, odometry) -> list:
    """(parent, child, parent_from_child) of ``world -> odom`` and ``odom -> base_link`` for a
    ground-truth and an odometry robot pose (x [m], y [m], yaw [rad]) each."""
    world_from_robot, odom_from_robot = Pose.planar(*truth), Pose.planar(*odometry)
    return [(WORLD, ODOM, world_from_robot @ odom_from_robot.inverse()),
            (ODOM, BASE_LINK, odom_from_robot)]


def body_twist(times, poses) -> np.ndarray:
    """Velocities (T, 3) of robot poses (T, 3) at times (T,) [s]: forward and leftward speed
    [m/s] in the robot frame and yaw rate [rad/s], over the step to the next pose (the last
    pose repeats the last step; a single pose: zero)."""
    t = np.asarray(times, dtype=float)
    p = np.asarray(poses, dtype=float).reshape(-1, 3)
    if len(p) < 2:
        return np.zeros((len(p), 3))
    rate = np.diff(p, axis=0) / np.diff(t)[:, None]
    c, s = np.cos(p[:-1, 2]), np.sin(p[:-1, 2])
    body = np.stack([c * rate[:, 0] + s * rate[:, 1], -s * rate[:, 0] + c * rate[:, 1],
                     rate[:, 2]], axis=-1)
    return np.vstack([body, body[-1:]])
