"""``mitsonar scenes``: the shipped scenes, by the names every command accepts."""

from __future__ import annotations

import json

from mitsonar.scene.catalog import shipped_scenes


def add_cli(subparsers) -> None:
    """``mitsonar scenes``."""
    p = subparsers.add_parser(
        "scenes", help="list the shipped scenes (give their names wherever a scene is asked for)",
        description="List the scenes installed with mitsonar: name, description and file. Every "
                    "command that takes a scene accepts such a name as well as a path, e.g. "
                    "'mitsonar scan room_glass --out out/scan'.")
    p.set_defaults(func=_run_scenes)


def _run_scenes(args) -> int:
    scenes = shipped_scenes()
    if not scenes:
        raise FileNotFoundError("no shipped scenes found (is the mitsonar.scenes package "
                                "installed?)")
    width = max(map(len, scenes))
    for name, path in scenes.items():
        truth = path.with_name("ground_truth.json")
        about = json.loads(truth.read_text()).get("description", "") if truth.is_file() else ""
        print(f"{name:{width}s}  {about}\n{'':{width}s}  {path}")
    return 0
