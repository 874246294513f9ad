"""Ray grids and ray casting of the acoustic trace: where the rays go and what they hit.

A beam's rays leave the transmit origin on a grid over a cone around the beam axis, regular in a
warped tangent-plane coordinate (deterministic importance sampling: each ray owns an exactly
known cell of solid angle; :class:`~mitsonar.trace.settings.TraceSettings` ``ray_density``).
:class:`RayCaster` holds that grid, casts rays through the scene (stepping through acoustically
transparent surfaces), refines cells at silhouettes, material changes, depth jumps and curved
surfaces into sub-rays, and tests the visibility of receive elements from hits (shadow rays).
The scattering physics on the hits is :mod:`mitsonar.trace.tracer`'s.
"""

from __future__ import annotations

import drjit as dr
import numpy as np
from scipy.ndimage import binary_dilation

from mitsonar.frames import orthonormal_basis
from mitsonar.jit import backend, to_jit
from mitsonar.physics.array import ArrayGeometry
from mitsonar.scene.loading import AcousticScene, mitsuba
from mitsonar.trace.density import (DEPTH_JUMP, block_cells, block_sizes, blocks, continuous,
                                    patch_phase_error)

#: Offset of secondary ray origins from a surface [m].
_EPS = 1e-4
#: Acoustically transparent layers a ray may step through.
_MAX_TRANSPARENT_LAYERS = 8


def _warped_grid(n: int, half_extent: float, sigma: float, floor: float):
    """Cell centres and widths (n,) of a 1-D grid on [-E, E] with density floor + gauss(sigma)."""
    a = np.linspace(-half_extent, half_extent, 4097)
    density = floor + np.exp(-0.5 * (a / sigma) ** 2)
    cdf = np.concatenate([[0.0], np.cumsum(0.5 * (density[1:] + density[:-1]) * np.diff(a))])
    edges = np.interp(np.linspace(0.0, cdf[-1], n + 1), cdf, a)
    return 0.5 * (edges[1:] + edges[:-1]), np.diff(edges)


def _rows_dot(a, b):
    """Dot products of 3-vectors along the last axis (broadcasting): explicit, which NumPy runs
    several times faster than einsum or matmul over so short an axis."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def _length(v):
    """Lengths of 3-vectors along the last axis (faster than np.linalg.norm there)."""
    return np.sqrt(_rows_dot(v, v))


def _unit(v):
    return v / _length(v)[..., None]


def ray_differentials(d, norm_v, e1, e2, wa, wb):
    """Edges (dd1, dd2) (H, 3) of the cells of rays of unit directions ``d`` (H, 3) through
    tangent-plane offsets of norm ``norm_v`` (H,) = |u + a e1 + b e2| and widths ``wa``, ``wb``
    (H,) along the tangent axes ``e1``, ``e2`` ((H, 3) or (3,)): the changes of the unit
    direction across the cell (perpendicular to ``d``)."""
    inv = (1.0 / norm_v)[:, None]
    dd1 = (e1 - d * _rows_dot(d, e1)[:, None]) * inv * wa[:, None]
    dd2 = (e2 - d * _rows_dot(d, e2)[:, None]) * inv * wb[:, None]
    return dd1, dd2


def _rotate(rotation, v, inverse: bool = False):
    """Rows (K, 3) rotated by their own matrices (K, 3, 3) (transposed with ``inverse``)."""
    return np.einsum("kji,kj->ki" if inverse else "kij,kj->ki", rotation, v)


def _rows(vectors) -> np.ndarray:
    """(R, 3) float64 array of a Dr.Jit 3-vector array, copied component by component: NumPy's
    conversion of the whole 3-vector array runs a kernel with the ray count as a literal, a new
    kernel (compiled anew) for every ray count."""
    return np.stack([np.asarray(vectors[k], dtype=float) for k in range(3)], axis=1)


class RayCaster:
    """Ray grid, ray casts, refinement and shadow rays in one loaded scene.

    Args:
        scene: the loaded acoustic scene.
        geometry: arrays of the sensor head.
        settings: the trace's :class:`~mitsonar.trace.settings.TraceSettings` (grid, refinement,
            merging, shadow rays).
        wavenumbers: (carrier, top of the band) [rad/m] of the patch criterion
            (:mod:`mitsonar.trace.density`); None: cells are never merged.
    """

    def __init__(self, scene: AcousticScene, geometry: ArrayGeometry, settings,
                 wavenumbers: tuple[float, float] | None = None):
        self.mi = mitsuba()
        self.scene = scene
        self.geometry = geometry
        self.settings = settings
        self._wavenumbers = wavenumbers
        self._transparent = np.array([m.transparent for m in scene.materials])
        s = settings
        if s.model == "paper":
            offsets = (np.arange(s.paper_grid) - (s.paper_grid - 1) / 2) * np.tan(s.paper_spacing)
            aa, bb = np.meshgrid(offsets, offsets, indexing="ij")
            zero = np.zeros_like(aa)
            self._grid = (aa, bb, zero, zero, np.ones(aa.shape, bool))
        else:
            half = np.tan(s.cone_half_angle)
            sigma = 1.5 * np.tan(s.main_lobe_width) / 2.355
            if s.ray_density == "beam":
                centres, widths = _warped_grid(s.rays_per_axis, half, sigma, s.importance_floor)
            else:
                edges = np.tan(np.linspace(-s.cone_half_angle, s.cone_half_angle,
                                           s.rays_per_axis + 1))
                centres, widths = 0.5 * (edges[1:] + edges[:-1]), np.diff(edges)
            aa, bb = np.meshgrid(centres, centres, indexing="ij")
            da, db = np.meshgrid(widths, widths, indexing="ij")
            self._grid = (aa, bb, da, db, np.hypot(aa, bb) <= half)
            self._refinable = np.hypot(aa, bb) <= np.tan(s.refine_radius)

    @property
    def grid_rays(self) -> int:
        """Rays of a beam's grid before refinement (cells of its square, inside the cone or not)."""
        return int(self._grid[0].size)

    def _taper(self, a, b):
        """Weight of a ray at tangent-plane offsets (a, b): 1 inside, fading to 0 at the cone
        edge."""
        if self.settings.model == "paper":
            return np.ones_like(a)
        return self._fade(np.hypot(a, b) / np.tan(self.settings.cone_half_angle))

    def _fade(self, rho):
        """Weight at tangent-plane radius ``rho`` in units of the cone's: 1 inside, fading to 0
        over the outer ``taper`` of the cone."""
        s = self.settings
        fade = np.clip((1.0 - rho) / s.taper, 0.0, 1.0) if s.taper > 0 else (rho <= 1).astype(float)
        return np.sin(0.5 * np.pi * fade) ** 2

    def _union_weight(self, cos):
        """Weight of rays whose cosines to the beam axes are ``cos`` (..., B): the largest of the
        beams' cone weights (:meth:`_fade`), so the union of the cones fades at its edge as each
        cone does."""
        tan = np.sqrt(np.maximum(1.0 - cos * cos, 0.0)) / np.where(cos > 0, cos, 1.0)
        rho = np.where(cos > 0, tan / np.tan(self.settings.cone_half_angle), np.inf)
        return self._fade(rho).max(axis=-1)

    def _union_grid(self, directions, step: float):
        """Ray grid over the union of the cones around unit beam axes ``directions`` (B, 3),
        regular in angle with ``step`` [rad] along both axes of the tangent plane of their mean
        axis (cells of equal angle, each with its exact tangent-plane widths) and clipped at
        80 deg from it. Returns the axis u0 (3,), tangent basis e1, e2 (3,), the grid (a, b, wa,
        wb, inside) for :meth:`_cast_grid`, each (1, n_a, n_b) (inside: a cell whose centre
        some cone weights), and the cells within ``refine_radius`` of a beam axis (the beams'
        main lobes, which :meth:`_cast_grid` splits as ``dense``)."""
        s = self.settings
        u0 = _unit(directions.mean(axis=0))
        e1, e2 = orthonormal_basis(u0)
        along = directions @ u0
        limit = np.radians(80.0)  # the tangent plane is kept away from 90 deg

        def axis(offsets):
            angles = np.arctan2(offsets, along)
            low = max(angles.min() - s.cone_half_angle, -limit)
            high = min(angles.max() + s.cone_half_angle, limit)
            edges = np.tan(np.linspace(low, high, max(int(np.ceil((high - low) / step)), 1) + 1))
            return 0.5 * (edges[1:] + edges[:-1]), np.diff(edges)

        (ca, wa), (cb, wb) = axis(directions @ e1), axis(directions @ e2)
        aa, bb = np.meshgrid(ca, cb, indexing="ij")
        da, db = np.meshgrid(wa, wb, indexing="ij")
        cos = _unit(u0 + aa[..., None] * e1 + bb[..., None] * e2) @ directions.T  # (n_a, n_b, B)
        inside = self._union_weight(cos) > 0
        refinable = cos.max(axis=-1) >= np.cos(s.refine_radius)
        return u0, e1, e2, tuple(x[None] for x in (aa, bb, da, db, inside)), refinable[None]

    def intersect(self, origins, directions):
        """First non-transparent hit of rays from ``origins`` (R, 3) [m] along unit ``directions``
        (R, 3), world frame (the sonar's own caster: acoustically transparent surfaces are passed).

        Returns t (inf: miss), p, n (world), material index (-1: miss) and shape index (-1:
        miss). Each layer is one :meth:`SceneHits.first <mitsonar.scene.hits.SceneHits.first>`
        (Mitsuba's preliminary intersection: no per-call dispatch over the scene's shapes).
        """
        n_rays = len(origins)
        t_total = np.zeros(n_rays)
        t = np.full(n_rays, np.inf)
        p = np.zeros((n_rays, 3))
        nrm = np.zeros((n_rays, 3))
        mat = np.full(n_rays, -1)
        shape = np.full(n_rays, -1)
        active = np.arange(n_rays)
        o = origins.copy()
        hits = self.scene.hits
        for _ in range(_MAX_TRANSPARENT_LAYERS):  # loop over layers, each vectorised over rays
            hit_t, hit_p, hit_n, hit_shape = hits.first(o[active], directions[active])
            valid = hit_shape >= 0
            m = np.where(valid, self.scene.shape_material[np.maximum(hit_shape, 0)], -1)
            through = valid & self._transparent[np.maximum(m, 0)]
            done = ~through
            idx = active[done]
            t[idx] = t_total[idx] + hit_t[done]
            p[idx] = hit_p[done]
            nrm[idx] = hit_n[done]
            mat[idx] = m[done]
            shape[idx] = hit_shape[done]
            nxt = active[through]
            step = hit_t[through] + _EPS
            t_total[nxt] += step
            o[nxt] = o[nxt] + step[:, None] * directions[nxt]
            active = nxt
            if len(active) == 0:
                break
        return t, p, nrm, mat, shape

    def _shadow_rays(self, starts, rotation, translation):
        """(H x N_rx,) True where the segment from start h (world, (H, 3)) to receive element j
        of hit h's pose (rotation (H, 3, 3), translation (H, 3)) is unobstructed.

        The segments are built in Dr.Jit from the H starts and N_rx elements (no (H x N_rx, 3)
        NumPy temporaries, which cost several times the tests themselves); one any-hit test per
        segment, and only the blocked ones, if the scene has acoustically transparent surfaces,
        traced again through them."""
        Float64, UInt32 = backend().Float64, backend().UInt32

        mi = self.mi
        rx = self.geometry.rx_positions
        n_rx = len(rx)
        index = dr.arange(UInt32, len(starts) * n_rx)
        hit, element = index // n_rx, index % n_rx
        per_hit = lambda column: dr.gather(Float64, to_jit(Float64, column), hit)  # noqa: E731
        elem = [dr.gather(Float64, to_jit(Float64, rx[:, k]), element) for k in range(3)]
        seg = [per_hit(translation[:, a] - starts[:, a])
               + sum(per_hit(rotation[:, a, b]) * elem[b] for b in range(3)) for a in range(3)]
        dist = dr.sqrt(sum(c * c for c in seg))
        d = [c / dist for c in seg]
        origin = [per_hit(starts[:, a]) + _EPS * d[a] for a in range(3)]
        ray = mi.Ray3f(mi.Point3f(*(mi.Float(c) for c in origin)),
                       mi.Vector3f(*(mi.Float(c) for c in d)), mi.Float(dist - 2 * _EPS),
                       mi.Float(0.0), [])
        blocked = self.scene.scene.ray_test(ray)
        if not self._transparent.any():
            dr.eval(blocked)
            return ~np.asarray(blocked, dtype=bool)
        dr.eval(blocked, origin, d, dist)
        visible = ~np.asarray(blocked, dtype=bool)
        recheck = np.flatnonzero(~visible)
        if len(recheck):
            o, v = (np.stack([np.asarray(c)[recheck] for c in x], axis=1) for x in (origin, d))
            visible[recheck] = self.intersect(o, v)[0] >= np.asarray(dist)[recheck] - 2 * _EPS
        return visible

    def _cast(self, rotation, translation, u, e1, e2, beam, a, b):
        """Rays of beams ``beam`` (K,) through tangent-plane offsets (a, b) (K,) around their axes
        u (B, 3) with bases e1, e2 (B, 3); returns directions (sensor frame), |u + a e1 + b e2|
        and the intersection results of :meth:`intersect`."""
        v = u[beam] + a[:, None] * e1[beam] + b[:, None] * e2[beam]
        norm_v = _length(v)
        d = v / norm_v[:, None]
        world_d = _rotate(rotation[beam], d)
        return d, norm_v, self.intersect(translation[beam], world_d)

    def _refine_mask(self, inside, t, n_w, shape):
        """(..., n, n) cells to split: a 4-neighbour differs in hit, shape, normal or depth;
        grown by one. Leading axes (beams) are independent grids."""
        hit = np.isfinite(t)
        cos_max = np.cos(self.settings.refine_normal_angle)
        refine = np.zeros_like(inside)
        for axis in (-2, -1):  # the two grid directions
            sl_a = (Ellipsis, slice(None, -1), slice(None)) if axis == -2 else (Ellipsis, slice(None, -1))
            sl_b = (Ellipsis, slice(1, None), slice(None)) if axis == -2 else (Ellipsis, slice(1, None))
            both = inside[sl_a] & inside[sl_b]
            both_hit = hit[sl_a] & hit[sl_b]
            depth_a = np.where(hit[sl_a], t[sl_a], 0.0)
            depth_b = np.where(hit[sl_b], t[sl_b], 0.0)
            n_a = n_w[sl_a + (slice(None),)]
            n_b = n_w[sl_b + (slice(None),)]
            differ = (hit[sl_a] != hit[sl_b]) | (shape[sl_a] != shape[sl_b]) | (both_hit & (
                (np.abs(np.sum(n_a * n_b, axis=-1)) < cos_max)
                | (np.abs(depth_a - depth_b) > 0.05 * np.maximum(depth_a, depth_b))))
            differ &= both
            refine[sl_a] |= differ
            refine[sl_b] |= differ
        # Grow by one cell (8-neighbourhood): an edge or corner can cross a cell whose own ray
        # and 4-neighbours all agree.
        grow = np.ones((1,) * (refine.ndim - 2) + (3, 3), bool)
        return binary_dilation(refine, structure=grow) & inside

    def _visibility(self, rotation, translation, points, normals) -> np.ndarray:
        """(H, N_rx) 1.0 where receive element j sees hit h, else 0.0; points and normals (H, 3)
        in the sensor frame of poses (rotation (H, 3, 3), translation (H, 3))."""
        rx = self.geometry.rx_positions
        if not self.settings.shadow_rays or len(points) == 0:
            return np.ones((len(points), len(rx)))
        start = _rotate(rotation, points + _EPS * normals) + translation  # (H, 3) world
        visible = self._shadow_rays(start, rotation, translation)
        return visible.reshape(len(points), len(rx)).astype(float)


    def _merging(self) -> bool:
        """Whether cells are merged where the patch criterion allows: the physical model with a
        merge size above 1 and known wavenumbers."""
        s = self.settings
        return s.model == "physical" and s.max_merge > 1 and self._wavenumbers is not None

    def _phase_error(self, rotation, u, e1, e2, beam, a, b, wa, wb, t, n_w, spread):
        """(K,) phase error [rad] of the patches of cells (a, b, wa, wb) (K,) of grids ``beam``
        at ranges ``t`` on surfaces of world normals ``n_w`` (K, 3) spread by ``spread`` (K,)
        [rad] (:func:`~mitsonar.trace.density.patch_phase_error`)."""
        v = u[beam] + a[:, None] * e1[beam] + b[:, None] * e2[beam]
        norm_v = _length(v)
        d = v / norm_v[:, None]
        dd1, dd2 = ray_differentials(d, norm_v, e1[beam], e2[beam], wa, wb)
        normals = _rotate(rotation[beam], n_w, inverse=True)
        return patch_phase_error(t, d, normals, dd1, dd2, *self._wavenumbers[::-1], spread)

    def _merge_blocks(self, rotation, u, e1, e2, grid, t, n_w, shapes, free):
        """Blocks of cells that one ray each may replace (:mod:`~mitsonar.trace.density`), the
        largest first, each cell in one block at most.

        Args:
            grid: (a, b, wa, wb, inside), each (G, n_a, n_b), as :meth:`_cast_grid` takes it.
            t, n_w, shapes: (G, n_a, n_b) ranges, (G, n_a, n_b, 3) world normals and shape ids
                of the cells' rays.
            free: (G, n_a, n_b) cells that may be merged (inside, hit, not split).
        Returns:
            The blocks' rays (a, b, wa, wb, grid index), each (M,), the shape id and range [m]
            their centre rays must find (M,), and per block size the (M_k, cells) flat indices
            of its blocks' cells, in the order of the rays.
        """
        s = self.settings
        n_a, n_b = free.shape[1:]
        cell = np.arange(free.size).reshape(free.shape)
        normals = n_w.reshape(-1, 3)
        flip = _rows_dot(normals, _rotate(np.repeat(rotation, n_a * n_b, axis=0),
                                          self._grid_directions(u, e1, e2, grid))) > 0
        facing = np.where(flip[:, None], -normals, normals)
        flat = [x.ravel() for x in (*grid[:4], shapes, t)]
        covered = np.zeros(free.size, bool)
        chosen = []  # per block size: block centres and widths, grid, shape, range, cells
        for size in block_sizes(s.max_merge):  # a few shapes, largest first
            whole = blocks(free & ~covered.reshape(free.shape), size, False).all(axis=-1)
            cells = blocks(cell, size, -1)[whole]  # (K, cells per block), all free
            ok, normal, spread, depth = continuous(cells, flat[4], facing, flat[5],
                                                   s.refine_normal_angle)
            cells, g = cells[ok], cells[ok, 0] // (n_a * n_b)
            centre = block_cells(*flat[:4], cells)
            take = self._phase_error(rotation, u, e1, e2, g, *centre, depth[ok], normal[ok],
                                     spread[ok]) <= s.max_patch_phase
            if np.any(take):
                covered[cells[take].ravel()] = True
                chosen.append((*(x[take] for x in centre), g[take], flat[4][cells[take, 0]],
                               depth[ok][take], cells[take]))
        if not chosen:
            return None
        return tuple(np.concatenate([c[k] for c in chosen]) for k in range(7)), \
            [c[7] for c in chosen]

    @staticmethod
    def _owners(blocks_cells, good, n_cells: int) -> np.ndarray:
        """(n_cells,) index among the ``good`` (M,) blocks of the block that replaces each cell
        (-1: none)."""
        owner = np.full(n_cells, -1)
        rank = np.cumsum(good) - 1
        start = 0
        for cells in blocks_cells:  # per block size (a few)
            rows = np.flatnonzero(good[start:start + len(cells)])
            owner[cells[rows]] = rank[start + rows][:, None]
            start += len(cells)
        return owner

    @staticmethod
    def _grid_directions(u, e1, e2, grid):
        """(G x n_a x n_b, 3) unit directions (sensor frame) of the cells of ``grid``."""
        a, b = grid[0], grid[1]
        v = u[:, None, None] + a[..., None] * e1[:, None, None] + b[..., None] * e2[:, None, None]
        return _unit(v).reshape(-1, 3)

    def _cast_grid(self, rotation, translation, u, e1, e2, grid, refinable, dense=None):
        """Cast the rays of G grids of cells, grid g around axis u[g] (G, 3) with tangent basis
        e1[g], e2[g] from pose (rotation[g] (3, 3), translation[g] (3,)), refine them, and merge
        blocks of cells where the patch criterion allows (:meth:`_merging`).

        Args:
            grid: (a, b, wa, wb, inside), each (G, n_a, n_b): cell centres and widths in the
                tangent plane, and the cells traced.
            refinable: (G, n_a, n_b) cells that may be split at silhouettes (or None).
            dense: (G, n_a, n_b) cells split whatever they hit (or None).
        Returns:
            The rays kept (each grid's cells in grid order, then its sub-rays and merged rays),
            as arrays over rays: tangent offsets a, b and widths wa, wb, directions d (sensor
            frame), |u + a e1 + b e2|, t (inf: miss), world hit points and normals, material
            index, and grid index; the ray count per grid (G,); and None, or where blocks were
            merged, the rays of the fixed grid (in the same order as without merging): grid
            index, t, material, cell width product wa wb, and the index of the kept ray that
            stands for each (itself, or its block's).
        """
        s = self.settings
        inside = grid[4]
        shape = inside.shape
        beam = np.repeat(np.arange(shape[0]), shape[1] * shape[2])
        a, b, wa, wb = (x.ravel() for x in grid[:4])
        keep = inside.ravel().copy()
        t = np.full(len(a), np.inf)
        p_w, n_w = np.zeros((len(a), 3)), np.zeros((len(a), 3))
        mats, shapes = np.full(len(a), -1), np.full(len(a), -1)
        d, norm_v = np.zeros((len(a), 3)), np.ones(len(a))
        d[keep], norm_v[keep], (t[keep], p_w[keep], n_w[keep], mats[keep], shapes[keep]) = \
            self._cast(rotation, translation, u, e1, e2, beam[keep], a[keep], b[keep])
        m = s.refine
        split = np.zeros(len(a), bool)
        if m > 1 and s.model == "physical":
            if dense is not None:
                split = (dense & inside).ravel()
            # The refinement's mask, where it can still split a cell.
            if refinable is not None and np.any(refinable.ravel() & inside.ravel() & ~split):
                split |= (self._refine_mask(inside, t.reshape(shape), n_w.reshape(shape + (3,)),
                                            shapes.reshape(shape)) & refinable).ravel()
        keep &= ~split
        fixed = keep.copy()  # the fixed grid's cells
        # New rays, cast together: sub-rays of the split cells, then the merged blocks' rays.
        frac = (np.arange(m) + 0.5) / m - 0.5
        fa, fb = (x.ravel() for x in np.meshgrid(frac, frac, indexing="ij"))
        new = [(a[split, None] + fa[None] * wa[split, None]).ravel(),
               (b[split, None] + fb[None] * wb[split, None]).ravel(),
               np.repeat(wa[split] / m, m * m), np.repeat(wb[split] / m, m * m),
               np.repeat(beam[split], m * m)]
        n_sub = len(new[0])
        merged = None
        if self._merging():
            hit = np.isfinite(t) & (mats >= 0)
            merged = self._merge_blocks(rotation, u, e1, e2, grid, t.reshape(shape),
                                        n_w.reshape(shape + (3,)), shapes.reshape(shape),
                                        (keep & hit).reshape(shape))
            if merged is not None:
                new = [np.concatenate([x, y]) for x, y in zip(new, merged[0][:5])]
        extra, owner = None, None
        if len(new[0]):
            cd, cnorm, (ct, cp, cn, cmat, cshape) = self._cast(rotation, translation, u, e1, e2,
                                                               new[4], new[0], new[1])
            extra = (*new[:4], cd, cnorm, ct, cp, cn, cmat, new[4])
            if merged is not None:
                # A block's centre ray must find its cells' surface at their depth, else the
                # cells stay as they are.
                shape_ref, depth = merged[0][5:]
                good = (cshape[n_sub:] == shape_ref) \
                    & (np.abs(ct[n_sub:] - depth) <= DEPTH_JUMP * depth)
                owner = self._owners(merged[1], good, len(a))
                keep &= owner < 0
                rows = np.concatenate([np.ones(n_sub, bool), good])
                extra = tuple(x[rows] for x in extra)
        rays = (a, b, wa, wb, d, norm_v, t, p_w, n_w, mats, beam)
        if extra is None:
            rays_kept = tuple(x[keep] for x in rays)
            return rays_kept, np.bincount(rays_kept[-1], minlength=shape[0]), None
        # Per grid: its kept rays in grid order, then its sub-rays and merged rays.
        kept = np.concatenate([np.flatnonzero(keep), len(a) + np.arange(len(extra[0]))])
        order = np.argsort(np.concatenate([beam[keep], extra[-1]]), kind="stable")
        rays_kept = tuple(np.concatenate([x[keep], y])[order] for x, y in zip(rays, extra))
        counts = np.bincount(rays_kept[-1], minlength=shape[0])
        if owner is None or not np.any(owner >= 0):
            return rays_kept, counts, None
        # The fixed grid's rays (cells before merging, then sub-rays) and the kept ray that
        # stands for each: itself, or the block that replaced it.
        position = np.empty(len(a) + len(extra[0]), int)
        position[kept[order]] = np.arange(len(order))
        stands = np.where(owner >= 0, len(a) + n_sub + owner, np.arange(len(a)))
        pairs = ((beam, extra[-1]), (t, extra[6]), (mats, extra[9]), (wa * wb, extra[2] * extra[3]))
        attributes = [np.concatenate([x[fixed], y[:n_sub]]) for x, y in pairs]
        stand = np.concatenate([stands[fixed], len(a) + np.arange(n_sub)])
        by_grid = np.argsort(attributes[0], kind="stable")
        return rays_kept, counts, (*(x[by_grid] for x in attributes), position[stand[by_grid]])
