"""Point clouds brought to a common resolution (before they are scored; a surfel map's samples):
one seeded random point per voxel (:class:`VoxelThinner`, the ground truth's 1 cm: noise is not
averaged away) or the mean of each voxel's points (:func:`voxel_means`, a voxel map's own
resolution)."""

from __future__ import annotations

import numpy as np

from mitsonar.recon.voxelmap import VoxelMapSettings, voxelise
from mitsonar.validation import check_positive


class VoxelThinner:
    """One point per occupied ``voxel`` [m] cube of all the points added, a seeded random one
    of them (each point draws a key from ``default_rng(seed)`` as it comes; a cube keeps its
    smallest-key point), kept as the points come: at most ``batch`` points wait between two
    compactions. The result does not depend on when compactions happen, so :meth:`result` may
    be read at any time (the cloud so far) without changing the final one."""

    def __init__(self, voxel: float = 0.01, seed: int = 0, batch: int = 4_000_000):
        check_positive("VoxelThinner.voxel [m]", voxel)
        self.voxel, self.batch = voxel, batch
        self.rng = np.random.default_rng(seed)
        self.points, self.keys, self.labels = np.zeros((0, 3)), np.zeros(0), np.zeros(0, int)
        self.waiting, self.raw = [], 0

    def add(self, points, labels=None) -> None:
        """Add points (N, 3) [m], each with an integer label (N,) that stays with it (default
        0; e.g. a surfel map's plane group)."""
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        labels = np.zeros(len(points), int) if labels is None else np.asarray(labels, int)
        self.waiting.append((points, labels))
        self.raw += len(points)
        if sum(len(p) for p, _ in self.waiting) >= self.batch:
            self._compact()

    def _compact(self) -> None:
        new = [p for p, _ in self.waiting]
        points = np.concatenate([self.points] + new)
        labels = np.concatenate([self.labels] + [q for _, q in self.waiting])
        keys = np.concatenate([self.keys, self.rng.random(len(points) - len(self.points))])
        cell = cell_index(points, self.voxel)
        order = np.argsort(keys, kind="stable")  # by key, then (stable) by cell: each
        order = order[np.argsort(cell[order], kind="stable")]  # cell's smallest key first
        first = np.ones(len(order), dtype=bool)
        first[1:] = cell[order[1:]] != cell[order[:-1]]
        keep = np.sort(order[first])
        self.points, self.keys, self.labels = points[keep], keys[keep], labels[keep]
        self.waiting = []

    def result(self) -> np.ndarray:
        """The thinned points so far (M, 3) [m]."""
        self._compact()
        return self.points.copy()

    def labelled_result(self) -> tuple[np.ndarray, np.ndarray]:
        """The thinned points so far (M, 3) [m] and their labels (M,)."""
        self._compact()
        return self.points.copy(), self.labels.copy()


def cell_index(points, voxel: float) -> np.ndarray:
    """(N,) int64 index of each point's (N, 3) [m] ``voxel`` [m] cube, unique within the points'
    bounding box (one sort key instead of three: 2.8x faster to sort)."""
    cells = np.floor(points / voxel).astype(np.int64)
    if not len(cells):
        return np.zeros(0, np.int64)
    cells -= cells.min(axis=0)
    span = cells.max(axis=0) + 1
    if np.prod(span.astype(float)) >= 2.0 ** 62:
        raise ValueError(f"points span {span.tolist()} cubes of {voxel} m: too many to index")
    return (cells[:, 0] * span[1] + cells[:, 1]) * span[2] + cells[:, 2]


def voxel_means(points, voxel: float) -> np.ndarray:
    """(M, 3) mean [m] of the points (N, 3) [m] in each occupied ``voxel`` [m] cube of the grid
    with a corner at the world origin: the repeated-scanning map's own voxelisation
    (:func:`mitsonar.recon.voxelmap.voxelise`, no outlier removal), so a voxel map of that size
    comes out unchanged."""
    check_positive("voxel [m]", voxel)
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    if not len(p):
        return np.zeros((0, 3))
    settings = VoxelMapSettings(voxel_size=voxel, outlier_neighbours=0)
    return voxelise(p, np.full(p.shape, np.nan), settings).positions
