"""Speed against accuracy of the fidelity presets (mitsonar.evaluation.fidelity) on the shipped scenes.

For each scene, the beams of a field-of-view grid are pinged from a few poses along the scene's
trajectory at every preset (plus the paper's 25-reflector model). Accuracy is the depth
difference to the ``fine`` preset on beams both detect (median, 90th percentile) and the
fraction of beams whose detection decision differs; and, against the ground truth, the distance
of the detected points to the scene's true surfaces (median, 90th percentile). Speed is wall-clock
time per ping. Writes a CSV + Markdown table and the chart (time per ping against both).

    .venv/bin/python experiments/speed_accuracy.py --out out/speed_accuracy           # ~10 min
    .venv/bin/python experiments/speed_accuracy.py --quick --out out/speed_accuracy   # ~1 min
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import mitsonar
from mitsonar.evaluation.fidelity import PRESETS, FidelityRun, ping_at
from mitsonar.io import write_table
from mitsonar.plots import _pyplot, save_png
from mitsonar.scene.loading import load_scene
from mitsonar.scene.mesh import scene_mesh
from mitsonar.sensors.trajectory import sensor_poses

SCENES = Path(__file__).resolve().parents[1] / "scenes"


def runs_for_scene(scene_name: str, step_deg: float, n_poses: int, levels) -> dict[str, FidelityRun]:
    """Runs per level name (and 'paper model') on one scene."""
    path = SCENES / scene_name / "scene.xml"
    scene = load_scene(path)
    trajectory = mitsonar.Trajectory.from_scene(path)
    poses = sensor_poses(trajectory.poses_at(np.linspace(0, trajectory.duration, n_poses + 2)[1:-1]))
    directions = mitsonar.ArrayGeometry().fov_grid(np.radians(step_deg))
    config = mitsonar.SonarConfig()
    mesh = scene_mesh(scene)  # the ground truth
    runs = {name: ping_at(scene, config, PRESETS[name], poses, directions, mesh=mesh)
            for name in levels}
    runs["paper model"] = ping_at(scene, mitsonar.SonarConfig.preset("paper"), PRESETS["standard"],
                                  poses, directions, mesh=mesh)
    return runs


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/speed_accuracy"))
    parser.add_argument("--scenes", default="room_glass,office", help="comma separated")
    parser.add_argument("--step", type=float, default=10.0, help="beam grid step [deg]")
    parser.add_argument("--poses", type=int, default=3, help="poses along each trajectory")
    parser.add_argument("--quick", action="store_true", help="room_glass, 20 deg grid, one pose")
    args = parser.parse_args(argv)
    scenes, step, n_poses = args.scenes.split(","), args.step, args.poses
    levels = list(PRESETS)
    if args.quick:
        scenes, step, n_poses, levels = ["room_glass"], 20.0, 1, ["draft", "standard", "fine"]
    rows = []
    for scene_name in scenes:
        runs = runs_for_scene(scene_name, step, n_poses, levels)
        for name, run in runs.items():
            median, p90, flips = run.depth_error(runs["fine"])
            surface_median, surface_p90 = run.surface_error()
            rows.append({"scene": scene_name, "level": name, "beams": len(run.depth),
                         "detected": int(np.isfinite(run.depth).sum()),
                         "ms_per_ping": 1e3 * run.seconds_per_ping,
                         "median_surface_distance_mm": 1e3 * surface_median,
                         "p90_surface_distance_mm": 1e3 * surface_p90,
                         "median_depth_diff_mm": 1e3 * median, "p90_depth_diff_mm": 1e3 * p90,
                         "decision_flips": flips})
            print(f"{scene_name} {name:12s} {rows[-1]['ms_per_ping']:7.1f} ms/ping, median "
                  f"{1e3 * surface_median:.2f} mm from the true surfaces, "
                  f"{rows[-1]['median_depth_diff_mm']:.2f} mm vs fine, {flips:.0%} flips", file=sys.stderr)
    write_outputs(args.out, rows)
    return 0


def write_outputs(out: Path, rows: list[dict]) -> None:
    out.mkdir(parents=True, exist_ok=True)
    md = ["| scene | level | ms per ping | detected | distance to true surfaces, median [mm] | "
          "p90 [mm] | depth diff vs fine, median [mm] | p90 [mm] | decision flips |",
          "|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    md += [f"| {r['scene']} | {r['level']} | {r['ms_per_ping']:.0f} | {r['detected']}/{r['beams']} | "
           f"{r['median_surface_distance_mm']:.1f} | {r['p90_surface_distance_mm']:.1f} | "
           f"{r['median_depth_diff_mm']:.2f} | {r['p90_depth_diff_mm']:.1f} | {r['decision_flips']:.0%} |"
           for r in rows]
    write_table(out / "speed_accuracy.csv", rows, md)
    plt = _pyplot()
    from matplotlib.ticker import NullFormatter, ScalarFormatter

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    levels = list(dict.fromkeys(r["level"] for r in rows))
    colour = {level: f"C{list(PRESETS).index(level) if level in PRESETS else 4}" for level in levels}
    panels = (("median_surface_distance_mm", "median distance of the detected points\n"
               "to the true surfaces [mm]", "accuracy against the ground truth", "linear"),
              ("median_depth_diff_mm", "median depth difference to 'fine',\nbeam by beam [mm] "
               "(floor 1e-3)", "agreement with 'fine' (speckle differs between ray grids)", "log"))
    for ax, (key, ylabel, title, yscale) in zip(axes, panels):
        for scene_name, marker in zip(scenes, "osd^v"):
            for r in (r for r in rows if r["scene"] == scene_name):
                y = max(r[key], 1e-3) if np.isfinite(r[key]) else np.nan
                ax.plot(r["ms_per_ping"], y, marker, color=colour[r["level"]])
        ax.set_xscale("log")
        ax.set_yscale(yscale)
        if yscale == "linear":
            ax.set_ylim(bottom=0)
        ax.axvline(30.0, color="0.6", ls=":")
        ax.set_xticks([10, 20, 50, 100, 200, 500, 1000])
        ax.xaxis.set_major_formatter(ScalarFormatter())
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("wall-clock time per ping, end to end [ms] (2-core CPU)")
        ax.set_ylabel(ylabel)
        ax.set_title(title, fontsize=10)
    for scene_name, marker in zip(scenes, "osd^v"):  # legend: a marker per scene ...
        axes[0].plot([], [], marker, color="0.4", label=scene_name)
    for level in levels:  # ... and a colour per level
        axes[0].plot([], [], "s", color=colour[level], label=level)
    axes[0].plot([], [], ":", color="0.6", label="real sensor, one ping (30 ms)")
    axes[0].legend(fontsize=8, ncol=2)
    fig.suptitle("Fidelity presets: speed against accuracy")
    fig.tight_layout()
    save_png(fig, out / "speed_accuracy.png")
    print("\n".join(md))
    print(f"Wrote {out}/speed_accuracy.csv, .md and .png")


if __name__ == "__main__":
    sys.exit(main())
