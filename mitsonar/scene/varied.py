"""Varied rooms: :func:`varied_room` draws a furnished room from a seed, so methods can be tried
on rooms nobody tuned them for, beside the four shipped scenes.

Each room (named ``varied_<seed>``) is drawn by a NumPy generator seeded with the seed, so the
same seed writes byte-identical files:

* plan (:mod:`~mitsonar.scene.varied_plan`): 4-9 m x 3.5-7 m, 2.4-3.2 m high, sometimes an L
  (a corner cut off by a thick block); the robot's default trajectory is a loop once round the
  room, 0.9 m or more from each wall (more where furniture stands along it) and 0.85 m or more
  from every object's footprint, driving towards the wall ahead and turning on the spot at the
  corners. It starts at the world origin facing +x, with a clear view of the wall ahead.
* glass (:mod:`~mitsonar.scene.varied_glass`): windows in the outer walls and/or a free-standing
  glass partition (every room has at least one), a sun through a window in most rooms with
  windows, and the sky seen through them.
* looks (:mod:`~mitsonar.scene.varied_looks`): wall colours (pale near-uniform ones included)
  and textures, floor and ceiling finishes, ceiling lights of one kind.
* furniture (:mod:`~mitsonar.scene.varied_furniture`): a cabinet and more pieces (shelves,
  sofas, tables with chairs, desks, a floor lamp), none overlapping, clear of the loop.

Glass (windows and the partition) has the acoustic ``glass`` preset and a ``thindielectric``
optical BSDF; the partition is an object (role 'furniture', id ``partition``) with a plan
footprint in ground_truth.json, the windows are listed under ``windows``. Write rooms with
``python scenes/generate.py --varied N --out DIR`` or :func:`write_varied_rooms`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mitsonar.scene.building.furniture import glass_partition
from mitsonar.scene.building.lights import ceiling_lights
from mitsonar.scene.building.materials import PANEL_WHITE, Material
from mitsonar.scene.building.shell import ThickWall, enclosure
from mitsonar.scene.building.spec import SceneSpec
from mitsonar.scene.varied_furniture import (DRAW, build, common_materials, draw_pieces, place,
                                             plan_walls)
from mitsonar.scene.varied_glass import PARTITION_BAND, draw_partition, draw_sun, draw_windows
from mitsonar.scene.varied_looks import draw_lights, draw_surfaces
from mitsonar.scene.varied_plan import (CLEARANCE, FreeFloor, draw_insets, draw_outline, exact, gap,
                                        grid, loop_corners, loop_legs, loop_trajectory, moved)

#: Draws of a whole room before giving up (a draw fails where no glass or no furniture fits).
ATTEMPTS = 50
#: Depth of the outer walls: windows sit in reveals this deep [m].
WINDOW_REVEAL = 0.1
#: Piece kind -> (name, plural) in the description.
NAMES = {"cabinet": ("cabinet", "cabinets"), "shelves": ("shelf unit", "shelf units"),
         "sofa": ("sofa", "sofas"), "table": ("table with chairs", "tables with chairs"),
         "desk": ("desk", "desks"), "lamp": ("floor lamp", "floor lamps")}


def varied_room(seed: int) -> SceneSpec:
    """The room ``varied_<seed>``: a deterministic function of ``seed`` (see the module
    docstring for what is drawn)."""
    rng = np.random.default_rng(seed)
    for _ in range(ATTEMPTS):
        spec = _draw(rng, int(seed))
        if spec is not None:
            return spec
    raise RuntimeError(f"varied_room({seed}): no room in {ATTEMPTS} draws")


def write_varied_rooms(out_dir, seeds) -> list[Path]:
    """Write ``varied_room(seed)`` for each of ``seeds`` into ``out_dir/varied_<seed>/``;
    returns the scene.xml paths."""
    return [varied_room(s).write(Path(out_dir), f"mitsonar.scene.varied.varied_room({s})")
            for s in seeds]


def _draw(rng: np.random.Generator, seed: int) -> SceneSpec | None:
    """One draw of the room, or None where it has no glass or no furniture."""
    local = draw_outline(rng)
    height = grid(rng.uniform(2.4, 3.2))
    area = sum((r[1] - r[0]) * (r[3] - r[2]) for _, r in local.rooms)
    pieces = draw_pieces(rng, area, height)
    if rng.random() < 0.5:
        pieces.append(DRAW["lamp"](rng, height))
    n_windows = int(rng.choice(4, p=(0.25, 0.35, 0.25, 0.15)))
    want_partition = rng.random() < 0.6
    if n_windows == 0 and not want_partition:
        want_partition = rng.random() < 0.6
        n_windows = 0 if want_partition else 1
    # half the partitions stand in front of a wall: keep a band for it there
    partition_wall = int(rng.integers(len(local.walls))) if want_partition and \
        rng.random() < 0.5 else None
    reserved = {} if partition_wall is None else {partition_wall: PARTITION_BAND}
    insets, assigned = plan_walls(rng, local, draw_insets(rng, local), pieces, reserved)
    corners = loop_corners(local, insets)
    (ax, ay), (bx, _) = corners[0], corners[1]
    sx, sy = exact(ax + grid(rng.uniform(0.2, 0.6) * (bx - ax))), ay
    floor = FreeFloor(local, loop_legs(corners))
    floor.keep_clear.append((sx, local.outer[1], sy - 0.4, sy + 0.4))  # the view from the start

    windows = draw_windows(rng, floor, height, n_windows, insets)
    partition = draw_partition(rng, floor, corners, height, insets, partition_wall) \
        if want_partition else None
    if not windows and partition is None:
        return None
    placed = [(piece, at) for piece, wall in assigned
              if (at := place(rng, floor, piece, wall)) is not None]
    if not any(piece.kind != "lamp" for piece, _ in placed):
        return None

    # planned with walls on the grid, written with the loop's start at the world origin
    outline = local.shifted(-sx, -sy)
    x0, x1, y0, y1 = outline.outer
    sun = draw_sun(rng, windows) if windows and rng.random() < 0.7 else None
    spec = SceneSpec(f"varied_{seed}", "", height, sky=bool(windows), sun=sun,
                     overview=((x0 + 0.3, y0 + 0.3, height - 0.3),
                               (0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.5)))
    spec.rooms = [{"id": rid, "x": r[:2], "y": r[2:]} for rid, r in outline.rooms]
    surfaces = draw_surfaces(rng, spec, outline, {w.wall.side for w in windows})
    lights = [(moved(r, -sx, -sy), radiance) for r, radiance in draw_lights(rng, local)]
    glass = spec.material(Material("window_glass", "glass", optical="thindielectric", ior=1.5))
    openings: dict[str, list] = {}
    for w in windows:
        side = openings.setdefault(w.wall.side, [])
        side.append(w.opening(f"window_{w.wall.side}_{len(side) + 1}", glass,
                              -sx if w.wall.axis == "x" else -sy))
    interior = [] if outline.block is None else [
        ThickWall("corner_block", "x", outline.block[:2], outline.block[2:])]
    enclosure(spec, outline.outer, surfaces.walls, surfaces.floor, surfaces.ceiling, openings,
              interior=interior, interior_mat=surfaces.block, lights=lights,
              window_reveal=WINDOW_REVEAL)
    panel = spec.material(Material("light_panel", "plaster", rgb=PANEL_WHITE))
    spec.add(*ceiling_lights(lights, height, panel))
    if partition is not None:
        rect, top = moved(partition[0], -sx, -sy), partition[1]
        pane = spec.material(Material("partition_glass", "glass", optical="thindielectric",
                                      ior=1.5))
        spec.add(*glass_partition("partition", rect[:2], rect[2:], top, pane,
                                  common_materials(spec)["bright"]))
    counts: dict[str, int] = {}
    for piece, (rect, axis, back) in placed:
        counts[piece.kind] = counts.get(piece.kind, 0) + 1
        gid = f"{piece.kind}_{counts[piece.kind]}"
        spec.add(*build(spec, rng, gid, piece, moved(rect, -sx, -sy), axis, back))
    corners = [(exact(x - sx), exact(y - sy)) for x, y in corners]
    looks = [] if partition is None or partition[2] is None else [
        (exact(partition[2][0] - sx), exact(partition[2][1] - sy))]
    spec.trajectory = loop_trajectory(corners, (0.0, 0.0), looks)
    spec.description = _description(seed, outline, height, surfaces.summary, len(lights),
                                    windows, partition is not None, counts)
    _check_clearance(spec, loop_legs(corners))
    return spec


def _description(seed, outline, height, looks, n_lights, windows, partition, counts) -> str:
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
