"""Varied rooms: :func:`varied_room` draws a furnished room from a seed, so methods can be tried
on rooms nobody tuned them for, beside the four shipped scenes.

Each room (named ``varied_<seed>``) is drawn by a NumPy generator seeded with the seed, so the
same seed writes byte-identical files:

* plan (:mod:`~mitsonar.scene.varied.plan`): 4-9 m x 3.5-7 m, 2.4-3.2 m high, sometimes an L
  (a corner cut off by a thick block); the robot's default trajectory is a loop once round the
  room, 0.9 m or more from each wall (more where furniture stands along it) and 0.85 m or more
  from every object's footprint, driving towards the wall ahead and turning on the spot at the
  corners. It starts at the world origin facing +x, with a clear view of the wall ahead.
* glass (:mod:`~mitsonar.scene.varied.glass`): windows in the outer walls and/or a free-standing
  glass partition (every room has at least one), a sun through a window in most rooms with
  windows (the ``ceiling`` look's; the ``key`` look has its key light instead), and the sky
  seen through them.
* looks (:mod:`~mitsonar.scene.varied.looks`): wall colours (pale near-uniform ones included)
  and textures, floor and ceiling finishes, ceiling lights of one kind.
* furniture (:mod:`~mitsonar.scene.varied.furniture`): a cabinet and more pieces (shelves,
  sofas, tables with chairs, desks, a floor lamp), none overlapping, clear of the loop.

Glass (windows and the partition) has the acoustic ``glass`` preset and a ``thindielectric``
optical BSDF; the partition is an object (role 'furniture', id ``partition``) with a plan
footprint in ground_truth.json, the windows are listed under ``windows``. Write rooms with
``python scenes/generate.py --varied N --out DIR`` or :func:`write_varied_rooms`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from mitsonar.scene.building.furniture import glass_partition
from mitsonar.scene.building.lights import LIGHTINGS, ceiling_lights
from mitsonar.scene.building.materials import PANEL_WHITE, Material
from mitsonar.scene.building.shell import ThickWall, enclosure
from mitsonar.scene.building.spec import SceneSpec
from mitsonar.scene.varied.furniture import DRAW, build, draw_pieces, place, plan_walls, shared
from mitsonar.scene.varied.glass import (PARTITION_BAND, Window, draw_partition, draw_sun,
                                         draw_windows)
from mitsonar.scene.varied.looks import draw_lights, draw_surfaces
from mitsonar.scene.varied.plan import (CLEARANCE, FreeFloor, Outline, draw_insets, draw_outline,
                                        exact, gap, grid, loop_corners, loop_legs, loop_trajectory,
                                        moved)

#: Draws of a whole room before giving up (a draw fails where no glass or no furniture fits).
ATTEMPTS = 50
#: Depth of the outer walls: windows sit in reveals this deep [m].
WINDOW_REVEAL = 0.1
#: Piece kind -> (name, plural) in the description.
NAMES = {"cabinet": ("cabinet", "cabinets"), "shelves": ("shelf unit", "shelf units"),
         "sofa": ("sofa", "sofas"), "table": ("table with chairs", "tables with chairs"),
         "desk": ("desk", "desks"), "lamp": ("floor lamp", "floor lamps")}


def varied_room(seed: int, lighting: str = LIGHTINGS[0]) -> SceneSpec:
    """The room ``varied_<seed>``: a deterministic function of ``seed`` (see the module
    docstring for what is drawn), lit in the look ``lighting``
    (:data:`~mitsonar.scene.building.lights.LIGHTINGS`; the same room either way)."""
    rng = np.random.default_rng(seed)
    for _ in range(ATTEMPTS):
        plan = _plan(rng)
        if plan is not None:
            return replace(_spec(rng, int(seed), plan), lighting=lighting)
    raise RuntimeError(f"varied_room({seed}): no room in {ATTEMPTS} draws")


def write_varied_rooms(out_dir, seeds, lighting: str = LIGHTINGS[0]) -> list[Path]:
    """Write ``varied_room(seed, lighting)`` for each of ``seeds`` into
    ``out_dir/varied_<seed>/``; returns the scene.xml paths."""
    return [varied_room(s, lighting).write(Path(out_dir),
                                           f"mitsonar.scene.varied.varied_room({s}"
                                           + ("" if lighting == LIGHTINGS[0] else
                                              f", lighting={lighting!r}") + ")")
            for s in seeds]


@dataclass(frozen=True)
class _Plan:
    """A room planned with its walls on the grid (south-west corner at the origin): outline,
    height [m], loop corners, the loop's start (the world origin once written), windows, the
    partition (see :func:`~mitsonar.scene.varied.glass.draw_partition`) and the placed pieces
    (see :func:`~mitsonar.scene.varied.furniture.place`)."""

    outline: Outline
    height: float
    corners: list
    start: tuple[float, float]
    windows: list[Window]
    partition: tuple | None
    placed: list


def _plan(rng: np.random.Generator) -> _Plan | None:
    """One draw of the plan, or None where it has no glass or no furniture."""
    outline = draw_outline(rng)
    height = grid(rng.uniform(2.4, 3.2))
    area = sum((r[1] - r[0]) * (r[3] - r[2]) for _, r in outline.rooms)
    pieces = draw_pieces(rng, area, height)
    if rng.random() < 0.5:
        pieces.append(DRAW["lamp"](rng, height))
    n_windows = int(rng.choice(4, p=(0.25, 0.35, 0.25, 0.15)))
    want_partition = rng.random() < 0.6
    if n_windows == 0 and not want_partition:
        want_partition = rng.random() < 0.6
        n_windows = 0 if want_partition else 1
    # half the partitions stand in front of a wall: keep a band for it there
    partition_wall = int(rng.integers(len(outline.walls))) if want_partition and \
        rng.random() < 0.5 else None
    reserved = {} if partition_wall is None else {partition_wall: PARTITION_BAND}
    insets, assigned = plan_walls(rng, outline, draw_insets(rng, outline), pieces, reserved)
    corners = loop_corners(outline, insets)
    (ax, ay), (bx, _) = corners[0], corners[1]
    start = (exact(ax + grid(rng.uniform(0.2, 0.6) * (bx - ax))), ay)
    floor = FreeFloor(outline, loop_legs(corners))
    # the view from the start, straight ahead to the wall
    floor.keep_clear.append((start[0], outline.outer[1], start[1] - 0.4, start[1] + 0.4))
    windows = draw_windows(rng, floor, height, n_windows, insets)
    partition = draw_partition(rng, floor, corners, height, insets, partition_wall) \
        if want_partition else None
    if not windows and partition is None:
        return None
    placed = [(piece, at) for piece, wall in assigned
              if (at := place(rng, floor, piece, wall)) is not None]
    if not any(piece.kind != "lamp" for piece, _ in placed):
        return None
    return _Plan(outline, height, corners, start, windows, partition, placed)


def _spec(rng: np.random.Generator, seed: int, plan: _Plan) -> SceneSpec:
    """The scene of ``plan``, moved so that the loop's start is the world origin, with its
    looks drawn."""
    dx, dy = -plan.start[0], -plan.start[1]
    outline, height, windows = plan.outline.shifted(dx, dy), plan.height, plan.windows
    x0, x1, y0, y1 = outline.outer
    sun = draw_sun(rng, windows) if windows and rng.random() < 0.7 else None
    spec = SceneSpec(f"varied_{seed}", "", height, sky=bool(windows), sun=sun,
                     overview=((x0 + 0.3, y0 + 0.3, height - 0.3),
                               (0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.5)))
    spec.rooms = [{"id": rid, "x": r[:2], "y": r[2:]} for rid, r in outline.rooms]
    surfaces = draw_surfaces(rng, spec, outline, {w.wall.side for w in windows})
    lights = [(moved(r, dx, dy), radiance) for r, radiance in draw_lights(rng, plan.outline)]
    openings: dict[str, list] = {}
    for w in windows:
        glass = spec.material(Material("window_glass", "glass", optical="thindielectric",
                                       ior=1.5))
        side = openings.setdefault(w.wall.side, [])
        side.append(w.opening(f"window_{w.wall.side}_{len(side) + 1}", glass,
                              dx if w.wall.axis == "x" else dy))
    interior = [] if outline.block is None else [
        ThickWall("corner_block", "x", outline.block[:2], outline.block[2:])]
    enclosure(spec, outline.outer, surfaces.walls, surfaces.floor, surfaces.ceiling, openings,
              interior=interior, interior_mat=surfaces.block, lights=lights,
              window_reveal=WINDOW_REVEAL)
    panel = spec.material(Material("light_panel", "plaster", rgb=PANEL_WHITE))
    spec.add(*ceiling_lights(lights, height, panel))
    looks = []
    if plan.partition is not None:
        rect, top, look = plan.partition
        rect = moved(rect, dx, dy)
        pane = spec.material(Material("partition_glass", "glass", optical="thindielectric",
                                      ior=1.5))
        spec.add(*glass_partition("partition", rect[:2], rect[2:], top, pane,
                                  shared(spec, "bright")))
        looks += [] if look is None else [(exact(look[0] + dx), exact(look[1] + dy))]
    counts: dict[str, int] = {}
    for piece, (rect, axis, back) in plan.placed:
        counts[piece.kind] = counts.get(piece.kind, 0) + 1
        gid = f"{piece.kind}_{counts[piece.kind]}"
        spec.add(*build(spec, rng, gid, piece, moved(rect, dx, dy), axis, back))
    corners = [(exact(x + dx), exact(y + dy)) for x, y in plan.corners]
    spec.trajectory = loop_trajectory(corners, (0.0, 0.0), looks)
    spec.description = _description(seed, outline, height, surfaces.summary, len(lights),
                                    windows, plan.partition is not None, counts)
    _check_clearance(spec, loop_legs(corners))
    return spec


def _description(seed, outline, height, looks, n_lights, windows, partition, counts) -> str:
    """One line on the room for its scene.xml and ground_truth.json."""
    x0, x1, y0, y1 = outline.outer
    shape = ", L-shaped" if outline.block is not None else ""
    glass = [f"{len(windows)} window{'s' * (len(windows) != 1)}"] if windows else []
    glass += ["a glass partition"] if partition else []
    things = ", ".join(f"{n} {NAMES[kind][n > 1]}" for kind, n in counts.items())
    return (f"varied room (seed {seed}) {x1 - x0:.2f} m x {y1 - y0:.2f} m x {height:.2f} m{shape}"
            f": {looks}, {n_lights} ceiling light{'s' * (n_lights != 1)}, "
            f"{' and '.join(glass)}; furniture: {things}")


def _check_clearance(spec: SceneSpec, legs) -> None:
    """Every object's footprint is CLEARANCE or more from the loop (else a generator bug)."""
    for obj in spec.objects():
        near = min(gap(tuple(obj["footprint_xy_m"]), leg) for leg in legs)
        if near < CLEARANCE:
            raise RuntimeError(f"{spec.name}: '{obj['id']}' is {near:.3f} m from the robot's "
                               f"loop (< {CLEARANCE} m)")
