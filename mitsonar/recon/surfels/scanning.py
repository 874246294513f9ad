"""One pose of surfel scanning (:func:`scan_pose`): the image rendered, line segments and
triangle surfels detected in it (:mod:`mitsonar.recon.lines`), four pings per surfel, the paper's
verification (:func:`verify`) and the spread test (:func:`spread_ratio`), registration (12) by the
odometry pose and the fill pings inside each registered surfel (:func:`fill_pixels`); what the
pose contributed is a :class:`PoseScan`. A pinger (:mod:`mitsonar.recon.surfels.pinging`) fires
the beams: all from the image's pose, or one after another while the robot drives on."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from mitsonar.frames import Pose
from mitsonar.physics.beampattern import in_fov
from mitsonar.recon.lines import (detect_segments, fov_crop_box, scan_directions, scan_pixels,
                                  triangle_surfels)
from mitsonar.recon.surfels.planes import fit_plane, plane_through
from mitsonar.recon.surfels.settings import SurfelSettings
from mitsonar.sensors.camera import CameraModel, CameraRenderer
from mitsonar.validation import check_positive

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


@dataclass(frozen=True)
class PoseScan:
    """What one pose contributed.

    Attributes:
        pose: world-from-sensor pose used for registration (odometry) [m].
        camera: the working camera model.
        box: (u0, v0, u1, v1) field-of-view crop [pixels].
        segments: (n, 4) detected line segments [pixels].
        triangles: (k, 3, 2) image triangles of all candidate surfels [pixels] (a region
            surfel's vertices are its outer scan pixels, :func:`add_surfels`).
        segment_pairs: (k, 2) segments of each candidate ((-1, -1): a region surfel,
            :func:`add_surfels`).
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

    def on_segments(self, removed) -> np.ndarray:
        """(k,) True for the candidates built on a segment ``removed`` (n,) bool marks (a
        region surfel, segment pair (-1, -1), is built on none)."""
        pairs = self.segment_pairs.reshape(-1, 2)
        hit = np.zeros(pairs.shape, dtype=bool)
        own = pairs >= 0
        hit[own] = np.asarray(removed, dtype=bool)[pairs[own]]
        return hit.any(axis=1)


@dataclass(frozen=True)
class CheckPings:
    """Check pings of one pose (:func:`~mitsonar.recon.surfels.growing.check_pose`): beams aimed
    inside the grown regions to confirm or refute the planes grown there.

    Attributes:
        pixels: (n, 2) image pixel each beam was aimed through [pixels].
        points: (n, 3) measured points [m], world frame by the odometry pose; NaN: no echo.
    """

    pixels: np.ndarray
    points: np.ndarray


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


def _fill_targets(camera: CameraModel, geometry, pixels, points_sensor):
    """Beam directions (k, m, 3) and their target points (k, m, 3) [m] (NaN where none) for
    fill pixels (k, m, 2): where each pixel's camera ray meets the plane of its surfel's four
    measured points (k, 4, 3) (sensor frame), so the camera's parallax is removed; directions
    outside the field of view are dropped (NaN)."""
    k, m = pixels.shape[:2]
    out = np.full((k, m, 3), np.nan)
    target = np.full((k, m, 3), np.nan)
    ok = np.all(np.isfinite(pixels), axis=-1) & \
        np.all(np.isfinite(points_sensor), axis=(1, 2))[:, None]
    if not np.any(ok):
        return out, target
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
        return out, target
    dirs = scan_directions(camera, pixels[ok], depth=depth[ok])
    inside = in_fov(dirs, geometry.fov_horizontal, geometry.fov_vertical)
    rows = np.nonzero(ok)
    out[rows[0][inside], rows[1][inside]] = dirs[inside]
    target[rows[0][inside], rows[1][inside]] = \
        dirs[inside] * (depth[ok][inside] / dirs[inside, 2])[:, None]
    return out, target


def ping_surfels(pinger, camera: CameraModel, odometry_pose: Pose, triangles,
                 settings: SurfelSettings, seed: int, pixels=None):
    """Ping candidate surfels, image triangles (k, 3, 2) [pixels], at their four scan pixels
    (``pixels`` (k, 4, 2) [pixels], the centroid last; None: the paper's,
    :func:`~mitsonar.recon.lines.scan_pixels`), verify (:func:`verify`, :func:`spread_ratio`),
    register (12) by ``odometry_pose`` and ping the registered ones again at their fill pixels
    (:func:`fill_pixels`).

    Returns measured points (k, 4, 3) [m] (world, NaN: no echo), verification residuals (k,)
    [m], accepted (k,) and fill points (k, ``max_fill``, 3) [m] (NaN where none)."""
    sonar = pinger.sonar
    triangles = np.asarray(triangles, dtype=float).reshape(-1, 3, 2)
    if pixels is None:
        pixels = scan_pixels(triangles) if len(triangles) else np.zeros((0, 4, 2))
    directions = scan_directions(camera, pixels)
    measured = pinger.fire(directions.reshape(-1, 3), seed).reshape(-1, 4, 3)
    points = odometry_pose.transform_points(measured)
    accepted, residual = verify(points, settings.verify_threshold) if len(points) else \
        (np.zeros(0, bool), np.zeros(0))
    if len(triangles):
        spread = spread_ratio(measured, directions.reshape(-1, 4, 3))
        accepted &= np.nan_to_num(spread) >= settings.min_spread
    fill = np.full((len(triangles), settings.max_fill, 3), np.nan)
    if settings.max_fill and np.any(accepted):
        f = camera.focal_pixels
        fp = fill_pixels(triangles[accepted], f * np.tan(settings.fill_spacing),
                         f * np.tan(settings.fill_margin), settings.max_fill)
        dirs, targets = _fill_targets(camera, sonar.config.geometry, fp, measured[accepted])
        aim = np.all(np.isfinite(dirs), axis=-1)
        if np.any(aim):
            fill_seed = int(np.random.SeedSequence([seed, 1]).generate_state(1)[0])
            second = pinger.fire(dirs[aim], fill_seed, targets[aim])
            got = np.full(dirs.shape, np.nan)
            got[aim] = odometry_pose.transform_points(second)
            # a fill echo off the surfel's plane by more than the verification threshold came
            # from something else (an object in front, a side lobe): dropped
            world = points[accepted]
            for i in range(len(world)):
                n, d = fit_plane(world[i])
                far = np.abs(got[i] @ n - d) > settings.verify_threshold
                got[i][far] = np.nan
            fill[accepted] = got
    return points, residual, accepted, fill


def scan_pose(pinger, renderer: CameraRenderer, odometry_pose: Pose,
              settings: SurfelSettings = SurfelSettings(), seed: int = 0) -> PoseScan:
    """Render, detect lines and surfels, ping their scan points, verify, register, fill.

    ``pinger`` (:class:`~mitsonar.recon.surfels.pinging.StillPinger` or
    :class:`~mitsonar.recon.surfels.pinging.MovingPinger`) fires the beams; its ``pose`` places
    the camera in the scene; ``odometry_pose`` registers the points (12).
    """
    camera = renderer.model
    fired = pinger.pings
    images = renderer.render(pinger.pose, seed=seed)
    box = fov_crop_box(camera, pinger.sonar.config.geometry)
    segments = detect_segments(tone_map(images.gray), box, settings.segment_min_length,
                               slope_sigma=settings.slope_sigma)
    surfels = triangle_surfels(segments)
    points, residual, accepted, fill = ping_surfels(pinger, camera, odometry_pose,
                                                    surfels.vertices, settings, seed)
    return PoseScan(odometry_pose, camera, box, segments, surfels.vertices, surfels.segment_pairs,
                    points, residual, accepted, images.gray, pinger.pings - fired, fill)


def add_surfels(pinger, scan: PoseScan, triangles, settings: SurfelSettings,
                seed: int) -> PoseScan:
    """``scan`` with region surfels (:func:`~mitsonar.recon.surfels.growing.region_triangles`),
    image triangles (k, 3, 2) [pixels] built on no segment (segment pair (-1, -1)), pinged at
    their vertices and centroid (spread over the region, not a third of the way in), verified
    and filled like the others (:func:`ping_surfels`) by ``pinger`` from the scan's image
    pose."""
    fired = pinger.pings
    triangles = np.asarray(triangles, dtype=float).reshape(-1, 3, 2)
    pixels = np.concatenate([triangles, triangles.mean(axis=1, keepdims=True)], axis=1)
    points, residual, accepted, fill = ping_surfels(pinger, scan.camera, scan.pose, triangles,
                                                    settings, seed, pixels)
    old_fill = scan.fill_world if scan.fill_world is not None else \
        np.full((len(scan.triangles), settings.max_fill, 3), np.nan)
    return replace(scan, triangles=np.concatenate([scan.triangles.reshape(-1, 3, 2), triangles]),
                   segment_pairs=np.concatenate([scan.segment_pairs.reshape(-1, 2),
                                                 np.full((len(points), 2), -1)]).astype(int),
                   points_world=np.concatenate([scan.points_world.reshape(-1, 4, 3), points]),
                   residual=np.concatenate([scan.residual, residual]),
                   accepted=np.concatenate([scan.accepted, accepted]),
                   fill_world=np.concatenate([old_fill, fill]),
                   pings=scan.pings + pinger.pings - fired)
