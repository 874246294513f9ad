"""Surfel scanning reconstruction (paper section III-D, Fig. 5): camera lines -> triangle surfels
-> four pings each -> verification -> registration (12) -> fill pings -> plane optimisation
(14)(15) and joint refinement with the image creases ->
planes grown inside the image regions bounded by the line segments -> surfel map.

Per pose (:func:`scan_pose`): the image is rendered, line segments are detected in the part
inside the array's field of view, triangle surfels are built from segment pairs and each is
pinged at its four scan pixels (:mod:`mitsonar.recon.lines`; beam directions by (10)(11), parallel to
the camera rays). A surfel is registered when all four beams detect an echo and the measured
centroid lies within ``verify_threshold`` (0.15 m, the paper's) of the plane through the three
other points; its points go to the world by (12) with the odometry pose. Beyond the paper, the
three outer points must also span at least ``min_spread`` of the triangle the aimed beams give
at the measured ranges (:func:`spread_ratio`): four echoes bunched on one edge (a window frame
answering for glass seen obliquely, which returns no echo) pass the coplanarity test whatever
plane they are said to span, and such a surfel, tilted 36 deg on room_glass, pulled a window and
the floor into one group.

Plane optimisation (:func:`group_surfels`): the paper groups surfels whose normals agree
(cosine similarity); here that is only the first, coarse gate (see the deviations below). Two
surfels share a plane when their normals agree within ``merge_angle`` widened by
``merge_sigmas`` standard errors of the two normals, and every point of both (four scan points
and the fill points) lies within ``merge_sigmas`` expected errors (``range_sigma``,
``angle_sigma``: the refinement's weights, below) of the least-squares plane through all of them
(connected components, so groups chain along a wall). Each group's plane is the least-squares fit
(14)(15) of its points: the last right singular vector of the centred points, oriented towards
the sensor positions that saw it. Then, until nothing changes: every surfel moves to the group
whose fitted plane fits all its points (the same two tests against the group's plane), the best
by its worst point's distance over its expected error, or to a group of its own if none does,
and groups whose points fit one plane together merge. A group of one surfel whose normal is
poorly determined (standard error above ``max_normal_error``: a small noisy surfel that fits no
other group) claims no image region, so no plane is grown from it (:func:`grow_planes`; its
points still enter the fits).

Deviations from the paper, measured on a rendered room corner (two walls and a floor, three
poses 2.8 m away, 'paper' preset; per scan point, measured against the true range along the
beam): the echo of a scan point always comes from the face it is aimed at (all 25 reflectors of
the paper model, and all rays within 4 deg of the axis of the physical model, hit that face, the
nearest crease being 17 cm or more away), so neighbouring faces are not the error source. The
error is the footprint's: at incidence theta the footprint spans r w tan(theta) in range
(10-25 cm on the walls at 20-47 deg, 50-65 cm on the floor at 73-75 deg) and the strongest
envelope peak picks a part of it, as if the echo came from a direction about 1 deg off the axis:
points lie 0-3.5 cm off their plane on the walls (random sign), +3.2-3.8 cm on the floor (the
nearer part of a grazing footprint echoes louder); the physical model's diffuse speckle is worse
(up to 6 cm off on the walls, 25 cm range errors on the floor). Four such points per surfel and
three surfels per face give normals 1-3 deg off. Hence:

* Fill pings (:func:`fill_pixels`): each registered surfel is pinged again at up to
  ``max_fill`` pixels on a grid of one footprint (``fill_spacing``, 5 deg) inside its triangle,
  at least ``fill_margin`` (3 deg: half a footprint plus the line's error) from its edges, so no
  footprint reaches across a crease; these beams are re-aimed at the plane of the surfel's four
  measured points (:func:`~mitsonar.recon.lines.scan_directions` with a depth), removing the 7.5 cm
  camera-array parallax. Fill echoes farther than ``verify_threshold`` from the surfel's plane
  are dropped. They join the group fits (14)(15) but not the verification.
* Grouping by point fit (:func:`group_surfels`): the paper compares the surfels' normals. A
  surfel's normal is determined by its points' errors over its extent: the standard error is
  atan(s / S2), s the per-point error (from the fit's residuals, at least the expected error)
  and S2 the points' second singular value. A small surfel with 1-3 cm point errors has a
  normal 7-13 deg off (10-17 deg standard error) and formed a group of its own, which claimed
  an image region and grew a wrong plane, or split a wall so that a shadow line across it was
  kept (the shadow test with the edge at 0.9 m: now removed in all three poses, normals
  0.7-1.4 deg off). Judged by whether its points fit the wall's plane within their expected
  errors, with the normal test widened by the normals' standard errors, it joins the wall; a
  surfel on another face has points tens of centimetres off the plane and a normal 90 deg off,
  and stays apart. On scenes/room_glass (8 poses, 800 px, 'paper' preset: five registered
  surfels, all on the two windows) this puts the third surfel on the east window into that
  window's group, yet the map gets worse (15.3 % of the sampled points within 2 cm instead of
  24.8 %): most of it comes from one pose whose 13 segments close no region, so its whole crop
  is grown onto the nearest claiming plane, and the window's plane, fitted to 12 points on a
  strip 37 cm tall, is tilted 2.5 deg (grouping cannot fix either).
* Joint refinement (:func:`refine_planes`): the planes are refitted together, minimising robust
  (soft L1) residuals of (a) every point's distance from its plane over its expected error
  sqrt(``range_sigma``^2 + (r tan(``angle_sigma``) sin(theta))^2), which down-weights grazing
  points, and (b) for every detected segment with a different plane on each side (a crease,
  :func:`segment_sides`), the pixel distance of its ends from the image of the line where the two
  planes meet, over ``crease_sigma``. The camera fixes where planes meet (the paper's "planes
  expand until they intersect ... constrained by the line segments", used here as a constraint
  on the fit), the sonar fixes the depth and the rest of the orientation. Constraints whose
  residual on the sonar-only planes exceeds ``crease_gate`` (an occlusion edge, a segment
  between unrelated planes) are left out. On the corner this gives normals within 0.7 deg and
  the corner within 1 cm (tests/test_surfels.py); the pose meshes are then grown again on the
  refined planes. ``max_fill=0, refine=False`` is the paper's method.

Growing (:func:`region_labels`, :func:`grow_planes`): the detected segments, extended by
``barrier_extension`` and drawn ``barrier_width`` thick, cut the field-of-view crop into
4-connected regions. Every registered surfel (from any pose) whose scan points project into a
region claims it for its group. Each claimed region's pixels (on a ``stride`` grid) are
back-projected along the camera rays onto every claiming plane and the *nearest* intersection in
front of the camera (within ``max_range``) is kept: inside a room (concave corners) the nearest
of two planes is the visible one, so a region that leaks across an undetected crease is still
split at the planes' intersection ("planes expand until they intersect or exceed the field of
view, constrained by the line segments"). Convex edges seen from outside (a box corner) would
need the farthest instead; this implementation assumes room interiors. The mesh of a pose joins
grid neighbours on the same plane into triangles; the map is the union over poses, rebuilt on
the global planes.

Junctions (:func:`~mitsonar.recon.lines.close_junctions`): before the segments become barriers,
an end that stops at most ``junction_gap`` pixels short of a junction with another segment is
extended to it; FLD often stops a few pixels short of a window's corner, and the whole crop
leaked through that gap onto the window's plane.

Check pings (:func:`check_pose`, :func:`_support`; an addition beyond the paper,
``check_spacing=0`` turns it off): a plane grown over a whole region asserts depths the sonar
never measured. After the first map, every pose pings its grown planes on a ``check_spacing``
(5 deg) grid, ``fill_margin`` away from the lines, aimed at the grown plane's point. A check
echo on a plane claiming its region (within ``merge_sigmas`` expected errors) joins that plane's
fit (:func:`_check_points`; assignment and refit repeat until the set settles), and the map is
grown again, each plane only where the nearest evidence in the same region (projected surfel
points and heard check pings) confirms it; a check without an echo (a smooth wall seen
obliquely reflects away from the array) says nothing. On scenes/room_glass (8 poses, 800 px,
'paper' preset) a window plane fitted to 12 points on a 37 cm strip was 2.4 deg off and grown
over a whole crop: 15.3 % of the sampled points within 2 cm; junction closing, the check
points in the fits and the gating bring it to 99.8 % (measured on raw 32 spp images).

Shadow lines (paper Fig. 8a, :func:`shadow_segments`): a segment whose two sides (sampled
``shadow_offset`` pixels across it) both lie in regions claimed by the same single plane group
is not a structural edge (a cast shadow, a texture edge): it is removed, the surfels built on it
are dropped, and the regions are recomputed without it.

Pixel coordinates follow :mod:`mitsonar.recon.lines` (pixel centres at half-integers).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from mitsonar.physics.beampattern import in_fov
from mitsonar.sensors.camera import CameraModel, CameraRenderer
from mitsonar.frames import Pose
from mitsonar.recon.lines import (close_junctions, detect_segments, fov_crop_box, scan_directions, scan_pixels,
                    triangle_surfels)
from mitsonar.sensors.sonar import Sonar
from mitsonar.validation import check_positive, check_range

#: Why surfels were not registered (keys of :attr:`SurfelMap.rejected`).
REJECTIONS = ("no_echo", "verification", "shadow_line")


@dataclass(frozen=True)
class SurfelSettings:
    """Parameters of surfel scanning; pixel quantities refer to the working ``image_width``.

    Attributes:
        image_width: camera image width [pixels] (the 1600 x 1200 camera scaled down).
        spp: camera samples per pixel (8 with the camera's denoiser; FLD needs 32 or more on raw
            path-traced images).
        min_length: shortest line segment kept [pixels]; None: the paper's 50 px at 1600 px,
            scaled to ``image_width``.
        verify_threshold: largest distance of the measured centroid from the plane of the three
            other measured points for a surfel to be registered [m] (paper: 0.15 m).
        min_spread: smallest :func:`spread_ratio` of a registered surfel (module docstring).
        merge_angle: coarse gate: largest angle between the normals of one plane group [rad],
            widened by ``merge_sigmas`` standard errors of the two normals.
        merge_sigmas: surfels share a plane when all their points lie within this many expected
            errors (``range_sigma``, ``angle_sigma``) of it (module docstring).
        max_normal_error: a group of one surfel whose normal's standard error exceeds this
            [rad] (a small noisy surfel) claims no image region: no plane is grown from it.
        max_link_error: a surfel or group whose normal's standard error exceeds this [rad]
            links no others into one group (:func:`_links`).
        barrier_extension: how far each segment is extended at both ends when drawn as a
            region barrier [pixels] (closes small gaps at junctions).
        barrier_width: thickness of the drawn barriers [pixels].
        junction_gap: barrier segments that stop at most this short of a junction with another
            segment are extended to it [pixels] (:func:`~mitsonar.recon.lines.close_junctions`).
        stride: grid step of the back-projected pixels [pixels].
        max_range: farthest back-projected map point from the camera [m]; None: the sonar's
            ``SonarConfig.max_range``, beyond which no check ping can confirm or refute a grown
            plane (a floor grown through a doorway onto the wall behind it reached 10 m); no
            limit where planes are grown without a sonar (:func:`build_map` called directly).
        shadow_offset: distance across a segment at which its two sides are sampled [pixels].
        remove_shadows: remove shadow lines (segments with one plane on both sides) and the
            surfels built on them; False keeps every segment (for comparison).
        max_iterations: cap on the regroup/refit iterations.
        seed: seeds the images and the pings.
        fill_spacing: angular spacing of the fill pings inside a registered surfel [rad] (about
            one beam footprint, 5 deg: neighbouring footprints barely overlap, so their range
            errors are nearly independent).
        fill_margin: smallest angle between a fill ping and the surfel's two line segments [rad]
            (the footprint's half-width, 2.5 deg, plus 0.5 deg for the line's pixel error).
        max_fill: most fill pings per surfel (0: the paper's four pings only).
        refine: refine the planes jointly with the crease constraints (module docstring).
        check_spacing: angular spacing of the check pings over the grown planes [rad] (0: no
            check pings, planes fill their claimed regions unchecked as in the paper).
        range_sigma, angle_sigma: a point at range r seen at incidence theta is expected off
            its plane by sqrt(range_sigma^2 + (r tan(angle_sigma) sin(theta))^2) [m]: the echo's
            range belongs to a direction up to a fraction of the footprint off the beam axis
            (1 deg: 2-3.5 cm measured at 2-2.5 m and 20-75 deg incidence), plus the timing error.
        crease_sigma: expected error of a detected line [pixels].
        crease_gate: crease constraints whose sonar-only residual exceeds this [pixels] are not
            used (an occlusion edge or a segment between two unrelated planes).
    """

    image_width: int = 400
    spp: int = 8
    min_length: float | None = None
    verify_threshold: float = 0.15
    min_spread: float = 0.5
    merge_angle: float = np.radians(10.0)
    merge_sigmas: float = 3.0
    max_normal_error: float = np.radians(5.0)
    max_link_error: float = np.radians(20.0)
    barrier_extension: float = 4.0
    barrier_width: int = 3
    junction_gap: float = 25.0
    stride: int = 2
    max_range: float | None = None
    shadow_offset: float = 5.0
    remove_shadows: bool = True
    max_iterations: int = 20
    seed: int = 0
    fill_spacing: float = np.radians(5.0)
    fill_margin: float = np.radians(3.0)
    max_fill: int = 8
    refine: bool = True
    check_spacing: float = np.radians(5.0)
    range_sigma: float = 0.005
    angle_sigma: float = np.radians(1.0)
    crease_sigma: float = 1.0
    crease_gate: float = 30.0

    def __post_init__(self):
        if int(self.max_fill) != self.max_fill or self.max_fill < 0:
            raise ValueError(f"SurfelSettings.max_fill must be an integer >= 0, got {self.max_fill}")
        for name in ("fill_spacing", "fill_margin", "range_sigma", "angle_sigma", "crease_sigma",
                     "crease_gate"):
            check_positive(f"SurfelSettings.{name}", getattr(self, name))
        for name in ("image_width", "spp", "barrier_width", "stride", "max_iterations"):
            value = getattr(self, name)
            if int(value) != value or value < 1:
                raise ValueError(f"SurfelSettings.{name} must be a positive integer, got {value}")
        if self.min_length is not None:
            check_positive("SurfelSettings.min_length [pixels]", self.min_length)
        check_positive("SurfelSettings.verify_threshold [m]", self.verify_threshold)
        check_range("SurfelSettings.min_spread", self.min_spread, 0.0, 1.0)
        check_range("SurfelSettings.merge_angle [rad]", self.merge_angle, 0.0, np.pi / 2)
        check_positive("SurfelSettings.merge_sigmas", self.merge_sigmas)
        check_range("SurfelSettings.max_normal_error [rad]", self.max_normal_error, 0.0, np.pi / 2)
        check_range("SurfelSettings.max_link_error [rad]", self.max_link_error, 0.0, np.pi / 2)
        check_range("SurfelSettings.barrier_extension [pixels]", self.barrier_extension, 0, np.inf)
        check_range("SurfelSettings.junction_gap [pixels]", self.junction_gap, 0, np.inf)
        check_range("SurfelSettings.check_spacing [rad]", self.check_spacing, 0, np.pi / 2)
        if self.max_range is not None:
            check_positive("SurfelSettings.max_range [m]", self.max_range)
        check_positive("SurfelSettings.shadow_offset [pixels]", self.shadow_offset)

    @property
    def segment_min_length(self) -> float:
        """Shortest segment kept at ``image_width`` [pixels]."""
        if self.min_length is not None:
            return float(self.min_length)
        return 50.0 * self.image_width / 1600.0


# ---- geometry --------------------------------------------------------------------------------
def plane_through(points) -> tuple[np.ndarray, np.ndarray]:
    """Unit normals (k, 3) and offsets (k,) [m] (n . x = d) of the planes through the first three
    of points (k, >=3, 3); NaN for collinear triples."""
    p = np.asarray(points, dtype=float)
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.where(norm > 1e-12, n / np.maximum(norm, 1e-300), np.nan)
    return n, np.einsum("kc,kc->k", n, p[:, 0])


def verify(points, threshold: float = 0.15) -> tuple[np.ndarray, np.ndarray]:
    """The paper's surfel test on measured points (k, 4, 3) [m] (three, then the centroid).

    Returns (accepted (k,), residual (k,) [m]): the distance of the fourth point from the plane
    of the first three (inf if any point is NaN or the three are collinear), accepted when at
    most ``threshold`` [m].
    """
    p = np.asarray(points, dtype=float)
    if p.ndim != 3 or p.shape[1:] != (4, 3):
        raise ValueError(f"surfel points must have shape (k, 4, 3), got {p.shape}")
    check_positive("verify threshold [m]", threshold)
    n, d = plane_through(p)
    residual = np.abs(np.einsum("kc,kc->k", n, p[:, 3]) - d)
    residual = np.where(np.isfinite(residual), residual, np.inf)
    return residual <= threshold, residual


def _triangle_areas(p) -> np.ndarray:
    """Areas (k,) [m^2] of the triangles of the first three of points (k, >=3, 3)."""
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=-1)


def spread_ratio(points, directions) -> np.ndarray:
    """(k,) area of the triangle of the three outer measured points (k, 4, 3) [m] over the area
    of the triangle the aimed unit directions (k, 4, 3) give at the same ranges (both in the
    sensor frame); NaN where a point is missing."""
    p = np.asarray(points, dtype=float)
    aimed = np.asarray(directions, dtype=float) * np.linalg.norm(p, axis=-1, keepdims=True)
    expected = _triangle_areas(aimed)
    return _triangle_areas(p) / np.where(expected > 0, expected, np.nan)


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
    the least-squares plane of the two sets together.

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
    dist = np.abs(np.einsum("amc,abc->abm", q, pair) - np.einsum("abc,abc->ab", mean, pair)[..., None])
    sigma = _point_sigma(points[:, None], viewpoints[:, None], pair[:, :, None], settings)
    inside = np.all(~ok[:, None] | (dist <= settings.merge_sigmas * sigma), axis=-1)  # a's points
    gate = settings.merge_angle + settings.merge_sigmas * np.hypot(error[:, None], error[None, :])
    angle = np.arccos(np.clip(np.abs(normal @ normal.T), 0.0, 1.0))
    vague = error > settings.max_link_error
    linked = inside & inside.T & (angle <= gate + 1e-12) & ~vague[:, None] & ~vague[None, :]
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
            (:func:`_plane_stats`); single-surfel groups above ``max_normal_error`` are not
            grown.
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


def group_surfels(points, viewpoints, settings: SurfelSettings = SurfelSettings(),
                  extra=None) -> PlaneGroups:
    """Plane groups of registered surfels (module docstring: grouping, (14)(15), iteration).

    Args:
        points: (k, 4, 3) measured world points of each surfel [m].
        viewpoints: (k, 3) sensor position from which each surfel was measured [m].
        settings: ``merge_angle``, ``merge_sigmas``, ``range_sigma``, ``angle_sigma`` (the
            tolerances) and ``max_iterations`` (cap on the regroup/refit rounds).
        extra: (k, m, 3) fill points of each surfel [m] (NaN-padded), used in the tests and fits.
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
    if extra is not None:
        p = np.concatenate([p, np.asarray(extra, dtype=float).reshape(len(p), -1, 3)], axis=1)
    seen = np.broadcast_to(view[:, None], p.shape)
    stats = _plane_stats(p, seen, settings)
    surfel_normals, _, own_error = stats
    label = _components(len(p), *_links(p, seen, settings, stats))
    z = settings.merge_sigmas
    for iteration in range(1, settings.max_iterations + 1):
        gn, gd, _, ge, _, _ = _fit_groups(p, view, label, settings)
        # each surfel to the group whose plane fits all its points best, else one of its own
        sigma = _point_sigma(p[:, None], seen[:, None], gn[None, :, None], settings)  # (k, G, n)
        misfit = np.abs(np.einsum("knc,gc->kgn", p, gn) - gd[None, :, None]) / sigma
        misfit = np.max(np.where(np.isfinite(misfit), misfit, 0.0), axis=-1)  # worst point
        gate = settings.merge_angle + z * np.hypot(own_error[:, None], ge[None, :])
        fits = (misfit <= z) & (np.arccos(np.clip(np.abs(surfel_normals @ gn.T), 0, 1)) <= gate)
        own = label.max() + 1 + np.arange(len(p))
        moved = _relabel(np.where(fits.any(axis=1),
                                  np.argmin(np.where(fits, misfit, np.inf), axis=1), own))
        *_, pts, pts_view = _fit_groups(p, view, moved, settings)
        merged = _components(int(moved.max()) + 1, *_links(pts, pts_view, settings))[moved]
        if np.array_equal(merged, label):
            break
        label = merged
    gn, gd, gc, ge, _, _ = _fit_groups(p, view, label, settings)
    return PlaneGroups(label, gn, gd, gc, ge, iteration)


def project_onto_plane(points, normal, offset) -> np.ndarray:
    """Orthogonal projection of points (..., 3) [m] onto planes n . x = d (normals (..., 3) and
    offsets (...) [m] broadcast against the points)."""
    p = np.asarray(points, dtype=float)
    n = np.asarray(normal, dtype=float)
    return p - (np.sum(p * n, axis=-1) - offset)[..., None] * n


def camera_rays(camera: CameraModel, camera_pose: Pose, pixels) -> np.ndarray:
    """World directions (..., 3) (not normalised, camera z = 1) of pixels (..., 2)."""
    p = np.asarray(pixels, dtype=float)
    uc, vc = camera.principal_point
    f = camera.focal_pixels
    local = np.stack([(p[..., 0] - uc) / f, (p[..., 1] - vc) / f, np.ones(p.shape[:-1])], axis=-1)
    return camera_pose.transform_vectors(local)


def intersect_planes(origin, rays, normals, offsets) -> np.ndarray:
    """Ray parameters t (..., G) of rays (..., 3) from ``origin`` (3,) hitting planes (G, 3),
    (G,); NaN where parallel."""
    denom = np.asarray(rays) @ np.asarray(normals).T
    num = np.asarray(offsets)[None, :] - (np.asarray(normals) @ origin)[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(np.abs(denom) > 1e-12, num.reshape((1,) * (denom.ndim - 1) + (-1,))
                        / denom, np.nan)


# ---- one pose --------------------------------------------------------------------------------
@dataclass(frozen=True)
class PoseScan:
    """What one pose contributed.

    Attributes:
        pose: world-from-sensor pose used for registration (odometry) [m].
        camera: the working camera model.
        box: (u0, v0, u1, v1) field-of-view crop [pixels].
        segments: (n, 4) detected line segments [pixels].
        triangles: (k, 3, 2) image triangles of all candidate surfels [pixels].
        segment_pairs: (k, 2) segments of each candidate.
        points_world: (k, 4, 3) measured points [m], NaN where no echo.
        residual: (k,) verification residual [m] (inf: an echo missing).
        accepted: (k,) registered.
        gray: (H, W) linear luminance image (for figures).
        pings: beams fired.
        fill_world: (k, max_fill, 3) measured fill points of the registered surfels [m], NaN
            where none (None: no fill pings).
        checks: the check pings fired over the grown planes (None: none, growth unchecked).
    """

    pose: Pose
    camera: CameraModel
    box: tuple
    segments: np.ndarray
    triangles: np.ndarray
    segment_pairs: np.ndarray
    points_world: np.ndarray
    residual: np.ndarray
    accepted: np.ndarray
    gray: np.ndarray
    pings: int
    fill_world: np.ndarray | None = None
    checks: CheckPings | None = None


def tone_map(gray, percentile: float = 99.0) -> np.ndarray:
    """Display-like [0, 1] image of linear luminance (H, W): divided by its ``percentile`` [%]
    (so a bright window or lamp does not darken the walls), clipped, gamma 2.2."""
    g = np.asarray(gray, dtype=float)
    top = np.percentile(g, percentile) if g.size else 1.0
    top = top if top > 0 else 1.0
    return np.clip(g / top, 0.0, 1.0) ** (1 / 2.2)


def fill_pixels(triangles, spacing: float, margin: float, count: int) -> np.ndarray:
    """Fill scan pixels (k, count, 2) [pixels] inside triangles (k, 3, 2), NaN-padded.

    Candidates lie on a square grid of ``spacing`` [pixels] anchored at the centroid, at least
    ``margin`` [pixels] inside every edge; starting from the paper's four scan pixels, the
    candidate farthest from all chosen pixels is taken next (farthest-point sampling) until
    ``count`` are chosen or the farthest is nearer than ``spacing`` / 2.
    """
    tri = np.asarray(triangles, dtype=float).reshape(-1, 3, 2)
    out = np.full((len(tri), count, 2), np.nan)
    if count == 0:
        return out
    for k, t in enumerate(tri):  # a few dozen surfels
        c = t.mean(axis=0)
        reach = np.max(np.linalg.norm(t - c, axis=1))
        steps = np.arange(-np.ceil(reach / spacing), np.ceil(reach / spacing) + 1) * spacing
        grid = c + np.stack(np.meshgrid(steps, steps), axis=-1).reshape(-1, 2)
        inside = np.ones(len(grid), bool)
        for i in range(3):  # signed distance to each edge, positive towards the third vertex
            a, b, o = t[i], t[(i + 1) % 3], t[(i + 2) % 3]
            e = (b - a) / max(np.linalg.norm(b - a), 1e-12)
            nrm = np.array([-e[1], e[0]])
            nrm = nrm if (o - a) @ nrm > 0 else -nrm
            inside &= (grid - a) @ nrm >= margin
        cand = grid[inside]
        chosen = list(scan_pixels(t[None])[0])
        for j in range(count):
            if len(cand) == 0:
                break
            dist = np.min(np.linalg.norm(cand[:, None] - np.array(chosen)[None], axis=-1), axis=1)
            best = int(np.argmax(dist))
            if dist[best] < spacing / 2:
                break
            out[k, j] = cand[best]
            chosen.append(cand[best])
    return out


def _fill_directions(camera: CameraModel, geometry, pixels, points_sensor):
    """Beam directions (k, m, 3) (NaN where none) for fill pixels (k, m, 2), re-aimed at the
    plane of each surfel's four measured points (k, 4, 3) (sensor frame) to remove the camera's
    parallax; directions outside the field of view are dropped (NaN)."""
    k, m = pixels.shape[:2]
    out = np.full((k, m, 3), np.nan)
    ok = np.all(np.isfinite(pixels), axis=-1) & np.all(np.isfinite(points_sensor), axis=(1, 2))[:, None]
    if not np.any(ok):
        return out
    uc, vc = camera.principal_point
    f = camera.focal_pixels
    ray = np.stack([(pixels[..., 0] - uc) / f, (pixels[..., 1] - vc) / f, np.ones((k, m))], -1)
    normal = np.zeros((k, 3))
    offset = np.zeros(k)
    for i in np.nonzero(ok.any(axis=1))[0]:
        normal[i], offset[i] = fit_plane(points_sensor[i])
    origin = np.asarray(camera.offset, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (offset - normal @ origin)[:, None] / np.einsum("kmc,kc->km", ray, normal)
    depth = origin[2] + t  # sensor-frame z of the camera ray's hit of the surfel plane
    ok &= np.isfinite(depth) & (depth > 0.05)
    if not np.any(ok):
        return out
    dirs = scan_directions(camera, pixels[ok], depth=depth[ok])
    inside = in_fov(dirs, geometry.fov_horizontal, geometry.fov_vertical)
    rows = np.nonzero(ok)
    out[rows[0][inside], rows[1][inside]] = dirs[inside]
    return out


def scan_pose(sonar: Sonar, renderer: CameraRenderer, true_pose: Pose, odometry_pose: Pose,
              settings: SurfelSettings = SurfelSettings(), seed: int = 0) -> PoseScan:
    """Render, detect lines and surfels, ping their scan points in one scan, verify, register.

    ``true_pose`` places the sensor in the scene; ``odometry_pose`` registers the points (12).
    """
    camera = renderer.model
    images = renderer.render(true_pose, seed=seed)
    box = fov_crop_box(camera, sonar.config.geometry)
    segments = detect_segments(tone_map(images.gray), box, settings.segment_min_length)
    surfels = triangle_surfels(segments)
    pixels = scan_pixels(surfels.vertices) if len(surfels) else np.zeros((0, 4, 2))
    directions = scan_directions(camera, pixels)
    points = np.full((len(surfels), 4, 3), np.nan)
    if len(surfels):
        scan = sonar.scan(true_pose, directions.reshape(-1, 3), seed=seed)
        points = odometry_pose.transform_points(scan.points_sensor).reshape(-1, 4, 3)
    accepted, residual = verify(points, settings.verify_threshold) if len(points) else \
        (np.zeros(0, bool), np.zeros(0))
    if len(surfels):
        spread = spread_ratio(scan.points_sensor.reshape(-1, 4, 3), directions.reshape(-1, 4, 3))
        accepted &= np.nan_to_num(spread) >= settings.min_spread
    fill = np.full((len(surfels), settings.max_fill, 3), np.nan)
    pings = 4 * len(surfels)
    if settings.max_fill and np.any(accepted):
        f = camera.focal_pixels
        fp = fill_pixels(surfels.vertices[accepted], f * np.tan(settings.fill_spacing),
                         f * np.tan(settings.fill_margin), settings.max_fill)
        measured = scan.points_sensor.reshape(-1, 4, 3)[accepted]
        dirs = _fill_directions(camera, sonar.config.geometry, fp, measured)
        aim = np.all(np.isfinite(dirs), axis=-1)
        if np.any(aim):
            second = sonar.scan(true_pose, dirs[aim],
                                seed=int(np.random.SeedSequence([seed, 1]).generate_state(1)[0]))
            got = np.full(dirs.shape, np.nan)
            got[aim] = odometry_pose.transform_points(second.points_sensor)
            # a fill echo off the surfel's plane by more than the verification threshold came
            # from something else (an object in front, a side lobe): dropped
            world = points[accepted]
            for i in range(len(world)):
                n, d = fit_plane(world[i])
                far = np.abs(got[i] @ n - d) > settings.verify_threshold
                got[i][far] = np.nan
            fill[accepted] = got
            pings += int(aim.sum())
    return PoseScan(odometry_pose, camera, box, segments, surfels.vertices, surfels.segment_pairs,
                    points, residual, accepted, images.gray, pings, fill)


# ---- regions and growing ----------------------------------------------------------------------
def region_labels(segments, box, shape, extension: float = 4.0, width: int = 3) -> np.ndarray:
    """Regions (H, W) int of the field-of-view crop cut by the segments: -1 outside the crop and
    on the barriers, else the 4-connected component (0, 1, ...).

    Args:
        segments: (n, 4) [u1, v1, u2, v2] [pixels]; each is extended by ``extension`` [pixels] at
            both ends and drawn ``width`` [pixels] thick.
        box: (u0, v0, u1, v1) crop [pixels]; shape: (H, W) of the image.
    """
    import cv2

    h, w = shape
    free = np.zeros((h, w), np.uint8)
    u0, v0, u1, v1 = box
    free[v0:v1, u0:u1] = 1
    s = np.asarray(segments, dtype=float).reshape(-1, 4)
    a, b = s[:, :2], s[:, 2:]
    unit = (b - a) / np.maximum(np.linalg.norm(b - a, axis=1, keepdims=True), 1e-12)
    ends = np.concatenate([a - extension * unit, b + extension * unit], axis=1) - 0.5  # OpenCV
    shift = 4  # fixed-point bits: sub-pixel line ends
    for e in np.round(ends * (1 << shift)).astype(np.int64):  # a few dozen segments
        cv2.line(free, (int(e[0]), int(e[1])), (int(e[2]), int(e[3])), 0, int(width),
                 cv2.LINE_8, shift)
    _, label = cv2.connectedComponents(free, connectivity=4)
    return np.where(free > 0, label - 1, -1)


def _image_points(camera: CameraModel, pose: Pose, points) -> tuple[np.ndarray, np.ndarray]:
    """Pixels (P, 2) of world points (..., 3) [m] seen from sensor ``pose`` and (P,) True
    where in front of the camera and inside the image."""
    cam = camera.world_from_camera(pose).inverse().transform_points(
        np.asarray(points, dtype=float).reshape(-1, 3))
    uv = np.full((len(cam), 2), np.nan)
    front = cam[:, 2] > 1e-6
    uv[front] = camera.project(cam[front])
    with np.errstate(invalid="ignore"):
        inside = front & (uv[:, 0] >= 0) & (uv[:, 0] < camera.width) & (uv[:, 1] >= 0) & \
            (uv[:, 1] < camera.height)
    return uv, inside


def _region_at(regions, uv) -> np.ndarray:
    """Region (P,) of pixels (P, 2) (-1 outside the image or on a barrier)."""
    uv = np.asarray(uv, dtype=float).reshape(-1, 2)
    out = np.full(len(uv), -1)
    ok = np.all(np.isfinite(uv), axis=1)
    iu, iv = np.floor(uv[ok]).astype(int).T
    h, w = regions.shape
    inside = (iu >= 0) & (iu < w) & (iv >= 0) & (iv < h)
    rows = np.nonzero(ok)[0][inside]
    out[rows] = regions[iv[inside], iu[inside]]
    return out


def _on_planes(points, viewpoint, groups: PlaneGroups, settings: SurfelSettings) -> np.ndarray:
    """(c, G) True where points (c, 3) [m] seen from ``viewpoint`` (3,) [m] lie on each
    group's plane within ``merge_sigmas`` expected errors (:func:`_point_sigma`)."""
    sigma = _point_sigma(points[:, None], viewpoint, groups.normals[None], settings)
    return np.abs(points @ groups.normals.T - groups.offsets) <= settings.merge_sigmas * sigma


@dataclass(frozen=True)
class CheckPings:
    """Check pings of one pose (:func:`check_pose`): beams aimed inside the grown regions to
    confirm or refute the planes grown there.

    Attributes:
        pixels: (n, 2) image pixel each beam was aimed through [pixels].
        points: (n, 3) measured points [m], world frame by the odometry pose; NaN: no echo.
    """

    pixels: np.ndarray
    points: np.ndarray


def _support(scan: PoseScan, regions, groups: PlaneGroups, surfel_uv, surfel_group, pixels,
             settings: SurfelSettings) -> np.ndarray | None:
    """(..., G) True where the sonar evidence of ``scan``'s image supports growing each plane
    at ``pixels`` (..., 2), None when the pose has no check pings (everything allowed).

    Evidence lives in pixels: every projected surfel point (``surfel_uv`` (P, 2), groups
    ``surfel_group`` (P,)) confirms its group; a check ping confirms every group whose plane its
    measured point lies on (within ``merge_sigmas`` expected errors, :func:`_point_sigma`) and
    refutes all others; pings without an echo say nothing. A pixel supports a group when its
    nearest evidence on that group in the same region confirms it.
    """
    from scipy.spatial import cKDTree

    if scan.checks is None or len(groups) == 0:
        return None
    checks = scan.checks
    heard = np.all(np.isfinite(checks.points), axis=1)
    c_uv, c_points = checks.pixels[heard], checks.points[heard]
    on_plane = _on_planes(c_points, scan.pose.translation, groups, settings)
    shape = np.shape(pixels)[:-1]
    px = np.asarray(pixels, dtype=float).reshape(-1, 2)
    # the region as a far-off third coordinate: evidence in another region is never nearest
    far = 10.0 * (regions.shape[0] + regions.shape[1])

    def lift(uv):
        return np.column_stack([uv, far * _region_at(regions, uv)])

    where = lift(px)
    s_lift, c_lift = lift(surfel_uv), lift(c_uv)
    out = np.zeros((len(px), len(groups)), dtype=bool)
    for g in range(len(groups)):  # a few dozen planes
        yes = np.concatenate([s_lift[surfel_group == g], c_lift[on_plane[:, g]]])
        no = c_lift[~on_plane[:, g]]
        if len(yes) == 0:
            continue
        d_yes = cKDTree(yes).query(where)[0]
        d_no = cKDTree(no).query(where)[0] if len(no) else np.full(len(px), np.inf)
        out[:, g] = d_yes <= d_no
    return out.reshape(shape + (len(groups),))


@dataclass(frozen=True)
class PoseMesh:
    """Planes grown in one pose's image.

    Attributes:
        vertices: (V, 3) [m]; triangles: (F, 3) vertex indices; plane: (F,) group per triangle.
        regions: (H, W) region labels (see :func:`region_labels`).
        region_groups: (R, G) surfel points of each group claiming each region.
        grid_pixels: (gv, gu, 2) the back-projected pixel grid [pixels].
        grid_plane: (gv, gu) plane grown at each grid pixel, -1 none.
        grid_points: (gv, gu, 3) its world point [m] (undefined where none).
    """

    vertices: np.ndarray
    triangles: np.ndarray
    plane: np.ndarray
    regions: np.ndarray
    region_groups: np.ndarray
    grid_pixels: np.ndarray
    grid_plane: np.ndarray
    grid_points: np.ndarray


def grow_planes(scan: PoseScan, segments, groups: PlaneGroups, surfel_points, settings:
                SurfelSettings = SurfelSettings()) -> PoseMesh:
    """Mesh of one pose: claimed regions back-projected onto their planes where the pose's
    sonar evidence supports them (module docstring).

    Args:
        segments: (n, 4) barrier segments [pixels] (the pose's segments minus shadow lines).
        groups: the plane groups; surfel_points: (k, 4, 3) points of the grouped surfels [m].
    """
    cam = scan.camera
    n_groups = len(groups)
    regions = region_labels(close_junctions(segments, settings.junction_gap), scan.box,
                            (cam.height, cam.width), settings.barrier_extension,
                            settings.barrier_width)
    projected = project_onto_plane(surfel_points, groups.normals[groups.label][:, None, :],
                                   groups.offsets[groups.label][:, None])
    uv, seen = _image_points(cam, scan.pose, projected)
    group_of = np.repeat(groups.label, projected.shape[1])
    where = _region_at(regions, uv[seen])
    claims = np.zeros((max(regions.max() + 1, 0), n_groups), dtype=int)
    np.add.at(claims, (where[where >= 0], group_of[seen][where >= 0]), 1)
    lone = np.bincount(groups.label, minlength=n_groups) == 1
    claims[:, lone & (groups.normal_errors > settings.max_normal_error)] = 0
    s = settings.stride
    u0, v0, u1, v1 = scan.box
    vs, us = np.arange(v0 + s // 2, v1, s), np.arange(u0 + s // 2, u1, s)
    grid_r = regions[np.ix_(vs, us)]  # (gv, gu)
    uu, vv = np.meshgrid(us + 0.5, vs + 0.5)
    pixels = np.stack([uu, vv], axis=-1)
    camera_pose = cam.world_from_camera(scan.pose)
    rays = camera_rays(cam, camera_pose, pixels)
    origin = camera_pose.translation
    t = intersect_planes(origin, rays, groups.normals, groups.offsets)  # (gv, gu, G)
    dist = t * np.linalg.norm(rays, axis=-1, keepdims=True)
    allowed = np.zeros(grid_r.shape + (n_groups,), dtype=bool)
    inside = grid_r >= 0
    allowed[inside] = claims[grid_r[inside]] > 0
    support = _support(scan, regions, groups, uv[seen], group_of[seen], pixels, settings)
    if support is not None:
        allowed &= support
    limit = np.inf if settings.max_range is None else settings.max_range
    valid = allowed & (t > 1e-6) & (dist <= limit)
    dist = np.where(valid, dist, np.inf)
    if n_groups:
        best = np.argmin(dist, axis=-1)
        found = np.isfinite(np.take_along_axis(dist, best[..., None], -1)[..., 0])
        t_best = np.take_along_axis(np.nan_to_num(t), best[..., None], -1)[..., 0]
    else:
        best, found, t_best = (np.zeros(grid_r.shape, int), np.zeros(grid_r.shape, bool),
                               np.zeros(grid_r.shape))
    points = origin + rays * t_best[..., None]
    key = np.where(found, grid_r * max(n_groups, 1) + best, -1)  # region and plane
    index = np.cumsum(found).reshape(found.shape) - 1
    quads = [key[:-1, :-1], key[:-1, 1:], key[1:, :-1], key[1:, 1:]]
    ids = [index[:-1, :-1], index[:-1, 1:], index[1:, :-1], index[1:, 1:]]
    faces, plane = [], []
    for a, b, c in ((0, 1, 2), (1, 3, 2)):  # two triangles per grid cell
        ok = (quads[a] >= 0) & (quads[a] == quads[b]) & (quads[a] == quads[c])
        faces.append(np.stack([ids[a][ok], ids[b][ok], ids[c][ok]], axis=-1))
        plane.append(best[:-1, :-1][ok] if a == 0 else best[:-1, 1:][ok])
    return PoseMesh(points[found], np.concatenate(faces).reshape(-1, 3),
                    np.concatenate(plane).astype(int), regions, claims, pixels,
                    np.where(found, best, -1), points)


def check_pose(sonar: Sonar, true_pose: Pose, scan: PoseScan, mesh: PoseMesh,
               settings: SurfelSettings = SurfelSettings(), seed: int = 0) -> PoseScan:
    """``scan`` with check pings: beams one ``check_spacing`` apart over the planes grown in
    its image (``mesh``), at least ``fill_margin`` from every barrier line (so no footprint
    reaches across a crease), each aimed at its grid pixel's point on the grown plane (so the
    camera's parallax is removed); fired from ``true_pose``, registered by the scan's odometry
    pose."""
    import cv2

    f = scan.camera.focal_pixels
    u0, v0, u1, v1 = scan.box
    clear = np.ones(mesh.regions.shape, np.uint8)  # 0 on the barriers inside the crop
    clear[v0:v1, u0:u1] = mesh.regions[v0:v1, u0:u1] >= 0
    margin = cv2.distanceTransform(clear, cv2.DIST_L2, 5)
    step = max(int(round(f * np.tan(settings.check_spacing) / settings.stride)), 1)
    rows = slice(step // 2, None, step)
    at = np.floor(mesh.grid_pixels[rows, rows]).astype(int)
    grown = (mesh.grid_plane[rows, rows] >= 0) & \
        (margin[at[..., 1], at[..., 0]] >= f * np.tan(settings.fill_margin))
    pixels, targets = mesh.grid_pixels[rows, rows][grown], mesh.grid_points[rows, rows][grown]
    directions = scan.pose.inverse().transform_points(targets)
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    geometry = sonar.config.geometry
    inside = in_fov(directions, geometry.fov_horizontal, geometry.fov_vertical)
    pixels, directions = pixels[inside], directions[inside]
    points = np.zeros((0, 3))
    if len(directions):
        measured = sonar.scan(true_pose, directions, seed=seed)
        points = scan.pose.transform_points(measured.points_sensor)
    return replace(scan, checks=CheckPings(pixels, points), pings=scan.pings + len(directions))


def segment_sides(segments, regions, claims, offset: float = 5.0,
                  samples: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """Plane group on each side (left (n,), right (n,); -1: undecided) of segments (n, 4).

    A side's plane is the single group claiming the region found ``offset`` [pixels] across the
    segment at ``samples`` points along it (majority over the points); regions claimed by none or
    by several groups are undecided.
    """
    s = np.asarray(segments, dtype=float).reshape(-1, 4)
    if len(s) == 0 or claims.size == 0:
        return np.full(len(s), -1), np.full(len(s), -1)
    a, b = s[:, :2], s[:, 2:]
    d = (b - a) / np.maximum(np.linalg.norm(b - a, axis=1, keepdims=True), 1e-12)
    normal = np.stack([-d[:, 1], d[:, 0]], axis=-1)
    f = (np.arange(samples) + 0.5) / samples
    along = a[:, None, :] + f[None, :, None] * (b - a)[:, None, :]  # (n, samples, 2)
    single = np.where((claims > 0).sum(axis=1) == 1, np.argmax(claims, axis=1), -1)

    def side_plane(sign):
        q = np.floor(along + sign * offset * normal[:, None, :]).astype(int)
        h, w = regions.shape
        ok = (q[..., 0] >= 0) & (q[..., 0] < w) & (q[..., 1] >= 0) & (q[..., 1] < h)
        r = np.where(ok, regions[np.clip(q[..., 1], 0, h - 1), np.clip(q[..., 0], 0, w - 1)], -1)
        g = np.where(r >= 0, single[np.maximum(r, 0)], -1)  # (n, samples)
        votes = np.stack([(g == k).sum(axis=1) for k in range(claims.shape[1])], axis=1)
        winner = np.argmax(votes, axis=1)
        return np.where(votes.max(axis=1) * 2 > samples, winner, -1)

    return side_plane(1.0), side_plane(-1.0)


def shadow_segments(scan: PoseScan, regions, claims, offset: float = 5.0,
                    samples: int = 5) -> np.ndarray:
    """(n,) True for segments of ``scan`` whose two sides lie on one plane (module docstring;
    sides by :func:`segment_sides`); segments with an undecided side are kept."""
    left, right = segment_sides(scan.segments, regions, claims, offset, samples)
    return (left >= 0) & (left == right)


def _crease_residuals(normals, offsets, creases):
    """Distances [pixels] (2 per crease) of the detected segment's ends from the image of the
    line where its two planes meet; creases: list of (camera, world-from-camera pose, segment
    (4,), group a, group b)."""
    out = np.zeros(2 * len(creases))
    for c, (camera, camera_pose, segment, ga, gb) in enumerate(creases):
        line = np.cross(normals[ga], normals[gb])
        norm = np.linalg.norm(line)
        if norm < 1e-9:  # parallel planes: no crease
            out[2 * c: 2 * c + 2] = 1e3
            continue
        line /= norm
        o = camera_pose.translation
        p0 = np.linalg.solve(np.array([normals[ga], normals[gb], line]),
                             [offsets[ga], offsets[gb], line @ o])  # nearest to the camera
        to_camera = camera_pose.inverse()
        h = np.cross(to_camera.transform_points(p0[None])[0],
                     to_camera.transform_vectors(line[None])[0])  # image line, normalised coords
        f = camera.focal_pixels
        uc, vc = camera.principal_point
        ends = np.asarray(segment, float).reshape(2, 2)
        xy = np.column_stack([(ends[:, 0] - uc) / f, (ends[:, 1] - vc) / f, np.ones(2)])
        out[2 * c: 2 * c + 2] = f * (xy @ h) / max(np.hypot(h[0], h[1]), 1e-12)
    return out


def refine_planes(groups: PlaneGroups, points, label, viewpoints, creases,
                  settings: SurfelSettings = SurfelSettings()) -> PlaneGroups:
    """Planes fitted jointly to the sonar points and the image creases (module docstring).

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
    start = _crease_residuals(groups.normals, groups.offsets, creases)
    keep = [c for k, c in enumerate(creases)
            if np.max(np.abs(start[2 * k: 2 * k + 2])) <= settings.crease_gate]

    def unpack(x):
        v = x.reshape(n_groups, 4)
        return v[:, :3] / np.linalg.norm(v[:, :3], axis=1, keepdims=True), v[:, 3]

    sigma = _point_sigma(points, viewpoints, groups.normals[label], settings)

    def residuals(x):
        n, d = unpack(x)
        r_points = (np.einsum("pc,pc->p", points, n[label]) - d[label]) / sigma
        return np.concatenate([r_points,
                               _crease_residuals(n, d, keep) / settings.crease_sigma])

    x0 = np.column_stack([groups.normals, groups.offsets]).ravel()
    n, d = unpack(least_squares(residuals, x0, loss="soft_l1", f_scale=2.0).x)
    flip = np.where(np.einsum("gc,gc->g", n, groups.normals) < 0, -1.0, 1.0)
    n, d = n * flip[:, None], d * flip
    return replace(groups, normals=n, offsets=d)


# ---- the map ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class SurfelMap:
    """The surfel map of a set of poses.

    Attributes:
        scans: per pose what was seen and measured.
        groups: global plane groups of the registered surfels.
        surfel_pose: (k,) pose index of each registered surfel; surfel_index: (k,) its index
            among that pose's candidates.
        surfel_points: (k, 4, 3) their measured points [m].
        surfel_triangles: (k, 3, 3) their image triangles back-projected onto their group plane
            [m].
        vertices: (V, 3), triangles: (F, 3), plane: (F,) the map mesh (union over poses).
        shadow: per pose, (n,) True for segments removed as shadow lines.
        rejected: counts of candidates not registered, by reason (:data:`REJECTIONS`).
        meshes: per pose, the planes grown in its image (:class:`PoseMesh`).
        settings: the settings the map was built with.
    """

    scans: list
    groups: PlaneGroups
    surfel_pose: np.ndarray
    surfel_index: np.ndarray
    surfel_points: np.ndarray
    surfel_triangles: np.ndarray
    vertices: np.ndarray
    triangles: np.ndarray
    plane: np.ndarray
    shadow: list
    rejected: dict = field(default_factory=dict)
    meshes: list = field(default_factory=list)
    settings: SurfelSettings = SurfelSettings()

    def sample(self, spacing: float = 0.01, seed: int = 0):
        """Points (M, 3) [m] sampled uniformly on the mesh, one per ``spacing``^2 (metrics'
        :func:`~mitsonar.evaluation.metrics.sample_surface`), and their plane group (M,)."""
        from mitsonar.evaluation.metrics import sample_surface
        from mitsonar.scene.loading import SceneMesh

        n = len(self.groups)
        mesh = SceneMesh(self.vertices, self.triangles, self.plane,
                         [f"plane{g}" for g in range(n)], np.zeros(n, int), np.zeros(n, bool), [])
        samples = sample_surface(mesh, spacing, seed)
        return samples.points, self.plane[samples.triangle]


def _register(scans, shadow):
    """Registered surfels of all poses, minus those built on a shadow segment: pose (k,),
    candidate index (k,), points (k, 4, 3), viewpoints (k, 3), fill points (k, m, 3)."""
    pose_ids, index = [], []
    for p, (scan, removed) in enumerate(zip(scans, shadow)):
        ok = scan.accepted.copy()
        if len(scan.segment_pairs):
            ok &= ~removed[scan.segment_pairs].any(axis=1)
        pose_ids.append(np.full(int(ok.sum()), p))
        index.append(np.nonzero(ok)[0])
    pose_ids, index = np.concatenate(pose_ids).astype(int), np.concatenate(index).astype(int)
    points = np.array([scans[p].points_world[i] for p, i in zip(pose_ids, index)]).reshape(-1, 4, 3)
    view = np.array([scans[p].pose.translation for p in pose_ids]).reshape(-1, 3)
    m = max((s.fill_world.shape[1] for s in scans if s.fill_world is not None), default=0)
    extra = np.full((len(pose_ids), m, 3), np.nan)
    for k, (p, i) in enumerate(zip(pose_ids, index)):
        if scans[p].fill_world is not None:
            extra[k, :scans[p].fill_world.shape[1]] = scans[p].fill_world[i]
    return pose_ids, index, points, view, extra


def _check_points(scans, meshes, groups: PlaneGroups, settings: SurfelSettings):
    """Check-ping points that join the plane fits: points (c, 3) [m], group (c,) and the
    sensor position they were measured from (c, 3) [m]. A check point joins the nearest plane
    claiming its pixel's region that it lies on (:func:`_on_planes`)."""
    out, label, view = [np.zeros((0, 3))], [np.zeros(0, int)], [np.zeros((0, 3))]
    for scan, mesh in zip(scans, meshes):
        if scan.checks is None or len(groups) == 0:
            continue
        heard = np.all(np.isfinite(scan.checks.points), axis=1)
        pts = scan.checks.points[heard]
        region = _region_at(mesh.regions, scan.checks.pixels[heard])
        claimed = np.zeros((len(pts), len(groups)), dtype=bool)
        claimed[region >= 0] = mesh.region_groups[region[region >= 0]] > 0
        claimed &= _on_planes(pts, scan.pose.translation, groups, settings)
        off = np.where(claimed, np.abs(pts @ groups.normals.T - groups.offsets), np.inf)
        g = np.argmin(off, axis=1) if len(pts) else np.zeros(0, int)
        near = np.isfinite(np.take_along_axis(off, g[:, None], 1)[:, 0])
        out.append(pts[near])
        label.append(g[near])
        view.append(np.broadcast_to(scan.pose.translation, (int(near.sum()), 3)))
    return np.concatenate(out), np.concatenate(label), np.concatenate(view)


def build_map(scans, settings: SurfelSettings = SurfelSettings()) -> SurfelMap:
    """Group the registered surfels of all poses, remove shadow lines, grow every pose's regions
    on the global planes and join the meshes (module docstring)."""
    shadow = [np.zeros(len(s.segments), dtype=bool) for s in scans]
    for _ in range(2):  # group, find shadow lines, then once more without them
        pose_ids, index, points, view, extra = _register(scans, shadow)
        groups = group_surfels(points, view, settings, extra)
        meshes = [grow_planes(s, s.segments[~r], groups, points, settings)
                  for s, r in zip(scans, shadow)]
        if not settings.remove_shadows:
            break
        found = [shadow_segments(replace_segments(s, ~r), m.regions, m.region_groups,
                                 settings.shadow_offset) for s, r, m in zip(scans, shadow, meshes)]
        new = [r.copy() for r in shadow]
        for r, f in zip(new, found):
            r[np.nonzero(~r)[0][f]] = True
        if all(np.array_equal(a, b) for a, b in zip(new, shadow)):
            break
        shadow = new
    if settings.refine and len(groups):
        creases = []
        for s, r, m in zip(scans, shadow, meshes):
            segments = s.segments[~r]
            left, right = segment_sides(segments, m.regions, m.region_groups,
                                        settings.shadow_offset)
            pose = s.camera.world_from_camera(s.pose)
            creases += [(s.camera, pose, seg, a, b) for seg, a, b in zip(segments, left, right)
                        if a >= 0 and b >= 0 and a != b]
        every = np.concatenate([points.reshape(-1, 3), extra.reshape(-1, 3)])
        label = np.concatenate([np.repeat(groups.label, 4),
                                np.repeat(groups.label, extra.shape[1])])
        seen = np.concatenate([np.repeat(view, 4, axis=0), np.repeat(view, extra.shape[1], axis=0)])
        finite = np.all(np.isfinite(every), axis=1)
        every, label, seen = every[finite], label[finite], seen[finite]
        previous = None
        for _ in range(settings.max_iterations):  # until the check points on the planes settle
            checked, check_label, check_view = _check_points(scans, meshes, groups, settings)
            if previous is not None and np.array_equal(previous[0], checked) and \
                    np.array_equal(previous[1], check_label):
                break
            previous = checked, check_label
            groups = refine_planes(groups, np.concatenate([every, checked]),
                                   np.concatenate([label, check_label]),
                                   np.concatenate([seen, check_view]), creases, settings)
        meshes = [grow_planes(s, s.segments[~r], groups, points, settings)
                  for s, r in zip(scans, shadow)]
    vertices, triangles, plane, offset = [], [], [], 0
    for m in meshes:
        vertices.append(m.vertices)
        triangles.append(m.triangles + offset)
        plane.append(m.plane)
        offset += len(m.vertices)
    tri3d = _surfel_triangles(scans, pose_ids, index, groups)
    rejected = {"no_echo": 0, "verification": 0, "shadow_line": 0}
    for s, r in zip(scans, shadow):
        rejected["no_echo"] += int(np.sum(~np.isfinite(s.residual)))
        rejected["verification"] += int(np.sum(np.isfinite(s.residual) & ~s.accepted))
        if len(s.segment_pairs):
            rejected["shadow_line"] += int(np.sum(s.accepted & r[s.segment_pairs].any(axis=1)))
    return SurfelMap(list(scans), groups, pose_ids, index, points, tri3d,
                     np.concatenate(vertices).reshape(-1, 3),
                     np.concatenate(triangles).reshape(-1, 3).astype(np.int64),
                     np.concatenate(plane).astype(int), shadow, rejected, meshes, settings)


def replace_segments(scan: PoseScan, keep) -> PoseScan:
    """``scan`` with only the segments ``keep`` (n,) bool (pairs of dropped ones are not
    meaningful in the result and are emptied)."""
    return replace(scan, segments=scan.segments[np.asarray(keep, bool)],
                   segment_pairs=np.zeros((0, 2), int), triangles=np.zeros((0, 3, 2)),
                   points_world=np.zeros((0, 4, 3)), residual=np.zeros(0),
                   accepted=np.zeros(0, bool), fill_world=None, checks=None)


def _surfel_triangles(scans, pose_ids, index, groups: PlaneGroups) -> np.ndarray:
    """(k, 3, 3) image triangles of the registered surfels back-projected onto their planes."""
    out = np.zeros((len(pose_ids), 3, 3))
    for k, (p, i) in enumerate(zip(pose_ids, index)):  # a few dozen surfels
        scan = scans[p]
        camera_pose = scan.camera.world_from_camera(scan.pose)
        rays = camera_rays(scan.camera, camera_pose, scan.triangles[i])
        g = groups.label[k]
        t = intersect_planes(camera_pose.translation, rays, groups.normals[g:g + 1],
                             groups.offsets[g:g + 1])[:, 0]
        out[k] = camera_pose.translation + rays * t[:, None]
    return out


def map_surfels(sonar: Sonar, poses, odometry=None, settings: SurfelSettings = SurfelSettings(),
                progress=None) -> SurfelMap:
    """Surfel map from world-from-sensor ``poses`` (list of :class:`Pose`); ``odometry`` (same
    length) registers the points instead of the true poses when given; ``progress`` is called
    with each pose index (and again for each pose's check pings).

    With ``settings.check_spacing`` > 0 the map is built twice: the first map's grown planes
    are pinged from every pose (:func:`check_pose`) and the second grows each plane only where
    that evidence supports it (:func:`_support`)."""
    poses = list(poses)
    odometry = poses if odometry is None else list(odometry)
    if len(odometry) != len(poses):
        raise ValueError(f"odometry has {len(odometry)} poses, poses {len(poses)}")
    if not poses:
        raise ValueError("map_surfels needs at least one pose")
    if settings.max_range is None:
        settings = replace(settings, max_range=sonar.config.max_range)
    camera = CameraModel(spp=settings.spp).at_resolution(settings.image_width)
    renderer = CameraRenderer(sonar.scene, camera)
    scans = []
    for k, (pose, odo) in enumerate(zip(poses, odometry)):
        scans.append(scan_pose(sonar, renderer, pose, odo, settings, seed=settings.seed + k))
        if progress is not None:
            progress(k)
    surfel_map = build_map(scans, settings)
    if settings.check_spacing == 0 or len(surfel_map.groups) == 0:
        return surfel_map
    checked = []
    for k, (pose, scan, mesh) in enumerate(zip(poses, scans, surfel_map.meshes)):
        seed = int(np.random.SeedSequence([settings.seed + k, 2]).generate_state(1)[0])
        checked.append(check_pose(sonar, pose, scan, mesh, settings, seed))
        if progress is not None:
            progress(k)
    return build_map(checked, settings)


# ---- outputs ----------------------------------------------------------------------------------
def plane_colours(count: int) -> np.ndarray:
    """(count, 3) distinct RGB colours in [0, 1] (matplotlib's tab20, cycled)."""
    from mitsonar.plots import _pyplot

    cmap = _pyplot().get_cmap("tab20")
    return np.array([cmap(k % 20)[:3] for k in range(count)]).reshape(-1, 3)


def summary(surfel_map: SurfelMap) -> dict:
    """JSON-ready description: planes, counts, rejected surfels and why."""
    g = surfel_map.groups
    sizes = np.bincount(g.label, minlength=len(g))
    return {
        "units": "SI: metres; plane n . x = d, n towards the sensors",
        "poses": len(surfel_map.scans),
        "pings": int(sum(s.pings for s in surfel_map.scans)),
        "segments": int(sum(len(s.segments) for s in surfel_map.scans)),
        "candidate_surfels": int(sum(len(s.triangles) for s in surfel_map.scans)),
        "registered_surfels": len(surfel_map.surfel_pose),
        "rejected_surfels": surfel_map.rejected,
        "shadow_lines_removed": int(sum(r.sum() for r in surfel_map.shadow)),
        "regroup_iterations": g.iterations,
        "planes": [{"normal": g.normals[k].round(6).tolist(), "d_m": round(float(g.offsets[k]), 6),
                    "surfels": int(sizes[k])} for k in range(len(g))],
        "mesh": {"vertices": len(surfel_map.vertices), "triangles": len(surfel_map.triangles)},
        "surfels": [{"pose": int(p), "candidate": int(i), "plane": int(lab),
                     "points_m": pts.round(5).tolist()}
                    for p, i, lab, pts in zip(surfel_map.surfel_pose, surfel_map.surfel_index,
                                              g.label, surfel_map.surfel_points)],
    }


def save_surfel_figure(path, surfel_map: SurfelMap, points, plane, title: str = "") -> None:
    """PNG: the sampled map coloured by plane from the top and in perspective, and the detected
    lines (shadow lines dashed) and registered/rejected surfels over the first pose's image.

    Args:
        points: (M, 3) sampled map points [m]; plane: (M,) their plane group.
    """
    from mitsonar.plots import _pyplot, save_png

    plt = _pyplot()
    colours = plane_colours(max(len(surfel_map.groups), 1))
    fig = plt.figure(figsize=(17, 5.6))
    ax_top, ax_3d = fig.add_subplot(1, 3, 1), fig.add_subplot(1, 3, 2, projection="3d")
    ax_img = fig.add_subplot(1, 3, 3)
    show = np.random.default_rng(0).permutation(len(points))[:60000]  # enough to see
    p, c = points[show], colours[plane[show]] if len(points) else np.zeros((0, 3))
    sensors = np.array([s.pose.translation for s in surfel_map.scans])
    ax_top.scatter(p[:, 0], p[:, 1], c=c, s=0.5, linewidths=0)
    ax_top.plot(sensors[:, 0], sensors[:, 1], "k.-", lw=1.0, label="sensor")
    ax_top.set(xlabel="x [m]", ylabel="y [m]", title="top view (1 cm samples by plane)")
    ax_top.set_aspect("equal", adjustable="datalim")
    ax_top.legend(loc="best", fontsize=8)
    if len(p):
        ax_3d.scatter(p[:, 0], p[:, 1], p[:, 2], c=c, s=0.3, linewidths=0, depthshade=False)
        lo, hi = p.min(axis=0), p.max(axis=0)
        ax_3d.set_box_aspect(tuple(np.maximum(hi - lo, 1e-3)))
    ax_3d.plot(sensors[:, 0], sensors[:, 1], sensors[:, 2], "k.-")
    ax_3d.view_init(elev=30.0, azim=-60.0)
    ax_3d.set(xlabel="x [m]", ylabel="y [m]", zlabel="z [m]", title="perspective")
    scan = surfel_map.scans[0]
    ax_img.imshow(tone_map(scan.gray), cmap="gray", vmin=0, vmax=1)
    u0, v0, u1, v1 = scan.box
    ax_img.plot([u0, u1, u1, u0, u0], [v0, v0, v1, v1, v0], "y-", lw=0.8)
    for seg, removed in zip(scan.segments, surfel_map.shadow[0]):
        ax_img.plot(seg[[0, 2]], seg[[1, 3]], "c--" if removed else "c-", lw=1.2)
    mine = surfel_map.surfel_pose == 0
    registered = set(surfel_map.surfel_index[mine].tolist())
    for k, tri in enumerate(scan.triangles):
        closed = np.vstack([tri, tri[:1]])
        ax_img.plot(closed[:, 0], closed[:, 1], "r--" if k in registered else "m:", lw=1.0)
    caption = "pose 0: lines (cyan, dashed: shadow), surfels (red; magenta: rejected)"
    if scan.checks is not None and len(scan.checks.pixels) and len(surfel_map.groups):
        heard = np.all(np.isfinite(scan.checks.points), axis=1)
        on = np.zeros(len(heard), dtype=bool)
        on[heard] = _on_planes(scan.checks.points[heard], scan.pose.translation,
                               surfel_map.groups, surfel_map.settings).any(axis=1)
        for mask, colour in ((~heard, "0.6"), (heard & on, "lime"), (heard & ~on, "orangered")):
            ax_img.scatter(*scan.checks.pixels[mask].T, s=18, facecolors="none",
                           edgecolors=colour, linewidths=1.0)
        caption += "\ncheck pings: on a plane (green), off (orange), no echo (grey)"
    ax_img.set_title(caption, fontsize=9)
    ax_img.axis("off")
    fig.suptitle(title)
    fig.tight_layout()
    save_png(fig, path)


def save_surfel_map(out_dir, surfel_map: SurfelMap, spacing: float = 0.01, title: str = ""):
    """Write ``surfel_map.ply`` (mesh coloured by plane), ``surfel_points.ply`` (``spacing`` [m]
    sampling), ``surfels.json`` and ``surfel_map.png`` into ``out_dir``; returns the samples."""
    from mitsonar.data.io import write_json, write_ply

    out = Path(out_dir)
    colours = np.round(plane_colours(max(len(surfel_map.groups), 1)) * 255).astype(np.uint8)
    vertex_plane = np.zeros(len(surfel_map.vertices), dtype=int)
    vertex_plane[surfel_map.triangles.ravel()] = np.repeat(surfel_map.plane, 3)
    write_ply(out / "surfel_map.ply", surfel_map.vertices, colours[vertex_plane],
              faces=surfel_map.triangles)
    points, plane = surfel_map.sample(spacing)
    write_ply(out / "surfel_points.ply", points, colours[plane], scalars={"plane": plane})
    write_json(out / "surfels.json", summary(surfel_map))
    save_surfel_figure(out / "surfel_map.png", surfel_map, points, plane, title)
    return points, plane
