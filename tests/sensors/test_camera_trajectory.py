"""Camera model against equations (10)(11) and Mitsuba's renderer; trajectories and odometry."""

import drjit as dr
import numpy as np
import pytest

import mitsonar
from mitsonar.sensors.camera import CameraModel, CameraRenderer
from mitsonar.sensors.ofdm_sonar import pose_along
from mitsonar.frames import direction_from_angles
from mitsonar.sensors.trajectory import OdometryDrift, Trajectory
from helpers import IDENTITY, SCENES
from mitsonar.scene.xml import material_xml, rectangle_xml

SMALL = CameraModel().at_resolution(160)


def test_intrinsics_cover_the_array_field_of_view():
    cam = CameraModel()
    assert cam.focal_pixels == pytest.approx(6e-3 / 4.5e-6)
    assert np.degrees(cam.horizontal_fov) > 60.0
    assert np.degrees(2 * np.arctan(cam.height / 2 / cam.focal_pixels)) > 40.0
    low = cam.at_resolution(400)
    assert low.height == 300 and low.horizontal_fov == pytest.approx(cam.horizontal_fov)


def test_pixel_to_ray_and_back_through_equations_10_11(scene_file):
    """Point -> pixel -> (theta, phi) by (10)(11) -> ray from the camera -> the same point."""
    scene = mitsonar.load_scene(scene_file("w", material_xml("w", preset="drywall"),
                                           rectangle_xml("w", (0.3, 0.2, 3.0), (20, 30, 0), size=(8, 8))))
    renderer = CameraRenderer(scene, SMALL)
    camera_pose = SMALL.world_from_camera(IDENTITY)
    rng = np.random.default_rng(1)
    uv = rng.uniform([10, 10], [150, 110], size=(20, 2))
    theta, phi = SMALL.pixel_angles(uv[:, 0], uv[:, 1])
    d = camera_pose.transform_vectors(direction_from_angles(theta, phi))
    mi = renderer.mi
    o = camera_pose.translation
    si = scene.scene.ray_intersect(mi.Ray3f(mi.Point3f(*[mi.Float(np.full(20, o[k])) for k in range(3)]),
                                            mi.Vector3f(*[mi.Float(d[:, k]) for k in range(3)])))
    hit = np.asarray(si.p, dtype=float).T
    back = SMALL.project(camera_pose.inverse().transform_points(hit))
    np.testing.assert_allclose(back, uv, atol=1e-4)  # sub-pixel (1e-4 px)


def test_rendered_image_agrees_with_the_pinhole_model(scene_file):
    """A small emitter at a known point lights the pixel the model projects it to."""
    target = np.array([0.4, -0.25, 2.5])  # sensor frame = world frame here
    lamp = (f'<shape type="sphere"><point name="center" x="{target[0]}" y="{target[1]}" '
            f'z="{target[2]}"/><float name="radius" value="0.02"/>'
            '<emitter type="area"><rgb name="radiance" value="50"/></emitter><ref id="w"/></shape>')
    scene = mitsonar.load_scene(scene_file("lamp", material_xml("w", preset="drywall"), lamp,
                                           rectangle_xml("w", (0, 0, 6.0), size=(20, 20))))
    renderer = CameraRenderer(scene, CameraModel(spp=4).at_resolution(320))
    images = renderer.render(IDENTITY, seed=0)
    bright = images.gray > 10.0  # the lamp's disc (radius about 2 px)
    vv, uu = np.nonzero(bright)
    centroid = np.array([uu.mean() + 0.5, vv.mean() + 0.5])
    expected = renderer.model.project(renderer.model.camera_from_sensor().transform_points(target))
    assert np.hypot(*(centroid - expected)) <= 0.5  # pixels


def test_rendering_is_seeded_and_independent_of_the_threads():
    """Same seed, same image on 1 and 3 CPU threads (each pixel's samples summed by one thread:
    12 spp rendered in one pass differ between thread counts in ~40 of room_glass's pixels at
    320 px); another seed, other noise. 12 spp: passes of 4 samples."""
    scene = mitsonar.load_scene(SCENES / "room_glass" / "scene.xml")
    renderer = CameraRenderer(scene, CameraModel(spp=12, denoise=False).at_resolution(320))
    pose = pose_along(Trajectory.from_scene(SCENES / "room_glass" / "scene.xml"))(0.0)
    threads = dr.thread_count()
    try:
        images = []
        for count in (1, 3):
            dr.set_thread_count(count)
            images.append(renderer.render(pose, seed=4).rgb)
    finally:
        dr.set_thread_count(threads)
    other = renderer.render(pose, seed=5).rgb
    assert images[0].std() > 0 and np.array_equal(images[0], images[1])
    assert not np.array_equal(images[0], other)


def test_frozen_render_replays_the_plain_render_bit_for_bit():
    """The renderer's frozen pass (recorded once, replayed for later poses and seeds) gives the
    image that Mitsuba's plain render of the same camera, pose and seed gives, at every pose
    along a drive: the first call records, the second records again with the changing values
    opaque, the later ones replay."""
    path = SCENES / "room_glass" / "scene.xml"
    scene = mitsonar.load_scene(path)
    model = CameraModel(spp=8, denoise=False).at_resolution(160)
    renderer, plain = CameraRenderer(scene, model), CameraRenderer(scene, model, frozen=False)
    pose_at = pose_along(Trajectory.from_scene(path))
    for k, t in enumerate((0.0, 6.0, 12.0, 18.0)):
        image = renderer.render(pose_at(t), seed=k).rgb
        assert image.std() > 0
        np.testing.assert_array_equal(image, plain.render(pose_at(t), seed=k).rgb)
    assert renderer._pass.frozen.n_recordings <= 2  # replayed, not traced again


def test_frozen_render_is_recorded_anew_when_another_scene_comes_and_goes():
    """A recording reaches the scene's objects through Dr.Jit's registry, which every other
    scene's shapes, BSDFs and emitters join and leave: after another scene was loaded and freed
    the pass is recorded anew (replaying the old recording raised ``assign_with_registry()`` or
    crashed the process, at random, in freshly cloned suites) and still gives the plain render's
    image; with nothing loaded or freed in between it replays."""
    import gc

    path = SCENES / "room_glass" / "scene.xml"
    scene = mitsonar.load_scene(path)
    model = CameraModel(spp=2, denoise=False).at_resolution(64)
    renderer, plain = CameraRenderer(scene, model), CameraRenderer(scene, model, frozen=False)
    pose = pose_along(Trajectory.from_scene(path))(0.0)
    for seed in (0, 1, 2):
        renderer.render(pose, seed=seed)
    recorded = renderer._pass.frozen.n_recordings
    other = mitsonar.load_scene(SCENES / "structure" / "scene.xml")
    del other
    gc.collect()
    np.testing.assert_array_equal(renderer.render(pose, seed=3).rgb, plain.render(pose, seed=3).rgb)
    assert (recorded, renderer._pass.frozen.n_recordings) == (2, 1)  # dropped, recorded anew
    for seed in (4, 5):  # recorded with the changing values opaque, then replayed
        np.testing.assert_array_equal(renderer.render(pose, seed=seed).rgb,
                                      plain.render(pose, seed=seed).rgb)
    assert renderer._pass.frozen.n_recordings == 2


def test_camera_depth_matches_sonar_depth_on_a_wall(scene_file):
    path = scene_file("w", material_xml("w", preset="concrete"), rectangle_xml("w", (0, 0, 2.5), size=(20, 20)))
    sonar = mitsonar.Sonar(path)
    renderer = CameraRenderer(sonar.scene, SMALL)
    depth, _ = renderer.ground_truth(SMALL.world_from_camera(IDENTITY))
    for u, v in [(80.5, 60.5), (86.5, 63.5)]:
        theta, phi = SMALL.pixel_angles(u, v)
        det = sonar.ping(IDENTITY, direction_from_angles(theta, phi)).detection
        camera_range = depth[int(v), int(u)] / np.cos(theta)  # along the same direction
        assert det.detected and abs(det.depth - camera_range) <= 5e-3


def test_glass_is_transparent_to_the_camera_and_reflective_to_the_sonar(scene_file):
    glass = ('<bsdf type="acoustic" id="pane"><string name="preset" value="glass"/>'
             '<bsdf type="thindielectric"/></bsdf>')
    light = ('<shape type="rectangle"><transform name="to_world"><scale x="10" y="10"/>'
             '<rotate y="1" angle="180"/><translate z="4"/></transform>'
             '<emitter type="area"><rgb name="radiance" value="1"/></emitter><ref id="back"/></shape>')
    path = scene_file("pane", glass, material_xml("back", preset="drywall"), light, rectangle_xml("pane", (0, 0, 2.0), size=(3, 3)))
    sonar = mitsonar.Sonar(path)
    images = CameraRenderer(sonar.scene, CameraModel(spp=2).at_resolution(64)).render(IDENTITY)
    centre = images.gray[20:28, 28:36].mean()
    assert centre > 0.8  # the light behind the pane shows through (transmittance ~0.92)
    det = sonar.ping(IDENTITY, np.array([0.0, 0.0, 1.0])).detection
    assert det.detected and abs(det.depth - 2.0) <= 5e-3


def test_trajectory_timing_and_poses():
    traj = Trajectory(np.array([[0, 0, 0], [1, 0, 0], [1, 0, np.pi / 2], [1, 1, np.pi / 2]]),
                      speed=0.5, yaw_rate=np.pi / 4)
    np.testing.assert_allclose(traj.segment_times(), [0, 2, 4, 6])
    np.testing.assert_allclose(traj.poses_at([1.0, 3.0, 5.0]),
                               [[0.5, 0, 0], [1, 0, np.pi / 4], [1, 0.5, np.pi / 2]])
    times, poses = traj.sample(0.5)
    assert len(times) == 13 and np.allclose(poses[-1], [1, 1, np.pi / 2])
    with pytest.raises(ValueError, match="waypoint 1"):
        Trajectory(np.array([[0, 0, 0], [np.nan, 0, 0]]))


def test_shipped_scene_trajectory_loads():
    traj = Trajectory.from_scene("scenes/room_glass/scene.xml")
    assert traj.duration > 10 and np.allclose(traj.waypoints[0], 0)


def test_odometry_drift_is_seeded_and_grows_with_distance():
    traj = Trajectory(np.array([[0, 0, 0], [4, 0, 0]]), speed=0.2)
    _, truth = traj.sample(0.1)
    exact = OdometryDrift(0.0, 0.0, 0.0).apply(truth, seed=0)
    np.testing.assert_allclose(exact, truth, atol=1e-12)
    drift = OdometryDrift()
    a, b = drift.apply(truth, seed=3), drift.apply(truth, seed=3)
    assert np.array_equal(a, b)
    errors = np.array([np.abs(OdometryDrift().apply(truth, seed=s) - truth)[:, 1] for s in range(40)])
    assert errors[:, -1].mean() > 3 * errors[:, len(truth) // 4].mean()  # lateral drift grows


def test_sensor_frames_follow_their_rate_along_the_trajectory():
    """A 13 s trajectory (2 m at 0.2 m/s, then a quarter turn at 30 deg/s): a sensor at rate
    f takes floor(13 f) frames (duration x rate) k / f apart, at poses on the trajectory; the
    first 4 s give 4 f."""
    trajectory = Trajectory(np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 0.0, np.pi / 2]]),
                            speed=0.2, yaw_rate=np.radians(30.0))
    assert trajectory.duration == pytest.approx(13.0)
    for rate, count in ((10.0, 130), (30.0, 390), (25.0, 325), (1 / 0.2085, 62)):
        times = trajectory.times_at_rate(rate)
        assert len(times) == count and times[0] == 0.0
        np.testing.assert_allclose(np.diff(times), 1.0 / rate)
    times = trajectory.times_at_rate(10.0, duration=4.0)
    assert len(times) == 40 and times[-1] == pytest.approx(3.9)
    np.testing.assert_allclose(trajectory.poses_at(times), np.stack(
        [0.2 * times, np.zeros(40), np.zeros(40)], axis=-1), atol=1e-12)
    turn = trajectory.poses_at(trajectory.times_at_rate(10.0)[-20:])
    np.testing.assert_allclose(turn[:, :2], [[2.0, 0.0]] * 20)
    assert np.all(np.diff(turn[:, 2]) == pytest.approx(np.radians(3.0)))
    assert len(Trajectory(np.zeros((1, 3))).times_at_rate(10.0)) == 1  # standing: one frame
    with pytest.raises(ValueError, match="duration"):
        trajectory.times_at_rate(10.0, duration=14.0)
    with pytest.raises(ValueError, match="rate"):
        trajectory.times_at_rate(0.0)


def test_shipped_window_is_seen_through_by_the_camera_and_reflects_sound():
    """room_glass, robot at the origin, beam 17 deg up into the east pane (x = 3.1 m): the rays
    hit glass and the pane returns an echo far above the noise at its range (at this incidence
    the wall below the sill, seen through the side lobes, echoes more strongly, so the side-lobe
    check reports no detection rather than a wrong depth); the camera sees the sky through it."""
    sonar = mitsonar.Sonar("scenes/room_glass/scene.xml")
    pose = mitsonar.Pose.sensor_on_robot(0.0, 0.0, 0.0)
    pane_point = np.array([3.1, -0.25, 1.4])  # world: inside the window opening
    wall_point = np.array([3.0, 1.5, 1.4])  # world: plain wall left of the window
    u = pose.inverse().transform_points(pane_point)
    u /= np.linalg.norm(u)
    ping = sonar.ping(pose, u)
    glass = [i for i, m in enumerate(sonar.scene.materials) if m.name == "window_glass"
             or m.impedance == mitsonar.preset("glass").impedance]
    on_glass = np.isin(ping.trace.hit_materials, glass)
    central = np.linalg.norm(ping.trace.hit_points / np.linalg.norm(ping.trace.hit_points, axis=1,
                                                                      keepdims=True) - u, axis=1) < 0.05
    assert on_glass[central].all()  # every ray within 3 deg of the beam hits the pane
    distance = (3.1 - pose.translation[0]) / pose.transform_vectors(u)[0]
    c = sonar.config.medium.speed_of_sound
    at_pane = np.abs(ping.recording.times * c - 2 * distance) < 0.05
    assert ping.envelope[at_pane].max() > 10 * sonar.config.detection.detection_floor
    assert not ping.detection.detected or abs(ping.detection.depth - distance) <= 5e-3
    model = CameraModel(spp=4).at_resolution(160)
    images = CameraRenderer(sonar.scene, model).render(pose)
    cam = model.world_from_camera(pose).inverse()
    (pu, pv), (wu, wv) = model.project(cam.transform_points([pane_point, wall_point]))
    pane_px, wall_px = images.rgb[int(pv), int(pu)], images.rgb[int(wv), int(wu)]
    assert sonar.scene.shape_ids[images.shape_index[int(pv), int(pu)]] == "window_east"
    # blue sky, brighter than the wall beside it (which faces away from the key look's key light:
    # the sky is 1.8 times brighter, 3.6 times under the ceiling look's panels)
    assert pane_px[2] > pane_px[0] and pane_px.mean() > 1.5 * wall_px.mean()


def test_trajectory_files_are_read_and_bad_ones_named(tmp_path):
    import json

    good = tmp_path / "path.json"
    good.write_text(json.dumps({"waypoints": [[0, 0, 0], [2, 0, 90]], "speed_m_s": 0.5,
                                "yaw_rate_deg_s": 45}))
    traj = Trajectory.from_file(good)
    np.testing.assert_allclose(traj.waypoints[-1], [2, 0, np.pi / 2])
    assert traj.speed == 0.5 and traj.yaw_rate == pytest.approx(np.pi / 4)
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"waypoints": [[0, 0, 0], [float("nan"), 0, 0]], "speed_m_s": 0.5,
                               "yaw_rate_deg_s": 45}))
    with pytest.raises(ValueError, match="bad.json.*not finite"):
        Trajectory.from_file(bad)
    with pytest.raises(ValueError, match="missing.json"):
        Trajectory.from_file(tmp_path / "missing.json")
