"""Mitsuba shape primitives with exact geometry: rectangles, boxes (``cube``), closed cylinders
(``cylinder`` plus two ``disk`` caps) and spheres, each placed by an explicit ``to_world`` matrix,
with the surface area, bounds and XML the scene writer needs."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mitsonar.scene.building.formatting import fmt, fmt_vec, fmt_vec_f32

#: Geometric tolerance [m] when comparing coordinates.
TOL = 1e-9

Interval = tuple[float, float]
Rect2 = tuple[float, float, float, float]  # (u0, u1, v0, v1)

#: Mitsuba shape types of the scenes. In local coordinates: 'rectangle' [-1, 1]^2 at z = 0
#: (normal +z), 'cube' [-1, 1]^3, 'cylinder' radius 1 from z = 0 to z = 1 (the open tube: no
#: caps, Mitsuba's surface_area() is 2 pi r h), 'disk' radius 1 at z = 0 (normal +z), 'sphere'
#: radius 1 about the origin.
SHAPE_KINDS = ("rectangle", "cube", "cylinder", "disk", "sphere")


@dataclass(frozen=True)
class Shape:
    """One Mitsuba shape of a type in ``SHAPE_KINDS``, placed by the affine ``to_world`` (4, 4)
    matrix. Cylinders, disks and spheres take a rotation times a scale (radius in the local x
    and y, the length along the local z of a cylinder): no shear, equal x and y scales (as
    Mitsuba requires for them).

    Attributes:
        id: unique shape id.
        kind: one of ``SHAPE_KINDS``.
        to_world: (4, 4) local-to-world matrix [m].
        material: material id.
        role: what the shape is: 'wall', 'interior_wall', 'window', 'floor', 'ceiling',
            'light', 'furniture', 'small_object'.
        group: the object the shape is a piece of (e.g. the wall 'wall_east', the table
            'bench_1').
        radiance: area-light radiance (linear RGB) [W/(m^2 sr)], or None.
    """

    id: str
    kind: str
    to_world: np.ndarray
    material: str
    role: str
    group: str
    radiance: tuple[float, float, float] | None = None

    def __post_init__(self):
        if self.kind not in SHAPE_KINDS:
            raise ValueError(f"shape '{self.id}': unknown kind {self.kind!r}")
        if self.kind in ("cylinder", "disk", "sphere"):
            a, b, c = (self.to_world[:3, k] for k in range(3))
            ra, rb = np.linalg.norm(a), np.linalg.norm(b)
            gram = np.array([[a @ a, a @ b, a @ c], [b @ a, b @ b, b @ c], [c @ a, c @ b, c @ c]])
            off = gram - np.diag(np.diag(gram))
            if (abs(ra - rb) > 1e-12 * ra or np.abs(off).max() > 1e-12 * ra * ra
                    or (self.kind == "sphere" and abs(np.linalg.norm(c) - ra) > 1e-12 * ra)):
                raise ValueError(f"shape '{self.id}': a {self.kind} needs a rotation times a "
                                 "scale with equal radial scales")

    @property
    def radius(self) -> float:
        """Radius [m] of a cylinder, disk or sphere."""
        return float(np.linalg.norm(self.to_world[:3, 0]))

    @property
    def area(self) -> float:
        """Surface area [m^2] (exact for the affine ``to_world``; as Mitsuba's surface_area())."""
        a, b, c = (self.to_world[:3, k] for k in range(3))
        if self.kind == "rectangle":
            return 4.0 * float(np.linalg.norm(np.cross(a, b)))
        if self.kind == "cube":
            return 8.0 * float(np.linalg.norm(np.cross(a, b)) + np.linalg.norm(np.cross(b, c))
                               + np.linalg.norm(np.cross(c, a)))
        if self.kind == "cylinder":
            return 2.0 * np.pi * self.radius * float(np.linalg.norm(c))
        if self.kind == "disk":
            return np.pi * float(np.linalg.norm(a) * np.linalg.norm(b))
        return 4.0 * np.pi * self.radius ** 2

    def corners(self) -> np.ndarray:
        """(4, 3) corners of a rectangle, counter-clockwise about its normal."""
        m = self.to_world
        local = np.array([[-1, -1, 0, 1], [1, -1, 0, 1], [1, 1, 0, 1], [-1, 1, 0, 1]], float)
        return (local @ m.T)[:, :3]

    def bbox(self) -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned bounds (min, max) [m]."""
        m = self.to_world
        if self.kind in ("rectangle", "cube"):
            local = np.array([[x, y, z, 1] for x in (-1, 1) for y in (-1, 1)
                              for z in ((0,) if self.kind == "rectangle" else (-1, 1))], float)
            pts = (local @ m.T)[:, :3]
            return pts.min(axis=0), pts.max(axis=0)
        # a circle c + a cos(t) + b sin(t) reaches c_i +- sqrt(a_i^2 + b_i^2) along axis i
        reach = np.sqrt(m[:3, 0] ** 2 + m[:3, 1] ** 2)
        if self.kind == "sphere":
            reach = np.full(3, self.radius)
        ends = [m[:3, 3], m[:3, 3] + m[:3, 2]] if self.kind == "cylinder" else [m[:3, 3]]
        return np.min(ends, axis=0) - reach, np.max(ends, axis=0) + reach

    def normal(self) -> np.ndarray:
        """Unit normal of a rectangle or disk (the side its one-sided optical BSDF shows), or
        the axis of a cylinder."""
        if self.kind == "cylinder":
            return self.to_world[:3, 2] / np.linalg.norm(self.to_world[:3, 2])
        n = np.cross(self.to_world[:3, 0], self.to_world[:3, 1])
        return n / np.linalg.norm(n)

    def xml(self) -> list[str]:
        """Lines of the shape's XML element, with a comment on its bounds and area."""
        lo, hi = self.bbox()
        note = ", ".join(f"{axis} {fmt(a)}" if abs(b - a) < 1e-9 else
                         f"{axis} {fmt(a)}..{fmt(b)}" for axis, a, b in zip("xyz", lo, hi))
        if self.kind in ("rectangle", "disk"):
            note += f", normal ({fmt_vec(self.normal())})"
        if self.kind in ("cylinder", "disk", "sphere"):
            note += f", radius {fmt(self.radius)}"
        if self.kind == "cylinder":
            note += f", axis ({fmt_vec(self.normal())})"
        row_fmt = fmt_vec_f32 if self.kind == "cube" else fmt_vec
        rows = "  ".join(row_fmt(row) for row in self.to_world)
        lines = [f'<shape type="{self.kind}" id="{self.id}">',
                 f'    <!-- {self.role}: {note}, {fmt(self.area)} m^2 -->',
                 '    <transform name="to_world">',
                 f'        <matrix value="{rows}"/>',
                 '    </transform>',
                 f'    <ref id="{self.material}"/>']
        if self.radiance is not None:
            lines += ['    <emitter type="area">',
                      f'        <rgb name="radiance" value="{fmt_vec(self.radiance)}"/>',
                      '    </emitter>']
        lines.append('</shape>')
        return lines


def rectangle(shape_id: str, centre, half_u, half_v, material: str, role: str, group: str,
              radiance=None) -> Shape:
    """Rectangle centred at ``centre`` with half-edge vectors ``half_u``, ``half_v`` [m]; its
    normal (the side a one-sided BSDF shows) is along half_u x half_v."""
    u, v, c = (np.asarray(x, dtype=float) for x in (half_u, half_v, centre))
    n = np.cross(u, v)
    if np.linalg.norm(n) < 1e-12:
        raise ValueError(f"shape '{shape_id}': degenerate rectangle")
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = u, v, n / np.linalg.norm(n), c
    return Shape(shape_id, "rectangle", m, material, role, group, radiance)


def box(shape_id: str, centre, size, material: str, role: str, group: str,
        yaw_deg: float = 0.0) -> Shape:
    """Axis-aligned box of ``size`` (x, y, z) [m] centred at ``centre``, turned by ``yaw_deg``
    about z (Mitsuba ``cube``). All six faces count in its area: use it for free-standing
    objects, not for walls whose faces touch other surfaces."""
    if float(yaw_deg) % 90.0 == 0.0:  # exact quarter turns (no 6e-17 in the matrix)
        c, s = [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)][int(yaw_deg // 90) % 4]
    else:
        c, s = np.cos(np.radians(yaw_deg)), np.sin(np.radians(yaw_deg))
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    m = np.eye(4)
    m[:3, :3] = rot @ np.diag(np.asarray(size, dtype=float) / 2)
    m[:3, 3] = centre
    return Shape(shape_id, "cube", m, material, role, group)


def _axis_frame(axis) -> np.ndarray:
    """Rotation (3, 3) whose third column is the unit ``axis``; the identity for +z."""
    e3 = np.asarray(axis, dtype=float)
    e3 = e3 / np.linalg.norm(e3)
    if np.allclose(e3, (0.0, 0.0, 1.0)):
        return np.eye(3)
    ref = np.array([0.0, 0.0, 1.0]) if abs(e3[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(ref, e3)
    e1 /= np.linalg.norm(e1)
    return np.column_stack([e1, np.cross(e3, e1), e3])


def closed_cylinder(shape_id: str, base, radius: float, length: float, material: str,
                    role: str, group: str, axis=(0.0, 0.0, 1.0),
                    cap_material: str | None = None) -> list[Shape]:
    """A closed cylinder: Mitsuba's open ``cylinder`` (id ``shape_id``) from the centre of its
    base ``base`` along ``axis`` for ``length`` [m], plus its two end caps as ``disk`` shapes
    facing outwards (``<id>_cap0`` at the base, ``<id>_cap1`` at the far end), so its area is
    2 pi r (r + h) like a solid's."""
    rot = _axis_frame(axis)
    e1, e2, e3 = rot.T
    base = np.asarray(base, dtype=float)
    cap = cap_material or material

    def mat(cols, centre):
        m = np.eye(4)
        m[:3, :3] = np.column_stack(cols)
        m[:3, 3] = centre
        return m

    return [Shape(shape_id, "cylinder", mat([radius * e1, radius * e2, length * e3], base),
                  material, role, group),
            Shape(f"{shape_id}_cap0", "disk", mat([radius * e1, -radius * e2, -e3], base),
                  cap, role, group),
            Shape(f"{shape_id}_cap1", "disk",
                  mat([radius * e1, radius * e2, e3], base + length * e3), cap, role, group)]


def sphere(shape_id: str, centre, radius: float, material: str, role: str,
           group: str) -> Shape:
    """Sphere of ``radius`` [m] about ``centre``."""
    m = np.eye(4)
    m[:3, :3] *= radius
    m[:3, 3] = centre
    return Shape(shape_id, "sphere", m, material, role, group)


# Free-standing objects are built from closed pieces (cubes, capped cylinders, spheres), so each
# piece's area is that of a solid; where pieces touch (a leg under a table top, a can on a shelf)
# the touching faces are hidden but still counted in the ground-truth areas.
def _span(lo_hi: Interval) -> tuple[float, float]:
    """(centre, size) of an interval."""
    return 0.5 * (lo_hi[0] + lo_hi[1]), lo_hi[1] - lo_hi[0]


#: Grid [m] that :func:`block` corners are snapped to (2^-16 m, 15 micrometres).
SNAP = 2.0 ** -16


def _snap(v: float) -> float:
    """``v`` on the SNAP grid. Mitsuba turns a ``cube`` into a mesh whose vertices it stores in
    float32 world coordinates: a 3 cm chair leg 3 m from the origin then loses ~1e-5 of its
    area to rounding. Corners on this grid (and their midpoints and half-differences) are exact
    in float32 up to 128 m, so the mesh is exact and surface_area() agrees to float32 rounding."""
    return round(float(v) / SNAP) * SNAP


def block(shape_id: str, x: Interval, y: Interval, z: Interval, material: str, role: str,
          group: str) -> Shape:
    """Axis-aligned box over the intervals x, y, z [m] (corners snapped to the SNAP grid); a box
    longer in y than in x is written turned by 90 deg, so a texture's v axis (wood grain) runs
    along its longer side."""
    x, y, z = ((_snap(a), _snap(b)) for a, b in (x, y, z))
    (cx, sx), (cy, sy), (cz, sz) = _span(x), _span(y), _span(z)
    if sy > sx + TOL:
        return box(shape_id, (cx, cy, cz), (sy, sx, sz), material, role, group, yaw_deg=90.0)
    return box(shape_id, (cx, cy, cz), (sx, sy, sz), material, role, group)
