"""MCAP recordings of mitsonar's sensors with ROS 2 messages (docs/mcap.md).

Topics (:data:`TOPICS`): the frame tree on ``/tf_static`` and ``/tf``
(:mod:`mitsonar.data.ros_frames`), the drifting wheel odometry on ``/odom`` beside the ground
truth on ``/ground_truth/pose``, the camera's images and calibration, the sonar's detections
(``PointCloud2``: every echo, with fields x, y, z [m], amplitude [Pa], beam, code, rank, snr,
arrival direction and coherence) and per-channel echoes (``mitsonar_msgs/SonarEchoes``), and a
map's final point cloud. Every message is logged at its
simulated time (its header's stamp). Files are written atomically: a failed or interrupted
recording leaves no file behind.
"""

from __future__ import annotations

from collections import Counter
from contextlib import contextmanager

import numpy as np

from mitsonar.data import ros_messages as msg
from mitsonar.io import atomic_path
from mitsonar.data.ros_frames import (BASE_LINK, CAMERA_OPTICAL, ODOM, SONAR_OPTICAL, WORLD,
                                      robot_transforms, static_transforms)
from mitsonar.data.ros_schemas import definition, schema_name
from mitsonar.frames import Pose
from mitsonar.signal.detection import Echoes

#: Topic -> message type.
TOPICS = {
    "/tf_static": "tf2_msgs/TFMessage",
    "/tf": "tf2_msgs/TFMessage",
    "/odom": "nav_msgs/Odometry",
    "/ground_truth/pose": "geometry_msgs/PoseStamped",
    "/camera/image": "sensor_msgs/Image",
    "/camera/depth": "sensor_msgs/Image",
    "/camera/camera_info": "sensor_msgs/CameraInfo",
    "/sonar/detections": "sensor_msgs/PointCloud2",
    "/sonar/echoes": "mitsonar_msgs/SonarEchoes",
    "/map": "sensor_msgs/PointCloud2",
}
#: ``code`` of beams fired with the scan's single pulse (not an OFDM code).
PULSE_CODE = -1


class McapRecorder:
    """Writes mitsonar's topics as MCAP.

    Args:
        stream: writable binary file to write each message into at once (see :func:`record`);
            None keeps the messages until :meth:`save` writes them in time order (for runs
            that do not produce them in time order; nothing is written if the run fails).
    """

    def __init__(self, stream=None):
        self._pending: list = []
        self._schemas: dict = {}
        self.counts: Counter = Counter()  # messages written per topic
        self._writer = None if stream is None else _writer(stream)

    def write(self, topic: str, t: float, message: dict) -> None:
        """Log ``message`` on ``topic`` at simulated time ``t`` [s]."""
        if self._writer is None:
            self._pending.append((msg.nanoseconds(t), len(self._pending), topic, message))
        else:
            self._write(msg.nanoseconds(t), topic, message)

    def _write(self, ns: int, topic: str, message: dict) -> None:
        kind = TOPICS[topic]
        if kind not in self._schemas:
            self._schemas[kind] = self._writer.register_msgdef(schema_name(kind), definition(kind))
        self._writer.write_message(topic, self._schemas[kind], message, log_time=ns,
                                   publish_time=ns, sequence=self.counts[topic])
        self.counts[topic] += 1

    def save(self, path) -> dict:
        """Write the kept messages in time order as the MCAP file ``path`` (atomically); returns
        the message count per topic."""
        with atomic_path(path) as tmp:
            with open(tmp, "wb") as stream:
                self._writer = _writer(stream)
                for ns, _, topic, message in sorted(self._pending, key=lambda m: m[:2]):
                    self._write(ns, topic, message)
                self.finish()
        return dict(self.counts)

    def finish(self) -> None:
        """Close the MCAP stream (writes its summary and index)."""
        self._writer.finish()

    def static_frames(self, t: float, robot_from_sensor: Pose, camera_from_sensor: Pose) -> None:
        """The fixed frames (``/tf_static``) of a sensor mount and camera extrinsic."""
        self.write("/tf_static", t, msg.tf_message(
            t, static_transforms(robot_from_sensor, camera_from_sensor)))

    def robot_frames(self, t: float, truth, odometry) -> None:
        """``world -> odom -> base_link`` (``/tf``) for robot poses (x [m], y [m], yaw [rad])."""
        self.write("/tf", t, msg.tf_message(t, robot_transforms(truth, odometry)))

    def odometry(self, t: float, truth, odometry, twist) -> None:
        """``/odom`` (odometry pose and twist, see :func:`~mitsonar.data.ros_messages.odometry`)
        and ``/ground_truth/pose`` (the true ``base_link`` in ``world``)."""
        self.write("/odom", t, msg.odometry(t, ODOM, BASE_LINK, Pose.planar(*odometry), twist))
        self.write("/ground_truth/pose", t, msg.pose_stamped(t, WORLD, Pose.planar(*truth)))

    def camera(self, t: float, intrinsics, pixels: np.ndarray, encoding: str,
               depth: np.ndarray | None = None) -> None:
        """An image (``/camera/image``: 'rgb8' or 'mono8'), its calibration and optionally the
        z-depth [m] (``/camera/depth``, '32FC1', inf where nothing was hit)."""
        height, width = pixels.shape[:2]
        self.write("/camera/image", t, msg.image(t, CAMERA_OPTICAL, pixels, encoding))
        self.write("/camera/camera_info", t,
                   msg.camera_info(t, CAMERA_OPTICAL, intrinsics, width, height))
        if depth is not None:
            self.write("/camera/depth", t,
                       msg.image(t, CAMERA_OPTICAL, np.asarray(depth, np.float32), "32FC1"))

    def detections(self, t: float, echoes: Echoes, code) -> None:
        """``/sonar/detections``: every echo of ``echoes`` (points in ``sonar_optical``), one
        point each with its amplitude [Pa], beam index, rank in its beam, SNR, unit arrival
        direction, coherence and OFDM code (``code``: (E,) or one for all;
        :data:`PULSE_CODE` for pulses)."""
        points = np.asarray(echoes.point, dtype=np.float32).reshape(-1, 3)
        arrival = np.asarray(echoes.direction, dtype=np.float32).reshape(-1, 3)
        self.write("/sonar/detections", t, msg.point_cloud(t, SONAR_OPTICAL, {
            "x": points[:, 0], "y": points[:, 1], "z": points[:, 2],
            "amplitude": np.asarray(echoes.amplitude, np.float32),
            "beam": np.asarray(echoes.beam, np.uint32),
            "code": np.broadcast_to(np.asarray(code, np.int32), (len(points),)),
            "rank": np.asarray(echoes.rank, np.uint32),
            "snr": np.asarray(echoes.snr, np.float32),
            "arrival_x": arrival[:, 0], "arrival_y": arrival[:, 1], "arrival_z": arrival[:, 2],
            "coherence": np.asarray(echoes.coherence, np.float32)}))

    def echoes(self, t: float, **beam) -> None:
        """``/sonar/echoes``: one beam's echoes (keywords of
        :func:`~mitsonar.data.ros_messages.sonar_echoes`), in ``sonar_optical``."""
        self.write("/sonar/echoes", t, msg.sonar_echoes(t, SONAR_OPTICAL, **beam))

    def map(self, t: float, points, colours=None, **scalars) -> None:
        """``/map``: points (N, 3) [m] in ``world``, optional colours (N, 3) in [0, 1] as a
        packed 'rgb' field (PCL convention), and float32 scalar fields (N,)."""
        points = np.asarray(points, dtype=np.float32).reshape(-1, 3)
        columns = {"x": points[:, 0], "y": points[:, 1], "z": points[:, 2]}
        if colours is not None:
            rgb = np.round(np.clip(np.asarray(colours, float), 0, 1) * 255).astype(np.uint32)
            packed = (rgb[:, 0] << 16) | (rgb[:, 1] << 8) | rgb[:, 2]
            columns["rgb"] = packed.view(np.float32)
        columns.update({name: np.asarray(v, np.float32) for name, v in scalars.items()})
        self.write("/map", t, msg.point_cloud(t, WORLD, columns))


def describe(path, counts: dict) -> str:
    """One line naming a recording, its message count and its topics."""
    return (f"{path}: {sum(counts.values())} messages on {len(counts)} topics "
            f"({', '.join(sorted(counts))}); docs/mcap.md says how to open it in Foxglove")


@contextmanager
def record(path):
    """Yield a :class:`McapRecorder` writing each message into ``path`` at once; the file
    appears only if the block succeeds (an error leaves no partial recording)."""
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as stream:
            recorder = McapRecorder(stream)
            yield recorder
            recorder.finish()


def _writer(stream):
    from mcap_ros2.writer import Writer

    return Writer(stream)  # zstd-compressed chunks of 1 MiB, CRCs
