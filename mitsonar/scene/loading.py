"""Loading Mitsuba scenes with acoustic materials: one ``mi.Scene`` serves camera, sonar, ground truth."""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from mitsonar._native import configure_llvm
from mitsonar.jit import count_registry_changes, variant
from mitsonar.physics.materials import DEFAULT_MATERIAL_NAME, AcousticMaterial, preset
from mitsonar.scene.catalog import resolve_scene, shipped_scenes

class SceneError(ValueError):
    """A scene file could not be loaded; the message names the file and the cause."""


class DefaultMaterialWarning(UserWarning):
    """Shapes without acoustic properties were given the default material."""


_registered = False


def mitsuba():
    """Import Mitsuba with a working LLVM, set mitsonar's variant (:func:`mitsonar.jit.variant`),
    register the plugins."""
    global _registered
    configure_llvm()
    import mitsuba as mi

    if mi.variant() != variant():
        try:
            mi.set_variant(variant())
        except (ImportError, AttributeError) as err:
            raise ValueError(f"Mitsuba variant {variant()!r} is not available here: {err}") from None
    if not _registered:
        from mitsonar.plugins import acoustic, lights

        acoustic.register()
        lights.register()
        _registered = True
    return mi


@dataclass
class AcousticScene:
    """A loaded scene and the acoustic material of each of its shapes.

    Attributes:
        path: the scene file.
        scene: the Mitsuba scene (camera, sonar and ground truth all use it).
        shape_ids: id of every shape, in ``scene.shapes()`` order.
        materials: distinct acoustic materials.
        shape_material: (n_shapes,) index into ``materials`` per shape.
        registry_ids: (n_shapes,) Dr.Jit registry id of each shape (what ``si.shape`` holds).
    """

    path: Path
    scene: object
    shape_ids: list
    materials: list
    shape_material: np.ndarray
    registry_ids: np.ndarray

    @cached_property
    def hits(self):
        """First-hit queries on this scene (:class:`~mitsonar.scene.hits.SceneHits`), their
        tables made once, when first asked for."""
        from mitsonar.scene.hits import SceneHits

        return SceneHits(self)


def load_scene(path, default_material: AcousticMaterial | None = None) -> AcousticScene:
    """Load a Mitsuba XML scene whose BSDFs may be ``<bsdf type="acoustic">``; ``path`` may
    also name a shipped scene (:func:`~mitsonar.scene.catalog.resolve_scene`).

    Shapes without acoustic properties get ``default_material`` (the ``drywall`` preset unless
    given) and one :class:`DefaultMaterialWarning` names them all. Raises :class:`SceneError`
    naming the file for a missing or malformed file and for invalid acoustic properties.
    """
    path = resolve_scene(path)
    if not path.is_file():
        raise SceneError(f"{path}: scene file not found (shipped scenes: "
                         f"{', '.join(shipped_scenes())})")
    mi = mitsuba()
    import drjit as dr
    from mitsonar.plugins.acoustic import AcousticBSDF

    try:
        scene = mi.load_file(str(path), optimize=False)
    except Exception as err:  # Mitsuba raises RuntimeError/ValueError with the parser's message
        raise _loading_error(path, str(err)) from None
    default = default_material or preset(DEFAULT_MATERIAL_NAME)
    shapes = list(scene.shapes())
    if not shapes:
        raise SceneError(f"{path}: the scene has no shapes")
    materials: list[AcousticMaterial] = []
    index_of: dict[int, int] = {}
    shape_material = np.empty(len(shapes), dtype=np.int64)
    registry_ids = np.empty(len(shapes), dtype=np.int64)
    defaulted = []
    for k, shape in enumerate(shapes):
        bsdf = shape.bsdf()
        if isinstance(bsdf, AcousticBSDF):
            material = bsdf.acoustic
        else:
            material = default
            defaulted.append(shape.id() or f"shape #{k}")
        key = id(material)
        if key not in index_of:
            index_of[key] = len(materials)
            materials.append(material)
        shape_material[k] = index_of[key]
        registry_ids[k] = int(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(shape))[0])
    if defaulted:
        warnings.warn(f"{path}: {len(defaulted)} shape(s) have no acoustic material and get the "
                      f"default '{default.name}': {', '.join(defaulted)}", DefaultMaterialWarning,
                      stacklevel=2)
    loaded = AcousticScene(path, scene, [s.id() for s in shapes], materials, shape_material,
                           registry_ids)
    count_registry_changes(loaded)  # its shapes, BSDFs and emitters (mitsonar.jit)
    return loaded


#: Mitsuba's source location before its messages, e.g. "[parser.cpp:1718] ".
_SOURCE_TAG = re.compile(r"\[[\w.]+:\d+\] ")
#: Where the parser failed: "At FILE (line L, col C): ".
_AT = re.compile(r"At (?P<file>.+?) \((?P<where>line \d+, col \d+)\): ")
#: The traceback Mitsuba wraps a Python plugin's exception in, up to the exception's message.
_PLUGIN_TRACEBACK = re.compile(r"failed to instantiate \w+ plugin of type \"\w+\": "
                               r"Traceback \(most recent call last\):\n(?:.*\n)*[\w.]+: ")


def _loading_error(path: Path, message: str) -> SceneError:
    """One line from Mitsuba's loading error: its source tags and the traceback around a Python
    plugin's exception (an invalid acoustic material) removed, the failure located as
    'FILE (line L, col C)' where Mitsuba says where."""
    message = _PLUGIN_TRACEBACK.sub("", _SOURCE_TAG.sub("", message))
    at = _AT.match(message)
    if at is None:
        return SceneError(f"{path}: {message}")
    where = f"{at['file']} ({at['where']})"
    if at["file"] != str(path):  # in an included file
        where = f"{path}: {where}"
    return SceneError(f"{where}: {message[at.end():]}")


def optically_transparent(bsdf) -> bool:
    """True if a Mitsuba BSDF lets light through: any transmission lobe (dielectric,
    thindielectric, roughdielectric) or a null component (``null``, ``mask`` with opacity < 1).
    The ``acoustic`` wrapper reports its nested BSDF's flags."""
    mi = mitsuba()
    return bool(mi.has_flag(bsdf.flags(), mi.BSDFFlags.Transmission | mi.BSDFFlags.Null))
