"""Small objects in front of a wall (the paper's Fig. 8b, first failure case): what the sonar's
wide beam, a VLP-16 class LiDAR and a Kinect v2 class depth camera make of them, against object
size and distance.

Scenes (written on the fly): one object centred at the sensor height (0.5 m), 1 m in front of a
3 m x 3 m drywall wall, no floor (its echo would compete with the object's):

* box: a cube of edge s, one face towards the sensor (wood, as cardboard);
* bottle: a closed vertical cylinder of diameter s, 2 s tall (the 'wood' preset, which the
  shipped scenes use for plastics);
* pole: a vertical cylinder of diameter s, 2 m tall (metal).

Trials: for every shape, size s and distance d (sensor head to the object's centre),
``--trials`` robot poses facing the object, each shifted sideways and up or down by uniform
random offsets within +-d tan(2.5 deg) (half the sonar's 5 deg beam spacing, more than half the
LiDAR's 2 deg ring spacing), so the object falls anywhere between beams. Per trial:

* sonar: single pings (default physical model, TCT40 class transducers) on the paper's 5 deg
  grid, the beams within 12.5 deg of the object's direction (the others see only the wall).
  A beam gives one point, at its strongest echo: where the footprint covers a small object and
  the wall behind it, the wall's echo often wins;
* LiDAR: one revolution; depth camera: one frame (both from the same robot pose).

Scores (:mod:`mitsonar.evaluation.metrics` conventions, 2 cm threshold). Object points are the points whose
nearest scene surface is the object. Detection rate: fraction of trials with a point within 5 cm
of the object. Accuracy: fraction of the object points within 2 cm, and their median distance,
pooled over the trials. Completeness: fraction of the object's surface (sampled every 5 mm) in
line of sight and within the sonar's 12.5 deg cone that has a point within 2 cm, mean over the
trials. Writes small_objects.csv/.md and small_objects.png (curves against size, and top views
of one setting).

    .venv/bin/python experiments/small_objects.py --out out/small_objects          # ~7 min
    .venv/bin/python experiments/small_objects.py --quick --out out/small_objects  # ~30 s
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

import mitsonar
from mitsonar.sensors.baselines import DepthCamera, Lidar
from mitsonar.frames import SENSOR_MOUNT_TRANSLATION, Pose
from mitsonar.io import write_table
from mitsonar.evaluation.metrics import DEFAULT_THRESHOLD, point_to_mesh, sample_surface, visible_from
from mitsonar.plots import _pyplot, save_png
from mitsonar.scene.mesh import scene_mesh

#: Acoustic preset of each shape.
SHAPES = {"box": "wood", "bottle": "wood", "pole": "metal"}
SENSORS = {"sonar": "sonar (pings)", "lidar": "VLP-16", "depth_camera": "Kinect v2"}
HEIGHT = float(SENSOR_MOUNT_TRANSLATION[2])  # object centre = sensor height [m]
WALL_GAP = 1.0  # wall behind the object's centre [m]
POLE_LENGTH = 2.0  # [m]
BEAM_STEP = np.radians(5.0)  # sonar beam grid [rad]
CONE = np.radians(12.5)  # beams (and completeness) within this angle of the object [rad]
DETECT_RADIUS = 0.05  # a point this close to the object detects it [m]
SAMPLE_SPACING = 0.005  # object surface samples [m]
ERROR_CLIP = 0.10  # colour scale of the top views [m]


def object_xml(shape: str, size: float) -> str:
    """Shapes of the object (material id 'object') of ``size`` [m] centred at (0, 0, HEIGHT)."""
    r = size / 2
    if shape == "box":
        return (f'<shape type="cube"><transform name="to_world"><scale value="{r}"/>'
                f'<translate z="{HEIGHT}"/></transform><ref id="object"/></shape>')
    length = 2 * size if shape == "bottle" else POLE_LENGTH
    z0, z1 = HEIGHT - length / 2, HEIGHT + length / 2
    tube = (f'<shape type="cylinder"><float name="radius" value="{r}"/>'
            f'<point name="p0" x="0" y="0" z="{z0}"/><point name="p1" x="0" y="0" z="{z1}"/>'
            '<ref id="object"/></shape>')
    caps = "".join(f'<shape type="disk"><transform name="to_world"><scale value="{r}"/>{flip}'
                   f'<translate z="{z}"/></transform><ref id="object"/></shape>'
                   for z, flip in ((z0, '<rotate x="1" angle="180"/>'), (z1, "")))
    return tube + caps


def object_scene(directory: Path, shape: str, size: float) -> Path:
    """Scene file of ``shape`` of ``size`` [m] in front of the wall."""
    path = directory / f"{shape}_{size:g}.xml"
    path.write_text(
        '<scene version="3.0.0">'
        '<bsdf type="acoustic" id="wall"><string name="preset" value="drywall"/>'
        '<bsdf type="diffuse"/></bsdf>'
        f'<bsdf type="acoustic" id="object"><string name="preset" value="{SHAPES[shape]}"/>'
        '<bsdf type="diffuse"/></bsdf>'
        '<shape type="rectangle"><transform name="to_world"><scale x="1.5" y="1.5"/>'
        f'<rotate y="1" angle="-90"/><translate x="{WALL_GAP}" z="{HEIGHT}"/></transform>'
        f'<ref id="wall"/></shape>{object_xml(shape, size)}</scene>')
    return path


def in_cone(points, pose: Pose, axis) -> np.ndarray:
    """(N,) True where world points (N, 3) [m] lie within CONE of the sensor-frame ``axis``."""
    v = pose.inverse().transform_points(points)
    return v @ axis >= np.cos(CONE) * np.linalg.norm(v, axis=1)


class ObjectBench:
    """One object scene loaded once: the three sensors and the object's ground truth."""

    def __init__(self, path: Path):
        self.sonar = mitsonar.Sonar(path)
        self.lidar = Lidar(self.sonar.scene)
        self.camera = DepthCamera(self.sonar.scene)
        self.mesh = scene_mesh(self.sonar.scene)
        self.object = [m.name for m in self.mesh.materials].index("object")
        samples = sample_surface(self.mesh, SAMPLE_SPACING)
        self.samples = samples.points[self.mesh.triangle_material[samples.triangle] == self.object]
        self.grid = self.sonar.fov_grid(BEAM_STEP)

    def trial(self, robot: Pose, seed: int) -> tuple[dict, np.ndarray]:
        """World points (N, 3) [m] per sensor key from a robot at ``robot``, and the object
        samples (M, 3) [m] that count for completeness."""
        pose = robot @ Pose.sensor_mount()
        axis = pose.inverse().transform_points([0.0, 0.0, HEIGHT])
        axis /= np.linalg.norm(axis)
        beams = self.grid[self.grid @ axis >= np.cos(CONE)]
        scan = self.sonar.scan(pose, beams, seed=seed)
        points = {"sonar": pose.transform_points(scan.points_sensor[scan.detected]),
                  "lidar": self.lidar.measure(robot, seed=seed).points_world,
                  "depth_camera": self.camera.measure(robot, seed=seed).points_world}
        seen = visible_from(self.sonar.scene, self.samples, pose.translation[None]) \
            & in_cone(self.samples, pose, axis)
        return points, self.samples[seen]

    def score(self, points, targets) -> dict:
        """Object points' distances [m], detection, and covered fraction of ``targets``."""
        distance, _, tri, _ = point_to_mesh(points, self.mesh)
        on_object = self.mesh.triangle_material[tri] == self.object
        covered = np.zeros(len(targets), dtype=bool)
        if len(points) and len(targets):
            covered = cKDTree(points).query(targets, distance_upper_bound=DEFAULT_THRESHOLD)[0] \
                <= DEFAULT_THRESHOLD
        return {"distance": distance[on_object],
                "detected": bool(np.any(distance[on_object] <= DETECT_RADIUS)),
                "completeness": float(np.mean(covered)) if len(targets) else np.nan}


def run(shapes, sizes, distances, trials: int, seed: int, example) -> tuple[list[dict], dict]:
    """Rows per (shape, size, distance, sensor), and per sensor the world points of all trials
    of the ``example`` (shape, size, distance) setting with their distance to the ground truth:
    (N, 4) x, y, z, distance [m]."""
    rows, example_points = [], {}
    with tempfile.TemporaryDirectory() as tmp:
        for i, shape in enumerate(shapes):
            for j, size in enumerate(sizes):
                bench = ObjectBench(object_scene(Path(tmp), shape, size))
                for k, d in enumerate(distances):
                    scores = {key: [] for key in SENSORS}
                    for t in range(trials):  # robot poses
                        trial_seed = int(np.random.SeedSequence([seed, i, j, k, t])
                                         .generate_state(1)[0])
                        dy, dz = np.random.default_rng(trial_seed).uniform(-1, 1, 2) \
                            * d * np.tan(BEAM_STEP / 2)
                        robot = Pose.planar(-d - SENSOR_MOUNT_TRANSLATION[0], dy, 0.0, dz)
                        points, targets = bench.trial(robot, trial_seed)
                        for key, p in points.items():
                            scores[key].append(bench.score(p, targets))
                        if (shape, size, d) == example:
                            for key, p in points.items():
                                example_points.setdefault(key, []).append(
                                    np.column_stack([p, point_to_mesh(p, bench.mesh)[0]]))
                    for key, s in scores.items():
                        rows.append(summary_row(shape, size, d, key, s))
                    print(f"{shape:6s} {100 * size:4.0f} cm at {d:.1f} m: detected " + ", ".join(
                        f"{SENSORS[r['sensor']]} {r['detection_rate']:.0%}" for r in rows[-3:]),
                        file=sys.stderr)
    return rows, {key: np.concatenate(p) for key, p in example_points.items()}


def summary_row(shape: str, size: float, distance: float, key: str, scores: list[dict]) -> dict:
    d = np.concatenate([s["distance"] for s in scores])
    return {"shape": shape, "size_m": size, "distance_m": distance, "sensor": key,
            "trials": len(scores),
            "detection_rate": float(np.mean([s["detected"] for s in scores])),
            "object_points_per_trial": len(d) / len(scores),
            "accuracy": float(np.mean(d <= DEFAULT_THRESHOLD)) if len(d) else np.nan,
            "median_distance_m": float(np.median(d)) if len(d) else np.nan,
            "completeness": float(np.nanmean([s["completeness"] for s in scores]))}


def _floats(text: str, name: str) -> list[float]:
    """Comma-separated positive lengths [m] of the option ``name``."""
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = [np.nan]
    if not all(np.isfinite(v) and v > 0 for v in values):
        raise ValueError(f"{name} must be positive numbers [m], comma separated, got {text!r}")
    return values


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/small_objects"))
    parser.add_argument("--shapes", default=",".join(SHAPES), help="comma separated")
    parser.add_argument("--sizes", default="0.02,0.05,0.1,0.2",
                        help="box edge / bottle and pole diameter [m], comma separated")
    parser.add_argument("--distances", default="1,2,3",
                        help="sensor to object centre [m], comma separated")
    parser.add_argument("--trials", type=int, default=4, help="robot poses per setting")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--quick", action="store_true",
                        help="box and pole, 5 and 20 cm, at 1.5 m, 2 trials (for the test suite)")
    args = parser.parse_args(argv)
    shapes = args.shapes.split(",")
    unknown = sorted(set(shapes) - set(SHAPES))
    if unknown:
        raise ValueError(f"--shapes: unknown {', '.join(unknown)}; known: {', '.join(SHAPES)}")
    sizes, distances = _floats(args.sizes, "--sizes"), _floats(args.distances, "--distances")
    trials = args.trials
    if args.quick:
        shapes, sizes, distances, trials = ["box", "pole"], [0.05, 0.2], [1.5], 2
    if trials < 1:
        raise ValueError(f"--trials must be >= 1, got {trials}")
    example = (shapes[0], min(sizes, key=lambda s: abs(s - 0.1)),
               min(distances, key=lambda d: abs(d - 2.0)))
    rows, example_points = run(shapes, sizes, distances, trials, args.seed, example)
    write_outputs(args.out, rows, example, example_points)
    return 0


def _pct(x) -> str:
    """A fraction in %; '-' for NaN."""
    return f"{100 * x:.0f}" if np.isfinite(x) else "-"


def _cm(x) -> str:
    """A length [m] in cm; '-' for NaN."""
    return f"{100 * x:.1f}" if np.isfinite(x) else "-"


def write_outputs(out: Path, rows: list[dict], example, example_points: dict) -> None:
    out.mkdir(parents=True, exist_ok=True)
    md = ["Per cell: sonar / VLP-16 / Kinect v2.", "",
          "| shape | size cm | distance m | detection % | object points per trial | "
          "accuracy % (< 2 cm) | median error cm | completeness % |",
          "|---|---:|---:|---|---|---|---|---|"]
    for i in range(0, len(rows), len(SENSORS)):
        group = rows[i:i + len(SENSORS)]
        r = group[0]

        def cell(column, fmt=_pct):
            return " / ".join(fmt(g[column]) for g in group)

        md.append(f"| {r['shape']} | {100 * r['size_m']:g} | {r['distance_m']:g} | "
                  f"{cell('detection_rate')} | "
                  f"{cell('object_points_per_trial', lambda x: f'{x:.1f}')} | "
                  f"{cell('accuracy')} | {cell('median_distance_m', _cm)} | "
                  f"{cell('completeness')} |")
    write_table(out / "small_objects.csv", rows, md)
    save_figure(out / "small_objects.png", rows, example, example_points)
    print("\n".join(md))
    print(f"Wrote {out}/small_objects.csv, .md and .png")


def save_figure(path: Path, rows: list[dict], example, example_points: dict) -> None:
    """Detection rate, completeness and median error against size (a column per shape, colour
    per sensor, line style per distance), and top views of the ``example`` setting."""
    plt = _pyplot()
    shapes = list(dict.fromkeys(r["shape"] for r in rows))
    distances = sorted({r["distance_m"] for r in rows})
    columns = max(len(shapes), len(SENSORS))
    fig = plt.figure(figsize=(5.0 * columns, 15.0), layout="constrained")
    axes = fig.subplots(4, columns, squeeze=False)
    curves = (("detection_rate", 100, "detection rate [%]"),
              ("completeness", 100, "completeness of the object [%]"),
              ("median_distance_m", 100, "median error of object points [cm]"))
    styles = ["-", "--", ":", "-."]
    for c, shape in enumerate(shapes):
        for a, (column, scale, ylabel) in enumerate(curves):
            ax = axes[a, c]
            for s, key in enumerate(SENSORS):
                for d, ls in zip(distances, styles * len(distances)):
                    sel = [r for r in rows if r["shape"] == shape and r["sensor"] == key
                           and r["distance_m"] == d]
                    ax.plot([100 * r["size_m"] for r in sel], [scale * r[column] for r in sel],
                            ls, marker="os^"[s], color=f"C{s}",
                            label=f"{SENSORS[key]}, {d:g} m")
            ax.set_xscale("log")
            ax.set_xticks(sorted({100 * r["size_m"] for r in rows}), minor=False)
            ax.xaxis.set_major_formatter("{x:g}")
            ax.minorticks_off()
            ax.set_xlabel(f"{shape}: {'edge' if shape == 'box' else 'diameter'} [cm]")
            ax.set_ylabel(ylabel)
            ax.grid(True, lw=0.3, alpha=0.5)
            if column != "median_distance_m":
                ax.set_ylim(-5, 105)
        axes[0, c].set_title(shape)
    for ax in axes[:3, len(shapes):].ravel():
        ax.axis("off")
    axes[0, 0].legend(fontsize=7)
    shape, size, d = example
    for ax, key in zip(axes[3], SENSORS):
        p = example_points.get(key, np.zeros((0, 4)))
        p = p[(np.abs(p[:, 1]) < 0.4) & (p[:, 0] > -0.4) & (p[:, 0] < WALL_GAP + 0.1)]
        outline = _outline(shape, size)
        ax.fill(outline[:, 0], outline[:, 1], color="0.85", zorder=0)
        im = ax.scatter(p[:, 0], p[:, 1], c=100 * p[:, 3], cmap="turbo", vmin=0,
                        vmax=100 * ERROR_CLIP, s=float(np.clip(2000 / max(len(p), 1), 0.5, 16)),
                        linewidths=0)
        ax.axvline(WALL_GAP, color="0.6", lw=0.8)
        ax.set_xlim(-0.4, WALL_GAP + 0.1)
        ax.set_ylim(-0.4, 0.4)
        ax.set_aspect("equal")
        ax.set_xlabel("x: away from the robot [m]")
        ax.set_ylabel("y [m]")
        ax.set_title(f"{SENSORS[key]}: {shape} {100 * size:g} cm at {d:g} m,\n"
                     "all trials (top view)", fontsize=9)
    fig.colorbar(im, ax=axes[3, -1],
                 label=f"distance to ground truth [cm] (clipped at {100 * ERROR_CLIP:.0f})")
    fig.suptitle("Small objects 1 m in front of a wall: sonar (5 deg beam grid), VLP-16 and "
                 "Kinect v2 (grey: the object; wall at x = 1 m)")
    save_png(fig, path)


def _outline(shape: str, size: float) -> np.ndarray:
    """(K, 2) top-view outline of the object [m]."""
    r = size / 2
    if shape == "box":
        return np.array([[-r, -r], [r, -r], [r, r], [-r, r]])
    a = np.linspace(0, 2 * np.pi, 65)
    return r * np.stack([np.cos(a), np.sin(a)], axis=1)


if __name__ == "__main__":
    sys.exit(main())
