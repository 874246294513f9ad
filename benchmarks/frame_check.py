"""Same frames before and after a speed change: OFDM frames saved by one version of the code and
compared with another's (decisions, depths, echo tables).

    .venv/bin/python benchmarks/frame_check.py --save out/frames_before.npz
    (change the code)
    .venv/bin/python benchmarks/frame_check.py --against out/frames_before.npz

The frames: the benchmark's (``benchmarks/run.py``: 117 beams from the origin pose, the default
configuration, seed 0) on room_glass and office, and the whole-trajectory experiments' (the
``paper`` preset with every echo and range cell, ``echoes='cells'``, as
``experiments/imaging.py`` runs it) on office at three times of its trajectory; each on the
per-channel and the detection-only path. ``--against`` prints, per frame, the beams whose
decision changed and the largest depth and echo-point differences, and exits 1 when a decision
changed or a depth moved by more than ``--tolerance`` [m].
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import mitsonar
from mitsonar.sensors.ofdm_sonar import OfdmSonar, pose_along

ROOT = Path(__file__).resolve().parents[1]
#: Times [s] on office's trajectory of the paper preset's frames.
TRAJECTORY_TIMES = (0.0, 20.85, 62.55)


def frames(quick: bool = False) -> dict:
    """{name: Frame} of every frame checked (module docstring)."""
    out = {}
    origin = mitsonar.Pose.sensor_on_robot(0.0, 0.0, 0.0)
    cases = [(scene, "default", [(0.0, lambda t: origin)]) for scene in ("room_glass", "office")]
    office = ROOT / "scenes" / "office" / "scene.xml"
    along = pose_along(mitsonar.Trajectory.from_scene(office))
    cases.append(("office", "paper", [(t, along) for t in TRAJECTORY_TIMES[: 1 if quick else 3]]))
    for scene, preset, starts in cases:
        config = mitsonar.SonarConfig.preset(preset)
        if preset == "paper":
            config = config.with_detection(echoes="cells")
        sonar = mitsonar.Sonar(ROOT / "scenes" / scene / "scene.xml", config)
        ofdm = OfdmSonar(sonar)
        schedule = ofdm.schedule(sonar.fov_grid(np.radians(10.0 if quick else 5.0)))
        for start, pose_at in starts:
            for channels in (True, False):
                name = f"{scene}_{preset}_{start:g}s_{'channels' if channels else 'detection'}"
                out[name] = ofdm.frame(schedule, pose_at, start_time=start, seed=0,
                                       channels=channels)
    return out


def arrays(frame) -> dict:
    e = frame.echo_table
    return {"detected": frame.detected, "depth": frame.depth, "points": frame.points_sensor,
            "echo_beam": e.beam, "echo_point": e.point}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    which = parser.add_mutually_exclusive_group(required=True)
    which.add_argument("--save", type=Path, help="write the frames here (.npz)")
    which.add_argument("--against", type=Path, help="compare with frames saved here")
    parser.add_argument("--tolerance", type=float, default=1e-6, help="depth tolerance [m]")
    parser.add_argument("--quick", action="store_true", help="fewer beams and frames")
    args = parser.parse_args(argv)
    now = {f"{name}/{key}": value for name, frame in frames(args.quick).items()
           for key, value in arrays(frame).items()}
    if args.save:
        args.save.parent.mkdir(parents=True, exist_ok=True)
        np.savez(args.save, **now)
        print(f"saved {len(now) // 5} frames to {args.save}")
        return 0
    before = np.load(args.against)
    failed = False
    for name in sorted({key.split("/")[0] for key in now}):
        get = lambda source, key: source[f"{name}/{key}"]  # noqa: E731
        changed = int(np.sum(get(now, "detected") != get(before, "detected")))
        both = get(now, "detected") & get(before, "detected")
        depth = np.abs(get(now, "depth") - get(before, "depth"))[both].max(initial=0.0)
        same_echoes = np.array_equal(get(now, "echo_beam"), get(before, "echo_beam"))
        point = np.abs(get(now, "echo_point") - get(before, "echo_point")).max(initial=0.0) \
            if same_echoes else np.inf
        bad = changed > 0 or depth > args.tolerance or not same_echoes
        failed |= bad
        print(f"{name:<42s} {int(both.sum()):3d} detected, {changed} decisions changed, depth "
              f"{depth:.3g} m, {len(get(now, 'echo_beam'))} echoes "
              f"({'same beams' if same_echoes else 'DIFFERENT'}, points {point:.3g} m)"
              f"{'  FAIL' if bad else ''}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
