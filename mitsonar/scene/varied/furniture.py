"""Furniture of the varied rooms (:mod:`mitsonar.scene.varied`): pieces drawn from the kit of
:mod:`mitsonar.scene.building.furniture` (cabinets, open shelves with boxes, sofas, tables with
chairs and cups, desk workstations, floor lamps), each placed against a wall or free inside the
loop where the :class:`~mitsonar.scene.varied.plan.FreeFloor` has room, none overlapping.

A piece's plan rectangle is its length (along the wall, or its long axis) by its depth; against
a wall it stands WALL_GAP in front of the face, its back (a sofa's backrest, a cabinet's rear,
a desk's far edge) towards the wall, and a table has chairs on its room side only.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from mitsonar.scene.building.furniture import (chair, floor_lamp, item_box, item_can,
                                               shelf_unit, sofa, table, workstation)
from mitsonar.scene.building.materials import PANEL_WHITE, Material
from mitsonar.scene.building.shapes import Rect2, Shape, block
from mitsonar.scene.building.spec import SceneSpec
from mitsonar.scene.varied.plan import (CLEARANCE, MARGIN, MIN_INSET, FreeFloor, Outline, grid,
                                        loop_corners)

#: Gap between a piece and the wall behind it [m] (on the grid).
WALL_GAP = 0.05
#: Depth of the strip a chair takes beside a table or desk [m] (seat 0.45 m, 0.1 m from it).
CHAIR_STRIP = 0.55
#: Upholstery colours (linear RGB).
FABRICS = ((0.55, 0.08, 0.07), (0.12, 0.12, 0.13), (0.04, 0.30, 0.32), (0.62, 0.42, 0.06),
           (0.08, 0.12, 0.35), (0.15, 0.35, 0.15), (0.65, 0.58, 0.45))
#: Cabinet paints (linear RGB): greys, white, red, blue, green, yellow.
CABINET_PAINTS = ((0.62, 0.63, 0.64), (0.82, 0.82, 0.80), (0.55, 0.05, 0.04), (0.10, 0.20, 0.45),
                  (0.20, 0.40, 0.25), (0.85, 0.70, 0.20))
#: Warm radiance of a floor lamp's globe [W/(m^2 sr)].
LAMP_RADIANCE = (18.0, 14.5, 10.0)
_OPPOSITE = {"north": "south", "south": "north", "east": "west", "west": "east"}


@dataclass(frozen=True)
class Piece:
    """A drawn piece before placement: its ``kind``, plan ``length`` x ``depth`` [m] against a
    wall and ``free_depth`` standing free, where it may stand ('wall', 'free'), the axes its
    length may run along, and what its builder needs (``params``)."""

    kind: str
    length: float
    depth: float
    free_depth: float
    places: tuple[str, ...]
    axes: tuple[str, ...] = ("x", "y")
    params: dict = field(default_factory=dict)


def _strip(rect: Rect2, side: str, d0: float, d1: float) -> Rect2:
    """The part of ``rect`` from ``d0`` to ``d1`` [m] in from its ``side``."""
    x0, x1, y0, y1 = rect
    return {"north": (x0, x1, y1 - d1, y1 - d0), "south": (x0, x1, y0 + d0, y0 + d1),
            "east": (x1 - d1, x1 - d0, y0, y1), "west": (x0 + d0, x0 + d1, y0, y1)}[side]


def _span(rect: Rect2, axis: str) -> tuple[float, float]:
    """The interval of ``rect`` along world ``axis``."""
    return rect[:2] if axis == "x" else rect[2:]


def _pair(rect: Rect2):
    """(x interval, y interval) of a plan rectangle."""
    return rect[:2], rect[2:]


def _cut(rect: Rect2, axis: str, a: float, b: float) -> Rect2:
    """``rect`` with its coordinate along ``axis`` limited to [a, b]."""
    return (a, b, *rect[2:]) if axis == "x" else (*rect[:2], a, b)


def _colour(rng, colours) -> tuple[float, float, float]:
    """One of ``colours``."""
    return tuple(float(c) for c in colours[rng.integers(len(colours))])


# ---- drawing pieces --------------------------------------------------------------------------
def _draw_cabinet(rng, height):
    """Cabinet 0.8-1.2 m x 0.45-0.6 m, 0.8-1.1 m or 1.6-2 m tall, painted steel or oak."""
    tall = rng.random() < 0.5
    wooden = rng.random() < 0.3
    return Piece("cabinet", grid(rng.uniform(0.8, 1.2)), grid(rng.uniform(0.45, 0.6)), 0.0,
                 ("wall",), params={"height": grid(rng.uniform(1.6, 2.0) if tall else
                                                   rng.uniform(0.8, 1.1)),
                                    "wooden": wooden, "paint": _colour(rng, CABINET_PAINTS)})


def _draw_shelves(rng, height):
    """Open shelves 0.8-2 m x 0.35-0.45 m, 1.2-2.2 m tall (0.3 m under the ceiling at most),
    3-5 boards, oak or blue steel."""
    tall = grid(rng.uniform(1.2, min(2.2, height - 0.3)))
    n = int(rng.integers(3, 6))
    return Piece("shelves", grid(rng.uniform(0.8, 2.0)), grid(rng.uniform(0.35, 0.45)), 0.0,
                 ("wall",), params={"height": tall, "levels": n, "metal": rng.random() < 0.4})


def _draw_sofa(rng, height):
    """Sofa 1.6-2.2 m x 0.8-0.95 m."""
    return Piece("sofa", grid(rng.uniform(1.6, 2.2)), grid(rng.uniform(0.8, 0.95)), 0.0,
                 ("wall",), params={"fabric": _colour(rng, FABRICS)})


def _draw_table(rng, height):
    """Table 1-1.8 m x 0.7-1 m with 1 or 2 chairs a side (one side against a wall), 0-2 cups;
    free twice as often as against a wall."""
    length, depth = grid(rng.uniform(1.0, 1.8)), grid(rng.uniform(0.7, 1.0))
    return Piece("table", length, grid(depth + CHAIR_STRIP), grid(depth + 2 * CHAIR_STRIP),
                 ("wall", "free", "free"),
                 params={"table_depth": depth, "height": grid(rng.uniform(0.72, 0.76)),
                         "chairs": 2 if length >= 1.3 else 1, "fabric": _colour(rng, FABRICS),
                         "cups": int(rng.integers(0, 3)), "walnut": rng.random() < 0.5})


def _draw_desk(rng, height):
    """Desk workstation 1.2-1.6 m x 0.7-0.8 m along x, its chair on the room side."""
    length, depth = grid(rng.uniform(1.2, 1.6)), grid(rng.uniform(0.7, 0.8))
    return Piece("desk", length, grid(depth + CHAIR_STRIP), grid(depth + CHAIR_STRIP),
                 ("wall", "free"), axes=("x",),
                 params={"desk_depth": depth, "fabric": _colour(rng, FABRICS),
                         "sitter": ("north", "south")[rng.integers(2)]})


def _draw_lamp(rng, height):
    """Floor lamp 1.5-1.8 m tall, globe of radius 0.15-0.2 m."""
    return Piece("lamp", 0.4, 0.4, 0.4, ("wall", "free"),
                 params={"height": grid(rng.uniform(1.5, 1.8)),
                         "globe": grid(rng.uniform(0.15, 0.2)),
                         "scale": round(float(rng.uniform(0.7, 1.2)), 3)})


#: Kind -> drawing function (rng, room height [m]) -> Piece.
DRAW: dict[str, Callable] = {"cabinet": _draw_cabinet, "shelves": _draw_shelves,
                             "sofa": _draw_sofa, "table": _draw_table, "desk": _draw_desk,
                             "lamp": _draw_lamp}
#: Relative frequency of the kinds drawn after the first cabinet.
_KIND_P = {"cabinet": 0.15, "shelves": 0.2, "sofa": 0.2, "table": 0.25, "desk": 0.2}


def draw_pieces(rng: np.random.Generator, area: float, height: float) -> list[Piece]:
    """A cabinet, then 1-8 more pieces (more in larger rooms: one per 8 m^2 of floor ``area``
    at most), tables and desks first (they need the most room)."""
    kinds = list(_KIND_P)
    p = np.array(list(_KIND_P.values()))
    n = int(rng.integers(1, 2 + min(7, int(area // 8))))
    drawn = [kinds[k] for k in rng.choice(len(kinds), size=n, p=p / p.sum())]
    order = ["table", "desk", "sofa", "shelves", "cabinet"]
    return [DRAW["cabinet"](rng, height)] + [DRAW[k](rng, height)
                                             for k in sorted(drawn, key=order.index)]


def _island(outline: Outline, insets: list[float]) -> tuple[float, float] | None:
    """Size (x, y) [m] of the floor inside the loop, CLEARANCE + MARGIN from its bounding box's
    sides, or None where the loop does not close."""
    corners = loop_corners(outline, insets)
    if corners is None:
        return None
    xs, ys = [c[0] for c in corners], [c[1] for c in corners]
    keep = 2 * (CLEARANCE + MARGIN)
    return max(xs) - min(xs) - keep, max(ys) - min(ys) - keep


def _stands_free(piece: Piece, island: tuple[float, float]) -> bool:
    """True where ``piece`` fits inside an island of this size, along one of its axes."""
    sizes = {"x": (piece.length, piece.free_depth), "y": (piece.free_depth, piece.length)}
    return any(sizes[a][0] <= island[0] and sizes[a][1] <= island[1] for a in piece.axes)


def plan_walls(rng: np.random.Generator, outline: Outline, insets: list[float],
               pieces: list[Piece], reserved: dict[int, float]) -> tuple[list[float], list]:
    """Insets of the loop [m] per wall and (piece, index of the wall it is to stand against or
    None to stand free) per piece kept. ``insets`` are the least insets; ``reserved`` maps a
    wall's index to a depth [m] kept for something else (a glass partition). Pieces are taken
    in order, each where drawn (or else the other way it may stand): against a drawn wall where
    that wall's band, deepened for it, still lets the loop close around every free piece kept
    and the wall has length left; free where the floor inside the loop is large enough; else
    left out."""
    if loop_corners(outline, insets) is None:
        insets = [MIN_INSET] * len(outline.walls)
    need = [CLEARANCE + MARGIN + WALL_GAP + reserved.get(k, -WALL_GAP)
            for k in range(len(insets))]
    used = [0.0] * len(insets)
    kept: list = []

    def deepened(k, depth):
        out = [grid(max(base, n)) for base, n in zip(insets, need)]
        out[k] = grid(max(out[k], CLEARANCE + MARGIN + WALL_GAP + depth))
        return out

    def feasible(candidate, extra=None):
        island = _island(outline, candidate)
        free = [p for p, k in kept if k is None] + ([extra] if extra is not None else [])
        return island is not None and all(_stands_free(p, island) for p in free)

    if not feasible(deepened(0, 0.0)):
        need = [0.0] * len(insets)
    for piece in pieces:
        drawn = piece.places[rng.integers(len(piece.places))]
        for where in [drawn] + [p for p in piece.places if p != drawn]:
            if where == "free" and feasible(deepened(0, 0.0), piece):
                kept.append((piece, None))
                break
            walls = [k for k, w in enumerate(outline.walls) if w.axis in piece.axes
                     and w.length - used[k] >= piece.length + 0.2]
            if where == "wall" and walls:
                k = walls[rng.integers(len(walls))]
                if feasible(deepened(k, piece.depth)):
                    need[k] = max(need[k], CLEARANCE + MARGIN + WALL_GAP + piece.depth)
                    used[k] += piece.length + 0.1
                    kept.append((piece, k))
                    break
    return deepened(0, 0.0), kept


def place(rng: np.random.Generator, floor: FreeFloor, piece: Piece, wall: int | None,
          tries: int = 40):
    """(plan rectangle, axis of its length, side of the wall behind it or None) of ``piece``
    against the wall of index ``wall`` (or any wall, where it does not fit there) or free inside
    the loop (``wall`` None), taken from ``floor``; None where ``tries`` positions of each do
    not fit."""
    walls = [w for w in floor.outline.walls
             if w.axis in piece.axes and w.length >= piece.length + 0.1]
    if wall is None:
        attempts = ["free"] * tries + (["wall"] * tries if "wall" in piece.places else [])
    else:
        attempts = ["assigned"] * tries + ["wall"] * tries
    for how in attempts:
        if how == "free":
            axis = piece.axes[rng.integers(len(piece.axes))]
            cx, cy = floor.inside_loop(rng)
            hl, hd = piece.length / 2, piece.free_depth / 2
            hx, hy = (hl, hd) if axis == "x" else (hd, hl)
            rect, back = (grid(cx - hx), grid(cx + hx), grid(cy - hy), grid(cy + hy)), None
        else:
            if not walls:
                return None
            w = floor.outline.walls[wall] if how == "assigned" else walls[rng.integers(len(walls))]
            s0 = grid(rng.uniform(w.span[0] + 0.05, w.span[1] - 0.05 - piece.length))
            rect = w.band((s0, grid(s0 + piece.length)), (WALL_GAP, WALL_GAP + piece.depth))
            axis, back = w.axis, w.facing
        if floor.fits(rect):
            return floor.take(rect), axis, back
    return None


# ---- building placed pieces ------------------------------------------------------------------
def build(spec: SceneSpec, rng: np.random.Generator, gid: str, piece: Piece, rect: Rect2,
          axis: str, back: str | None) -> list[Shape]:
    """Shapes of ``piece`` placed over ``rect`` (see :func:`place`); registers its materials.
    ``gid`` names the piece's object (a desk's objects are numbered by the digits ending it)."""
    return _BUILD[piece.kind](spec, rng, gid, piece, rect, axis, back)


#: Materials several pieces share, by short name.
SHARED = {"oak": Material("oak", "wood", texture="wood_oak.png"),
          "walnut": Material("walnut", "wood", texture="wood_walnut.png"),
          "steel": Material("steel_dark", "metal", rgb=(0.18, 0.18, 0.19)),
          "bright": Material("steel_bright", "metal", rgb=(0.55, 0.56, 0.58)),
          "ceramic": Material("ceramic_white", "concrete", rgb=(0.85, 0.85, 0.83)),
          "cardboard": Material("cardboard", "wood", rgb=(0.45, 0.29, 0.14))}


def shared(spec: SceneSpec, name: str) -> str:
    """Register the shared material ``name`` (a key of SHARED) and return its id."""
    return spec.material(SHARED[name])


def _build_cabinet(spec, rng, gid, piece, rect, axis, back):
    p = piece.params
    h, depth = p["height"], piece.depth
    if p["wooden"]:
        body = doors = shared(spec, "oak")
    else:
        body = spec.material(Material(f"{gid}_paint", "metal", rgb=p["paint"]))
        doors = spec.material(Material(f"{gid}_doors", "metal",
                                       rgb=tuple(round(0.85 * c, 3) for c in p["paint"])))
    shapes = [block(f"{gid}_body", *_pair(_strip(rect, back, 0.0, depth - 0.02)), (0.0, h),
                    body, "furniture", gid)]
    front = _strip(rect, back, depth - 0.02, depth)
    a, b = _span(rect, axis)
    mid = 0.5 * (a + b)
    for k, (s0, s1) in enumerate(((a + 0.01, mid - 0.003), (mid + 0.003, b - 0.01))):
        shapes.append(block(f"{gid}_door_{k + 1}", *_pair(_cut(front, axis, s0, s1)),
                            (0.06, h - 0.03), doors, "furniture", gid))
    return shapes


def _build_shelves(spec, rng, gid, piece, rect, axis, back):
    p = piece.params
    h = p["height"]
    levels = [round(0.05 + k * (h - 0.05) / (p["levels"] - 1), 3) for k in range(p["levels"])]
    if p["metal"]:
        side = spec.material(Material("shelf_blue", "metal", rgb=(0.05, 0.14, 0.42)))
        board = shared(spec, "bright")
    else:
        side = board = shared(spec, "oak")
    shapes = shelf_unit(gid, *_pair(rect), h, levels, side, board)
    a, b = _span(rect, axis)
    across = _span(rect, "y" if axis == "x" else "x")
    k = 0
    for lower, upper in zip(levels[:-1], levels[1:]):
        s = a + 0.06
        while rng.random() < 0.6:
            size = (grid(rng.uniform(0.15, 0.35)), min(0.3, piece.depth - 0.06),
                    min(grid(rng.uniform(0.1, 0.3)), upper - lower - 0.08))
            if s + size[0] > b - 0.06:
                break
            k += 1
            c_along, c_across = s + size[0] / 2, 0.5 * (across[0] + across[1])
            centre = (c_along, c_across) if axis == "x" else (c_across, c_along)
            dims = size if axis == "x" else (size[1], size[0], size[2])
            shapes.append(item_box(f"{gid}_box_{k}", centre, lower, dims,
                                   shared(spec, "cardboard")))
            s += size[0] + grid(rng.uniform(0.03, 0.2))
    return shapes


def _build_sofa(spec, rng, gid, piece, rect, axis, back):
    fabric = spec.material(Material(f"{gid}_fabric", "fabric", rgb=piece.params["fabric"]))
    return sofa(gid, *_pair(rect), back, fabric)


def _build_table(spec, rng, gid, piece, rect, axis, back):
    p = piece.params
    steel = shared(spec, "steel")
    depth, h = p["table_depth"], p["height"]
    across_side = ("south" if axis == "x" else "west")
    if back is None:  # free: chairs on both long sides
        top = _strip(rect, across_side, CHAIR_STRIP, CHAIR_STRIP + depth)
        sitters = [across_side, _OPPOSITE[across_side]]
    else:
        top = _strip(rect, back, 0.0, depth)
        sitters = [_OPPOSITE[back]]
    shapes = table(gid, *_pair(top), h, shared(spec, "walnut" if p["walnut"] else "oak"), steel)
    seat = spec.material(Material(f"{gid}_chairs", "fabric", rgb=p["fabric"]))
    a, b = _span(top, axis)
    n = p["chairs"]
    k = 0
    for side in sitters:
        strip = _strip(top, side, -CHAIR_STRIP, 0.0)
        c = 0.5 * (sum(_span(strip, "y" if axis == "x" else "x")))
        for j in range(n):
            s = a + (j + 0.5) * (b - a) / n
            k += 1
            shapes += chair(f"{gid}_chair_{k}", (s, c) if axis == "x" else (c, s),
                            _OPPOSITE[side], seat, steel)
    across = _span(top, "y" if axis == "x" else "x")
    for j in range(p["cups"]):
        s = a + (j + 1) * (b - a) / (p["cups"] + 1)
        c = 0.5 * (across[0] + across[1]) + (0.1 if j % 2 else -0.1)
        shapes += item_can(f"{gid}_cup_{j + 1}", (s, c) if axis == "x" else (c, s), h, 0.04,
                           0.095, shared(spec, "ceramic"))
    return shapes


def _build_desk(spec, rng, gid, piece, rect, axis, back):
    p = piece.params
    sitter = _OPPOSITE[back] if back is not None else p["sitter"]
    desk = _strip(rect, _OPPOSITE[sitter], 0.0, p["desk_depth"])
    seat = spec.material(Material(f"{gid}_chair", "fabric", rgb=p["fabric"]))
    screen = spec.material(Material("monitor_black", "metal", rgb=(0.025, 0.025, 0.03)))
    plastic = spec.material(Material("plastic_grey", "wood", rgb=(0.30, 0.30, 0.32)))
    # workstation() names its objects desk_<k>, chair_<k>, ... from the number ending gid
    return workstation(int(gid.rsplit("_", 1)[1]), *_pair(desk), sitter, shared(spec, "walnut"),
                       shared(spec, "steel"), seat, screen, plastic, shared(spec, "ceramic"))


def _build_lamp(spec, rng, gid, piece, rect, axis, back):
    p = piece.params
    globe = spec.material(Material("lamp_globe", "plaster", rgb=PANEL_WHITE))
    centre = (0.5 * (rect[0] + rect[1]), 0.5 * (rect[2] + rect[3]))
    radiance = tuple(round(v * p["scale"], 3) for v in LAMP_RADIANCE)
    return floor_lamp(gid, centre, p["height"], shared(spec, "steel"), globe, radiance,
                      globe=p["globe"])


_BUILD = {"cabinet": _build_cabinet, "shelves": _build_shelves, "sofa": _build_sofa,
          "table": _build_table, "desk": _build_desk, "lamp": _build_lamp}
