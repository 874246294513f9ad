"""Ground-truth geometry: every shape of a loaded scene as one triangle mesh in the world frame."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mitsonar.scene.loading import AcousticScene, SceneError, mitsuba, optically_transparent
from mitsonar.validation import check_positive


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
        return face_normals(self.vertices, self.triangles)


def face_normals(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(F, 3) unit right-hand normals of ``triangles`` (F, 3) (vertex indices) of ``vertices``
    (V, 3) [m] (zero for degenerate triangles)."""
    v = vertices[triangles]
    c = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    n = np.linalg.norm(c, axis=1, keepdims=True)
    return np.divide(c, n, out=np.zeros_like(c), where=n > 0)


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


@dataclass(frozen=True)
class SurfaceSamples:
    """Points on the ground-truth surface.

    Attributes:
        points: (M, 3) positions [m], world frame.
        triangle: (M,) index of the mesh triangle each sample lies on.
    """

    points: np.ndarray
    triangle: np.ndarray

    def subset(self, mask) -> "SurfaceSamples":
        """The samples where the boolean ``mask`` (M,) is True."""
        m = np.asarray(mask, dtype=bool)
        if m.shape != (len(self.points),):
            raise ValueError(f"observable mask must have shape ({len(self.points)},), got {m.shape}")
        return SurfaceSamples(self.points[m], self.triangle[m])


def sample_surface(mesh: SceneMesh, spacing: float = 0.01, seed: int = 0) -> SurfaceSamples:
    """Uniform area-weighted samples, one per ``spacing``^2 [m] on average: each triangle of area
    A gets floor(A / spacing^2 + u) samples (u uniform in [0, 1)) placed uniformly at random
    inside it, so the count per surface is nearly exact; the same seed gives the same samples."""
    check_positive("sample spacing [m]", spacing)
    rng = np.random.default_rng(seed)
    areas = mesh.triangle_areas()
    counts = np.floor(areas / spacing**2 + rng.random(len(areas))).astype(np.int64)
    tri = np.repeat(np.arange(len(areas)), counts)
    r1, r2 = rng.random((2, len(tri)))
    s = np.sqrt(r1)
    v = mesh.vertices[mesh.triangles[tri]]
    pts = ((1 - s)[:, None] * v[:, 0] + (s * (1 - r2))[:, None] * v[:, 1]
           + (s * r2)[:, None] * v[:, 2])
    return SurfaceSamples(pts, tri)
