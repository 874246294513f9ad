"""First hits of rays in a loaded scene, from Mitsuba's preliminary intersection.

Mitsuba's ``Scene.ray_intersect`` computes the surface interaction through a virtual call over
the scene's shapes, and that call costs the same whatever the number of rays: ~20 ms per call
on the furnished scenes (office's 271 shapes), where the intersection itself
(``ray_intersect_preliminary``) takes 0.2-1 ms for 2 000-20 000 rays. What the sonar's tracer,
the baseline sensors and the camera's ground truth read of a hit (its distance, point,
geometric normal and shape) follows from the preliminary intersection (distance, primitive,
shape) and tables made once per scene:

* meshes (``rectangle``, ``cube``, ``obj``, ``ply``): each triangle's normal, the right-hand
  normal of its winding (as Mitsuba's geometric normal);
* ``sphere``, ``cylinder``: their ``to_world`` transform M (translation T). At a point p, with
  local coordinates l = M^-1 (p - T), the normal is M^-T times the local normal: l for the
  unit sphere, (l_x, l_y, 0) for the unit tube;
* ``disk``: M (0, 0, 1), the normal of the plane Mitsuba intersects (through the centre, normal
  to that; where M shears the disk, e.g. a ``rotate`` about an axis that is not of unit length,
  which Mitsuba does not normalise, this is not M^-T (0, 0, 1)).

The point is o + t d in double precision (Mitsuba's interpolates the triangle's vertices in
single precision: they agree to a few 1e-7 of the distance, 3e-6 m on the shipped scenes).
Normals carry the sign of Mitsuba's own, ``flip_normals`` aside: every user takes their line
only (incidence angles, normals turned to face the ray). A scene holding any other kind of shape
(instances, curves, SDF grids) is intersected by ``ray_intersect`` as before.
"""

from __future__ import annotations

import numpy as np

from mitsonar.scene.loading import AcousticScene, mitsuba
from mitsonar.scene.mesh import face_normals
from mitsonar.scene.rays import rays

#: Local normal of each analytic shape at local point l: n_local = l * SCALE + OFFSET.
_ANALYTIC = {"Disk": ((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
             "Sphere": ((1.0, 1.0, 1.0), (0.0, 0.0, 0.0)),
             "Cylinder": ((1.0, 1.0, 0.0), (0.0, 0.0, 0.0))}


class SceneHits:
    """First-hit queries on one loaded scene (module docstring); construct once per scene.

    Args:
        scene: the loaded scene.
    """

    def __init__(self, scene: AcousticScene):
        self.mi = mitsuba()
        self.scene = scene
        shapes = list(scene.scene.shapes())
        reg = np.asarray(scene.registry_ids)
        #: Shape index (into ``scene.shapes()``) of each Dr.Jit registry id (-1: none).
        self.shape_of_registry = np.full(reg.max() + 1, -1)
        self.shape_of_registry[reg] = np.arange(len(reg))
        kinds = [shape.class_name() for shape in shapes]
        #: False where some shape is neither a mesh nor an analytic shape of ``_ANALYTIC``.
        self.tabulated = all(s.is_mesh() or k in _ANALYTIC for s, k in zip(shapes, kinds))
        if not self.tabulated:
            return
        normals, offsets, start = [], np.zeros(len(shapes), np.int64), 0
        self._inverse = np.zeros((len(shapes), 3, 3))
        self._normal_matrix = np.zeros((len(shapes), 3, 3))
        self._origin = np.zeros((len(shapes), 3))
        self._local = np.zeros((len(shapes), 2, 3))
        self._analytic = np.zeros(len(shapes), bool)
        for k, (shape, kind) in enumerate(zip(shapes, kinds)):
            if shape.is_mesh():
                v = np.asarray(shape.vertex_positions_buffer(), dtype=float).reshape(-1, 3)
                f = np.asarray(shape.faces_buffer(), dtype=np.int64).reshape(-1, 3)
                normals.append(face_normals(v, f))
                offsets[k], start = start, start + len(f)
                continue
            m = np.asarray(self.mi.traverse(shape)["to_world"].matrix, dtype=float).reshape(4, 4)
            inverse = np.linalg.inv(m[:3, :3])
            self._inverse[k] = inverse
            self._normal_matrix[k] = m[:3, :3] if kind == "Disk" else inverse.T
            self._origin[k] = m[:3, 3]
            self._local[k] = _ANALYTIC[kind]
            self._analytic[k] = True
        self._face_normals = np.concatenate(normals) if normals else np.zeros((0, 3))
        self._face_offset = offsets

    def first(self, origins, directions):
        """The first hit of rays from ``origins`` (R, 3) [m] along unit ``directions`` (R, 3),
        world frame: t (R,) [m] (inf: none), point (R, 3) [m], unit geometric normal (R, 3)
        and shape index (R,) (into ``scene.shapes()``; -1: none)."""
        import drjit as dr

        mi = self.mi
        o = np.asarray(origins, dtype=float).reshape(-1, 3)
        d = np.asarray(directions, dtype=float).reshape(-1, 3)
        ray = rays(o, d)
        if self.tabulated:
            hit = self.scene.scene.ray_intersect_preliminary(ray, coherent=False)
            dr.eval(hit.t, hit.prim_index, hit.shape)
            primitive = np.asarray(hit.prim_index, dtype=np.int64)
        else:
            hit = self.scene.scene.ray_intersect(ray, ray_flags=mi.RayFlags.Minimal,
                                                 coherent=False)
            dr.eval(hit.t, hit.n, hit.shape)
        t = np.asarray(hit.t, dtype=float)
        reg = np.asarray(dr.reinterpret_array(mi.UInt32, hit.shape), dtype=np.int64)
        table = self.shape_of_registry
        shape = np.where(np.isfinite(t) & (reg < len(table)), table[np.minimum(reg, len(table) - 1)],
                         -1)
        on = shape >= 0
        t = np.where(on, t, np.inf)
        point = o + np.where(on, t, 0.0)[:, None] * d  # (whole arrays: faster than masked rows)
        point[~on] = 0.0
        if not self.tabulated:
            normal = np.asarray(hit.n, dtype=float).T.copy()
            normal[~on] = 0.0
            return t, point, normal, shape
        k = np.maximum(shape, 0)
        flat = on & ~self._analytic[k]
        if len(self._face_normals):
            normal = self._face_normals[np.where(flat, self._face_offset[k] + primitive, 0)]
            normal[~flat] = 0.0
        else:
            normal = np.zeros_like(d)
        quadric = np.flatnonzero(on & self._analytic[k])
        k = shape[quadric]
        if len(quadric):
            local = np.einsum("hij,hj->hi", self._inverse[k], point[quadric] - self._origin[k])
            local = local * self._local[k, 0] + self._local[k, 1]
            n = np.einsum("hij,hj->hi", self._normal_matrix[k], local)
            normal[quadric] = n / np.linalg.norm(n, axis=1, keepdims=True)
        return t, point, normal, shape

