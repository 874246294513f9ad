"""Thinning to one seeded point per voxel and voxel means, against hand-computed cases."""

import numpy as np
import pytest

from mitsonar.recon.thinning import VoxelThinner, voxel_means
from mitsonar.recon.voxelmap import VoxelMapSettings, voxelise


def test_thinner_keeps_one_input_point_per_voxel_whatever_the_batches():
    rng = np.random.default_rng(1)
    points = rng.uniform(0.0, 0.1, size=(5000, 3))  # 10 x 10 x 10 voxels of 1 cm
    whole = VoxelThinner(0.01, seed=3)
    whole.add(points)
    kept = whole.result()
    cells = np.floor(kept / 0.01).astype(int)
    assert len(np.unique(cells, axis=0)) == len(kept) == len(np.unique(
        np.floor(points / 0.01).astype(int), axis=0))
    assert {tuple(p) for p in kept} <= {tuple(p) for p in points}  # points, not means
    batched = VoxelThinner(0.01, seed=3, batch=700)
    for part in np.array_split(points, 9):
        batched.add(part)
        batched.result()  # reading the cloud so far does not change the final one
    np.testing.assert_array_equal(batched.result(), kept)
    assert batched.raw == len(points)
    other = VoxelThinner(0.01, seed=4)
    other.add(points)
    assert not np.array_equal(other.result(), kept)  # the seed picks the point
    labelled = VoxelThinner(0.01, seed=3, batch=700)
    for part, label in zip(np.array_split(points, 9), range(9)):
        labelled.add(part, np.full(len(part), label))
    kept_labelled, labels = labelled.labelled_result()
    np.testing.assert_array_equal(kept_labelled, kept)  # labels do not change the choice
    owner = {tuple(p): k for k, part in enumerate(np.array_split(points, 9)) for p in part}
    assert labels.tolist() == [owner[tuple(p)] for p in kept_labelled]  # each keeps its own


def test_voxel_means_average_each_voxel_and_leave_a_voxel_map_unchanged():
    points = np.array([[0.01, 0.01, 0.01], [0.03, 0.03, 0.01], [0.06, 0.01, 0.01]])
    means = voxel_means(points, 0.05)
    np.testing.assert_allclose(sorted(map(tuple, means)), [(0.02, 0.02, 0.01),
                                                           (0.06, 0.01, 0.01)])
    cloud = np.random.default_rng(0).uniform(-1, 1, size=(2000, 3))
    voxel_map = voxelise(cloud, np.full(cloud.shape, np.nan),
                         VoxelMapSettings(voxel_size=0.05, outlier_neighbours=0)).positions
    np.testing.assert_allclose(voxel_means(voxel_map, 0.05), voxel_map)
    assert voxel_means(np.zeros((0, 3)), 0.05).shape == (0, 3)
    with pytest.raises(ValueError, match="voxel"):
        voxel_means(points, 0.0)
