"""Wall thickness against robot speed in OFDM repeated scanning (the paper's Fig. 8b failure case).

The robot drives straight at a concrete wall 3.5 m ahead and fires OFDM frames back to back.
A 208.5 ms frame leaves from poses up to v x 0.21 m apart; registering every beam of a frame
with the frame's odometry pose (the paper's (12), ``registration="frame"``) smears the wall
along the motion, so it gets thicker with speed. Registering each beam with its own pose at
firing (``registration="beam"``) removes the smear. Thickness is the 5-95 % spread of the
voxel map's wall voxels along the wall normal (x). Writes CSV + Markdown tables and a PNG.

    .venv/bin/python experiments/ofdm_motion.py --out out/ofdm_motion          # about 15 min
    .venv/bin/python experiments/ofdm_motion.py --quick --out out/ofdm_motion  # about 30 s
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

import mitsonar
from mitsonar.io import write_table
from mitsonar.recon.repeated import REGISTRATIONS, RepeatedMapSpec, build_voxel_map, scan_repeated
from mitsonar.plots import _pyplot, save_png
from mitsonar.recon.voxelmap import VoxelMapSettings

#: World x of the wall [m]; the robot starts at x = 0 facing +x (sensor head at x = 0.1).
WALL_X = 3.5


def wall_scene(directory: Path) -> Path:
    """A 10 m x 4 m concrete wall facing -x at ``WALL_X``, lit by a uniform sky."""
    path = directory / "wall.xml"
    path.write_text(
        '<scene version="3.0.0">'
        '<bsdf type="acoustic" id="wall"><string name="preset" value="concrete"/>'
        '<bsdf type="diffuse"/></bsdf>'
        '<shape type="rectangle"><transform name="to_world"><scale x="2" y="5"/>'
        f'<rotate y="1" angle="-90"/><translate x="{WALL_X}" z="1.0"/></transform>'
        '<ref id="wall"/></shape>'
        '<emitter type="constant"><rgb name="radiance" value="1"/></emitter></scene>')
    return path


def thickness(positions: np.ndarray) -> float:
    """5-95 % spread [m] of voxel positions (M, 3) along the wall normal x (NaN if < 5 voxels)."""
    x = positions[np.abs(positions[:, 0] - WALL_X) < 1.0, 0]
    return float(np.subtract(*np.percentile(x, [95, 5]))) if len(x) >= 5 else np.nan


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/ofdm_motion"))
    parser.add_argument("--speeds", default="0.1,0.25,0.5,1,1.5", help="m/s, comma separated")
    parser.add_argument("--frames", type=int, default=4, help="OFDM frames per speed")
    parser.add_argument("--step", type=float, default=5.0, help="beam grid step [deg]")
    parser.add_argument("--quick", action="store_true",
                        help="2 speeds, 2 frames on a 20 deg beam grid (for the test suite)")
    args = parser.parse_args(argv)
    speeds = [float(s) for s in args.speeds.split(",")]
    frames, step = args.frames, args.step
    if args.quick:
        speeds, frames, step = [0.1, 1.5], 2, 20.0
    config = mitsonar.SonarConfig(transducer=mitsonar.Transducer.broadband())
    spec = RepeatedMapSpec(frames=frames, scan_step=np.radians(step), image_width=160, spp=4,
                           voxels=VoxelMapSettings(voxel_size=0.02))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        sonar = mitsonar.Sonar(wall_scene(Path(tmp)), config)
        for v in speeds:
            trajectory = mitsonar.Trajectory(np.array([[0.0, 0.0, 0.0], [3.0, 0.0, 0.0]]), speed=v)
            scanned, camera = scan_repeated(sonar, trajectory, spec)
            points = sum(int(s.frame.detected.sum()) for s in scanned)
            row = {"speed_m_s": v, "smear_per_frame_m": v * scanned[0].frame.schedule.frame_duration,
                   "points": points}
            for registration in REGISTRATIONS:
                voxels = build_voxel_map(scanned, camera, replace(spec, registration=registration))
                row[f"thickness_{registration}_m"] = thickness(voxels.positions)
            rows.append(row)
            print(f"{v:4.2f} m/s: {points} points, wall thickness "
                  f"{100 * row['thickness_frame_m']:.1f} cm (frame pose), "
                  f"{100 * row['thickness_beam_m']:.1f} cm (beam poses)", file=sys.stderr)
    write_outputs(args.out, rows, frames, step)
    return 0


def write_outputs(out: Path, rows: list[dict], frames: int, step: float) -> None:
    out.mkdir(parents=True, exist_ok=True)
    md = ["| speed [m/s] | motion per frame [cm] | points | thickness, frame pose [cm] | "
          "thickness, beam poses [cm] |", "|---:|---:|---:|---:|---:|"]
    md += [f"| {r['speed_m_s']:.2f} | {100 * r['smear_per_frame_m']:.1f} | {r['points']} | "
           f"{100 * r['thickness_frame_m']:.1f} | {100 * r['thickness_beam_m']:.1f} |" for r in rows]
    write_table(out / "ofdm_motion.csv", rows, md)
    plt = _pyplot()
    v = np.array([r["speed_m_s"] for r in rows])
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(v, [100 * r["thickness_frame_m"] for r in rows], "o-",
            label="one odometry pose per frame (paper)")
    ax.plot(v, [100 * r["thickness_beam_m"] for r in rows], "s-", label="each beam's own pose")
    ax.plot(v, [100 * r["smear_per_frame_m"] for r in rows], "k:", label="motion during a frame")
    ax.set_xlabel("robot speed towards the wall [m/s]")
    ax.set_ylabel("wall thickness in the voxel map, 5-95 % [cm]")
    ax.set_title(f"OFDM repeated scanning: {frames} frames, {step:g} deg beams, 2 cm voxels")
    ax.legend()
    fig.tight_layout()
    save_png(fig, out / "ofdm_motion.png")
    print("\n".join(md))
    print(f"Wrote {out}/ofdm_motion.csv, .md and .png")


if __name__ == "__main__":
    sys.exit(main())
