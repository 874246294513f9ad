"""Helpers shared by the tests: repository paths and common poses (scene XML pieces are in
``mitsonar.scene.xml``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import mitsonar

#: The repository's root, and its shipped scenes.
ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "scenes"

#: The sensor sits at the world origin looking along +z (world frame = sensor frame).
IDENTITY = mitsonar.Pose.identity()
BROADSIDE = np.array([0.0, 0.0, 1.0])


# ---- MCAP recordings (tests/data/test_*mcap*.py, tests/cli/test_scenes_mcap_cli.py) ----
def read_mcap(path) -> list:
    """(topic, log time [ns], decoded message) of every message of an MCAP file, in time order."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        return [(channel.topic, message.log_time, decoded)
                for _, channel, message, decoded in reader.iter_decoded_messages()]


def ros_pose(p) -> mitsonar.Pose:
    """Pose of a decoded geometry_msgs Pose or Transform."""
    from scipy.spatial.transform import Rotation

    t = getattr(p, "position", None) or p.translation
    q = getattr(p, "orientation", None) or p.rotation
    return mitsonar.Pose(Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix(), [t.x, t.y, t.z])


def tf_tree(read, ns) -> dict:
    """child -> (parent, parent_from_child) of /tf_static and the /tf messages at ``ns``."""
    tree = {}
    for topic, time, m in read:
        if topic == "/tf_static" or (topic == "/tf" and time == ns):
            for tf in m.transforms:
                tree[tf.child_frame_id] = (tf.header.frame_id, ros_pose(tf.transform))
    return tree


def world_from(tree, frame) -> mitsonar.Pose:
    """World-from-``frame`` pose through a :func:`tf_tree`."""
    pose = mitsonar.Pose.identity()
    while frame != "world":
        frame, parent_from_child = tree[frame]
        pose = parent_from_child @ pose
    return pose
