"""Furniture kit and small objects: tables, chairs, sofas, shelving, a desk workstation, a
free-standing glass partition, a floor lamp, and boxes, cans and rods standing or lying on a
surface. Free-standing objects are built from closed
pieces (cubes, capped cylinders, spheres), so each piece's area is that of a solid; where pieces
touch (a leg under a table top, a can on a shelf) the touching faces are hidden but still
counted in the ground-truth areas. Every piece's group is its object's id ``gid``."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from mitsonar.scene.building.shapes import Interval, Shape, block, closed_cylinder, sphere


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


def workstation(k: int, x: Interval, y: Interval, sitter: str, top_mat: str, leg_mat: str,
                seat_mat: str, screen_mat: str, keyboard_mat: str, cup_mat: str,
                height: float = 0.75) -> list[Shape]:
    """Desk ``desk_<k>`` over the plan rectangle x, y with its upper face at ``height`` [m];
    ``chair_<k>`` on the ``sitter`` side ('north' or 'south'; the sitter faces the desk),
    ``monitor_<k>`` at the far edge, ``keyboard_<k>`` near the sitter and ``cup_<k>`` beside
    the keyboard (0.45 m along +x)."""
    shapes = table(f"desk_{k}", x, y, height, top_mat, leg_mat, top=0.03, leg=0.04)
    cx = 0.5 * (x[0] + x[1])
    sy = 1.0 if sitter == "north" else -1.0
    near = y[1] if sy > 0 else y[0]
    far = y[0] if sy > 0 else y[1]
    shapes += chair(f"chair_{k}", (cx, near + sy * 0.325), "south" if sy > 0 else "north",
                    seat_mat, leg_mat)
    my = far + sy * 0.15
    shapes += [item_box(f"monitor_{k}", (cx, my), height + 0.17, (0.54, 0.025, 0.32),
                        screen_mat, role="furniture", part="screen"),
               item_box(f"monitor_{k}", (cx, my - sy * 0.03), height, (0.04, 0.04, 0.2),
                        screen_mat, role="furniture", part="stand"),
               item_box(f"monitor_{k}", (cx, my - sy * 0.03), height, (0.2, 0.15, 0.012),
                        screen_mat, role="furniture", part="base"),
               item_box(f"keyboard_{k}", (cx, near - sy * 0.2), height, (0.44, 0.14, 0.02),
                        keyboard_mat)]
    return shapes + item_can(f"cup_{k}", (cx + 0.45, near - sy * 0.22), height, 0.04, 0.095,
                             cup_mat)


def glass_partition(gid: str, x: Interval, y: Interval, height: float, glass_mat: str,
                    foot_mat: str, pane: float = 0.012, foot: float = 0.05) -> list[Shape]:
    """Free-standing glass screen over the plan rectangle x, y: a pane ``pane`` [m] thick (a
    closed thin box, ``glass_mat``: the glass preset with a thin dielectric, like the windows)
    along the rectangle's longer axis, centred across it, from ``foot`` to ``height`` [m], on two
    feet ``foot`` [m] high and wide, as deep as the rectangle, under its ends."""
    along_x = (x[1] - x[0]) >= (y[1] - y[0])
    lo, hi = x if along_x else y
    c = 0.5 * (y[0] + y[1]) if along_x else 0.5 * (x[0] + x[1])
    across = (c - pane / 2, c + pane / 2)
    shapes = [block(f"{gid}_pane", *((x, across) if along_x else (across, y)), (foot, height),
                    glass_mat, "furniture", gid)]
    for k, ends in enumerate(((lo, lo + foot), (hi - foot, hi))):
        shapes.append(block(f"{gid}_foot_{k + 1}", *((ends, y) if along_x else (x, ends)),
                            (0.0, foot), foot_mat, "furniture", gid))
    return shapes


def floor_lamp(gid: str, centre_xy, height: float, body_mat: str, globe_mat: str,
               radiance, globe: float = 0.15) -> list[Shape]:
    """Floor lamp at plan point ``centre_xy``: a round base (radius 0.16 m, 0.03 m high), a pole
    and a glowing globe of radius ``globe`` [m] whose top is at ``height`` [m]; the globe is an
    area light of ``radiance`` [W/(m^2 sr)] (linear RGB)."""
    cx, cy = centre_xy
    top_of_pole = height - 2 * globe
    return [*closed_cylinder(f"{gid}_base", (cx, cy, 0.0), 0.16, 0.03, body_mat, "furniture",
                             gid),
            *closed_cylinder(f"{gid}_pole", (cx, cy, 0.03), 0.015, top_of_pole - 0.03, body_mat,
                             "furniture", gid),
            replace(sphere(f"{gid}_globe", (cx, cy, height - globe), globe, globe_mat,
                           "furniture", gid), radiance=tuple(radiance))]
