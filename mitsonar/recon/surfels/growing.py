"""Planes grown in one pose's image: the regions the line segments cut the field of view into
(:func:`region_labels`), the claimed regions back-projected onto their planes where the pose's
sonar evidence supports them (:func:`grow_planes`, :class:`PoseMesh`), the check pings fired over
the grown planes (:func:`check_pose`), the region surfels of regions no plane claims
(:func:`region_triangles`) and the plane on each side of a segment (:func:`segment_sides`,
:func:`shadow_segments`)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from mitsonar.frames import Pose
from mitsonar.physics.beampattern import in_fov
from mitsonar.recon.lines import close_junctions, merge_collinear
from mitsonar.recon.surfels.planes import PlaneGroups, _on_planes, project_onto_plane
from mitsonar.recon.surfels.scanning import CheckPings, PoseScan
from mitsonar.recon.surfels.settings import SurfelSettings
from mitsonar.sensors.camera import CameraModel

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


def barriers(segments, box, settings: SurfelSettings) -> np.ndarray:
    """Segments (m, 4) [pixels] that cut the field-of-view crop ``box`` into regions: the
    detected ``segments`` (n, 4), bridges across the gaps between pieces of one line (collinear
    within :func:`~mitsonar.recon.lines.merge_collinear`'s tolerances, gaps up to
    ``bridge_gap`` x the image width between them), and ends that stop at most ``junction_gap``
    short of another segment or of the crop's border extended to it
    (:func:`~mitsonar.recon.lines.close_junctions`); a bridged line's ends reach further, up to
    its own length and at most ``bridge_gap`` x the image width (a crease found over 400 px
    and missed over its last 130 px to the crop's side is a gap like those between pieces).

    A wall-floor crease seen at a grazing angle is found in pieces; through the gaps the floor's
    region reached the wall's, and with no wall surfel the floor plane was grown over the wall's
    pixels, behind the wall up to the sonar's range (varied_1: 18 % of the map's area in a band
    of 20 px above the crease; the crease's last 130 px to the crop's side missed). An extra
    barrier only splits a region, never joins two.
    """
    s = np.asarray(segments, dtype=float).reshape(-1, 4)
    u0, v0, u1, v1 = box
    border = np.array([[u0, v0, u1, v0], [u1, v0, u1, v1], [u1, v1, u0, v1], [u0, v1, u0, v0]],
                      dtype=float)
    bridged = merge_collinear(s, gap_tolerance=settings.bridge_gap * settings.image_width) \
        if len(s) else s
    every = np.concatenate([s, bridged, border])
    length = np.hypot(bridged[:, 2] - bridged[:, 0], bridged[:, 3] - bridged[:, 1])
    reach = np.concatenate([np.full(len(s), settings.junction_gap),
                            np.clip(length, settings.junction_gap,
                                    max(settings.bridge_gap * settings.image_width,
                                        settings.junction_gap)),
                            np.full(len(border), settings.junction_gap)])
    return close_junctions(every, settings.junction_gap, reach=reach)[:len(s) + len(bridged)]


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


@dataclass(frozen=True)
class HeardChecks:
    """Check echoes: measured points (c, 3) [m] (world frame) and the sensor positions they were
    measured from (c, 3) [m]."""

    points: np.ndarray
    viewpoints: np.ndarray


def own_checks(scan: PoseScan) -> HeardChecks | None:
    """The check echoes ``scan`` heard (None: it fired no check pings)."""
    if scan.checks is None:
        return None
    heard = np.all(np.isfinite(scan.checks.points), axis=1)
    return HeardChecks(scan.checks.points[heard],
                       np.broadcast_to(scan.pose.translation, (int(heard.sum()), 3)))


def heard_checks(scans) -> HeardChecks | None:
    """The check echoes every scan of ``scans`` heard (None: none fired check pings)."""
    own = [c for c in map(own_checks, scans) if c is not None]
    if not own:
        return None
    return HeardChecks(np.concatenate([c.points for c in own]).reshape(-1, 3),
                       np.concatenate([c.viewpoints for c in own]).reshape(-1, 3))


def _support(scan: PoseScan, regions, groups: PlaneGroups, surfel_uv, surfel_group, pixels,
             settings: SurfelSettings, checks: HeardChecks | None,
             candidates: np.ndarray) -> np.ndarray | None:
    """(..., G) True where the sonar evidence supports growing each plane at ``pixels`` (..., 2)
    of ``scan``'s image, None without check echoes (everything allowed). Only the ``candidates``
    (..., G) (where a plane may grow at all) are looked at; elsewhere the result is False.

    Evidence lives in pixels: every projected surfel point (``surfel_uv`` (P, 2), groups
    ``surfel_group`` (P,)) confirms its group; a check echo (``checks``: of every pose, projected
    into this image) confirms every group whose plane its measured point lies on (within
    ``merge_sigmas`` expected errors from where it was measured,
    :func:`~mitsonar.recon.surfels.planes._point_sigma`) and refutes all others; pings without an
    echo say nothing. A pixel supports a group when its nearest evidence on that group in the
    same region confirms it. Echoes heard from other poses count as this pose's own: a plane
    hypothesis refuted by the pings of one pose (on varied_3, 33 of a pose's 37 check echoes on
    the wall behind a cabinet lay on neither plane grown there) is refuted in every image.
    """
    from scipy.spatial import cKDTree

    if checks is None or len(groups) == 0:
        return None
    c_uv, seen = _image_points(scan.camera, scan.pose, checks.points)
    c_uv, c_points = c_uv[seen], checks.points[seen]
    on_plane = _on_planes(c_points, checks.viewpoints[seen][:, None], groups, settings)
    shape = np.shape(pixels)[:-1]
    px = np.asarray(pixels, dtype=float).reshape(-1, 2)
    # the region as a far-off third coordinate: evidence in another region is never nearest
    far = 10.0 * (regions.shape[0] + regions.shape[1])

    def lift(uv):
        return np.column_stack([uv, far * _region_at(regions, uv)])

    asked = np.asarray(candidates, dtype=bool).reshape(len(px), len(groups))
    rows = np.flatnonzero(asked.any(axis=1))
    where, asked = lift(px[rows]), asked[rows]
    s_lift, c_lift = lift(surfel_uv), lift(c_uv)
    found = np.zeros(asked.shape, dtype=bool)
    for g in range(len(groups)):  # a few dozen planes, each at the pixels it may claim
        yes = np.concatenate([s_lift[surfel_group == g], c_lift[on_plane[:, g]]])
        no = c_lift[~on_plane[:, g]]
        if len(yes) == 0 or not asked[:, g].any():
            continue
        at = where[asked[:, g]]
        d_yes = cKDTree(yes).query(at)[0]
        d_no = cKDTree(no).query(at)[0] if len(no) else np.full(len(at), np.inf)
        found[asked[:, g], g] = d_yes <= d_no
    out = np.zeros((len(px), len(groups)), dtype=bool)
    out[rows] = found
    return out.reshape(shape + (len(groups),))


@dataclass(frozen=True)
class PoseMesh:
    """Planes grown in one pose's image.

    Attributes:
        vertices: (V, 3) [m]; triangles: (F, 3) vertex indices; plane: (F,) group per triangle.
        regions: (H, W) region labels (see :func:`region_labels`).
        region_groups: (R, G) surfel points of each group claiming each region.
        hypotheses: (R, G) the same, counting also the groups whose normal is too poorly
            determined to claim (``max_normal_error``): planes the check pings may confirm.
        grid_pixels: (gv, gu, 2) the back-projected pixel grid [pixels].
        grid_plane: (gv, gu) plane grown at each grid pixel, -1 none.
        grid_points: (gv, gu, 3) its world point [m] (undefined where none).
    """

    vertices: np.ndarray
    triangles: np.ndarray
    plane: np.ndarray
    regions: np.ndarray
    region_groups: np.ndarray
    hypotheses: np.ndarray
    grid_pixels: np.ndarray
    grid_plane: np.ndarray
    grid_points: np.ndarray


def grow_planes(scan: PoseScan, segments, groups: PlaneGroups, surfel_points, settings:
                SurfelSettings = SurfelSettings(), checks: HeardChecks | None = None,
                tentative: bool = False) -> PoseMesh:
    """Mesh of one pose: claimed regions back-projected onto their planes where the pose's
    sonar evidence supports them (package docstring).

    Args:
        segments: (n, 4) barrier segments [pixels] (the pose's segments minus shadow lines).
        groups: the plane groups; surfel_points: (k, 4, 3) points of the grouped surfels [m].
        checks: the check echoes that confirm or refute the planes (:func:`heard_checks` of
            every pose); None: ``scan``'s own (:func:`own_checks`).
        tentative: grow the hypotheses too (:attr:`PoseMesh.hypotheses`: where check pings are
            aimed), not only the planes that claim.
    """
    cam = scan.camera
    n_groups = len(groups)
    regions = region_labels(barriers(segments, scan.box, settings), scan.box,
                            (cam.height, cam.width), settings.barrier_extension,
                            settings.barrier_width)
    projected = project_onto_plane(surfel_points, groups.normals[groups.label][:, None, :],
                                   groups.offsets[groups.label][:, None])
    uv, seen = _image_points(cam, scan.pose, projected)
    group_of = np.repeat(groups.label, projected.shape[1])
    where = _region_at(regions, uv[seen])
    claims = np.zeros((max(regions.max() + 1, 0), n_groups), dtype=int)
    np.add.at(claims, (where[where >= 0], group_of[seen][where >= 0]), 1)
    hypotheses = claims.copy()
    claims[:, groups.normal_errors > settings.max_normal_error] = 0
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
    allowed[inside] = (hypotheses if tentative else claims)[grid_r[inside]] > 0
    limit = np.inf if settings.max_range is None else settings.max_range
    valid = allowed & (t > 1e-6) & (dist <= limit)
    if settings.below_floor is not None:  # nothing is seen through the floor
        valid &= origin[2] + rays[..., 2:] * t >= -settings.below_floor
    support = _support(scan, regions, groups, uv[seen], group_of[seen], pixels, settings,
                       own_checks(scan) if checks is None else checks, valid)
    if support is not None:
        valid &= support
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
                    np.concatenate(plane).astype(int), regions, claims, hypotheses, pixels,
                    np.where(found, best, -1), points)


def check_pose(pinger, scan: PoseScan, mesh: PoseMesh, settings: SurfelSettings = SurfelSettings(),
               seed: int = 0) -> PoseScan:
    """``scan`` with check pings: beams one ``check_spacing`` apart over the planes grown in
    its image (``mesh``), at least ``fill_margin`` from every barrier line (so no footprint
    reaches across a crease), each aimed at its grid pixel's point on the grown plane (so the
    camera's parallax is removed); fired by ``pinger``
    (:mod:`~mitsonar.recon.surfels.pinging`) from the scan's image pose, registered by the
    scan's odometry pose."""
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
    local = scan.pose.inverse().transform_points(targets)
    directions = local / np.linalg.norm(local, axis=1, keepdims=True)
    geometry = pinger.sonar.config.geometry
    inside = in_fov(directions, geometry.fov_horizontal, geometry.fov_vertical)
    fired = pinger.pings
    points = scan.pose.transform_points(pinger.fire(directions[inside], seed, local[inside]))
    return replace(scan, checks=CheckPings(pixels[inside], points),
                   pings=scan.pings + pinger.pings - fired)


def region_triangles(scan: PoseScan, settings: SurfelSettings = SurfelSettings(),
                     mesh: PoseMesh | None = None) -> np.ndarray:
    """Region surfels of ``scan``: one per region of its field-of-view crop (cut by its
    segments, :func:`barriers`) that no plane claims (``mesh.region_groups``; ``mesh`` None:
    no plane yet, every region). Returns their three outer scan pixels (k, 3, 2) [pixels],
    spread over the part of the region at least ``fill_margin`` from every barrier (not from
    the crop's edges, which are no crease: a footprint reaching past them stays on the same
    surface, and a floor seen between a wall-floor crease and the crop's lower edge is a band
    a few footprints tall).

    A triangle surfel needs two segments meeting at a junction; a floor bounded by one
    wall-floor crease and the crop's border, or a wall whose corners are out of view, has
    none and was never pinged (room_glass, first 8 s: 0.7 % of the observable floor
    proposed, 15.8 % in view).
    The points: the part's pixel farthest from its centroid, the pixel farthest from that one,
    and the pixel farthest from the line through both; kept when that last one is at least
    ``fill_margin`` off the line (three directions, not a line) and the three points' centroid
    (the verification point) lies in the part too."""
    import cv2

    cam = scan.camera
    regions = mesh.regions if mesh is not None else \
        region_labels(barriers(scan.segments, scan.box, settings), scan.box,
                      (cam.height, cam.width), settings.barrier_extension, settings.barrier_width)
    count = max(regions.max() + 1, 0)
    claimed = np.zeros(count, dtype=bool)
    if mesh is not None and mesh.region_groups.size:
        claimed[:len(mesh.region_groups)] = mesh.region_groups.sum(axis=1) > 0
    u0, v0, u1, v1 = scan.box
    open_ = np.ones(regions.shape, np.uint8)  # 0 on the barriers inside the crop
    open_[v0:v1, u0:u1] = regions[v0:v1, u0:u1] >= 0
    far = cv2.distanceTransform(open_, cv2.DIST_L2, 5) >= cam.focal_pixels * \
        np.tan(settings.fill_margin)
    out = []
    for r in np.nonzero(~claimed)[0]:  # a few regions
        clear = far & (regions == r)
        v, u = np.nonzero(clear)
        if len(u) < 3:
            continue
        p = np.column_stack([u, v]) + 0.5
        a = p[np.argmax(np.linalg.norm(p - p.mean(axis=0), axis=1))]
        b = p[np.argmax(np.linalg.norm(p - a, axis=1))]
        e = (b - a) / max(np.linalg.norm(b - a), 1e-12)
        off = np.abs((p - a) @ np.array([-e[1], e[0]]))
        c = p[np.argmax(off)]
        iu, iv = np.floor((a + b + c) / 3).astype(int)
        if off.max() >= cam.focal_pixels * np.tan(settings.fill_margin) and clear[iv, iu]:
            out.append([a, b, c])
    return np.array(out, dtype=float).reshape(-1, 3, 2)


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
    """(n,) True for segments of ``scan`` whose two sides lie on one plane (package docstring;
    sides by :func:`segment_sides`); segments with an undecided side are kept."""
    left, right = segment_sides(scan.segments, regions, claims, offset, samples)
    return (left >= 0) & (left == right)
