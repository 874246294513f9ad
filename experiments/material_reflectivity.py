"""Material reflectivity study: echo amplitude and detection rate against impedance and incidence.

A: a smooth wall 2 m ahead at normal incidence with impedances from 100 Rayl to 1e8 Rayl (and
the presets): the beamformed echo over that of a rigid wall, squared, against the paper's energy
reflection coefficient (4), R = ((Z2 - Z1) / (Z2 + Z1))^2.
B: walls of the presets turned by an incidence angle of 0-40 deg about the vertical: echo level
re normal incidence and detection rate over seeds (noise and diffuse phases). Smooth walls
vanish a few degrees off the normal (the specular return leaves the array); rough ones keep a
diffuse echo that falls with the Lambert factors.
Writes CSV + Markdown tables and a PNG.

    .venv/bin/python experiments/material_reflectivity.py --out out/material_reflectivity
    .venv/bin/python experiments/material_reflectivity.py --quick --out out/material_reflectivity
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

import mitsonar
from mitsonar.io import atomic_path, write_table
from mitsonar.physics.materials import preset
from mitsonar.plots import _pyplot, save_png

BROADSIDE = np.array([0.0, 0.0, 1.0])
DISTANCE = 2.0  # wall distance [m]
PRESETS = ("glass", "drywall", "concrete", "wood", "fabric", "foam")


def wall_scene(directory: Path, name: str, material: str, incidence: float = 0.0) -> Path:
    """A 30 m x 30 m wall turned by ``incidence`` [rad] about a vertical axis through the point
    ``DISTANCE`` ahead of the sensor (the beam always meets it there); ``material`` is the inside
    of the acoustic BSDF element."""
    path = directory / f"{name}.xml"
    path.write_text(
        f'<scene version="3.0.0"><bsdf type="acoustic" id="wall">{material}</bsdf>'
        '<shape type="rectangle"><transform name="to_world"><scale x="15" y="15"/>'
        f'<rotate y="1" angle="{np.degrees(incidence)}"/><translate z="{DISTANCE}"/>'
        '</transform><ref id="wall"/></shape></scene>')
    return path


def pings(path: Path, seeds=(0,)) -> list:
    """Detections of broadside pings at the wall of scene ``path``, one per seed (scene loaded once)."""
    sonar = mitsonar.Sonar(path)
    return [sonar.ping(mitsonar.Pose.identity(), BROADSIDE, seed=seed).detection for seed in seeds]


def impedance_sweep(tmp: Path, impedances) -> list[dict]:
    rigid = pings(wall_scene(tmp, "rigid", '<float name="impedance" value="1e12"/>'
                                           '<float name="scattering" value="0"/>'))[0].amplitude
    z_air = mitsonar.Medium().impedance
    rows = []
    for label, z in [(f"{z:.3g} Rayl", z) for z in impedances] + [
            (p, preset(p).normal_impedance(z_air)) for p in PRESETS]:
        det = pings(wall_scene(tmp, "z", f'<float name="impedance" value="{z}"/>'
                                         '<float name="scattering" value="0"/>'))[0]
        rows.append({"material": label, "impedance_rayl": z,
                     "energy_reflection_measured": (det.amplitude / rigid) ** 2,
                     "energy_reflection_eq4": ((z - z_air) / (z + z_air)) ** 2,
                     "depth_m": det.depth})
    return rows


def incidence_sweep(tmp: Path, angles, seeds) -> list[dict]:
    rows = []
    for name in PRESETS:
        normal = None
        for angle in angles:
            path = wall_scene(tmp, name, f'<string name="preset" value="{name}"/>', angle)
            dets = pings(path, seeds)
            level = float(np.mean([d.amplitude for d in dets]))
            normal = level if normal is None else normal
            depth = np.array([d.depth for d in dets])
            rows.append({"material": name, "scattering": preset(name).scattering,
                         "incidence_deg": float(np.degrees(angle)),
                         "echo_db_re_normal": 20 * np.log10(level / normal),
                         "detection_rate": float(np.mean([d.detected for d in dets])),
                         "median_depth_error_mm": float(1e3 * np.nanmedian(np.abs(depth - DISTANCE)))
                         if np.isfinite(depth).any() else np.nan})
            print(f"{name:9s} {np.degrees(angle):4.0f} deg: {rows[-1]['echo_db_re_normal']:+6.1f} dB, "
                  f"detected {rows[-1]['detection_rate']:.0%}", file=sys.stderr)
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/material_reflectivity"))
    parser.add_argument("--seeds", type=int, default=5, help="pings per wall and angle")
    parser.add_argument("--quick", action="store_true", help="few impedances, angles and seeds")
    args = parser.parse_args(argv)
    impedances = np.logspace(2, 8, 4 if args.quick else 13)
    angles = np.radians([0, 10, 30] if args.quick else np.arange(0, 41, 5))
    seeds = range(1 if args.quick else args.seeds)
    with tempfile.TemporaryDirectory() as tmp:
        table_a = impedance_sweep(Path(tmp), impedances)
        table_b = incidence_sweep(Path(tmp), angles, seeds)
    write_outputs(args.out, table_a, table_b)
    return 0


def write_outputs(out: Path, table_a: list[dict], table_b: list[dict]) -> None:
    out.mkdir(parents=True, exist_ok=True)
    write_table(out / "impedance.csv", table_a)
    write_table(out / "incidence.csv", table_b)
    md = ["| material | Z [Rayl] | R measured | R by (4) |", "|---|---:|---:|---:|"]
    md += [f"| {r['material']} | {r['impedance_rayl']:.3g} | {r['energy_reflection_measured']:.4f} | "
           f"{r['energy_reflection_eq4']:.4f} |" for r in table_a]
    angles = sorted({r["incidence_deg"] for r in table_b})
    md += ["", "| material (scattering) | " + " | ".join(f"{a:.0f} deg" for a in angles) + " |",
           "|---|" + "---:|" * len(angles)]
    for name in PRESETS:
        rows = [r for r in table_b if r["material"] == name]
        md.append(f"| {name} ({rows[0]['scattering']:.2f}) | " + " | ".join(
            f"{r['echo_db_re_normal']:+.1f} dB, {r['detection_rate']:.0%}" for r in rows) + " |")
    with atomic_path(out / "material_reflectivity.md") as tmp:
        tmp.write_text("\n".join(md) + "\n")

    plt = _pyplot()
    fig, (a1, a2, a3) = plt.subplots(1, 3, figsize=(15, 4.2))
    z = np.logspace(1, 9, 400)
    z_air = mitsonar.Medium().impedance
    a1.semilogx(z, ((z - z_air) / (z + z_air)) ** 2, "k-", label="(4): ((Z2 - Z1) / (Z2 + Z1))^2")
    sweep = [r for r in table_a if r["material"].endswith("Rayl")]
    a1.semilogx([r["impedance_rayl"] for r in sweep], [r["energy_reflection_measured"] for r in sweep],
                "o", label="mitsonar echo^2 / rigid wall's")
    for r in table_a:
        if not r["material"].endswith("Rayl"):
            a1.semilogx(r["impedance_rayl"], r["energy_reflection_measured"], "s")
            a1.annotate(r["material"], (r["impedance_rayl"], r["energy_reflection_measured"]),
                        textcoords="offset points", xytext=(4, -10), fontsize=8)
    a1.axvline(z_air, color="0.7", ls=":")
    a1.set_xlabel("wall impedance Z2 [Rayl]  (dotted: air)")
    a1.set_ylabel("energy reflection coefficient R")
    a1.set_title("normal incidence, 2 m")
    a1.legend(fontsize=8)
    for name in PRESETS:
        rows = [r for r in table_b if r["material"] == name]
        x = [r["incidence_deg"] for r in rows]
        a2.plot(x, [r["echo_db_re_normal"] for r in rows], "o-", label=f"{name} (s={rows[0]['scattering']:.2f})")
        a3.plot(x, [100 * r["detection_rate"] for r in rows], "o-", label=name)
    a2.set_xlabel("incidence angle [deg]")
    a2.set_ylabel("echo level re normal incidence [dB]")
    a2.set_title("beam at broadside, wall turned")
    a2.legend(fontsize=8)
    a3.set_xlabel("incidence angle [deg]")
    a3.set_ylabel("detection rate [%]")
    a3.set_ylim(-5, 105)
    fig.tight_layout()
    save_png(fig, out / "material_reflectivity.png")
    print("\n".join(md))
    print(f"Wrote {out}/impedance.csv, incidence.csv, material_reflectivity.md and .png")


if __name__ == "__main__":
    sys.exit(main())
