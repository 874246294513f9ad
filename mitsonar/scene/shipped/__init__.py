"""The shipped scenes (written into ``mitsonar.scenes`` by ``python scenes/generate.py``), one
module per scene, each built from ``mitsonar.scene.building``: ``room_glass`` and ``structure``
(surfel-mode scenes of the paper, texture-less), ``workshop`` and ``office`` (repeated-scan
scenes: furniture, small objects, colours and textures). Adding a scene: write a module whose
``build()`` returns a :class:`~mitsonar.scene.building.spec.SceneSpec` and register it in
``SCENES``."""

from __future__ import annotations

from typing import Callable

from mitsonar.scene.building.spec import SceneSpec
from mitsonar.scene.shipped import office, room_glass, structure, workshop

#: Scene name -> function building it.
SCENES: dict[str, Callable[[], SceneSpec]] = {"room_glass": room_glass.build,
                                              "structure": structure.build,
                                              "workshop": workshop.build, "office": office.build}
