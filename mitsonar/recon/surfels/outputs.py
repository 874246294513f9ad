"""Outputs of a surfel map: plane colours, the JSON-ready summary (:func:`summary`), the figure
(:func:`save_surfel_figure`) and the files :func:`save_surfel_map` writes (PLY mesh and samples,
JSON, PNG)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mitsonar.recon.surfels.map import SurfelMap
from mitsonar.recon.surfels.planes import _on_planes
from mitsonar.recon.surfels.scanning import tone_map

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
    from mitsonar.io import write_json, write_ply

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
