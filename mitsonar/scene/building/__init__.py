"""Building blocks of Mitsuba scenes with acoustic materials and exact ground truth: the shipped
scenes (``mitsonar.scene.shipped``) are written from them, and so can your own rooms.

A room in a few lines::

    from mitsonar.scene.building.lights import PANEL_RADIANCE, ceiling_lights
    from mitsonar.scene.building.materials import Material
    from mitsonar.scene.building.shell import enclosure
    from mitsonar.scene.building.spec import SceneSpec

    spec = SceneSpec("my_room", "a 4 m x 3 m room", height=2.5)
    spec.rooms = [{"id": "room", "x": (-1.0, 3.0), "y": (-1.5, 1.5)}]
    wall = spec.material(Material("wall", "drywall"))
    lights = [((0.5, 1.5, -0.3, 0.3), PANEL_RADIANCE)]
    enclosure(spec, (-1.0, 3.0, -1.5, 1.5), wall, wall, wall, lights=lights)
    spec.add(*ceiling_lights(lights, spec.height, wall))
    spec.write("out")  # out/my_room/scene.xml, ground_truth.json

Modules, one concept each:

* ``spec``: :class:`~mitsonar.scene.building.spec.SceneSpec`, the scene description, and its
  writer (scene.xml, ground_truth.json, sky and texture PNGs; the file formats are described
  there).
* ``shapes``: Mitsuba shape primitives with exact areas (rectangle, box, block, closed cylinder,
  sphere).
* ``surfaces``: a rectangle minus holes; wall faces and floors/ceilings built from the pieces.
* ``shell``: floor, ceiling and outer walls of a plan rectangle, thick interior walls.
* ``openings``: doorways and windows with their reveals and glass panes.
* ``lights``: ceiling light panels, the sun and the sky environment map.
* ``materials``: the ``acoustic`` material with its optical BSDF, and a palette.
* ``textures``: procedural PNG textures (wood, concrete, hazard stripes, carpet).
* ``furniture``: tables, chairs, sofas, shelving, desk workstations, a glass partition, a
  floor lamp, boxes, cans and rods.
* ``formatting``: exact number formatting and atomic output, so the files are reproducible.
* ``preview``: PNG previews rendered with Mitsuba.

The blocks compute with NumPy only (importing them runs ``mitsonar/__init__.py``); previews
render with Mitsuba.
"""
