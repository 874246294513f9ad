"""Write the shipped Mitsuba scenes: ``python scenes/generate.py [--out DIR] [--only NAME]``.

Each scene goes to ``<out>/<name>/`` as

* ``scene.xml``: Mitsuba 3 scene. Every surface is its own shape with a unique id (wall segments
  around an opening, each face of a thick wall, each ceiling tile between light panels, each
  piece of a piece of furniture), built from Mitsuba's ``rectangle`` shapes for the building
  and closed solids for furniture and small objects: ``cube``s (:func:`box`, :func:`block`;
  corners on a 2^-16 m grid so Mitsuba's float32 mesh is exact), ``cylinder``s capped by two
  ``disk``s (:func:`closed_cylinder`; Mitsuba's cylinder is an open tube) and ``sphere``s,
  each with an explicit ``to_world`` matrix.
  Materials are ``<bsdf type="acoustic">`` with a ``preset`` and a nested optical BSDF (plain
  ``diffuse`` colours, or a ``bitmap`` texture written by this module as reflectance); windows
  are holes in their wall filled by a ``thindielectric`` pane (the camera sees through it, the
  sonar reflects from it). Light: area-light panels set into the ceiling (interior walls cast
  their shadows) and, where a scene has windows, a sky/ground environment map seen through them
  and a directional sun falling through them in sunlit patches with sharp shadow edges (the
  paper's "shadow lines"). The integrator is ``volpath``: unlike ``path``, its shadow rays pass
  thin glass panes (their null transmission). That needs the ``acoustic`` BSDF to forward
  ``eval_null_transmission`` to its nested BSDF; where it does not, sun and direct sky light
  stop at the glass (the sky is still seen through it). A
  ``perspective`` camera placeholder sits at the camera of a robot at the world origin facing
  +x; its film size, samples per pixel and path depth are the XML defaults ``width``,
  ``height``, ``spp`` and ``max_depth`` (override them with ``mi.load_file(path, spp=...)``).
* ``ground_truth.json``: per shape its id, material id, acoustic preset, role ('wall',
  'interior_wall', 'window', 'floor', 'ceiling', 'light', 'furniture', 'small_object'), group
  (the object it belongs to), surface area [m^2] (as Mitsuba's ``surface_area()``; hidden faces
  where solids touch count too) and geometry (``to_world``; corners and normal of rectangles;
  radius and centre of disks and spheres, radius, base centre, axis and length of cylinders);
  the area per material; rooms; windows; the camera placeholder; the default robot
  trajectory. Scenes with furniture also list their textures and per object (furniture
  piece or small object) its shapes, area, plan footprint and height range.
* ``sky.png`` (scenes with windows): the environment map; texture PNGs (``TEXTURES``) where
  materials use them.

World frame: metres, z up, floor at z = 0. The world origin is a sensible robot position (the
one the Makefile's demo scans from), with the robot facing +x. Robot poses are (x [m], y [m],
yaw [deg]) of the chassis centre in the world frame; the sensor head is 0.1 m ahead and 0.5 m
above it (``mitsonar.frames``), the camera 0.075 m above the sensor head.

Scenes: ``room_glass`` and ``structure`` (surfel-mode scenes of the paper, texture-less),
``workshop`` and ``office`` (repeated-scan scenes: furniture, small objects, colours and
textures). Adding a scene: write a function returning a :class:`SceneSpec` (see
:func:`room_glass`, :func:`structure`; :func:`workshop` and :func:`office` for furniture) and
register it in ``SCENES``. Everything is deterministic: no randomness,
fixed number formatting, so regenerating gives identical bytes (a test checks the shipped
files against a fresh generation).

This module needs only NumPy; ``--preview DIR`` (rendering PNG previews) needs mitsonar.
"""

from __future__ import annotations

import argparse
import json
import struct
import sys
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

#: Robot chassis centre -> sensor head [m] (``mitsonar.frames.SENSOR_MOUNT_TRANSLATION``).
SENSOR_MOUNT = (0.1, 0.0, 0.5)
#: Camera optical centre above the sensor head's array origin [m] (DESIGN.md, Camera).
CAMERA_ABOVE_SENSOR = 0.075
#: Horizontal field of view of the camera placeholder [deg]; at 4:3 it covers the array's 60 x 40.
CAMERA_FOV_DEG = 60.0
#: Geometric tolerance [m] when comparing coordinates.
_TOL = 1e-9

Interval = tuple[float, float]
Rect2 = tuple[float, float, float, float]  # (u0, u1, v0, v1)


# ---- optical materials ------------------------------------------------------------------------
@dataclass(frozen=True)
class Material:
    """An ``acoustic`` BSDF: an acoustic preset plus the optical BSDF the camera sees.

    Attributes:
        id: material id in the XML.
        preset: acoustic preset name (``mitsonar.physics.materials.PRESETS``).
        optical: nested Mitsuba BSDF type: 'diffuse', 'thindielectric' or 'dielectric'.
        rgb: diffuse reflectance (linear RGB) for 'diffuse' without a texture.
        ior: interior index of refraction for the dielectrics.
        texture: PNG in the scene folder (a key of ``TEXTURES``) used as the diffuse reflectance
            through a ``bitmap`` texture (8-bit sRGB, repeated), or None for the plain ``rgb``.
        uv_scale: repeats of the texture across a shape's (u, v) parametrisation ([0, 1]^2 over
            a rectangle and over each face of a cube).
    """

    id: str
    preset: str
    optical: str = "diffuse"
    rgb: tuple[float, float, float] = (0.7, 0.7, 0.7)
    ior: float = 1.5
    texture: str | None = None
    uv_scale: tuple[float, float] = (1.0, 1.0)

    def __post_init__(self):
        if self.optical not in ("diffuse", "thindielectric", "dielectric"):
            raise ValueError(f"material '{self.id}': unsupported optical BSDF {self.optical!r}")
        if self.texture is not None and (self.optical != "diffuse" or
                                         self.texture not in TEXTURES):
            raise ValueError(f"material '{self.id}': texture {self.texture!r} needs a diffuse "
                             f"BSDF and one of {sorted(TEXTURES)}")

    def xml(self) -> list[str]:
        lines = [f'<bsdf type="acoustic" id="{self.id}">',
                 f'    <string name="preset" value="{self.preset}"/>']
        if self.optical == "diffuse" and self.texture is not None:
            su, sv = self.uv_scale
            lines += ['    <bsdf type="diffuse">',
                      '        <texture type="bitmap" name="reflectance">',
                      f'            <string name="filename" value="{self.texture}"/>',
                      '            <transform name="to_uv">',
                      f'                <scale x="{_fmt(su)}" y="{_fmt(sv)}"/>',
                      '            </transform>',
                      '        </texture>',
                      '    </bsdf>']
        elif self.optical == "diffuse":
            lines += ['    <bsdf type="diffuse">',
                      f'        <rgb name="reflectance" value="{_fmt_vec(self.rgb)}"/>',
                      '    </bsdf>']
        else:
            lines += [f'    <bsdf type="{self.optical}">',
                      f'        <float name="int_ior" value="{_fmt(self.ior)}"/>',
                      '        <float name="ext_ior" value="1"/>',
                      '    </bsdf>']
        lines.append('</bsdf>')
        return lines


# ---- shapes -----------------------------------------------------------------------------------
#: Mitsuba shape types the generator writes. In local coordinates: 'rectangle' [-1, 1]^2 at z = 0
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
        lo, hi = self.bbox()
        note = ", ".join(f"{axis} {_fmt(a)}" if abs(b - a) < 1e-9 else
                         f"{axis} {_fmt(a)}..{_fmt(b)}" for axis, a, b in zip("xyz", lo, hi))
        if self.kind in ("rectangle", "disk"):
            note += f", normal ({_fmt_vec(self.normal())})"
        if self.kind in ("cylinder", "disk", "sphere"):
            note += f", radius {_fmt(self.radius)}"
        if self.kind == "cylinder":
            note += f", axis ({_fmt_vec(self.normal())})"
        fmt = _fmt_vec_f32 if self.kind == "cube" else _fmt_vec
        rows = "  ".join(fmt(row) for row in self.to_world)
        lines = [f'<shape type="{self.kind}" id="{self.id}">',
                 f'    <!-- {self.role}: {note}, {_fmt(self.area)} m^2 -->',
                 '    <transform name="to_world">',
                 f'        <matrix value="{rows}"/>',
                 '    </transform>',
                 f'    <ref id="{self.material}"/>']
        if self.radiance is not None:
            lines += ['    <emitter type="area">',
                      f'        <rgb name="radiance" value="{_fmt_vec(self.radiance)}"/>',
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


# ---- 2D decomposition of surfaces with openings -----------------------------------------------
def _complement(lo: float, hi: float, covered: list[Interval]) -> list[Interval]:
    """Parts of [lo, hi] not covered by the intervals."""
    free, at = [], lo
    for a, b in sorted(covered):
        if a > at + _TOL:
            free.append((at, min(a, hi)))
        at = max(at, b)
    if hi > at + _TOL:
        free.append((at, hi))
    return free


def rect_minus(outer: Rect2, holes: list[Rect2]) -> list[Rect2]:
    """Axis-aligned rectangle minus axis-aligned holes, as non-overlapping rectangles (u0, u1,
    v0, v1): strips along u cut at every hole edge, neighbouring strips with the same free v
    intervals merged. Deterministic order (u, then v)."""
    u0, u1, v0, v1 = outer
    clipped = [(max(a, u0), min(b, u1), max(c, v0), min(d, v1)) for a, b, c, d in holes]
    clipped = [h for h in clipped if h[1] > h[0] + _TOL and h[3] > h[2] + _TOL]
    cuts = sorted({u0, u1, *(h[0] for h in clipped), *(h[1] for h in clipped)})
    strips: list[tuple[float, float, list[Interval]]] = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        if b - a <= _TOL:
            continue
        mid = 0.5 * (a + b)
        free = _complement(v0, v1, [(h[2], h[3]) for h in clipped if h[0] < mid < h[1]])
        if strips and strips[-1][2] == free and abs(strips[-1][1] - a) <= _TOL:
            strips[-1] = (strips[-1][0], b, free)
        else:
            strips.append((a, b, free))
    return [(a, b, c, d) for a, b, free in strips for c, d in free]


# ---- walls, floors, ceilings ------------------------------------------------------------------
@dataclass(frozen=True)
class Opening:
    """A hole in a wall: along-wall interval [s0, s1] (world coordinate along the wall's axis,
    x or y) and height interval [z0, z1] [m]. ``pane`` is the material filling it (a window)
    or None (a doorway)."""

    id: str
    s0: float
    s1: float
    z0: float
    z1: float
    pane: str | None = None


def _plan_axes(axis: str):
    """Unit vectors (along, across) of a wall running along world 'x' or 'y'."""
    if axis == "x":
        return np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    if axis == "y":
        return np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0])
    raise ValueError(f"wall axis must be 'x' or 'y', got {axis!r}")


def vertical_face(prefix: str, axis: str, across: float, s_range: Interval, z_range: Interval,
                  facing: int, material: str, role: str, holes: list[Rect2] = (),
                  group: str | None = None) -> list[Shape]:
    """A vertical face in the plane (across-coordinate = ``across``) of a wall running along
    ``axis``, spanning ``s_range`` along it and ``z_range`` in height, minus ``holes`` given as
    (s0, s1, z0, z1); normal towards +across (``facing=+1``) or -across (-1). Pieces are named
    prefix_1, prefix_2, ... (or just prefix if the face is whole); ``group`` defaults to prefix."""
    t, w = _plan_axes(axis)
    z = np.array([0.0, 0.0, 1.0])
    pieces = rect_minus((*s_range, *z_range), list(holes))
    shapes = []
    for k, (s0, s1, z0, z1) in enumerate(pieces):
        centre = t * 0.5 * (s0 + s1) + w * across + z * 0.5 * (z0 + z1)
        hu, hv = t * 0.5 * (s1 - s0), z * 0.5 * (z1 - z0)
        if np.dot(np.cross(hu, hv), w) * facing < 0:
            hu, hv = hv, hu
        name = prefix if len(pieces) == 1 else f"{prefix}_{k + 1}"
        shapes.append(rectangle(name, centre, hu, hv, material, role, group or prefix))
    return shapes


def horizontal_surface(prefix: str, outer: Rect2, z: float, facing: int, material: str,
                       role: str, holes: list[Rect2] = (), group: str | None = None) -> list[Shape]:
    """A horizontal surface at height ``z`` over ``outer`` = (x0, x1, y0, y1) minus ``holes``,
    normal +z (``facing=+1``, floors) or -z (-1, ceilings)."""
    shapes = []
    pieces = rect_minus(outer, list(holes))
    for k, (x0, x1, y0, y1) in enumerate(pieces):
        hu, hv = np.array([0.5 * (x1 - x0), 0, 0]), np.array([0, 0.5 * (y1 - y0), 0])
        if facing < 0:
            hu, hv = hv, hu
        name = prefix if len(pieces) == 1 else f"{prefix}_{k + 1}"
        shapes.append(rectangle(name, (0.5 * (x0 + x1), 0.5 * (y0 + y1), z), hu, hv, material,
                                role, group or prefix))
    return shapes


@dataclass(frozen=True)
class ThickWall:
    """An interior wall of thickness > 0 standing on the floor, running along world ``axis``
    over ``s_range`` with its across-coordinate in ``c_range`` [m]. Its faces, exposed ends
    and the reveals (jambs, soffits, sills) of its openings become separate rectangles."""

    id: str
    axis: str
    s_range: Interval
    c_range: Interval
    openings: tuple[Opening, ...] = ()

    def footprint(self) -> Rect2:
        """Plan rectangle (x0, x1, y0, y1)."""
        if self.axis == "x":
            return (*self.s_range, *self.c_range)
        return (*self.c_range, *self.s_range)

    def floor_footprints(self) -> list[Rect2]:
        """Plan rectangles where the wall stands on the floor (doorways excluded)."""
        doors = [(o.s0, o.s1, self.c_range[0], self.c_range[1]) for o in self.openings
                 if o.z0 <= _TOL]
        pieces = rect_minus((*self.s_range, *self.c_range), doors)
        return [p if self.axis == "x" else (p[2], p[3], p[0], p[1]) for p in pieces]


def _touching(plane_axis: int, plane_value: float, side: int, span: Interval,
              footprints: list[Rect2]) -> list[Interval]:
    """Intervals of ``span`` (along the other plan axis) where a footprint touches the plane
    {plan coordinate ``plane_axis`` = plane_value} from the side ``side`` (+1: greater)."""
    cut = []
    for fp in footprints:
        lo, hi = (fp[0], fp[1]) if plane_axis == 0 else (fp[2], fp[3])
        olo, ohi = (fp[2], fp[3]) if plane_axis == 0 else (fp[0], fp[1])
        edge = lo if side > 0 else hi
        if abs(edge - plane_value) <= 1e-6:
            a, b = max(olo, span[0]), min(ohi, span[1])
            if b > a + _TOL:
                cut.append((a, b))
    return cut


# ---- the scene description --------------------------------------------------------------------
@dataclass
class SceneSpec:
    """Everything one scene directory holds; written by :meth:`write`.

    Attributes:
        name: directory name.
        description: one line for humans.
        height: room height [m].
        rooms: plan rectangles of the rooms, {'id', 'x': (x0, x1), 'y': (y0, y1)} [m].
        materials: materials by id (written in insertion order).
        shapes: shapes (written in order; ids unique).
        windows: per window {'id', 'wall', 'centre', 'width_m', 'height_m', 'sill_m'}.
        trajectory: waypoints (x [m], y [m], yaw [deg], unwrapped) of the robot, world frame.
        speed: robot speed along the trajectory [m/s].
        yaw_rate: turning rate in place [deg/s].
        sky: write the sky environment map (scenes with windows).
        sun: (direction of travel, irradiance [W/m^2] linear RGB) of a directional sun, or None.
        overview: (origin, target) of the overview camera used for the README preview.
    """

    name: str
    description: str
    height: float
    rooms: list[dict] = field(default_factory=list)
    materials: dict[str, Material] = field(default_factory=dict)
    shapes: list[Shape] = field(default_factory=list)
    windows: list[dict] = field(default_factory=list)
    trajectory: list[tuple[float, float, float]] = field(default_factory=list)
    speed: float = 0.2
    yaw_rate: float = 30.0
    sky: bool = False
    sun: tuple | None = None
    overview: tuple = ((0.0, 0.0, 2.0), (1.0, 0.0, 1.0))

    # -- building --
    def material(self, mat: Material) -> str:
        if mat.id in self.materials and self.materials[mat.id] != mat:
            raise ValueError(f"material '{mat.id}' defined twice with different values")
        self.materials[mat.id] = mat
        return mat.id

    def add(self, *shapes: Shape) -> None:
        known = {s.id for s in self.shapes}
        for s in shapes:
            if s.id in known:
                raise ValueError(f"scene '{self.name}': duplicate shape id '{s.id}'")
            if s.material not in self.materials:
                raise ValueError(f"shape '{s.id}': unknown material '{s.material}'")
            known.add(s.id)
            self.shapes.append(s)

    def enclosure(self, outer: Rect2, wall_mat: str | dict[str, str], floor_mat: str,
                  ceiling_mat: str,
                  openings: dict[str, list[Opening]] | None = None,
                  interior: list[ThickWall] = (), interior_mat: str = "",
                  lights: list[tuple[Rect2, tuple]] = (), window_reveal: float = 0.0):
        """Floor, ceiling (with light panels set into it) and the four outer walls (inner faces
        only) of the plan rectangle ``outer`` = (x0, x1, y0, y1), plus thick interior walls.

        ``openings`` maps 'east' (x = x1), 'west', 'north' (y = y1), 'south' to the openings of
        that wall (s is the world y on the east and west walls, x on the north and south ones).
        ``interior`` walls use ``interior_mat``. ``lights`` are (plan rectangle, radiance) of
        ceiling panels; their holes are left in the ceiling (:meth:`ceiling_lights` fills them).
        Openings of the outer walls get reveals ``window_reveal`` [m] deep (the outer walls'
        thickness), with the glass pane at their outer end. ``wall_mat`` is one material for
        all four walls or a material per side ('east', 'west', 'north', 'south').
        """
        x0, x1, y0, y1 = outer
        h = self.height
        openings = openings or {}
        fps = [w.footprint() for w in interior]
        sides = {"east": ("y", x1, -1, (y0, y1), 0, -1), "west": ("y", x0, +1, (y0, y1), 0, +1),
                 "north": ("x", y1, -1, (x0, x1), 1, -1), "south": ("x", y0, +1, (x0, x1), 1, +1)}
        for side, (axis, across, facing, span, plane_axis, touch_side) in sides.items():
            mat = wall_mat[side] if isinstance(wall_mat, dict) else wall_mat
            ops = openings.get(side, [])
            holes = [(o.s0, o.s1, o.z0, o.z1) for o in ops]
            holes += [(a, b, 0.0, h) for a, b in
                      _touching(plane_axis, across, touch_side, span, fps)]
            self.add(*vertical_face(f"wall_{side}", axis, across, span, (0.0, h), facing,
                                    mat, "wall", holes))
            self._openings(f"wall_{side}", axis, across, facing, ops, window_reveal, mat)
        floor_holes = [fp for w in interior for fp in w.floor_footprints()]
        self.add(*horizontal_surface("floor", outer, 0.0, +1, floor_mat, "floor", floor_holes))
        panels = [rect for rect, _ in lights]
        self.add(*horizontal_surface("ceiling", outer, h, -1, ceiling_mat, "ceiling",
                                     fps + panels))
        for wall in interior:
            self._thick_wall(wall, interior, outer, interior_mat)

    def ceiling_lights(self, lights: list[tuple[Rect2, tuple]], material: str) -> None:
        """Area-light panels flush with the ceiling (in the holes :meth:`enclosure` left)."""
        for k, ((x0, x1, y0, y1), radiance) in enumerate(lights):
            self.add(rectangle(f"light_{k + 1}", (0.5 * (x0 + x1), 0.5 * (y0 + y1), self.height),
                               (0, 0.5 * (y1 - y0), 0), (0.5 * (x1 - x0), 0, 0), material,
                               "light", f"light_{k + 1}", radiance=radiance))

    def _openings(self, wall: str, axis: str, across: float, facing: int, ops: list[Opening],
                  reveal: float, mat: str) -> None:
        """Reveals (jambs, sill, soffit; ``reveal`` [m] deep, outwards from the inner face) and
        glass panes (at the reveal's outer end) of the openings of an outer wall."""
        t, w = _plan_axes(axis)
        other_axis = "x" if axis == "y" else "y"
        outside = across - facing * reveal
        c_lo, c_hi = min(across, outside), max(across, outside)
        for o in ops:
            if reveal > 0:
                for s, f, tag in ((o.s0, +1, "jamb_1"), (o.s1, -1, "jamb_2")):
                    self.add(*vertical_face(f"{o.id}_{tag}", other_axis, s, (c_lo, c_hi),
                                            (o.z0, o.z1), f, mat, "wall", group=wall))
                plan = (o.s0, o.s1, c_lo, c_hi) if axis == "x" else (c_lo, c_hi, o.s0, o.s1)
                if o.z0 > _TOL:
                    self.add(*horizontal_surface(f"{o.id}_sill", plan, o.z0, +1, mat, "wall",
                                                 group=wall))
                if o.z1 < self.height - _TOL:
                    self.add(*horizontal_surface(f"{o.id}_soffit", plan, o.z1, -1, mat, "wall",
                                                 group=wall))
            if o.pane is None:
                continue
            centre = t * 0.5 * (o.s0 + o.s1) + w * outside + np.array([0, 0, 0.5 * (o.z0 + o.z1)])
            self.add(rectangle(o.id, centre, t * 0.5 * (o.s1 - o.s0),
                               np.array([0, 0, 0.5 * (o.z1 - o.z0)]), o.pane, "window", o.id))
            self.windows.append({"id": o.id, "wall": wall, "centre": _round_list(centre),
                                 "width_m": _r(o.s1 - o.s0), "height_m": _r(o.z1 - o.z0),
                                 "sill_m": _r(o.z0), "pane_behind_wall_face_m": _r(reveal)})

    def _thick_wall(self, wall: ThickWall, interior: list[ThickWall], outer: Rect2,
                    mat: str) -> None:
        h = self.height
        others = [w.footprint() for w in interior if w is not wall]
        x0, x1, y0, y1 = outer
        # the outer walls as thin footprints outside the plan, so wall ends touching them are cut
        others += [(x1, x1 + 1, y0, y1), (x0 - 1, x0, y0, y1), (x0, x1, y1, y1 + 1),
                   (x0, x1, y0 - 1, y0)]
        pa = 0 if wall.axis == "y" else 1  # plan axis of the across-coordinate
        s0, s1 = wall.s_range
        c0, c1 = wall.c_range
        holes = [(o.s0, o.s1, o.z0, o.z1) for o in wall.openings]
        # face name by its normal: (axis, sign) -> compass side
        side = {("x", 1): "east", ("x", -1): "west", ("y", 1): "north", ("y", -1): "south"}
        other_axis = "x" if wall.axis == "y" else "y"
        for across, facing in ((c1, +1), (c0, -1)):
            tag = side[(other_axis, facing)]
            cut = [(a, b, 0.0, h) for a, b in _touching(pa, across, facing, (s0, s1), others)]
            self.add(*vertical_face(f"{wall.id}_{tag}", wall.axis, across, (s0, s1), (0.0, h),
                                    facing, mat, "interior_wall", holes + cut, wall.id))
        # exposed ends: faces across the thickness at s0 (facing -along) and s1 (+along)
        for s, facing in ((s0, -1), (s1, +1)):
            tag = side[(wall.axis, facing)] + "_end"
            cut = [(a, b, 0.0, h) for a, b in _touching(1 - pa, s, facing, (c0, c1), others)]
            self.add(*vertical_face(f"{wall.id}_{tag}", other_axis, s, (c0, c1), (0.0, h),
                                    facing, mat, "interior_wall", cut, wall.id))
        # reveals of the openings: jambs, soffit (top), sill (bottom, windows)
        for o in wall.openings:
            for s, facing, tag in ((o.s0, +1, "jamb_1"), (o.s1, -1, "jamb_2")):
                self.add(*vertical_face(f"{wall.id}_{o.id}_{tag}", other_axis, s, (c0, c1),
                                        (o.z0, o.z1), facing, mat, "interior_wall",
                                        group=wall.id))
            plan = (o.s0, o.s1, c0, c1) if wall.axis == "x" else (c0, c1, o.s0, o.s1)
            if o.z1 < h - _TOL:
                self.add(*horizontal_surface(f"{wall.id}_{o.id}_soffit", plan, o.z1, -1, mat,
                                             "interior_wall", group=wall.id))
            if o.z0 > _TOL:
                self.add(*horizontal_surface(f"{wall.id}_{o.id}_sill", plan, o.z0, +1, mat,
                                             "interior_wall", group=wall.id))

    # -- output --
    def textures(self) -> list[str]:
        """Texture PNGs the materials use (sorted)."""
        return sorted({m.texture for m in self.materials.values() if m.texture is not None})

    def objects(self) -> list[dict]:
        """Per furniture piece or small object (shapes sharing a group): its role, shapes,
        total area and axis-aligned bounds; ``footprint_xy_m`` = (x0, x1, y0, y1) is its plan
        rectangle (the robot keeps its distance from it)."""
        groups: dict[str, list[Shape]] = {}
        for s in self.shapes:
            if s.role in ("furniture", "small_object"):
                groups.setdefault(s.group, []).append(s)
        out = []
        for g, shapes in groups.items():
            if len({s.role for s in shapes}) != 1:
                raise ValueError(f"object '{g}' mixes roles {sorted({s.role for s in shapes})}")
            lo = np.min([s.bbox()[0] for s in shapes], axis=0)
            hi = np.max([s.bbox()[1] for s in shapes], axis=0)
            out.append({"id": g, "role": shapes[0].role, "shapes": [s.id for s in shapes],
                        "area_m2": _r_area(sum(s.area for s in shapes)),
                        "footprint_xy_m": _round_list([lo[0], hi[0], lo[1], hi[1]]),
                        "z_m": _round_list([lo[2], hi[2]])})
        return out

    def camera(self) -> dict:
        """Camera placeholder: the camera of a robot at the world origin facing +x."""
        origin = (SENSOR_MOUNT[0], SENSOR_MOUNT[1], SENSOR_MOUNT[2] + CAMERA_ABOVE_SENSOR)
        return {"robot_pose": [0.0, 0.0, 0.0], "origin": list(origin),
                "target": [origin[0] + 1.0, origin[1], origin[2]], "up": [0.0, 0.0, 1.0],
                "fov_deg": CAMERA_FOV_DEG, "fov_axis": "x",
                "note": "placeholder: the camera module sets the real intrinsics and pose"}

    def xml(self) -> str:
        cam = self.camera()
        out = ['<?xml version="1.0" encoding="utf-8"?>',
               f'<!-- {self.name}: {self.description} -->',
               '<!-- Written by scenes/generate.py: edit the generator, not this file. '
               'World frame: metres, z up; robot at the origin faces +x. -->',
               '<scene version="3.0.0">',
               '    <default name="spp" value="64"/>',
               '    <default name="width" value="1600"/>',
               '    <default name="height" value="1200"/>',
               '    <default name="max_depth" value="8"/>',
               '',
               '    <!-- volpath: its shadow rays continue through thin glass panes (null '
               'transmission), so sun and sky light reach the room through the windows where '
               'the acoustic BSDF forwards eval_null_transmission -->',
               '    <integrator type="volpath">',
               '        <integer name="max_depth" value="$max_depth"/>',
               '    </integrator>',
               '',
               '    <!-- camera placeholder: robot at (0, 0, yaw 0); sensor head 0.1 m ahead and'
               ' 0.5 m up, camera 0.075 m above it -->',
               '    <sensor type="perspective" id="camera">',
               f'        <float name="fov" value="{_fmt(cam["fov_deg"])}"/>',
               '        <string name="fov_axis" value="x"/>',
               '        <float name="near_clip" value="0.01"/>',
               '        <float name="far_clip" value="1000"/>',
               '        <transform name="to_world">',
               f'            <lookat origin="{_fmt_vec(cam["origin"])}" '
               f'target="{_fmt_vec(cam["target"])}" up="0, 0, 1"/>',
               '        </transform>',
               '        <sampler type="independent">',
               '            <integer name="sample_count" value="$spp"/>',
               '        </sampler>',
               '        <film type="hdrfilm">',
               '            <integer name="width" value="$width"/>',
               '            <integer name="height" value="$height"/>',
               '            <rfilter type="gaussian"/>',
               '        </film>',
               '    </sensor>',
               '']
        if self.sun is not None:
            direction, irradiance = self.sun
            out += ['    <!-- sun: parallel light entering through the windows (sunlit patches '
                    'with sharp shadow edges) -->',
                    '    <emitter type="directional" id="sun">',
                    f'        <vector name="direction" value="{_fmt_vec(direction)}"/>',
                    f'        <rgb name="irradiance" value="{_fmt_vec(irradiance)}"/>',
                    '    </emitter>',
                    '']
        if self.sky:
            out += ['    <!-- sky above the horizon, ground below it; seen through the windows -->',
                    '    <emitter type="envmap" id="sky">',
                    f'        <string name="filename" value="{SKY_FILE}"/>',
                    f'        <float name="scale" value="{_fmt(SKY_SCALE)}"/>',
                    '        <transform name="to_world">',
                    '            <rotate x="1" angle="90"/>',
                    '        </transform>',
                    '    </emitter>',
                    '']
        for mat in self.materials.values():
            out += ["    " + line for line in mat.xml()]
        out.append('')
        for s in self.shapes:
            out += ["    " + line for line in s.xml()]
        out.append('</scene>')
        return "\n".join(out) + "\n"

    def ground_truth(self) -> dict:
        per_material: dict[str, dict] = {}
        for s in self.shapes:
            entry = per_material.setdefault(s.material, {
                "preset": self.materials[s.material].preset,
                "optical": self.materials[s.material].optical, "shapes": 0, "area_m2": 0.0})
            if self.materials[s.material].texture is not None:
                entry["texture"] = self.materials[s.material].texture
            entry["shapes"] += 1
            entry["area_m2"] += s.area
        for entry in per_material.values():
            entry["area_m2"] = _r_area(entry["area_m2"])
        shapes = []
        for s in self.shapes:
            d = {"id": s.id, "material": s.material, "preset": self.materials[s.material].preset,
                 "role": s.role, "group": s.group, "type": s.kind, "area_m2": _r_area(s.area)}
            if s.kind == "rectangle":
                d["normal"] = _round_list(s.normal())
                d["corners"] = [_round_list(c) for c in s.corners()]
            if s.kind in ("cylinder", "disk", "sphere"):
                d["radius_m"] = _r(s.radius)
                # a cylinder's origin is the centre of its base (local z = 0)
                d["base" if s.kind == "cylinder" else "centre"] = _round_list(s.to_world[:3, 3])
            if s.kind == "cylinder":
                d["length_m"] = _r(np.linalg.norm(s.to_world[:3, 2]))
                d["axis"] = _round_list(s.normal())
            if s.kind == "disk":
                d["normal"] = _round_list(s.normal())
            d["to_world"] = [_round_list(row) for row in s.to_world]
            shapes.append(d)
        xs = [v for r in self.rooms for v in r["x"]]
        ys = [v for r in self.rooms for v in r["y"]]
        gt = {
            "scene": self.name,
            "description": self.description,
            "units": "SI: metres, m^2, m/s; angles in degrees (yaw)",
            "frame": "world: z up, floor at z = 0; robot pose (x, y, yaw) is the chassis centre, "
                     "yaw from +x towards +y",
            "height_m": self.height,
            "interior_extent_m": {"x": [min(xs), max(xs)], "y": [min(ys), max(ys)],
                                  "z": [0.0, self.height]},
            "rooms": [{"id": r["id"], "x_m": list(r["x"]), "y_m": list(r["y"]),
                       "floor_area_m2": _r((r["x"][1] - r["x"][0]) * (r["y"][1] - r["y"][0]))}
                      for r in self.rooms],
            "floor_area_m2": _r(sum(s.area for s in self.shapes if s.role == "floor")),
            "total_area_m2": _r_area(sum(s.area for s in self.shapes)),
            "materials": per_material,
            "windows": self.windows,
            "camera_placeholder": self.camera(),
            "trajectory": {
                "frame": "world",
                "waypoints": [[_r(x), _r(y), _r(yaw)] for x, y, yaw in self.trajectory],
                "waypoint_format": "[x_m, y_m, yaw_deg] of the robot chassis centre; yaw is "
                                   "unwrapped (continuous between waypoints)",
                "speed_m_s": self.speed,
                "yaw_rate_deg_s": self.yaw_rate,
                "motion": "straight lines at speed_m_s between waypoints with the same yaw; turns "
                          "in place at yaw_rate_deg_s between waypoints at the same position",
            },
            "shapes": shapes,
        }
        objects = self.objects()
        if objects:  # scenes with furniture: per-object bounds and the textures
            gt = {k: v for k, v in gt.items() if k != "shapes"} | {
                "textures": self.textures(), "objects": objects, "shapes": shapes}
        return gt

    def write(self, out_dir: Path) -> Path:
        """Write scene.xml, ground_truth.json (and sky.png, texture PNGs) into
        ``out_dir/<name>``."""
        d = Path(out_dir) / self.name
        d.mkdir(parents=True, exist_ok=True)
        _write_atomic(d / "scene.xml", self.xml().encode())
        _write_atomic(d / "ground_truth.json", (_dump_json(self.ground_truth()) + "\n").encode())
        if self.sky:
            _write_atomic(d / SKY_FILE, sky_png())
        for name in self.textures():
            _write_atomic(d / name, TEXTURES[name]())
        return d / "scene.xml"


# ---- the scenes -------------------------------------------------------------------------------
#: Palette (linear RGB diffuse reflectance).
LIGHT_GREY = (0.72, 0.72, 0.72)
CEILING_WHITE = (0.82, 0.82, 0.82)
CONCRETE_GREY = (0.42, 0.41, 0.40)
ORANGE = (0.85, 0.33, 0.06)
PANEL_WHITE = (0.9, 0.9, 0.9)
#: Radiance of a ceiling light panel [W/(m^2 sr)], warm white.
PANEL_RADIANCE = (14.0, 13.0, 11.5)
#: Sun: direction the light travels (the sun stands at azimuth 39 deg from +x towards +y, 35 deg
#: above the horizon, so it shines into both windows of room_glass) and its irradiance [W/m^2]
#: normal to the rays.
SUN_DIRECTION = (-0.55, -0.45, -0.5)
SUN_IRRADIANCE = (6.0, 5.6, 5.0)


def room_glass() -> SceneSpec:
    """Single room, 7.5 m x 6 m x 2.6 m (45 m^2), two glass windows, plain light-grey drywall,
    concrete floor, plaster ceiling with two light panels.

    Plan (world frame, robot at the origin facing +x):
        x in [-4.5, 3.0], y in [-3.0, 3.0]. The east wall (x = 3.0, 2.9 m ahead of the sensor
        head at the demo pose) has window_east: 1.6 m wide centred at y = -0.25 (slightly right
        of the robot's heading, so a left/right mix-up shows), 0.8-2.2 m high. The north wall
        (y = 3.0) has window_north centred at x = 0.75, same size. The windows sit in 0.1 m deep
        reveals (jambs, sill, soffit: the outer walls' thickness) with the thin glass pane at
        their outer end (x = 3.1 and y = 3.1).
    """
    spec = SceneSpec("room_glass", "single room 7.5 m x 6 m x 2.6 m (45 m^2), two glass windows, "
                     "texture-less walls, concrete floor, ceiling light panels", height=2.6,
                     sky=True, sun=(SUN_DIRECTION, SUN_IRRADIANCE),
                     overview=((-4.2, -2.7, 1.6), (1.5, 1.2, 1.0)))
    outer = (-4.5, 3.0, -3.0, 3.0)
    spec.rooms = [{"id": "room", "x": (-4.5, 3.0), "y": (-3.0, 3.0)}]
    wall = spec.material(Material("wall_drywall", "drywall", rgb=LIGHT_GREY))
    floor = spec.material(Material("floor_concrete", "concrete", rgb=CONCRETE_GREY))
    ceiling = spec.material(Material("ceiling_plaster", "plaster", rgb=CEILING_WHITE))
    glass = spec.material(Material("window_glass", "glass", optical="thindielectric", ior=1.5))
    panel = spec.material(Material("light_panel", "plaster", rgb=PANEL_WHITE))
    # window centres: y = -0.25 on the east wall, x = 0.75 on the north wall
    sill, top, width = 0.8, 2.2, 1.6
    east_c, north_c = -0.25, 0.75
    openings = {
        "east": [Opening("window_east", east_c - width / 2, east_c + width / 2, sill, top, glass)],
        "north": [Opening("window_north", north_c - width / 2, north_c + width / 2, sill, top,
                          glass)],
    }
    lights = [((-3.0, -1.8, -0.3, 0.3), PANEL_RADIANCE), ((0.3, 1.5, -0.3, 0.3), PANEL_RADIANCE)]
    spec.enclosure(outer, wall, floor, ceiling, openings, lights=lights, window_reveal=0.1)
    spec.ceiling_lights(lights, panel)
    # A loop 1.5 m inside the walls (2 m from the east wall), facing the wall ahead; it starts at
    # the demo pose facing window_east and drives towards window_north on the second leg.
    spec.trajectory = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (1.0, 0.0, 90.0), (1.0, 1.5, 90.0),
                       (1.0, 1.5, 180.0), (-3.0, 1.5, 180.0), (-3.0, 1.5, 270.0),
                       (-3.0, -1.5, 270.0), (-3.0, -1.5, 360.0), (1.0, -1.5, 360.0)]
    return spec


def structure() -> SceneSpec:
    """Several rooms with orange interior walls (0.1 m thick, 1.4 m wide doorways), light-grey
    outer walls, concrete floor, plaster ceiling with a light panel per room; no windows.

    Plan (world frame, robot at the origin facing +x), 12 m x 8 m x 2.6 m:
        outer x in [-3.5, 8.5], y in [-4.0, 4.0].
        wall_a: x in [3.0, 3.1], full depth, doorway y in [0.5, 1.9] (the robot at the origin
            faces it 2.9 m ahead, the doorway on its left).
        wall_b: y in [-1.0, -0.9], from wall_a to the east wall, doorway x in [5.0, 6.4].
        wall_c: y in [1.5, 1.6], a partition from the west wall to x = -1.0 (free end).
    Rooms: west (6.5 m x 8 m, with the partition), north-east, south-east.
    """
    spec = SceneSpec("structure", "indoor structure 12 m x 8 m x 2.6 m: three rooms, orange "
                     "interior walls with doorways, a partition, ceiling light panels", height=2.6,
                     overview=((-3.2, -3.7, 2.4), (3.5, 1.5, 0.6)))
    outer = (-3.5, 8.5, -4.0, 4.0)
    spec.rooms = [{"id": "west", "x": (-3.5, 3.0), "y": (-4.0, 4.0)},
                  {"id": "north_east", "x": (3.1, 8.5), "y": (-0.9, 4.0)},
                  {"id": "south_east", "x": (3.1, 8.5), "y": (-4.0, -1.0)}]
    wall = spec.material(Material("wall_drywall", "drywall", rgb=LIGHT_GREY))
    inner = spec.material(Material("interior_wall_orange", "drywall", rgb=ORANGE))
    floor = spec.material(Material("floor_concrete", "concrete", rgb=CONCRETE_GREY))
    ceiling = spec.material(Material("ceiling_plaster", "plaster", rgb=CEILING_WHITE))
    panel = spec.material(Material("light_panel", "plaster", rgb=PANEL_WHITE))
    door_h = 2.1
    interior = [
        ThickWall("wall_a", "y", (-4.0, 4.0), (3.0, 3.1),
                  (Opening("door", 0.5, 1.9, 0.0, door_h),)),
        ThickWall("wall_b", "x", (3.1, 8.5), (-1.0, -0.9),
                  (Opening("door", 5.0, 6.4, 0.0, door_h),)),
        ThickWall("wall_c", "x", (-3.5, -1.0), (1.5, 1.6)),
    ]
    lights = [((-1.0, 0.2, -2.3, -1.7), PANEL_RADIANCE), ((-2.5, -1.3, 2.5, 3.1), PANEL_RADIANCE),
              ((1.0, 2.2, 1.7, 2.3), PANEL_RADIANCE), ((5.2, 6.4, 1.2, 1.8), PANEL_RADIANCE),
              ((5.2, 6.4, -2.8, -2.2), PANEL_RADIANCE)]
    spec.enclosure(outer, wall, floor, ceiling, interior=interior, interior_mat=inner,
                   lights=lights)
    spec.ceiling_lights(lights, panel)
    # A survey for surfel scanning, which needs two or three creases meeting in the camera's
    # view within the sonar's 5 m: the robot drives straight at room corners (stopping 2-3 m
    # short) and turns on the spot between them. West room: its south-east corner, south-west
    # corner, the corner of the west wall and the partition; then on towards wall_a's doorway
    # (the west room's north-east corner on its left), through it into the north-east room
    # (its east corners), south through wall_b's doorway into the south-east room (its east
    # and west corners).
    spec.trajectory = [(0.0, 0.0, 0.0), (0.0, 0.0, -53.0), (1.2, -1.6, -53.0),
                       (1.2, -1.6, -153.0), (-1.5, -3.0, -153.0), (-1.5, -3.0, -246.0),
                       (-2.3, -1.2, -246.0), (-2.3, -1.2, -324.0), (1.0, 1.2, -324.0),
                       (1.0, 1.2, -360.0), (5.7, 1.2, -360.0), (5.7, 1.2, -315.0),
                       (5.7, 1.2, -397.0), (5.7, 1.2, -450.0), (5.7, -2.5, -450.0),
                       (5.7, -2.5, -388.0), (5.7, -2.5, -510.0)]
    return spec


# ---- furniture ----------------------------------------------------------------------------------
# Free-standing objects are built from closed pieces (cubes, capped cylinders, spheres), so each
# piece's area is that of a solid; where pieces touch (a leg under a table top, a can on a shelf)
# the touching faces are hidden but still counted in the ground-truth areas.
def _span(lo_hi: Interval) -> tuple[float, float]:
    """(centre, size) of an interval."""
    return 0.5 * (lo_hi[0] + lo_hi[1]), lo_hi[1] - lo_hi[0]


#: Grid [m] that furniture box corners are snapped to (2^-16 m, 15 micrometres).
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
    if sy > sx + _TOL:
        return box(shape_id, (cx, cy, cz), (sy, sx, sz), material, role, group, yaw_deg=90.0)
    return box(shape_id, (cx, cy, cz), (sx, sy, sz), material, role, group)


def table(gid: str, x: Interval, y: Interval, height: float, top_mat: str, leg_mat: str,
          top: float = 0.04, leg: float = 0.05, inset: float = 0.03) -> list[Shape]:
    """Table: a top ``top`` [m] thick whose upper face is at ``height`` over the plan rectangle
    x, y, on four square legs ``leg`` [m] wide set ``inset`` [m] in from the corners."""
    shapes = [block(f"{gid}_top", x, y, (height - top, height), top_mat, "furniture", gid)]
    k = 0
    for lx in (x[0] + inset, x[1] - inset - leg):
        for ly in (y[0] + inset, y[1] - inset - leg):
            k += 1
            shapes.append(block(f"{gid}_leg_{k}", (lx, lx + leg), (ly, ly + leg),
                                (0.0, height - top), leg_mat, "furniture", gid))
    return shapes


#: Unit plan vectors of the compass directions.
_DIRS = {"east": (1.0, 0.0), "west": (-1.0, 0.0), "north": (0.0, 1.0), "south": (0.0, -1.0)}


def chair(gid: str, centre, facing: str, seat_mat: str, leg_mat: str,
          seat: float = 0.45, seat_h: float = 0.46, back_h: float = 0.42) -> list[Shape]:
    """Chair: a square seat ``seat`` [m] wide whose top is at ``seat_h``, a backrest ``back_h``
    [m] tall along its rear edge (the sitter faces ``facing``), four square legs."""
    cx, cy = centre
    fx, fy = _DIRS[facing]
    h = seat / 2
    x, y = (cx - h, cx + h), (cy - h, cy + h)
    shapes = [block(f"{gid}_seat", x, y, (seat_h - 0.05, seat_h), seat_mat, "furniture", gid)]
    t = 0.04  # backrest thickness [m]
    bx = x if fx == 0 else ((cx - h, cx - h + t) if fx > 0 else (cx + h - t, cx + h))
    by = y if fy == 0 else ((cy - h, cy - h + t) if fy > 0 else (cy + h - t, cy + h))
    shapes.append(block(f"{gid}_back", bx, by, (seat_h, seat_h + back_h), seat_mat, "furniture",
                        gid))
    leg, inset, k = 0.03, 0.02, 0
    for lx in (x[0] + inset, x[1] - inset - leg):
        for ly in (y[0] + inset, y[1] - inset - leg):
            k += 1
            shapes.append(block(f"{gid}_leg_{k}", (lx, lx + leg), (ly, ly + leg),
                                (0.0, seat_h - 0.05), leg_mat, "furniture", gid))
    return shapes


def sofa(gid: str, x: Interval, y: Interval, back: str, material: str) -> list[Shape]:
    """Sofa over the plan rectangle x, y: a base 0.42 m high, a backrest 0.22 m thick up to
    0.85 m along the side ``back`` ('north', ...), and two arms 0.18 m wide up to 0.62 m."""
    bx, by = _DIRS[back]
    t, a = 0.22, 0.18
    shapes = [block(f"{gid}_base", x, y, (0.0, 0.42), material, "furniture", gid)]
    if by != 0:
        back_y = (y[1] - t, y[1]) if by > 0 else (y[0], y[0] + t)
        seat_y = (y[0], y[1] - t) if by > 0 else (y[0] + t, y[1])
        shapes.append(block(f"{gid}_back", x, back_y, (0.42, 0.85), material, "furniture", gid))
        arms = [((x[0], x[0] + a), seat_y), ((x[1] - a, x[1]), seat_y)]
    else:
        back_x = (x[1] - t, x[1]) if bx > 0 else (x[0], x[0] + t)
        seat_x = (x[0], x[1] - t) if bx > 0 else (x[0] + t, x[1])
        shapes.append(block(f"{gid}_back", back_x, y, (0.42, 0.85), material, "furniture", gid))
        arms = [(seat_x, (y[0], y[0] + a)), (seat_x, (y[1] - a, y[1]))]
    for k, (ax, ay) in enumerate(arms):
        shapes.append(block(f"{gid}_arm_{k + 1}", ax, ay, (0.42, 0.62), material, "furniture",
                            gid))
    return shapes


def shelf_unit(gid: str, x: Interval, y: Interval, height: float, levels: list[float],
               side_mat: str, board_mat: str) -> list[Shape]:
    """Open shelving along its longer plan axis: two side panels 0.04 m thick at its ends,
    full height, and boards 0.03 m thick between them whose upper faces are at ``levels`` [m]."""
    side, board = 0.04, 0.03
    along_x = (x[1] - x[0]) >= (y[1] - y[0])
    shapes = []
    ends = [(x[0], x[0] + side), (x[1] - side, x[1])] if along_x else \
        [(y[0], y[0] + side), (y[1] - side, y[1])]
    for k, e in enumerate(ends):
        ex, ey = (e, y) if along_x else (x, e)
        shapes.append(block(f"{gid}_side_{k + 1}", ex, ey, (0.0, height), side_mat, "furniture",
                            gid))
    inner = (ends[0][1], ends[1][0])
    for k, z in enumerate(levels):
        bx, by = (inner, y) if along_x else (x, inner)
        shapes.append(block(f"{gid}_board_{k + 1}", bx, by, (z - board, z), board_mat,
                            "furniture", gid))
    return shapes


def item_box(gid: str, centre_xy, z0: float, size, material: str, role: str = "small_object",
             part: str = "") -> Shape:
    """Axis-aligned box of ``size`` (x, y, z) [m] standing on the surface at height ``z0``."""
    sid = f"{gid}_{part}" if part else gid
    (cx, cy), (sx, sy, sz) = centre_xy, size
    return block(sid, (cx - sx / 2, cx + sx / 2), (cy - sy / 2, cy + sy / 2), (z0, z0 + sz),
                 material, role, gid)


def item_can(gid: str, centre_xy, z0: float, radius: float, height: float, material: str,
             role: str = "small_object", part: str = "") -> list[Shape]:
    """Upright closed cylinder (can, cup, drum) standing on the surface at height ``z0``."""
    sid = f"{gid}_{part}" if part else gid
    return closed_cylinder(sid, (centre_xy[0], centre_xy[1], z0), radius, height, material, role,
                           gid)


def item_rod(gid: str, centre_xy, z0: float, radius: float, length: float, axis: str,
             material: str, part: str = "") -> list[Shape]:
    """Closed cylinder lying on the surface at height ``z0`` along world 'x' or 'y'."""
    sid = f"{gid}_{part}" if part else gid
    d = np.array(_DIRS["east" if axis == "x" else "north"] + (0.0,))
    base = np.array([centre_xy[0], centre_xy[1], z0 + radius]) - d * length / 2
    return closed_cylinder(sid, base, radius, length, material, "small_object", gid, axis=d)


# ---- workshop and office ----------------------------------------------------------------------
#: Fluorescent strip radiance [W/(m^2 sr)], cool white.
STRIP_RADIANCE = (16.0, 16.0, 15.0)


def workshop() -> SceneSpec:
    """Small workshop, 8 m x 6 m x 3 m: painted concrete walls (a colour per wall), a concrete
    slab floor (texture with saw-cut joints every 2 m), three workbenches (oak tops, steel legs),
    two tall blue shelving units with cardboard boxes and plastic bins, a red tool cabinet, a
    milling machine (hazard-striped base), an oil drum and a wooden crate, and 37 small tools
    and parts (boxes, capped cylinders and balls 2-15 cm across; the thinnest 1 cm) on the
    benches and shelves. Four
    fluorescent strips in the ceiling; no windows.

    Plan (world frame, robot at the origin facing +x): x in [-3, 5], y in [-3, 3].
        bench_1, bench_2 along the south wall (y in [-2.95, -2.15]), bench_3 along the west
        wall (x in [-2.95, -2.15]); shelf_1, shelf_2 along the north wall (y in [2.45, 2.95],
        2.2 m tall); along the east wall the cabinet (y in [1.4, 2.3]), the machine (y in
        [-0.5, 0.5], 3.75 m ahead of the sensor head at the demo pose) and the drum (centre
        (4.45, -1.8)); the crate in the south-east corner. The robot loops around the free
        middle, >= 0.5 m from every footprint.

    Acoustic presets: hard plastic and cardboard have no preset of their own; they use 'wood'
    (any rigid solid reflects > 99.9 % of the energy at 40 kHz, so the choice hardly matters).
    """
    spec = SceneSpec("workshop", "small workshop 8 m x 6 m x 3 m: workbenches, tall shelves "
                     "with boxes, cabinet, machine, drum, crate, 37 small tools and parts",
                     height=3.0, overview=((-2.8, -2.8, 2.6), (2.5, 1.2, 0.6)))
    outer = (-3.0, 5.0, -3.0, 3.0)
    spec.rooms = [{"id": "workshop", "x": (-3.0, 5.0), "y": (-3.0, 3.0)}]
    walls = {side: spec.material(Material(f"wall_{side}_paint", "concrete", rgb=rgb))
             for side, rgb in (("north", (0.40, 0.52, 0.68)), ("east", (0.74, 0.64, 0.36)),
                               ("south", (0.50, 0.62, 0.46)), ("west", (0.70, 0.54, 0.44)))}
    floor = spec.material(Material("floor_concrete", "concrete", texture="concrete_floor.png",
                                   uv_scale=(4.0, 3.0)))
    ceiling = spec.material(Material("ceiling_concrete", "concrete", rgb=CEILING_WHITE))
    panel = spec.material(Material("light_panel", "plaster", rgb=PANEL_WHITE))
    oak = spec.material(Material("bench_oak", "wood", texture="wood_oak.png"))
    steel = spec.material(Material("steel_dark", "metal", rgb=(0.20, 0.21, 0.23)))
    bright = spec.material(Material("steel_bright", "metal", rgb=(0.55, 0.56, 0.58)))
    rack = spec.material(Material("rack_blue", "metal", rgb=(0.05, 0.14, 0.42)))
    board = spec.material(Material("rack_board", "metal", rgb=(0.50, 0.51, 0.52)))
    cardboard = spec.material(Material("cardboard", "wood", rgb=(0.45, 0.29, 0.14)))
    bin_red = spec.material(Material("bin_red", "wood", rgb=(0.60, 0.07, 0.05)))
    cabinet_red = spec.material(Material("cabinet_red", "metal", rgb=(0.55, 0.05, 0.04)))
    hazard = spec.material(Material("machine_hazard", "metal", texture="hazard.png",
                                    uv_scale=(2.0, 2.0)))
    green = spec.material(Material("machine_green", "metal", rgb=(0.10, 0.36, 0.20)))
    drum_blue = spec.material(Material("drum_blue", "metal", rgb=(0.04, 0.14, 0.50)))
    red = spec.material(Material("plastic_red", "wood", rgb=(0.70, 0.06, 0.04)))
    yellow = spec.material(Material("plastic_yellow", "wood", rgb=(0.85, 0.62, 0.03)))
    blue = spec.material(Material("plastic_blue", "wood", rgb=(0.05, 0.25, 0.70)))
    white = spec.material(Material("paint_white", "metal", rgb=(0.80, 0.80, 0.78)))
    orange = spec.material(Material("paint_orange", "metal", rgb=(0.85, 0.30, 0.04)))
    handle = spec.material(Material("handle_wood", "wood", rgb=(0.50, 0.32, 0.16)))

    lights = [((x0, x0 + 1.6, y0, y0 + 0.3), STRIP_RADIANCE)
              for x0 in (-1.9, 1.9) for y0 in (-1.35, 1.05)]
    spec.enclosure(outer, walls, floor, ceiling, lights=lights)
    spec.ceiling_lights(lights, panel)

    # workbenches: upper faces at 0.9 m
    top = 0.9
    for gid, x, y in (("bench_1", (-2.6, -0.8), (-2.95, -2.15)),
                      ("bench_2", (0.4, 2.2), (-2.95, -2.15)),
                      ("bench_3", (-2.95, -2.15), (-1.0, 0.8))):
        spec.add(*table(gid, x, y, top, oak, steel, top=0.05, leg=0.06))
    # tall shelving along the north wall, boards at these heights [m]
    levels = [0.12, 0.62, 1.12, 1.62, 2.12]
    for gid, x in (("shelf_1", (-2.6, -0.6)), ("shelf_2", (-0.3, 1.7))):
        spec.add(*shelf_unit(gid, x, (2.45, 2.95), 2.2, levels, rack, board))
    # boxes and bins on the shelves (furniture-sized): (id, centre x, level, size, material)
    for gid, cx, lv, size, mat in (
            ("box_1", -2.2, 0, (0.5, 0.4, 0.35), cardboard),
            ("box_2", -1.5, 0, (0.5, 0.4, 0.35), cardboard),
            ("bin_1", -2.25, 1, (0.4, 0.35, 0.25), bin_red),
            ("bin_2", -1.75, 1, (0.4, 0.35, 0.25), bin_red),
            ("bin_3", -1.25, 1, (0.4, 0.35, 0.25), bin_red),
            ("box_3", -1.9, 3, (0.6, 0.4, 0.3), cardboard),
            ("box_4", 0.2, 0, (0.6, 0.4, 0.4), cardboard),
            ("box_5", 1.1, 0, (0.5, 0.4, 0.3), cardboard),
            ("bin_4", 0.1, 2, (0.4, 0.35, 0.25), blue),
            ("bin_5", 0.6, 2, (0.4, 0.35, 0.25), blue),
            ("box_6", 0.9, 3, (0.6, 0.4, 0.3), cardboard)):
        spec.add(item_box(gid, (cx, 2.7), levels[lv], size, mat, role="furniture"))
    # large objects along the east wall and in the south-east corner
    spec.add(block("cabinet_body", (4.4, 4.95), (1.4, 2.3), (0.0, 1.1), cabinet_red,
                   "furniture", "cabinet"))
    for k, (z0, z1) in enumerate(((0.08, 0.30), (0.32, 0.54), (0.56, 0.78), (0.80, 1.02))):
        spec.add(block(f"cabinet_drawer_{k + 1}", (4.385, 4.4), (1.45, 2.25), (z0, z1), bright,
                       "furniture", "cabinet"))
    spec.add(block("machine_base", (3.9, 4.8), (-0.5, 0.5), (0.0, 0.85), hazard, "furniture",
                   "machine"),
             block("machine_table", (3.85, 4.3), (-0.45, 0.45), (0.85, 0.95), bright,
                   "furniture", "machine"),
             block("machine_column", (4.35, 4.8), (-0.3, 0.3), (0.85, 2.1), green, "furniture",
                   "machine"),
             block("machine_head", (3.95, 4.35), (-0.22, 0.22), (1.55, 1.95), green,
                   "furniture", "machine"),
             *closed_cylinder("machine_spindle", (4.15, 0.0, 1.35), 0.04, 0.2, bright,
                              "furniture", "machine"))
    spec.add(*item_can("drum", (4.45, -1.8), 0.0, 0.29, 0.88, drum_blue, role="furniture"))
    spec.add(block("crate", (2.9, 3.9), (-2.9, -2.2), (0.0, 0.7), oak, "furniture", "crate"))

    # small tools and parts; benches' upper faces at z = top, shelf boards at levels[k]
    tools: list = [
        # bench_1 (x -2.6..-0.8, y -2.95..-2.15)
        item_box("tool_01", (-2.35, -2.32), top, (0.15, 0.12, 0.12), steel),        # vise
        [*item_rod("tool_02", (-1.945, -2.55), top, 0.012, 0.11, "x", handle, "handle"),
         item_box("tool_02", (-1.875, -2.55), top, (0.03, 0.09, 0.03), steel,
                  part="head")],                                                     # hammer
        item_rod("tool_03", (-1.55, -2.30), top, 0.012, 0.15, "x", red),              # screwdriver
        item_rod("tool_04", (-1.55, -2.40), top, 0.010, 0.14, "x", yellow),          # screwdriver
        item_can("tool_05", (-1.20, -2.75), top, 0.055, 0.11, white),                # paint can
        item_can("tool_06", (-1.02, -2.82), top, 0.033, 0.15, orange),                # spray can
        item_box("tool_07", (-1.40, -2.80), top, (0.1, 0.06, 0.04), yellow),         # screws
        item_box("tool_08", (-1.00, -2.35), top, (0.07, 0.07, 0.04), yellow),        # tape
        item_box("tool_09", (-1.80, -2.85), top, (0.15, 0.03, 0.01), bright),  # wrench
        [item_box("tool_10", (-2.30, -2.75), top, (0.11, 0.06, 0.07), yellow, part="body"),
         *item_rod("tool_10", (-2.225, -2.75), top + 0.015, 0.02, 0.04, "x", steel,
                   "chuck")],                                                        # drill
        # bench_2 (x 0.4..2.2)
        item_box("tool_11", (0.65, -2.75), top, (0.15, 0.1, 0.08), blue),            # parts bin
        item_can("tool_12", (0.90, -2.80), top, 0.04, 0.12, bright),                 # tins
        item_can("tool_13", (1.00, -2.80), top, 0.04, 0.12, bright),
        item_can("tool_14", (1.10, -2.80), top, 0.04, 0.12, bright),
        item_box("tool_15", (1.40, -2.40), top, (0.1, 0.05, 0.05), steel),           # block
        sphere("tool_16", (1.60, -2.35, top + 0.03), 0.03, bright, "small_object", "tool_16"),
        sphere("tool_17", (1.70, -2.45, top + 0.025), 0.025, bright, "small_object",
               "tool_17"),                                                           # balls
        item_box("tool_18", (1.20, -2.35), top, (0.15, 0.05, 0.015), red),    # pliers
        item_box("tool_19", (0.75, -2.35), top, (0.15, 0.025, 0.01), steel),   # file
        item_can("tool_20", (1.90, -2.80), top, 0.025, 0.12, white),                 # glue
        item_box("tool_21", (2.00, -2.45), top, (0.08, 0.15, 0.04), yellow),         # meter
        # bench_3 (x -2.95..-2.15, y -1.0..0.8)
        [item_box("tool_22", (-2.60, 0.40), top, (0.15, 0.12, 0.03), steel, part="base"),
         *item_rod("tool_22", (-2.60, 0.40), top + 0.03, 0.06, 0.15, "y", green,
                   "motor")],                                                        # grinder
        item_can("tool_23", (-2.75, -0.70), top, 0.04, 0.14, red),                   # oil can
        item_box("tool_24", (-2.45, -0.55), top, (0.12, 0.08, 0.06), blue),
        item_box("tool_25", (-2.50, -0.10), top, (0.08, 0.15, 0.03), handle),        # chisels
        item_rod("tool_26", (-2.35, 0.10), top, 0.02, 0.15, "y", bright),            # pipe
        item_box("tool_27", (-2.30, -0.30), top, (0.03, 0.14, 0.01), bright),       # spanner
        # shelf_1, board at levels[2]
        item_can("tool_28", (-2.30, 2.70), levels[2], 0.05, 0.12, orange),
        item_can("tool_29", (-2.15, 2.75), levels[2], 0.05, 0.12, white),
        item_box("tool_30", (-1.60, 2.70), levels[2], (0.12, 0.1, 0.1), yellow),
        item_box("tool_31", (-1.30, 2.65), levels[2], (0.08, 0.08, 0.15), red),
        item_can("tool_32", (-1.00, 2.70), levels[2], 0.033, 0.15, orange),
        # shelf_2, board at levels[1]
        item_can("tool_33", (0.00, 2.70), levels[1], 0.06, 0.15, white),
        item_box("tool_34", (0.50, 2.70), levels[1], (0.14, 0.1, 0.08), blue),
        sphere("tool_35", (0.80, 2.70, levels[1] + 0.04), 0.04, orange, "small_object",
               "tool_35"),
        item_can("tool_36", (1.10, 2.65), levels[1], 0.03, 0.1, red),
        item_box("tool_37", (1.40, 2.70), levels[1], (0.1, 0.1, 0.1), steel),
    ]
    for t in tools:
        spec.add(*(t if isinstance(t, list) else [t]))

    # A loop around the free middle: east to the machine, north, west along the shelves,
    # south to the benches, east along them; facing the furniture or the wall ahead.
    spec.trajectory = [(0.0, 0.0, 0.0), (2.6, 0.0, 0.0), (2.6, 0.0, 90.0), (2.6, 1.5, 90.0),
                       (2.6, 1.5, 180.0), (-1.4, 1.5, 180.0), (-1.4, 1.5, 270.0),
                       (-1.4, -1.5, 270.0), (-1.4, -1.5, 360.0), (2.6, -1.5, 360.0)]
    return spec


def office() -> SceneSpec:
    """Large office, 12 m x 9 m x 2.8 m: drywall in four colours, blue-grey carpet tiles
    (fabric), plaster ceiling with six light panels, five small windows (0.9 m x 1.0 m, sill
    1.0 m: three in the north wall, two in the east wall; thin glass panes in 0.1 m reveals)
    with sky and sun. Furniture: a row of four desks along the south wall and a cluster of four
    in the middle (walnut tops, steel legs), each with a chair, a monitor, a keyboard and a cup;
    two sofas and a coffee table with two cups in the north-west lounge, a bookshelf with books
    on the west wall, two tall cabinets, a printer and two potted plants; a 0.4 m x 0.4 m
    concrete column (floor to ceiling, four faces, role 'interior_wall') in the west half.

    Plan (world frame, robot at the origin facing +x): x in [-4.5, 7.5], y in [-3.5, 5.5].
        South desks y in [-3.45, -2.75] (chairs up to y = -2.2), cluster x in [1.0, 3.8],
        y in [1.2, 2.6] (chairs y in [0.65, 3.15]), sofas at x in [-4.0, -2.0] against the
        north wall and x in [-4.45, -3.6] against the west wall, the column at x in
        [-2.9, -2.5], y in [-1.6, -1.2]. Windows: north wall at
        x = -3.5, -1.5, 1.5, east wall at y = -0.5, 2.5. The robot's loop looks at every window
        from 2-7 m.

    Acoustic presets: ceramic cups use 'concrete' (the nearest impedance of the presets), hard
    plastic 'wood', monitors 'metal', foliage 'fabric' (porous, rough).
    """
    spec = SceneSpec("office", "large office 12 m x 9 m x 2.8 m: desks, chairs, monitors, "
                     "cups, two sofas, bookshelf, five small glass windows, sun", height=2.8,
                     sky=True, sun=(SUN_DIRECTION, SUN_IRRADIANCE),
                     overview=((7.3, -2.2, 2.5), (0.0, 2.2, 0.3)))
    outer = (-4.5, 7.5, -3.5, 5.5)
    spec.rooms = [{"id": "office", "x": (-4.5, 7.5), "y": (-3.5, 5.5)}]
    walls = {side: spec.material(Material(f"wall_{side}_paint", "drywall", rgb=rgb))
             for side, rgb in (("north", (0.42, 0.55, 0.72)), ("east", (0.78, 0.76, 0.70)),
                               ("south", (0.55, 0.68, 0.52)), ("west", (0.76, 0.64, 0.48)))}
    floor = spec.material(Material("floor_carpet", "fabric", texture="carpet.png",
                                   uv_scale=(12.0, 9.0)))
    ceiling = spec.material(Material("ceiling_plaster", "plaster", rgb=CEILING_WHITE))
    glass = spec.material(Material("window_glass", "glass", optical="thindielectric", ior=1.5))
    panel = spec.material(Material("light_panel", "plaster", rgb=PANEL_WHITE))
    walnut = spec.material(Material("desk_walnut", "wood", texture="wood_walnut.png"))
    oak = spec.material(Material("shelf_oak", "wood", texture="wood_oak.png"))
    legs = spec.material(Material("steel_dark", "metal", rgb=(0.18, 0.18, 0.19)))
    seat_red = spec.material(Material("chair_red", "fabric", rgb=(0.55, 0.08, 0.07)))
    seat_grey = spec.material(Material("chair_charcoal", "fabric", rgb=(0.12, 0.12, 0.13)))
    teal = spec.material(Material("sofa_teal", "fabric", rgb=(0.04, 0.30, 0.32)))
    mustard = spec.material(Material("sofa_mustard", "fabric", rgb=(0.62, 0.42, 0.06)))
    screen = spec.material(Material("monitor_black", "metal", rgb=(0.025, 0.025, 0.03)))
    plastic = spec.material(Material("plastic_grey", "wood", rgb=(0.30, 0.30, 0.32)))
    printer_mat = spec.material(Material("plastic_light", "wood", rgb=(0.75, 0.75, 0.73)))
    cabinet = spec.material(Material("cabinet_grey", "metal", rgb=(0.62, 0.63, 0.64)))
    cups = [spec.material(Material(f"ceramic_{name}", "concrete", rgb=rgb))
            for name, rgb in (("white", (0.85, 0.85, 0.83)), ("red", (0.70, 0.08, 0.06)),
                              ("blue", (0.06, 0.22, 0.65)), ("yellow", (0.85, 0.65, 0.05)))]
    books = [spec.material(Material(f"book_{name}", "wood", rgb=rgb))
             for name, rgb in (("green", (0.10, 0.35, 0.15)), ("red", (0.60, 0.10, 0.08)),
                               ("cream", (0.80, 0.75, 0.60)))]
    pot = spec.material(Material("pot_terracotta", "concrete", rgb=(0.55, 0.24, 0.12)))
    leaves = spec.material(Material("foliage", "fabric", rgb=(0.07, 0.28, 0.06)))

    sill, top, half = 1.0, 2.0, 0.45
    openings = {
        "north": [Opening(f"window_north_{k + 1}", c - half, c + half, sill, top, glass)
                  for k, c in enumerate((-3.5, -1.5, 1.5))],
        "east": [Opening(f"window_east_{k + 1}", c - half, c + half, sill, top, glass)
                 for k, c in enumerate((-0.5, 2.5))],
    }
    lights = [((cx - 0.6, cx + 0.6, cy - 0.3, cy + 0.3), PANEL_RADIANCE)
              for cx in (-2.5, 1.5, 5.0) for cy in (-1.2, 2.8)]
    column = spec.material(Material("column_concrete", "concrete", rgb=(0.62, 0.62, 0.60)))
    spec.enclosure(outer, walls, floor, ceiling, openings,
                   interior=[ThickWall("column", "x", (-2.9, -2.5), (-1.6, -1.2))],
                   interior_mat=column, lights=lights, window_reveal=0.1)
    spec.ceiling_lights(lights, panel)

    desk_h = 0.75
    cup_k = 0

    def workstation(k: int, x: Interval, y: Interval, sitter: str, seat_mat: str):
        """Desk k over x, y; the chair on the ``sitter`` side (the sitter faces the desk);
        monitor at the far edge, keyboard near the sitter, a cup to the right."""
        nonlocal cup_k
        gid = f"desk_{k}"
        spec.add(*table(gid, x, y, desk_h, walnut, legs, top=0.03, leg=0.04))
        cx = 0.5 * (x[0] + x[1])
        sy = 1.0 if sitter == "north" else -1.0
        near = y[1] if sy > 0 else y[0]
        far = y[0] if sy > 0 else y[1]
        spec.add(*chair(f"chair_{k}", (cx, near + sy * 0.325), "south" if sy > 0 else "north",
                        seat_mat, legs))
        my = far + sy * 0.15
        spec.add(item_box(f"monitor_{k}", (cx, my), desk_h + 0.17, (0.54, 0.025, 0.32), screen,
                          role="furniture", part="screen"),
                 item_box(f"monitor_{k}", (cx, my - sy * 0.03), desk_h, (0.04, 0.04, 0.2),
                          screen, role="furniture", part="stand"),
                 item_box(f"monitor_{k}", (cx, my - sy * 0.03), desk_h, (0.2, 0.15, 0.012),
                          screen, role="furniture", part="base"))
        spec.add(item_box(f"keyboard_{k}", (cx, near - sy * 0.2), desk_h, (0.44, 0.14, 0.02),
                          plastic))
        cup_k += 1
        spec.add(*item_can(f"cup_{cup_k}", (cx + 0.45, near - sy * 0.22), desk_h, 0.04, 0.095,
                           cups[cup_k % len(cups)]))

    # south row: sitters north of the desks; middle cluster: back-to-back rows
    k = 0
    for x0 in (-3.3, -1.1, 1.1, 3.3):
        k += 1
        workstation(k, (x0, x0 + 1.4), (-3.45, -2.75), "north", seat_red)
    for y, sitter in (((1.2, 1.9), "south"), ((1.9, 2.6), "north")):
        for x0 in (1.0, 2.4):
            k += 1
            workstation(k, (x0, x0 + 1.4), y, sitter, seat_grey)

    # lounge: two sofas, a coffee table with two cups
    spec.add(*sofa("sofa_1", (-4.0, -2.0), (4.6, 5.45), "north", teal))
    spec.add(*sofa("sofa_2", (-4.45, -3.6), (1.55, 3.45), "west", mustard))
    spec.add(*table("coffee_table", (-3.2, -2.2), (2.8, 3.6), 0.44, walnut, legs, top=0.04,
                    leg=0.05))
    for cxy in ((-2.9, 3.1), (-2.5, 3.3)):
        cup_k += 1
        spec.add(*item_can(f"cup_{cup_k}", cxy, 0.44, 0.04, 0.095, cups[cup_k % len(cups)]))

    # bookshelf on the west wall with books (spines 3-5 cm thick)
    levels = [0.05, 0.45, 0.85, 1.25, 1.65, 2.0]
    spec.add(*shelf_unit("bookshelf", (-4.45, -4.1), (-2.0, 0.6), 2.0, levels, oak, oak))
    b = 0
    for lv, y0 in ((1, -1.9), (2, -1.2), (3, -0.4), (4, -1.6)):
        y = y0
        for thick, height in ((0.04, 0.28), (0.05, 0.30), (0.03, 0.24)):
            b += 1
            spec.add(item_box(f"book_{b}", (-4.3, y + thick / 2), levels[lv], (0.2, thick, height),
                              books[b % len(books)]))
            y += thick + 0.005

    # cabinets (south-east), printer (east wall), plants (north-east, south-west)
    for k, x in enumerate(((5.5, 6.4), (6.5, 7.4))):
        spec.add(block(f"cabinet_{k + 1}", x, (-3.45, -2.95), (0.0, 1.9), cabinet, "furniture",
                       f"cabinet_{k + 1}"))
    spec.add(block("printer", (6.8, 7.4), (0.6, 1.4), (0.0, 1.0), printer_mat, "furniture",
                   "printer"))
    for k, (cx, cy, r_pot, r_leaf) in enumerate(((6.9, 4.9, 0.22, 0.38),
                                                 (-4.0, -3.0, 0.20, 0.33))):
        gid = f"plant_{k + 1}"
        spec.add(*item_can(gid, (cx, cy), 0.0, r_pot, 0.45, pot, role="furniture", part="pot"),
                 sphere(f"{gid}_leaves", (cx, cy, 0.45 + 0.8 * r_leaf), r_leaf, leaves,
                        "furniture", gid))

    # Look east and north from the demo pose, go north, east along the north wall, south
    # along the east side, west along the south desks, end facing north.
    spec.trajectory = [(0.0, 0.0, 0.0), (0.0, 0.0, 90.0), (0.0, 3.9, 90.0), (0.0, 3.9, 0.0),
                       (5.2, 3.9, 0.0), (5.2, 3.9, -90.0), (5.2, -1.4, -90.0),
                       (5.2, -1.4, -180.0), (-1.8, -1.4, -180.0), (-1.8, -1.4, -270.0)]
    return spec


#: Scene name -> function building it.
SCENES: dict[str, Callable[[], SceneSpec]] = {"room_glass": room_glass, "structure": structure,
                                              "workshop": workshop, "office": office}


# ---- environment map --------------------------------------------------------------------------
SKY_FILE = "sky.png"
#: Multiplier on the sky image's linear values (envmap ``scale``).
SKY_SCALE = 1.5
_SKY_ZENITH = np.array([0.25, 0.42, 0.80])
_SKY_HORIZON = np.array([0.80, 0.86, 0.92])
_GROUND_NEAR = np.array([0.20, 0.22, 0.14])
_GROUND_HORIZON = np.array([0.34, 0.36, 0.30])


def sky_pixels(width: int = 128, height: int = 64) -> np.ndarray:
    """Linear RGB (height, width, 3) lat-long image: sky gradient above the horizon, ground
    below (Mitsuba envmap convention, top row = zenith after the +90 deg rotation about x)."""
    elevation = np.pi / 2 - (np.arange(height) + 0.5) / height * np.pi
    s = np.sin(elevation)[:, None]
    sky = _SKY_HORIZON + (_SKY_ZENITH - _SKY_HORIZON) * np.sqrt(np.clip(s, 0, 1))
    ground = _GROUND_HORIZON + (_GROUND_NEAR - _GROUND_HORIZON) * np.sqrt(np.clip(-s, 0, 1))
    row = np.where(s > 0, sky, ground)
    return np.repeat(row[:, None, :], width, axis=1)


def sky_png() -> bytes:
    """The sky image as an 8-bit sRGB PNG (deterministic bytes)."""
    lin = np.clip(sky_pixels(), 0.0, 1.0)
    srgb = np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * lin ** (1 / 2.4) - 0.055)
    return _png(np.round(srgb * 255).astype(np.uint8))


def _png(rgb: np.ndarray) -> bytes:
    h, w, _ = rgb.shape
    raw = b"".join(b"\x00" + rgb[y].tobytes() for y in range(h))

    def chunk(tag: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


# ---- procedural textures ----------------------------------------------------------------------
# Tileable 8-bit sRGB PNGs made from integer-hash value noise (no random generator: the same
# bytes on every machine). Each is one repeat of the pattern; the material's ``uv_scale`` sets
# how often it repeats over a shape.
def _hash01(ix: np.ndarray, iy: np.ndarray, seed: int) -> np.ndarray:
    """Deterministic pseudo-random values in [0, 1) of integer lattice points."""
    m = np.uint64(0xFFFFFFFF)
    h = ((ix.astype(np.uint64) * np.uint64(0x9E3779B1)) ^ (iy.astype(np.uint64) *
         np.uint64(0x85EBCA77)) ^ np.uint64((seed * 0xC2B2AE3D) & 0xFFFFFFFF)) & m
    for mult, shift in ((0x2C1B3C6D, 15), (0x297A2D39, 12), (0x7FEB352D, 15)):
        h ^= h >> np.uint64(shift)
        h = (h * np.uint64(mult)) & m
    h ^= h >> np.uint64(16)
    return h.astype(np.float64) / 2.0 ** 32


def _value_noise(size: tuple[int, int], cells: tuple[int, int], seed: int) -> np.ndarray:
    """(rows, cols) smooth value noise in [0, 1), tileable: ``cells`` = (along cols, along rows)
    lattice cells per repeat."""
    rows, cols = size
    u = (np.arange(cols) + 0.5) / cols * cells[0]
    v = (np.arange(rows) + 0.5) / rows * cells[1]
    iu, iv = np.floor(u).astype(np.int64), np.floor(v).astype(np.int64)
    fu, fv = u - iu, v - iv
    fu, fv = fu * fu * (3 - 2 * fu), fv * fv * (3 - 2 * fv)
    u0, u1 = iu % cells[0], (iu + 1) % cells[0]
    v0, v1 = iv % cells[1], (iv + 1) % cells[1]

    def at(a, b):
        return _hash01(a[None, :], b[:, None], seed)

    top = at(u0, v0) * (1 - fu) + at(u1, v0) * fu
    bottom = at(u0, v1) * (1 - fu) + at(u1, v1) * fu
    return top * (1 - fv)[:, None] + bottom * fv[:, None]


def _fbm(size, cells, seed, octaves=4) -> np.ndarray:
    """Sum of octaves of value noise, normalised to [0, 1]."""
    total, norm = np.zeros(size), 0.0
    for k in range(octaves):
        amp = 0.5 ** k
        total += amp * _value_noise(size, (cells[0] * 2 ** k, cells[1] * 2 ** k), seed + 17 * k)
        norm += amp
    return total / norm


def _srgb_png(rgb01: np.ndarray) -> bytes:
    return _png(np.round(np.clip(rgb01, 0.0, 1.0) * 255).astype(np.uint8))


def wood_png(light=(0.78, 0.60, 0.40), dark=(0.55, 0.36, 0.20), seed=11) -> bytes:
    """Plank of wood, 128 x 128: growth rings and fibres running along v (image columns)."""
    n = 128
    x = (np.arange(n) + 0.5) / n
    warp = _fbm((n, n), (2, 3), seed)
    rings = 0.5 + 0.5 * np.cos(2 * np.pi * (9 * x[None, :] + 2.2 * warp))
    fibre = _value_noise((n, n), (48, 3), seed + 5)
    t = np.clip(0.75 * rings ** 3 + 0.25 * fibre, 0, 1)[..., None]
    return _srgb_png(np.asarray(light) * (1 - t) + np.asarray(dark) * t)


def concrete_png() -> bytes:
    """2 m x 2 m slab of a sealed concrete floor, 128 x 128: mottled grey with sparse dark
    specks and a dark saw-cut joint along two edges (a joint grid when repeated)."""
    n = 128
    mottle = _fbm((n, n), (4, 4), 23)
    fine = _value_noise((n, n), (64, 64), 29)
    grey = 0.50 + 0.16 * (mottle - 0.5) + 0.05 * (fine - 0.5)
    speck = _hash01(np.arange(n)[None, :], np.arange(n)[:, None], 31) > 0.985
    grey = np.where(speck, grey - 0.18, grey)
    joint = np.zeros((n, n), bool)
    joint[:1, :] = True
    joint[:, :1] = True
    grey = np.where(joint, 0.25, grey)
    rgb = grey[..., None] * np.array([1.0, 0.98, 0.94])
    return _srgb_png(rgb)


def hazard_png() -> bytes:
    """Yellow and black diagonal safety stripes, 64 x 64 (4 stripe pairs per repeat)."""
    n = 64
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    band = ((i + j) // (n // 8)) % 2 == 0
    rgb = np.where(band[..., None], np.array([0.93, 0.74, 0.08]), np.array([0.08, 0.08, 0.08]))
    return _srgb_png(rgb)


def carpet_png() -> bytes:
    """1 m x 1 m of carpet tiles, 128 x 128: four 0.5 m tiles, each pile striped and turned a
    quarter from its neighbours (a checkerboard of stripe directions), blue-grey."""
    n = 128
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    turned = ((i // (n // 2)) + (j // (n // 2))) % 2 == 1
    stripes = np.where(turned, np.sin(2 * np.pi * i / 8), np.sin(2 * np.pi * j / 8))
    pile = _value_noise((n, n), (64, 64), 41)
    t = (0.5 + 0.25 * stripes + 0.25 * (pile - 0.5))[..., None]
    rgb = np.array([0.30, 0.34, 0.42]) * (1 - t) + np.array([0.46, 0.50, 0.58]) * t
    seam = (i % (n // 2) == 0) | (j % (n // 2) == 0)
    return _srgb_png(np.where(seam[..., None], rgb * 0.8, rgb))


#: Texture file name -> function writing its PNG bytes (``Material.texture`` keys).
TEXTURES: dict[str, Callable[[], bytes]] = {
    "wood_oak.png": wood_png,
    "wood_walnut.png": lambda: wood_png(light=(0.55, 0.37, 0.22), dark=(0.33, 0.19, 0.10),
                                        seed=13),
    "concrete_floor.png": concrete_png,
    "hazard.png": hazard_png,
    "carpet.png": carpet_png,
}


# ---- formatting -------------------------------------------------------------------------------
def _r(v: float) -> float:
    """Round for output (1e-9) and drop negative zeros."""
    return float(round(float(v), 9)) + 0.0


def _r_area(v: float) -> float:
    """Round an area for output to 12 significant digits (small objects' areas are ~1e-4 m^2)."""
    return float(f"{float(v):.12g}") + 0.0


def _round_list(v) -> list[float]:
    return [_r(x) for x in np.asarray(v, dtype=float).ravel()]


def _fmt(v: float) -> str:
    s = f"{_r(v):.9g}"
    return "0" if s in ("-0", "0") else s


def _fmt_vec(v) -> str:
    return ", ".join(_fmt(x) for x in np.asarray(v, dtype=float).ravel())


def _fmt_vec_f32(v) -> str:
    """Numbers with 9 significant digits (no rounding to 1e-9 first): a value that is exact in
    float32 (see :func:`_snap`) reads back exactly."""
    return ", ".join("0" if x == 0 else f"{x:.9g}" for x in np.asarray(v, dtype=float).ravel())


def _dump_json(obj, indent: int = 0) -> str:
    """JSON with lists of numbers (and lists of such lists) on one line."""
    pad, inner = " " * indent, " " * (indent + 2)

    def flat(o):
        return isinstance(o, list) and all(
            isinstance(x, (int, float)) or (isinstance(x, list) and all(
                isinstance(y, (int, float)) for y in x)) for x in o)

    if isinstance(obj, dict):
        if not obj:
            return "{}"
        items = [f"{inner}{json.dumps(k)}: {_dump_json(v, indent + 2)}" for k, v in obj.items()]
        return "{\n" + ",\n".join(items) + "\n" + pad + "}"
    if isinstance(obj, (list, tuple)):
        obj = list(obj)
        if flat(obj):
            return json.dumps(obj)
        items = [inner + _dump_json(v, indent + 2) for v in obj]
        return "[\n" + ",\n".join(items) + "\n" + pad + "]"
    return json.dumps(obj)


def _write_atomic(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_bytes(data)
    tmp.replace(path)


# ---- previews (need mitsonar) -----------------------------------------------------------------
def render_preview(scene_xml, png, view: str = "camera", width: int = 320, height: int = 240,
                   spp: int = 16, overview=None) -> None:
    """Render a PNG of ``scene_xml`` with Mitsuba's path tracer from the camera placeholder
    (``view='camera'``) or from ``overview`` = (origin, target) with a 75 deg lens."""
    import mitsonar  # noqa: F401  (configures Dr.Jit's LLVM)
    from mitsonar.scene.loading import mitsuba

    mi = mitsuba()
    scene = mi.load_file(str(scene_xml), optimize=False, width=width, height=height, spp=spp)
    sensor = scene.sensors()[0]
    if view == "overview":
        origin, target = overview
        sensor = mi.load_dict({
            "type": "perspective", "fov": 75.0, "fov_axis": "x",
            "to_world": mi.ScalarTransform4f().look_at(origin=origin, target=target, up=[0, 0, 1]),
            "sampler": {"type": "independent", "sample_count": spp},
            "film": {"type": "hdrfilm", "width": width, "height": height,
                     "rfilter": {"type": "gaussian"}}})
    image = mi.render(scene, sensor=sensor, spp=spp, seed=0)
    Path(png).parent.mkdir(parents=True, exist_ok=True)
    mi.util.write_bitmap(str(png), image)


def generate(out_dir=None, names=None) -> list[Path]:
    """Write the scenes ``names`` (default: all) into ``out_dir`` (default: beside this file)."""
    out_dir = Path(out_dir) if out_dir is not None else Path(__file__).resolve().parent
    names = list(SCENES) if names is None else list(names)
    unknown = [n for n in names if n not in SCENES]
    if unknown:
        raise ValueError(f"unknown scene(s) {unknown}; known: {', '.join(SCENES)}")
    return [SCENES[n]().write(out_dir) for n in names]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=None,
                   help="output directory (default: the directory of this script)")
    p.add_argument("--only", action="append", metavar="NAME",
                   help=f"scene to write (repeatable; default all: {', '.join(SCENES)})")
    p.add_argument("--preview", type=Path, metavar="DIR",
                   help="also render <DIR>/<scene>_camera.png and <scene>_overview.png "
                        "(320 x 240, 16 spp)")
    args = p.parse_args(argv)
    try:
        paths = generate(args.out, args.only)
    except ValueError as err:
        print(f"generate.py: error: {err}", file=sys.stderr)
        return 2
    for path in paths:
        gt = json.loads((path.parent / "ground_truth.json").read_text())
        print(f"{path}: {len(gt['shapes'])} shapes, floor {gt['floor_area_m2']:.2f} m^2, "
              f"{len(gt['windows'])} windows")
        if args.preview:
            spec = SCENES[path.parent.name]()
            for view in ("camera", "overview"):
                png = args.preview / f"{spec.name}_{view}.png"
                render_preview(path, png, view, overview=spec.overview)
                print(f"  preview {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
