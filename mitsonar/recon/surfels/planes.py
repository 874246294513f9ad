"""Planes of surfel scanning: the plane through a surfel's points, least-squares planes (14)(15)
and their normals' standard errors, the expected error of a point off its plane, plane groups of
surfels (:func:`group_surfels`) and their joint refinement with the image creases
(:func:`refine_planes`). Arrays in, arrays out; the method and why it deviates from the paper:
the :mod:`mitsonar.recon.surfels` docstring."""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np
from scipy.sparse import coo_matrix

from mitsonar.recon.surfels.settings import SurfelSettings

def plane_through(points) -> tuple[np.ndarray, np.ndarray]:
    """Unit normals (k, 3) and offsets (k,) [m] (n . x = d) of the planes through the first three
    of points (k, >=3, 3); NaN for collinear triples."""
    p = np.asarray(points, dtype=float)
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.where(norm > 1e-12, n / np.maximum(norm, 1e-300), np.nan)
    return n, np.einsum("kc,kc->k", n, p[:, 0])


def fit_plane(points, towards=None) -> tuple[np.ndarray, float]:
    """Least-squares plane (14)(15) of points (n >= 3, 3) [m]: the unit normal x minimising
    |A x|^2 for the centred points A is the last right singular vector of A.

    Returns (normal (3,), offset d [m]) with n . p = d on the plane; the normal points towards
    ``towards`` (3,) [m] when given (e.g. the sensor), else its largest component is positive.
    """
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    if len(p) < 3:
        raise ValueError(f"fit_plane needs at least 3 points, got {len(p)}")
    centroid = p.mean(axis=0)
    normal = np.linalg.svd(p - centroid, full_matrices=False)[2][-1]
    side = (np.asarray(towards, dtype=float) - centroid) @ normal if towards is not None \
        else normal[np.argmax(np.abs(normal))]
    if side < 0:
        normal = -normal
    return normal, float(normal @ centroid)


def _components(n: int, i, j) -> np.ndarray:
    """Labels (n,) of the connected components of the graph with edges (i, j), numbered in
    order of their first node (deterministic)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    graph = coo_matrix((np.ones(len(i)), (np.asarray(i), np.asarray(j))), shape=(n, n))
    label = connected_components(graph, directed=False)[1]
    return _relabel(label)


def _relabel(label) -> np.ndarray:
    """Labels renumbered 0, 1, ... in order of first occurrence."""
    _, first, inverse = np.unique(label, return_index=True, return_inverse=True)
    rank = np.empty(len(first), dtype=int)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    return rank[inverse]


def _point_sigma(points, viewpoints, normals, settings: SurfelSettings) -> np.ndarray:
    """Expected distance [m] of points (..., 3) seen from viewpoints (..., 3) off their planes
    with unit normals (..., 3): sqrt(``range_sigma``^2 + (r tan(``angle_sigma``) sin(theta))^2)
    at range r and incidence theta (:class:`SurfelSettings`)."""
    ray = points - viewpoints
    r = np.linalg.norm(ray, axis=-1)
    cos = np.einsum("...c,...c->...", ray, normals) / np.maximum(r, 1e-12)
    sin = np.sqrt(np.clip(1 - cos ** 2, 0, 1))
    return np.hypot(settings.range_sigma, r * np.tan(settings.angle_sigma) * sin)


def _weighted_sums(points, viewpoints, normals, settings: SurfelSettings, origin):
    """Sums of point sets (u, m, 3) [m] (NaN-padded, seen from viewpoints (u, m, 3)) for
    weighted plane fits, each point weighted by 1 / sigma^2, sigma its expected error
    (:func:`_point_sigma`) off its set's plane with unit normal (u, 3): the weights' sum (u,)
    [1/m^2], sum w q (u, 3) [1/m] and sum w q q^T (u, 3, 3) [1] of q = point - ``origin``."""
    ok = np.all(np.isfinite(points), axis=-1)
    sigma = _point_sigma(points, viewpoints, normals[:, None], settings)
    w = np.where(ok, 1.0 / np.where(ok, sigma, 1.0) ** 2, 0.0)
    q = np.where(ok[..., None], points - origin, 0.0)
    return w.sum(axis=1), np.einsum("um,umi->ui", w, q), np.einsum("um,umi,umj->uij", w, q, q)


def _misfit(weight, first, second) -> np.ndarray:
    """chi^2 (sum of w d^2 over the points) of the weighted least-squares plane of point sets
    given by :func:`_weighted_sums` (any leading shape): the smallest eigenvalue of their
    weighted scatter; 0 for an empty set."""
    mean = first / np.maximum(weight, 1e-300)[..., None]
    scatter = second - weight[..., None, None] * mean[..., :, None] * mean[..., None, :]
    return np.maximum(np.linalg.eigvalsh(scatter)[..., 0], 0.0)


def _coplanar_limit(settings: SurfelSettings) -> float:
    """Largest chi^2 increase (:func:`_separation`) of two point sets on one plane: its
    three degrees of freedom (the second plane's tilt and offset) exceed it with the
    probability that a normal deviate exceeds ``merge_sigmas`` (0.27 % at 3)."""
    from scipy.special import erf
    from scipy.stats import chi2

    return float(chi2.ppf(erf(settings.merge_sigmas / np.sqrt(2.0)), 3))


def _separation(a, b) -> np.ndarray:
    """How much worse one plane fits two point sets than a plane each: the chi^2 of the
    weighted least-squares plane of both together minus those of each alone (sums ``a``, ``b``
    of :func:`_weighted_sums`, broadcast against each other); chi^2 with three degrees of
    freedom when they share a plane and their errors are as expected (:func:`_point_sigma`).

    Two point sets on parallel planes a few cm apart (a wall's face and a window pane 10 cm
    behind it) each lie within ``merge_sigmas`` expected errors of one plane tilted between
    them (3 x 3-4.5 cm at 3 m and oblique incidence), but that plane leaves both with
    residuals their own planes do not have; the likelihood-ratio test weighs exactly that."""
    joint = _misfit(*(x + y for x, y in zip(a, b)))
    return joint - _misfit(*a) - _misfit(*b)


def _plane_stats(points, viewpoints, settings: SurfelSettings):
    """Least-squares planes (14)(15) of u point sets (u, m, 3) [m] (NaN-padded, >= 3 points
    each) seen from viewpoints (u, m, 3) [m].

    Returns unit normals (u, 3) (unoriented), centroids (u, 3) [m] and the normals' standard
    errors (u,) [rad]: atan(s / S2), S2 the set's second singular value (its extent across its
    narrower in-plane direction) and s the per-point error, estimated from the residuals
    (last singular value over sqrt(m - 3)) but not below the mean expected error
    (:func:`_point_sigma`; four points leave one degree of freedom).
    """
    ok = np.all(np.isfinite(points), axis=-1)
    count = ok.sum(axis=1)
    centroid = np.where(ok[..., None], points, 0.0).sum(axis=1) / count[:, None]
    a = np.where(ok[..., None], points - centroid[:, None], 0.0)
    w, v = np.linalg.eigh(np.einsum("umi,umj->uij", a, a))  # ascending: S3^2, S2^2, S1^2
    normal = v[..., 0]
    sigma = _point_sigma(points, viewpoints, normal[:, None], settings)
    expected = np.where(ok, sigma, 0.0).sum(axis=1) / count
    s = np.maximum(np.sqrt(np.maximum(w[:, 0], 0) / np.maximum(count - 3, 1)), expected)
    return normal, centroid, np.arctan2(s, np.sqrt(np.maximum(w[:, 1], 0)))


def _links(points, viewpoints, settings: SurfelSettings,
           stats=None) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i < j) of point sets (u, m, 3) [m] (NaN-padded, seen from viewpoints
    (u, m, 3)) that lie on one plane: their normals agree within the coarse gate
    ``merge_angle`` + ``merge_sigmas`` x the combined standard error of the two normals, and
    every point of both lies within ``merge_sigmas`` expected errors (:func:`_point_sigma`) of
    the least-squares plane of the two sets together, and that plane fits them no worse than
    a plane each by more than chance allows (:func:`_separation` within
    :func:`_coplanar_limit`).

    Sets whose normal's standard error exceeds ``max_link_error`` link nothing: such a set (a
    small surfel far away) fits several planes at once and would chain them into one group (on
    room_glass a 13 cm surfel at 3.2 m, normal error 28 deg, joined both windows and the
    floor). It can still join the group whose plane fits it when the groups are refitted.
    ``stats``: :func:`_plane_stats` of the sets, if the caller has them."""
    normal, _, error = stats or _plane_stats(points, viewpoints, settings)
    ok = np.all(np.isfinite(points), axis=-1)
    q = np.where(ok[..., None], points - np.nanmean(points.reshape(-1, 3), axis=0), 0.0)
    count = ok.sum(axis=1).astype(float)
    total = q.sum(axis=1)
    moment = np.einsum("umi,umj->uij", q, q)
    n = count[:, None] + count[None, :]
    mean = (total[:, None] + total[None, :]) / n[..., None]
    scatter = moment[:, None] + moment[None, :] - n[..., None, None] * np.einsum(
        "abi,abj->abij", mean, mean)
    pair = np.linalg.eigh(scatter)[1][..., 0]  # (u, u, 3): normal of the joint plane
    dist = np.abs(np.einsum("amc,abc->abm", q, pair)
                  - np.einsum("abc,abc->ab", mean, pair)[..., None])
    sigma = _point_sigma(points[:, None], viewpoints[:, None], pair[:, :, None], settings)
    inside = np.all(~ok[:, None] | (dist <= settings.merge_sigmas * sigma), axis=-1)  # a's points
    gate = settings.merge_angle + settings.merge_sigmas * np.hypot(error[:, None], error[None, :])
    angle = np.arccos(np.clip(np.abs(normal @ normal.T), 0.0, 1.0))
    vague = error > settings.max_link_error
    sums = _weighted_sums(points, viewpoints, normal, settings, points[ok].mean(axis=0))
    apart = _separation(tuple(x[:, None] for x in sums), tuple(x[None] for x in sums))
    linked = inside & inside.T & (angle <= gate + 1e-12) & ~vague[:, None] & ~vague[None, :]
    linked &= apart <= _coplanar_limit(settings)
    return np.nonzero(np.triu(linked, k=1))


@dataclass(frozen=True)
class PlaneGroups:
    """Plane groups of surfels.

    Attributes:
        label: (k,) group of every surfel.
        normals: (G, 3) unit normals, towards the sensors that saw the group.
        offsets: (G,) [m], n . x = d on the plane.
        centroids: (G, 3) [m] mean of the group's points.
        normal_errors: (G,) standard errors of the least-squares normals [rad]
            (:func:`_plane_stats`); groups above ``max_normal_error`` are not grown.
        iterations: regroup/refit rounds run.
    """

    label: np.ndarray
    normals: np.ndarray
    offsets: np.ndarray
    centroids: np.ndarray
    normal_errors: np.ndarray
    iterations: int

    def __len__(self) -> int:
        return len(self.normals)


def _pad_groups(points, viewpoints, label) -> tuple[np.ndarray, np.ndarray]:
    """NaN-padded points (G, m, 3) [m] and their viewpoints (G, m, 3) of the groups ``label``
    (k,) of surfels with points (k, n, 3) (NaN for missing ones) seen from viewpoints (k, 3)."""
    count = label.max() + 1
    seen = np.broadcast_to(viewpoints[:, None], points.shape)
    rows = [np.all(np.isfinite(points), axis=-1) & (label == g)[:, None] for g in range(count)]
    m = max(int(r.sum()) for r in rows)
    out, view = np.full((count, m, 3), np.nan), np.full((count, m, 3), np.nan)
    for g, r in enumerate(rows):  # a few dozen groups
        out[g, :r.sum()], view[g, :r.sum()] = points[r], seen[r]
    return out, view


def _fit_groups(points, viewpoints, label, settings: SurfelSettings):
    """Normals (G, 3), offsets (G,) [m], centroids (G, 3) [m] and normal standard errors (G,)
    [rad] of the groups ``label`` (k,) of surfels with points (k, n, 3) (NaN-padded) seen from
    viewpoints (k, 3), oriented towards the mean viewpoint of each group; then the groups'
    padded points and viewpoints (:func:`_pad_groups`)."""
    pts, view = _pad_groups(points, viewpoints, label)
    normals, centroids, errors = _plane_stats(pts, view, settings)
    towards = np.array([viewpoints[label == g].mean(axis=0) for g in range(len(pts))])
    flip = np.where(np.einsum("gc,gc->g", towards - centroids, normals) < 0, -1.0, 1.0)
    normals = normals * flip[:, None]
    return normals, np.einsum("gc,gc->g", normals, centroids), centroids, errors, pts, view


def _joins(sums, label, count: int) -> np.ndarray:
    """(k, G) :func:`_separation` of each of k surfels (``sums`` of :func:`_weighted_sums`)
    from each of ``count`` groups ``label`` (k,) without it."""
    group = [np.zeros((count,) + x.shape[1:]) for x in sums]
    for g, x in zip(group, sums):
        np.add.at(g, label, x)
    own = np.arange(count)[None] == label[:, None]  # (k, G): the surfel's own group
    rest = tuple(g[None] - np.where(own.reshape(own.shape + (1,) * (x.ndim - 1)), x[:, None], 0)
                 for g, x in zip(group, sums))
    return _separation(tuple(x[:, None] for x in sums), rest)


def _drop_misfits(sums, label, limit: float) -> np.ndarray:
    """Groups ``label`` (k,) of surfels (``sums`` of :func:`_weighted_sums`) after taking out,
    one per group and round, the surfel the rest of its group fits worst while that
    :func:`_separation` exceeds ``limit``: pairwise links chain, and a surfel on a parallel
    plane 10 cm off links with each small patch of the other plane that a tilted plane through
    both fits, but not with the whole of it."""
    label = np.asarray(label).copy()
    for _ in range(len(label)):  # each round takes out at least one surfel
        apart = _joins(sums, label, label.max() + 1)[np.arange(len(label)), label]
        worst = np.full(label.max() + 1, -np.inf)
        np.maximum.at(worst, label, apart)
        out = (apart == worst[label]) & (apart > limit)
        if not out.any():
            break
        label[out] = label.max() + 1 + np.arange(int(out.sum()))
    return _relabel(label)


def _apart(i, j, alone) -> tuple[np.ndarray, np.ndarray]:
    """Link pairs (i, j) without those that touch a member flagged in ``alone`` (None: all)."""
    if alone is None:
        return i, j
    keep = ~(alone[i] | alone[j])
    return i[keep], j[keep]


def group_surfels(points, viewpoints, settings: SurfelSettings = SurfelSettings(),
                  extra=None, alone=None, floor=None) -> PlaneGroups:
    """Plane groups of registered surfels (package docstring: grouping, (14)(15), iteration).

    Args:
        points: (k, 4, 3) measured world points of each surfel [m].
        viewpoints: (k, 3) sensor position from which each surfel was measured [m].
        settings: ``merge_angle``, ``merge_sigmas``, ``range_sigma``, ``angle_sigma`` (the
            tolerances) and ``max_iterations`` (cap on the regroup/refit rounds).
        extra: (k, m, 3) fill points of each surfel [m] (NaN-padded), used in the tests and fits.
        alone: (k,) True for surfels that form a group of their own whatever they fit (the
            members of a group the check pings refuted, judged one by one); None: none.
        floor: (k,) True for surfels grouped only among themselves, after the others (those
            whose echoes fit the floor the robot drives on); None: none.
    """
    p = np.asarray(points, dtype=float)
    if p.ndim != 3 or p.shape[1:] != (4, 3):
        raise ValueError(f"surfel points must have shape (k, 4, 3), got {p.shape}")
    view = np.asarray(viewpoints, dtype=float).reshape(-1, 3)
    if len(view) != len(p):
        raise ValueError(f"viewpoints must have shape ({len(p)}, 3), got {view.shape}")
    if len(p) == 0:
        return PlaneGroups(np.zeros(0, int), np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3)),
                           np.zeros(0), 0)
    if floor is not None and np.any(floor):
        floor = np.asarray(floor, dtype=bool)
        parts = [group_surfels(p[side], view[side], settings,
                               None if extra is None else np.asarray(extra)[side],
                               None if alone is None else np.asarray(alone)[side])
                 for side in (~floor, floor)]
        label = np.empty(len(p), dtype=int)
        label[~floor], label[floor] = parts[0].label, parts[1].label + len(parts[0])
        return PlaneGroups(label, *(np.concatenate([getattr(q, name) for q in parts])
                                    for name in ("normals", "offsets", "centroids",
                                                 "normal_errors")),
                           max(q.iterations for q in parts))
    if extra is not None:
        p = np.concatenate([p, np.asarray(extra, dtype=float).reshape(len(p), -1, 3)], axis=1)
    seen = np.broadcast_to(view[:, None], p.shape)
    stats = _plane_stats(p, seen, settings)
    surfel_normals, _, own_error = stats
    sums = _weighted_sums(p, seen, surfel_normals, settings, np.nanmean(p.reshape(-1, 3), axis=0))
    limit = _coplanar_limit(settings)
    alone = None if alone is None or not np.any(alone) else np.asarray(alone, dtype=bool)
    label = _drop_misfits(sums, _components(len(p), *_apart(*_links(p, seen, settings, stats),
                                                             alone)), limit)
    z = settings.merge_sigmas
    for iteration in range(1, settings.max_iterations + 1):
        gn, gd, _, ge, _, _ = _fit_groups(p, view, label, settings)
        # each surfel to the group whose plane fits all its points best, else one of its own
        sigma = _point_sigma(p[:, None], seen[:, None], gn[None, :, None], settings)  # (k, G, n)
        misfit = np.abs(np.einsum("knc,gc->kgn", p, gn) - gd[None, :, None]) / sigma
        misfit = np.max(np.where(np.isfinite(misfit), misfit, 0.0), axis=-1)  # worst point
        gate = settings.merge_angle + z * np.hypot(own_error[:, None], ge[None, :])
        fits = (misfit <= z) & (np.arccos(np.clip(np.abs(surfel_normals @ gn.T), 0, 1)) <= gate)
        fits &= _joins(sums, label, len(gn)) <= limit
        if alone is not None:  # neither joins nor is joined
            fits[alone] = False
            fits[:, label[alone]] = False
        own = label.max() + 1 + np.arange(len(p))
        moved = _relabel(np.where(fits.any(axis=1),
                                  np.argmin(np.where(fits, misfit, np.inf), axis=1), own))
        *_, pts, pts_view = _fit_groups(p, view, moved, settings)
        lone = None if alone is None else np.isin(np.arange(moved.max() + 1), moved[alone])
        merged = _components(int(moved.max()) + 1,
                             *_apart(*_links(pts, pts_view, settings), lone))[moved]
        merged = _drop_misfits(sums, merged, limit)
        if np.array_equal(merged, label):
            break
        label = merged
    gn, gd, gc, ge, _, _ = _fit_groups(p, view, label, settings)
    return PlaneGroups(label, gn, gd, gc, ge, iteration)


#: The floor the robot drives on: the plane z = 0 of the world frame, where
#: ``Pose.sensor_on_robot`` puts its wheels (unit normal, offset [m]).
GROUND = (np.array([0.0, 0.0, 1.0]), 0.0)


def on_ground(n_groups: int, points, label, viewpoints,
              settings: SurfelSettings = SurfelSettings()) -> np.ndarray:
    """(G,) True for the ``n_groups`` groups (of surfels, or single surfels) whose points fit
    the ground plane (:data:`GROUND`) as the merging tests let two groups share a plane, the
    ground being known exactly: every point within ``merge_sigmas`` expected errors of it, and
    its chi^2 there exceeding that of the group's own least-squares plane by at most
    :func:`_coplanar_limit` (three points at least).

    Args:
        n_groups: G.
        points: (P, 3) measured points [m] (surfel, fill and check echoes); label: (P,) their
            group in [0, G); viewpoints: (P, 3) the sensor positions they were measured from [m].
    """
    label = np.asarray(label)
    if n_groups == 0 or len(label) == 0:
        return np.zeros(n_groups, dtype=bool)
    up, level = GROUND
    w = _point_sigma(points, viewpoints, up, settings) ** -2.0
    ground = np.bincount(label, weights=w * (points @ up - level) ** 2, minlength=n_groups)
    worst = np.zeros(n_groups)
    np.maximum.at(worst, label, np.abs(points @ up - level) * np.sqrt(w))
    q = points - points.mean(axis=0)  # the weighted sums of each group's own plane fit
    first = np.stack([np.bincount(label, weights=w * q[:, i], minlength=n_groups)
                      for i in range(3)], axis=1)
    second = np.zeros((n_groups, 3, 3))
    np.add.at(second, label, w[:, None, None] * q[:, :, None] * q[:, None, :])
    own = _misfit(np.bincount(label, weights=w, minlength=n_groups), first, second)
    count = np.bincount(label, minlength=n_groups)
    return (count >= 3) & (worst <= settings.merge_sigmas) \
        & (ground - own <= _coplanar_limit(settings))


def project_onto_plane(points, normal, offset) -> np.ndarray:
    """Orthogonal projection of points (..., 3) [m] onto planes n . x = d (normals (..., 3) and
    offsets (...) [m] broadcast against the points)."""
    p = np.asarray(points, dtype=float)
    n = np.asarray(normal, dtype=float)
    return p - (np.sum(p * n, axis=-1) - offset)[..., None] * n


def _plane_offsets(points, viewpoint, groups: PlaneGroups, settings: SurfelSettings) -> np.ndarray:
    """(c, G) signed distances of points (c, 3) [m] seen from ``viewpoint`` (3,) [m] from each
    group's plane, in expected errors (:func:`_point_sigma`)."""
    sigma = _point_sigma(points[:, None], viewpoint, groups.normals[None], settings)
    return (points @ groups.normals.T - groups.offsets) / sigma


def _on_planes(points, viewpoint, groups: PlaneGroups, settings: SurfelSettings) -> np.ndarray:
    """(c, G) True where points (c, 3) [m] seen from ``viewpoint`` (3,) [m] lie on each
    group's plane within ``merge_sigmas`` expected errors (:func:`_plane_offsets`)."""
    return np.abs(_plane_offsets(points, viewpoint, groups, settings)) <= settings.merge_sigmas


@dataclass(frozen=True)
class Creases:
    """Image creases as arrays (C = number of creases): the groups on either side ``a``, ``b``
    (C,), the world-from-camera rotations (C, 3, 3) and camera positions (C, 3) [m], focal
    lengths (C,) and principal points (C, 2) [pixels], and the segments' ends (C, 2, 2)
    [pixels]."""

    a: np.ndarray
    b: np.ndarray
    rotation: np.ndarray
    origin: np.ndarray
    focal: np.ndarray
    principal: np.ndarray
    ends: np.ndarray

    @classmethod
    def of(cls, creases) -> "Creases":
        """From a list of (camera, world-from-camera pose, segment (4,), group a, group b)."""
        c = list(creases)
        return cls(np.array([k[3] for k in c], int), np.array([k[4] for k in c], int),
                   np.array([k[1].rotation for k in c]).reshape(-1, 3, 3),
                   np.array([k[1].translation for k in c]).reshape(-1, 3),
                   np.array([k[0].focal_pixels for k in c], float),
                   np.array([k[0].principal_point for k in c], float).reshape(-1, 2),
                   np.array([k[2] for k in c], float).reshape(-1, 2, 2))

    def __len__(self) -> int:
        return len(self.a)

    def take(self, keep) -> "Creases":
        """The creases at ``keep`` (indices or mask)."""
        return Creases(*(getattr(self, f.name)[keep] for f in fields(self)))


def _crease_residuals(normals, offsets, creases: Creases) -> np.ndarray:
    """Distances [pixels] (C, 2) of each detected segment's ends from the image of the line
    where its two planes meet (1e3 where the planes are parallel: no crease)."""
    if not len(creases):
        return np.zeros((0, 2))
    na, nb = normals[creases.a], normals[creases.b]
    line = np.cross(na, nb)
    norm = np.linalg.norm(line, axis=1)
    parallel = norm < 1e-9
    line = np.where(parallel[:, None], [0.0, 0.0, 1.0], line) / np.where(parallel, 1.0,
                                                                         norm)[:, None]
    o = creases.origin
    system = np.stack([np.where(parallel[:, None], [1.0, 0.0, 0.0], na),
                       np.where(parallel[:, None], [0.0, 1.0, 0.0], nb), line], axis=1)
    rhs = np.column_stack([offsets[creases.a], offsets[creases.b], np.einsum("ci,ci->c", line, o)])
    p0 = np.linalg.solve(system, rhs[..., None])[..., 0]  # on the crease, nearest the camera
    r = creases.rotation  # camera frame: R^T (x - o)
    h = np.cross(np.einsum("cji,cj->ci", r, p0 - o), np.einsum("cji,cj->ci", r, line))
    f = creases.focal[:, None]
    xy = np.concatenate([(creases.ends - creases.principal[:, None]) / f[..., None],
                         np.ones(creases.ends.shape[:2] + (1,))], axis=2)
    out = f * np.einsum("cei,ci->ce", xy, h) / np.maximum(np.hypot(h[:, 0], h[:, 1]),
                                                           1e-12)[:, None]
    return np.where(parallel[:, None], 1e3, out)


def refine_planes(groups: PlaneGroups, points, label, viewpoints, creases,
                  settings: SurfelSettings = SurfelSettings()) -> PlaneGroups:
    """Planes fitted jointly to the sonar points and the image creases (package docstring).

    Args:
        groups: the least-squares groups (starting point and orientation).
        points: (P, 3) measured points [m]; label: (P,) their group; viewpoints: (P, 3) the
            sensor positions they were measured from [m].
        creases: (camera, world-from-camera pose, segment (4,), group a, group b) of every
            segment with a different plane on each side.
    Minimises sum rho(r_i^2) over the point-to-plane distances / their expected error (from
    ``range_sigma`` and ``angle_sigma`` at the incidence on the starting plane) and the
    crease distances / ``crease_sigma`` (rho: soft L1, so a residual beyond about two sigmas
    counts linearly: robust to the few echoes from elsewhere); creases whose residual on the
    starting planes exceeds ``crease_gate`` pixels are left out.
    """
    from scipy.optimize import least_squares

    n_groups = len(groups)
    if n_groups == 0 or len(points) == 0:
        return groups
    label = np.asarray(label)
    creases = Creases.of(creases)
    start = _crease_residuals(groups.normals, groups.offsets, creases)
    keep = creases.take(np.max(np.abs(start), axis=1, initial=0.0) <= settings.crease_gate)

    def unpack(x):
        v = x.reshape(n_groups, 4)
        return v[:, :3] / np.linalg.norm(v[:, :3], axis=1, keepdims=True), v[:, 3]

    sigma = _point_sigma(points, viewpoints, groups.normals[label], settings)

    def residuals(x):
        n, d = unpack(x)
        r_points = (np.einsum("pc,pc->p", points, n[label]) - d[label]) / sigma
        return np.concatenate([r_points,
                               _crease_residuals(n, d, keep).ravel() / settings.crease_sigma])

    # Which parameters each residual depends on: a point its group's 4, a crease's two ends the
    # 8 of its two groups; the finite-difference Jacobian then perturbs independent columns
    # together instead of one at a time.
    owners = np.concatenate([np.column_stack([label, label]),
                             np.repeat(np.column_stack([keep.a, keep.b]), 2, axis=0)])
    cols = (4 * owners[:, :, None] + np.arange(4)).reshape(len(owners), 8)
    sparsity = coo_matrix((np.ones(cols.size), (np.repeat(np.arange(len(owners)), 8),
                                                cols.ravel())),
                          shape=(len(owners), 4 * n_groups)).tocsr()
    x0 = np.column_stack([groups.normals, groups.offsets]).ravel()
    n, d = unpack(least_squares(residuals, x0, loss="soft_l1", f_scale=2.0,
                                jac_sparsity=sparsity).x)
    flip = np.where(np.einsum("gc,gc->g", n, groups.normals) < 0, -1.0, 1.0)
    n, d = n * flip[:, None], d * flip
    return replace(groups, normals=n, offsets=d)
