"""``structure``: the paper's indoor structure of three rooms with orange interior walls
(surfel mode, texture-less)."""

from __future__ import annotations

from mitsonar.scene.building.lights import PANEL_RADIANCE, ceiling_lights
from mitsonar.scene.building.materials import (CEILING_WHITE, CONCRETE_GREY, LIGHT_GREY, ORANGE,
                                               PANEL_WHITE, Material)
from mitsonar.scene.building.openings import Opening
from mitsonar.scene.building.shell import ThickWall, enclosure
from mitsonar.scene.building.spec import SceneSpec


def build() -> SceneSpec:
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
    enclosure(spec, outer, wall, floor, ceiling, interior=interior, interior_mat=inner,
              lights=lights)
    spec.add(*ceiling_lights(lights, spec.height, panel))
    # A survey for surfel scanning, which needs two or three creases meeting in the camera's
    # view within the sonar's 5 m: the robot drives straight at room corners (stopping 2-3 m
    # short) and turns on the spot between them. West room: its south-east corner, south-west
    # corner, the corner of the west wall and the partition; then on towards wall_a's doorway
    # (the west room's north-east corner on its left), through it into the north-east room
    # (its east corners), south through wall_b's doorway into the south-east room (its east
    # and west corners).
    spec.trajectory = [(0.0, 0.0, 0.0), (0.0, 0.0, -53.0), (1.2, -1.6, -53.0),
                       (1.2, -1.6, -153.0), (-1.5, -3.0, -153.0), (-1.5, -3.0, -246.0),
                       (-2.3, -1.2, -246.0), (-2.3, -1.2, -324.0), (1.0, 1.2, -324.0),
                       (1.0, 1.2, -360.0), (5.7, 1.2, -360.0), (5.7, 1.2, -315.0),
                       (5.7, 1.2, -397.0), (5.7, 1.2, -450.0), (5.7, -2.5, -450.0),
                       (5.7, -2.5, -388.0), (5.7, -2.5, -510.0)]
    return spec
