"""Speed of mitsonar against the real sensor and against plain baselines, side by side in one run.

    .venv/bin/python benchmarks/run.py [--scene scenes/room_glass/scene.xml] [--quick]

Prints one line per figure (value, baseline, ratio) and exits non-zero if any figure is not
finite. Timings are wall-clock on this machine, measured in this one run; compare ratios, not
absolute numbers, across machines.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import pstats
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

import mitsonar
from mitsonar.evaluation.fidelity import fidelity
from mitsonar.physics.transducer import Transducer
from mitsonar.recon.repeated import RepeatedMapSpec, scan_repeated
from mitsonar.scene.rays import rays
from mitsonar.sensors.camera import CameraModel, CameraRenderer
from mitsonar.sensors.imaging_sonar import DEFOCUSED, ImagingSonar, TransmitSettings
from mitsonar.sensors.ofdm_sonar import OfdmSonar
from mitsonar.signal.detection import ECHO_MODES
from mitsonar.evaluation.reference import direct_summation
from mitsonar.sensors.sonar import TRACE_BATCH

REAL_PING_S = 0.030  # one ping listens ~30 ms for 5 m (the paper)
REAL_FRAME_S = 0.2085  # one 13 x 9 OFDM frame (the paper)
#: Goals of issue 23, as ratios to the real sensor: 1 000 pings/s, 5 frames/s (per-channel),
#: 10 frames/s (detection-only).
PING_GOAL = 1000 * REAL_PING_S
FRAME_GOAL = 5 * REAL_FRAME_S
DETECTION_GOAL = 10 * REAL_FRAME_S
ROOT = Path(__file__).resolve().parents[1]
#: The full-rate reference: every element pair, real recordings at 400 kHz, band floor 1e-5.
FULL_RATE = dict(sample_rate=400e3, narrowband_bandwidth=0.0, baseband=False, band_floor=1e-5)
#: Broadband transducers, as ``mitsonar map repeated --broadband`` chooses them: every element
#: pair synthesised (no narrow-band merge).
BROADBAND = Transducer.broadband()


def _timed(fn, repeat: int = 1):
    fn()  # warm-up: kernels compiled or loaded from Dr.Jit's cache
    t0 = time.perf_counter()
    for _ in range(repeat):
        out = fn()
    return (time.perf_counter() - t0) / repeat, out


#: Stages of the profile: (name, functions whose inclusive times add up, functions subtracted),
#: functions as (file, name). Disjoint by construction (``drive_spectra`` runs inside
#: ``driven_samples``, shared hits' synthesis; ``impulse_grid`` is not called with factored
#: paths on these paths, so it never holds ``_pair_grids``); the rest is "other".
STAGES = (
    ("ray casts and refinement", [("casting.py", "_cast")], []),
    ("shadow rays", [("casting.py", "_visibility")], []),
    ("element-factor kernel", [("element_factors.py", "element_factors")], []),
    ("rest of the trace (per-hit NumPy)",
     [("tracer.py", "trace_many"), ("tracer.py", "trace_union"), ("tracer.py", "patch_paths")],
     [("casting.py", "_cast"), ("casting.py", "_visibility"),
      ("element_factors.py", "element_factors")]),
    ("narrow-band merge kernel", [("hitpaths.py", "merged")], []),
    ("gridding kernel",
     [("synthesis.py", "impulse_grid"), ("synthesis.py", "_pair_grids")], []),
    ("synthesis FFTs and filters",
     [("synthesis.py", "groups_spectrum"), ("band.py", "to_samples"),
      ("synthesis.py", "driven_samples")],
     [("synthesis.py", "impulse_grid"), ("synthesis.py", "_pair_grids")]),
    ("receiver noise", [("synthesis.py", "recording"), ("synthesis.py", "band_noise")], []),
    ("channel transforms", [("band.py", "band_spectra")], []),
    ("receive chain (beamforming to depth)", [("receiver.py", "process_spectra"),
                                              ("receiver.py", "noiseless_envelopes")], []),
)


def profile(fn, beams: int, units: int, rate_name: str) -> list:
    """Where the time of ``fn`` (``beams`` beams, ``units`` pings or frames) goes, by
    :data:`STAGES` (cProfile, inclusive times): prints one line per stage with its time per
    beam, its share, and the rate that stage alone would allow; returns [(stage, seconds per
    beam)]."""
    profiler = cProfile.Profile()
    profiler.runcall(fn)
    stats = pstats.Stats(profiler).stats  # (file, line, name) -> (cc, nc, tt, ct, callers)
    inclusive: dict = {}
    for (file, _, name), (_, _, _, ct, _) in stats.items():
        key = (Path(file).name, name)
        inclusive[key] = inclusive.get(key, 0.0) + ct
    total = max(ct for (_, _, _, ct, _) in stats.values())
    total_of = lambda functions: sum(inclusive.get(f, 0.0) for f in functions)  # noqa: E731
    rows = [(name, (total_of(add) - total_of(sub)) / beams) for name, add, sub in STAGES]
    rows.append(("other (Python, copies, bookkeeping)", total / beams - sum(t for _, t in rows)))
    for name, seconds in rows:
        print(f"    {name:<38s} {seconds * 1e3:8.2f} ms/beam {seconds * beams / total:6.1%}"
              f"   alone: {units / (seconds * beams) if seconds > 0 else np.inf:9.4g} {rate_name}")
    return rows


def tracer_vs_ray_intersect(sonar, pose, directions):
    """Acoustic trace of a batch of beams (as scans trace them) vs one bare scene.ray_intersect
    of as many rays."""
    tracer = sonar.tracer
    k = len(directions)
    t_trace, results = _timed(lambda: tracer.trace_many([pose] * k, directions, range(k)), repeat=5)
    n = sum(result.ray_count for result in results)
    d = np.random.default_rng(0).normal(size=(n, 3))
    d[:, 2] = np.abs(d[:, 2]) + 2
    d = pose.transform_vectors(d / np.linalg.norm(d, axis=1, keepdims=True))
    o = pose.translation

    def bare():
        import drjit as dr

        si = sonar.scene.scene.ray_intersect(rays(o, d))  # aligned inputs, as the tracer's
        dr.eval(si.t)
        return np.asarray(si.t)

    t_bare, _ = _timed(bare, repeat=5)
    return n / t_trace, n / t_bare


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default=str(ROOT / "scenes" / "room_glass" / "scene.xml"))
    parser.add_argument("--quick", action="store_true", help="fewer beams (a smoke run)")
    parser.add_argument("--memory-probe", choices=["ping", "frame", "sample"], help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.memory_probe:
        return _memory_probe(args.scene, args.memory_probe)
    sonar = mitsonar.Sonar(args.scene)
    pose = mitsonar.Pose.sensor_on_robot(0.0, 0.0, 0.0)
    step = np.radians(20.0 if args.quick else 5.0)  # the full run: a 117-beam scan
    dirs = sonar.fov_grid(step)
    lines = []

    def report(name, value, unit, baseline, baseline_name, goal=None):
        ratio = value / baseline
        lines.append((name, value, ratio))
        target = "" if goal is None else (
            f"; goal {goal:g}: " + ("reached" if ratio >= goal else f"{goal / ratio:.3g}x short"))
        print(f"{name:<34s} {value:12.4g} {unit:<10s} vs {baseline_name} {baseline:.4g}: "
              f"ratio {ratio:.3g} (higher is better{target})")

    def report_depths(ours, reference, reference_name="full-rate reference"):
        """Depth of the default configuration against the full-rate reference (or another
        ``reference_name``), beam by beam."""
        ours, reference = np.asarray(ours), np.asarray(reference)
        both = np.isfinite(ours) & np.isfinite(reference)
        same = int(np.sum(np.isfinite(ours) == np.isfinite(reference)))
        diff = np.abs(ours[both] - reference[both]) * 1000
        worst = diff.max(initial=0.0)
        lines.append(("depth difference", worst, worst))
        print(f"{'  depth vs ' + reference_name:<34s} {worst:12.3g} mm max, "
              f"{np.median(diff) if len(diff) else 0.0:.3g} mm median over {int(both.sum())} beams; "
              f"same decision on {same}/{len(ours)} (goal: within 1 mm)")

    middle = len(dirs) // 2
    ours, bare = tracer_vs_ray_intersect(sonar, pose, dirs[middle:middle + TRACE_BATCH])
    report(f"acoustic trace rays/s ({TRACE_BATCH} beams)", ours, "rays/s", bare,
           "bare ray_intersect", goal=0.5)

    t_ping, _ = _timed(lambda: sonar.scan(pose, dirs))
    report("single-beam pings/s (scan)", len(dirs) / t_ping, "pings/s", 1 / REAL_PING_S,
           "real sensor", goal=PING_GOAL)
    t_shared, _ = _timed(lambda: sonar.scan(pose, dirs, shared_hits=True))
    report("  the same, shared hits", len(dirs) / t_shared, "pings/s", 1 / REAL_PING_S,
           "real sensor", goal=PING_GOAL)
    t_alone, _ = _timed(lambda: [sonar.ping(pose, u) for u in dirs])
    print(f"{'  one ping() call per beam':<34s} {len(dirs) / t_alone:12.4g} pings/s")
    draft = mitsonar.Sonar(sonar.scene, fidelity("draft").apply(sonar.config))
    t_draft, _ = _timed(lambda: draft.scan(pose, dirs))
    print(f"{'  the draft preset (scan)':<34s} {len(dirs) / t_draft:12.4g} pings/s "
          f"(as accurate against the ground truth on the shipped scenes: docs/performance.md)")
    print("  where the time goes (cProfile of the scan, inclusive times per beam):")
    profiled = profile(lambda: sonar.scan(pose, dirs), len(dirs), len(dirs), "pings/s")
    # Full-rate reference: every element pair synthesised at 400 kHz; both without noise, so that
    # only the synthesis differs (same rays, same diffuse phases).
    quiet = replace(sonar.config, noise_rms=0.0)
    fast = mitsonar.Sonar(sonar.scene, quiet)
    full = mitsonar.Sonar(sonar.scene, replace(quiet, **FULL_RATE))
    per_beam_scan = fast.scan(pose, dirs).depth
    report_depths(per_beam_scan, full.scan(pose, dirs).depth)
    print("  where the time goes with shared hits (cProfile of the scan, per beam):")
    profiled += profile(lambda: sonar.scan(pose, dirs, shared_hits=True), len(dirs), len(dirs),
                        "pings/s")
    shared_scan = fast.scan(pose, dirs, shared_hits=True).depth
    report_depths(shared_scan, full.scan(pose, dirs, shared_hits=True).depth,
                  "its full-rate reference (shared)")
    report_depths(shared_scan, per_beam_scan, "per-beam trace (shared hits; side lobes)")

    schedule = OfdmSonar(sonar).schedule(sonar.fov_grid(np.radians(10.0 if args.quick else 5.0)))
    real_frames = 1 / REAL_FRAME_S * 117 / len(schedule.directions)
    for name, config in (("", sonar.config),
                         (", broadband", replace(sonar.config, transducer=BROADBAND))):
        shared_sonar = mitsonar.Sonar(sonar.scene, config)
        for shared in (False, True):
            ofdm = OfdmSonar(shared_sonar, shared_hits=shared)
            label = name + (", shared hits" if shared else "")
            for path, channels, goal in (("per-channel", True, FRAME_GOAL),
                                         ("detection-only", False, DETECTION_GOAL)):
                t_frame, _ = _timed(lambda: ofdm.frame(schedule, lambda t: pose,
                                                       channels=channels))
                report(f"OFDM frames/s ({len(schedule.directions)} beams{label}, {path})",
                       1 / t_frame, "frames/s", real_frames, "real sensor (per beam count)",
                       goal=goal)
                print(f"  where the time goes ({path}; cProfile of the frame, inclusive times "
                      f"per beam):")
                profiled += profile(lambda: ofdm.frame(schedule, lambda t: pose,
                                                       channels=channels),
                                    len(schedule.directions), 1, "frames/s")
        fast, full = (OfdmSonar(mitsonar.Sonar(sonar.scene, replace(config, noise_rms=0.0, **rate)),
                                shared_hits=False) for rate in ({}, FULL_RATE))
        per_beam = fast.frame(schedule, lambda t: pose).depth
        report_depths(per_beam, full.frame(schedule, lambda t: pose).depth)
        report_depths(fast.frame(schedule, lambda t: pose, channels=False).depth, per_beam,
                      "per-channel path")
        shared, shared_full = (OfdmSonar(o.sonar, shared_hits=True) for o in (fast, full))
        shared_depth = shared.frame(schedule, lambda t: pose).depth
        report_depths(shared_depth, shared_full.frame(schedule, lambda t: pose).depth,
                      "full-rate reference, shared hits")
        report_depths(shared_depth, per_beam, "per-beam trace (shared hits)")

    # Whole trajectories: repeated mode's frames (OFDM frame + camera image, as `mitsonar map
    # repeated` fires them) along the scene's trajectory, simulated by one process and by two
    # worker processes (mitsonar.parallel: the same frames; the workers' start included).
    trajectory = mitsonar.Trajectory.from_scene(args.scene)
    count = 2 if args.quick else 16
    print(f"repeated-mode frames along the trajectory ({count} frames from its start, "
          f"1 process vs 2 workers, the workers' start included):")
    for preset in ("paper",) if args.quick else ("paper", "default"):
        driven = mitsonar.Sonar(sonar.scene, mitsonar.SonarConfig.preset(preset))
        spec = RepeatedMapSpec(frames=count)
        rates = {}
        for workers in (1, 2):
            t0 = time.perf_counter()
            scan_repeated(driven, trajectory, spec, workers=workers)
            rates[workers] = count / (time.perf_counter() - t0)
            report(f"  {preset} preset, {workers} process{'es' if workers > 1 else ''}",
                   rates[workers], "frames/s", 1 / REAL_FRAME_S, "real sensor", goal=FRAME_GOAL)
        print(f"{'  ' + preset + ' preset: 2 workers / 1':<34s} {rates[2] / rates[1]:12.3g} x")

    # Echo modes (issue 28): what keeping every echo, every range cell or a cone image per beam
    # costs per detection-only frame beside the first echo; and one single-ping receive image.
    print("echo modes, detection-only OFDM frame (seconds per frame, ratio to the first echo):")
    seconds = {}
    for mode in ECHO_MODES:
        config = replace(sonar.config, detection=replace(sonar.config.detection, echoes=mode))
        moded = OfdmSonar(mitsonar.Sonar(sonar.scene, config))
        seconds[mode], frame = _timed(lambda: moded.frame(schedule, lambda t: pose,
                                                          channels=False))
        print(f"  {mode:<32s} {seconds[mode]:12.4g} s/frame  {len(frame.echo_table):5d} echoes  "
              f"ratio {seconds[mode] / seconds['first']:.3g} (goal: at most 2)")
        lines.append((f"echo mode {mode}", seconds[mode], seconds[mode] / seconds["first"]))
    # ... one driven by the 30-50 kHz sweep (mitsonar.Chirp()'s) behind broadband transducers,
    # and the strategy chart's best: the paper preset's 20-80 kHz sweep from the whole array
    # defocused (its images' points by the sub-band trust rule)
    wide = mitsonar.SonarConfig.preset("paper").with_drive(chirp="20-80")
    for name, config, transmit in (
            ("", sonar.config, TransmitSettings()),
            (", 30-50 kHz chirp", replace(sonar.config, pulse=mitsonar.Chirp(),
                                          transducer=BROADBAND), TransmitSettings()),
            (", paper 20-80 kHz defocused", wide, DEFOCUSED)):
        imager = ImagingSonar(mitsonar.Sonar(sonar.scene, config), transmit=transmit)
        t_image, image = _timed(lambda: imager.image(pose))
        print(f"  {'single-ping receive image' + name:<52s} {t_image:8.4g} s/image  "
              f"{len(image):5d} points  (one image per {imager.cycle_time * 1e3:.1f} ms "
              "listening cycle)")
        lines.append(("single-ping image" + name, t_image, t_image))

    # The camera image of a repeated-mode frame (320 px, 8 spp): the frozen render pass, replayed,
    # against Mitsuba's plain render (traced anew every call), both after their first calls.
    camera_model = CameraModel(spp=8).at_resolution(320)
    renders = {}
    for frozen in (True, False):
        camera = CameraRenderer(sonar.scene, camera_model, frozen=frozen)
        camera.render(pose, seed=1)  # the frozen pass records here and in _timed's warm-up
        renders[frozen] = _timed(lambda: camera.render(pose), repeat=3)[0]
    report("camera image, frozen render", 1.0 / renders[True], "images/s", 1.0 / renders[False],
           "plain render")

    # Fast synthesis vs the direct summation of (1)(3) on the same paths (paper model, ideal
    # transducers, 400 kHz: both agree to ~2e-4 of the peak), recorded to 1 m past the middle
    # beam's nearest reflector (at least 3 m).
    cfg = mitsonar.SonarConfig(trace=mitsonar.TraceSettings(model="paper"), transducer_response=False,
                               sample_rate=400e3, noise_rms=0.0, max_range=3.0, baseband=False,
                               band_floor=1e-5)
    u = dirs[len(dirs) // 2]
    paths = mitsonar.Sonar(sonar.scene, cfg).tracer.trace(pose, u).paths
    if len(paths.tx_delay):
        reach = cfg.medium.speed_of_sound * paths.tx_delay.min() + 1.0
        cfg = replace(cfg, max_range=max(cfg.max_range, reach))
    paper = mitsonar.Sonar(sonar.scene, cfg)
    t_fast, fast = _timed(lambda: paper.synthesizer.synthesize(paths, 25), repeat=3)
    t0 = time.perf_counter()
    slow = direct_summation(paths, cfg.pulse, 25, fast.times)
    t_slow = time.perf_counter() - t0
    error = np.abs(fast.samples - slow).max() / np.abs(slow).max()
    depth_fast = paper.processor.process(fast, u)[1].depth
    from mitsonar.signal.band import Recording

    depth_slow = paper.processor.process(Recording(slow, fast.sample_rate, fast.start_time), u)[1].depth
    report("fast synthesis speed-up", t_slow / t_fast, "x", 1.0, "direct (1)(3) summation", goal=100)
    depths = "neither detects" if np.isnan(depth_fast) and np.isnan(depth_slow) else \
        f"depth difference {abs(depth_fast - depth_slow) * 1000:.4f} mm"
    print(f"{'  same paths: max difference':<34s} {error:12.3g} of peak; {depths}")
    lines.append(("synthesis error", error, error))

    from peer_sionna import peer_lines  # benchmarks/peer_sionna.py, beside this script

    lines += peer_lines(args.scene, sonar, pose, dirs[middle:middle + TRACE_BATCH], args.quick)

    for probe in ("ping", "frame", "sample"):
        peak = _probe_peak(args.scene, probe)
        print(f"{'peak memory, one ' + probe:<34s} {peak / 2**20:12.1f} MiB (fresh process)")
        lines.append((probe, peak, peak))
    bad = [name for name, value, ratio in lines if not (np.isfinite(value) and np.isfinite(ratio))]
    bad += [f"profile: {name}" for name, seconds in profiled if not np.isfinite(seconds)]
    if bad:
        print(f"non-finite output: {', '.join(bad)}", file=sys.stderr)
        return 1
    return 0


def _probe_peak(scene: str, probe: str) -> float:
    """Peak resident memory [bytes] of a fresh process doing one ping, frame or dataset sample."""
    out = subprocess.run([sys.executable, __file__, "--scene", scene, "--memory-probe", probe],
                         capture_output=True, text=True, check=True)
    return float(json.loads(out.stdout.strip().splitlines()[-1])["peak_bytes"])


def _memory_probe(scene: str, what: str) -> int:
    pose = mitsonar.Pose.sensor_on_robot(0.0, 0.0, 0.0)
    sonar = mitsonar.Sonar(scene)
    if what == "ping":
        sonar.ping(pose, np.array([0.0, 0.0, 1.0]))
    elif what == "frame":
        ofdm = OfdmSonar(sonar)
        ofdm.frame(ofdm.schedule(sonar.fov_grid(np.radians(10.0))), lambda t: pose)
    else:
        import tempfile

        from mitsonar.data.dataset import DatasetSpec, render_dataset

        with tempfile.TemporaryDirectory() as tmp:
            render_dataset(DatasetSpec(scene, max_samples=1), Path(tmp) / "ds")
    # VmHWM (peak resident set of this process image); ru_maxrss would carry the parent's peak
    # across fork + exec on Linux.
    status = Path("/proc/self/status").read_text()
    hwm_kib = next(int(line.split()[1]) for line in status.splitlines() if line.startswith("VmHWM:"))
    print(json.dumps({"peak_bytes": hwm_kib * 1024}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
