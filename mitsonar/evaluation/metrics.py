"""Scoring a reconstructed point cloud against the scene's ground-truth mesh (paper section IV).

The paper samples the scene models at 1 cm into a ground-truth cloud and reads CloudCompare's
point-to-point distances. Here:

* Accuracy uses the exact point-to-*mesh* distance of every reconstructed point (Open3D's
  ``RaycastingScene``), so no sampling error enters it. Reported: the fraction within the
  threshold (the paper's "90 % of the points' distance error is less than 2 cm"), and the mean,
  median and 90th percentile distance.
* Completeness is the fraction of ground-truth samples that have a reconstructed point within
  the threshold. The samples (:func:`~mitsonar.scene.mesh.sample_surface`) are drawn uniformly by area at one per ``spacing``^2 (1 cm: one per
  cm^2): each triangle gets floor(A/s^2 + u) samples (u uniform in [0, 1), so the expected count
  is exact) placed uniformly at random inside it. Stratifying by triangle keeps the count per
  surface nearly exact; the binomial error of a completeness measured over a surface of area A
  is at most 0.5 s / sqrt(A) (0.5 % for 1 m^2 at 1 cm). Only *observable* samples count when a
  mask is given (e.g. :func:`visible_from` the trajectory).
* F-score at the threshold, as in Tanks and Temples: 2 P R / (P + R) with precision P = accuracy
  fraction and recall R = completeness.
* Consistency, see :func:`error_jumps`.

Every figure is also given per acoustic material (reconstructed points by the material of their
nearest triangle, ground-truth samples by their own) and per optical class (``opaque`` /
``transparent``: glass separately).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from mitsonar.scene.rays import rays
from mitsonar.plots import save_png
from mitsonar.scene.loading import AcousticScene
from mitsonar.scene.mesh import SceneMesh, SurfaceSamples, sample_surface
from mitsonar.validation import check_finite, check_positive

#: The paper's accuracy threshold [m].
DEFAULT_THRESHOLD = 0.02
#: Neighbours of a point are on the same surface when their triangle normals differ by less.
SAME_SURFACE_ANGLE = np.radians(30.0)


def point_to_mesh(points, mesh: SceneMesh):
    """Closest points on the mesh of points (N, 3) [m].

    Returns:
        distance (N,) [m]; signed (N,) [m], negative behind the nearest triangle (against its
        normal); triangle (N,) index of the nearest triangle; foot (N, 3) the closest points [m].
    """
    from mitsonar._native import import_open3d

    o3d = import_open3d()
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    if len(p) == 0:
        return np.zeros(0), np.zeros(0), np.zeros(0, dtype=np.int64), np.zeros((0, 3))
    raycast = o3d.t.geometry.RaycastingScene()
    raycast.add_triangles(o3d.core.Tensor(mesh.vertices.astype(np.float32)),
                          o3d.core.Tensor(mesh.triangles.astype(np.uint32)))
    ans = raycast.compute_closest_points(o3d.core.Tensor(p.astype(np.float32)))
    foot = ans["points"].numpy().astype(float)
    tri = ans["primitive_ids"].numpy().astype(np.int64)
    offset = p - foot
    distance = np.linalg.norm(offset, axis=1)
    side = np.einsum("ij,ij->i", offset, mesh.triangle_normals()[tri])
    return distance, np.where(side < 0, -distance, distance), tri, foot


def error_jumps(foot, signed_error, normals, radius: float = 0.05, neighbours: int = 8,
                block: int = 200_000) -> np.ndarray:
    """Consistency: how abruptly the error changes between neighbouring points.

    For every point i, the mean of |e_i - e_j| [m] over its up to ``neighbours`` nearest points
    j on the same surface. Neighbours are searched among the points' feet on the ground truth
    (their closest surface points) within ``radius`` [m], so points of different frames that
    cover the same spot are neighbours however far apart their errors put them; "same surface"
    means the normals of their nearest triangles are within 30 deg, so the signed errors share
    a reference. NaN for points without such a neighbour.

    Why this measures the paper's "continuity of colour changes": the paper colours each point
    by its error, and a depth camera registered frame by frame with wheel odometry lays frames
    with different pose errors over and beside each other, so neighbouring points carry
    different errors (abrupt colour changes) even where each frame alone is accurate. A point on
    a seam where two patches disagree by D gets D times the share of its neighbours across the
    seam; points of two interleaved frames D apart get about D / 2. A reconstruction that is off
    by a smoothly varying amount (one global pose error, a globally optimised surfel map)
    changes colour gradually: its jumps are ~0 however large the error itself. Independent
    per-point noise of standard deviation sigma gives 2 sigma / sqrt(pi) = 1.13 sigma. The
    scores report the mean jump (seams count even where they are a minority of the points) and
    its 90th percentile.

    Args:
        foot: (N, 3) closest ground-truth points [m]; signed_error: (N,) [m]; normals: (N, 3)
            unit normals of the nearest triangles. ``block`` points are processed at a time.
    """
    from scipy.spatial import cKDTree

    f = np.asarray(foot, dtype=float)
    e = np.asarray(signed_error, dtype=float)
    n = len(f)
    out = np.full(n, np.nan)
    if n < 2:
        return out
    tree = cKDTree(f)
    min_cos = np.cos(SAME_SURFACE_ANGLE)
    for start in range(0, n, block):  # blocks of points bound the (block, k, 3) temporaries
        rows = np.arange(start, min(start + block, n))
        dist, idx = tree.query(f[rows], k=neighbours + 1, distance_upper_bound=radius)
        j = np.minimum(idx, n - 1)
        ok = np.isfinite(dist) & (idx != rows[:, None])
        ok &= np.einsum("ikc,ic->ik", normals[j], normals[rows]) >= min_cos
        count = ok.sum(axis=1)
        total = np.where(ok, np.abs(e[j] - e[rows, None]), 0.0).sum(axis=1)
        has = count > 0
        out[rows[has]] = total[has] / count[has]
    return out


def visible_from(scene: AcousticScene, points, viewpoints, max_range: float = np.inf) -> np.ndarray:
    """(M,) True where a surface point (M, 3) [m] is seen from at least one viewpoint (V, 3)
    [m]: within ``max_range`` [m] and nothing in between (every surface occludes, glass too).
    The sight line stops 1 mm short of the point so its own surface does not hide it."""
    import drjit as dr

    p = np.asarray(points, dtype=float).reshape(-1, 3)
    views = np.asarray(viewpoints, dtype=float).reshape(-1, 3)
    check_finite("viewpoints [m]", views)
    seen = np.zeros(len(p), dtype=bool)
    for v in views:  # one vectorised batch of sight lines per viewpoint
        todo = np.flatnonzero(~seen)
        w = p[todo] - v
        dist = np.linalg.norm(w, axis=1)
        near = (dist <= max_range) & (dist > 2e-3)
        todo, w, dist = todo[near], w[near], dist[near]
        if len(todo) == 0:  # Dr.Jit aborts on empty rays
            continue
        d = w / dist[:, None]
        blocked = scene.scene.ray_test(rays(v, d, dist - 1e-3))
        dr.eval(blocked)
        seen[todo] = ~np.asarray(blocked, dtype=bool)
    return seen


def _stat(func, values) -> float:
    return float(func(values)) if len(values) else float("nan")


@dataclass(frozen=True)
class Scores:
    """The figures of one group of points and samples (NaN where the group has none).

    Attributes:
        points: reconstructed points in the group.
        samples: observable ground-truth samples in the group.
        accuracy: fraction of the points within the threshold (precision).
        completeness: fraction of the samples with a point within the threshold (recall).
        fscore: 2 P R / (P + R) (0 when both are 0).
        mean_distance, median_distance, p90_distance: point-to-mesh distances [m].
        consistency: mean error jump between neighbouring points [m] (:func:`error_jumps`).
        consistency_p90: its 90th percentile [m].
    """

    points: int
    samples: int
    accuracy: float
    completeness: float
    fscore: float
    mean_distance: float
    median_distance: float
    p90_distance: float
    consistency: float
    consistency_p90: float

    @classmethod
    def of(cls, distance, jumps, covered, threshold: float) -> "Scores":
        """From point distances (n,) [m], their error jumps (n,) [m] (NaN: none) and the
        samples' covered flags (m,)."""
        p = _stat(np.mean, distance <= threshold)
        r = _stat(np.mean, covered)
        f = 2 * p * r / (p + r) if p + r > 0 else (0.0 if p + r == 0 else float("nan"))
        j = jumps[np.isfinite(jumps)]
        return cls(len(distance), len(covered), p, r, f, _stat(np.mean, distance),
                   _stat(np.median, distance), _stat(lambda x: np.percentile(x, 90), distance),
                   _stat(np.mean, j), _stat(lambda x: np.percentile(x, 90), j))

    def to_dict(self) -> dict:
        """Plain JSON values, units in the keys; NaN becomes None."""
        units = {"mean_distance": "mean_distance_m", "median_distance": "median_distance_m",
                 "p90_distance": "p90_distance_m", "consistency": "consistency_m",
                 "consistency_p90": "consistency_p90_m"}
        return {units.get(k, k): (None if isinstance(v, float) and np.isnan(v) else v)
                for k, v in asdict(self).items()}


@dataclass(frozen=True)
class Evaluation:
    """Scores of a reconstruction, overall and per group.

    Attributes:
        threshold: distance threshold [m].
        overall: all points and samples.
        per_material: acoustic material name -> scores.
        per_optics: 'opaque' and 'transparent' (glass) -> scores.
        transparent_materials: names of the materials on optically transparent shapes.
        distance: (N,) point-to-mesh distance of every reconstructed point [m].
        jumps: (N,) error jump of every point [m] (NaN: no same-surface neighbour).
    """

    threshold: float
    overall: Scores
    per_material: dict
    per_optics: dict
    transparent_materials: list
    distance: np.ndarray = field(repr=False)
    jumps: np.ndarray = field(repr=False)

    def table_rows(self) -> list[dict]:
        """One row a group ('all', 'optics:<class>', 'material:<name>'), columns of
        :meth:`Scores.to_dict`."""
        groups = [("all", self.overall)]
        groups += [(f"optics:{k}", v) for k, v in self.per_optics.items()]
        groups += [(f"material:{k}", v) for k, v in self.per_material.items()]
        return [{"group": g, **s.to_dict()} for g, s in groups]

    def to_dict(self) -> dict:
        return {"threshold_m": self.threshold, "overall": self.overall.to_dict(),
                "per_optics": {k: v.to_dict() for k, v in self.per_optics.items()},
                "per_material": {k: v.to_dict() for k, v in self.per_material.items()},
                "transparent_materials": list(self.transparent_materials)}

    def markdown(self) -> str:
        """The table for people: fractions in %, distances in cm."""
        head = ("| group | points | samples | accuracy % | completeness % | F-score % | "
                "mean cm | median cm | p90 cm | consistency cm |")
        lines = [head, "|" + "---|" * 10]
        for g, s in [("all", self.overall)] + [(k, v) for k, v in self.per_optics.items()] \
                + [(k, v) for k, v in self.per_material.items()]:
            pct = [f"{100 * x:.1f}" if np.isfinite(x) else "-" for x in
                   (s.accuracy, s.completeness, s.fscore)]
            cm = [f"{100 * x:.2f}" if np.isfinite(x) else "-" for x in
                  (s.mean_distance, s.median_distance, s.p90_distance, s.consistency)]
            lines.append(f"| {g} | {s.points} | {s.samples} | " + " | ".join(pct + cm) + " |")
        return "\n".join(lines)


def evaluate(points, mesh: SceneMesh, threshold: float = DEFAULT_THRESHOLD,
             samples: SurfaceSamples | None = None, observable=None, spacing: float = 0.01,
             seed: int = 0, consistency_radius: float = 0.05) -> Evaluation:
    """Score a reconstruction against the ground-truth mesh.

    Args:
        points: (N, 3) reconstructed points [m], world frame.
        mesh: the ground truth (:func:`mitsonar.scene.mesh.scene_mesh`).
        threshold: distance within which a point is accurate and a sample covered [m].
        samples: ground-truth samples; by default :func:`sample_surface` (``spacing`` [m],
            ``seed``).
        observable: optional (M,) boolean mask of the samples that count for completeness.
        consistency_radius: neighbourhood radius of :func:`error_jumps` [m].
    """
    from scipy.spatial import cKDTree

    check_positive("threshold [m]", threshold)
    check_positive("consistency_radius [m]", consistency_radius)
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"reconstructed points must be (N, 3), got shape {p.shape}")
    check_finite("reconstructed points [m]", p)
    if samples is None:
        samples = sample_surface(mesh, spacing, seed)
    if observable is not None:
        samples = samples.subset(observable)
    distance, signed, tri, foot = point_to_mesh(p, mesh)
    jumps = error_jumps(foot, signed, mesh.triangle_normals()[tri], consistency_radius)
    if len(p):
        gap, _ = cKDTree(p).query(samples.points, distance_upper_bound=threshold)
        covered = gap <= threshold
    else:
        covered = np.zeros(len(samples.points), dtype=bool)

    def scores(point_mask, sample_mask):
        return Scores.of(distance[point_mask], jumps[point_mask], covered[sample_mask], threshold)

    names = np.array([m.name for m in mesh.materials], dtype=object)
    tri_names = names[mesh.triangle_material]
    point_names, sample_names = tri_names[tri], tri_names[samples.triangle]
    per_material = {str(k): scores(point_names == k, sample_names == k)
                    for k in sorted(set(point_names) | set(sample_names))}
    point_glass = mesh.triangle_transparent[tri]
    sample_glass = mesh.triangle_transparent[samples.triangle]
    per_optics = {"opaque": scores(~point_glass, ~sample_glass),
                  "transparent": scores(point_glass, sample_glass)}
    glass = sorted({str(n) for n in tri_names[mesh.triangle_transparent]})
    return Evaluation(threshold, scores(slice(None), slice(None)), per_material, per_optics,
                      glass, distance, jumps)


def read_points(path) -> np.ndarray:
    """(N, 3) points [m] of a PLY point cloud; ValueError naming the file if it has none."""
    from mitsonar._native import import_open3d

    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path}: point cloud file not found")
    o3d = import_open3d()
    pts = np.asarray(o3d.io.read_point_cloud(str(path), format="ply").points, dtype=float)
    if len(pts) == 0:
        raise ValueError(f"{path}: no points read (empty or not a PLY point cloud)")
    if not np.all(np.isfinite(pts)):
        raise ValueError(f"{path}: {int(np.sum(~np.isfinite(pts).all(axis=1)))} points are not finite")
    return pts


def save_error_figure(path, points, distance, threshold: float, title: str = "",
                      max_points: int = 150_000) -> None:
    """PNG of the points coloured by their distance to the ground truth [m]: top view,
    perspective view, and the cumulative distribution of the distances."""
    from mitsonar.plots import _pyplot

    plt = _pyplot()
    p = np.asarray(points, dtype=float)
    d = np.asarray(distance, dtype=float)
    if len(p) > max_points:  # a fixed subset keeps the figure quick to draw and deterministic
        keep = np.sort(np.random.default_rng(0).choice(len(p), max_points, replace=False))
        p, d = p[keep], d[keep]
    vmax = 5 * threshold
    fig = plt.figure(figsize=(18.5, 5.8))
    ax_top = fig.add_subplot(1, 3, 1)
    ax_3d = fig.add_subplot(1, 3, 2, projection="3d")
    ax_cdf = fig.add_subplot(1, 3, 3)
    order = np.argsort(p[:, 2], kind="stable")  # highest points drawn last in the top view
    style = dict(c=100 * d[order], cmap="turbo", vmin=0.0, vmax=100 * vmax, s=1.5, linewidths=0)
    im = ax_top.scatter(p[order, 0], p[order, 1], **style)
    ax_top.set_aspect("equal", adjustable="datalim")
    ax_top.set_xlabel("x [m]")
    ax_top.set_ylabel("y [m]")
    ax_top.set_title("top view")
    ax_3d.scatter(p[order, 0], p[order, 1], p[order, 2], depthshade=False, **style)
    ax_3d.set_xlabel("x [m]")
    ax_3d.set_ylabel("y [m]")
    ax_3d.set_zlabel("z [m]")
    ax_3d.set_title("perspective")
    fig.colorbar(im, ax=[ax_top, ax_3d], orientation="horizontal", fraction=0.05, pad=0.12,
                 label=f"distance to ground truth [cm] (clipped at {100 * vmax:.0f})")
    if len(d):
        xs = np.sort(d)
        ax_cdf.plot(100 * xs, 100 * np.arange(1, len(xs) + 1) / len(xs), "k-")
    ax_cdf.axvline(100 * threshold, color="r", ls="--",
                   label=f"{100 * threshold:.0f} cm: {100 * np.mean(d <= threshold):.1f} % of points"
                   if len(d) else f"{100 * threshold:.0f} cm")
    ax_cdf.set_xlim(0, 100 * vmax)
    ax_cdf.set_ylim(0, 100)
    ax_cdf.set_xlabel("distance to ground truth [cm]")
    ax_cdf.set_ylabel("points within [%]")
    ax_cdf.set_title("cumulative distribution")
    ax_cdf.grid(True, lw=0.3, alpha=0.5)
    ax_cdf.legend(loc="lower right")
    if title:
        fig.suptitle(title)
    save_png(fig, path)
