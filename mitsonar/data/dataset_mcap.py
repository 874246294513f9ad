"""MCAP export of a rendered dataset (``mitsonar dataset export DIR --out FILE.mcap``).

Every sample k gives, at its time t_k [s] on the trajectory's clock: the robot's frames
(``/tf``), its drifting odometry (``/odom``, twist from the odometry poses' differences) and
ground truth (``/ground_truth/pose``), the camera's sRGB image (the pixels of ``rgb.png``), its
z-depth and calibration, one ``/sonar/detections`` cloud with every echo of the scan (the rows of
the echo table in ``echoes.npz``, with their attributes) and one ``/sonar/echoes`` message per
beam. The dataset renders a sample's scan from one pose at one instant, so all its beams carry
the sample's time. The fixed frames (``/tf_static``) come from the dataset's calibration. Every
file is verified against its sample's manifest first; a missing, truncated or corrupt file (or a
sample without an echo table) stops the export with a
:class:`~mitsonar.data.dataset.DatasetError` naming it, and no MCAP file is written.
"""

from __future__ import annotations

from dataclasses import fields

import numpy as np

from mitsonar.data.dataset import DatasetError, open_dataset
from mitsonar.data.mcap_recorder import PULSE_CODE, record
from mitsonar.data.ros_frames import body_twist
from mitsonar.frames import Pose
from mitsonar.sensors.camera import srgb8
from mitsonar.signal.detection import Echoes


def _pose(matrix) -> Pose:
    m = np.asarray(matrix, dtype=float)
    return Pose(m[:3, :3], m[:3, 3])


def echo_table(arrays: dict, source: str) -> Echoes:
    """The echo table of a sample's ``echoes.npz`` arrays (its ``echo_`` columns; datasets
    rendered before the ``off_beam`` column read as having no re-placed echo);
    :class:`~mitsonar.data.dataset.DatasetError` naming ``source`` if it has none or lacks
    another column."""
    if "echo_beam" not in arrays:
        raise DatasetError(f"{source}: no echo table (rendered before datasets recorded every "
                           f"echo); render the dataset again")
    columns = {f.name: arrays.get("echo_" + f.name) for f in fields(Echoes)}
    if columns["off_beam"] is None:  # rendered before off-beam re-placement existed: none was
        columns["off_beam"] = np.zeros(len(columns["beam"]), dtype=bool)
    missing = [name for name, column in columns.items() if column is None]
    if missing:
        raise DatasetError(f"{source}: echo table lacks {', '.join(missing)}; render the dataset "
                           f"again")
    return Echoes(**columns)


def export_dataset(path, out, progress=None) -> dict:
    """Write dataset ``path`` as the MCAP file ``out`` (atomically); ``progress`` is called with
    each sample's index. Returns the message count per topic."""
    ds = open_dataset(path)
    meta = ds.meta
    times = np.asarray(meta["times_s"], dtype=float)
    truth = np.asarray(meta["robot_poses_truth"], dtype=float)
    odometry = np.asarray(meta["robot_poses_odometry"], dtype=float)
    twist = body_twist(times, odometry)
    calib = meta["calibration"]
    channels = np.asarray(calib["rx_positions_m"], dtype=float)
    with record(out) as recorder:
        recorder.static_frames(times[0], _pose(calib["robot_from_sensor"]),
                               _pose(calib["camera_from_sensor"]))
        for k in range(len(ds)):
            sample = ds[k]  # checks every file of the sample against its manifest
            t = times[k]
            recorder.robot_frames(t, truth[k], odometry[k])
            recorder.odometry(t, truth[k], odometry[k], twist[k])
            recorder.camera(t, calib["camera_intrinsics_px"], srgb8(sample.rgb), "rgb8",
                            depth=sample.depth.reshape(sample.depth.shape[:2]))
            e = sample.echoes
            detected = np.asarray(e["detected"], dtype=bool)
            recorder.detections(t, echo_table(e, f"{ds.path}/samples/{k:06d}/echoes.npz"),
                                PULSE_CODE)
            for b in range(len(detected)):
                recorder.echoes(t, beam=b, code=PULSE_CODE, direction=e["directions"][b],
                                channel_positions=channels, echoes=e["echoes"][b],
                                sample_rate=float(e["sample_rate"]),
                                start_time=float(e["start_time"]),
                                carrier=float(e["carrier_frequency"]), detected=detected[b],
                                depth=float(e["depth"][b]), amplitude=float(e["amplitude"][b]))
            if progress is not None:
                progress(k)
    return dict(recorder.counts)
