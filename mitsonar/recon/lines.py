"""Image side of surfel scanning (section III-D, Fig. 5): lines, triangle surfels, scan points.

The camera image is cropped to the array's field of view, a Fast Line Detector (FLD) finds line
segments, both of steps in brightness and of creases where only the shading's slope changes
(:func:`slope_strength`), segments of one line are merged and those shorter than 50 pixels
dropped; pairs of
segments meeting at a common point (a junction) span triangle surfels, each scanned at four
points (three at one third of the way from the centroid to the vertices, then the centroid)
whose beam directions come from equations (10)(11).

Pixel coordinates are (u right, v down) in the full image, continuous, with pixel (i, j)
covering u in [i, i+1), v in [j, j+1) as in :mod:`mitsonar.sensors.camera` (so pixel centres sit at
half-integers; OpenCV's integer pixel centres are shifted by +0.5 on the way in).

"Counterclockwise" means counterclockwise as the image is displayed (v pointing down): for
vertices a, b, c, the cross product (b - a) x (c - a) = du1 dv2 - dv1 du2 is negative in (u, v).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mitsonar.physics.array import ArrayGeometry
from mitsonar.sensors.camera import CameraModel
from mitsonar.frames import direction_from_angles
from mitsonar.validation import check_finite, check_positive, check_range

#: OpenCV's pixel centres are integers, mitsonar's half-integers.
OPENCV_TO_PIXEL = 0.5
#: Default tolerances of :func:`merge_collinear`: direction [rad], offset across the line
#: [pixels] (wide enough for the two edges of a line 3-4 px thick, about 5 px apart) and gap
#: along it [pixels].
MERGE_ANGLE = np.radians(2.0)
MERGE_DISTANCE = 6.0
MERGE_GAP = 15.0
#: Smallest automatic Canny threshold on |g_u| + |g_v| of the 3x3 Sobel gradient: a sharp step
#: of 4.6 grey levels after the 1 px pre-blur (which turns a step of d levels into 2.6 d).
EDGE_FLOOR = 12.0
#: Automatic Canny threshold in standard deviations of one Sobel gradient component of the
#: image noise (|g_u| + |g_v| of pure noise exceeds 4 of them at about 1 % of pixels, and Canny
#: keeps only those that chain into a line).
EDGE_NOISE_SIGMAS = 4.0
#: Shading-slope creases (:func:`slope_strength`): scale of the Gaussian the second derivatives
#: are taken at [pixels]. Two walls of one paint under the same lights often meet with no step
#: in brightness, only a change of its slope (the shading falls towards the corner on both
#: sides): 0.3-0.5 grey levels per pixel on either side of the wall-wall creases of room_glass
#: in the ``ceiling`` look, invisible to the step detector.
SLOPE_SIGMA = 2.0
#: A pixel belongs to a slope crease where its strength is at least this many times the median
#: strength of the crop (flat walls: the denoised render's noise). On room_glass (ceiling look,
#: 320 px) the median is 4-8e-4, the 99th percentile on flat walls 2-5e-3, the faintest
#: wall-wall creases 7-12e-3.
SLOPE_NOISE_MULTIPLE = 6.0
#: ... and at least this strength: a kink where the slope changes by 0.2 grey levels per pixel
#: (of 255), which gives 0.2 / 255 * sigma / sqrt(2 pi) (matters only on noiseless images).
SLOPE_FLOOR = 0.2 / 255.0 * SLOPE_SIGMA / np.sqrt(2.0 * np.pi)
#: Steps of brightness this many Canny thresholds strong are the step detector's: the slope
#: strength within 2 sigma of them (their flanks, +-sigma off the edge) is ignored.
SLOPE_STEP_MULTIPLE = 3.0


def fov_crop_box(camera: CameraModel, geometry: ArrayGeometry,
                 depth: float = np.inf) -> tuple[int, int, int, int]:
    """Pixel box (u0, v0, u1, v1) of the image inside the array's field of view.

    The image part is ``image[v0:v1, u0:u1]``; box edges are the projections of the field of
    view's edges (horizontal +-fov_horizontal/2, vertical +-fov_vertical/2) rounded to the
    nearest pixel edge and clipped to the image.

    ``depth`` [m] is the sensor-frame z of the points the box is for. The default (infinity)
    projects directions only: the camera's axes are the sensor's, so directions at infinity land
    on the same pixels whatever the 7.5 cm offset. At a finite depth z the array's field of view
    is seen shifted by f * offset / z pixels (the camera sits above the array, so the footprint
    moves down the image: 50 px at 2 m at full resolution, f = 1333 px); pass the depth to get
    that box instead.
    """
    if depth != np.inf:
        check_positive("fov_crop_box depth [m]", depth)
    th, tv = np.tan(geometry.fov_horizontal / 2), np.tan(geometry.fov_vertical / 2)
    corners = np.array([[-th, -tv, 1.0], [th, tv, 1.0]])  # top-left, bottom-right directions
    if np.isinf(depth):
        points = corners
    else:
        points = camera.camera_from_sensor().transform_points(corners * depth)
    (u0, v0), (u1, v1) = np.round(camera.project(points)).astype(int)
    u0, u1 = np.clip([u0, u1], 0, camera.width)
    v0, v1 = np.clip([v0, v1], 0, camera.height)
    if u1 <= u0 or v1 <= v0:
        raise ValueError(f"fov_crop_box: the field of view at depth {depth} m falls outside the "
                         f"{camera.width} x {camera.height} image")
    return int(u0), int(v0), int(u1), int(v1)


def _as_uint8(gray) -> np.ndarray:
    """(H, W) uint8 image from uint8, or float in [0, 1] (values outside are clipped)."""
    g = np.asarray(gray)
    if g.ndim != 2:
        raise ValueError(f"gray image must be 2-D (H, W), got shape {g.shape}")
    if g.dtype == np.uint8:
        return np.ascontiguousarray(g)
    if not np.issubdtype(g.dtype, np.floating):
        raise ValueError(f"gray image must be uint8 or float in [0, 1], got dtype {g.dtype}")
    check_finite("gray image", g)
    return np.round(np.clip(g, 0.0, 1.0) * 255.0).astype(np.uint8)


def noise_level(image) -> float:
    """Standard deviation [grey levels] of white noise in an (H, W) image: Immerkaer's fast
    estimate (J. Immerkaer, "Fast noise variance estimation", CVIU 64(2), 1996), the mean
    absolute response to a mask that cancels local planes, so edges barely bias it."""
    import cv2

    mask = np.array([[1.0, -2.0, 1.0], [-2.0, 4.0, -2.0], [1.0, -2.0, 1.0]])
    response = cv2.filter2D(np.asarray(image, dtype=float), -1, mask)[1:-1, 1:-1]
    return float(np.sqrt(np.pi / 2.0) * np.mean(np.abs(response)) / 6.0)


def edge_threshold(image, blur_sigma: float) -> float:
    """Canny threshold for :func:`detect_segments` on ``image`` (uint8): EDGE_NOISE_SIGMAS
    standard deviations of one Sobel component of its noise after the ``blur_sigma`` [pixels]
    Gaussian, and at least EDGE_FLOOR."""
    import cv2

    impulse = np.zeros((41, 41))
    impulse[20, 20] = 1.0
    if blur_sigma > 0:
        impulse = cv2.GaussianBlur(impulse, (0, 0), blur_sigma)
    gain = np.linalg.norm(cv2.Sobel(impulse, cv2.CV_64F, 1, 0, ksize=3))
    return max(EDGE_FLOOR, EDGE_NOISE_SIGMAS * gain * noise_level(image))


def slope_strength(image, sigma: float = SLOPE_SIGMA) -> np.ndarray:
    """Scale-normalised curvature (H, W) of an image (H, W) in [0, 1]: sigma^2 times the
    largest magnitude of the Hessian's eigenvalues of the image smoothed by a Gaussian of
    ``sigma`` [pixels]. Where the brightness gradient changes by d per pixel across a straight
    crease, it peaks on the crease at d sigma / sqrt(2 pi), half as high 1.18 sigma either
    side; a step of brightness d gives two peaks of 0.24 d, sigma either side of it."""
    import cv2

    check_positive("slope sigma [pixels]", sigma)
    smooth = cv2.GaussianBlur(np.asarray(image, dtype=np.float64), (0, 0), sigma)
    # 3x3 Sobel second derivatives carry a gain of 4 over the derivative per pixel^2
    duu, dvv, duv = (cv2.Sobel(smooth, cv2.CV_64F, du, dv, ksize=3) / 4.0
                     for du, dv in ((2, 0), (0, 2), (1, 1)))
    half_trace, radius = (duu + dvv) / 2, np.sqrt(((duu - dvv) / 2) ** 2 + duv ** 2)
    return sigma ** 2 * (np.abs(half_trace) + radius)


def _slope_segments(image, blurred, canny: float, sigma: float) -> np.ndarray:
    """FLD segments (n, 4) [pixels, OpenCV's coordinates in ``image``] along the bands where
    :func:`slope_strength` of ``image`` (H, W) in [0, 1] reaches its threshold
    (SLOPE_NOISE_MULTIPLE times its median, at least SLOPE_FLOOR) and half the strongest
    within 2 sigma (so a band is about 2.4 sigma wide, however strong the crease), outside 2
    sigma of steps stronger than SLOPE_STEP_MULTIPLE times ``canny`` in ``blurred`` (the uint8
    image FLD sees for steps). FLD outlines a band by its two edges, 1.2 sigma either side of
    the crease; :func:`merge_collinear` joins them."""
    import cv2

    strength = slope_strength(image, sigma)
    threshold = max(SLOPE_NOISE_MULTIPLE * float(np.median(strength)), SLOPE_FLOOR)
    gradient = sum(np.abs(cv2.Sobel(blurred.astype(np.float64), cv2.CV_64F, du, 1 - du, ksize=3))
                   for du in (0, 1))
    reach = 2 * int(np.ceil(2 * sigma)) + 1
    kernel = np.ones((reach, reach), np.uint8)
    steps = cv2.dilate((gradient >= SLOPE_STEP_MULTIPLE * canny).astype(np.uint8), kernel) > 0
    band = (strength >= threshold) & (2 * strength >= cv2.dilate(strength, kernel)) & ~steps
    found = cv2.ximgproc.createFastLineDetector(10, 1.414, 50.0, 100.0, 3, False).detect(
        band.astype(np.uint8) * 255)
    return np.zeros((0, 4)) if found is None else found.reshape(-1, 4).astype(float)


def _check_box(box, shape) -> tuple[int, int, int, int]:
    h, w = shape
    if box is None:
        return 0, 0, w, h
    u0, v0, u1, v1 = (int(b) for b in box)
    if not (0 <= u0 < u1 <= w and 0 <= v0 < v1 <= h):
        raise ValueError(f"box (u0, v0, u1, v1) = {tuple(box)} is not a non-empty box inside the "
                         f"{w} x {h} image")
    return u0, v0, u1, v1


def _check_segments(segments) -> np.ndarray:
    s = np.asarray(segments, dtype=float)
    if s.size == 0:
        return np.zeros((0, 4))
    if s.ndim != 2 or s.shape[1] != 4:
        raise ValueError(f"segments must have shape (n, 4) [u1, v1, u2, v2], got {s.shape}")
    check_finite("segments", s)
    return s


def detect_segments(gray, box=None, min_length: float = 50.0, *,
                    angle_tolerance: float = MERGE_ANGLE,
                    distance_tolerance: float = MERGE_DISTANCE,
                    gap_tolerance: float = MERGE_GAP, blur_sigma: float = 1.0,
                    fld_length: int = 10, fld_distance: float = 1.414,
                    canny_low: float | None = None, canny_high: float | None = None,
                    context: int = 8, slope_sigma: float | None = SLOPE_SIGMA) -> np.ndarray:
    """Line segments (n, 4) [u1, v1, u2, v2] [pixels, full-image coordinates] of a gray image.

    Runs OpenCV's Fast Line Detector on ``gray[v0:v1, u0:u1]`` (``box`` from
    :func:`fov_crop_box`; None: the whole image) for steps of brightness and, with
    ``slope_sigma``, on the bands of shading-slope creases (:func:`slope_strength`), merges
    pieces of one line with
    :func:`merge_collinear` (tolerances passed through; ``distance_tolerance`` also merges the
    two edges FLD reports on either side of a thin line) and drops segments shorter than
    ``min_length`` [pixels] after merging, as the paper does (50 px at 1600 x 1200).

    Args:
        gray: (H, W) uint8, or float in [0, 1] (clipped to it, then scaled to 0..255: tone-map
            linear radiance first if it is not in that range).
        blur_sigma: Gaussian pre-blur [pixels] against render noise; 0: none. 1 px keeps step
            edges sharp and, on a path-traced corner at 400 x 300, suppresses the noise
            edges of 16 spp and more (much more blur weakens low-contrast edges below the
            Canny thresholds).
        fld_length: FLD's own length threshold [pixels]; short so that broken edges survive
            to be merged.
        fld_distance: FLD's outlier distance from a hypothesis line [pixels] (OpenCV default).
        canny_low, canny_high: FLD's Canny hysteresis thresholds on the 3x3 Sobel gradient
            |g_u| + |g_v|: a sharp step edge of d grey levels gives 4 d (2.6 d after the 1 px
            blur, 1.5 d after 2 px), so 50 passes steps above 13 (19, 33) grey levels.
            None: :func:`edge_threshold` of the cropped image (12 on a denoised render, steps
            above 4.6 levels; 40-80 on raw 32 spp path tracing).
        context: FLD runs on the box grown by this many pixels on each side (within the
            image) and the segments are clipped back to the box: the blur, the Sobel kernel and
            FLD's own end handling stop edges several pixels short of the border of the image
            they see, and a crease that stops short of the box edge leaves a gap through which
            the regions of :func:`mitsonar.recon.surfels.region_labels` leak.
        slope_sigma: scale [pixels] of the shading-slope creases (thresholds: SLOPE_*); None:
            steps of brightness only.
    FLD's own merging is off: :func:`merge_collinear` does it with stated tolerances.
    """
    import cv2

    image = _as_uint8(gray)
    box = _check_box(box, image.shape)
    check_positive("min_length [pixels]", min_length)
    check_range("blur_sigma [pixels]", blur_sigma, 0.0, np.inf)
    if int(context) != context or context < 0:
        raise ValueError(f"context must be an integer >= 0 [pixels], got {context}")
    h, w = image.shape
    u0, v0 = max(box[0] - context, 0), max(box[1] - context, 0)
    u1, v1 = min(box[2] + context, w), min(box[3] + context, h)
    crop = np.ascontiguousarray(image[v0:v1, u0:u1])
    if canny_low is None or canny_high is None:
        automatic = edge_threshold(crop, blur_sigma)
        canny_low, canny_high = (automatic if c is None else c for c in (canny_low, canny_high))
    blurred = cv2.GaussianBlur(crop, (0, 0), blur_sigma) if blur_sigma > 0 else crop
    fld = cv2.ximgproc.createFastLineDetector(int(fld_length), float(fld_distance),
                                              float(canny_low), float(canny_high), 3, False)
    found = fld.detect(blurred)
    segments = np.zeros((0, 4)) if found is None else found.reshape(-1, 4).astype(float)
    if slope_sigma is not None:
        fine = np.asarray(gray)[v0:v1, u0:u1]
        fine = fine / 255.0 if fine.dtype == np.uint8 else np.clip(fine, 0.0, 1.0)
        segments = np.concatenate([segments, _slope_segments(fine, blurred, float(canny_low),
                                                             slope_sigma)])
    if not len(segments):
        return np.zeros((0, 4))
    segments = segments + OPENCV_TO_PIXEL
    segments += np.array([u0, v0, u0, v0], dtype=float)
    segments = clip_segments(segments, box)
    merged = merge_collinear(segments, angle_tolerance, distance_tolerance, gap_tolerance)
    lengths = np.hypot(merged[:, 2] - merged[:, 0], merged[:, 3] - merged[:, 1])
    return merged[lengths >= min_length]


def clip_segments(segments, box) -> np.ndarray:
    """Parts (m, 4) of segments (n, 4) [pixels] inside the box (u0, v0, u1, v1) [pixels]
    (Liang-Barsky); segments entirely outside (or touching it in a point) are dropped."""
    s = _check_segments(segments)
    a, d = s[:, :2], s[:, 2:] - s[:, :2]
    lo, hi = np.asarray(box[:2], float), np.asarray(box[2:], float)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_lo, t_hi = (lo - a) / d, (hi - a) / d  # (n, 2) where each axis crosses each side
    flat = d == 0  # parallel to a side: inside for all t or for none
    enter = np.where(flat, np.where((a >= lo) & (a <= hi), 0.0, np.inf), np.minimum(t_lo, t_hi))
    leave = np.where(flat, np.where((a >= lo) & (a <= hi), 1.0, -np.inf), np.maximum(t_lo, t_hi))
    t0 = np.maximum(enter.max(axis=1), 0.0)
    t1 = np.minimum(leave.min(axis=1), 1.0)
    keep = t1 > t0
    t0, t1 = t0[keep, None], t1[keep, None]
    return np.concatenate([a[keep] + t0 * d[keep], a[keep] + t1 * d[keep]], axis=1)


def _segment_frames(s: np.ndarray):
    """Midpoints (n, 2), unit directions (n, 2) and lengths (n,) of segments (n, 4)."""
    a, b = s[:, :2], s[:, 2:]
    d = b - a
    length = np.hypot(d[:, 0], d[:, 1])
    unit = d / np.maximum(length, 1e-12)[:, None]
    return (a + b) / 2, unit, length


def _angle_neighbours(theta: np.ndarray, tolerance: float, chunk: int):
    """Pairs (i, j) of lines whose directions theta (n,) [rad, mod pi] differ by at most
    ``tolerance``, each unordered pair once, yielded in chunks of at most about ``chunk`` pairs.

    Sorting the directions turns the neighbours of each line into a run of the sorted list
    (continued through pi = 0), so only those runs are listed, not all n^2 pairs.
    """
    n = len(theta)
    order = np.argsort(theta, kind="stable")
    ts = theta[order]
    hi = np.searchsorted(np.concatenate([ts, ts + np.pi]), ts + tolerance, side="right")
    count = np.clip(hi - np.arange(n) - 1, 0, n - 1)  # neighbours after each sorted position
    ends = np.cumsum(count)
    cuts = np.unique(np.searchsorted(ends, np.arange(chunk, ends[-1], chunk), side="left"))
    for lo, up in zip(np.r_[0, cuts + 1], np.r_[cuts + 1, n]):
        c = count[lo:up]
        pos = np.repeat(np.arange(lo, up), c)
        step = np.arange(c.sum()) - np.repeat(np.cumsum(c) - c, c) + 1
        yield order[pos], order[(pos + step) % n]


def _collinear_pairs(s: np.ndarray, angle_tolerance, distance_tolerance, gap_tolerance,
                     chunk: int = 1 << 20):
    """Pairs (i, j) of segments on one line, judged in the frame of the longer of each pair."""
    mid, unit, length = _segment_frames(s)
    ends = s.reshape(-1, 2, 2)
    theta = np.mod(np.arctan2(unit[:, 1], unit[:, 0]), np.pi)
    found = [(np.zeros(0, int), np.zeros(0, int))]
    for a, b in _angle_neighbours(theta, angle_tolerance, chunk):
        # r: the reference, the longer segment of the pair (ties: the lower index); o: the other
        a_ref = (length[a] > length[b]) | ((length[a] == length[b]) & (a < b))
        r, o = np.where(a_ref, a, b), np.where(a_ref, b, a)
        # both ends within the distance only if the midpoint is: a cheap first cut
        dm = mid[o] - mid[r]
        near = np.abs(dm[:, 1] * unit[r, 0] - dm[:, 0] * unit[r, 1]) <= distance_tolerance
        a, b, r, o = a[near], b[near], r[near], o[near]
        rel = ends[o] - mid[r][:, None, :]  # (pairs, endpoint, uv)
        along = np.einsum("mkc,mc->mk", rel, unit[r])
        across = np.abs(rel[..., 1] * unit[r][:, None, 0] - rel[..., 0] * unit[r][:, None, 1])
        half = length[r] / 2
        gap = np.maximum(along.min(axis=1) - half, -half - along.max(axis=1))
        keep = (across.max(axis=1) <= distance_tolerance) & (gap <= gap_tolerance)
        found.append((a[keep], b[keep]))
    return tuple(np.concatenate(x) for x in zip(*found))


def _fit_groups(s: np.ndarray, label: np.ndarray, count: int) -> np.ndarray:
    """One segment (count, 4) per group ``label`` (n,) of segments (n, 4), spanning the extreme
    projections of the group's endpoints on the group's line.

    The line passes through the length-weighted mean midpoint along the length-weighted mean
    direction (directions averaged as doubled angles, so opposite orientations agree); it is
    oriented towards +u (+v when vertical).
    """
    mid, unit, length = _segment_frames(s)
    w = length + 1e-12

    def total(x):
        return np.bincount(label, weights=x, minlength=count)

    angle2 = 2 * np.arctan2(unit[:, 1], unit[:, 0])
    half = np.arctan2(total(w * np.sin(angle2)), total(w * np.cos(angle2))) / 2
    d = np.stack([np.cos(half), np.sin(half)], axis=-1)
    d[(d[:, 0] < -1e-12) | ((np.abs(d[:, 0]) <= 1e-12) & (d[:, 1] < 0))] *= -1
    centre = np.stack([total(w * mid[:, 0]), total(w * mid[:, 1])], axis=-1) / total(w)[:, None]
    point_label = np.repeat(label, 2)
    t = np.einsum("pc,pc->p", s.reshape(-1, 2) - centre[point_label], d[point_label])
    t_min, t_max = np.full(count, np.inf), np.full(count, -np.inf)
    np.minimum.at(t_min, point_label, t)
    np.maximum.at(t_max, point_label, t)
    return np.concatenate([centre + t_min[:, None] * d, centre + t_max[:, None] * d], axis=1)


def merge_collinear(segments, angle_tolerance: float = MERGE_ANGLE,
                    distance_tolerance: float = MERGE_DISTANCE,
                    gap_tolerance: float = MERGE_GAP) -> np.ndarray:
    """Merge segments (n, 4) [u1, v1, u2, v2] lying on one line into segments (m, 4).

    Two segments are on one line when their directions differ by at most ``angle_tolerance``
    [rad], both endpoints of the shorter lie within ``distance_tolerance`` [pixels] of the
    longer one's line, and along that line they overlap or leave a gap of at most
    ``gap_tolerance`` [pixels]. Connected groups of such pairs (repeated until nothing changes)
    become one segment spanning their extreme projections on the group's fitted line. Output
    order: groups in order of their first input segment; every output segment runs towards +u
    (+v when vertical).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    s = _check_segments(segments)
    check_range("angle_tolerance [rad]", angle_tolerance, 0.0, np.pi / 2)
    check_range("distance_tolerance [pixels]", distance_tolerance, 0.0, np.inf)
    check_range("gap_tolerance [pixels]", gap_tolerance, 0.0, np.inf)
    while len(s):
        i, j = _collinear_pairs(s, angle_tolerance, distance_tolerance, gap_tolerance)
        graph = coo_matrix((np.ones(len(i)), (i, j)), shape=(len(s), len(s)))
        count, label = connected_components(graph, directed=False)
        s, merged = _fit_groups(s, label, count), count < len(s)
        if not merged:
            break
    return s


@dataclass(frozen=True)
class Surfels2D:
    """Triangle surfels in the image.

    Attributes:
        vertices: (k, 3, 2) [pixels]: junction point, then the far ends of the two segments,
            counterclockwise as displayed.
        segment_pairs: (k, 2) indices into ``segments`` of the two segments of each surfel.
        segments: (n, 4) [u1, v1, u2, v2] segments the surfels came from [pixels].
    """

    vertices: np.ndarray
    segment_pairs: np.ndarray
    segments: np.ndarray

    def __len__(self) -> int:
        return len(self.vertices)


def triangle_surfels(segments, join_tolerance: float = 10.0,
                     min_angle: float = np.radians(10.0)) -> Surfels2D:
    """Triangle surfels from pairs of segments (n, 4) that meet at a common point.

    For each pair whose supporting lines cross within ``join_tolerance`` [pixels] of an endpoint
    of both segments (a corner, not a crossing in the middle of either), the triangle is
    (crossing point, far end of one segment, far end of the other). Pairs whose legs from the
    crossing meet at less than ``min_angle`` [rad] or more than pi - ``min_angle`` (nearly
    collinear), and triangles with a leg no longer than ``join_tolerance`` (degenerate), are
    dropped. Pairs (i, j), i < j, are listed in lexicographic order.
    """
    s = _check_segments(segments)
    check_positive("join_tolerance [pixels]", join_tolerance)
    check_range("min_angle [rad]", min_angle, 0.0, np.pi / 2)
    i, j = np.triu_indices(len(s), k=1)
    a, da = s[i, :2], s[i, 2:] - s[i, :2]
    b, db = s[j, :2], s[j, 2:] - s[j, :2]
    cross = da[:, 0] * db[:, 1] - da[:, 1] * db[:, 0]
    ok = np.abs(cross) > 1e-9 * np.hypot(*da.T) * np.hypot(*db.T)
    w = b - a
    t = np.divide(w[:, 0] * db[:, 1] - w[:, 1] * db[:, 0], cross, out=np.zeros(len(i)), where=ok)
    x = a + t[:, None] * da  # crossing of the two supporting lines

    def far_end(seg):
        ends = seg.reshape(-1, 2, 2)
        dist = np.linalg.norm(ends - x[:, None, :], axis=-1)
        near = dist.min(axis=1) <= join_tolerance
        return near, ends[np.arange(len(seg)), np.argmax(dist, axis=1)]

    near_a, pa = far_end(s[i])
    near_b, pb = far_end(s[j])
    la, lb = pa - x, pb - x
    len_a, len_b = np.hypot(*la.T), np.hypot(*lb.T)
    keep = ok & near_a & near_b & (len_a > join_tolerance) & (len_b > join_tolerance)
    cos = np.sum(la * lb, axis=1) / np.maximum(len_a * len_b, 1e-12)
    keep &= np.abs(cos) <= np.cos(min_angle)
    area2 = la[:, 0] * lb[:, 1] - la[:, 1] * lb[:, 0]
    ccw = area2 < 0  # counterclockwise as displayed (v down)
    first = np.where(ccw[:, None], pa, pb)
    second = np.where(ccw[:, None], pb, pa)
    vertices = np.stack([x, first, second], axis=1)[keep]
    return Surfels2D(vertices, np.stack([i, j], axis=1)[keep], s)


def close_junctions(segments, gap: float, min_angle: float = np.radians(10.0),
                    reach=None) -> np.ndarray:
    """Segments (n, 4) [pixels] with ends extended to the junctions they stop short of.

    A detector often stops a few pixels short of where two lines meet (the corner of a window,
    a wall meeting the floor), leaving a gap through which image regions leak. For every pair
    of segments that are not nearly parallel (``min_angle`` [rad]) and whose supporting lines
    cross within ``gap`` [pixels] of both segments, each segment's nearer end is moved to the
    crossing if the crossing lies beyond it; of several such junctions an end takes the
    nearest. ``reach`` (n,) [pixels]: how far each segment's own ends may be extended instead
    of ``gap`` (the crossing still within ``gap`` of the other segment). Segments are only
    lengthened, never shortened or moved sideways.
    """
    s = _check_segments(segments).copy()
    check_range("gap [pixels]", gap, 0.0, np.inf)
    reach = np.full(len(s), float(gap)) if reach is None else np.asarray(reach, float)
    if reach.shape != (len(s),) or np.any(~(reach >= 0)):
        raise ValueError(f"reach must be {len(s)} lengths >= 0 [pixels], got {reach}")
    if len(s) < 2 or not np.any(reach > 0):
        return s
    i, j = np.nonzero(~np.eye(len(s), dtype=bool))  # ordered pairs: i is extended towards j
    a, da = s[i, :2], s[i, 2:] - s[i, :2]
    b, db = s[j, :2], s[j, 2:] - s[j, :2]
    len_a, len_b = np.hypot(*da.T), np.hypot(*db.T)
    cross = da[:, 0] * db[:, 1] - da[:, 1] * db[:, 0]
    ok = np.abs(cross) > np.sin(min_angle) * len_a * len_b
    w = b - a
    ta = np.divide(w[:, 0] * db[:, 1] - w[:, 1] * db[:, 0], cross, out=np.zeros(len(i)), where=ok)
    tb = np.divide(w[:, 0] * da[:, 1] - w[:, 1] * da[:, 0], cross, out=np.zeros(len(i)), where=ok)
    beyond_a = np.maximum(np.maximum(-ta, ta - 1.0), 0.0) * len_a  # crossing past i's ends
    beyond_b = np.maximum(np.maximum(-tb, tb - 1.0), 0.0) * len_b
    ok &= (beyond_a > 0) & (beyond_a <= reach[i]) & (beyond_b <= gap)
    x = a + ta[:, None] * da
    end = np.where(ta > 1.0, 2, 0)  # column of the end that moves: (u2, v2) or (u1, v1)
    for e in (0, 2):  # each end takes its nearest junction
        sel = ok & (end == e)
        order = np.lexsort((-beyond_a[sel], i[sel]))  # per segment, the nearest written last
        s[i[sel][order], e:e + 2] = x[sel][order]
    return s


def scan_pixels(vertices) -> np.ndarray:
    """The paper's four scan points (k, 4, 2) [pixels] of triangles (k, 3, 2).

    Points one third of the way from the centroid to each vertex, in the vertices' order
    (counterclockwise for :func:`triangle_surfels`), then the centroid (the verification point).
    """
    v = np.asarray(vertices, dtype=float)
    if v.ndim != 3 or v.shape[1:] != (3, 2):
        raise ValueError(f"vertices must have shape (k, 3, 2), got {v.shape}")
    check_finite("vertices [pixels]", v)
    centroid = v.mean(axis=1, keepdims=True)
    return np.concatenate([centroid + (v - centroid) / 3.0, centroid], axis=1)


def scan_directions(camera: CameraModel, pixels, depth=None) -> np.ndarray:
    """Unit beam directions (..., 3) in the sensor frame for pixels (..., 2) [pixels].

    ``depth`` None: equations (10)(11) (:meth:`CameraModel.pixel_angles`), the camera ray's
    direction, as in the paper; the beam from the array origin then runs parallel to the camera
    ray, 7.5 cm below it. ``depth`` [m] (scalar or (...)): the direction from the array origin to
    the point of the camera ray at that sensor-frame z, which removes that parallax.
    """
    p = np.asarray(pixels, dtype=float)
    if p.shape[-1:] != (2,):
        raise ValueError(f"pixels must have shape (..., 2), got {p.shape}")
    check_finite("pixels", p)
    ray = direction_from_angles(*camera.pixel_angles(p[..., 0], p[..., 1]))
    if depth is None:
        return ray
    z = np.asarray(depth, dtype=float)
    check_positive("scan depth [m]", z)
    along = (z - camera.offset[2]) / ray[..., 2]  # camera ray length to sensor-frame z = depth
    point = ray * along[..., None] + camera.offset
    return point / np.linalg.norm(point, axis=-1, keepdims=True)
