"""MCAP recordings of map runs (``mitsonar map repeated|surfel ... --record FILE.mcap``).

A run is recorded on its simulated clock (the trajectory's time [s]): each camera image at the
time it was taken, each sonar echo (every row of the echo table, with its attributes) at its
beam's firing time, in ``sonar_optical`` (an OFDM frame's beams fire one slot apart while the
robot moves: one ``/sonar/detections`` cloud per beam, empty when the beam detected nothing;
single-ping images: one cloud per image, every point of it; a surfel run pings from a pose that
the robot holds: one cloud per scan, at the pose's time), and
the final map (``/map``, world frame) at the end. The robot's frames (``/tf``) are written at
every one of these times and at the wheel odometry's rate, so that a viewer places every
detection with its beam's exact pose. Map recordings carry no per-channel echoes (an OFDM cycle
records all its beams together; ``mitsonar dataset export`` has them).

Odometry: the ground truth sampled every :data:`ODOMETRY_PERIOD` along the trajectory, with the
drift of :class:`~mitsonar.sensors.trajectory.OdometryDrift` (seeded by the run's seed), and
interpolated linearly between its samples for the frames at other times.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from mitsonar.data.mcap_recorder import PULSE_CODE, McapRecorder
from mitsonar.data.ros_frames import body_twist
from mitsonar.data.ros_messages import nanoseconds
from mitsonar.frames import Pose
from mitsonar.sensors.camera import CameraModel, srgb8
from mitsonar.sensors.trajectory import OdometryDrift, Trajectory

#: Period of the recorded wheel odometry [s] (20 Hz).
ODOMETRY_PERIOD = 0.05


class RunTimeline:
    """Ground truth and drifting odometry of a run along ``trajectory`` from 0 to ``end`` [s]."""

    def __init__(self, trajectory: Trajectory, end: float, seed: int = 0,
                 drift: OdometryDrift = OdometryDrift()):
        self.trajectory = trajectory
        self.times = np.arange(0.0, end + 1e-9, ODOMETRY_PERIOD)
        self.truth = trajectory.poses_at(self.times)
        self.odometry = drift.apply(self.truth, seed=seed)

    def poses(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Ground-truth and odometry robot poses (x [m], y [m], yaw [rad]) at time ``t`` [s]."""
        odometry = np.array([np.interp(t, self.times, self.odometry[:, k]) for k in range(3)])
        return self.trajectory.poses_at([t])[0], odometry

    def record(self, recorder: McapRecorder, stamps) -> None:
        """``/odom`` and ``/ground_truth/pose`` at the odometry's samples, ``/tf`` at those and at
        every time of ``stamps`` [s]."""
        twist = body_twist(self.times, self.odometry)
        for k, t in enumerate(self.times):
            recorder.odometry(t, self.truth[k], self.odometry[k], twist[k])
        unique = {nanoseconds(t): t for t in [*stamps, *self.times]}
        for t in unique.values():
            recorder.robot_frames(t, *self.poses(t))


def record_repeated(path, scanned, voxels, trajectory: Trajectory, seed: int = 0) -> dict:
    """Record a repeated-scanning run (the frames and voxel map of
    :func:`~mitsonar.recon.repeated.map_repeated`) as ``path``; returns the messages per topic."""
    recorder = McapRecorder()
    camera = CameraModel().at_resolution(scanned[0].image.shape[1])
    recorder.static_frames(0.0, Pose.sensor_mount(), camera.camera_from_sensor())
    stamps = []
    for s in scanned:
        recorder.camera(s.start_time, camera.intrinsics(), srgb8(s.image), "rgb8")
        if s.frame is not None:  # an OFDM frame: a cloud per beam, at its firing time
            fired = s.start_time + s.frame.schedule.transmit_time
            table = s.frame.echo_table
            for b, t in enumerate(fired):
                recorder.detections(t, table.take(table.beam == b),
                                    s.frame.schedule.code_index[b])
        else:  # single-ping images: a cloud per image, at its firing time
            fired = np.array(s.image_times)
            for t, table in zip(fired, s.image_tables):
                recorder.detections(t, table, PULSE_CODE)
        stamps += [s.start_time, *fired]
    end = max(stamps)
    RunTimeline(trajectory, end, seed).record(recorder, stamps)
    recorder.map(end, voxels.positions, voxels.display_colours(), count=voxels.counts)
    return recorder.save(path)


class SurfelRunRecording:
    """Records a surfel run as it runs: pass :attr:`sonar` to
    :func:`~mitsonar.recon.surfels.map_surfels` instead of the run's sonar, then :meth:`save`.

    Args:
        sonar: the run's :class:`~mitsonar.sensors.sonar.Sonar`.
        trajectory: the trajectory the poses lie on.
        times: (P,) time of each pose on it [s].
        poses: the P world-from-sensor poses the run scans from.
        seed: seeds the odometry drift.
    """

    def __init__(self, sonar, trajectory: Trajectory, times, poses, seed: int = 0):
        self.recorder = McapRecorder()
        self.trajectory, self.times, self.seed = trajectory, np.asarray(times, float), seed
        self.sonar = _ScanLog(sonar, [p.matrix() for p in poses], self._detections)
        self._fired = np.zeros(len(self.times), dtype=int)  # beams fired so far at each pose

    def _detections(self, k: int, scan) -> None:
        """Log a scan fired from pose ``k``: its echoes at the pose's time, each beam numbered
        among every beam fired from that pose."""
        table = scan.echo_table
        self.recorder.detections(self.times[k], replace(table, beam=self._fired[k] + table.beam),
                                 PULSE_CODE)
        self._fired[k] += len(scan.detected)

    def save(self, path, surfel_map, points, plane) -> dict:
        """Add each pose's image and the final map (``points`` (M, 3) [m] sampled on it and
        their plane (M,), coloured as in the map's PLY) and write ``path``; returns the messages
        per topic."""
        from mitsonar.recon.surfels import plane_colours

        scans = surfel_map.scans
        self.recorder.static_frames(0.0, Pose.sensor_mount(), scans[0].camera.camera_from_sensor())
        # a driven run's frames were taken when the sonar was free, not at every pose listed
        times = surfel_map.times if len(surfel_map.times) else self.times
        for t, scan in zip(times, scans):
            self.recorder.camera(t, scan.camera.intrinsics(), srgb8(scan.gray), "mono8")
        end = float(self.times.max())
        RunTimeline(self.trajectory, end, self.seed).record(self.recorder, self.times)
        colours = plane_colours(max(len(surfel_map.groups), 1))[plane]
        self.recorder.map(end, points, colours, plane=plane)
        return self.recorder.save(path)


class _ScanLog:
    """Stands in for a Sonar: forwards everything, and hands every scan and the index of the
    pose it was fired from (the nearest of ``poses``, (4, 4) each) to ``log``."""

    def __init__(self, sonar, poses, log):
        self._sonar, self._poses, self._log = sonar, np.asarray(poses), log

    def __getattr__(self, name):
        return getattr(self._sonar, name)

    def scan(self, pose: Pose, directions, seed: int = 0, progress=None):
        scan = self._sonar.scan(pose, directions, seed=seed, progress=progress)
        k = int(np.argmin(np.abs(self._poses - pose.matrix()).sum(axis=(1, 2))))
        self._log(k, scan)
        return scan
