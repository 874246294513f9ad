"""``mitsonar scan``: a grid of beams from one robot pose."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from mitsonar.cli.arguments import (add_output_argument, add_preset_argument, add_scene_argument,
                                    add_shared_hits_argument, parse_fov, parse_pose)


def add_cli(subparsers) -> None:
    """``mitsonar scan``."""
    p = subparsers.add_parser(
        "scan", help="scan a grid of beam directions from one robot pose",
        description="Ping every direction of a grid over the field of view from one robot pose; "
                    "write the point cloud (PLY), the echoes (NPZ), a summary (JSON) and a "
                    "picture (PNG).")
    add_scene_argument(p)
    p.add_argument("--pose", type=parse_pose, default=(0.0, 0.0, 0.0),
                   help="robot pose 'x,y,yaw': metres, metres, degrees (default 0,0,0)")
    p.add_argument("--fov", type=parse_fov, default=None,
                   help="scanned field of view 'HxV' [deg] (default: the array's, 60x40)")
    p.add_argument("--step", type=float, default=5.0, help="beam grid step [deg] (default 5)")
    add_preset_argument(p)
    p.add_argument("--config", type=Path, default=None,
                   help="TOML sonar configuration file, overriding --preset (default: none)")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the noise and the diffuse phases (default 0)")
    add_shared_hits_argument(p)
    add_output_argument(p)
    p.set_defaults(func=_run_scan)


def _run_scan(args) -> int:
    from tqdm import tqdm

    from mitsonar import Pose, Sonar, SonarConfig
    from mitsonar.frames import fov_angles
    from mitsonar.io import write_json, write_npz, write_ply
    from mitsonar.plots import save_scan_figure

    config = SonarConfig.from_toml(args.config) if args.config else SonarConfig.preset(args.preset)
    if args.step <= 0 or not np.isfinite(args.step):
        raise ValueError(f"--step must be > 0 degrees, got {args.step}")
    t0 = time.perf_counter()
    sonar = Sonar(args.scene, config)
    x, y, yaw = args.pose
    pose = Pose.sensor_on_robot(x, y, yaw)
    dirs = sonar.fov_grid(np.radians(args.step))
    if args.fov is not None:
        h, v = fov_angles(dirs)
        keep = (np.abs(h) <= args.fov[0] / 2 + 1e-9) & (np.abs(v) <= args.fov[1] / 2 + 1e-9)
        config.geometry.check_in_fov(
            np.array([[np.tan(args.fov[0] / 2), np.tan(args.fov[1] / 2), 1.0]]))
        dirs = dirs[keep]
    load_time = time.perf_counter() - t0
    with tqdm(total=len(dirs), desc="beams", unit="beam", file=sys.stderr) as bar:
        scan = sonar.scan(pose, dirs, seed=args.seed, progress=lambda _: bar.update(),
                          shared_hits=args.shared_hits)
    scan_time = time.perf_counter() - t0 - load_time
    out = args.out
    write_ply(out / "points.ply", scan.points_world, scalars={"amplitude": scan.amplitude[scan.detected]})
    write_npz(out / "echoes.npz", **scan.arrays(), world_from_sensor=pose.matrix(),
              tx_positions=config.geometry.tx_positions, rx_positions=config.geometry.rx_positions)
    save_scan_figure(out / "scan.png", scan, title=f"{args.scene.name}, robot at "
                     f"({x:.2f} m, {y:.2f} m, {np.degrees(yaw):.0f} deg)")
    depth = scan.depth[scan.detected]
    summary = {
        "scene": str(args.scene), "robot_pose": {"x_m": x, "y_m": y, "yaw_deg": float(np.degrees(yaw))},
        "beams": int(len(dirs)), "detected": int(scan.detected.sum()),
        "shared_hits": bool(args.shared_hits and sonar.tracer.shares_hits()),
        "depth_m": {"min": float(depth.min()), "median": float(np.median(depth)),
                    "max": float(depth.max())} if len(depth) else None,
        "seconds": {"load": round(load_time, 3), "scan": round(scan_time, 3),
                    "per_beam": round(scan_time / max(len(dirs), 1), 4)},
        "files": {"points": "points.ply (world frame, detected beams, amplitude in Pa)",
                  "echoes": "echoes.npz (format: docs/datasets.md)",
                  "picture": "scan.png (depth and echo amplitude over the field of view)"},
    }
    write_json(out / "summary.json", summary)
    print(f"{summary['detected']}/{summary['beams']} beams detected an echo "
          f"in {scan_time:.1f} s ({summary['seconds']['per_beam'] * 1000:.0f} ms per beam).")
    if len(depth):
        print(f"Depths {depth.min():.2f}-{depth.max():.2f} m (median {np.median(depth):.2f} m).")
    print(f"Wrote {out}/points.ply, echoes.npz, summary.json and scan.png "
          "(depth and echo amplitude over the field of view).")
    return 0


