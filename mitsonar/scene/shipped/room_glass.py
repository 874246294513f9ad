"""``room_glass``: the paper's single room with two glass windows (surfel mode, texture-less)."""

from __future__ import annotations

from mitsonar.scene.building.lights import (PANEL_RADIANCE, SUN_DIRECTION, SUN_IRRADIANCE,
                                            ceiling_lights)
from mitsonar.scene.building.materials import (CEILING_WHITE, CONCRETE_GREY, LIGHT_GREY,
                                               PANEL_WHITE, Material)
from mitsonar.scene.building.openings import Opening
from mitsonar.scene.building.shell import enclosure
from mitsonar.scene.building.spec import SceneSpec


def build() -> SceneSpec:
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
    enclosure(spec, outer, wall, floor, ceiling, openings, lights=lights, window_reveal=0.1)
    spec.add(*ceiling_lights(lights, spec.height, panel))
    # A loop 1.5 m inside the walls (2 m from the east wall), facing the wall ahead; it starts at
    # the demo pose facing window_east and drives towards window_north on the second leg.
    spec.trajectory = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (1.0, 0.0, 90.0), (1.0, 1.5, 90.0),
                       (1.0, 1.5, 180.0), (-3.0, 1.5, 180.0), (-3.0, 1.5, 270.0),
                       (-3.0, -1.5, 270.0), (-3.0, -1.5, 360.0), (1.0, -1.5, 360.0)]
    return spec
