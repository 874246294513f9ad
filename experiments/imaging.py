"""Scanning strategies (issue 28): points per second of driving, their accuracy and the map's
completeness for the sequential scan, OFDM frames and single-ping receive imaging.

For each scene (office, workshop) and sonar configuration (:data:`PRESETS`: the physical
default ``SonarConfig()``, the same with broadband transducers, ``Transducer.broadband()``, as
issue 28 measured the physical default and as repeated mode maps, and
``SonarConfig.preset('paper')``) the robot drives the scene's default trajectory (0.2 m/s, 30
deg/s on the spot) and the sonar scans at its own rate, every point registered with the pose
it was measured from (no odometry drift):

* sequential: single-beam pings over the 117-beam 5 deg grid, one listening time
  (``SonarConfig.record_duration``) apart, each from the robot's pose at its own firing time; a
  sweep of the grid is a frame (3.6 s with the paper preset, 4.0 s with the default).
* OFDM: frames of the 117 coded beams back to back (208.5 ms each, 25 codes per cycle, each
  beam from its own pose, :class:`~mitsonar.sensors.ofdm_sonar.OfdmSonar`); ``ofdm_trusted``
  and ``ofdm_image`` decode the same frames otherwise (:data:`DECODINGS`: every echo and range
  cell trusted by its arrival direction alone, inside :data:`TRUSTED_CONE` of the axis; receive
  imaging over each beam's lit cone, :mod:`mitsonar.signal.cone`).
* imaging: single-ping receive images (:class:`~mitsonar.sensors.imaging_sonar.ImagingSonar`,
  one transmit element), one per listening cycle (30.4 / 34.0 ms), also at the trust
  thresholds of :data:`IMAGING_TRUST` (``<scan>_trust_<threshold>``). ``imaging_chirp``: the
  element driven by a 4 ms 30-50 kHz sweep (``Chirp``, :data:`CHIRP_SCANS`), as RTIS images;
  ``imaging_chirp_wide``: a 4 ms 20-80 kHz sweep (``paper``) at 250 kHz, traced at five
  frequency nodes (docs/imaging.md); ``_bands``: its trust rule read in three sub-bands, each
  point at that coherence's peak (``WIDE_SWEEP_SETTINGS``, :data:`TRUST`); ``_defocused``: the
  same rule, the sweep sent by the whole array defocused over the field of view
  (``imaging_sonar.DEFOCUSED``, :data:`TRANSMIT`; 14 dB over one element).

Echoes. The sequential and OFDM beams are simulated once with ``DetectionSettings.echoes =
'cells'``; one simulation gives three point sets: ``first`` (each beam's strongest trusted
echo), ``all`` (every resolved peak) and ``cells`` (every row: the peaks, then the range cells
across extended echoes).

Scoring, with the comparison's definitions for every sensor (``experiments/comparison.py``):
each cloud is thinned to one point per 1 cm voxel (``VoxelThinner``) and scored as
:func:`mitsonar.evaluation.metrics.evaluate` does: ``accuracy_pct`` is the share of its points
within 2 cm of the mesh, ``completeness_5cm_pct`` the share of the observable ground-truth
samples (1 cm apart, in line of sight of the sensor head at least once a second along the
drive) with a point within 5 cm; ``sonar_in_view_pct`` the share of those in the sonar's field
of view, range and line of sight from a pose every :data:`IN_VIEW_PERIOD`
(:func:`~mitsonar.evaluation.coverage.in_view_along`): no sonar strategy's completeness can
exceed it. The VLP-16 (10 Hz, each column at its own time,
:func:`mitsonar.sensors.baselines.sweep`) drives the same path, whole, scored the same way.
Each of these is also given per surface class (``<class>_share_pct``, ``<class>_in_view_pct``,
``<class>_vlp16_pct``, ``<class>_completeness_pct``; classes
:data:`~mitsonar.evaluation.coverage.SURFACE_CLASSES`: horizontal below the sensor head,
above it, vertical, sloped): which surfaces a strategy misses, and which no forward-looking
sonar sees.

``--stride K`` simulates every K-th frame (sweep, OFDM frame or image) of the sensor's schedule
along the drive, still at the sensor's own times and poses: ``points_per_s`` is the sensor's
(points per simulated frame x frames per second), while ``completeness_5cm_pct`` counts only
what was simulated, a lower bound of the whole drive's. ``frames_simulated``, ``frames_total``
and ``stride`` say which, and ``completeness_5cm_half_pct`` is the completeness of every other
simulated frame (stride 2K), how much the completeness grows with the frames. ``sim_seconds``
is the wall-clock time of the simulation (shared by a scan's echo sets).

Writes imaging.csv/.md (a row per scene, preset and strategy) and imaging.png (points per
second against accuracy and completeness, the VLP-16's completeness and issue 28's goals
marked), shown in docs/imaging.md (``--stride 20``: 22 min on 2 shared cores; unstrided ~4 h).

    .venv/bin/python experiments/imaging.py --stride 20 --out out/imaging
    .venv/bin/python experiments/imaging.py --quick --out out/imaging    # ~30 s
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

import mitsonar
from mitsonar.evaluation.coverage import (SURFACE_CLASSES, covered_by_class, in_view_along,
                                          surface_classes)
from mitsonar.evaluation.metrics import point_to_mesh, sample_surface, visible_from
from mitsonar.recon.thinning import VoxelThinner
from mitsonar.io import write_table
from mitsonar.parallel import ordered_map
from mitsonar.scene.mesh import scene_mesh
from mitsonar.sensors.baselines import Lidar, sweep
from mitsonar.sensors.imaging_sonar import DEFOCUSED, ImagingSonar, TransmitSettings
from mitsonar.sensors.ofdm_sonar import OfdmSonar, pose_along
from mitsonar.sensors.sonar import beam_seed
from mitsonar.sensors.trajectory import sensor_poses
from mitsonar.signal.imaging_settings import WIDE_SWEEP_SETTINGS, ImagingSettings
from mitsonar.signal.receiver import EchoProcessor

if str(Path(__file__).resolve().parent) not in sys.path:  # the comparison's definitions
    sys.path.append(str(Path(__file__).resolve().parent))
from comparison import IN_VIEW_PERIOD, THIN_VOXEL, VIEW_PERIOD  # noqa: E402
from imaging_report import (TODAY_POINTS_PER_S, markdown, save_figure,  # noqa: E402
                            save_surface_figure)

SCENES = Path(__file__).resolve().parents[1] / "scenes"
SCENE_NAMES = ("office", "workshop")
#: The chart's sonar configurations (:func:`config_for`): "broadband" is the physical default
#: with 20 kHz transducers (``Transducer.broadband()``).
PRESETS = ("default", "broadband", "paper")
SCANS = ("sequential", "ofdm", "ofdm_trusted", "ofdm_image", "imaging", "imaging_chirp",
         "imaging_chirp_wide", "imaging_chirp_wide_bands", "imaging_chirp_wide_defocused")
#: The chirp imaging scans (module docstring): the presets they run with and the sonar's
#: configuration changed for the sweep: 30-50 kHz, the broadband transducers' -6 dB band, traced
#: at its centre as those transducers' tone bursts are; 20-80 kHz traced at five frequency
#: nodes (docs/imaging.md). The TCT40 class (``default``) passes 2 kHz: no sweep.
CHIRP_SCANS = {"imaging_chirp": (("broadband", "paper"),
                                 lambda c: replace(c, pulse=mitsonar.Chirp())),
               **{scan: (("paper",), mitsonar.SonarConfig.with_wide_sweep) for scan in SCANS
                  if scan.startswith("imaging_chirp_wide")}}
#: Echo sets of one sequential or OFDM simulation (module docstring).
ECHO_SETS = ("first", "all", "cells")
#: The lit cone of ``ofdm_trusted``: arrival directions within it of their beam's axis [rad]
#: (the steered transmit beam's -6 dB half-width, 3.1 deg at 40 kHz, as ``image_half_angle``).
TRUSTED_CONE = np.radians(3.0)
#: The OFDM frames decoded otherwise (module docstring): their receiver settings.
DECODINGS = {"ofdm_trusted": dict(echoes="cells", ghost_margin=0.0, arrival_cone=TRUSTED_CONE),
             "ofdm_image": dict(echoes="image")}
#: What each scan of one point set reports (``echoes`` in the table).
SINGLE_SETS = {"ofdm_trusted": "cells", "ofdm_image": "image",
               **{scan: "image" for scan in SCANS if scan.startswith("imaging")}}
#: Further trust thresholds of the imaging scan (``ImagingSettings.min_coherence``) beside its
#: default: the same images, each threshold's points a strategy of its own,
#: ``imaging_trust_<threshold>`` (points per second against accuracy along the trade-off).
IMAGING_TRUST = (0.35, 0.5)
#: The imaging scans' points rule where not ``ImagingSettings()`` (its ``min_coherence`` the
#: scan's default trust threshold), and their transmission where not one element.
TRUST = dict.fromkeys(("imaging_chirp_wide_bands", "imaging_chirp_wide_defocused"),
                      WIDE_SWEEP_SETTINGS)
TRANSMIT = {"imaging_chirp_wide_defocused": DEFOCUSED}
#: Accuracy threshold [m] and completeness threshold [m].
ACCURACY_THRESHOLD = 0.02
COMPLETENESS_THRESHOLD = 0.05
@dataclass(frozen=True)
class RunSettings:
    """How the chart is driven and simulated.

    Attributes:
        duration: seconds of each trajectory driven; None: all of it.
        stride: simulate every ``stride``-th frame of each schedule.
        step: beam grid step of the sequential and OFDM scans [rad].
        spacing: ground-truth sample spacing [m].
        rays_per_axis: rays per axis of the physical model's beams (None: ``TraceSettings``'s).
        image_rays_per_axis: rays per axis of an image's wide transmission (physical model).
        seed: seeds the sonar, the LiDAR's noise, the samples and the thinning.
        subbands: frequency nodes of every configuration's trace (``TraceSettings.subbands``;
            None: its default, as many as each band needs); ``imaging_chirp_wide`` always
            takes five.
        workers: processes that simulate the frames at once (the same frames;
            :func:`~mitsonar.parallel.ordered_map`).
    """

    duration: float | None
    stride: int
    step: float
    spacing: float
    rays_per_axis: int | None
    image_rays_per_axis: int
    seed: int
    subbands: int | None = None
    workers: int = 1


@dataclass
class Simulated:
    """What one scan gave along the drive: per echo set (one set, named after the scan, for
    the scans of :data:`SINGLE_SETS`) the
    world points (N_k, 3) [m] of each simulated frame k, the frames of its schedule and those
    simulated, its frame rate [Hz] and the simulation's wall-clock time [s]."""

    points: dict
    frame_rate: float
    frames_total: int
    frames_simulated: int
    seconds: float


def imaging_trust_sets(image, scan: str = "imaging") -> dict:
    """Points (N, 3) [m] of one image of ``scan`` per imaging strategy: ``<scan>`` those of the
    default trust threshold, ``<scan>_trust_<t>`` those of each threshold t of
    :data:`IMAGING_TRUST` (the image made with the lowest of them)."""
    default = TRUST.get(scan, ImagingSettings()).min_coherence
    return {scan if t == default else f"{scan}_trust_{t:g}":
            image.points_world[image.coherence >= t] for t in (default,) + IMAGING_TRUST}


def echo_sets(echoes, points_world) -> dict:
    """Points (N, 3) [m] per echo set (:data:`ECHO_SETS`) of an echo table simulated with
    ``echoes = 'cells'`` and its world points (E, 3) [m]."""
    return {"first": points_world[echoes.peak & (echoes.rank == 0)],
            "all": points_world[echoes.peak], "cells": points_world}


def config_for(preset: str) -> mitsonar.SonarConfig:
    """The sonar configuration of a chart preset (:data:`PRESETS`)."""
    if preset == "broadband":
        return replace(mitsonar.SonarConfig(), transducer=mitsonar.Transducer.broadband())
    return mitsonar.SonarConfig.preset(preset)


def sonar_for(path: Path, preset: str, settings: RunSettings) -> mitsonar.Sonar:
    """The scene's sonar with ``preset``, every echo and range cell reported."""
    config = config_for(preset)
    trace = config.trace if settings.rays_per_axis is None else \
        replace(config.trace, rays_per_axis=settings.rays_per_axis)
    if settings.subbands is not None:
        trace = replace(trace, subbands=settings.subbands)
    return mitsonar.Sonar(path, replace(config, trace=trace).with_detection(echoes="cells"))


def sequential_frame(sonar, pose_at, grid, start: float, seed: int) -> dict:
    """One sweep of single-beam pings over ``grid`` (B, 3) from ``start`` [s], one listening
    time apart, each from the pose at its firing time; its points per echo set."""
    period = sonar.config.record_duration
    sets = []
    for b, direction in enumerate(grid):  # pings follow each other in time
        scan = sonar.scan(pose_at(start + b * period), direction[None], seed=beam_seed(seed, b))
        sets.append(echo_sets(scan.echo_table, scan.echo_points_world))
    return {name: np.concatenate([s[name] for s in sets]) for name in ECHO_SETS}


class ScanFrames:
    """The frames of one scan (:data:`SCANS`) driven along a trajectory at its own rate: frame k
    fired at the k-th time of its schedule (:attr:`times`), its points per echo set; a pure
    function of k, the settings and the scene, so any process can simulate any frame."""

    def __init__(self, scan: str, sonar, trajectory, settings: RunSettings):
        self.scan, self.settings = scan, settings
        self.pose_at = pose_along(trajectory)
        self.grid = sonar.fov_grid(settings.step)
        if scan == "sequential":
            self.sonar = sonar
            period = len(self.grid) * sonar.config.record_duration
        elif scan == "ofdm" or scan in DECODINGS:
            self.ofdm = OfdmSonar(sonar)
            if scan in DECODINGS:  # the same frames, decoded otherwise
                config = sonar.config
                self.ofdm.processor = EchoProcessor(config.geometry, self.ofdm.band,
                                                    config.medium.speed_of_sound,
                                                    replace(config.detection, **DECODINGS[scan]),
                                                    config.noise_rms)
            self.schedule = self.ofdm.schedule(self.grid)
            period = self.schedule.frame_duration
        else:
            if scan in CHIRP_SCANS:  # the same sonar driven by a sweep
                sonar = mitsonar.Sonar(sonar.scene, CHIRP_SCANS[scan][1](sonar.config))
            rule = TRUST.get(scan, ImagingSettings())
            trust = replace(rule, min_coherence=min((rule.min_coherence,) + IMAGING_TRUST))
            self.imaging = ImagingSonar(sonar, trust, replace(
                TRANSMIT.get(scan, TransmitSettings()),
                rays_per_axis=settings.image_rays_per_axis))
            period = self.imaging.cycle_time
        self.frame_rate = 1.0 / period
        self.times = trajectory.times_at_rate(self.frame_rate, settings.duration)

    @classmethod
    def load(cls, scan: str, path: Path, preset: str, trajectory, settings: RunSettings):
        """In a worker process: the preset's sonar made anew (:func:`sonar_for`)."""
        return cls(scan, sonar_for(path, preset, settings), trajectory, settings)

    def frame(self, k: int) -> dict:
        t, seed = float(self.times[k]), beam_seed(self.settings.seed, k)
        if self.scan == "sequential":
            return sequential_frame(self.sonar, self.pose_at, self.grid, t, seed)
        if self.scan == "ofdm" or self.scan in DECODINGS:
            result = self.ofdm.frame(self.schedule, self.pose_at, start_time=t, seed=seed)
            if self.scan in DECODINGS:
                return {self.scan: result.echo_points_world}
            return echo_sets(result.echo_table, result.echo_points_world)
        return imaging_trust_sets(self.imaging.image(self.pose_at(t), seed=seed), self.scan)


def _frame(frames: ScanFrames, k: int) -> dict:
    return frames.frame(k)


def simulate(scan: str, sonar, trajectory, settings: RunSettings, progress, path: Path,
             preset: str) -> Simulated:
    """Drive ``trajectory`` scanning with ``scan`` (:data:`SCANS`) at its own rate, every
    ``settings.stride``-th frame simulated (by ``settings.workers`` processes, each making the
    ``preset`` sonar of the scene at ``path`` anew: the same frames); ``progress`` is called
    after each with (done, total)."""
    frames = ScanFrames(scan, sonar, trajectory, settings)
    chosen = np.arange(0, len(frames.times), settings.stride)
    workers = min(settings.workers, len(chosen))
    make = (lambda: frames) if workers <= 1 else \
        partial(ScanFrames.load, scan, path, preset, trajectory, settings)
    start = time.perf_counter()
    clouds = []
    for done, cloud in enumerate(ordered_map(make, _frame, chosen, workers)):
        clouds.append(cloud)  # frames follow each other in time
        progress(done + 1, len(chosen))
    points = {name: [c[name] for c in clouds] for name in clouds[0]}
    return Simulated(points, frames.frame_rate, len(frames.times), len(chosen),
                     time.perf_counter() - start)


@dataclass(frozen=True)
class Truth:
    """What every cloud of a scene is scored against: the mesh, the samples, which of them
    are observable along the drive (S,), which of those the sonar's field of view covers and
    their surface classes (:func:`~mitsonar.evaluation.coverage.surface_classes`)
    (O,) (module docstring)."""

    mesh: object
    samples: object
    observable: np.ndarray
    in_view: np.ndarray
    classes: np.ndarray


def thinned(points, seed: int) -> np.ndarray:
    """World points (N, 3) [m] thinned to one per 1 cm voxel, as the comparison does."""
    thinner = VoxelThinner(THIN_VOXEL, seed=seed)
    thinner.add(points)
    return thinner.result()


def covered(points, truth: Truth) -> np.ndarray:
    """(S_observable,) whether each observable ground-truth sample has one of ``points`` (N, 3)
    [m] within 5 cm (:func:`mitsonar.evaluation.metrics.evaluate`'s completeness: the mean)."""
    samples = truth.samples.points[truth.observable]
    if not len(points):
        return np.zeros(len(samples), bool)
    gap, _ = cKDTree(points).query(samples, distance_upper_bound=COMPLETENESS_THRESHOLD)
    return gap <= COMPLETENESS_THRESHOLD


def class_columns(prefix: str, flags, truth: Truth) -> dict:
    """``<class>_<prefix>_pct`` columns: the share [%] of each surface class's observable
    samples that ``flags`` (S_observable,) marks."""
    return {f"{name}_{prefix}_pct": 100 * share
            for name, share in covered_by_class(flags, truth.classes).items()}


def score(points, truth: Truth, seed: int) -> tuple[float, np.ndarray, int]:
    """(accuracy within 2 cm, :func:`covered` samples, thinned points) of world points (N, 3)
    [m] thinned to one per 1 cm voxel: each point's distance to the mesh computed once
    (:func:`~mitsonar.evaluation.metrics.point_to_mesh`), the coverage once."""
    cloud = thinned(points, seed)
    distance = point_to_mesh(cloud, truth.mesh)[0]
    accuracy = float(np.mean(distance <= ACCURACY_THRESHOLD)) if len(cloud) else float("nan")
    return accuracy, covered(cloud, truth), len(cloud)


def scene_truth(scene, trajectory, config, settings: RunSettings) -> Truth:
    """The scene's :class:`Truth` along the drive, the sonar's view from ``config``'s field of
    view and range."""
    mesh = scene_mesh(scene)
    samples = sample_surface(mesh, settings.spacing, settings.seed)
    driven = trajectory.driven(settings.duration)
    views = sensor_poses(trajectory.poses_at(np.arange(0.0, driven + 1e-9, VIEW_PERIOD)))
    heads = np.array([p.translation for p in views])
    observable = visible_from(scene, samples.points, heads)
    classes = surface_classes(mesh.triangle_normals()[samples.triangle[observable]],
                              samples.points[observable, 2], float(np.median(heads[:, 2])))
    return Truth(mesh, samples, observable, in_view_along(
        scene, samples.points[observable], trajectory, driven, config, IN_VIEW_PERIOD), classes)


def lidar_covered(scene, trajectory, truth: Truth, settings: RunSettings, bar) -> np.ndarray:
    """:func:`covered` by the VLP-16 driving the same path at 10 Hz."""
    thinner = VoxelThinner(THIN_VOXEL, seed=settings.seed)
    lidar = Lidar(scene)
    bar.reset(total=len(trajectory.times_at_rate(lidar.model.rate, settings.duration)))
    for _, points in sweep(lidar, trajectory, settings.duration, settings.seed):
        thinner.add(points)
        bar.update()
    return covered(thinner.result(), truth)


def scene_columns(truth: Truth, lidar_flags) -> dict:
    """The columns every row of a scene shares, computed once: the VLP-16's completeness (its
    :func:`covered` samples ``lidar_flags``) and the sonar's view, whole [%] and per surface
    class (``<class>_share_pct``, ``<class>_in_view_pct``, ``<class>_vlp16_pct``)."""
    return {"vlp16_completeness_5cm_pct": 100 * float(np.mean(lidar_flags)),
            "sonar_in_view_pct": 100 * float(np.mean(truth.in_view)),
            **{f"{c}_share_pct": 100 * np.mean(truth.classes == k)
               for k, c in enumerate(SURFACE_CLASSES)},
            **class_columns("in_view", truth.in_view, truth),
            **class_columns("vlp16", lidar_flags, truth)}


def scan_rows(name: str, preset: str, scan: str, sim: Simulated, truth: Truth, shared: dict,
              settings: RunSettings, driven: float) -> list[dict]:
    """The chart's rows of one scan's simulation ``sim`` (a row per point set), scored against
    ``truth`` beside the scene's :func:`scene_columns` ``shared``; ``driven`` [s]."""
    lidar = shared["vlp16_completeness_5cm_pct"] / 100
    by_class = {k: v for k, v in shared.items() if k.startswith(SURFACE_CLASSES)}
    rows = []
    for echoes, frames in sim.points.items():
        points = np.concatenate(frames)
        accuracy, flags, kept = score(points, truth, settings.seed)
        covers = float(np.mean(flags))
        half = np.mean(covered(thinned(np.concatenate(frames[::2]), settings.seed), truth))
        # a set named after its scan is a strategy; others are the scan's echo sets
        strategy = echoes if echoes.startswith(scan) else f"{scan}_{echoes}"
        per_frame = len(points) / sim.frames_simulated
        rows.append({
            "scene": name, "strategy": strategy, "preset": preset,
            "scan": scan.split("_")[0],  # ofdm_image, ofdm_trusted: OFDM frames
            "echoes": SINGLE_SETS.get(scan, echoes), "frame_rate_hz": sim.frame_rate,
            "points_per_frame": per_frame, "points_per_s": per_frame * sim.frame_rate,
            "points_per_s_vs_today": per_frame * sim.frame_rate / TODAY_POINTS_PER_S[preset],
            "accuracy_pct": 100 * accuracy, "completeness_5cm_pct": 100 * covers,
            "completeness_5cm_half_pct": 100 * half,
            "vlp16_completeness_5cm_pct": shared["vlp16_completeness_5cm_pct"],
            "completeness_vs_vlp16": covers / lidar,
            "sonar_in_view_pct": shared["sonar_in_view_pct"],
            "points": len(points), "thinned_points": kept,
            "frames_simulated": sim.frames_simulated, "frames_total": sim.frames_total,
            "stride": settings.stride, "driven_s": driven, "sim_seconds": sim.seconds,
            "sim_seconds_per_frame": sim.seconds / sim.frames_simulated,
            **by_class, **class_columns("completeness", flags, truth)})
        print(f"{name} {preset} {strategy}: {per_frame:.1f} points/frame, "
              f"{per_frame * sim.frame_rate:.0f} points/s, {100 * accuracy:.1f} % within 2 cm, "
              f"completeness {100 * covers:.1f} % (5 cm), "
              f"{sim.seconds / sim.frames_simulated:.2f} s/frame", file=sys.stderr)
    return rows


def run_scene(name: str, presets, scans, settings: RunSettings) -> list[dict]:
    """The chart's rows of one scene."""
    from tqdm import tqdm

    path = SCENES / name / "scene.xml"
    trajectory = mitsonar.Trajectory.from_scene(path)
    driven = trajectory.driven(settings.duration)
    rows = []
    with tqdm(desc=f"{name}", unit="frame", file=sys.stderr) as bar:
        sonars = {preset: sonar_for(path, preset, settings) for preset in presets}
        first = next(iter(sonars.values()))  # every preset's scene, field of view and range
        scene = first.scene
        bar.set_description(f"{name}: ground truth")
        truth = scene_truth(scene, trajectory, first.config, settings)
        bar.set_description(f"{name}: VLP-16 at 10 Hz")
        shared = scene_columns(truth, lidar_covered(scene, trajectory, truth, settings, bar))
        print(f"{name}: VLP-16 completeness within 5 cm "
              f"{shared['vlp16_completeness_5cm_pct']:.1f} %, in the sonar's view "
              f"{shared['sonar_in_view_pct']:.1f} % ({driven:.1f} s driven)", file=sys.stderr)
        for preset, sonar in sonars.items():
            for scan in scans:
                if scan in CHIRP_SCANS and preset not in CHIRP_SCANS[scan][0]:
                    continue  # a sweep the preset's transducers cannot pass
                bar.set_description(f"{name} {preset}: {scan} (stride {settings.stride})")

                def step(done, total):
                    bar.total = total
                    bar.update(done - bar.n)

                bar.reset()
                sim = simulate(scan, sonar, trajectory, settings, step, path, preset)
                rows += scan_rows(name, preset, scan, sim, truth, shared, settings, driven)
    return rows


def _subset(text: str, known, option: str) -> list[str]:
    names = text.split(",")
    unknown = sorted(set(names) - set(known))
    if unknown:
        raise ValueError(f"{option}: unknown {', '.join(unknown)}; known: {', '.join(known)}")
    return names


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/imaging"))
    choices = {"scenes": SCENE_NAMES, "presets": PRESETS, "scans": SCANS}
    for option, known in choices.items():
        parser.add_argument(f"--{option}", default=",".join(known),
                            help=f"comma separated subset of {', '.join(known)} (default: all)")
    parser.add_argument("--duration", type=float, default=None,
                        help="drive only the first DURATION seconds (default: the whole "
                             "trajectory)")
    parser.add_argument("--stride", type=int, default=1,
                        help="simulate every K-th frame of each sensor's schedule (default 1)")
    parser.add_argument("--step", type=float, default=5.0,
                        help="beam grid step of the sequential and OFDM scans [deg] (default 5)")
    parser.add_argument("--spacing", type=float, default=0.01,
                        help="ground-truth sample spacing [m] (default 0.01)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--subbands", type=int, default=None,
                        help="trace every configuration at this many frequency nodes "
                             "(TraceSettings.subbands; default: as many as each band needs, "
                             "imaging_chirp_wide: 5)")
    parser.add_argument("--workers", type=int, default=1,
                        help="processes that simulate the frames at once, the same frames "
                             "(default 1; 2 on 2 cores: about twice as fast with the paper "
                             "preset)")
    parser.add_argument("--quick", action="store_true",
                        help="office, 0.3 s of driving, 20 deg grid, 16 rays per axis per beam "
                             "and 32 per image, 5 cm ground truth (for the test suite)")
    args = parser.parse_args(argv)
    scenes, presets, scans = (_subset(getattr(args, option), known, f"--{option}")
                              for option, known in choices.items())
    for name, value in (("--stride", args.stride), ("--workers", args.workers)):
        if value < 1:
            parser.error(f"{name} must be >= 1, got {value}")
    if args.subbands is not None:
        try:
            mitsonar.TraceSettings(subbands=args.subbands)  # its own check
        except ValueError as error:
            parser.error(f"--subbands: {error}")
    settings = RunSettings(args.duration, args.stride, np.radians(args.step), args.spacing, None,
                           TransmitSettings.rays_per_axis, args.seed, args.subbands,
                           args.workers)
    if args.quick:
        scenes = ["office"]
        settings = replace(settings, duration=0.3, step=np.radians(20.0), spacing=0.05,
                           rays_per_axis=16, image_rays_per_axis=32)
    rows = [row for name in scenes for row in run_scene(name, presets, scans, settings)]
    args.out.mkdir(parents=True, exist_ok=True)
    md = markdown(rows)
    write_table(args.out / "imaging.csv", rows, md)
    save_figure(args.out / "imaging.png", rows)
    save_surface_figure(args.out / "imaging_surfaces.png", rows)
    print("\n".join(md))
    print(f"Wrote {args.out}/imaging.csv, imaging.md, imaging.png and imaging_surfaces.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
