"""Shipped scenes by name: the folders of the package ``mitsonar.scenes`` (``scenes/`` in the
repository) that hold a ``scene.xml``, wherever mitsonar is installed."""

from __future__ import annotations

import importlib.util
from pathlib import Path


def shipped_scenes() -> dict[str, Path]:
    """Scene name -> its ``scene.xml``, sorted by name."""
    spec = importlib.util.find_spec("mitsonar.scenes")
    folders = [Path(p) for p in (spec.submodule_search_locations or [])] if spec else []
    found = {xml.parent.name: xml for folder in folders for xml in folder.glob("*/scene.xml")}
    return dict(sorted(found.items()))


def resolve_scene(scene) -> Path:
    """The scene file ``scene`` names: an existing file as given, else the shipped scene of that
    name (``room_glass`` -> its ``scene.xml``), else the path unchanged (loading reports it)."""
    path = Path(scene)
    if path.is_file():
        return path
    return shipped_scenes().get(str(scene), path)
