"""Where surfel mode loses coverage: one drive of ``map_surfels_along`` per scene, then, per
camera frame and per kind of surface (walls, floor, ceiling, windows, other), what the camera
proposed, what the pings confirmed and what the map grew, against the ground truth.

Per frame (``surfel_coverage_frames.csv``): the pings fired, segments and candidate surfels
(triangles), the share of the field-of-view crop each kind of surface takes, the share of it
under a candidate triangle (proposed), under a registered one, and grown (a plane of the final
map back-projected there), and the share of the grown pixels within 2 cm of the true surface
along the camera ray; each candidate's fate: no echo (on how many of its four scan points),
verification (the centroid off the plane of the three others by more than
``verify_threshold``), spread (the outer echoes span less than ``min_spread`` of the aimed
triangle), registered, removed as a shadow line, refuted, and of the registered those whose
group claims no region (a lone surfel with a poorly determined normal).

Per scene and kind of surface (``surfel_coverage.csv``), over the ground-truth samples
observable along the drive (in line of sight of the sensor head once a second, as
``experiments/comparison.py`` counts them): the share within the sonar's field of view and
range and in line of sight of the camera in some frame (the most any map from these frames can
cover), inside a candidate triangle in some frame, inside a registered one, and within 2 cm of
the map (completeness); the map's points within 2 cm (accuracy) by the kind of their nearest
surface; and completeness of the maps built from the first frames only (does the map keep
what earlier frames registered).

    .venv/bin/python experiments/surfel_coverage.py --duration 8 --out out/surfel_coverage
    .venv/bin/python experiments/surfel_coverage.py --quick --out out/surfel_coverage  # ~1 min
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import mitsonar
from mitsonar.evaluation.coverage import covered_fraction
from mitsonar.evaluation.metrics import DEFAULT_THRESHOLD, point_to_mesh, visible_from
from mitsonar.io import write_table
from mitsonar.recon.surfels import SurfelSettings, map_surfels_along
from mitsonar.recon.surfels.map import build_map
from mitsonar.scene.mesh import sample_surface, scene_mesh
from mitsonar.sensors.camera import CameraRenderer
from mitsonar.sensors.trajectory import sensor_poses

SCENES = Path(__file__).resolve().parents[1] / "scenes"
KINDS = ("wall", "floor", "ceiling", "window", "other")
#: The ground truth counts as observable where the sensor head sees it at least once in this
#: many seconds of driving [s] (as in experiments/comparison.py).
VIEW_PERIOD = 1.0
#: A face is horizontal (floor, ceiling) or vertical (wall) within this many degrees.
LEVEL_TOLERANCE = np.radians(10.0)


def surface_kinds(mesh, height: float) -> np.ndarray:
    """(F,) index into :data:`KINDS` of every ground-truth triangle: glass is a window,
    horizontal faces within 5 cm of the floor or of the ceiling ``height`` [m] are floor or
    ceiling, vertical faces walls, the rest (furniture tops, slopes) other."""
    normal = mesh.triangle_normals()
    z = mesh.vertices[mesh.triangles][:, :, 2].mean(axis=1)
    level = np.abs(normal[:, 2]) > np.cos(LEVEL_TOLERANCE)
    upright = np.abs(normal[:, 2]) < np.sin(LEVEL_TOLERANCE)
    kind = np.full(len(z), KINDS.index("other"))
    kind[upright] = KINDS.index("wall")
    kind[level & (z < 0.05)] = KINDS.index("floor")
    kind[level & (z > height - 0.05)] = KINDS.index("ceiling")
    kind[mesh.triangle_transparent] = KINDS.index("window")
    return kind


def _triangle_mask(triangles, shape) -> np.ndarray:
    """(H, W) True inside any of the image triangles (k, 3, 2) [pixels]."""
    import cv2

    mask = np.zeros(shape, np.uint8)
    for t in np.asarray(triangles, dtype=float).reshape(-1, 3, 2):  # a few dozen
        cv2.fillPoly(mask, [np.round(t - 0.5).astype(np.int32)], 1)
    return mask > 0


def _grid_index(mesh, uv) -> tuple[np.ndarray, np.ndarray]:
    """Row and column (P,) of the growth grid cell nearest each pixel (P, 2), clipped."""
    g = mesh.grid_pixels
    u0, v0 = g[0, 0]
    step = (g[0, 1, 0] - u0) if g.shape[1] > 1 else 1.0
    col = np.clip(np.round((uv[:, 0] - u0) / step).astype(int), 0, g.shape[1] - 1)
    row = np.clip(np.round((uv[:, 1] - v0) / step).astype(int), 0, g.shape[0] - 1)
    return row, col


def _fates(surfel_map, p: int) -> dict:
    """Counts of what became of pose ``p``'s candidate surfels (module docstring)."""
    scan, settings = surfel_map.scans[p], surfel_map.settings
    missing = np.sum(~np.all(np.isfinite(scan.points_world), axis=-1), axis=1)
    heard = np.isfinite(scan.residual)
    verified = heard & (scan.residual <= settings.verify_threshold)
    removed = scan.on_segments(surfel_map.shadow[p])
    mine = surfel_map.surfel_pose == p
    registered = np.zeros(len(scan.accepted), bool)
    registered[surfel_map.surfel_index[mine]] = True
    claims = surfel_map.meshes[p].region_groups.sum(axis=0) > 0 if len(surfel_map.groups) \
        else np.zeros(0, bool)
    claiming = int(np.sum(claims[surfel_map.groups.label[mine]])) if np.any(mine) else 0
    out = {f"no_echo_{m}": int(np.sum(missing == m)) for m in range(1, 5)}
    out.update(verification=int(np.sum(heard & ~verified)),
               spread=int(np.sum(verified & ~scan.accepted)),
               shadow=int(np.sum(scan.accepted & removed)),
               refuted=int(np.sum(scan.accepted & ~removed & ~registered)),
               registered=int(registered.sum()), claiming=claiming)
    return out


def frame_rows(scene_name, surfel_map, renderer, kind_of_shape) -> tuple[list, list]:
    """Per-frame rows and, per frame, the pixel masks (proposed, registered) for the samples."""
    rows, masks = [], []
    for p, (scan, mesh) in enumerate(zip(surfel_map.scans, surfel_map.meshes)):
        cam = scan.camera
        depth, shape = renderer.ground_truth(cam.world_from_camera(scan.pose))
        kind = np.where(shape >= 0, kind_of_shape[np.maximum(shape, 0)], -1)
        u0, v0, u1, v1 = scan.box
        crop = np.zeros(kind.shape, bool)
        crop[v0:v1, u0:u1] = True
        proposed = _triangle_mask(scan.triangles, kind.shape) & crop
        mine = surfel_map.surfel_pose == p
        registered = _triangle_mask(scan.triangles[surfel_map.surfel_index[mine]], kind.shape) \
            & crop
        masks.append((proposed, registered))
        grid = np.floor(mesh.grid_pixels).astype(int)
        grown = mesh.grid_plane >= 0
        grid_kind = kind[grid[..., 1], grid[..., 0]]
        z_grown = cam.world_from_camera(scan.pose).inverse().transform_points(
            mesh.grid_points.reshape(-1, 3))[:, 2].reshape(grown.shape)
        z_true = depth[grid[..., 1], grid[..., 0]]
        ray = np.linalg.norm(np.concatenate([(mesh.grid_pixels - cam.principal_point)
                                             / cam.focal_pixels,
                                             np.ones(grown.shape + (1,))], axis=-1), axis=-1)
        good = grown & (np.abs(z_grown - z_true) * ray <= DEFAULT_THRESHOLD)
        row = {"scene": scene_name, "frame": p,
               "time_s": float(surfel_map.times[p]) if len(surfel_map.times) else float(p),
               "pings": scan.pings, "segments": len(scan.segments),
               "candidates": len(scan.triangles), **_fates(surfel_map, p),
               "proposed_pct": 100.0 * proposed.sum() / crop.sum()}
        for k, name in enumerate(KINDS):
            here = crop & (kind == k)
            cells = grid_kind == k
            row[f"{name}_crop_pct"] = 100.0 * here.sum() / crop.sum()
            row[f"{name}_proposed_pct"] = 100.0 * (proposed & here).sum() / max(here.sum(), 1)
            row[f"{name}_registered_pct"] = 100.0 * (registered & here).sum() / max(here.sum(), 1)
            row[f"{name}_grown_pct"] = 100.0 * (grown & cells).sum() / max(cells.sum(), 1)
            row[f"{name}_grown_ok_pct"] = 100.0 * (good & cells).sum() / max((grown & cells).sum(),
                                                                              1)
        rows.append(row)
    return rows, masks


def sample_funnel(scene, surfel_map, samples, observable, masks, max_range: float) -> tuple:
    """(M,) bool per observable sample: in some frame's field-of-view crop within ``max_range``
    [m] and in the camera's line of sight (reachable), inside a candidate triangle there
    (proposed), inside a registered one (registered)."""
    points = samples.points[observable]
    reach, proposed, registered = (np.zeros(len(points), bool) for _ in range(3))
    for scan, (prop, reg) in zip(surfel_map.scans, masks):
        cam = scan.camera
        pose = cam.world_from_camera(scan.pose)
        local = pose.inverse().transform_points(points)
        front = local[:, 2] > 1e-3
        uv = np.full((len(points), 2), -1.0)
        uv[front] = cam.project(local[front])
        u0, v0, u1, v1 = scan.box
        inside = front & (uv[:, 0] >= u0) & (uv[:, 0] < u1) & (uv[:, 1] >= v0) & (uv[:, 1] < v1)
        inside &= np.linalg.norm(points - scan.pose.translation, axis=1) <= max_range
        rows = np.nonzero(inside)[0]
        seen = visible_from(scene, points[rows], pose.translation[None])
        rows = rows[seen]
        iu, iv = np.floor(uv[rows]).astype(int).T
        reach[rows] = True
        proposed[rows] |= prop[iv, iu]
        registered[rows] |= reg[iv, iu]
    return reach, proposed, registered


def run_scene(name: str, path: Path, args) -> tuple[list, list, str]:
    """(per-frame rows, per-kind rows, a summary line) of one scene's drive."""
    scene = mitsonar.load_scene(path)
    trajectory = mitsonar.Trajectory.from_scene(path)
    sonar = mitsonar.Sonar(scene, mitsonar.SonarConfig.preset(args.preset))
    settings = SurfelSettings(image_width=args.width, spp=args.spp, seed=args.seed,
                              region_surfels=args.region_surfels)
    duration = min(args.duration, trajectory.duration)
    start = time.perf_counter()
    surfel_map = map_surfels_along(sonar, trajectory, settings, duration)
    seconds = time.perf_counter() - start
    mesh = scene_mesh(scene)
    height = float(np.max(mesh.vertices[:, 2]))
    kind = surface_kinds(mesh, height)
    kind_of_shape = np.full(len(mesh.shape_ids), KINDS.index("other"))
    kind_of_shape[mesh.triangle_shape] = kind
    renderer = CameraRenderer(scene, surfel_map.scans[0].camera)
    frames, masks = frame_rows(name, surfel_map, renderer, kind_of_shape)
    driven = trajectory.driven(duration)
    samples = sample_surface(mesh, args.spacing, args.seed)
    views = trajectory.poses_at(np.arange(0.0, driven + 1e-9, VIEW_PERIOD))
    observable = visible_from(scene, samples.points,
                              np.array([p.translation for p in sensor_poses(views)]))
    reach, proposed, registered = sample_funnel(scene, surfel_map, samples, observable, masks,
                                                sonar.config.max_range)
    points = surfel_map.sample(0.01, seed=args.seed)[0] if len(surfel_map.triangles) \
        else np.zeros((0, 3))
    truth = samples.points[observable]
    gap = np.full(len(truth), np.inf)
    if len(points):
        from scipy.spatial import cKDTree

        gap = cKDTree(points).query(truth, distance_upper_bound=DEFAULT_THRESHOLD)[0]
    covered = gap <= DEFAULT_THRESHOLD
    distance, _, nearest, _ = point_to_mesh(points, mesh)
    sample_kind = kind[samples.triangle[observable]]
    rows = []
    for k, kname in enumerate(["all", *KINDS]):
        sel = np.ones(len(truth), bool) if kname == "all" else sample_kind == k - 1
        near = np.ones(len(points), bool) if kname == "all" else kind[nearest] == k - 1
        if not sel.any() and not near.any():
            continue
        rows.append({"scene": name, "kind": kname, "observable_m2": sel.sum() * args.spacing ** 2,
                     "reachable_pct": 100.0 * np.mean(reach[sel]) if sel.any() else np.nan,
                     "proposed_pct": 100.0 * np.mean(proposed[sel]) if sel.any() else np.nan,
                     "registered_pct": 100.0 * np.mean(registered[sel]) if sel.any() else np.nan,
                     "complete_pct": 100.0 * np.mean(covered[sel]) if sel.any() else np.nan,
                     "map_points": int(near.sum()),
                     "accuracy_pct": 100.0 * np.mean(distance[near] <= DEFAULT_THRESHOLD)
                     if near.any() else np.nan})
    growth = []
    for count in np.unique(np.linspace(1, len(surfel_map.scans), 4).round().astype(int)):
        early = build_map(surfel_map.scans[:count], surfel_map.settings)
        cloud = early.sample(0.01, seed=args.seed)[0] if len(early.triangles) \
            else np.zeros((0, 3))
        share = covered_fraction(cloud, truth, DEFAULT_THRESHOLD)
        growth.append(f"{count} frames {100 * share:.1f}")
    line = (f"{name}: {driven:.1f} s driven, {len(surfel_map.scans)} frames, "
            f"{sum(s.pings for s in surfel_map.scans)} pings, {seconds:.0f} s; "
            f"{len(surfel_map.surfel_pose)} surfels registered, {len(surfel_map.groups)} planes; "
            f"completeness of the first frames' maps: {', '.join(growth)} %")
    return frames, rows, line


def parse_args(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/surfel_coverage"))
    parser.add_argument("--preset", default="paper", choices=("default", "paper"))
    parser.add_argument("--scenes", default="room_glass,structure", help="shipped scenes, a,b")
    parser.add_argument("--duration", type=float, default=8.0,
                        help="seconds of each scene's default trajectory driven, at most all of it "
                             "(default 8)")
    parser.add_argument("--width", type=int, default=800, help="camera image width [pixels]")
    parser.add_argument("--spp", type=int, default=8, help="camera samples per pixel")
    parser.add_argument("--spacing", type=float, default=0.02,
                        help="ground-truth sample spacing [m] (default 0.02)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--region-surfels", action="store_true",
                        help="also region surfels (SurfelSettings.region_surfels)")
    parser.add_argument("--quick", action="store_true",
                        help="room_glass's first 0.3 s, 320 px, 4 spp, 5 cm samples")
    args = parser.parse_args(argv)
    if args.quick:
        args.scenes, args.duration, args.width, args.spp, args.spacing = \
            "room_glass", 0.3, 320, 4, 0.05
    for option, value in (("--duration", args.duration), ("--spacing", args.spacing),
                          ("--width", args.width), ("--spp", args.spp)):
        if value <= 0:
            parser.error(f"{option} must be > 0, got {value}")
    return args


def main(argv=None) -> int:
    args = parse_args(argv)
    names = args.scenes.split(",")
    missing = [n for n in names if not (SCENES / n / "scene.xml").exists()]
    if missing:
        print(f"error: --scenes: no shipped scene {', '.join(missing)}", file=sys.stderr)
        return 2
    frames, kinds, lines = [], [], []
    for name in names:
        f, k, line = run_scene(name, SCENES / name / "scene.xml", args)
        frames += f
        kinds += k
        lines.append(line)
        print(line, file=sys.stderr)
    args.out.mkdir(parents=True, exist_ok=True)
    write_table(args.out / "surfel_coverage_frames.csv", frames)
    md = ["| scene | surface | observable m^2 | in view % | proposed % | registered % | "
          "complete % | map points | within 2 cm % |",
          "|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    md += [f"| {r['scene']} | {r['kind']} | {r['observable_m2']:.1f} | {r['reachable_pct']:.1f} | "
           f"{r['proposed_pct']:.1f} | {r['registered_pct']:.1f} | {r['complete_pct']:.1f} | "
           f"{r['map_points']} | {r['accuracy_pct']:.1f} |" for r in kinds]
    md += [""] + lines
    write_table(args.out / "surfel_coverage.csv", kinds, md)
    print("\n".join(md))
    return 0


if __name__ == "__main__":
    sys.exit(main())
