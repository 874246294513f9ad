"""ROS 2 messages as the dictionaries ``mcap_ros2`` encodes (field names of
``mitsonar/data/msg``); simulated times in seconds, poses as :class:`~mitsonar.frames.Pose`."""

from __future__ import annotations

import numpy as np

from mitsonar.frames import Pose

#: PointField datatype codes by NumPy type.
_POINT_FIELD_TYPES = {np.dtype(np.int8): 1, np.dtype(np.uint8): 2, np.dtype(np.int16): 3,
                      np.dtype(np.uint16): 4, np.dtype(np.int32): 5, np.dtype(np.uint32): 6,
                      np.dtype(np.float32): 7, np.dtype(np.float64): 8}


def nanoseconds(t: float) -> int:
    """Simulated time [s] -> integer nanoseconds (MCAP log times, ROS stamps)."""
    if not (np.isfinite(t) and t >= 0):
        raise ValueError(f"message time must be finite and >= 0 s, got {t}")
    return int(round(float(t) * 1e9))


def header(t: float, frame: str) -> dict:
    sec, nanosec = divmod(nanoseconds(t), 1_000_000_000)
    return {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": frame}


def quaternion(rotation) -> dict:
    """Unit quaternion {x, y, z, w} of a (3, 3) rotation matrix, w >= 0."""
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(np.asarray(rotation, dtype=float)).as_quat()
    if w < 0:
        x, y, z, w = -x, -y, -z, -w
    return {"x": float(x), "y": float(y), "z": float(z), "w": float(w)}


def _xyz(v) -> dict:
    return dict(zip("xyz", map(float, v)))


def pose(p: Pose) -> dict:
    """geometry_msgs/Pose."""
    return {"position": _xyz(p.translation), "orientation": quaternion(p.rotation)}


def transform(t: float, parent: str, child: str, parent_from_child: Pose) -> dict:
    """geometry_msgs/TransformStamped."""
    return {"header": header(t, parent), "child_frame_id": child,
            "transform": {"translation": _xyz(parent_from_child.translation),
                          "rotation": quaternion(parent_from_child.rotation)}}


def tf_message(t: float, transforms) -> dict:
    """tf2_msgs/TFMessage of (parent, child, parent_from_child) triples."""
    return {"transforms": [transform(t, *entry) for entry in transforms]}


def pose_stamped(t: float, frame: str, p: Pose) -> dict:
    """geometry_msgs/PoseStamped."""
    return {"header": header(t, frame), "pose": pose(p)}


def odometry(t: float, frame: str, child: str, p: Pose, twist) -> dict:
    """nav_msgs/Odometry: pose ``p`` of ``child`` in ``frame``; twist (forward [m/s], leftward
    [m/s], yaw rate [rad/s]) in ``child``; covariances zero (not estimated)."""
    forward, left, yaw_rate = map(float, twist)
    zeros = [0.0] * 36
    return {"header": header(t, frame), "child_frame_id": child,
            "pose": {"pose": pose(p), "covariance": zeros},
            "twist": {"twist": {"linear": _xyz((forward, left, 0.0)),
                                "angular": _xyz((0.0, 0.0, yaw_rate))}, "covariance": zeros}}


def point_cloud(t: float, frame: str, columns: dict) -> dict:
    """sensor_msgs/PointCloud2 of one row of points: ``columns`` maps field names to (N,) arrays
    (their dtypes are the fields' types), 'x', 'y', 'z' first; little-endian, packed."""
    arrays = {name: np.asarray(values) for name, values in columns.items()}
    dtype = np.dtype([(name, a.dtype.newbyteorder("<")) for name, a in arrays.items()])
    n = len(arrays["x"])
    points = np.empty(n, dtype=dtype)
    for name, a in arrays.items():
        points[name] = a
    fields = [{"name": name, "offset": dtype.fields[name][1],
               "datatype": _POINT_FIELD_TYPES[a.dtype.newbyteorder("=")], "count": 1}
              for name, a in arrays.items()]
    finite = all(np.all(np.isfinite(arrays[k])) for k in "xyz")
    return {"header": header(t, frame), "height": 1, "width": n, "fields": fields,
            "is_bigendian": False, "point_step": dtype.itemsize,
            "row_step": dtype.itemsize * n, "data": points.tobytes(), "is_dense": bool(finite)}


def cloud_columns(message) -> dict:
    """Inverse of :func:`point_cloud` for a decoded message: field name -> (N,) array."""
    types = {code: dtype for dtype, code in _POINT_FIELD_TYPES.items()}
    dtype = np.dtype({"names": [f.name for f in message.fields],
                      "formats": [types[f.datatype].newbyteorder("<") for f in message.fields],
                      "offsets": [f.offset for f in message.fields],
                      "itemsize": message.point_step})
    points = np.frombuffer(bytes(message.data), dtype=dtype, count=message.width * message.height)
    return {name: points[name].astype(points[name].dtype.newbyteorder("=")) for name in dtype.names}


def image(t: float, frame: str, pixels: np.ndarray, encoding: str) -> dict:
    """sensor_msgs/Image of (H, W) or (H, W, C) pixels in a ROS encoding ('rgb8', 'mono8',
    '32FC1'); little-endian."""
    a = np.ascontiguousarray(pixels)
    a = a.astype(a.dtype.newbyteorder("<"), copy=False)
    height, width = a.shape[:2]
    return {"header": header(t, frame), "height": height, "width": width, "encoding": encoding,
            "is_bigendian": 0, "step": a.strides[0], "data": a.tobytes()}


def camera_info(t: float, frame: str, intrinsics, width: int, height: int) -> dict:
    """sensor_msgs/CameraInfo of an ideal pinhole camera (no distortion, no rectification)."""
    k = np.asarray(intrinsics, dtype=float).reshape(3, 3)
    return {"header": header(t, frame), "height": int(height), "width": int(width),
            "distortion_model": "plumb_bob", "d": [0.0] * 5, "k": k.ravel().tolist(),
            "r": np.eye(3).ravel().tolist(), "p": np.hstack([k, np.zeros((3, 1))]).ravel().tolist(),
            "binning_x": 0, "binning_y": 0,
            "roi": {"x_offset": 0, "y_offset": 0, "height": 0, "width": 0, "do_rectify": False}}


def sonar_echoes(t: float, frame: str, beam: int, code: int, direction, channel_positions,
                 echoes: np.ndarray, sample_rate: float, start_time: float, carrier: float,
                 detected: bool, depth: float, amplitude: float) -> dict:
    """mitsonar_msgs/SonarEchoes of one beam: ``echoes`` (channels, samples) float32 pressure or
    complex64 baseband [Pa] (``carrier`` > 0), the rest as in the message definition."""
    complex_ = np.iscomplexobj(echoes)
    values = np.ascontiguousarray(echoes, dtype="<c8" if complex_ else "<f4")
    return {"header": header(t, frame), "beam": int(beam), "code": int(code),
            "direction": _xyz(direction),
            "channel_positions": [_xyz(p) for p in np.asarray(channel_positions, dtype=float)],
            "sample_rate": float(sample_rate), "start_time": float(start_time),
            "carrier_frequency": float(carrier), "samples": int(values.shape[-1]),
            "encoding": "32FC2" if complex_ else "32FC1", "is_bigendian": 0,
            "data": values.tobytes(), "detected": bool(detected), "depth": float(depth),
            "amplitude": float(amplitude)}


def echo_samples(message) -> np.ndarray:
    """Inverse of :func:`sonar_echoes` for a decoded message: (channels, samples) array."""
    dtype = "<c8" if message.encoding == "32FC2" else "<f4"
    return np.frombuffer(bytes(message.data), dtype=dtype).reshape(-1, message.samples)
