"""``mitsonar evaluate``: score a point cloud against a scene's ground truth."""

from __future__ import annotations

import csv
import sys
from pathlib import Path

from mitsonar.cli.arguments import output_directory, scene_path
from mitsonar.io import atomic_path, write_json
from mitsonar.evaluation.metrics import DEFAULT_THRESHOLD, evaluate, read_points, save_error_figure
from mitsonar.validation import check_positive


def add_cli(subparsers) -> None:
    """``mitsonar evaluate``."""
    e = subparsers.add_parser(
        "evaluate", help="score a reconstructed point cloud against the scene's ground truth",
        description="Accuracy, completeness, F-score and consistency of a PLY point cloud "
                    "against the scene's surfaces, overall, per optical class and per material. "
                    "Writes metrics.json, metrics.csv and errors.png.")
    e.add_argument("recon", type=Path, help="reconstructed point cloud (PLY, world frame, metres)")
    e.add_argument("scene", type=scene_path,
                   help="Mitsuba XML scene it was reconstructed from, or a shipped scene's name")
    e.add_argument("--threshold", type=float, default=DEFAULT_THRESHOLD,
                   help="distance within which a point is accurate and a ground-truth sample "
                        f"is covered [m] (default {DEFAULT_THRESHOLD:g})")
    e.add_argument("--spacing", type=float, default=0.01,
                   help="ground-truth sample spacing [m] (default 0.01: one per cm^2)")
    e.add_argument("--seed", type=int, default=0,
                   help="seed of the ground-truth samples (default 0)")
    e.add_argument("--out", type=output_directory, default=None,
                   help="output directory, created if absent (default: <RECON name>_metrics "
                        "beside RECON)")
    e.set_defaults(func=_run_evaluate)


def _run_evaluate(args) -> int:
    from mitsonar.scene.loading import load_scene
    from mitsonar.scene.mesh import scene_mesh

    out = args.out or output_directory(args.recon.parent / f"{args.recon.stem}_metrics")
    check_positive("--threshold [m]", args.threshold)
    check_positive("--spacing [m]", args.spacing)
    points = read_points(args.recon)
    mesh = scene_mesh(load_scene(args.scene))
    print(f"Scoring {len(points)} points against {len(mesh.triangles)} triangles "
          f"({mesh.triangle_areas().sum():.1f} m^2) ...", file=sys.stderr)
    result = evaluate(points, mesh, args.threshold, spacing=args.spacing, seed=args.seed)
    write_json(out / "metrics.json", {"recon": str(args.recon), "scene": str(args.scene),
                                      "spacing_m": args.spacing, "seed": args.seed,
                                      **result.to_dict()})
    rows = result.table_rows()
    with atomic_path(out / "metrics.csv") as tmp:
        with open(tmp, "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
    save_error_figure(out / "errors.png", points, result.distance, args.threshold,
                      title=f"{args.recon.name} vs {args.scene.parent.name}/{args.scene.name}")
    print(result.markdown())
    print(f"Wrote {out}/metrics.json, metrics.csv and errors.png (points coloured by distance).")
    return 0
