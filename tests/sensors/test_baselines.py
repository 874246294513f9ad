"""VLP-16 class LiDAR and Kinect v2 class depth camera baselines, ray traced by Mitsuba."""

import numpy as np
import pytest

import mitsonar
from mitsonar.sensors.baselines import (DepthCamera, DepthCameraModel, Lidar, LidarModel,
                                map_trajectory, sweep)
from mitsonar.sensors.trajectory import Trajectory
from mitsonar.frames import SENSOR_MOUNT_TRANSLATION
from mitsonar.evaluation.metrics import evaluate
from mitsonar.scene.mesh import scene_mesh
from mitsonar.scene.xml import material_xml, rectangle_xml

#: Box room: x in [-3, 3], y in [-2, 2], z in [0, 2.5] [m]; rectangles overlap at the edges.
BOX_LO, BOX_HI = np.array([-3.0, -2.0, 0.0]), np.array([3.0, 2.0, 2.5])
ROBOT = (0.5, -0.3, np.radians(30.0))
NOISE_FREE = LidarModel(range_sigma=0.0)


def box_room(pane: str = ""):
    """Parts of a closed box room, with an optional pane of material ``pane`` at x = 1.5 m."""
    parts = [material_xml("wall", preset="drywall"),
             '<bsdf type="acoustic" id="glass"><string name="preset" value="glass"/>'
             '<bsdf type="thindielectric"/></bsdf>',
             rectangle_xml("wall", (0, 0, 0), size=(6.2, 4.2), shape_id="floor"),
             rectangle_xml("wall", (0, 0, 2.5), size=(6.2, 4.2), shape_id="ceiling"),
             rectangle_xml("wall", (3, 0, 1.25), (0, 90, 0), size=(2.7, 4.2), shape_id="east"),
             rectangle_xml("wall", (-3, 0, 1.25), (0, 90, 0), size=(2.7, 4.2), shape_id="west"),
             rectangle_xml("wall", (0, 2, 1.25), (90, 0, 0), size=(6.2, 2.7), shape_id="north"),
             rectangle_xml("wall", (0, -2, 1.25), (90, 0, 0), size=(6.2, 2.7), shape_id="south")]
    if pane:
        parts.append(rectangle_xml(pane, (1.5, 0, 0.7), (0, 90, 0), size=(1.0, 1.0),
                                   shape_id="pane"))
    return parts


def box_distance(origin, directions):
    """Distance [m] from a point inside the box to its walls along unit directions (N, 3)."""
    with np.errstate(divide="ignore"):
        t = np.where(directions > 0, (BOX_HI - origin) / directions,
                     (BOX_LO - origin) / directions)
    return np.min(np.where(directions != 0, t, np.inf), axis=1)


def test_noise_free_lidar_ranges_match_the_room_and_rings_are_at_their_elevations(scene_file):
    lidar = Lidar(scene_file("box", *box_room()), NOISE_FREE)
    frame = lidar.measure(ROBOT)
    pose = mitsonar.Pose.planar(*ROBOT) @ Lidar.mount()
    assert np.allclose(pose.translation[2], SENSOR_MOUNT_TRANSLATION[2])
    dirs = pose.transform_vectors(NOISE_FREE.directions().reshape(-1, 3))
    expected = box_distance(pose.translation, dirs).reshape(16, 1800)
    assert np.all(np.isfinite(frame.image))  # a closed room returns every beam
    assert np.max(np.abs(frame.image - expected)) < 1e-4
    rel = frame.points_world - pose.translation
    elevation = np.degrees(np.arctan2(rel[:, 2], np.hypot(rel[:, 0], rel[:, 1])))
    rings = elevation.reshape(16, 1800)
    assert np.allclose(rings, np.arange(-15, 16, 2)[:, None], atol=1e-4)
    azimuth = np.degrees(np.arctan2(rel[:, 1], rel[:, 0])).reshape(16, 1800) - 30.0
    assert np.allclose(np.diff(np.unwrap(np.radians(azimuth[0]))), np.radians(0.2), atol=1e-6)


def test_glass_is_not_seen_the_wall_behind_it_is(scene_file):
    lidar = Lidar(scene_file("glass", *box_room("glass")), NOISE_FREE)
    pane = lidar.scene.shape_ids.index("pane")
    frame = lidar.measure((0.0, 0.0, 0.0))
    origin = frame.world_from_sensor.translation
    d = frame.world_from_sensor.transform_vectors(NOISE_FREE.directions().reshape(-1, 3))
    t = (1.5 - origin[0]) / np.where(d[:, 0] > 0, d[:, 0], np.nan)
    cross = origin + t[:, None] * d
    through = (np.abs(cross[:, 1]) < 0.45) & (np.abs(cross[:, 2] - 0.7) < 0.45)
    assert through.sum() > 100
    assert pane not in frame.shape_index
    assert np.max(np.abs(frame.image.ravel()[through] - box_distance(origin, d[through]))) < 1e-4
    camera = DepthCamera(lidar.scene)
    assert pane not in camera.measure((0.0, 0.0, 0.0)).shape_index
    opaque = Lidar(scene_file("opaque", *box_room("wall")), NOISE_FREE).measure((0.0, 0.0, 0.0))
    assert np.all(opaque.shape_index[through] == pane)  # the same pane, diffuse: seen


def test_lidar_range_noise_has_the_model_sigma_and_follows_the_seed(scene_file):
    path = scene_file("box", *box_room())
    lidar = Lidar(path)  # sigma 1.5 cm
    truth = Lidar(lidar.scene, NOISE_FREE).measure(ROBOT).image
    frames = [lidar.measure(ROBOT, seed=s) for s in (0, 1)]
    residual = np.concatenate([(f.image - truth).ravel() for f in frames])  # 57600 ranges
    assert np.std(residual) == pytest.approx(0.015, rel=0.03)  # 3 sigma of the estimate: 1 %
    assert abs(np.mean(residual)) < 3 * 0.015 / np.sqrt(len(residual))
    again = lidar.measure(ROBOT, seed=0)
    assert np.array_equal(again.image, frames[0].image)
    assert not np.array_equal(frames[0].image, frames[1].image)


def test_depth_camera_drops_returns_outside_half_to_four_and_a_half_metres(scene_file):
    # Sensor at x = 0.1 m looking along +x: a plate at depth 2 m, a small plate at depth 0.3 m
    # hiding part of it, and the background wall at depth 5 m.
    path = scene_file("depths", material_xml("wall", preset="drywall"),
                      rectangle_xml("wall", (2.1, 0, 0.5), (0, 90, 0), size=(1.0, 1.0)),
                      rectangle_xml("wall", (0.4, 0.1, 0.5), (0, 90, 0), size=(0.2, 0.2)),
                      rectangle_xml("wall", (5.1, 0, 0.5), (0, 90, 0), size=(20.0, 20.0)))
    camera = DepthCamera(path)
    frame = camera.measure((0.0, 0.0, 0.0), seed=5)
    o = frame.world_from_sensor.translation
    d = frame.world_from_sensor.transform_vectors(camera.model.pixel_rays().reshape(-1, 3))

    def offsets(x):  # (y, z) offsets [m] of each pixel ray at the plane of given x from the plate centre
        p = o + ((x - o[0]) / d[:, 0])[:, None] * d
        return p[:, 1], p[:, 2] - 0.5

    y2, z2 = offsets(2.1)
    y0, z0 = offsets(0.4)
    on_far = np.maximum(np.abs(y2), np.abs(z2)) < 0.5
    on_near = np.maximum(np.abs(y0 - 0.1), np.abs(z0)) < 0.1
    expect = on_far & ~on_near
    edge = (np.abs(np.maximum(np.abs(y2), np.abs(z2)) - 0.5) < 0.01) \
        | (np.abs(np.maximum(np.abs(y0 - 0.1), np.abs(z0)) - 0.1) < 0.005)
    valid = np.isfinite(frame.image.ravel())
    assert on_near.sum() > 1000 and expect.sum() > 10000
    assert np.array_equal(valid[~edge], expect[~edge])
    assert np.all((frame.image[np.isfinite(frame.image)] >= 0.5)
                  & (frame.image[np.isfinite(frame.image)] <= 4.5))
    assert len(frame.points_sensor) == valid.sum()
    assert np.allclose(frame.points_world[:, 0], 2.1, atol=0.02)


def test_depth_noise_has_the_fankhauser_sigma(scene_file):
    path = scene_file("wall", material_xml("wall", preset="drywall"),
                      rectangle_xml("wall", (2.1, 0, 0.5), (0, 90, 0), size=(20.0, 20.0)))
    camera = DepthCamera(path)
    model = camera.model
    rays = model.pixel_rays()
    incidence = np.arccos(rays[..., 2])  # the wall faces the camera: theta = off-axis angle
    sigma = model.axial_sigma(2.0, incidence)
    assert model.axial_sigma(2.0, 0.0) == pytest.approx(1e-3 * (1.5 - 1.0 + 1.2))  # 1.7 mm
    assert model.axial_sigma(3.0, np.radians(89.0)) == model.axial_sigma(3.0, np.radians(80.0))
    frame = camera.measure((0.0, 0.0, 0.0), seed=2)
    z = (frame.image - 2.0) / sigma  # 217088 pixels, all valid
    assert np.all(np.isfinite(z))
    assert np.std(z) == pytest.approx(1.0, rel=0.03)  # 3 sigma of the estimate: 0.5 %
    assert abs(np.mean(z)) < 0.01
    pts = frame.points_sensor
    assert np.allclose(pts[:, :2] / pts[:, 2:], rays.reshape(-1, 3)[:, :2] / rays.reshape(-1, 3)[:, 2:])
    assert np.array_equal(camera.measure((0.0, 0.0, 0.0), seed=2).image, frame.image)


def test_map_trajectory_places_frames_with_the_odometry(scene_file):
    lidar = Lidar(scene_file("box", *box_room()), NOISE_FREE)
    truth = np.array([[0.0, 0.0, 0.0], [0.5, 0.2, np.radians(20)]])
    odometry = truth + [[0, 0, 0], [0.0, 0.1, 0.0]]
    exact, frame = map_trajectory(lidar, truth, seed=1)
    drifted, frame2 = map_trajectory(lidar, truth, odometry, seed=1)
    assert np.array_equal(frame, frame2) and set(frame) == {0, 1}
    assert np.allclose(drifted[frame == 0], exact[frame == 0])
    assert np.allclose(drifted[frame == 1] - exact[frame == 1], [0.0, 0.1, 0.0])
    scores = evaluate(exact, scene_mesh(lidar.scene), spacing=0.05).overall
    assert scores.accuracy == 1.0 and scores.mean_distance < 1e-4
    with pytest.raises(ValueError, match="odometry_poses"):
        map_trajectory(lidar, truth, odometry[:1])


def test_sweep_takes_each_sensors_frames_at_its_rate_and_places_every_beam(scene_file):
    """Driving 0.5 s of a trajectory that turns on the spot at 30 deg/s, then drives at
    0.2 m/s: the VLP-16 turns 5 times (10 Hz), the Kinect v2 takes 15 frames (30 Hz): duration
    x rate.
    A LiDAR column fired while the robot turns leaves from the pose of its own time and is
    placed with it: every noise-free point lies on the box room's walls (1e-4 m), and a
    revolution's points differ from those of the robot standing still at its start."""
    scene = scene_file("box", *box_room())
    trajectory = Trajectory(np.array([[0.0, 0.0, 0.0], [0.0, 0.0, np.pi / 2],
                                      [1.0, 0.0, np.pi / 2]]), speed=0.2, yaw_rate=np.radians(30.0))
    lidar, camera = Lidar(scene, NOISE_FREE), DepthCamera(scene)
    frames = {key: list(sweep(sensor, trajectory, duration=0.5, seed=3))
              for key, sensor in (("lidar", lidar), ("camera", camera))}
    assert [len(frames["lidar"]), len(frames["camera"])] == [5, 15]
    np.testing.assert_allclose([t for t, _ in frames["lidar"]], np.arange(5) / 10.0)
    np.testing.assert_allclose([t for t, _ in frames["camera"]], np.arange(15) / 30.0)
    mesh = scene_mesh(lidar.scene)
    for _, points in frames["lidar"][:3]:
        assert evaluate(points, mesh, spacing=0.1).overall.mean_distance < 1e-4
    still = lidar.measure(trajectory.poses_at([0.0])[0]).points_world
    moving = frames["lidar"][0][1]
    assert len(moving) == len(still) and np.abs(moving - still).max() > 0.05
    standing = Trajectory(np.array([[0.2, 0.1, 0.3]]))
    _, parked = next(sweep(lidar, standing, seed=0))
    np.testing.assert_allclose(parked, lidar.measure((0.2, 0.1, 0.3)).points_world, atol=1e-9)


def test_bad_poses_and_models_are_named(scene_file):
    lidar = Lidar(scene_file("box", *box_room()), NOISE_FREE)
    with pytest.raises(ValueError, match="robot pose"):
        lidar.measure((np.nan, 0.0, 0.0))
    with pytest.raises(ValueError, match="robot_poses"):
        map_trajectory(lidar, [[0.0, 0.0, np.inf]])
    with pytest.raises(ValueError, match="range_sigma"):
        LidarModel(range_sigma=-0.01)
    with pytest.raises(ValueError, match="rate"):
        LidarModel(rate=0.0)
    with pytest.raises(ValueError, match="elevation_max"):
        LidarModel(elevation_min=0.2, elevation_max=0.1)
    with pytest.raises(ValueError, match="max_depth"):
        DepthCameraModel(min_depth=2.0, max_depth=1.0)
    with pytest.raises(ValueError, match="width"):
        DepthCameraModel(width=0)
