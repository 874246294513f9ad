"""Write the shipped Mitsuba scenes: ``python scenes/generate.py [--out DIR] [--only NAME]``.

Each scene of ``mitsonar.scene.shipped.SCENES`` goes to ``<out>/<name>/`` (default: beside this
file) as scene.xml, ground_truth.json and its PNGs (formats: ``mitsonar.scene.building.spec``).
Deterministic: regenerating gives identical bytes (a test checks the shipped files against a
fresh generation). Needs mitsonar installed (``make install``); ``--preview DIR`` also renders
PNG previews with Mitsuba. ``--varied N --out DIR`` writes the varied rooms ``varied_0`` ...
``varied_<N-1>`` (``mitsonar.scene.varied``) instead of the shipped scenes. ``--lighting`` picks
the look (``mitsonar.scene.building.lights.LIGHTINGS``: ``key``, the default, or ``ceiling``).
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

from mitsonar.scene.building.lights import LIGHTINGS
from mitsonar.scene.building.preview import render_preview
from mitsonar.scene.shipped import SCENES
from mitsonar.scene.varied.room import varied_room, write_varied_rooms

#: What scene.xml's header names as the program to edit.
WRITTEN_BY = "scenes/generate.py"


def generate(out_dir=None, names=None, lighting: str = LIGHTINGS[0]) -> list[Path]:
    """Write the scenes ``names`` (default: all) into ``out_dir`` (default: beside this file)
    in the look ``lighting``."""
    out_dir = Path(out_dir) if out_dir is not None else Path(__file__).resolve().parent
    names = list(SCENES) if names is None else list(names)
    unknown = [n for n in names if n not in SCENES]
    if unknown:
        raise ValueError(f"unknown scene(s) {unknown}; known: {', '.join(SCENES)}")
    return [replace(SCENES[n](), lighting=lighting).write(out_dir, WRITTEN_BY) for n in names]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=None,
                   help="output directory (default: the directory of this script)")
    p.add_argument("--only", action="append", metavar="NAME",
                   help=f"scene to write (repeatable; default all: {', '.join(SCENES)})")
    p.add_argument("--preview", type=Path, metavar="DIR",
                   help="also render <DIR>/<scene>_camera.png and <scene>_overview.png "
                        "(320 x 240, 16 spp)")
    p.add_argument("--varied", type=int, metavar="N",
                   help="write the varied rooms varied_0 ... varied_<N-1> (seeds 0 ... N-1) "
                        "instead of the shipped scenes; needs --out")
    p.add_argument("--lighting", choices=LIGHTINGS, default=LIGHTINGS[0],
                   help="the look: 'key' (key light, fill and ambient, direct light only, as the "
                        "paper's Gazebo worlds) or 'ceiling' (ceiling panels, sun through the "
                        "windows, interreflection) (default: key)")
    args = p.parse_args(argv)
    if args.varied is not None and (args.out is None or args.only or args.varied < 1):
        p.error("--varied N needs N >= 1 and --out DIR, and no --only")
    try:
        paths = generate(args.out, args.only, args.lighting) if args.varied is None else \
            write_varied_rooms(args.out, range(args.varied), args.lighting)
    except ValueError as err:
        print(f"generate.py: error: {err}", file=sys.stderr)
        return 2
    for path in paths:
        gt = json.loads((path.parent / "ground_truth.json").read_text())
        print(f"{path}: {len(gt['shapes'])} shapes, floor {gt['floor_area_m2']:.2f} m^2, "
              f"{len(gt['windows'])} windows")
        if args.preview:
            name = path.parent.name
            spec = SCENES[name]() if args.varied is None else \
                varied_room(int(name.removeprefix("varied_")), args.lighting)
            for view in ("camera", "overview"):
                png = args.preview / f"{spec.name}_{view}.png"
                render_preview(path, png, view, overview=spec.overview)
                print(f"  preview {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
