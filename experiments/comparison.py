"""Reconstruction comparison (the paper's Fig. 7): sonar, VLP-16 class LiDAR and Kinect v2 class
depth camera on the four shipped scenes (and ``--varied N`` generated rooms), both sonar presets,
from the same drive, scored against ground truth.

The sonar runs in the mode the paper uses for each shipped scene: surfel scanning on the
structural scenes (room_glass, structure), OFDM repeated scanning on the furnished ones (office,
workshop); a generated room (``mitsonar.scene.varied``: furnished, coloured walls, glass) is
mapped in both modes. Every sensor drives the scene's default trajectory (its first
``--duration`` seconds, at most all of it) at the trajectory's speed (0.2 m/s, 30 deg/s on the
spot) and takes what it would take there in that time, at its own rate, in the same loaded
scene: the sonar fires OFDM frames back to back (4.8 frames/s with 117 beams) in repeated mode;
in surfel mode the camera takes a 25 Hz frame whenever the sonar is free and the sonar pings
every 30 ms (its listening time); the VLP-16 turns at 10 Hz (each column fired at its own time),
the Kinect v2 takes 30 frames/s. Every beam, frame or column is placed with the pose it was
taken from (no odometry drift), so consistency reflects the sensors alone. The LiDAR and the
depth camera do not depend on the sonar's preset: one row each per scene.

Sonar settings: ``--presets`` (both by default: the physical 'default' and 'paper', on which the
surfel pipeline is tuned; see docs/reconstruction.md). Surfel mode uses 800 px images (at 400 px
room_glass's planes grow wrongly). Repeated mode adds broadband transducers (20 kHz at -6 dB:
the OFDM tones span 32-48 kHz), a 5 deg beam grid (the paper's 13 x 9 beams per frame), every
echo of each beam (``RepeatedMapSpec.echoes='all'``, the most complete at the same accuracy in
experiments/imaging.py) and 5 cm voxels (the paper's voxel map); each beam is registered with its
own pose. ``--repeated-scan chirp`` fires single-ping receive images driven by a 30-50 kHz sweep
instead (six per camera image, each point registered with its image's pose; docs/imaging.md);
``chirp_wide`` drives them with RTIS's 20-80 kHz sweep behind the ``paper`` preset's ideal
transducers (``SonarConfig.with_wide_sweep``; the broadband transducers pass 20 kHz, so ``paper``
only), ``chirp_wide_bands`` the same with the images' trust rule read in three sub-bands and
their points placed at its peak (``mitsonar.signal.imaging_settings.WIDE_SWEEP_SETTINGS``),
``chirp_wide_defocused`` those sent by the whole array defocused (``imaging_sonar.DEFOCUSED``).

Scoring (:func:`mitsonar.evaluation.metrics.evaluate`, 2 cm threshold). Every cloud is first
thinned to one point per 1 cm voxel, the ground truth's resolution (:class:`VoxelThinner`: a
seeded random point of each voxel, not the mean, so noise is not averaged away; the baselines'
frames as they come). Completeness counts the ground-truth samples in line of sight of the
sensor head at least once a second along the drive (glass occludes), the same for all sensors;
``sonar_in_view_pct`` is the share of it that the sonar's 60 x 40 deg field of view covers within
its range and line of sight from poses 0.2 s apart
(:func:`~mitsonar.evaluation.coverage.in_view_along`), which no sonar map can exceed. Beside it,
at the voxel map's resolution: every sensor's thinned cloud is voxelised at 5 cm (the mean of
each voxel's points, :func:`voxel_means`, which leaves the repeated map as it is) and
scored at 5 cm (``*_voxel_pct``). Glass is also scored on its own. Completeness is also measured
at ``--checkpoints`` times along the drive (the cloud taken so far) against the distance driven.

Writes comparison.csv/.md (a row per scene, sensor, preset and mode), per_material.csv/.md,
comparison.png (top views coloured by the distance to the ground truth, scenes x
reconstructions), completeness.csv and completeness.png (against the distance driven), with
``--varied`` also comparison_varied.csv/.md (the rooms' rows) and comparison_varied.png, and per
reconstruction <scene>/<sensor>[_<mode>_<preset>].ply (points with their distance).

    .venv/bin/python experiments/comparison.py --out out/comparison            # hours, 2 cores
    .venv/bin/python experiments/comparison.py --quick --out out/comparison    # ~2 min
    .venv/bin/python experiments/comparison.py --scenes workshop --presets default \
        --baselines lidar --repeated-scan chirp --out out/comparison_chirp   # ~1 h a scene
    .venv/bin/python experiments/comparison.py --scenes workshop --presets paper \
        --baselines lidar --repeated-scan chirp_wide --out out/comparison_wide   # ~1.5 h a scene
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
from mitsonar.evaluation.coverage import (Curve, covered_fraction, distance_driven,
                                          in_view_along, save_completeness_figure)
from mitsonar.evaluation.metrics import (DEFAULT_THRESHOLD, Evaluation, evaluate,
                                         save_error_figure, visible_from)
from mitsonar.recon.thinning import VoxelThinner, voxel_means
from mitsonar.evaluation.topviews import Panel, SceneView, save_top_views
from mitsonar.io import write_ply, write_table
from mitsonar.recon.repeated import RepeatedMapSpec, build_voxel_map, scan_repeated
from mitsonar.recon.surfels import SurfelSettings, map_surfels_along
from mitsonar.recon.surfels.map import build_map
from mitsonar.recon.voxelmap import VoxelMapSettings
from mitsonar.signal.imaging_settings import WIDE_SWEEP_SETTINGS, ImagingSettings
from mitsonar.scene.mesh import sample_surface, scene_mesh
from mitsonar.sensors.baselines import DepthCamera, Lidar, sweep
from mitsonar.sensors.imaging_sonar import DEFOCUSED, TransmitSettings
from mitsonar.sensors.trajectory import sensor_poses

SCENES = Path(__file__).resolve().parents[1] / "scenes"
#: The sonar's mode per shipped scene, as in the paper; generated rooms get both.
MODES = {"room_glass": "surfel", "structure": "surfel", "office": "repeated", "workshop": "repeated"}
VARIED_MODES = ("surfel", "repeated")
PRESETS = ("default", "paper")
BASELINES = {"lidar": Lidar, "depth_camera": DepthCamera}
#: Edge of the thinning voxels [m] (the ground truth's sample spacing).
THIN_VOXEL = 0.01
#: Voxel size of the repeated-scanning map and of every cloud's voxel score [m].
MAP_VOXEL = 0.05
#: The ground truth counts as observable where the sensor head sees it at least once in this
#: many seconds of driving [s].
VIEW_PERIOD = 1.0
#: The sonar's view (``sonar_in_view_pct``) is taken from poses this far apart along the drive
#: [s] (about its frame period).
IN_VIEW_PERIOD = 0.2
#: What repeated mode can fire (:class:`RunSettings` ``repeated_scan``) and the mode each row
#: reads.
REPEATED_SCANS = {"ofdm": "repeated", "chirp": "repeated-chirp",
                  "chirp_wide": "repeated-chirp-wide",
                  "chirp_wide_bands": "repeated-chirp-wide-bands",
                  "chirp_wide_defocused": "repeated-chirp-wide-defocused"}
#: The images' points rule and transmission of the repeated scans that are not
#: ``(ImagingSettings(), TransmitSettings())``.
REPEATED_IMAGES = {"chirp_wide_bands": (WIDE_SWEEP_SETTINGS, TransmitSettings()),
                   "chirp_wide_defocused": (WIDE_SWEEP_SETTINGS, DEFOCUSED)}


@dataclass(frozen=True)
class RunSettings:
    """How each scene is reconstructed.

    Attributes:
        duration: seconds of each scene's trajectory driven (at most all of it); None: all.
        width: surfel camera image width [pixels]; spp: its samples per pixel.
        step: OFDM beam grid step [rad].
        spacing: ground-truth sample spacing [m].
        presets: sonar presets (``SonarConfig.preset``), each a row.
        baselines: keys of :data:`BASELINES` driven beside the sonar.
        checkpoints: completeness is measured this many times along the drive.
        seed: seeds the sonar, the baselines' noise, the samples and the thinning.
        repeated_scan: what repeated mode fires: "ofdm" (OFDM frames, every echo of each beam),
            "chirp" (single-ping receive images driven by a 30-50 kHz frequency sweep behind
            broadband transducers, ``RepeatedMapSpec.scan='imaging'``) or "chirp_wide" (the same
            images driven by ``SonarConfig.with_wide_sweep``, ``paper`` preset only) or
            "chirp_wide_bands" (those with ``WIDE_SWEEP_SETTINGS``) or "chirp_wide_defocused"
            (those sent by the whole array defocused, ``DEFOCUSED``); each row's mode is the
            scan's in :data:`REPEATED_SCANS`.
        dither: OFDM beam grid dithered over ``dither`` x ``dither`` offsets from frame to frame
            (``RepeatedMapSpec.dither``; 1: the paper's fixed grid); the rows' mode reads
            "repeated-dither<n>" then.
        workers: processes that simulate repeated mode's frames at once (the same frames;
            ``scan_repeated``).
    """

    duration: float | None
    width: int
    spp: int
    step: float
    spacing: float
    presets: tuple
    baselines: tuple
    checkpoints: int
    seed: int
    repeated_scan: str = "ofdm"
    dither: int = 1
    workers: int = 1


@dataclass(frozen=True)
class Reconstruction:
    """One scored cloud.

    Attributes:
        sensor: 'sonar' or a key of :data:`BASELINES`; mode: the sonar's ('' otherwise);
        preset: the sonar's ('' otherwise).
        points: (N, 3) [m] thinned; raw_points: points before thinning.
        frames: the sensor's frames along the drive (sonar: camera frames in surfel mode, OFDM
            frames in repeated mode).
        evaluation: at 2 cm; voxel: the :data:`MAP_VOXEL` voxelised cloud at that threshold.
        curve: completeness along the drive (:class:`Curve`).
        seconds: wall-clock time of the reconstruction [s].
        diagnosis: what the sonar's pipeline kept and dropped (one line; '' for the others).
    """

    sensor: str
    mode: str
    preset: str
    points: np.ndarray
    raw_points: int
    frames: int
    evaluation: Evaluation
    voxel: Evaluation
    curve: Curve
    seconds: float
    diagnosis: str = ""


def sonar_run(scene, mode: str, preset: str, trajectory, settings: RunSettings, checkpoints,
              progress):
    """Drive the sonar: (thinned cloud at each checkpoint time [s] (the last the whole drive),
    raw points, frames, diagnosis)."""
    config = mitsonar.SonarConfig.preset(preset)
    if mode == "surfel":
        sonar = mitsonar.Sonar(scene, config)
        surfel = SurfelSettings(image_width=settings.width, spp=settings.spp, seed=settings.seed)
        final = map_surfels_along(sonar, trajectory, surfel, settings.duration, progress)
        clouds = []
        for t in checkpoints:  # one checkpoint's map at a time (each holds every pose's mesh)
            m = build_map(final.scans[:int(np.sum(final.times <= t + 1e-9))], final.settings) \
                if t < checkpoints[-1] else final
            clouds.append(m.sample(THIN_VOXEL, seed=settings.seed)[0] if len(m.triangles)
                          else np.zeros((0, 3)))
        rejected = ", ".join(f"{v} {k.replace('_', ' ')}" for k, v in final.rejected.items())
        diagnosis = (f"{len(final.surfel_pose)} surfels registered ({rejected}), "
                     f"{len(final.groups)} planes")
        return clouds, len(clouds[-1]), len(final.scans), diagnosis
    chirp = settings.repeated_scan != "ofdm"
    if settings.repeated_scan.startswith("chirp_wide"):
        config = config.with_wide_sweep()
    else:
        config = replace(config, transducer=mitsonar.Transducer.broadband(),
                         pulse=mitsonar.Chirp() if chirp else config.pulse)
    sonar = mitsonar.Sonar(scene, config)
    imaging, transmit = REPEATED_IMAGES.get(settings.repeated_scan,
                                            (ImagingSettings(), TransmitSettings()))
    spec = RepeatedMapSpec(duration=settings.duration, scan_step=settings.step, echoes="all",
                           dither=settings.dither,
                           seed=settings.seed, voxels=VoxelMapSettings(voxel_size=MAP_VOXEL),
                           scan="imaging" if chirp else "ofdm",
                           imaging=imaging, transmit=transmit)
    scanned, camera = scan_repeated(sonar, trajectory, spec, progress, settings.workers)
    starts = np.array([s.start_time for s in scanned])
    clouds = [build_voxel_map([s for s, t0 in zip(scanned, starts) if t0 <= t + 1e-9], camera,
                              spec).positions for t in checkpoints]
    echoes = sum(len(s.points) for s in scanned)
    if chirp:
        images = sum(len(s.images) for s in scanned)
        diagnosis = (f"{images} images, {echoes / images:.0f} points an image -> "
                     f"{len(clouds[-1])} voxels")
    else:
        detected = np.mean(np.concatenate([s.frame.detected for s in scanned]))
        diagnosis = (f"{100 * detected:.0f} % of beams detect, {echoes / len(scanned):.0f} "
                     f"echoes a frame -> {len(clouds[-1])} voxels")
    return clouds, echoes, len(scanned), diagnosis


def baseline_run(key: str, scene, trajectory, settings: RunSettings, checkpoints, label: str):
    """Drive a LiDAR or depth camera: thinned clouds at the checkpoint times, raw points,
    frames."""
    from tqdm import tqdm

    sensor = BASELINES[key](scene)
    thinner = VoxelThinner(THIN_VOXEL, seed=settings.seed)
    times = trajectory.times_at_rate(sensor.model.rate, settings.duration)
    clouds, pending = [], list(checkpoints)
    for start, points in tqdm(sweep(sensor, trajectory, settings.duration, settings.seed),
                              total=len(times), desc=label, unit="frame", file=sys.stderr):
        while len(pending) > 1 and start > pending[0] + 1e-9:  # frames up to the checkpoint
            clouds.append(thinner.result())
            pending.pop(0)
        thinner.add(points)
    clouds += [thinner.result()] * len(pending)
    return clouds, thinner.raw, len(times)


def score(sensor, mode, preset, clouds, raw, frames, seconds, truth, diagnosis=""):
    """A :class:`Reconstruction` from the clouds at the checkpoints (the last: the whole
    drive)."""
    mesh, samples, observable, distance = truth
    observed = samples.points[observable]
    points = clouds[-1]
    name = SENSORS[sensor] if sensor != "sonar" else f"sonar {mode}, {preset}"
    curve = Curve(name, distance,
                  np.array([covered_fraction(c, observed, DEFAULT_THRESHOLD) for c in clouds]),
                  np.array([covered_fraction(voxel_means(c, MAP_VOXEL), observed, MAP_VOXEL)
                            for c in clouds]))
    return Reconstruction(
        sensor, mode, preset, points, raw, frames,
        evaluate(points, mesh, samples=samples, observable=observable),
        evaluate(voxel_means(points, MAP_VOXEL), mesh, MAP_VOXEL, samples=samples,
                 observable=observable), curve, seconds, diagnosis)


def run_scene(name: str, path: Path, modes, settings: RunSettings) -> tuple[list, dict]:
    """Every reconstruction of the scene, and what the figures need about it."""
    from tqdm import tqdm

    trajectory = mitsonar.Trajectory.from_scene(path)
    settings = replace(settings, duration=None if settings.duration is None
                       else min(settings.duration, trajectory.duration))
    driven = trajectory.driven(settings.duration)
    checkpoints = driven * np.arange(1, settings.checkpoints + 1) / settings.checkpoints
    scene = mitsonar.load_scene(path)
    mesh = scene_mesh(scene)
    samples = sample_surface(mesh, settings.spacing, settings.seed)
    views = trajectory.poses_at(np.arange(0.0, driven + 1e-9, VIEW_PERIOD))
    viewpoints = np.array([p.translation for p in sensor_poses(views)])
    truth = (mesh, samples, visible_from(scene, samples.points, viewpoints),
             distance_driven(trajectory, checkpoints))
    in_view = in_view_along(scene, samples.points[truth[2]], trajectory, driven,
                            mitsonar.SonarConfig(), IN_VIEW_PERIOD)  # every preset's view
    recs = []
    for mode in modes:
        shown = REPEATED_SCANS[settings.repeated_scan] if mode == "repeated" else mode
        if mode == "repeated" and settings.repeated_scan == "ofdm" and settings.dither > 1:
            shown += f"-dither{settings.dither}"
        for preset in settings.presets:
            start = time.perf_counter()
            with tqdm(desc=f"{name}: sonar ({shown}, {preset})", file=sys.stderr) as bar:
                def step(*at):  # surfel mode: the time driven [s]; repeated: (frame, frames)
                    bar.total = round(driven, 1) if mode == "surfel" else at[1]
                    bar.update((round(at[0], 1) - bar.n) if mode == "surfel" else 1)

                clouds, raw, frames, diagnosis = sonar_run(scene, mode, preset, trajectory,
                                                           settings, checkpoints, step)
            recs.append(score("sonar", shown, preset, clouds, raw, frames,
                              time.perf_counter() - start, truth, diagnosis))
    for key in settings.baselines:
        start = time.perf_counter()
        clouds, raw, frames = baseline_run(key, scene, trajectory, settings, checkpoints,
                                           f"{name}: {key}")
        recs.append(score(key, "", "", clouds, raw, frames, time.perf_counter() - start, truth))
    for r in recs:
        o, v = r.evaluation.overall, r.voxel.overall
        print(f"{name} {r.curve.label:22s}: {r.frames} frames, {o.points} points, "
              f"{100 * o.accuracy:.1f} % within 2 cm, completeness {100 * o.completeness:.1f} %, "
              f"at {100 * MAP_VOXEL:.0f} cm voxels {100 * v.completeness:.1f} %, "
              f"{r.seconds:.0f} s {r.diagnosis}", file=sys.stderr)
    info = json.loads(path.with_name("ground_truth.json").read_text())
    band = (samples.points[:, 2] > 0.9) & (samples.points[:, 2] < 1.1)  # the scene at 1 m
    outline = samples.points[band][np.random.default_rng(0).permutation(int(band.sum()))[:40_000]]
    return recs, {"height": info["height_m"], "extent": info["interior_extent_m"],
                  "viewpoints": viewpoints, "outline": outline, "driven": driven,
                  "sonar_in_view": float(np.mean(in_view)) if len(in_view) else float("nan"),
                  "varied": name not in MODES}


def scene_list(scenes: str, varied: int, out: Path) -> list[tuple[str, Path, tuple]]:
    """(name, scene.xml, sonar modes) of the shipped scenes asked for ('none': no shipped
    scene) and of ``varied`` generated rooms varied_0 ... (written under ``out``/rooms)."""
    from mitsonar.scene.varied.room import write_varied_rooms

    names = [] if scenes == "none" else scenes.split(",")
    unknown = sorted(set(names) - set(MODES))
    if unknown:
        raise ValueError(f"--scenes: unknown scene(s) {', '.join(unknown)}; known: "
                         f"{', '.join(MODES)} (or none)")
    listed = [(n, SCENES / n / "scene.xml", (MODES[n],)) for n in names]
    rooms = write_varied_rooms(out / "rooms", range(varied)) if varied else []
    return listed + [(p.parent.name, p, VARIED_MODES) for p in rooms]


def parse_args(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/comparison"))
    parser.add_argument("--scenes", default=",".join(MODES),
                        help="comma separated shipped scenes, or none")
    parser.add_argument("--varied", type=int, default=0,
                        help="also N generated rooms (varied_0 ...), both sonar modes")
    parser.add_argument("--duration", type=float, default=None,
                        help="drive only the first DURATION seconds of each scene's trajectory "
                             "(at most all of it; default: all of it)")
    parser.add_argument("--presets", default=",".join(PRESETS),
                        help="sonar presets, comma separated (default: default,paper)")
    parser.add_argument("--baselines", default=",".join(BASELINES),
                        help="baseline sensors, comma separated (lidar, depth_camera) or none")
    parser.add_argument("--checkpoints", type=int, default=6,
                        help="completeness measured this many times along the drive (6)")
    parser.add_argument("--width", type=int, default=800,
                        help="surfel camera image width [pixels] (default 800)")
    parser.add_argument("--spp", type=int, default=8,
                        help="surfel camera samples per pixel (default 8, denoised)")
    parser.add_argument("--step", type=float, default=5.0, help="OFDM beam grid step [deg]")
    parser.add_argument("--dither", type=int, default=1,
                        help="OFDM beam grid shifted through DITHER x DITHER offsets of "
                             "step / DITHER from frame to frame (default 1: the paper's fixed "
                             "grid)")
    parser.add_argument("--repeated-scan", choices=tuple(REPEATED_SCANS), default="ofdm",
                        help="repeated mode fires OFDM frames (ofdm, default) or single-ping "
                             "images driven by a 30-50 kHz sweep (chirp) or by a 20-80 kHz "
                             "one (chirp_wide, --presets paper only; chirp_wide_bands: its "
                             "trust rule read in sub-bands; chirp_wide_defocused: those sent "
                             "by the whole array defocused; docs/imaging.md)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=1,
                        help="processes that simulate repeated mode's frames at once, the same "
                             "frames (default 1; 2 on 2 cores: about twice as fast with the "
                             "paper preset)")
    parser.add_argument("--quick", action="store_true",
                        help="room_glass and workshop, their first 0.3 s, 320 px surfel images, "
                             "20 deg OFDM grid, 2 cm ground truth, 2 checkpoints (test suite)")
    args = parser.parse_args(argv)
    presets = tuple(args.presets.split(","))
    if not presets or set(presets) - set(PRESETS):
        parser.error(f"--presets: give some of {', '.join(PRESETS)}, got {args.presets!r}")
    if args.repeated_scan.startswith("chirp_wide"):
        for preset in presets:
            try:
                mitsonar.SonarConfig.preset(preset).with_wide_sweep()
            except ValueError as error:
                parser.error(f"--repeated-scan {args.repeated_scan} needs --presets paper: "
                             f"the {preset!r} preset: {error}")
    baselines = () if args.baselines == "none" else tuple(args.baselines.split(","))
    if set(baselines) - set(BASELINES):
        parser.error(f"--baselines: give some of {', '.join(BASELINES)} or none, "
                     f"got {args.baselines!r}")
    for name, value, low in (("--duration", args.duration, 0.0), ("--varied", args.varied, -1),
                             ("--checkpoints", args.checkpoints, 0), ("--dither", args.dither, 0),
                             ("--workers", args.workers, 0)):
        if value is not None and value <= low:
            parser.error(f"{name} must be > {low}, got {value}")
    return args, presets, baselines


def main(argv=None) -> int:
    args, presets, baselines = parse_args(argv)
    settings = RunSettings(args.duration, args.width, args.spp, np.radians(args.step), 0.01,
                           presets, baselines, args.checkpoints, args.seed, args.repeated_scan,
                           args.dither, args.workers)
    scenes = args.scenes
    if args.quick:
        scenes = "room_glass,workshop" if args.scenes == ",".join(MODES) else args.scenes
        settings = replace(settings, duration=0.3, width=320, step=np.radians(20.0),
                           spacing=0.02, checkpoints=2)
    try:
        listed = scene_list(scenes, args.varied, args.out)
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    results, infos = {}, {}
    for name, path, modes in listed:
        results[name], infos[name] = run_scene(name, path, modes, settings)
    write_outputs(args.out, results, infos)
    return 0


SENSORS = {"sonar": "sonar", "lidar": "VLP-16", "depth_camera": "Kinect v2"}
#: A sonar panel this incomplete (at 2 cm and at the voxel size) gets its diagnosis written on.
NEARLY_EMPTY = 0.05


def label(r: Reconstruction) -> str:
    """Display name: 'sonar surfel, paper', 'VLP-16', ..."""
    return f"sonar {r.mode}, {r.preset}" if r.sensor == "sonar" else SENSORS[r.sensor]


def _pct(x) -> float:
    return 100.0 * x if np.isfinite(x) else float("nan")


def summary_row(scene: str, info: dict, r: Reconstruction, lidar) -> dict:
    """The CSV row of a reconstruction; ``lidar``: the scene's VLP-16 reconstruction or None.
    completeness_of_lidar_pct: the sonar's completeness over the VLP-16's, as the issue's goals
    compare them (surfel mode at 2 cm, repeated mode at the voxel size); sonar_in_view_pct: the
    share of the observable ground truth in the sonar's field of view along the drive, the
    ceiling of its completeness (the scene's, in every row)."""
    o, v, g = r.evaluation.overall, r.voxel.overall, r.evaluation.per_optics["transparent"]
    ratio = float("nan")
    if r.sensor == "sonar" and lidar is not None:
        ours, theirs = ((o, lidar.evaluation.overall) if r.mode == "surfel"
                        else (v, lidar.voxel.overall))
        ratio = ours.completeness / theirs.completeness if theirs.completeness > 0 else ratio
    return {"scene": scene, "sensor": r.sensor, "preset": r.preset, "mode": r.mode,
            "driven_s": info["driven"], "frames": r.frames, "raw_points": r.raw_points,
            "points": o.points, "accuracy_pct": _pct(o.accuracy),
            "median_error_cm": _pct(o.median_distance), "p90_error_cm": _pct(o.p90_distance),
            "completeness_pct": _pct(o.completeness), "fscore_pct": _pct(o.fscore),
            "voxel_points": v.points, "accuracy_voxel_pct": _pct(v.accuracy),
            "completeness_voxel_pct": _pct(v.completeness), "fscore_voxel_pct": _pct(v.fscore),
            "completeness_of_lidar_pct": _pct(ratio), "consistency_cm": _pct(o.consistency),
            "glass_points": g.points, "glass_accuracy_pct": _pct(g.accuracy),
            "glass_completeness_pct": _pct(g.completeness),
            "sonar_in_view_pct": _pct(info["sonar_in_view"]), "wall_s": r.seconds}


def _cell(x, digits: int = 1) -> str:
    return f"{x:.{digits}f}" if np.isfinite(x) else "-"


def markdown_table(rows: list[dict]) -> list[str]:
    """The table for people (percentages, centimetres)."""
    md = ["| scene | sensor | driven s | frames | points | within 2 cm % | median cm | p90 cm | "
          "complete % | 5 cm voxels complete % | F-score % | of VLP-16 % | glass points | "
          "glass within 2 cm % | glass complete % | in sonar's view % | wall s |",
          "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        name = (f"sonar {r['mode']}, {r['preset']}" if r["sensor"] == "sonar"
                else SENSORS[r["sensor"]])
        md.append(f"| {r['scene']} | {name} | {r['driven_s']:.1f} | {r['frames']} | "
                  f"{r['points']} | {_cell(r['accuracy_pct'])} | {_cell(r['median_error_cm'])} | "
                  f"{_cell(r['p90_error_cm'])} | {_cell(r['completeness_pct'])} | "
                  f"{_cell(r['completeness_voxel_pct'])} | {_cell(r['fscore_pct'])} | "
                  f"{_cell(r['completeness_of_lidar_pct'], 0)} | {r['glass_points']} | "
                  f"{_cell(r['glass_accuracy_pct'])} | {_cell(r['glass_completeness_pct'])} | "
                  f"{_cell(r['sonar_in_view_pct'])} | {r['wall_s']:.0f} |")
    return md


def varied_summary(rows: list[dict]) -> list[str]:
    """Per sonar mode and preset over the generated rooms: median and minimum accuracy, median
    completeness against the VLP-16's (the issue's goals for varied rooms)."""
    md = ["| sonar | rooms | median within 2 cm % | min within 2 cm % | rooms >= 90 % | "
          "median of VLP-16 % |", "|---|---:|---:|---:|---:|---:|"]
    for mode in VARIED_MODES:
        for preset in PRESETS:
            mine = [r for r in rows if r["sensor"] == "sonar" and (r["mode"], r["preset"])
                    == (mode, preset)]
            if not mine:
                continue
            acc = np.array([r["accuracy_pct"] for r in mine])
            ratio = np.array([r["completeness_of_lidar_pct"] for r in mine])
            md.append(f"| {mode}, {preset} | {len(mine)} | {_cell(np.nanmedian(acc))} | "
                      f"{_cell(np.nanmin(acc))} | {int(np.sum(acc >= 90))} | "
                      f"{_cell(np.nanmedian(ratio) if np.isfinite(ratio).any() else np.nan, 0)} |")
    return md


def _panels(scene: str, info: dict, recs: list) -> tuple:
    view = SceneView(info["height"], info["extent"], info["viewpoints"], info["outline"])
    panels = []
    for r in recs:
        o, v = r.evaluation.overall, r.voxel.overall
        note = ""
        if r.sensor == "sonar" and max(o.completeness, v.completeness) < NEARLY_EMPTY:
            note = (f"nearly empty: {r.frames} frames in {info['driven']:.1f} s;\n"
                    + r.diagnosis.replace(", ", ",\n", 1))
        panels.append(Panel(f"{scene}: {label(r)}\n{_cell(_pct(o.accuracy))} % within 2 cm, "
                            f"complete {_cell(_pct(o.completeness))} % "
                            f"({_cell(_pct(v.completeness))} % at 5 cm)",
                            r.points, r.evaluation.distance, note))
    return view, panels


def write_outputs(out: Path, results: dict, infos: dict) -> None:
    """The tables, figures and point clouds (module docstring)."""
    out.mkdir(parents=True, exist_ok=True)
    rows, material_rows, curve_rows, curves = [], [], [], {}
    for scene, recs in results.items():
        lidar = next((r for r in recs if r.sensor == "lidar"), None)
        curves[scene] = [r.curve for r in recs]
        for r in recs:
            rows.append(summary_row(scene, infos[scene], r, lidar))
            keys = {"scene": scene, "sensor": r.sensor, "preset": r.preset, "mode": r.mode}
            material_rows += [{**keys, "material": m, "points": s.points, "samples": s.samples,
                               "accuracy_pct": _pct(s.accuracy),
                               "completeness_pct": _pct(s.completeness),
                               "fscore_pct": _pct(s.fscore),
                               "median_error_cm": _pct(s.median_distance)}
                              for m, s in r.evaluation.per_material.items()]
            curve_rows += [{**keys, "distance_m": d, "completeness_pct": _pct(c),
                            "completeness_voxel_pct": _pct(cv)} for d, c, cv in
                           zip(r.curve.distance, r.curve.completeness, r.curve.completeness_voxel)]
            suffix = f"_{r.mode}_{r.preset}" if r.sensor == "sonar" else ""
            write_ply(out / scene / f"{r.sensor}{suffix}.ply", r.points,
                      scalars={"distance_m": r.evaluation.distance})
            if not infos[scene]["varied"]:
                save_error_figure(out / scene / f"{r.sensor}{suffix}_errors.png", r.points,
                                  r.evaluation.distance, DEFAULT_THRESHOLD,
                                  title=f"{scene}: {label(r)}, {infos[scene]['driven']:.1f} s "
                                        f"driven")
    shipped = [r for r in rows if not infos[r["scene"]]["varied"]]
    varied = [r for r in rows if infos[r["scene"]]["varied"]]
    for name, part, extra in (("comparison", shipped, []),
                              ("comparison_varied", varied, [""] + varied_summary(varied))):
        if part:
            md = markdown_table(part) + extra
            write_table(out / f"{name}.csv", part, md)
            print("\n".join(md))
            title = ("Top views [m], each scene's trajectory driven at the sensors' rates "
                     "(black: the sensor head once a second); floor and ceiling removed; grey: "
                     "ground-truth walls at 1 m")
            save_top_views(out / f"{name}.png", {s: _panels(s, infos[s], results[s])
                                                 for s in dict.fromkeys(r["scene"] for r in part)},
                           title)
    pm = ["| scene | sensor | preset | material | points | samples | within 2 cm % | "
          "complete % | F-score % | median cm |", "|---|---|---|---|---:|---:|---:|---:|---:|---:|"]
    pm += [f"| {r['scene']} | {r['sensor']} {r['mode']} | {r['preset']} | {r['material']} | "
           f"{r['points']} | {r['samples']} | {_cell(r['accuracy_pct'])} | "
           f"{_cell(r['completeness_pct'])} | {_cell(r['fscore_pct'])} | "
           f"{_cell(r['median_error_cm'])} |" for r in material_rows]
    write_table(out / "per_material.csv", material_rows, pm)
    write_table(out / "completeness.csv", curve_rows)
    save_completeness_figure(out / "completeness.png", curves, DEFAULT_THRESHOLD, MAP_VOXEL)
    print(f"Wrote {out}/comparison.csv, .md, .png, per_material.csv, .md, completeness.csv, "
          f".png, comparison_varied.* with --varied, and a PLY per reconstruction in "
          f"{out}/<scene>/")


if __name__ == "__main__":
    sys.exit(main())
