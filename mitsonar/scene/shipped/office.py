"""``office``: a large office with desks, sofas, a bookshelf and five small windows
(repeated-scan mode: furniture, small objects, colours and textures)."""

from __future__ import annotations

from mitsonar.scene.building.furniture import (item_box, item_can, shelf_unit, sofa, table,
                                               workstation)
from mitsonar.scene.building.lights import (PANEL_RADIANCE, SUN_DIRECTION, SUN_IRRADIANCE,
                                            ceiling_lights)
from mitsonar.scene.building.materials import CEILING_WHITE, PANEL_WHITE, Material
from mitsonar.scene.building.openings import Opening
from mitsonar.scene.building.shapes import block, sphere
from mitsonar.scene.building.shell import ThickWall, enclosure
from mitsonar.scene.building.spec import SceneSpec


def build() -> SceneSpec:
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
    enclosure(spec, outer, walls, floor, ceiling, openings,
              interior=[ThickWall("column", "x", (-2.9, -2.5), (-1.6, -1.2))],
              interior_mat=column, lights=lights, window_reveal=0.1)
    spec.add(*ceiling_lights(lights, spec.height, panel))

    # south row: sitters north of the desks; middle cluster: back-to-back rows
    desks = [((x0, x0 + 1.4), (-3.45, -2.75), "north", seat_red) for x0 in (-3.3, -1.1, 1.1, 3.3)]
    desks += [((x0, x0 + 1.4), y, sitter, seat_grey)
              for y, sitter in (((1.2, 1.9), "south"), ((1.9, 2.6), "north")) for x0 in (1.0, 2.4)]
    for k, (x, y, sitter, seat) in enumerate(desks, start=1):
        spec.add(*workstation(k, x, y, sitter, walnut, legs, seat, screen, plastic,
                              cups[k % len(cups)]))

    # lounge: two sofas, a coffee table with two cups
    spec.add(*sofa("sofa_1", (-4.0, -2.0), (4.6, 5.45), "north", teal))
    spec.add(*sofa("sofa_2", (-4.45, -3.6), (1.55, 3.45), "west", mustard))
    spec.add(*table("coffee_table", (-3.2, -2.2), (2.8, 3.6), 0.44, walnut, legs, top=0.04,
                    leg=0.05))
    for k, cxy in enumerate(((-2.9, 3.1), (-2.5, 3.3)), start=len(desks) + 1):
        spec.add(*item_can(f"cup_{k}", cxy, 0.44, 0.04, 0.095, cups[k % len(cups)]))

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
