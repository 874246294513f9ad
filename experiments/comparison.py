"""Reconstruction comparison (the paper's Fig. 7): sonar, VLP-16 class LiDAR and Kinect v2 class
depth camera on the four shipped scenes, from the same robot poses, scored against ground truth.

The sonar runs in the mode the paper uses for each scene: surfel scanning on the structural
scenes (room_glass, structure), OFDM repeated scanning on the furnished ones (office, workshop).
The robot poses are ``--frames`` instants spread evenly over the scene's default trajectory,
start to end: the surfel poses, or the start poses of the OFDM frames (each frame fired while the
robot drives; the frames in between are not simulated). The LiDAR and the depth camera take one
frame at each of these robot poses, in the same loaded scene. Every frame is placed with its true
pose (no odometry drift), so consistency reflects the sensors alone.

Sonar settings: ``--preset`` (default 'paper', on which the surfel pipeline is tuned; see
docs/reconstruction.md). Surfel mode uses 800 px images (at 400 px room_glass's planes grow
wrongly: 1.4 % within 2 cm instead of 100 %). Repeated mode adds broadband transducers (20 kHz
at -6 dB: the OFDM tones span 32-48 kHz), a 5 deg beam grid (the paper's 13 x 9 beams per frame)
and 2 cm voxels; each beam is registered with its own pose (``RepeatedMapSpec`` default; the
paper's one pose per frame smears what the robot passes while it drives or turns).

Scoring (:func:`mitsonar.evaluation.metrics.evaluate`, 2 cm threshold). Every cloud is first thinned to one
point per 1 cm voxel, the ground truth's resolution (the paper samples its surfel map at 1 cm;
without this, the depth camera's overlapping frames would outnumber everything else): a seeded
random point of each voxel, not the mean, so noise is not averaged away. Completeness counts the
ground-truth samples in line of sight of at least one sensor position (glass occludes), the same
for all three sensors. Glass is also scored on its own: the LiDAR and the depth camera look
through it, the sonar does not.

Writes comparison.csv/.md (a row per scene and sensor), per_material.csv/.md, comparison.png (top
views coloured by the distance to the ground truth, scenes x sensors), and per reconstruction
<scene>/<sensor>.ply (points with their distance) and <scene>/<sensor>_errors.png.

    .venv/bin/python experiments/comparison.py --out out/comparison            # ~15 min, 2 cores
    .venv/bin/python experiments/comparison.py --quick --out out/comparison    # ~40 s
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

import mitsonar
from mitsonar.sensors.baselines import DepthCamera, Lidar, map_trajectory
from mitsonar.io import write_ply, write_table
from mitsonar.recon.repeated import RepeatedMapSpec, map_repeated
from mitsonar.evaluation.metrics import (DEFAULT_THRESHOLD, Evaluation, evaluate, sample_surface,
                              save_error_figure, visible_from)
from mitsonar.plots import _pyplot, save_png
from mitsonar.scene.mesh import scene_mesh
from mitsonar.recon.surfels import SurfelSettings, map_surfels
from mitsonar.sensors.trajectory import sensor_poses
from mitsonar.recon.voxelmap import VoxelMapSettings

SCENES = Path(__file__).resolve().parents[1] / "scenes"
#: The sonar's mode per scene, as in the paper.
MODES = {"room_glass": "surfel", "structure": "surfel", "office": "repeated", "workshop": "repeated"}
SENSORS = {"sonar": "sonar", "lidar": "VLP-16", "depth_camera": "Kinect v2"}
#: Edge of the thinning voxels [m] (the ground truth's sample spacing).
THIN_VOXEL = 0.01
#: Voxel size of the repeated-scanning map [m].
REPEATED_VOXEL = 0.02
#: Top views drop points this close to the floor and to the ceiling [m].
FLOOR_MARGIN = 0.15
CEILING_MARGIN = 0.3
#: Colour scale of the error renderings is clipped here [m].
ERROR_CLIP = 0.10


@dataclass(frozen=True)
class RunSettings:
    """How each scene is reconstructed.

    Attributes:
        frames: robot poses per scene (surfel poses or OFDM frames).
        width: surfel camera image width [pixels]; spp: its samples per pixel.
        step: OFDM beam grid step [rad].
        spacing: ground-truth sample spacing [m].
        preset: sonar preset (``SonarConfig.preset``).
        seed: seeds the sonar, the baselines' noise, the samples and the thinning.
    """

    frames: int
    width: int
    spp: int
    step: float
    spacing: float
    preset: str
    seed: int


@dataclass(frozen=True)
class Reconstruction:
    """One scored cloud: points (N, 3) [m] (thinned), points before thinning, the evaluation and
    the wall-clock time of the reconstruction [s]."""

    points: np.ndarray
    raw_points: int
    evaluation: Evaluation
    seconds: float


def thin(points, voxel: float = THIN_VOXEL, seed: int = 0) -> np.ndarray:
    """Points (M, 3) [m] of ``points`` (N, 3): one per occupied ``voxel`` [m] cube, a seeded
    random one of its points."""
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    order = np.random.default_rng(seed).permutation(len(p))
    _, first = np.unique(np.floor(p[order] / voxel).astype(np.int64), axis=0, return_index=True)
    return p[np.sort(order[first])]


def sonar_cloud(path: Path, mode: str, trajectory, times, settings: RunSettings, progress):
    """The loaded :class:`mitsonar.Sonar` and its reconstruction (N, 3) [m] at ``times`` [s]."""
    config = mitsonar.SonarConfig.preset(settings.preset)
    if mode == "surfel":
        sonar = mitsonar.Sonar(path, config)
        surfel = SurfelSettings(image_width=settings.width, spp=settings.spp, seed=settings.seed)
        surfel_map = map_surfels(sonar, sensor_poses(trajectory.poses_at(times)), settings=surfel,
                                 progress=progress)
        return sonar, surfel_map.sample(THIN_VOXEL, seed=settings.seed)[0]
    broadband = replace(config, transducer=mitsonar.Transducer(bandwidth_6db=20e3))
    sonar = mitsonar.Sonar(path, broadband)
    spec = RepeatedMapSpec(frames=len(times), interval=times[1] if len(times) > 1 else None,
                           scan_step=settings.step, seed=settings.seed,
                           voxels=VoxelMapSettings(voxel_size=REPEATED_VOXEL))
    voxels, _, _ = map_repeated(sonar, trajectory, spec, progress)
    return sonar, voxels.positions


def run_scene(name: str, settings: RunSettings) -> tuple[dict, dict]:
    """Reconstructions per sensor key, and what the figures need about the scene."""
    from tqdm import tqdm

    path = SCENES / name / "scene.xml"
    mode = MODES[name]
    trajectory = mitsonar.Trajectory.from_scene(path)
    times = np.linspace(0.0, trajectory.duration, settings.frames)
    robot = trajectory.poses_at(times)
    clouds, seconds = {}, {}
    start = time.perf_counter()
    # surfel mode may visit each pose more than once (scan, then check pings): no fixed total
    total = len(times) if mode == "repeated" else None
    with tqdm(total=total, desc=f"{name}: sonar ({mode})", unit="step", file=sys.stderr) as bar:
        sonar, clouds["sonar"] = sonar_cloud(path, mode, trajectory, times, settings,
                                             lambda _: bar.update())
    seconds["sonar"] = time.perf_counter() - start
    for key, sensor in (("lidar", Lidar(sonar.scene)), ("depth_camera", DepthCamera(sonar.scene))):
        start = time.perf_counter()
        clouds[key] = map_trajectory(sensor, robot, seed=settings.seed)[0]
        seconds[key] = time.perf_counter() - start
    mesh = scene_mesh(sonar.scene)
    samples = sample_surface(mesh, settings.spacing, settings.seed)
    viewpoints = np.array([p.translation for p in sensor_poses(robot)])
    observable = visible_from(sonar.scene, samples.points, viewpoints)
    out = {}
    for key, cloud in clouds.items():
        points = thin(cloud, seed=settings.seed)
        out[key] = Reconstruction(points, len(cloud), evaluate(points, mesh, samples=samples,
                                                               observable=observable),
                                  seconds[key])
        score = out[key].evaluation.overall
        print(f"{name} {SENSORS[key]:9s}: {score.points} points, {100 * score.accuracy:.1f} % "
              f"within 2 cm, completeness {100 * score.completeness:.1f} %, "
              f"{seconds[key]:.0f} s", file=sys.stderr)
    info = json.loads(path.with_name("ground_truth.json").read_text())
    band = (samples.points[:, 2] > 0.9) & (samples.points[:, 2] < 1.1)  # the scene at 1 m
    outline = samples.points[band][np.random.default_rng(0).permutation(int(band.sum()))[:40_000]]
    scene_info = {"mode": mode, "height": info["height_m"], "extent": info["interior_extent_m"],
                  "viewpoints": viewpoints, "outline": outline}
    return out, scene_info


def label(key: str, mode: str) -> str:
    """Display name of a sensor ('sonar (surfel)', 'VLP-16', ...)."""
    return f"{SENSORS[key]} ({mode})" if key == "sonar" else SENSORS[key]


def summary_row(scene: str, mode: str, key: str, rec: Reconstruction, frames: int) -> dict:
    o, g = rec.evaluation.overall, rec.evaluation.per_optics["transparent"]
    return {"scene": scene, "sensor": key, "mode": mode if key == "sonar" else "", "frames": frames,
            "raw_points": rec.raw_points, "points": o.points, "accuracy": o.accuracy,
            "mean_distance_m": o.mean_distance, "median_distance_m": o.median_distance,
            "p90_distance_m": o.p90_distance, "completeness": o.completeness, "fscore": o.fscore,
            "consistency_m": o.consistency, "glass_points": g.points, "glass_accuracy": g.accuracy,
            "glass_completeness": g.completeness, "seconds": rec.seconds}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/comparison"))
    parser.add_argument("--scenes", default=",".join(MODES), help="comma separated subset")
    parser.add_argument("--frames", type=int, default=16,
                        help="robot poses per scene, spread over its trajectory (default 16)")
    parser.add_argument("--width", type=int, default=800,
                        help="surfel camera image width [pixels] (default 800)")
    parser.add_argument("--spp", type=int, default=8,
                        help="surfel camera samples per pixel (default 8, denoised)")
    parser.add_argument("--step", type=float, default=5.0, help="OFDM beam grid step [deg]")
    parser.add_argument("--preset", choices=("default", "paper"), default="paper",
                        help="sonar model (SonarConfig.preset; default paper)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--quick", action="store_true",
                        help="room_glass and workshop, 3 poses, 400 px surfel images, 20 deg "
                             "OFDM grid, 2 cm ground truth (for the test suite)")
    args = parser.parse_args(argv)
    scenes = args.scenes.split(",")
    unknown = sorted(set(scenes) - set(MODES))
    if unknown:
        raise ValueError(f"--scenes: unknown scene(s) {', '.join(unknown)}; known: {', '.join(MODES)}")
    if args.frames < 1:
        raise ValueError(f"--frames must be >= 1, got {args.frames}")
    settings = RunSettings(args.frames, args.width, args.spp, np.radians(args.step), 0.01,
                           args.preset, args.seed)
    if args.quick:
        scenes = ["room_glass", "workshop"]
        settings = replace(settings, frames=3, width=400, step=np.radians(20.0), spacing=0.02)
    results, infos = {}, {}
    for name in scenes:
        results[name], infos[name] = run_scene(name, settings)
    write_outputs(args.out, results, infos, settings.frames)
    return 0


def _x100(x) -> str:
    """A fraction in % or a length in cm, one decimal; '-' for NaN."""
    return f"{100 * x:.1f}" if np.isfinite(x) else "-"


def write_outputs(out: Path, results: dict, infos: dict, frames: int) -> None:
    out.mkdir(parents=True, exist_ok=True)
    rows, material_rows = [], []
    for scene, recs in results.items():
        for key, rec in recs.items():
            rows.append(summary_row(scene, infos[scene]["mode"], key, rec, frames))
            material_rows += [{"scene": scene, "sensor": key, "material": m, "points": s.points,
                               "samples": s.samples, "accuracy": s.accuracy,
                               "completeness": s.completeness, "fscore": s.fscore,
                               "median_distance_m": s.median_distance,
                               "p90_distance_m": s.p90_distance}
                              for m, s in rec.evaluation.per_material.items()]
            write_ply(out / scene / f"{key}.ply", rec.points,
                      scalars={"distance_m": rec.evaluation.distance})
            save_error_figure(out / scene / f"{key}_errors.png", rec.points,
                              rec.evaluation.distance, DEFAULT_THRESHOLD,
                              title=f"{scene}: {label(key, infos[scene]['mode'])}, {frames} poses")
    md = ["| scene | sensor | points | accuracy % (< 2 cm) | median cm | p90 cm | completeness % | "
          "F-score % | consistency cm | glass points | glass accuracy % | glass completeness % | "
          "time s |", "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    md += [f"| {r['scene']} | {label(r['sensor'], r['mode'])} | "
           f"{r['points']} | {_x100(r['accuracy'])} | {_x100(r['median_distance_m'])} | "
           f"{_x100(r['p90_distance_m'])} | {_x100(r['completeness'])} | {_x100(r['fscore'])} | "
           f"{_x100(r['consistency_m'])} | {r['glass_points']} | {_x100(r['glass_accuracy'])} | "
           f"{_x100(r['glass_completeness'])} | {r['seconds']:.0f} |" for r in rows]
    write_table(out / "comparison.csv", rows, md)
    pm = ["| scene | sensor | material | points | samples | accuracy % | completeness % | "
          "F-score % | median cm |", "|---|---|---|---:|---:|---:|---:|---:|---:|"]
    pm += [f"| {r['scene']} | {SENSORS[r['sensor']]} | {r['material']} | {r['points']} | "
           f"{r['samples']} | {_x100(r['accuracy'])} | {_x100(r['completeness'])} | "
           f"{_x100(r['fscore'])} | {_x100(r['median_distance_m'])} |" for r in material_rows]
    write_table(out / "per_material.csv", material_rows, pm)
    save_comparison_figure(out / "comparison.png", results, infos, frames)
    print("\n".join(md))
    print(f"Wrote {out}/comparison.csv, .md, per_material.csv, .md, comparison.png and a PLY and "
          f"error figure per reconstruction in {out}/<scene>/")


def save_comparison_figure(path: Path, results: dict, infos: dict, frames: int,
                           max_points: int = 80_000) -> None:
    """Scenes x sensors grid of top views, points coloured by their distance to the ground truth
    (clipped at ``ERROR_CLIP``), floor and ceiling left out (they would hide the rest); grey: the
    ground truth's walls at 1 m height."""
    plt = _pyplot()
    fig, axes = plt.subplots(len(results), len(SENSORS), squeeze=False,
                             figsize=(5.2 * len(SENSORS), 4.6 * len(results) + 1.0))
    rng = np.random.default_rng(0)
    for row, (scene, recs) in zip(axes, results.items()):
        info = infos[scene]
        for ax, key in zip(row, SENSORS):
            rec = recs[key]
            z = rec.points[:, 2]
            keep = (z > FLOOR_MARGIN) & (z < info["height"] - CEILING_MARGIN)
            p, d = rec.points[keep], rec.evaluation.distance[keep]
            if len(p) > max_points:
                pick = rng.choice(len(p), max_points, replace=False)
                p, d = p[pick], d[pick]
            order = np.argsort(p[:, 2], kind="stable")
            ax.scatter(*info["outline"][:, :2].T, c="0.8", s=0.2, linewidths=0)
            im = ax.scatter(p[order, 0], p[order, 1], c=100 * d[order], cmap="turbo", vmin=0,
                            vmax=100 * ERROR_CLIP, s=float(np.clip(3000 / max(len(p), 1), 0.6, 6)),
                            linewidths=0)
            ax.plot(*info["viewpoints"][:, :2].T, "k.-", lw=0.6, ms=3)
            ax.set_xlim(np.add(info["extent"]["x"], [-0.3, 0.3]))
            ax.set_ylim(np.add(info["extent"]["y"], [-0.3, 0.3]))
            ax.set_aspect("equal")
            score = rec.evaluation.overall
            ax.set_title(f"{scene}: {label(key, info['mode'])}\n{_x100(score.accuracy)} % within "
                         f"2 cm, completeness {_x100(score.completeness)} %", fontsize=9)
            ax.tick_params(labelsize=7)
    fig.suptitle(f"Top views [m], {frames} robot poses per scene (black); floor and ceiling "
                 "removed; grey: ground-truth walls at 1 m", fontsize=10)
    fig.tight_layout(rect=(0, 0.07, 1, 0.98))
    bar = fig.add_axes((0.25, 0.045, 0.5, 0.01))
    fig.colorbar(im, cax=bar, orientation="horizontal",
                 label=f"distance to ground truth [cm] (clipped at {100 * ERROR_CLIP:.0f})")
    save_png(fig, path)


if __name__ == "__main__":
    sys.exit(main())
