"""Repeated-scanning map (section III-E): colour sonar points from the camera image, move them to
the world (12), filter outliers and voxelise; a voxel's colour is the mean of its points' colours.

Per OFDM frame the sonar gives one reflector per beam in the *sensor* frame (NaN rows: no
detection) together with the world-from-sensor pose at the moment each beam was sent (the robot
moves during the 208.5 ms frame), and the camera gives one linear-RGB image taken at the frame's
reference pose. :func:`colourise` puts every point into the world by its own pose, projects it
into that image (world -> sensor at the image pose -> camera -> pixel) and samples the image
bilinearly. :class:`VoxelMap` accumulates the coloured world points of many frames and builds
the map: statistical outlier removal, then voxel averaging on a grid fixed in the world.

Colours are sRGB-encoded in [0, 1] (what PLY viewers and matplotlib expect); the image is
sampled in linear RGB and only the sample is encoded. There is no tone mapping: linear values
above 1 saturate (``exposure`` scales the image first). A point the camera cannot see (behind
it or outside the image) keeps a NaN colour and is counted; it still adds geometry to the map.
Occlusion is not checked: a point hidden from the camera by a nearer surface (parallax of the
7.5 cm camera offset, motion during a frame) takes that surface's colour.

Why not Open3D for the filters (both were checked against Open3D 0.20 in the tests):

* ``remove_statistical_outlier`` counts the point itself among its ``nb_neighbors`` and drops
  every point whose mean neighbour distance is 0, so *exact duplicates are all removed* -- and a
  robot standing still in a noise-free simulation returns exact duplicates every frame. Here
  the point itself is not a neighbour and duplicates are kept; otherwise the result is the same
  (``outlier_neighbours = k`` here keeps what ``nb_neighbors = k + 1`` keeps in Open3D).
* ``voxel_down_sample`` does average positions and colours per voxel (tested), but anchors its
  grid at the cloud's minimum bound minus half a voxel, so the grid moves as the map grows, and
  one NaN colour makes its voxel's colour NaN. Here the grid is anchored at a fixed world
  ``origin`` and the colour mean is taken over the coloured points only.

The result is still handed out as an Open3D ``PointCloud`` (:meth:`VoxelMap.build`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mitsonar.sensors.camera import CameraModel
from mitsonar.frames import Pose
from mitsonar.io import write_ply
from mitsonar.plots import save_png
from mitsonar.validation import check_finite, check_positive

#: Colour given to voxels without any coloured point when a format needs one (Open3D, PLY, PNG).
UNCOLOURED = (0.5, 0.5, 0.5)


# --------------------------------------------------------------------------------------------
# Colour from the camera image


def linear_to_srgb(linear) -> np.ndarray:
    """sRGB encoding (IEC 61966-2-1) of linear values, clipped to [0, 1] first; NaN stays NaN."""
    c = np.clip(np.asarray(linear, dtype=float), 0.0, 1.0)
    srgb = np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1.0 / 2.4) - 0.055)
    return np.clip(srgb, 0.0, 1.0)  # 1.055 - 0.055 rounds to 1 + 2e-16


def srgb_to_linear(srgb) -> np.ndarray:
    """Inverse of :func:`linear_to_srgb` on [0, 1]."""
    c = np.asarray(srgb, dtype=float)
    return np.where(c <= 0.04045, c / 12.92, np.power((c + 0.055) / 1.055, 2.4))


def bilinear_sample(image, pixels) -> np.ndarray:
    """Bilinear samples (N, C) of ``image`` (H, W, C) at pixel coordinates ``pixels`` (N, 2).

    Pixel (i, j) covers u in [i, i+1), v in [j, j+1) (as :class:`CameraModel`), so its value sits
    at (i + 0.5, j + 0.5). Coordinates must lie in [0, W] x [0, H]; within half a pixel of the
    border the edge pixels are used (clamped), as a renderer's box filter would give.
    """
    img = np.asarray(image)
    h, w = img.shape[:2]
    uv = np.asarray(pixels, dtype=float).reshape(-1, 2)
    x = np.clip(uv[:, 0] - 0.5, 0.0, w - 1)
    y = np.clip(uv[:, 1] - 0.5, 0.0, h - 1)
    x0 = np.minimum(np.floor(x).astype(np.int64), max(w - 2, 0))
    y0 = np.minimum(np.floor(y).astype(np.int64), max(h - 2, 0))
    x1 = np.minimum(x0 + 1, w - 1)
    y1 = np.minimum(y0 + 1, h - 1)
    fx = (x - x0)[:, None]
    fy = (y - y0)[:, None]
    top = img[y0, x0] * (1 - fx) + img[y0, x1] * fx
    bottom = img[y1, x0] * (1 - fx) + img[y1, x1] * fx
    return (top * (1 - fy) + bottom * fy).astype(float)


@dataclass(frozen=True)
class ColouredPoints:
    """The detections of one frame in the world, with their colour from the camera image.

    Attributes:
        points_world: (N, 3) reflector positions in the world [m], one per detection.
        colours: (N, 3) sRGB in [0, 1]; NaN rows where the camera does not see the point.
        pixels: (N, 2) image coordinates (u, v) [pixels] of each point; NaN behind the camera.
        beam_index: (N,) row of each point in the frame's (B, 3) input.
        n_beams: B, beams in the frame.
        n_behind_camera: points at or behind the camera's image plane (z_camera <= 0).
        n_outside_image: points in front of the camera that project outside the image.
    """

    points_world: np.ndarray
    colours: np.ndarray
    pixels: np.ndarray
    beam_index: np.ndarray
    n_beams: int
    n_behind_camera: int
    n_outside_image: int

    @property
    def n_detected(self) -> int:
        """Beams with a detection (N)."""
        return len(self.points_world)

    @property
    def n_uncoloured(self) -> int:
        """Detections without a colour: behind the camera or outside the image."""
        return self.n_behind_camera + self.n_outside_image

    @property
    def coloured(self) -> np.ndarray:
        """(N,) bool: the camera saw the point."""
        return ~np.isnan(self.colours[:, 0])


def _as_pose(name: str, value) -> Pose:
    if isinstance(value, Pose):
        return value
    m = np.asarray(value, dtype=float)
    if m.shape != (4, 4):
        raise ValueError(f"{name} must be a Pose or a (4, 4) matrix, got shape {m.shape}")
    _check_rigid(name, m[None])
    return Pose(m[:3, :3], m[:3, 3])


def _check_rigid(name: str, m: np.ndarray) -> None:
    """Every (4, 4) in ``m`` (B, 4, 4) must be a finite proper rigid transform."""
    finite = np.all(np.isfinite(m), axis=(1, 2))
    if not np.all(finite):
        k = int(np.argmin(finite))
        raise ValueError(f"{name}[{k}] is not finite:\n{m[k]}")
    r = m[:, :3, :3]
    ortho = np.abs(np.einsum("bij,bkj->bik", r, r) - np.eye(3)).max(axis=(1, 2)) <= 1e-6
    proper = np.linalg.det(r) > 0
    bottom = np.abs(m[:, 3] - np.array([0.0, 0.0, 0.0, 1.0])).max(axis=1) <= 1e-9
    ok = ortho & proper & bottom
    if not np.all(ok):
        k = int(np.argmin(ok))
        raise ValueError(f"{name}[{k}] is not a rigid transform (rotation must be orthonormal "
                         f"with det +1, last row [0, 0, 0, 1]):\n{m[k]}")


def colourise(points_sensor, world_from_sensor, image, camera_model: CameraModel,
              image_world_from_sensor, exposure: float = 1.0) -> ColouredPoints:
    """Colour one frame's detections from the camera image and move them to the world.

    Args:
        points_sensor: (B, 3) reflector per beam in the sensor frame [m]; an all-NaN row is a
            beam without detection (a row with some but not all NaN is an error).
        world_from_sensor: (B, 4, 4) pose of the sensor head when each beam was sent (a single
            (4, 4) is used for every beam). p_world = R p_sensor + t, equation (12).
        image: (H, W, 3) linear RGB of the camera, H x W as ``camera_model``.
        camera_model: the camera (intrinsics and its offset from the sensor head).
        image_world_from_sensor: world-from-sensor pose (a :class:`Pose` or (4, 4)) of the sensor
            head when the image was taken; the camera pose is this and the camera offset.
        exposure: factor applied to the linear image before sRGB encoding (no tone mapping).

    Returns:
        :class:`ColouredPoints`: world points and colours of the N detected beams; points the
        camera cannot see have NaN colours and are counted, never given a colour.
    """
    p = np.asarray(points_sensor, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"points_sensor must be (B, 3) [m], got shape {p.shape}")
    n_beams = len(p)
    poses = np.asarray(world_from_sensor, dtype=float)
    if poses.shape == (4, 4):
        poses = np.broadcast_to(poses, (n_beams, 4, 4))
    if poses.shape != (n_beams, 4, 4):
        raise ValueError(f"world_from_sensor must be (B, 4, 4) with B = {n_beams} beams (as "
                         f"points_sensor), got shape {poses.shape}")
    _check_rigid("world_from_sensor", poses)
    nan = np.isnan(p)
    partial = nan.any(axis=1) & ~nan.all(axis=1)
    if np.any(partial):
        k = int(np.argmax(partial))
        raise ValueError(f"points_sensor[{k}] = {p[k]} is partly NaN (a beam without detection "
                         f"must be an all-NaN row)")
    detected = ~nan.any(axis=1)
    if not np.all(np.isfinite(p[detected])):
        k = int(np.argmax(detected & ~np.all(np.isfinite(p), axis=1)))
        raise ValueError(f"points_sensor[{k}] = {p[k]} is infinite")
    img = np.asarray(image)
    h, w = camera_model.height, camera_model.width
    if img.shape != (h, w, 3):
        raise ValueError(f"image must be (H, W, 3) = ({h}, {w}, 3) as the camera model, got "
                         f"shape {img.shape}")
    if not np.all(np.isfinite(img)):
        raise ValueError("image has NaN or infinite pixels")
    check_positive("exposure", exposure)
    image_pose = _as_pose("image_world_from_sensor", image_world_from_sensor)

    index = np.flatnonzero(detected)
    pose = poses[index]
    world = np.einsum("bij,bj->bi", pose[:, :3, :3], p[index]) + pose[:, :3, 3]   # (12)
    camera_from_world = camera_model.camera_from_sensor() @ image_pose.inverse()
    cam = camera_from_world.transform_points(world)
    in_front = cam[:, 2] > 0.0
    pixels = np.full((len(index), 2), np.nan)
    pixels[in_front] = camera_model.project(cam[in_front])
    with np.errstate(invalid="ignore"):  # NaN pixels compare False: not inside
        inside = (in_front & (pixels[:, 0] >= 0.0) & (pixels[:, 0] <= w)
                  & (pixels[:, 1] >= 0.0) & (pixels[:, 1] <= h))
    colours = np.full((len(index), 3), np.nan)
    if np.any(inside):
        colours[inside] = linear_to_srgb(exposure * bilinear_sample(img, pixels[inside]))
    return ColouredPoints(world, colours, pixels, index, n_beams,
                          n_behind_camera=int(np.count_nonzero(~in_front)),
                          n_outside_image=int(np.count_nonzero(in_front & ~inside)))


# --------------------------------------------------------------------------------------------
# Filtering and voxels


@dataclass(frozen=True)
class VoxelMapSettings:
    """How the accumulated points become a voxel map.

    Attributes:
        voxel_size: edge of the cubic voxels [m].
        outlier_neighbours: k of the statistical outlier removal: a point's score is its mean
            distance to its k nearest other points; 0 disables the removal.
        outlier_std: a point is an outlier if its score exceeds the mean score plus
            ``outlier_std`` standard deviations of the scores (over the whole map).
        origin: (3,) a corner of the voxel grid in the world [m]; voxel (i, j, k) spans
            origin + voxel_size * [i, i+1) x [j, j+1) x [k, k+1).
    """

    voxel_size: float = 0.05
    outlier_neighbours: int = 20
    outlier_std: float = 2.0
    origin: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self):
        check_positive("VoxelMapSettings.voxel_size [m]", self.voxel_size)
        k = self.outlier_neighbours
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 0:
            raise ValueError(f"VoxelMapSettings.outlier_neighbours must be an integer >= 0 "
                             f"(0: no outlier removal), got {k!r}")
        check_positive("VoxelMapSettings.outlier_std", self.outlier_std)
        origin = np.asarray(self.origin, dtype=float)
        if origin.shape != (3,):
            raise ValueError(f"VoxelMapSettings.origin [m] must be (3,), got shape {origin.shape}")
        check_finite("VoxelMapSettings.origin [m]", origin)
        object.__setattr__(self, "outlier_neighbours", int(k))
        object.__setattr__(self, "origin", origin)


def statistical_outliers(points, neighbours: int, std_ratio: float) -> np.ndarray:
    """(N,) bool, True for outliers: mean distance to the ``neighbours`` nearest other points
    above mean + ``std_ratio`` x standard deviation (ddof 1) of that distance over all points.

    Exact duplicates are not outliers (Open3D's filter drops them). With fewer than
    ``neighbours`` + 1 points the N - 1 others are used; with fewer than 3 points nothing is an
    outlier.
    """
    from scipy.spatial import cKDTree

    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    n = len(pts)
    k = min(int(neighbours), n - 1)
    if k < 1 or n < 3:
        return np.zeros(n, dtype=bool)
    dist, _ = cKDTree(pts).query(pts, k=k + 1)
    score = dist[:, 1:].mean(axis=1)  # column 0: the point itself (or a duplicate, also at 0)
    threshold = score.mean() + std_ratio * score.std(ddof=1)
    return score > threshold


@dataclass(frozen=True)
class VoxelCloud:
    """A voxelised map: one point per occupied voxel.

    Attributes:
        positions: (M, 3) mean position of the voxel's points [m] (as Open3D's voxel filter).
        colours: (M, 3) mean sRGB colour of the voxel's coloured points; NaN rows where none.
        counts: (M,) points in the voxel.
        coloured_counts: (M,) points with a colour in the voxel.
        keys: (M, 3) integer voxel indices (see :class:`VoxelMapSettings.origin`).
        settings: the settings used.
        n_input: points in the map before filtering.
        n_outliers: points removed as outliers.
    """

    positions: np.ndarray
    colours: np.ndarray
    counts: np.ndarray
    coloured_counts: np.ndarray
    keys: np.ndarray
    settings: VoxelMapSettings
    n_input: int
    n_outliers: int

    def __len__(self) -> int:
        return len(self.positions)

    @property
    def n_uncoloured(self) -> int:
        """Voxels without any coloured point."""
        return int(np.count_nonzero(self.coloured_counts == 0))

    def display_colours(self, uncoloured=UNCOLOURED) -> np.ndarray:
        """(M, 3) colours in [0, 1] with ``uncoloured`` for voxels without a colour."""
        fill = np.broadcast_to(np.asarray(uncoloured, dtype=float), self.colours.shape)
        return np.where(np.isnan(self.colours), fill, self.colours)

    def to_open3d(self, uncoloured=UNCOLOURED):
        """Open3D ``PointCloud`` of the voxels; voxels without colour get ``uncoloured``."""
        from mitsonar._native import import_open3d

        o3d = import_open3d()
        cloud = o3d.geometry.PointCloud()
        cloud.points = o3d.utility.Vector3dVector(np.ascontiguousarray(self.positions))
        cloud.colors = o3d.utility.Vector3dVector(
            np.ascontiguousarray(self.display_colours(uncoloured)))
        return cloud


def voxelise(points, colours, settings: VoxelMapSettings, n_outliers: int = 0) -> VoxelCloud:
    """Average points (N, 3) [m] and colours (N, 3) (NaN rows: no colour) per voxel.

    Voxels are ordered by their integer keys (lexicographic), so the output is deterministic.
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    cols = np.asarray(colours, dtype=float).reshape(-1, 3)
    keys = np.floor((pts - settings.origin) / settings.voxel_size).astype(np.int64)
    uniq, inverse = np.unique(keys, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    m = len(uniq)
    counts = np.bincount(inverse, minlength=m)
    positions = np.stack([np.bincount(inverse, pts[:, a], minlength=m) for a in range(3)], axis=1)
    positions = positions / np.maximum(counts, 1)[:, None]
    has_colour = ~np.isnan(cols[:, 0])
    coloured_counts = np.bincount(inverse, has_colour.astype(float), minlength=m).astype(np.int64)
    filled = np.where(has_colour[:, None], cols, 0.0)
    sums = np.stack([np.bincount(inverse, filled[:, a], minlength=m) for a in range(3)], axis=1)
    mean_colour = np.full((m, 3), np.nan)
    some = coloured_counts > 0
    mean_colour[some] = sums[some] / coloured_counts[some, None]
    return VoxelCloud(positions, mean_colour, counts, coloured_counts, uniq, settings,
                      n_input=len(pts) + n_outliers, n_outliers=n_outliers)


class VoxelMap:
    """Accumulates coloured world points frame after frame; :meth:`build` makes the voxel map."""

    def __init__(self):
        self._points: list[np.ndarray] = []
        self._colours: list[np.ndarray] = []

    def __len__(self) -> int:
        return sum(len(p) for p in self._points)

    @property
    def n_frames(self) -> int:
        """Calls of :meth:`add` so far."""
        return len(self._points)

    def add(self, points_world, colours) -> None:
        """Add points (N, 3) [m] in the world and their sRGB colours (N, 3) in [0, 1].

        A colour row may be all NaN (the camera did not see the point): the point counts for the
        geometry and the outlier statistics but not for its voxel's colour.
        """
        p = np.asarray(points_world, dtype=float)
        c = np.asarray(colours, dtype=float)
        if p.ndim != 2 or p.shape[1] != 3:
            raise ValueError(f"points_world must be (N, 3) [m], got shape {p.shape}")
        if c.shape != p.shape:
            raise ValueError(f"colours must be (N, 3) like points_world {p.shape}, got {c.shape}")
        if not np.all(np.isfinite(p)):
            k = int(np.argmin(np.all(np.isfinite(p), axis=1)))
            raise ValueError(f"points_world[{k}] = {p[k]} is not finite (drop beams without "
                             f"detection before adding, as colourise does)")
        nan = np.isnan(c)
        bad = (nan.any(axis=1) & ~nan.all(axis=1)) | np.any(~nan & ((c < 0) | (c > 1)), axis=1)
        if np.any(bad):
            k = int(np.argmax(bad))
            raise ValueError(f"colours[{k}] = {c[k]}: each colour must lie in [0, 1] (sRGB) or "
                             f"be an all-NaN row (no colour)")
        self._points.append(p.copy())
        self._colours.append(c.copy())

    def add_frame(self, frame: ColouredPoints) -> None:
        """Add the output of :func:`colourise`."""
        self.add(frame.points_world, frame.colours)

    def points(self) -> tuple[np.ndarray, np.ndarray]:
        """All points (N, 3) [m] and colours (N, 3) added so far."""
        if not self._points:
            return np.zeros((0, 3)), np.zeros((0, 3))
        return np.concatenate(self._points), np.concatenate(self._colours)

    def voxelise(self, settings: VoxelMapSettings = VoxelMapSettings()) -> VoxelCloud:
        """Statistical outlier removal over all points, then voxel averaging."""
        pts, cols = self.points()
        outlier = np.zeros(len(pts), dtype=bool)
        if settings.outlier_neighbours > 0:
            outlier = statistical_outliers(pts, settings.outlier_neighbours, settings.outlier_std)
        return voxelise(pts[~outlier], cols[~outlier], settings,
                        n_outliers=int(np.count_nonzero(outlier)))

    def build(self, voxel_size: float = 0.05, outlier_neighbours: int = 20,
              outlier_std: float = 2.0, origin=(0.0, 0.0, 0.0)):
        """The voxel map as an Open3D ``PointCloud`` (see :meth:`voxelise`, :class:`VoxelMapSettings`).

        Voxels without any coloured point are kept for their geometry and drawn in
        :data:`UNCOLOURED` grey; :meth:`voxelise` gives their count and NaN colours.
        """
        return self.voxelise(VoxelMapSettings(voxel_size, outlier_neighbours, outlier_std,
                                              np.asarray(origin, dtype=float))).to_open3d()


# --------------------------------------------------------------------------------------------
# Output


def save_voxel_ply(path, voxels: VoxelCloud) -> None:
    """ASCII PLY of the voxels, atomically: x y z [m], 8-bit sRGB colour (voxels without colour
    in :data:`UNCOLOURED` grey), and per-voxel ``count`` and ``coloured`` (points with colour)."""
    rgb = np.round(voxels.display_colours() * 255.0).astype(np.uint8)
    write_ply(path, voxels.positions, rgb,
              scalars={"count": voxels.counts, "coloured": voxels.coloured_counts})


def save_voxel_figure(path, voxels: VoxelCloud, sensor_positions=None, title: str = "") -> None:
    """PNG of the map (matplotlib, no OpenGL): top view, side view and a perspective view.

    Args:
        sensor_positions: optional (T, 3) world positions of the sensor head [m], drawn as a line.
    """
    from mitsonar.plots import _pyplot

    plt = _pyplot()
    pos = voxels.positions
    rgb = voxels.display_colours()
    traj = None if sensor_positions is None else np.asarray(sensor_positions, dtype=float).reshape(-1, 3)
    fig = plt.figure(figsize=(17, 5.6))
    ax_top = fig.add_subplot(1, 3, 1)
    ax_side = fig.add_subplot(1, 3, 2)
    ax_3d = fig.add_subplot(1, 3, 3, projection="3d")
    if len(pos) == 0:
        for ax in (ax_top, ax_side):
            ax.text(0.5, 0.5, "empty map", ha="center", va="center", transform=ax.transAxes)
    extent = np.ptp(pos, axis=0).max() if len(pos) else 1.0
    # Marker about one voxel wide: a panel is about 330 pt wide for the map's extent.
    size = np.clip((330.0 * voxels.settings.voxel_size / max(extent, 1e-9)) ** 2, 0.5, 60.0)
    views = [(ax_top, 0, 1, 2, "x [m]", "y [m]", "top view (highest voxel in front)"),
             (ax_side, 0, 2, 1, "x [m]", "z [m]", "side view, looking along +y (nearest in front)")]
    for ax, a, b, depth_axis, xl, yl, name in views:
        sign = 1.0 if depth_axis == 2 else -1.0  # draw far voxels first, near ones on top
        order = np.argsort(sign * pos[:, depth_axis], kind="stable")
        ax.scatter(pos[order, a], pos[order, b], c=rgb[order], s=size, marker="s", linewidths=0)
        if traj is not None and len(traj):
            ax.plot(traj[:, a], traj[:, b], "k-", lw=1.0, label="sensor path")
            ax.plot(traj[:1, a], traj[:1, b], "ko", ms=4)
            ax.legend(loc="best", fontsize=8)
        ax.set_xlabel(xl)
        ax.set_ylabel(yl)
        ax.set_title(name)
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(True, lw=0.3, alpha=0.5)
    if len(pos):
        ax_3d.scatter(pos[:, 0], pos[:, 1], pos[:, 2], c=rgb, s=size * 0.6, marker="s",
                      linewidths=0, depthshade=False)
        if traj is not None and len(traj):
            ax_3d.plot(traj[:, 0], traj[:, 1], traj[:, 2], "k-", lw=1.0)
        lo, hi = pos.min(axis=0), pos.max(axis=0)
        if traj is not None and len(traj):
            lo, hi = np.minimum(lo, traj.min(axis=0)), np.maximum(hi, traj.max(axis=0))
        span = np.maximum(hi - lo, voxels.settings.voxel_size)
        ax_3d.set_xlim(lo[0], lo[0] + span[0])
        ax_3d.set_ylim(lo[1], lo[1] + span[1])
        ax_3d.set_zlim(lo[2], lo[2] + span[2])
        ax_3d.set_box_aspect(tuple(span))  # equal scale on the three axes
    ax_3d.view_init(elev=30.0, azim=-60.0)  # degrees: plots only
    ax_3d.set_xlabel("x [m]")
    ax_3d.set_ylabel("y [m]")
    ax_3d.set_zlabel("z [m]")
    ax_3d.set_title("perspective")
    s = voxels.settings
    summary = (f"{len(voxels)} voxels of {s.voxel_size * 100:g} cm from {voxels.n_input} points, "
               f"{voxels.n_outliers} outliers removed, {voxels.n_uncoloured} voxels without "
               f"colour (grey)")
    fig.suptitle(f"{title}\n{summary}" if title else summary)
    fig.tight_layout()
    save_png(fig, path)
