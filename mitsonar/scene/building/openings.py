"""Openings in walls: doorways, and windows filled by a glass pane. Each opening is lined by
reveals (jambs, sill, soffit) through the wall's thickness; in an outer wall the pane sits at
the reveal's outer end and the window is listed in the ground truth."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mitsonar.scene.building.formatting import rounded, rounded_list
from mitsonar.scene.building.shapes import TOL, Interval, Shape, rectangle
from mitsonar.scene.building.spec import SceneSpec
from mitsonar.scene.building.surfaces import horizontal_surface, plan_axes, vertical_face


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


def reveals(prefix: str, axis: str, o: Opening, c_range: Interval, height: float, material: str,
            role: str, group: str) -> tuple[list[Shape], list[Shape], list[Shape]]:
    """Faces lining the opening ``o`` through a wall running along ``axis`` whose
    across-coordinate spans ``c_range`` [m], in a room ``height`` [m] high: (jambs, sill,
    soffit), named ``<prefix>_jamb_1``, ``<prefix>_jamb_2``, ``<prefix>_sill`` and
    ``<prefix>_soffit``; no sill on the floor (doorways), no soffit at the ceiling."""
    other_axis = "x" if axis == "y" else "y"
    jambs = [piece for s, facing, tag in ((o.s0, +1, "jamb_1"), (o.s1, -1, "jamb_2"))
             for piece in vertical_face(f"{prefix}_{tag}", other_axis, s, c_range, (o.z0, o.z1),
                                        facing, material, role, group=group)]
    plan = (o.s0, o.s1, *c_range) if axis == "x" else (*c_range, o.s0, o.s1)
    sill = horizontal_surface(f"{prefix}_sill", plan, o.z0, +1, material, role,
                              group=group) if o.z0 > TOL else []
    soffit = horizontal_surface(f"{prefix}_soffit", plan, o.z1, -1, material, role,
                                group=group) if o.z1 < height - TOL else []
    return jambs, sill, soffit


def outer_wall_openings(spec: SceneSpec, wall: str, axis: str, across: float, facing: int,
                        ops: list[Opening], reveal: float, material: str) -> None:
    """Add to ``spec`` the reveals (``reveal`` [m] deep, outwards from the inner face) and glass
    panes (at the reveal's outer end) of the openings ``ops`` of the outer wall ``wall``, whose
    inner face is at ``across`` facing +across (``facing=+1``) or -across (-1), and list the
    windows."""
    t, w = plan_axes(axis)
    outside = across - facing * reveal
    c_range = (min(across, outside), max(across, outside))
    for o in ops:
        if reveal > 0:
            jambs, sill, soffit = reveals(o.id, axis, o, c_range, spec.height, material, "wall",
                                          wall)
            spec.add(*jambs, *sill, *soffit)
        if o.pane is None:
            continue
        centre = t * 0.5 * (o.s0 + o.s1) + w * outside + np.array([0, 0, 0.5 * (o.z0 + o.z1)])
        spec.add(rectangle(o.id, centre, t * 0.5 * (o.s1 - o.s0),
                           np.array([0, 0, 0.5 * (o.z1 - o.z0)]), o.pane, "window", o.id))
        spec.windows.append({"id": o.id, "wall": wall, "centre": rounded_list(centre),
                             "width_m": rounded(o.s1 - o.s0), "height_m": rounded(o.z1 - o.z0),
                             "sill_m": rounded(o.z0), "pane_behind_wall_face_m": rounded(reveal)})
