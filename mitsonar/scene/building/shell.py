"""Room shell: the floor, the ceiling (with holes for light panels) and the four outer walls
(inner faces only) of a plan rectangle, with openings in the outer walls, and thick interior
walls standing on the floor; every face, exposed end and reveal is a separate rectangle, cut
where another wall touches it."""

from __future__ import annotations

from dataclasses import dataclass

from mitsonar.scene.building.openings import Opening, outer_wall_openings, reveals
from mitsonar.scene.building.shapes import TOL, Interval, Rect2
from mitsonar.scene.building.spec import SceneSpec
from mitsonar.scene.building.surfaces import horizontal_surface, rect_minus, vertical_face


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
                 if o.z0 <= TOL]
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
            if b > a + TOL:
                cut.append((a, b))
    return cut


def enclosure(spec: SceneSpec, outer: Rect2, wall_mat: str | dict[str, str], floor_mat: str,
              ceiling_mat: str, openings: dict[str, list[Opening]] | None = None,
              interior: list[ThickWall] = (), interior_mat: str = "",
              lights: list[tuple[Rect2, tuple]] = (), window_reveal: float = 0.0) -> None:
    """Add to ``spec`` the floor, ceiling (with holes for light panels) and the four outer walls
    (inner faces only) of the plan rectangle ``outer`` = (x0, x1, y0, y1) [m], plus thick
    interior walls.

    ``openings`` maps 'east' (x = x1), 'west', 'north' (y = y1), 'south' to the openings of
    that wall (s is the world y on the east and west walls, x on the north and south ones).
    ``interior`` walls use ``interior_mat``. ``lights`` are (plan rectangle, radiance) of
    ceiling panels; their holes are left in the ceiling
    (:func:`mitsonar.scene.building.lights.ceiling_lights` fills them). Openings of the outer
    walls get reveals ``window_reveal`` [m] deep (the outer walls' thickness), with the glass
    pane at their outer end. ``wall_mat`` is one material for all four walls or a material per
    side ('east', 'west', 'north', 'south').
    """
    x0, x1, y0, y1 = outer
    h = spec.height
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
        spec.add(*vertical_face(f"wall_{side}", axis, across, span, (0.0, h), facing,
                                mat, "wall", holes))
        outer_wall_openings(spec, f"wall_{side}", axis, across, facing, ops, window_reveal, mat)
    floor_holes = [fp for w in interior for fp in w.floor_footprints()]
    spec.add(*horizontal_surface("floor", outer, 0.0, +1, floor_mat, "floor", floor_holes))
    panels = [rect for rect, _ in lights]
    spec.add(*horizontal_surface("ceiling", outer, h, -1, ceiling_mat, "ceiling",
                                 fps + panels))
    for wall in interior:
        _thick_wall(spec, wall, interior, outer, interior_mat)


def _thick_wall(spec: SceneSpec, wall: ThickWall, interior: list[ThickWall], outer: Rect2,
                mat: str) -> None:
    """Add to ``spec`` the faces, exposed ends and reveals of the interior ``wall``."""
    h = spec.height
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
        spec.add(*vertical_face(f"{wall.id}_{tag}", wall.axis, across, (s0, s1), (0.0, h),
                                facing, mat, "interior_wall", holes + cut, wall.id))
    # exposed ends: faces across the thickness at s0 (facing -along) and s1 (+along)
    for s, facing in ((s0, -1), (s1, +1)):
        tag = side[(wall.axis, facing)] + "_end"
        cut = [(a, b, 0.0, h) for a, b in _touching(1 - pa, s, facing, (c0, c1), others)]
        spec.add(*vertical_face(f"{wall.id}_{tag}", other_axis, s, (c0, c1), (0.0, h),
                                facing, mat, "interior_wall", cut, wall.id))
    # reveals of the openings: jambs, soffit (top), sill (bottom, windows)
    for o in wall.openings:
        jambs, sill, soffit = reveals(f"{wall.id}_{o.id}", wall.axis, o, (c0, c1), h, mat,
                                      "interior_wall", wall.id)
        spec.add(*jambs, *soffit, *sill)
