"""Ray density that follows range and footprint: neighbouring cells merged into one patch where
the patch model stays accurate at the patch's size.

**Accuracy criterion.** A hit stands for a planar patch (its ray's cell projected on the
surface) whose echo the tracer evaluates as the patch integral of the *linear* phase about its
centre, at the pulse's carrier (:mod:`mitsonar.trace.tracer`: A sinc sinc, one delay per element
pair). At a corner delta of the patch (range t, unit ray direction d), the true two-way path
length differs from the model's by the quadratic term |delta_perp|^2 / t (delta_perp the part
of delta across the ray: t (dd1 +- dd2) / 2 for a cell of ray differentials dd1, dd2), and the
linear term 2 (d . delta) that the model evaluates at the carrier's wavenumber k_c is off by
(k - k_c) 2 (d . delta) at another frequency of the band. The patch's phase error is the
largest over its corners at the band's top frequency (wavenumber k_top):

    phi = k_top t |dd1 +- dd2|^2 / 4 + (k_top - k_c) |d . (E1 +- E2)| + k_top |E1 +- E2| alpha,

E1, E2 the patch's edges (:func:`patch_phase_error`); the last term is a curved surface's own
departure from the patch's plane (two-way, its sagitta |delta| alpha_c / 2 at a corner whose
normal is alpha_c from the centre's, taken as twice the largest angle alpha between the merged
cells' normals and their mean). A patch with phi <= ``max_patch_phase``
(default pi / 8, the phase error at Fraunhofer's far-field distance 2 D^2 / lambda) is
as good as the finer patches it replaces. At normal incidence the allowed angular cell width
grows as 1 / sqrt(range): near surfaces need far fewer patches than the fixed grid gives them
(0.5 deg cells in the main lobe are 4 mm on a wall 0.5 m away, against a criterion of ~4 cm).

**Merging.** After the fixed grid is cast and refined, aligned blocks of p x q cells (p, q
powers of 2 up to ``max_merge``, the largest first) are replaced by one ray through the block's
centre where every cell of the block hit the same shape, with normals within
``refine_normal_angle`` and depths within 5 % of each other (the refinement's own tests of a
continuous surface), none was split, and the block's patch meets the criterion. The largest
such block wins. A block whose centre ray does not hit the same surface at the same depth keeps
its cells. A merged patch's diffuse (Lambert) phasor is the coherent sum of its cells' random
phasors, drawn as on the fixed grid, each with amplitude sqrt(its share of the block's area)
and the carrier phase of its two-way range to the block's centre
(``AcousticTracer._hit_roughness``): the same speckle realisation. Where the fixed grid is
coarser than the criterion asks (far surfaces outside the main lobe), it is kept as it is:
merging never makes the grid finer than the fixed one's default.
"""

from __future__ import annotations

import numpy as np

#: Largest relative depth difference within a block of one continuous surface (as the
#: refinement's depth-jump test).
DEPTH_JUMP = 0.05


def _rows_dot(a, b):
    """Dot products of 3-vectors along the last axis (broadcasting)."""
    return np.sum(a * b, axis=-1)


def patch_phase_error(t, d, normals, dd1, dd2, k_top: float, k_centre: float,
                      normal_spread=0.0) -> np.ndarray:
    """(H,) phase error [rad] of the patch model at the corners of patches of range ``t`` (H,)
    [m], unit ray directions ``d`` (H, 3), surface ``normals`` (H, 3), ray differentials
    ``dd1``, ``dd2`` (H, 3) and ``normal_spread`` (H,) [rad] (largest angle of the surface's
    normal within the patch to the patch's; 0 for a plane), at wavenumbers ``k_top`` (the
    band's top frequency) and ``k_centre`` (the carrier) [rad/m] (see the module docstring).
    Infinite at grazing incidence."""
    dn = _rows_dot(d, normals)
    grazing = np.abs(dn) < 1e-9
    dn = np.where(grazing, 1.0, dn)
    edges = [t[:, None] * (dd - d * (_rows_dot(dd, normals) / dn)[:, None]) for dd in (dd1, dd2)]
    errors = []
    for sign in (1.0, -1.0):  # the two diagonals: corners (+-1, +-1) / 2 and (+-1, -+1) / 2
        across, diagonal = dd1 + sign * dd2, edges[0] + sign * edges[1]
        errors.append(k_top * t * _rows_dot(across, across) / 4
                      + (k_top - k_centre) * np.abs(_rows_dot(d, diagonal))
                      + k_top * np.sqrt(_rows_dot(diagonal, diagonal)) * normal_spread)
    return np.where(grazing, np.inf, np.maximum(*errors))


def block_sizes(max_merge: int) -> list[tuple[int, int]]:
    """Block shapes (cells along a, along b) up to ``max_merge`` per axis (powers of 2), the
    largest first (square before oblong of the same area): cells of the fixed grid are oblong
    where one axis crosses the main lobe and the other does not."""
    sides = [1 << k for k in range(int(max_merge).bit_length())]
    shapes = [(p, q) for p in sides for q in sides if p * q > 1]
    return sorted(shapes, key=lambda s: (-s[0] * s[1], abs(s[0] - s[1])))


def blocks(x: np.ndarray, size: tuple[int, int], fill) -> np.ndarray:
    """Cells (G, n_a, n_b, ...) grouped into aligned blocks of ``size`` = (p, q) cells: (G, N_a,
    N_b, p q, ...), the grid padded with ``fill`` to whole blocks."""
    (g, n_a, n_b), (p, q) = x.shape[:3], size
    pad_a, pad_b = -n_a % p, -n_b % q
    x = np.pad(x, [(0, 0), (0, pad_a), (0, pad_b)] + [(0, 0)] * (x.ndim - 3),
               constant_values=fill)
    n_a, n_b = (n_a + pad_a) // p, (n_b + pad_b) // q
    x = x.reshape((g, n_a, p, n_b, q) + x.shape[3:])
    return np.moveaxis(x, 2, 3).reshape((g, n_a, n_b, p * q) + x.shape[5:])


def continuous(cells, shape, normals, t, normal_angle: float):
    """Which blocks of ``cells`` (K, n) (flat cell indices) lie on one continuous surface: the
    same ``shape`` id, unit ``normals`` (facing the rays) within ``normal_angle`` [rad] of each
    other, ranges ``t`` [m] within :data:`DEPTH_JUMP` of each other (``shape``, ``normals``,
    ``t``: flat over the cells). Returns the mask (K,), the blocks' unit mean normals (K, 3),
    the largest angle of a cell's normal to the mean [rad] (K,) and the largest range (K,)."""
    ids, depth, n = shape[cells], t[cells], normals[cells]
    mean = n.sum(axis=1)
    mean /= np.maximum(np.sqrt(_rows_dot(mean, mean)), 1e-30)[:, None]
    cos = np.clip(_rows_dot(n, mean[:, None]).min(axis=1), -1.0, 1.0)
    far = depth.max(axis=1)
    ok = (ids.min(axis=1) == ids.max(axis=1)) & (cos >= np.cos(0.5 * normal_angle)) \
        & (far - depth.min(axis=1) <= DEPTH_JUMP * far)
    return ok, mean, np.arccos(cos), far


def block_cells(a, b, wa, wb, cells):
    """Tangent-plane centre and widths (a, b, wa, wb) (K,) of blocks of ``cells`` (K, n) (flat
    indices into the cells' centres a, b and widths wa, wb)."""
    low_a, high_a = (a[cells] + s * wa[cells] / 2 for s in (-1, 1))
    low_b, high_b = (b[cells] + s * wb[cells] / 2 for s in (-1, 1))
    low_a, low_b = low_a.min(axis=-1), low_b.min(axis=-1)
    high_a, high_b = high_a.max(axis=-1), high_b.max(axis=-1)
    return 0.5 * (low_a + high_a), 0.5 * (low_b + high_b), high_a - low_a, high_b - low_b
