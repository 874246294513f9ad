"""MCAP export of a dataset: read back with the MCAP reader, equal to the dataset's files."""

import hashlib
import json
import re
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from mitsonar.cli import main
from mitsonar.data.dataset import DatasetSpec, open_dataset, render_dataset
from mitsonar.data.dataset_mcap import echo_table, export_dataset
from mitsonar.data.mcap_recorder import PULSE_CODE, TOPICS
from mitsonar.data.ros_messages import cloud_columns, echo_samples
from mitsonar.frames import Pose
from helpers import ROOT, SCENES, read_mcap, ros_pose, tf_tree, world_from

# Two samples, three beams each, tiny images (as tests/data/test_dataset.py).
SPEC = DatasetSpec(str(SCENES / "room_glass" / "scene.xml"), period=2.0,
                   scan_step=np.radians(30), image_width=24, spp=2, max_samples=2)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    return render_dataset(SPEC, tmp_path_factory.mktemp("ds") / "dataset")


@pytest.fixture(scope="module")
def messages(dataset, tmp_path_factory):
    out = tmp_path_factory.mktemp("mcap") / "dataset.mcap"
    counts = export_dataset(dataset, out)
    read = read_mcap(out)
    assert counts == {t: sum(topic == t for topic, _, _ in read) for t in counts}
    return out, read


def test_file_has_the_standard_schemas_channels_and_counts(messages, dataset):
    from mcap.reader import make_reader

    out, _ = messages
    with open(out, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert reader.get_header().profile == "ros2"
    beams = len(open_dataset(dataset)[0].echoes["detected"])
    expected = {"/tf_static": 1, "/sonar/echoes": 2 * beams}
    for cid, channel in summary.channels.items():
        schema = summary.schemas[channel.schema_id]
        package, kind = TOPICS[channel.topic].split("/")
        assert schema.name == f"{package}/msg/{kind}" and schema.encoding == "ros2msg"
        assert channel.message_encoding == "cdr"
        assert summary.statistics.channel_message_counts[cid] == expected.get(channel.topic, 2)
    assert {c.topic for c in summary.channels.values()} == set(TOPICS) - {"/map"}
    assert summary.statistics.message_end_time == 2_000_000_000  # the second sample, at 2 s


def test_stamps_frames_poses_and_point_clouds_equal_the_dataset(messages, dataset):
    _, read = messages
    ds = open_dataset(dataset)
    frames = {"/odom": "odom", "/ground_truth/pose": "world", "/camera/image": "camera_optical",
              "/camera/depth": "camera_optical", "/camera/camera_info": "camera_optical",
              "/sonar/detections": "sonar_optical", "/sonar/echoes": "sonar_optical"}
    for topic, time, m in read:
        if topic in frames:
            assert m.header.stamp.sec * 10**9 + m.header.stamp.nanosec == time
            assert m.header.frame_id == frames[topic]
    calib = ds.meta["calibration"]
    for k in range(len(ds)):
        sample = ds[k]
        ns = round(sample.pose["time_s"] * 1e9)
        at = {}
        for topic, time, m in read:
            if time == ns:
                at.setdefault(topic, []).append(m)
        tree = tf_tree(read, ns)
        np.testing.assert_allclose(world_from(tree, "sonar_optical").matrix(),
                                   sample.pose["world_from_sensor_truth"], atol=1e-12)
        sonar_from_camera = (world_from(tree, "sonar_optical").inverse()
                             @ world_from(tree, "camera_optical"))
        np.testing.assert_allclose(sonar_from_camera.matrix(),
                                   np.linalg.inv(calib["camera_from_sensor"]), atol=1e-12)
        odom, truth = at["/odom"][0], at["/ground_truth/pose"][0]
        for msg_pose, expected in ((odom.pose.pose, sample.pose["robot_pose_odometry"]),
                                   (truth.pose, sample.pose["robot_pose_truth"])):
            x, y, yaw = expected
            np.testing.assert_allclose(ros_pose(msg_pose).matrix(), Pose.planar(x, y, yaw).matrix(),
                                       atol=1e-12)
        assert odom.child_frame_id == "base_link"
        e = sample.echoes
        cloud = cloud_columns(at["/sonar/detections"][0])
        det = e["detected"]
        points = np.stack([cloud["x"], cloud["y"], cloud["z"]], axis=-1)
        arrival = np.stack([cloud[f"arrival_{a}"] for a in "xyz"], axis=-1)
        assert np.array_equal(points, e["echo_point"].astype(np.float32))  # every echo
        assert np.array_equal(arrival, e["echo_direction"].astype(np.float32))
        for name in ("amplitude", "snr", "coherence"):
            assert np.array_equal(cloud[name], e[f"echo_{name}"].astype(np.float32),
                                  equal_nan=True)
        assert np.array_equal(cloud["beam"], e["echo_beam"])
        assert np.array_equal(cloud["rank"], e["echo_rank"])
        assert np.all(cloud["code"] == PULSE_CODE)
        first = cloud["rank"] == 0  # each detected beam's strongest echo: its detection
        assert np.array_equal(cloud["beam"][first], np.nonzero(det)[0])
        assert np.array_equal(points[first], e["points_sensor"][det].astype(np.float32))
        echoes = at["/sonar/echoes"]
        assert [m.beam for m in echoes] == list(range(len(det)))
        for b, m in enumerate(echoes):
            assert np.array_equal(echo_samples(m), e["echoes"][b])
            assert m.detected == det[b] and m.carrier_frequency == e["carrier_frequency"]
            assert m.start_time == e["start_time"] and m.sample_rate == e["sample_rate"]
        assert len(echoes[0].channel_positions) == len(calib["rx_positions_m"])
        image = at["/camera/image"][0]
        png = cv2.imread(str(dataset / "samples" / f"{k:06d}" / "rgb.png"))[..., ::-1]
        assert image.encoding == "rgb8" and (image.height, image.width) == png.shape[:2]
        assert bytes(image.data) == png.tobytes()
        depth = at["/camera/depth"][0]
        assert depth.encoding == "32FC1"
        assert np.array_equal(np.frombuffer(bytes(depth.data), "<f4").reshape(depth.height, -1),
                              sample.depth.reshape(sample.depth.shape[:2]))
        info = at["/camera/camera_info"][0]
        np.testing.assert_array_equal(np.reshape(info.k, (3, 3)), calib["camera_intrinsics_px"])
        assert [info.width, info.height] == calib["image_size"]


def test_truncated_dataset_is_named_and_writes_nothing(dataset, tmp_path, capsys):
    copy = tmp_path / "copy"
    shutil.copytree(dataset, copy)
    echoes = copy / "samples" / "000001" / "echoes.npz"
    echoes.write_bytes(echoes.read_bytes()[:-100])
    out = tmp_path / "out" / "dataset.mcap"
    assert main(["dataset", "export", str(copy), "--out", str(out)]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if "error" in line]
    assert len(err) == 1 and "000001/echoes.npz" in err[0]
    assert not out.exists() and list(out.parent.iterdir()) == []
    (copy / "dataset.json").write_text(json.dumps({"format_version": 1})[:-3])
    assert main(["dataset", "export", str(copy), "--out", str(out)]) == 2
    assert "dataset.json" in capsys.readouterr().err and not out.exists()


def _older_copy(dataset, tmp_path, dropped) -> Path:
    """A copy of ``dataset`` whose first sample's echoes.npz lacks the arrays ``dropped(name)``
    selects, as an older mitsonar wrote it (manifest intact)."""
    copy = tmp_path / "copy"
    shutil.copytree(dataset, copy)
    folder = copy / "samples" / "000000"
    with np.load(folder / "echoes.npz") as data:
        old = {k: data[k] for k in data.files if not dropped(k)}
    with open(folder / "echoes.npz", "wb") as f:
        np.savez_compressed(f, **old)
    manifest = json.loads((folder / "manifest.json").read_text())
    blob = (folder / "echoes.npz").read_bytes()
    manifest["echoes.npz"] = {"bytes": len(blob), "sha256": hashlib.sha256(blob).hexdigest()}
    (folder / "manifest.json").write_text(json.dumps(manifest))
    return copy


def test_sample_without_echo_table_is_named_and_writes_nothing(dataset, tmp_path, capsys):
    """A sample rendered before datasets kept every echo (no ``echo_`` arrays, manifest intact)
    stops the export with one line naming its file."""
    copy = _older_copy(dataset, tmp_path, lambda name: name.startswith("echo_"))
    out = tmp_path / "out" / "dataset.mcap"
    assert main(["dataset", "export", str(copy), "--out", str(out)]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if "error" in line]
    assert len(err) == 1 and "000000/echoes.npz: no echo table" in err[0]
    assert not out.exists()


def test_sample_without_off_beam_column_reads_as_no_replaced_echo(dataset, tmp_path):
    """A sample rendered before the echo table's ``off_beam`` column exports; its echoes read as
    none re-placed (that mitsonar never re-placed one)."""
    copy = _older_copy(dataset, tmp_path, lambda name: name == "echo_off_beam")
    table = echo_table(open_dataset(copy)[0].echoes, "000000")
    assert len(table.beam) > 0 and not table.off_beam.any()
    out = tmp_path / "out" / "dataset.mcap"
    assert main(["dataset", "export", str(copy), "--out", str(out)]) == 0 and out.exists()


def test_foxglove_layout_shows_recorded_topics_and_frames():
    layout = json.loads((ROOT / "docs" / "foxglove_layout.json").read_text())
    text = json.dumps(layout)
    topics = set(re.findall(r'"(/[a-z_/]+)', text))
    paths = {p["value"].split(".")[0] for p in layout["configById"]["Plot!drift"]["paths"]}
    assert topics | paths <= set(TOPICS) and "/sonar/detections" in topics
    assert layout["configById"]["3D!mitsonar"]["followTf"] == "base_link"
    tiles = layout["layout"]
    panels = {tiles["first"], tiles["second"]["first"], tiles["second"]["second"]}
    assert set(layout["configById"]) == panels
