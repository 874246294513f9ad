"""Incidence study (issue 24, item 3): which surfaces each sonar preset detects along the shipped
scenes' trajectories, and how well, against the angle between the beam axis and the surface.

Along each scene's default trajectory (:meth:`mitsonar.Trajectory.from_scene`) a pose is taken
every ``--period`` seconds of driving (the sensor head on the robot,
:func:`~mitsonar.sensors.trajectory.sensor_poses`), and from each pose both presets (the
physical default ``SonarConfig()``, TCT40-class narrow-band transducers and physical-optics
plus Lambert scattering, and ``SonarConfig.preset('paper')``) fire single-beam pings over the
beam grid (:meth:`Sonar.scan <mitsonar.sensors.sonar.Sonar.scan>`, ``--step`` apart, every beam
from that pose). ``--presets`` also takes variants of the default that test why it loses
walls (:data:`VARIANTS`).

Ground truth of every beam, cast with the sonar's own acoustic ray caster (the first surface
that is not acoustically transparent, ``AcousticTracer.intersect``) from the transmit origin
(the sensor origin):

* the **axis hit**: the first surface along the beam axis, its material, the incidence angle
  (between the axis and that surface's normal) and its range ``axis_range``;
* the **cone range** ``cone_range``: the nearest surface hit inside the beam's two-way -3 dB
  cone (the directions where the transmit times receive pattern steered to the beam is at
  least 1/sqrt(2) of its peak, sampled every ``CONE_STEP``). A wall seen obliquely returns first
  from the near edge of the lobe, so this is where a first echo comes from.

Per detection (the beam's strongest trusted echo, ``Scan.depth`` and ``Scan.points_world``):
``|depth - axis_range|``, ``|depth - cone_range|``, and the distance of the detected point to
the nearest surface of the scene's mesh (:func:`~mitsonar.evaluation.metrics.point_to_mesh`,
how the maps are scored; the receiver places each point along its measured arrival direction,
not on the axis, so this is the error a map sees). "Within 2 cm" is that surface distance.

Beams whose axis hits nothing within the recorded range (``SonarConfig.max_range``) are left out.
The beams are binned by preset, axis material and incidence angle (``--bin`` wide): beams,
fraction detected, median and 90th percentile of each error, share within 2 cm. A material
whose name means different acoustic properties in different scenes is labelled per scene.

Writes incidence.csv/.md (a row per preset, material and bin; the .md adds, per material, the
incidences where detection is below 50 %), incidence_beams.csv (every beam) and incidence.png
(detected fraction and median errors against incidence, a line per material, a column per
preset). docs/incidence.md shows them.

    .venv/bin/python experiments/incidence.py --period 2 --out out/incidence    # 26 min
    .venv/bin/python experiments/incidence.py --quick --out out/incidence       # ~10 s
    .venv/bin/python experiments/incidence.py --scenes room_glass \
        --presets default,default_broadband,default_no_sidelobe_check --period 4
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

import mitsonar
from mitsonar.evaluation.metrics import point_to_mesh
from mitsonar.frames import direction_from_fov_angles, fov_angles
from mitsonar.io import write_table
from mitsonar.physics.beampattern import HALF_POWER, two_way_pattern
from mitsonar.plots import _pyplot, save_png
from mitsonar.scene.loading import DefaultMaterialWarning
from mitsonar.scene.mesh import scene_mesh
from mitsonar.sensors.sonar import beam_seed
from mitsonar.sensors.trajectory import sensor_poses

SCENES = Path(__file__).resolve().parents[1] / "scenes"
SCENE_NAMES = ("room_glass", "structure", "office", "workshop")
#: The presets compared, then two variants of the default that test why it loses walls (run
#: when named in --presets): broadband (20 kHz) transducers instead of the TCT40's 2 kHz, and
#: the receiver's side-lobe check off (``DetectionSettings.ghost_margin = 0``); one that
#: recovers what that check rejects: off-beam echoes re-placed where they arrive from
#: (``DetectionSettings.off_beam``); and the default's scans with shared hits, every beam with
#: its transmit side lobes over the field of view (``Sonar.scan(..., shared_hits=True)``).
PRESETS = ("default", "paper")
VARIANTS = ("default_broadband", "default_no_sidelobe_check", "default_off_beam",
            "default_shared_hits")
#: Grid step [rad] and half span [rad] (in field-of-view angles around each beam) on which the
#: beams' -3 dB cones are sampled; the span is checked to hold the whole cone.
CONE_STEP = np.radians(0.25)
CONE_SPAN = np.radians(4.0)
#: "Within 2 cm" [m].
ACCURACY_THRESHOLD = 0.02
#: Detected fraction whose crossing the Markdown summary reports.
HALF = 0.5
#: A material gets its own line when it holds at least this share of a preset's beams.
MIN_MATERIAL_SHARE = 0.015
ALL, OTHER = "all materials", "other materials"


@dataclass(frozen=True)
class RunSettings:
    """How the study is driven.

    Attributes:
        period: time between sampled poses along a trajectory [s].
        poses: at most this many poses per scene (None: the whole trajectory).
        step: beam grid step [rad].
        bin_width: incidence-angle bin width [rad].
        rays_per_axis: rays per axis of the physical model's beams (None: ``TraceSettings``'s).
        seed: seeds the pings.
        min_bin_beams: bins with fewer beams are not drawn and not used for the 50 % crossing.
    """

    period: float
    poses: int | None
    step: float
    bin_width: float
    rays_per_axis: int | None
    seed: int
    min_bin_beams: int = 20


@dataclass(frozen=True)
class Cone:
    """Sample directions (B, K, 3) around each of B beams (sensor frame) and (B, K) bool: inside
    the beam's two-way -3 dB cone."""

    directions: np.ndarray
    inside: np.ndarray


def beam_cones(config, directions) -> Cone:
    """The two-way -3 dB cones of the beams ``directions`` (B, 3) of a sonar ``config``: a
    ``CONE_STEP`` grid of field-of-view angles around each beam, inside where the transmit times
    receive pattern steered to the beam reaches ``HALF_POWER`` of its peak on the grid. Raises
    ValueError if a cone reaches the grid's edge."""
    u = np.asarray(directions, dtype=float).reshape(-1, 3)
    h, v = fov_angles(u)
    offsets = np.arange(-CONE_SPAN, CONE_SPAN + 1e-12, CONE_STEP)
    dh, dv = (a.ravel() for a in np.meshgrid(offsets, offsets, indexing="ij"))
    grid = direction_from_fov_angles(h[:, None] + dh, v[:, None] + dv)
    g = config.geometry
    k = float(config.medium.wavenumber(config.pulse.frequency))
    pattern = two_way_pattern(g.tx_positions, g.rx_positions, u[:, None], grid,
                              config.transducer, k)
    inside = pattern >= HALF_POWER * pattern.max(axis=1, keepdims=True)
    edge = (np.abs(dh) > CONE_SPAN - CONE_STEP / 2) | (np.abs(dv) > CONE_SPAN - CONE_STEP / 2)
    if inside[:, edge].any():
        raise ValueError("a beam's -3 dB cone reaches the edge of its sample grid: raise CONE_SPAN")
    return Cone(grid, inside)


@dataclass(frozen=True)
class BeamTruth:
    """Ground truth of B beams from one pose.

    Attributes:
        material: (B,) index into the scene's materials of the surface the axis hits (-1: none).
        incidence: (B,) angle between the axis and that surface's normal [rad] (NaN: none).
        axis_range: (B,) its distance from the transmit origin along the axis [m] (inf: none).
        cone_range: (B,) distance of the nearest surface hit inside the beam's -3 dB cone [m].
    """

    material: np.ndarray
    incidence: np.ndarray
    axis_range: np.ndarray
    cone_range: np.ndarray


def beam_truth(tracer, pose, directions, cone: Cone) -> BeamTruth:
    """Ground truth of beams ``directions`` (B, 3) (sensor frame) with their ``cone``s fired from
    ``pose`` (world from sensor), cast by ``tracer`` (an :class:`~mitsonar.trace.tracer.
    AcousticTracer`: the first surface that is not acoustically transparent)."""
    axes = pose.transform_vectors(np.asarray(directions, dtype=float).reshape(-1, 3))
    origins = np.repeat(pose.translation[None], len(axes), axis=0)  # the transmit origin
    axis_range, _, normal, material, _ = tracer.intersect(origins, axes)
    cos = np.abs(np.einsum("ij,ij->i", axes, normal))
    incidence = np.where(material >= 0, np.arccos(np.clip(cos, 0.0, 1.0)), np.nan)
    around = pose.transform_vectors(cone.directions.reshape(-1, 3))
    reach = tracer.intersect(np.repeat(pose.translation[None], len(around), axis=0), around)[0]
    cone_range = np.where(cone.inside, reach.reshape(cone.inside.shape), np.inf).min(axis=1)
    return BeamTruth(material, incidence, axis_range, cone_range)


def material_labels(scenes: dict) -> dict:
    """Label of every (scene name, material index) of loaded ``scenes`` {name: AcousticScene}:
    the material's name, or "name (scene)" where that name means different materials in
    different scenes."""
    by_name: dict = {}
    for scene in scenes.values():
        for m in scene.materials:
            by_name.setdefault(m.name, []).append(m)
    return {(s, k): m.name if all(o == m for o in by_name[m.name]) else f"{m.name} ({s})"
            for s, scene in scenes.items() for k, m in enumerate(scene.materials)}


def sonar_config(name: str) -> mitsonar.SonarConfig:
    """The configuration of a preset or variant (:data:`PRESETS`, :data:`VARIANTS`)."""
    if name == "default_broadband":
        return mitsonar.SonarConfig(transducer=mitsonar.Transducer.broadband())
    if name in ("default_no_sidelobe_check", "default_off_beam"):
        change = dict(ghost_margin=0.0) if name == "default_no_sidelobe_check" \
            else dict(off_beam=True)
        return mitsonar.SonarConfig().with_detection(**change)
    return mitsonar.SonarConfig.preset("default" if name == "default_shared_hits" else name)


def sonar_for(scene, preset: str, settings: RunSettings) -> mitsonar.Sonar:
    """The loaded ``scene``'s sonar with ``preset`` (:func:`sonar_config`; and the settings'
    rays per axis)."""
    config = sonar_config(preset)
    if settings.rays_per_axis is not None:
        config = replace(config, trace=replace(config.trace, rays_per_axis=settings.rays_per_axis))
    return mitsonar.Sonar(scene, config)


def scene_beams(index: int, name: str, scene, presets, settings: RunSettings,
                progress) -> dict:
    """Every beam of scene ``name`` (loaded ``scene``): columns (arrays over beams) preset,
    scene, time_s, beam, material (index), incidence, axis_range, cone_range, detected, depth,
    surface_distance (NaN where nothing was detected); ``progress`` is called per pose."""
    trajectory = mitsonar.Trajectory.from_scene(SCENES / name / "scene.xml")
    times = np.arange(0.0, trajectory.duration, settings.period)[:settings.poses]
    poses = sensor_poses(trajectory.poses_at(times))
    mesh = scene_mesh(scene)
    columns: dict = {}
    for preset in presets:
        sonar = sonar_for(scene, preset, settings)
        grid = sonar.fov_grid(settings.step)
        cone = beam_cones(sonar.config, grid)
        for k, (t, pose) in enumerate(zip(times, poses)):
            truth = beam_truth(sonar.tracer, pose, grid, cone)
            scan = sonar.scan(pose, grid, seed=beam_seed(settings.seed, index, k),
                              shared_hits=preset == "default_shared_hits")
            distance = np.full(len(grid), np.nan)
            distance[scan.detected] = point_to_mesh(scan.points_world, mesh)[0]
            beam = dict(preset=np.full(len(grid), preset), scene=np.full(len(grid), name),
                        time_s=np.full(len(grid), t), beam=np.arange(len(grid)),
                        material=truth.material, incidence=truth.incidence,
                        axis_range=truth.axis_range, cone_range=truth.cone_range,
                        detected=scan.detected, depth=scan.depth, surface_distance=distance,
                        max_range=np.full(len(grid), sonar.config.max_range))
            for key, value in beam.items():
                columns.setdefault(key, []).append(value)
            progress(preset)
    return {key: np.concatenate(value) for key, value in columns.items()}


def _stats(beams: dict, rows: np.ndarray) -> dict:
    """Detection and error statistics of the beams ``rows`` (indices) [mm, %]."""
    detected = beams["detected"][rows]
    depth = beams["depth"][rows][detected]
    errors = {"axis": np.abs(depth - beams["axis_range"][rows][detected]),
              "cone": np.abs(depth - beams["cone_range"][rows][detected]),
              "surface": beams["surface_distance"][rows][detected]}
    out = {"beams": len(rows), "detected": int(detected.sum()),
           "detected_pct": 100 * float(detected.mean()) if len(rows) else np.nan}
    for name, e in errors.items():
        out[f"{name}_error_median_mm"] = 1e3 * float(np.median(e)) if len(e) else np.nan
        out[f"{name}_error_p90_mm"] = 1e3 * float(np.percentile(e, 90)) if len(e) else np.nan
    out["within_2cm_pct"] = 100 * float(np.mean(errors["surface"] <= ACCURACY_THRESHOLD)) \
        if len(depth) else np.nan
    return out


def bin_rows(beams: dict, labels: np.ndarray, bin_width: float) -> list[dict]:
    """Rows per preset, material label (and :data:`ALL` materials) and incidence bin of the
    ``beams`` columns (:func:`scene_beams`) whose axis hits a surface within the recorded range;
    ``labels`` (N,) is each beam's material label. Bins are ``bin_width`` [rad] wide, centred on
    its multiples (a 5 deg grid meets walls parallel to the path at multiples of 5 deg), the
    first one [0, bin_width / 2)."""
    valid = (beams["material"] >= 0) & (beams["axis_range"] <= beams["max_range"])
    bins = np.floor(np.where(valid, beams["incidence"], 0.0) / bin_width + 0.5).astype(int)
    rows = []
    for preset in dict.fromkeys(beams["preset"]):
        mine = valid & (beams["preset"] == preset)
        for label in [ALL] + sorted(set(labels[mine])):
            group = mine & ((labels == label) if label != ALL else True)
            scenes = ";".join(dict.fromkeys(beams["scene"][group]))
            for b in np.unique(bins[group]):
                rows.append({"preset": preset, "material": label, "scenes": scenes,
                             "incidence_deg": float(np.degrees(b * bin_width)),
                             "incidence_lo_deg": float(np.degrees(max(b - 0.5, 0) * bin_width)),
                             "incidence_hi_deg": float(np.degrees((b + 0.5) * bin_width)),
                             **_stats(beams, np.flatnonzero(group & (bins == b)))})
    return rows


def crossings(rows: list[dict], min_beams: int, level: float = HALF) -> list[float]:
    """Incidences [deg] at which the detected fraction of one preset's and material's ``rows``
    (bins in increasing angle) crosses ``level``, falling and rising in turn, interpolated
    linearly between the centres (``incidence_deg``) of bins with at least ``min_beams`` beams;
    first -inf when the first such bin is already below."""
    kept = [r for r in rows if r["beams"] >= min_beams]
    centre = np.array([r["incidence_deg"] for r in kept])
    fraction = np.array([r["detected_pct"] / 100 for r in kept])
    below = fraction < level
    out = [-np.inf] if len(kept) and below[0] else []
    for i in np.flatnonzero(below[1:] != below[:-1]):
        f0, f1 = fraction[i], fraction[i + 1]
        out.append(float(centre[i] + (f0 - level) / (f0 - f1) * (centre[i + 1] - centre[i])))
    return out


def _loss_text(rows: list[dict], min_beams: int) -> str:
    """Where one preset's and material's detection is below 50 % (:func:`crossings`), as text:
    "a-b" [deg], "from a on", "<=c" for a start before the first bin counted (centre c), "-"
    for never."""
    angles = crossings(rows, min_beams)
    if not angles:
        return "-"
    first = min(r["incidence_deg"] for r in rows if r["beams"] >= min_beams)
    ends = [f"<={first:.1f}" if a == -np.inf else f"{a:.1f}" for a in angles]
    return ", ".join(f"{ends[k]}-{ends[k + 1]}" if k + 1 < len(ends) else f"from {ends[k]} on"
                     for k in range(0, len(ends), 2))


def plotted_materials(rows: list[dict], preset: str) -> list[str]:
    """Materials of ``preset`` holding at least :data:`MIN_MATERIAL_SHARE` of its beams, most
    beams first."""
    counts: dict = {}
    for r in rows:
        if r["preset"] == preset and r["material"] != ALL:
            counts[r["material"]] = counts.get(r["material"], 0) + r["beams"]
    total = sum(counts.values())
    return sorted((m for m, n in counts.items() if n >= MIN_MATERIAL_SHARE * total),
                  key=lambda m: -counts[m])


def markdown(rows: list[dict], min_beams: int) -> list[str]:
    """Per material: beams, detected %, within 2 cm and the incidences where detection is below
    50 % (:func:`_loss_text`, bins of at least ``min_beams`` beams) of each preset."""
    presets = list(dict.fromkeys(r["preset"] for r in rows))
    materials = list(dict.fromkeys(m for p in presets for m in [ALL] + plotted_materials(rows, p)))
    md = ["| material | " + " | ".join(
        f"{p}: beams | {p}: detected % | {p}: within 2 cm % | {p}: detected < 50 % at [deg]"
        for p in presets) + " |", "|---|" + "---:|---:|---:|---:|" * len(presets)]
    for material in materials:
        cells = []
        for p in presets:
            mine = [r for r in rows if r["preset"] == p and r["material"] == material]
            beams = sum(r["beams"] for r in mine)
            detected = sum(r["detected"] for r in mine)
            within = sum(r["within_2cm_pct"] * r["detected"] / 100 for r in mine if r["detected"])
            cells.append(f"{beams} | {100 * detected / max(beams, 1):.1f} | "
                         f"{100 * within / max(detected, 1):.1f} | "
                         f"{_loss_text(mine, min_beams)}")
        md.append(f"| {material} | " + " | ".join(cells) + " |")
    return md


def save_figure(path: Path, rows: list[dict], min_beams: int) -> None:
    """Detected fraction, median |depth - axis range| and median distance of the detected points
    to the surfaces against incidence (rows), a column per preset, a line per material (bins of
    at least ``min_beams`` beams), all materials in black."""
    plt = _pyplot()
    presets = list(dict.fromkeys(r["preset"] for r in rows))
    materials = list(dict.fromkeys(m for p in presets for m in plotted_materials(rows, p)))
    colours = {m: f"C{k % 10}" for k, m in enumerate(materials)}
    styles = {m: "-" if k < 10 else "--" for k, m in enumerate(materials)}
    quantities = (("detected_pct", "beams detected [%]"),
                  ("axis_error_median_mm", "median |depth - axis range| [mm]"),
                  ("surface_error_median_mm", "median distance of the point\nto the surface [mm]"))
    fig, axes = plt.subplots(len(quantities), len(presets), figsize=(7 * len(presets), 12),
                             squeeze=False, sharex=True)
    handles = {}
    for col, preset in enumerate(presets):
        for material in [ALL] + plotted_materials(rows, preset):
            mine = [r for r in rows if r["preset"] == preset and r["material"] == material
                    and r["beams"] >= min_beams]
            x = [r["incidence_deg"] for r in mine]
            style = dict(color="k", lw=2.2) if material == ALL else \
                dict(color=colours[material], ls=styles[material], lw=1.2)
            for row, (key, _) in enumerate(quantities):
                handles[material], = axes[row, col].plot(x, [r[key] for r in mine], marker=".",
                                                         label=material, **style)
        axes[0, col].set_title(f"preset '{preset}'")
        axes[0, col].axhline(100 * HALF, color="grey", ls=":", lw=1)
        axes[0, col].set_ylim(-3, 103)
        for row, (_, label) in enumerate(quantities):
            axes[row, col].set_ylabel(label)
            axes[row, col].grid(True, lw=0.3, alpha=0.5)
        for row in (1, 2):
            if any(np.nanmin(line.get_ydata(), initial=np.inf) > 0 for line in axes[row, col].lines
                   if len(line.get_ydata())):  # errors span decades; none drawn: linear
                axes[row, col].set_yscale("log")
        axes[2, col].axhline(1e3 * ACCURACY_THRESHOLD, color="grey", ls=":", lw=1)
        axes[-1, col].set_xlabel("incidence angle of the beam axis [deg]")
    fig.legend(handles=list(handles.values()), loc="lower center", ncol=4, fontsize=8)
    fig.tight_layout(rect=(0, 0.03 + 0.012 * ((len(handles) + 3) // 4), 1, 1))
    save_png(fig, path)


def _names(known):
    """Argument type of a comma separated subset of ``known`` names."""
    def parse(text: str) -> list[str]:
        unknown = sorted(set(text.split(",")) - set(known))
        if unknown:
            raise argparse.ArgumentTypeError(f"unknown {', '.join(unknown)}; "
                                             f"known: {', '.join(known)}")
        return text.split(",")
    return parse


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/incidence"))
    parser.add_argument("--scenes", type=_names(SCENE_NAMES), default=list(SCENE_NAMES),
                        help=f"comma separated subset of {', '.join(SCENE_NAMES)} (default: all)")
    parser.add_argument("--presets", type=_names(PRESETS + VARIANTS), default=list(PRESETS),
                        help=f"comma separated presets and variants of the default among "
                             f"{', '.join(PRESETS + VARIANTS)} (default: {', '.join(PRESETS)})")
    parser.add_argument("--period", type=float, default=2.0,
                        help="seconds of driving between sampled poses (default 2)")
    parser.add_argument("--step", type=float, default=5.0, help="beam grid step [deg] (default 5)")
    parser.add_argument("--bin", type=float, default=5.0,
                        help="incidence-angle bin width [deg] (default 5)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--quick", action="store_true",
                        help="room_glass, 3 poses 20 s apart, 10 deg grid, 16 rays per axis, "
                             "10 deg bins, every bin drawn (for the test suite)")
    args = parser.parse_args(argv)
    scenes = args.scenes
    for option in ("period", "step", "bin"):
        if not getattr(args, option) > 0:
            parser.error(f"--{option} must be > 0, got {getattr(args, option)}")
    settings = RunSettings(args.period, None, np.radians(args.step), np.radians(args.bin), None,
                           args.seed)
    if args.quick:
        scenes = ["room_glass"]
        settings = replace(settings, period=20.0, poses=3, step=np.radians(10.0),
                           bin_width=np.radians(10.0), rays_per_axis=16, min_bin_beams=1)
    start = time.perf_counter()
    parts, loaded = [], {}
    for index, name in enumerate(scenes):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DefaultMaterialWarning)
            loaded[name] = mitsonar.load_scene(SCENES / name / "scene.xml")
        done = [0]

        def progress(preset, name=name, done=done):
            done[0] += 1
            print(f"\r{name}: {done[0]} scans ({preset})", end="", file=sys.stderr)

        parts.append(scene_beams(index, name, loaded[name], args.presets, settings, progress))
        print(file=sys.stderr)
    beams = {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
    names = material_labels(loaded)
    labels = np.array([names[s, m] if m >= 0 else "" for s, m in
                       zip(beams["scene"], beams["material"])])
    rows = bin_rows(beams, labels, settings.bin_width)
    md = markdown(rows, settings.min_bin_beams)
    args.out.mkdir(parents=True, exist_ok=True)
    write_table(args.out / "incidence.csv", rows, md)
    write_table(args.out / "incidence_beams.csv", [
        {"preset": p, "scene": s, "time_s": t, "beam": int(b), "material": lab,
         "incidence_deg": float(np.degrees(i)), "axis_range_m": a, "cone_range_m": c,
         "detected": bool(d), "depth_m": z, "surface_distance_m": e}
        for p, s, t, b, lab, i, a, c, d, z, e in zip(
            beams["preset"], beams["scene"], beams["time_s"], beams["beam"], labels,
            beams["incidence"], beams["axis_range"], beams["cone_range"], beams["detected"],
            beams["depth"], beams["surface_distance"])])
    save_figure(args.out / "incidence.png", rows, settings.min_bin_beams)
    print("\n".join(md))
    print(f"{len(beams['detected'])} beams in {time.perf_counter() - start:.0f} s; wrote "
          f"{args.out}/incidence.csv, incidence.md, incidence_beams.csv and incidence.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
