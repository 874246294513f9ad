"""Reconstruction comparison (the paper's Fig. 7): sonar, VLP-16 class LiDAR and Kinect v2 class
depth camera on the four shipped scenes, from the same robot poses, scored against ground truth.

The sonar runs in the mode the paper uses for each scene: surfel scanning on the structural
scenes (room_glass, structure), OFDM repeated scanning on the furnished ones (office, workshop).
Every sensor drives the scene's whole default trajectory (or its first ``--duration`` seconds)
at the trajectory's speed (0.2 m/s, 30 deg/s on the spot) and takes what it would take there in
that time, at its own rate, in the same loaded scene: the sonar fires OFDM frames back to back
(4.8 frames/s with 117 beams) in repeated mode; in surfel mode the camera takes a 25 Hz frame
whenever the sonar is free and the sonar pings every 30 ms (its listening time); the VLP-16
turns at 10 Hz (each column fired at its own time), the Kinect v2 takes 30 frames/s. Every
beam, frame or column is placed with the pose it was taken from (no odometry drift), so
consistency reflects the sensors alone.

Sonar settings: ``--preset`` (default 'paper', on which the surfel pipeline is tuned; see
docs/reconstruction.md). Surfel mode uses 800 px images (at 400 px room_glass's planes grow
wrongly: 1.4 % within 2 cm instead of 100 %). Repeated mode adds broadband transducers (20 kHz
at -6 dB: the OFDM tones span 32-48 kHz), a 5 deg beam grid (the paper's 13 x 9 beams per frame)
and 2 cm voxels; each beam is registered with its own pose (``RepeatedMapSpec`` default; the
paper's one pose per frame smears what the robot passes while it drives or turns).

Scoring (:func:`mitsonar.evaluation.metrics.evaluate`, 2 cm threshold). Every cloud is first thinned to one
point per 1 cm voxel, the ground truth's resolution (the paper samples its surfel map at 1 cm;
without this, the depth camera's overlapping frames would outnumber everything else): a seeded
random point of each voxel, not the mean, so noise is not averaged away; the baselines' frames
are thinned as they come (:class:`VoxelThinner`: a Kinect v2 along a two-minute trajectory
returns some 10^9 points). Completeness counts the ground-truth samples in line of sight of the
sensor head at least once a second along the drive (glass occludes), the same for all three
sensors. Glass is also scored on its own: the LiDAR and the depth camera look through it, the
sonar does not.

Writes comparison.csv/.md (a row per scene and sensor), per_material.csv/.md, comparison.png (top
views coloured by the distance to the ground truth, scenes x sensors), and per reconstruction
<scene>/<sensor>.ply (points with their distance) and <scene>/<sensor>_errors.png.

    .venv/bin/python experiments/comparison.py --out out/comparison            # hours, 2 cores
    .venv/bin/python experiments/comparison.py --quick --out out/comparison    # ~1 min
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
from mitsonar.sensors.baselines import DepthCamera, Lidar, sweep
from mitsonar.io import write_ply, write_table
from mitsonar.recon.repeated import RepeatedMapSpec, map_repeated
from mitsonar.evaluation.metrics import (DEFAULT_THRESHOLD, Evaluation, evaluate, sample_surface,
                              save_error_figure, visible_from)
from mitsonar.plots import _pyplot, save_png
from mitsonar.scene.mesh import scene_mesh
from mitsonar.recon.surfels import SurfelSettings, map_surfels_along
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
#: The ground truth counts as observable where the sensor head sees it at least once in this
#: many seconds of driving [s].
VIEW_PERIOD = 1.0
#: Top views drop points this close to the floor and to the ceiling [m].
FLOOR_MARGIN = 0.15
CEILING_MARGIN = 0.3
#: Colour scale of the error renderings is clipped here [m].
ERROR_CLIP = 0.10


@dataclass(frozen=True)
class RunSettings:
    """How each scene is reconstructed.

    Attributes:
        duration: seconds of each scene's trajectory driven; None: all of it.
        width: surfel camera image width [pixels]; spp: its samples per pixel.
        step: OFDM beam grid step [rad].
        spacing: ground-truth sample spacing [m].
        preset: sonar preset (``SonarConfig.preset``).
        seed: seeds the sonar, the baselines' noise, the samples and the thinning.
    """

    duration: float | None
    width: int
    spp: int
    step: float
    spacing: float
    preset: str
    seed: int


@dataclass(frozen=True)
class Reconstruction:
    """One scored cloud: points (N, 3) [m] (thinned), points before thinning, the sensor's
    frames along the drive (sonar: camera frames in surfel mode, OFDM frames in repeated
    mode), the evaluation and the wall-clock time of the reconstruction [s]."""

    points: np.ndarray
    raw_points: int
    frames: int
    evaluation: Evaluation
    seconds: float


class VoxelThinner:
    """One point per occupied ``voxel`` [m] cube of all the points added, a seeded random one
    of them (each point draws a key from ``default_rng(seed)`` as it comes; a cube keeps its
    smallest-key point), kept as the points come: at most ``batch`` points wait between two
    compactions."""

    def __init__(self, voxel: float = THIN_VOXEL, seed: int = 0, batch: int = 4_000_000):
        self.voxel, self.batch = voxel, batch
        self.rng = np.random.default_rng(seed)
        self.points, self.keys = np.zeros((0, 3)), np.zeros(0)
        self.waiting, self.raw = [], 0

    def add(self, points) -> None:
        """Add points (N, 3) [m]."""
        self.waiting.append(np.asarray(points, dtype=float).reshape(-1, 3))
        self.raw += len(self.waiting[-1])
        if sum(len(p) for p in self.waiting) >= self.batch:
            self._compact()

    def _compact(self) -> None:
        new = np.concatenate(self.waiting) if self.waiting else np.zeros((0, 3))
        points = np.concatenate([self.points, new])
        keys = np.concatenate([self.keys, self.rng.random(len(new))])
        cells = np.floor(points / self.voxel).astype(np.int64)
        order = np.lexsort((keys, cells[:, 2], cells[:, 1], cells[:, 0]))
        first = np.ones(len(order), dtype=bool)
        first[1:] = np.any(np.diff(cells[order], axis=0) != 0, axis=1)
        keep = np.sort(order[first])
        self.points, self.keys, self.waiting = points[keep], keys[keep], []

    def result(self) -> np.ndarray:
        """The thinned points (M, 3) [m]."""
        self._compact()
        return self.points


def sonar_cloud(path: Path, mode: str, trajectory, settings: RunSettings, progress):
    """The loaded :class:`mitsonar.Sonar`, its reconstruction (N, 3) [m] along the drive and the
    number of its camera frames (surfel mode) or OFDM frames (repeated mode)."""
    config = mitsonar.SonarConfig.preset(settings.preset)
    if mode == "surfel":
        sonar = mitsonar.Sonar(path, config)
        surfel = SurfelSettings(image_width=settings.width, spp=settings.spp, seed=settings.seed)
        surfel_map = map_surfels_along(sonar, trajectory, surfel, settings.duration, progress)
        return sonar, surfel_map.sample(THIN_VOXEL, seed=settings.seed)[0], len(surfel_map.scans)
    broadband = replace(config, transducer=mitsonar.Transducer(bandwidth_6db=20e3))
    sonar = mitsonar.Sonar(path, broadband)
    spec = RepeatedMapSpec(duration=settings.duration, scan_step=settings.step, seed=settings.seed,
                           voxels=VoxelMapSettings(voxel_size=REPEATED_VOXEL))
    voxels, _, scanned = map_repeated(sonar, trajectory, spec, progress)
    return sonar, voxels.positions, len(scanned)


def run_scene(name: str, settings: RunSettings) -> tuple[dict, dict]:
    """Reconstructions per sensor key, and what the figures need about the scene."""
    from tqdm import tqdm

    path = SCENES / name / "scene.xml"
    mode = MODES[name]
    trajectory = mitsonar.Trajectory.from_scene(path)
    driven = trajectory.driven(settings.duration)
    clouds, seconds, frames = {}, {}, {}
    start = time.perf_counter()
    with tqdm(desc=f"{name}: sonar ({mode})", file=sys.stderr) as bar:
        def step(*at):  # surfel mode: the time driven [s]; repeated: (frame, frames)
            bar.total = round(driven, 1) if mode == "surfel" else at[1]
            bar.update((round(at[0], 1) - bar.n) if mode == "surfel" else 1)

        sonar, cloud, frames["sonar"] = sonar_cloud(path, mode, trajectory, settings, step)
    clouds["sonar"] = VoxelThinner(seed=settings.seed)
    clouds["sonar"].add(cloud)
    seconds["sonar"] = time.perf_counter() - start
    for key, sensor in (("lidar", Lidar(sonar.scene)), ("depth_camera", DepthCamera(sonar.scene))):
        start = time.perf_counter()
        clouds[key] = VoxelThinner(seed=settings.seed)
        rate = sensor.model.rate
        for _, points in tqdm(sweep(sensor, trajectory, settings.duration, settings.seed),
                              total=len(trajectory.times_at_rate(rate, settings.duration)),
                              desc=f"{name}: {SENSORS[key]} at {rate:g} Hz", unit="frame",
                              file=sys.stderr):
            clouds[key].add(points)
        frames[key] = len(trajectory.times_at_rate(rate, settings.duration))
        seconds[key] = time.perf_counter() - start
    mesh = scene_mesh(sonar.scene)
    samples = sample_surface(mesh, settings.spacing, settings.seed)
    views = trajectory.poses_at(np.arange(0.0, driven + 1e-9, VIEW_PERIOD))
    viewpoints = np.array([p.translation for p in sensor_poses(views)])
    observable = visible_from(sonar.scene, samples.points, viewpoints)
    out = {}
    for key, thinner in clouds.items():
        points = thinner.result()
        out[key] = Reconstruction(points, thinner.raw, frames[key],
                                  evaluate(points, mesh, samples=samples, observable=observable),
                                  seconds[key])
        score = out[key].evaluation.overall
        print(f"{name} {SENSORS[key]:9s}: {frames[key]} frames, {score.points} points, "
              f"{100 * score.accuracy:.1f} % within 2 cm, completeness "
              f"{100 * score.completeness:.1f} %, {seconds[key]:.0f} s", file=sys.stderr)
    info = json.loads(path.with_name("ground_truth.json").read_text())
    info["driven"] = driven
    band = (samples.points[:, 2] > 0.9) & (samples.points[:, 2] < 1.1)  # the scene at 1 m
    outline = samples.points[band][np.random.default_rng(0).permutation(int(band.sum()))[:40_000]]
    scene_info = {"mode": mode, "height": info["height_m"], "extent": info["interior_extent_m"],
                  "viewpoints": viewpoints, "outline": outline, "driven": driven}
    return out, scene_info


def label(key: str, mode: str) -> str:
    """Display name of a sensor ('sonar (surfel)', 'VLP-16', ...)."""
    return f"{SENSORS[key]} ({mode})" if key == "sonar" else SENSORS[key]


def summary_row(scene: str, info: dict, key: str, rec: Reconstruction) -> dict:
    o, g = rec.evaluation.overall, rec.evaluation.per_optics["transparent"]
    return {"scene": scene, "sensor": key, "mode": info["mode"] if key == "sonar" else "",
            "driven_s": info["driven"], "frames": rec.frames,
            "raw_points": rec.raw_points, "points": o.points, "accuracy": o.accuracy,
            "mean_distance_m": o.mean_distance, "median_distance_m": o.median_distance,
            "p90_distance_m": o.p90_distance, "completeness": o.completeness, "fscore": o.fscore,
            "consistency_m": o.consistency, "glass_points": g.points, "glass_accuracy": g.accuracy,
            "glass_completeness": g.completeness, "seconds": rec.seconds}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/comparison"))
    parser.add_argument("--scenes", default=",".join(MODES), help="comma separated subset")
    parser.add_argument("--duration", type=float, default=None,
                        help="drive only the first DURATION seconds of each scene's trajectory "
                             "(default: all of it)")
    parser.add_argument("--width", type=int, default=800,
                        help="surfel camera image width [pixels] (default 800)")
    parser.add_argument("--spp", type=int, default=8,
                        help="surfel camera samples per pixel (default 8, denoised)")
    parser.add_argument("--step", type=float, default=5.0, help="OFDM beam grid step [deg]")
    parser.add_argument("--preset", choices=("default", "paper"), default="paper",
                        help="sonar model (SonarConfig.preset; default paper)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--quick", action="store_true",
                        help="room_glass and workshop, their first 0.5 s, 320 px surfel images, "
                             "20 deg OFDM grid, 2 cm ground truth (for the test suite)")
    args = parser.parse_args(argv)
    scenes = args.scenes.split(",")
    unknown = sorted(set(scenes) - set(MODES))
    if unknown:
        raise ValueError(f"--scenes: unknown scene(s) {', '.join(unknown)}; known: {', '.join(MODES)}")
    if args.duration is not None and args.duration <= 0:
        raise ValueError(f"--duration must be > 0 [s], got {args.duration}")
    settings = RunSettings(args.duration, args.width, args.spp, np.radians(args.step), 0.01,
                           args.preset, args.seed)
    if args.quick:
        scenes = ["room_glass", "workshop"]
        settings = replace(settings, duration=0.5, width=320, step=np.radians(20.0), spacing=0.02)
    results, infos = {}, {}
    for name in scenes:
        results[name], infos[name] = run_scene(name, settings)
    write_outputs(args.out, results, infos)
    return 0


def _x100(x) -> str:
    """A fraction in % or a length in cm, one decimal; '-' for NaN."""
    return f"{100 * x:.1f}" if np.isfinite(x) else "-"


def write_outputs(out: Path, results: dict, infos: dict) -> None:
    out.mkdir(parents=True, exist_ok=True)
    rows, material_rows = [], []
    for scene, recs in results.items():
        for key, rec in recs.items():
            rows.append(summary_row(scene, infos[scene], key, rec))
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
                              title=f"{scene}: {label(key, infos[scene]['mode'])}, "
                                    f"{infos[scene]['driven']:.1f} s driven")
    md = ["| scene | sensor | driven s | frames | points | accuracy % (< 2 cm) | median cm | "
          "p90 cm | completeness % | F-score % | consistency cm | glass points | "
          "glass accuracy % | glass completeness % | time s |",
          "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    md += [f"| {r['scene']} | {label(r['sensor'], r['mode'])} | {r['driven_s']:.1f} | "
           f"{r['frames']} | {r['points']} | {_x100(r['accuracy'])} | "
           f"{_x100(r['median_distance_m'])} | "
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
    save_comparison_figure(out / "comparison.png", results, infos)
    print("\n".join(md))
    print(f"Wrote {out}/comparison.csv, .md, per_material.csv, .md, comparison.png and a PLY and "
          f"error figure per reconstruction in {out}/<scene>/")


def save_comparison_figure(path: Path, results: dict, infos: dict,
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
    fig.suptitle("Top views [m], each scene's trajectory driven at the sensors' rates (black: the "
                 "sensor head once a second); floor and ceiling removed; grey: ground-truth "
                 "walls at 1 m", fontsize=10)
    fig.tight_layout(rect=(0, 0.07, 1, 0.98))
    bar = fig.add_axes((0.25, 0.045, 0.5, 0.01))
    fig.colorbar(im, cax=bar, orientation="horizontal",
                 label=f"distance to ground truth [cm] (clipped at {100 * ERROR_CLIP:.0f})")
    save_png(fig, path)


if __name__ == "__main__":
    sys.exit(main())
