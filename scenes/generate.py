"""Write the shipped Mitsuba scenes: ``python scenes/generate.py [--out DIR] [--only NAME]``.

Each scene goes to ``<out>/<name>/`` as

* ``scene.xml``: Mitsuba 3 scene. Every surface is its own shape with a unique id (wall segments
  around an opening, each face of a thick wall, each ceiling tile between light panels), built
  from Mitsuba's ``rectangle`` shapes (``box()`` makes ``cube``s for furniture) with an explicit
  ``to_world`` matrix.
  Materials are ``<bsdf type="acoustic">`` with a ``preset`` and a nested optical BSDF; windows
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
* ``ground_truth.json``: per shape its id, material id, acoustic preset, role, surface area
  [m^2] and geometry (``to_world``, and corners and normal of rectangles); the area per
  material; rooms; windows; the camera placeholder; the default robot trajectory.
* ``sky.png`` (scenes with windows): the environment map.

World frame: metres, z up, floor at z = 0. The world origin is a sensible robot position (the
one the Makefile's demo scans from), with the robot facing +x. Robot poses are (x [m], y [m],
yaw [deg]) of the chassis centre in the world frame; the sensor head is 0.1 m ahead and 0.5 m
above it (``mitsonar.frames``), the camera 0.075 m above the sensor head.

Adding a scene: write a function returning a :class:`SceneSpec` (see :func:`room_glass` and
:func:`structure`) and register it in ``SCENES``. Everything is deterministic: no randomness,
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
        preset: acoustic preset name (``mitsonar.materials.PRESETS``).
        optical: nested Mitsuba BSDF type: 'diffuse', 'thindielectric' or 'dielectric'.
        rgb: diffuse reflectance (linear RGB) for 'diffuse'.
        ior: interior index of refraction for the dielectrics.
    """

    id: str
    preset: str
    optical: str = "diffuse"
    rgb: tuple[float, float, float] = (0.7, 0.7, 0.7)
    ior: float = 1.5

    def __post_init__(self):
        if self.optical not in ("diffuse", "thindielectric", "dielectric"):
            raise ValueError(f"material '{self.id}': unsupported optical BSDF {self.optical!r}")

    def xml(self) -> list[str]:
        lines = [f'<bsdf type="acoustic" id="{self.id}">',
                 f'    <string name="preset" value="{self.preset}"/>']
        if self.optical == "diffuse":
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
@dataclass(frozen=True)
class Shape:
    """One Mitsuba shape: a ``rectangle`` ([-1, 1]^2 in local xy, normal +z) or a ``cube``
    ([-1, 1]^3), placed by the affine ``to_world`` (4, 4) matrix.

    Attributes:
        id: unique shape id.
        kind: 'rectangle' or 'cube'.
        to_world: (4, 4) local-to-world matrix [m].
        material: material id.
        role: what the shape is: 'wall', 'interior_wall', 'window', 'floor', 'ceiling',
            'light', 'furniture'.
        group: the object the shape is a piece of (e.g. the wall 'wall_east').
        radiance: area-light radiance (linear RGB) [W/(m^2 sr)], or None.
    """

    id: str
    kind: str
    to_world: np.ndarray
    material: str
    role: str
    group: str
    radiance: tuple[float, float, float] | None = None

    @property
    def area(self) -> float:
        """Surface area [m^2] (exact for the affine ``to_world``)."""
        a, b, c = (self.to_world[:3, k] for k in range(3))
        if self.kind == "rectangle":
            return 4.0 * float(np.linalg.norm(np.cross(a, b)))
        return 8.0 * float(np.linalg.norm(np.cross(a, b)) + np.linalg.norm(np.cross(b, c))
                           + np.linalg.norm(np.cross(c, a)))

    def corners(self) -> np.ndarray:
        """(4, 3) corners of a rectangle, counter-clockwise about its normal."""
        m = self.to_world
        local = np.array([[-1, -1, 0, 1], [1, -1, 0, 1], [1, 1, 0, 1], [-1, 1, 0, 1]], float)
        return (local @ m.T)[:, :3]

    def bbox(self) -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned bounds (min, max) [m]."""
        local = np.array([[x, y, z, 1] for x in (-1, 1) for y in (-1, 1)
                          for z in ((0,) if self.kind == "rectangle" else (-1, 1))], float)
        pts = (local @ self.to_world.T)[:, :3]
        return pts.min(axis=0), pts.max(axis=0)

    def normal(self) -> np.ndarray:
        """Unit normal of a rectangle (the side its one-sided optical BSDF shows)."""
        n = np.cross(self.to_world[:3, 0], self.to_world[:3, 1])
        return n / np.linalg.norm(n)

    def xml(self) -> list[str]:
        lo, hi = self.bbox()
        note = ", ".join(f"{axis} {_fmt(a)}" if abs(b - a) < 1e-9 else
                         f"{axis} {_fmt(a)}..{_fmt(b)}" for axis, a, b in zip("xyz", lo, hi))
        if self.kind == "rectangle":
            note += f", normal ({_fmt_vec(self.normal())})"
        rows = "  ".join(_fmt_vec(row) for row in self.to_world)
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
    c, s = np.cos(np.radians(yaw_deg)), np.sin(np.radians(yaw_deg))
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    m = np.eye(4)
    m[:3, :3] = rot @ np.diag(np.asarray(size, dtype=float) / 2)
    m[:3, 3] = centre
    return Shape(shape_id, "cube", m, material, role, group)


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

    def enclosure(self, outer: Rect2, wall_mat: str, floor_mat: str, ceiling_mat: str,
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
        thickness), with the glass pane at their outer end.
        """
        x0, x1, y0, y1 = outer
        h = self.height
        openings = openings or {}
        fps = [w.footprint() for w in interior]
        sides = {"east": ("y", x1, -1, (y0, y1), 0, -1), "west": ("y", x0, +1, (y0, y1), 0, +1),
                 "north": ("x", y1, -1, (x0, x1), 1, -1), "south": ("x", y0, +1, (x0, x1), 1, +1)}
        for side, (axis, across, facing, span, plane_axis, touch_side) in sides.items():
            ops = openings.get(side, [])
            holes = [(o.s0, o.s1, o.z0, o.z1) for o in ops]
            holes += [(a, b, 0.0, h) for a, b in
                      _touching(plane_axis, across, touch_side, span, fps)]
            self.add(*vertical_face(f"wall_{side}", axis, across, span, (0.0, h), facing,
                                    wall_mat, "wall", holes))
            self._openings(f"wall_{side}", axis, across, facing, ops, window_reveal, wall_mat)
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
            entry["shapes"] += 1
            entry["area_m2"] += s.area
        for entry in per_material.values():
            entry["area_m2"] = _r(entry["area_m2"])
        shapes = []
        for s in self.shapes:
            d = {"id": s.id, "material": s.material, "preset": self.materials[s.material].preset,
                 "role": s.role, "group": s.group, "type": s.kind, "area_m2": _r(s.area)}
            if s.kind == "rectangle":
                d["normal"] = _round_list(s.normal())
                d["corners"] = [_round_list(c) for c in s.corners()]
            d["to_world"] = [_round_list(row) for row in s.to_world]
            shapes.append(d)
        xs = [v for r in self.rooms for v in r["x"]]
        ys = [v for r in self.rooms for v in r["y"]]
        return {
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
            "total_area_m2": _r(sum(s.area for s in self.shapes)),
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

    def write(self, out_dir: Path) -> Path:
        """Write scene.xml, ground_truth.json (and sky.png) into ``out_dir/<name>``."""
        d = Path(out_dir) / self.name
        d.mkdir(parents=True, exist_ok=True)
        _write_atomic(d / "scene.xml", self.xml().encode())
        _write_atomic(d / "ground_truth.json", (_dump_json(self.ground_truth()) + "\n").encode())
        if self.sky:
            _write_atomic(d / SKY_FILE, sky_png())
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
    # Start facing wall_a, go through its doorway into the north-east room, turn south through
    # wall_b's doorway into the south-east room, end facing wall_a from the east.
    spec.trajectory = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (1.0, 0.0, 90.0), (1.0, 1.2, 90.0),
                       (1.0, 1.2, 0.0), (5.7, 1.2, 0.0), (5.7, 1.2, -90.0), (5.7, -2.5, -90.0),
                       (5.7, -2.5, -180.0), (4.5, -2.5, -180.0)]
    return spec


#: Scene name -> function building it. Planned: 'workshop' (tables, shelves, tools) and
#: 'office' (desks, chairs, sofas, cups, small windows), built with :func:`box` and the helpers.
SCENES: dict[str, Callable[[], SceneSpec]] = {"room_glass": room_glass, "structure": structure}


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


# ---- formatting -------------------------------------------------------------------------------
def _r(v: float) -> float:
    """Round for output (1e-9) and drop negative zeros."""
    return float(round(float(v), 9)) + 0.0


def _round_list(v) -> list[float]:
    return [_r(x) for x in np.asarray(v, dtype=float).ravel()]


def _fmt(v: float) -> str:
    s = f"{_r(v):.9g}"
    return "0" if s in ("-0", "0") else s


def _fmt_vec(v) -> str:
    return ", ".join(_fmt(x) for x in np.asarray(v, dtype=float).ravel())


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
    from mitsonar.scene import mitsuba

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
