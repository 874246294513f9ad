"""Surfel scanning while the robot drives (mitsonar.recon.surfels.pinging, map_surfels_along):
pings one listening time apart from the pose of their own time, camera frames taken whenever
the sonar is free."""

import numpy as np
import pytest

import mitsonar
from mitsonar.recon.surfels import SurfelSettings, map_surfels_along
from mitsonar.recon.surfels.pinging import MovingPinger, StillPinger
from mitsonar.scene.xml import material_xml, rectangle_xml
from mitsonar.sensors.camera import CameraModel
from mitsonar.sensors.trajectory import Trajectory
from test_surfels import CREASE, corner_scene, plane_errors

#: Turning on the spot at 30 deg/s from yaw 0.
TURNING = Trajectory(np.array([[0.0, 0.0, 0.0], [0.0, 0.0, np.pi]]), yaw_rate=np.radians(30.0))


def wall_sonar(scene_file):
    """The 'paper' sonar facing a concrete wall x = 3 m, 8 m x 8 m."""
    return mitsonar.Sonar(scene_file("wall", material_xml("w", preset="concrete"),
                                     rectangle_xml("w", (3.0, 0, 0.5), (0, -90, 0), size=(8, 8))),
                          mitsonar.SonarConfig.preset("paper"))


def test_moving_pings_leave_a_listening_time_apart_each_from_its_own_pose(scene_file):
    """Three beams straight ahead of the image's pose while the robot turns at 30 deg/s: they
    leave 0, 1 and 2 listening times (30.4 ms) after the image, each turned back by the 0.9 deg
    the robot turned since the last, so all three hit the wall where the first did (within the
    0.1 m lever of the sensor head turning: 1.6 mm per ping) and are placed there (the wall's
    x within 1 mm; a beam kept in the sensor frame would move 5 cm a ping along the wall). A beam
    at the field of view's edge, which the turn carries out of it, is not fired and takes no
    time."""
    sonar = wall_sonar(scene_file)
    period = sonar.config.record_duration
    assert period == pytest.approx(0.0304, abs=5e-4)
    pinger = MovingPinger(sonar, TURNING, image_time=0.0, time=0.0)
    points = pinger.fire(np.tile([0.0, 0.0, 1.0], (3, 1)), seed=0)
    assert pinger.time == pytest.approx(3 * period) and pinger.pings == 3
    world = pinger.pose.transform_points(points)
    np.testing.assert_allclose(world[:, 0], 3.0, atol=1e-3)
    assert np.ptp(world[:, 1]) < 5e-3
    edge = np.array([np.sin(np.radians(29.9)), 0.0, np.cos(np.radians(29.9))])  # +x: the right
    late = MovingPinger(sonar, TURNING, image_time=0.0, time=0.5)  # turned 15 deg since
    assert np.all(np.isnan(late.fire(edge[None], seed=0)))
    assert late.time == 0.5 and late.pings == 0
    still = StillPinger(sonar, pinger.pose)
    np.testing.assert_allclose(still.fire(np.tile([0.0, 0.0, 1.0], (2, 1)), seed=0)[:, 2],
                               points[0, 2], atol=2e-3)
    assert still.pings == 2


@pytest.mark.slow
def test_driving_at_the_corner_maps_its_three_planes(scene_file):
    """The robot drives 2.5 s towards the rendered room corner of test_surfels (from 3.2 m, at
    0.2 m/s): a 25 Hz camera frame is taken whenever the sonar is free, its pings follow each
    other every 30.4 ms from the moving robot. Frames lie on the camera's 25 Hz grid, each one
    after the last echo of the one before (within a camera period: here 77 pings, 2.34 s, the
    next frame at 2.36 s); each plane within 1 deg and 1 cm (measured: 0.11 deg, 4 mm)."""
    path, planes = corner_scene(scene_file)
    sonar = mitsonar.Sonar(path, mitsonar.SonarConfig.preset("paper"))
    toward = np.array([1.0, 1.0]) / np.sqrt(2)
    start, stop = CREASE[:2] - 3.2 * toward, CREASE[:2] - 2.2 * toward
    trajectory = Trajectory(np.array([[*start, np.pi / 4], [*stop, np.pi / 4]]), speed=0.2)
    surfel_map = map_surfels_along(sonar, trajectory, SurfelSettings(), duration=2.5)
    times = surfel_map.times
    camera_period = 1.0 / CameraModel().frame_rate
    assert len(times) >= 2 and times[0] == 0.0
    np.testing.assert_allclose(times / camera_period, np.round(times / camera_period), atol=1e-9)
    busy = times[:-1] + np.array([s.pings for s in surfel_map.scans[:-1]]) \
        * sonar.config.record_duration
    assert np.all(times[1:] >= busy - 1e-9) and np.all(times[1:] < busy + camera_period + 1e-9)
    errors, _ = plane_errors(surfel_map.groups, planes)
    for name, (angle, offset) in errors.items():
        assert angle < 1.0 and abs(offset) < 0.01, (name, angle, offset)
