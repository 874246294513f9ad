"""MCAP recordings of map runs and the ROS frame tree (REP-103/105)."""

import numpy as np
import pytest

from mitsonar.data.map_mcap import ODOMETRY_PERIOD, RunTimeline, record_repeated
from mitsonar.data.mcap_recorder import McapRecorder
from mitsonar.data.ros_frames import BODY_FROM_OPTICAL, body_twist, static_transforms
from mitsonar.data.ros_messages import cloud_columns
from mitsonar.frames import Pose
from mitsonar.recon.repeated import RepeatedMapSpec, map_repeated
from mitsonar.scene.xml import material_xml, rectangle_xml
from mitsonar.sensors.camera import CameraModel
from mitsonar.physics.transducer import Transducer
from mitsonar.sensors.sonar import Sonar, SonarConfig
from mitsonar.sensors.trajectory import Trajectory
from helpers import read_mcap, tf_tree, world_from


def test_static_frames_follow_rep103():
    camera = CameraModel()
    tree = {child: (parent, pose) for parent, child, pose in
            static_transforms(Pose.sensor_mount(), camera.camera_from_sensor())}
    tree["base_link"] = ("world", Pose.identity())
    sonar, optical = tree["sonar"][1], tree["sonar_optical"][1]
    np.testing.assert_allclose(sonar.rotation, np.eye(3))  # body axes: x forward, z up
    np.testing.assert_allclose(optical.rotation, BODY_FROM_OPTICAL)  # z forward, y down
    np.testing.assert_allclose(tree["camera"][1].translation, [0.0, 0.0, 0.075])  # above
    np.testing.assert_allclose(world_from(tree, "sonar_optical").matrix(),
                               Pose.sensor_mount().matrix(), atol=1e-15)
    np.testing.assert_allclose(world_from(tree, "camera_optical").matrix(),
                               camera.world_from_camera(Pose.sensor_mount()).matrix(), atol=1e-15)


def test_body_twist_of_a_turning_robot():
    times = np.array([0.0, 1.0, 2.0])
    poses = np.array([[0.0, 0.0, np.pi / 2], [0.0, 0.5, np.pi / 2], [-0.5, 0.5, np.pi]])
    np.testing.assert_allclose(body_twist(times, poses),  # forward; then left while turning
                               [[0.5, 0.0, 0.0], [0.0, 0.5, np.pi / 2], [0.0, 0.5, np.pi / 2]],
                               atol=1e-12)


def test_run_timeline_drifts_and_its_frames_give_the_truth_at_every_stamp(tmp_path):
    trajectory = Trajectory(np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 0.0, 1.5]]))
    timeline = RunTimeline(trajectory, end=12.0, seed=1)
    recorder = McapRecorder()
    stamps = [0.123, 7.4567, 30.0]  # between odometry samples, and after the trajectory's end
    timeline.record(recorder, stamps)
    recorder.save(tmp_path / "run.mcap")
    read = read_mcap(tmp_path / "run.mcap")
    odometry = [m for topic, _, m in read if topic == "/odom"]
    assert len(odometry) == 12 / ODOMETRY_PERIOD + 1
    assert odometry[20].twist.twist.linear.x == pytest.approx(0.2, rel=0.05)  # 0.2 m/s
    truth = [m for topic, _, m in read if topic == "/ground_truth/pose"]
    assert truth[-1].pose.position.x == 2.0 and odometry[-1].pose.pose.position.x != 2.0
    for t in stamps + [5.0]:
        ns = round(t * 1e9)
        world_from_robot = world_from(tf_tree(read, ns), "base_link")
        np.testing.assert_allclose(world_from_robot.matrix(),
                                   Pose.planar(*trajectory.poses_at([t])[0]).matrix(), atol=1e-12)


@pytest.fixture
def wall_run(scene_file):
    """One OFDM frame of 9 beams on a wall, driving at 0.5 m/s, every echo and range cell, each
    beam traced in its own cone (with shared hits the wall's mirror echo through the side lobes
    leaves two beams with one echo each: too few to check the recorded echo ranks)."""
    wall = rectangle_xml("w", (2.1, 0.0, 0.5), (0, -90, 0), size=(10, 10))
    light = '<emitter type="constant"><rgb name="radiance" value="1"/></emitter>'
    broadband = SonarConfig(transducer=Transducer(bandwidth_6db=20e3))
    sonar = Sonar(scene_file("wall", material_xml("w", preset="concrete"), wall, light), broadband)
    trajectory = Trajectory(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]), speed=0.5)
    spec = RepeatedMapSpec(frames=1, scan_step=np.radians(20), image_width=32, spp=1,
                           echoes="cells", shared_hits=False)
    voxels, _, frames = map_repeated(sonar, trajectory, spec)
    return voxels, frames, trajectory


def test_repeated_run_records_every_beam_at_its_firing_time_and_pose(wall_run, tmp_path):
    voxels, frames, trajectory = wall_run
    out = tmp_path / "run.mcap"
    counts = record_repeated(out, frames, voxels, trajectory, seed=3)
    read = read_mcap(out)
    assert [t for _, t, _ in read] == sorted(t for _, t, _ in read)
    frame = frames[0].frame
    fired = np.round((frame.start_time + frame.schedule.transmit_time) * 1e9).astype(int)
    clouds = [(t, m) for topic, t, m in read if topic == "/sonar/detections"]
    assert counts["/sonar/detections"] == len(fired) and counts["/camera/image"] == 1
    assert frame.detected.sum() >= 3
    by_time = {t: m for t, m in clouds}
    table = frame.echo_table  # every echo of each beam
    assert len(table) > frame.detected.sum()
    for b, ns in enumerate(fired):
        cloud = cloud_columns(by_time[ns])
        mine = table.take(table.beam == b)
        assert len(cloud["x"]) == len(mine) >= frame.detected[b]
        pose = world_from(tf_tree(read, ns), "sonar_optical")
        np.testing.assert_allclose(pose.matrix(), frame.world_from_sensor[b], atol=1e-9)
        assert np.all(cloud["beam"] == b) and np.all(cloud["code"] == frame.schedule.code_index[b])
        np.testing.assert_array_equal(cloud["rank"], mine.rank)
        for name, column in (("x", mine.point[:, 0]), ("snr", mine.snr),
                             ("arrival_z", mine.direction[:, 2]), ("coherence", mine.coherence)):
            np.testing.assert_array_equal(cloud[name], np.float32(column))
        if frame.detected[b]:  # rank 0: the beam's detection
            np.testing.assert_array_equal(cloud["x"][0], np.float32(frame.points_sensor[b, 0]))
    assert counts["/odom"] == int(max(fired) / 1e9 / ODOMETRY_PERIOD) + 1
    (last_map,) = [m for topic, _, m in read if topic == "/map"]
    m = cloud_columns(last_map)
    assert last_map.header.frame_id == "world" and len(m["x"]) == len(voxels)
    np.testing.assert_array_equal(m["x"], voxels.positions[:, 0].astype(np.float32))


def test_an_image_run_records_every_image_at_its_firing_time_and_pose(scene_file, tmp_path):
    """Repeated mode with single-ping images (a 30-50 kHz sweep, broadband transducers): one
    ``/sonar/detections`` cloud per image at its firing time, the sensor's frame there the
    image's pose, every point of the image in it, strongest first (rank 0), with its arrival
    direction, SNR and coherence; one camera image per frame."""
    from mitsonar.sensors.imaging_sonar import TransmitSettings

    wall = rectangle_xml("w", (2.1, 0.0, 0.5), (0, -90, 0), size=(10, 10))
    light = '<emitter type="constant"><rgb name="radiance" value="1"/></emitter>'
    config = SonarConfig().with_drive(broadband=True, chirp=True)
    sonar = Sonar(scene_file("wall", material_xml("w", preset="concrete"), wall, light), config)
    trajectory = Trajectory(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]), speed=0.5)
    spec = RepeatedMapSpec(frames=1, scan="imaging", image_width=32, spp=1,
                           transmit=TransmitSettings(rays_per_axis=24))
    voxels, _, frames = map_repeated(sonar, trajectory, spec)
    out = tmp_path / "run.mcap"
    counts = record_repeated(out, frames, voxels, trajectory, seed=3)
    read = read_mcap(out)
    (frame,) = frames
    fired = np.round(np.array(frame.image_times) * 1e9).astype(int)
    assert counts["/sonar/detections"] == len(frame.images) == len(fired) > 1
    assert counts["/camera/image"] == 1
    clouds = {t: m for topic, t, m in read if topic == "/sonar/detections"}
    assert sum(len(image) for image in frame.images) > 0
    for ns, image, table in zip(fired, frame.images, frame.image_tables):
        cloud = cloud_columns(clouds[ns])
        pose = world_from(tf_tree(read, ns), "sonar_optical")
        np.testing.assert_allclose(pose.matrix(), image.pose.matrix(), atol=1e-9)
        assert len(cloud["x"]) == len(image)
        np.testing.assert_array_equal(cloud["rank"], np.arange(len(image)))
        strongest = np.argsort(-image.amplitude, kind="stable")
        for name, column in (("x", image.points_sensor[strongest, 0]),
                             ("snr", image.snr[strongest]),
                             ("arrival_z", image.direction[strongest, 2]),
                             ("coherence", image.coherence[strongest])):
            np.testing.assert_array_equal(cloud[name], np.float32(column))
        np.testing.assert_array_equal(table.point, image.points_sensor[strongest])
