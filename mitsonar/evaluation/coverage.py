"""Completeness as a map grows: the fraction of ground-truth samples covered by the cloud taken
so far, at checkpoints along a drive, against the distance driven (the curves of the sensor
comparison, ``experiments/comparison.py``).

Covered is :func:`mitsonar.evaluation.metrics.evaluate`'s definition: a sample is covered when a
reconstructed point lies within the threshold of it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mitsonar.evaluation.metrics import visible_from
from mitsonar.frames import Pose
from mitsonar.physics.beampattern import in_fov
from mitsonar.plots import _pyplot, save_png
from mitsonar.sensors.trajectory import Trajectory
from mitsonar.validation import check_finite, check_positive

#: Poses are sampled this often to measure the distance driven [s].
DISTANCE_STEP = 0.05
#: Classes of ground-truth surface (:func:`surface_classes`): horizontal surfaces below the
#: sensor head (floor, desk and seat tops: seen from above), horizontal ones above it (ceiling,
#: lamps: seen from below, or not at all by a forward-looking sensor), vertical ones (walls,
#: the sides of furniture) and the rest.
SURFACE_CLASSES = ("below", "above", "vertical", "sloped")
#: A surface is horizontal (vertical) where its normal lies within this angle of the vertical
#: (of the horizontal plane) [rad].
SURFACE_CLASS_TOLERANCE = np.radians(25.0)


def covered_fraction(points, sample_points, threshold: float) -> float:
    """Fraction of the samples (M, 3) [m] with one of the points (N, 3) [m] within ``threshold``
    [m] (NaN without samples; 0 without points)."""
    from scipy.spatial import cKDTree

    check_positive("threshold [m]", threshold)
    s = np.asarray(sample_points, dtype=float).reshape(-1, 3)
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    if not len(s):
        return float("nan")
    if not len(p):
        return 0.0
    gap, _ = cKDTree(p).query(s, distance_upper_bound=threshold)
    return float(np.mean(gap <= threshold))


def surface_classes(normals, heights, sensor_height: float) -> np.ndarray:
    """(M,) index into :data:`SURFACE_CLASSES` of surface samples with unit ``normals`` (M, 3)
    (world frame, z up; either orientation) at ``heights`` (M,) [m], the sensor head at
    ``sensor_height`` [m]."""
    nz = np.abs(np.asarray(normals, dtype=float).reshape(-1, 3)[:, 2])
    z = np.asarray(heights, dtype=float).reshape(-1)
    if len(nz) != len(z):
        raise ValueError(f"surface_classes: {len(nz)} normals but {len(z)} heights")
    check_finite("sensor height [m]", sensor_height)
    horizontal = nz >= np.cos(SURFACE_CLASS_TOLERANCE)
    vertical = nz <= np.sin(SURFACE_CLASS_TOLERANCE)
    return np.select([horizontal & (z < sensor_height), horizontal, vertical], [0, 1, 2], 3)


def covered_by_class(covered, classes) -> dict:
    """Per name of :data:`SURFACE_CLASSES`: the share of the samples of that class (``classes``
    (M,), :func:`surface_classes`) that ``covered`` (M,) bool marks (NaN where it has none)."""
    hit = np.asarray(covered, dtype=bool).reshape(-1)
    cls = np.asarray(classes).reshape(-1)
    if len(hit) != len(cls):
        raise ValueError(f"covered_by_class: {len(hit)} flags but {len(cls)} classes")
    return {name: float(np.mean(hit[cls == k])) if np.any(cls == k) else float("nan")
            for k, name in enumerate(SURFACE_CLASSES)}


def in_sensor_view(scene, points, poses: list[Pose], fov_horizontal: float, fov_vertical: float,
                   max_range: float) -> np.ndarray:
    """(M,) True where a surface point (M, 3) [m] lies, at one or more of the world-from-sensor
    ``poses`` at least, inside the sensor's ``fov_horizontal`` x ``fov_vertical`` [rad] field of
    view, within ``max_range`` [m] and in its line of sight
    (:func:`~mitsonar.evaluation.metrics.visible_from`): what a sensor with that field of view
    could map from those poses, an upper bound of its completeness."""
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    seen = np.zeros(len(p), dtype=bool)
    for pose in poses:  # one vectorised batch of sight lines per pose
        todo = np.flatnonzero(~seen)
        local = pose.inverse().transform_points(p[todo])  # sensor frame
        todo = todo[in_fov(local, fov_horizontal, fov_vertical)]
        if len(todo):  # within range: visible_from's test
            seen[todo] = visible_from(scene, p[todo], pose.translation[None], max_range)
    return seen


def in_view_along(scene, points, trajectory: Trajectory, driven: float, config,
                  period: float) -> np.ndarray:
    """:func:`in_sensor_view` of the sonar ``config`` (a ``SonarConfig``: its field of view and
    ``max_range``) from the sensor head's poses ``period`` [s] apart over the first ``driven``
    [s] of ``trajectory``: (M,) bool per surface point (M, 3) [m]."""
    from mitsonar.sensors.trajectory import sensor_poses

    check_positive("period [s]", period)
    poses = sensor_poses(trajectory.poses_at(np.arange(0.0, driven + 1e-9, period)))
    geometry = config.geometry
    return in_sensor_view(scene, points, poses, geometry.fov_horizontal, geometry.fov_vertical,
                          config.max_range)


def distance_driven(trajectory: Trajectory, times) -> np.ndarray:
    """Path length of the robot's chassis [m] from the trajectory's start to each of ``times``
    (K,) [s] (turns on the spot add nothing), measured on poses ``DISTANCE_STEP`` apart."""
    t = np.asarray(times, dtype=float)
    end = float(np.max(t)) if t.size else 0.0
    grid = np.append(np.arange(0.0, end, DISTANCE_STEP), end)
    xy = trajectory.poses_at(grid)[:, :2]
    length = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))])
    return np.interp(t, grid, length)


@dataclass(frozen=True)
class Curve:
    """Completeness of one sensor's map along a drive.

    Attributes:
        label: the sensor (and preset) as drawn.
        distance: (K,) distance driven at each checkpoint [m].
        completeness: (K,) fraction of the observable samples covered at the fine threshold.
        completeness_voxel: (K,) the same for the cloud voxelised at the voxel size, covered
            within it.
    """

    label: str
    distance: np.ndarray
    completeness: np.ndarray
    completeness_voxel: np.ndarray


def save_completeness_figure(path, curves: dict, fine: float, voxel: float,
                             title: str = "") -> None:
    """One panel per scene (``curves``: scene -> list of :class:`Curve`): completeness [%]
    against the distance driven [m], at ``fine`` [m] (solid) and at the ``voxel`` size [m] of
    the voxelised clouds (dashed), a colour per curve."""
    plt = _pyplot()
    n = max(len(curves), 1)
    cols = min(n, 4)
    rows = int(np.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, squeeze=False, figsize=(4.6 * cols, 3.9 * rows + 0.8))
    colours = plt.get_cmap("tab10")
    for ax, (scene, scene_curves) in zip(axes.flat, curves.items()):
        for k, c in enumerate(scene_curves):
            ax.plot(c.distance, 100 * np.asarray(c.completeness), "-o", ms=3, lw=1.2,
                    color=colours(k % 10), label=c.label)
            ax.plot(c.distance, 100 * np.asarray(c.completeness_voxel), "--", lw=1.0,
                    color=colours(k % 10))
        ax.set_title(scene, fontsize=10)
        ax.set_xlabel("distance driven [m]")
        ax.set_ylabel("completeness [%]")
        ax.set_ylim(0, 100)
        ax.grid(True, lw=0.3, alpha=0.5)
        ax.legend(fontsize=7, loc="upper left")
    for ax in axes.flat[len(curves):]:
        ax.set_visible(False)
    fig.suptitle(title or f"completeness along the drive: solid within {100 * fine:.0f} cm, "
                          f"dashed {100 * voxel:.0f} cm voxels within {100 * voxel:.0f} cm",
                 fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    save_png(fig, path)
