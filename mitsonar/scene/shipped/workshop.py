"""``workshop``: a small workshop with benches, shelves, machines and 37 small tools (repeated-scan
mode: furniture, small objects, colours and textures)."""

from __future__ import annotations

from mitsonar.scene.building.furniture import item_box, item_can, item_rod, shelf_unit, table
from mitsonar.scene.building.lights import STRIP_RADIANCE, ceiling_lights
from mitsonar.scene.building.materials import CEILING_WHITE, PANEL_WHITE, Material
from mitsonar.scene.building.shapes import block, closed_cylinder, sphere
from mitsonar.scene.building.shell import enclosure
from mitsonar.scene.building.spec import SceneSpec


def build() -> SceneSpec:
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
    enclosure(spec, outer, walls, floor, ceiling, lights=lights)
    spec.add(*ceiling_lights(lights, spec.height, panel))

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
