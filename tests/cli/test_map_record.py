"""``--record FILE.mcap`` of the map commands (the repeated mode's recording is checked beam by
beam in tests/data/test_map_mcap.py)."""

import numpy as np

from mitsonar.cli import main
from mitsonar.data.ros_messages import cloud_columns
from helpers import read_mcap


def test_surfel_run_by_scene_name_records_mcap(tmp_path):
    out = tmp_path / "run.mcap"
    assert main(["map", "surfel", "room_glass", "--out", str(tmp_path / "map"), "--frames", "1",
                 "--width", "120", "--spp", "1", "--record", str(out)]) == 0
    read = read_mcap(out)
    topics = {topic for topic, _, _ in read}
    assert {"/tf_static", "/tf", "/odom", "/ground_truth/pose", "/camera/image",
            "/camera/camera_info", "/sonar/detections", "/map"} == topics
    (image,) = [m for topic, _, m in read if topic == "/camera/image"]
    assert image.encoding == "mono8" and image.width == 120
    clouds = [cloud_columns(m) for topic, _, m in read if topic == "/sonar/detections"]
    assert sum(len(c["x"]) for c in clouds) >= 4  # the surfels' pings that heard an echo
    assert all(np.all(c["amplitude"] > 0) and np.all(c["z"] > 0) for c in clouds)
    assert all(time == 0 for topic, time, _ in read if topic != "/odom")
