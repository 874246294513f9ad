"""Loading Mitsuba scenes with acoustic materials: one ``mi.Scene`` serves camera, sonar, ground truth."""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mitsonar._native import configure_llvm
from mitsonar.physics.materials import DEFAULT_MATERIAL_NAME, AcousticMaterial, preset

#: Mitsuba variant used everywhere: Dr.Jit's LLVM backend (CPU), RGB for the camera.
VARIANT = "llvm_ad_rgb"


class SceneError(ValueError):
    """A scene file could not be loaded; the message names the file and the cause."""


class DefaultMaterialWarning(UserWarning):
    """Shapes without acoustic properties were given the default material."""


_registered = False


def mitsuba():
    """Import Mitsuba with a working LLVM, set mitsonar's variant, register the plugins."""
    global _registered
    configure_llvm()
    import mitsuba as mi

    if mi.variant() != VARIANT:
        mi.set_variant(VARIANT)
    if not _registered:
        from mitsonar.plugins import acoustic

        acoustic.register()
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
        material_of_registry_id: table from a shape's Dr.Jit registry id to its material index
            (-1 for ids that are not shapes of this scene).
    """

    path: Path
    scene: object
    shape_ids: list
    materials: list
    shape_material: np.ndarray
    registry_ids: np.ndarray
    material_of_registry_id: np.ndarray

    def material_index(self, shape_ptr) -> np.ndarray:
        """Material index per lane of a Dr.Jit ``ShapePtr`` array (-1 where nothing was hit)."""
        mi = mitsuba()
        import drjit as dr

        reg = np.asarray(dr.reinterpret_array(mi.UInt32, shape_ptr), dtype=np.int64)
        table = self.material_of_registry_id
        inside = reg < len(table)
        return np.where(inside, table[np.minimum(reg, len(table) - 1)], -1)


def load_scene(path, default_material: AcousticMaterial | None = None) -> AcousticScene:
    """Load a Mitsuba XML scene whose BSDFs may be ``<bsdf type="acoustic">``.

    Shapes without acoustic properties get ``default_material`` (the ``drywall`` preset unless
    given) and one :class:`DefaultMaterialWarning` names them all. Raises :class:`SceneError`
    naming the file for a missing or malformed file and for invalid acoustic properties.
    """
    path = Path(path)
    if not path.is_file():
        raise SceneError(f"{path}: scene file not found")
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
    table = np.full(registry_ids.max() + 1, -1, dtype=np.int64)
    table[registry_ids] = shape_material
    return AcousticScene(path, scene, [s.id() for s in shapes], materials, shape_material,
                         registry_ids, table)


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


# ---- ground-truth geometry -----------------------------------------------------------------
@dataclass(frozen=True)
class SceneMesh:
    """Every shape of a scene as one triangle mesh in the world frame: the ground truth.

    Attributes:
        vertices: (V, 3) positions [m].
        triangles: (F, 3) vertex indices, wound so that the right-hand normal is Mitsuba's.
        triangle_shape: (F,) index of each triangle's shape (into ``shape_ids``).
        shape_ids: id of every shape, in ``scene.shapes()`` order.
        shape_material: (n_shapes,) index into ``materials`` per shape.
        shape_transparent: (n_shapes,) True where the shape's optical BSDF transmits light.
        materials: the acoustic materials (``name`` is the BSDF id or preset).
    """

    vertices: np.ndarray
    triangles: np.ndarray
    triangle_shape: np.ndarray
    shape_ids: list
    shape_material: np.ndarray
    shape_transparent: np.ndarray
    materials: list

    @property
    def triangle_material(self) -> np.ndarray:
        """(F,) material index per triangle."""
        return self.shape_material[self.triangle_shape]

    @property
    def triangle_transparent(self) -> np.ndarray:
        """(F,) True for triangles of optically transparent shapes (glass)."""
        return self.shape_transparent[self.triangle_shape]

    def _edge_cross(self) -> np.ndarray:
        v = self.vertices[self.triangles]
        return np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])

    def triangle_areas(self) -> np.ndarray:
        """(F,) triangle areas [m^2]."""
        return 0.5 * np.linalg.norm(self._edge_cross(), axis=1)

    def triangle_normals(self) -> np.ndarray:
        """(F, 3) unit normals (zero for degenerate triangles)."""
        c = self._edge_cross()
        n = np.linalg.norm(c, axis=1, keepdims=True)
        return np.divide(c, n, out=np.zeros_like(c), where=n > 0)


def optically_transparent(bsdf) -> bool:
    """True if a Mitsuba BSDF lets light through: any transmission lobe (dielectric,
    thindielectric, roughdielectric) or a null component (``null``, ``mask`` with opacity < 1).
    The ``acoustic`` wrapper reports its nested BSDF's flags."""
    mi = mitsuba()
    return bool(mi.has_flag(bsdf.flags(), mi.BSDFFlags.Transmission | mi.BSDFFlags.Null))


def scene_mesh(scene: AcousticScene, tolerance: float = 1e-3, min_segments: int = 64) -> SceneMesh:
    """Triangle mesh of every shape of a loaded scene, in the world frame.

    Mesh shapes (``obj``, ``ply``, ``rectangle``, ``cube`` in Mitsuba 3.9) give their world-space
    buffers. The analytic ``disk``, ``cylinder`` (the open tube, as Mitsuba's) and ``sphere``
    (an icosphere) are tessellated in their local frame and placed by their ``to_world`` with
    chordal error at most ``tolerance`` [m] and at least ``min_segments`` segments round a
    circle (64 segments: a disk's area is 0.16 % low, a tube's 0.04 %, an icosphere's 0.1 %).
    Any other shape type raises :class:`SceneError` naming the shape.
    """
    from mitsonar.validation import check_positive

    check_positive("scene_mesh tolerance [m]", tolerance)
    mi = mitsuba()
    verts, tris, owner = [], [], []
    offset = 0
    shapes = list(scene.scene.shapes())
    for k, shape in enumerate(shapes):
        if shape.is_mesh():
            v = np.asarray(shape.vertex_positions_buffer(), dtype=float).reshape(-1, 3)
            f = np.asarray(shape.faces_buffer(), dtype=np.int64).reshape(-1, 3)
        else:
            kind = shape.class_name()
            if kind not in _TESSELLATORS:
                raise SceneError(f"{scene.path}: shape '{shape.id() or f'#{k}'}' of type {kind} "
                                 f"has no ground-truth mesh; supported analytic shapes: "
                                 f"{', '.join(sorted(_TESSELLATORS))} (and every mesh)")
            m = np.asarray(mi.traverse(shape)["to_world"].matrix, dtype=float).reshape(4, 4)
            radius = float(np.linalg.norm(m[:3, 0]))
            ratio = min(tolerance / radius, 1.0)
            segments = max(min_segments, int(np.ceil(np.pi / np.arccos(1.0 - ratio))))
            v, f = _TESSELLATORS[kind](segments)
            v = v @ m[:3, :3].T + m[:3, 3]
            if np.linalg.det(m[:3, :3]) < 0:  # a mirroring to_world flips the winding
                f = f[:, ::-1]
        verts.append(v)
        tris.append(f + offset)
        owner.append(np.full(len(f), k))
        offset += len(v)
    transparent = np.array([optically_transparent(s.bsdf()) for s in shapes], dtype=bool)
    return SceneMesh(np.concatenate(verts), np.concatenate(tris), np.concatenate(owner),
                     list(scene.shape_ids), scene.shape_material, transparent, scene.materials)


def _ring(segments: int) -> np.ndarray:
    a = 2 * np.pi * np.arange(segments) / segments
    return np.stack([np.cos(a), np.sin(a), np.zeros(segments)], axis=1)


def _disk(segments: int):
    """Unit disk at z = 0, normal +z: a fan round the centre."""
    i = np.arange(segments)
    f = np.stack([np.zeros(segments, dtype=np.int64), 1 + i, 1 + (i + 1) % segments], axis=1)
    return np.vstack([np.zeros((1, 3)), _ring(segments)]), f


def _cylinder(segments: int):
    """Open tube of radius 1 from z = 0 to z = 1, normals outwards."""
    ring = _ring(segments)
    top = ring + [0.0, 0.0, 1.0]
    i = np.arange(segments)
    j = (i + 1) % segments
    f = np.concatenate([np.stack([i, j, segments + j], 1), np.stack([i, segments + j, segments + i], 1)])
    return np.vstack([ring, top]), f


def _sphere(segments: int):
    """Unit icosphere, normals outwards, subdivided until an edge spans <= 2 pi / segments."""
    t = (1 + 5 ** 0.5) / 2
    v = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
                  [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], float)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9],
                  [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2],
                  [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10],
                  [8, 6, 7], [9, 8, 1]])
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    edge = np.arctan(2.0)  # angle spanned by an icosahedron edge
    while edge > 2 * np.pi / segments:  # split every triangle into four
        e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
        key = np.sort(e, axis=1)
        uniq, inv = np.unique(key, axis=0, return_inverse=True)
        mid = v[uniq[:, 0]] + v[uniq[:, 1]]
        m = len(v) + inv.reshape(3, -1)
        v = np.vstack([v, mid / np.linalg.norm(mid, axis=1, keepdims=True)])
        a, b, c = f.T
        f = np.concatenate([np.stack([a, m[0], m[2]], 1), np.stack([b, m[1], m[0]], 1),
                            np.stack([c, m[2], m[1]], 1), np.stack([m[0], m[1], m[2]], 1)])
        edge /= 2
    return v, f


_TESSELLATORS = {"Disk": _disk, "Cylinder": _cylinder, "Sphere": _sphere}
