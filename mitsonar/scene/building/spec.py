"""The scene description and its writer: a :class:`SceneSpec` collects materials, shapes,
rooms, windows, light and a robot trajectory, and writes its directory ``<out>/<name>/`` as

* ``scene.xml``: Mitsuba 3 scene. Every surface is its own shape with a unique id (wall segments
  around an opening, each face of a thick wall, each ceiling tile between light panels, each
  piece of a piece of furniture), built from Mitsuba's ``rectangle`` shapes for the building
  and closed solids for furniture and small objects (``mitsonar.scene.building.shapes``), each
  with an explicit ``to_world`` matrix.
  Materials are ``<bsdf type="acoustic">`` with a ``preset`` and a nested optical BSDF (plain
  ``diffuse`` colours, or a ``bitmap`` texture written beside the scene as reflectance); windows
  are holes in their wall filled by a ``thindielectric`` pane (the camera sees through it, the
  sonar reflects from it). Light (:attr:`SceneSpec.lighting`,
  :mod:`mitsonar.scene.building.lights`): area-light panels set into the ceiling and, where a
  scene has windows, a sky/ground environment map seen through them; then either the ``key``
  look (default: a key light, a fill and an ambient term, direct light only, Mitsuba's
  ``direct`` integrator) or the ``ceiling`` look (a directional sun falling through the windows
  in sunlit patches with sharp shadow edges, the paper's "shadow lines"; interior walls cast
  the panels' shadows; integrator ``volpath``: unlike ``path``, its shadow rays pass thin glass
  panes (their null transmission). That needs the ``acoustic`` BSDF to forward
  ``eval_null_transmission`` to its nested BSDF; where it does not, sun and direct sky light
  stop at the glass (the sky is still seen through it)). A
  ``perspective`` camera placeholder sits at the camera of a robot at the world origin facing
  +x; its film size, samples per pixel and path depth are the XML defaults ``width``,
  ``height``, ``spp`` and ``max_depth`` (override them with ``mi.load_file(path, spp=...)``).
* ``ground_truth.json``: per shape its id, material id, acoustic preset, role ('wall',
  'interior_wall', 'window', 'floor', 'ceiling', 'light', 'furniture', 'small_object'), group
  (the object it belongs to), surface area [m^2] (as Mitsuba's ``surface_area()``; hidden faces
  where solids touch count too) and geometry (``to_world``; corners and normal of rectangles;
  radius and centre of disks and spheres, radius, base centre, axis and length of cylinders);
  the area per material; rooms; windows; the camera placeholder; the default robot
  trajectory. Scenes with furniture also list their textures and per object (furniture
  piece or small object) its shapes, area, plan footprint and height range.
* ``sky.png`` (scenes with windows): the environment map; texture PNGs
  (``mitsonar.scene.building.textures.TEXTURES``) where materials use them.

World frame: metres, z up, floor at z = 0. The world origin is a sensible robot position, with
the robot facing +x. Robot poses are (x [m], y [m], yaw [deg]) of the chassis centre in the
world frame; the sensor head is 0.1 m ahead and 0.5 m above it (``mitsonar.frames``), the
camera 0.075 m above the sensor head. Everything is deterministic: no randomness, fixed number
formatting, so writing a scene again gives identical bytes.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mitsonar.frames import SENSOR_MOUNT_TRANSLATION
from mitsonar.scene.building.formatting import (dump_json, fmt, fmt_vec, rounded, rounded_area,
                                                rounded_list, write_atomic)
from mitsonar.scene.building.lights import (LIGHTINGS, SKY_FILE, key_lights_xml, sky_png,
                                            sky_xml, sun_xml)
from mitsonar.scene.building.materials import Material
from mitsonar.scene.building.shapes import Shape
from mitsonar.scene.building.textures import TEXTURES

#: Camera optical centre above the sensor head's array origin [m] (DESIGN.md, Camera).
CAMERA_ABOVE_SENSOR = 0.075
#: Horizontal field of view of the camera placeholder [deg]; at 4:3 it covers the array's 60 x 40.
CAMERA_FOV_DEG = 60.0


@dataclass
class SceneSpec:
    """Everything one scene directory holds; written by :meth:`write`.

    Attributes:
        name: directory name.
        description: one line for humans.
        height: room height [m].
        rooms: plan rectangles of the rooms, {'id', 'x': (x0, x1), 'y': (y0, y1)} [m].
        materials: materials by id (written in insertion order).
        shapes: shapes (written in order; ids unique).
        windows: per window {'id', 'wall', 'centre', 'width_m', 'height_m', 'sill_m'}.
        trajectory: waypoints (x [m], y [m], yaw [deg], unwrapped) of the robot, world frame.
        speed: robot speed along the trajectory [m/s].
        yaw_rate: turning rate in place [deg/s].
        sky: write the sky environment map (scenes with windows).
        sun: (direction of travel, irradiance [W/m^2] linear RGB) of a directional sun, or None
            (``ceiling`` look only: the ``key`` look has its key light instead).
        lighting: the look, one of :data:`~mitsonar.scene.building.lights.LIGHTINGS`: 'key'
            (key light, fill and ambient, direct light only) or 'ceiling' (ceiling panels, sun
            and interreflection).
        overview: (origin, target) of the overview camera used for the README preview.
    """

    name: str
    description: str
    height: float
    rooms: list[dict] = field(default_factory=list)
    materials: dict[str, Material] = field(default_factory=dict)
    shapes: list[Shape] = field(default_factory=list)
    windows: list[dict] = field(default_factory=list)
    trajectory: list[tuple[float, float, float]] = field(default_factory=list)
    speed: float = 0.2
    yaw_rate: float = 30.0
    sky: bool = False
    sun: tuple | None = None
    lighting: str = LIGHTINGS[0]
    overview: tuple = ((0.0, 0.0, 2.0), (1.0, 0.0, 1.0))

    def __post_init__(self):
        if self.lighting not in LIGHTINGS:
            raise ValueError(f"scene '{self.name}': lighting must be one of {LIGHTINGS}, got "
                             f"{self.lighting!r}")

    def room_boxes(self) -> list[tuple[float, ...]]:
        """(x0, x1, y0, y1, 0, height) [m] of every room: the boxes whose walls and ceiling cast
        no shadows of the ``key`` look's lights."""
        return [(*r["x"], *r["y"], 0.0, self.height) for r in self.rooms]

    def _integrator_xml(self) -> list[str]:
        if self.lighting == "key":
            return ['    <!-- direct: light reaches each surface straight from the lights, as in '
                    'the rasterised Gazebo worlds; the ambient term stands in for the bounces -->',
                    '    <integrator type="direct"/>']
        return ['    <!-- volpath: its shadow rays continue through thin glass panes (null '
                'transmission), so sun and sky light reach the room through the windows where '
                'the acoustic BSDF forwards eval_null_transmission -->',
                '    <integrator type="volpath">',
                '        <integer name="max_depth" value="$max_depth"/>',
                '    </integrator>']

    def material(self, mat: Material) -> str:
        """Register ``mat`` (again, if unchanged) and return its id."""
        if mat.id in self.materials and self.materials[mat.id] != mat:
            raise ValueError(f"material '{mat.id}' defined twice with different values")
        self.materials[mat.id] = mat
        return mat.id

    def add(self, *shapes: Shape) -> None:
        """Append shapes; their ids must be new and their materials registered."""
        known = {s.id for s in self.shapes}
        for s in shapes:
            if s.id in known:
                raise ValueError(f"scene '{self.name}': duplicate shape id '{s.id}'")
            if s.material not in self.materials:
                raise ValueError(f"shape '{s.id}': unknown material '{s.material}'")
            known.add(s.id)
            self.shapes.append(s)

    def textures(self) -> list[str]:
        """Texture PNGs the materials use (sorted)."""
        return sorted({m.texture for m in self.materials.values() if m.texture is not None})

    def objects(self) -> list[dict]:
        """Per furniture piece or small object (shapes sharing a group): its role, shapes,
        total area and axis-aligned bounds; ``footprint_xy_m`` = (x0, x1, y0, y1) is its plan
        rectangle (the robot keeps its distance from it)."""
        groups: dict[str, list[Shape]] = {}
        for s in self.shapes:
            if s.role in ("furniture", "small_object"):
                groups.setdefault(s.group, []).append(s)
        out = []
        for g, shapes in groups.items():
            if len({s.role for s in shapes}) != 1:
                raise ValueError(f"object '{g}' mixes roles {sorted({s.role for s in shapes})}")
            lo = np.min([s.bbox()[0] for s in shapes], axis=0)
            hi = np.max([s.bbox()[1] for s in shapes], axis=0)
            out.append({"id": g, "role": shapes[0].role, "shapes": [s.id for s in shapes],
                        "area_m2": rounded_area(sum(s.area for s in shapes)),
                        "footprint_xy_m": rounded_list([lo[0], hi[0], lo[1], hi[1]]),
                        "z_m": rounded_list([lo[2], hi[2]])})
        return out

    def camera(self) -> dict:
        """Camera placeholder: the camera of a robot at the world origin facing +x."""
        x, y, z = (float(v) for v in SENSOR_MOUNT_TRANSLATION)
        origin = (x, y, z + CAMERA_ABOVE_SENSOR)
        return {"robot_pose": [0.0, 0.0, 0.0], "origin": list(origin),
                "target": [origin[0] + 1.0, origin[1], origin[2]], "up": [0.0, 0.0, 1.0],
                "fov_deg": CAMERA_FOV_DEG, "fov_axis": "x",
                "note": "placeholder: the camera module sets the real intrinsics and pose"}

    def xml(self, written_by: str) -> str:
        """The scene.xml text; its header names ``written_by``, the program to edit instead."""
        cam = self.camera()
        out = ['<?xml version="1.0" encoding="utf-8"?>',
               f'<!-- {self.name}: {self.description} -->',
               f'<!-- Written by {written_by}: edit the generator, not this file. '
               'World frame: metres, z up; robot at the origin faces +x. -->',
               '<scene version="3.0.0">',
               '    <default name="spp" value="64"/>',
               '    <default name="width" value="1600"/>',
               '    <default name="height" value="1200"/>',
               '    <default name="max_depth" value="8"/>',
               '',
               *self._integrator_xml(),
               '',
               '    <!-- camera placeholder: robot at (0, 0, yaw 0); sensor head 0.1 m ahead and'
               ' 0.5 m up, camera 0.075 m above it -->',
               '    <sensor type="perspective" id="camera">',
               f'        <float name="fov" value="{fmt(cam["fov_deg"])}"/>',
               '        <string name="fov_axis" value="x"/>',
               '        <float name="near_clip" value="0.01"/>',
               '        <float name="far_clip" value="1000"/>',
               '        <transform name="to_world">',
               f'            <lookat origin="{fmt_vec(cam["origin"])}" '
               f'target="{fmt_vec(cam["target"])}" up="0, 0, 1"/>',
               '        </transform>',
               '        <sampler type="independent">',
               '            <integer name="sample_count" value="$spp"/>',
               '        </sampler>',
               '        <film type="hdrfilm">',
               '            <integer name="width" value="$width"/>',
               '            <integer name="height" value="$height"/>',
               '            <rfilter type="gaussian"/>',
               '        </film>',
               '    </sensor>',
               '']
        if self.lighting == "key":
            out += ["    " + line for line in key_lights_xml(self.room_boxes())] + ['']
        elif self.sun is not None:
            out += ["    " + line for line in sun_xml(*self.sun)] + ['']
        if self.sky:
            out += ["    " + line for line in sky_xml()] + ['']
        for mat in self.materials.values():
            out += ["    " + line for line in mat.xml()]
        out.append('')
        for s in self.shapes:
            out += ["    " + line for line in s.xml()]
        out.append('</scene>')
        return "\n".join(out) + "\n"

    def ground_truth(self) -> dict:
        """The ground_truth.json content (see the module docstring)."""
        per_material: dict[str, dict] = {}
        for s in self.shapes:
            entry = per_material.setdefault(s.material, {
                "preset": self.materials[s.material].preset,
                "optical": self.materials[s.material].optical, "shapes": 0, "area_m2": 0.0})
            if self.materials[s.material].texture is not None:
                entry["texture"] = self.materials[s.material].texture
            entry["shapes"] += 1
            entry["area_m2"] += s.area
        for entry in per_material.values():
            entry["area_m2"] = rounded_area(entry["area_m2"])
        shapes = []
        for s in self.shapes:
            d = {"id": s.id, "material": s.material, "preset": self.materials[s.material].preset,
                 "role": s.role, "group": s.group, "type": s.kind, "area_m2": rounded_area(s.area)}
            if s.kind == "rectangle":
                d["normal"] = rounded_list(s.normal())
                d["corners"] = [rounded_list(c) for c in s.corners()]
            if s.kind in ("cylinder", "disk", "sphere"):
                d["radius_m"] = rounded(s.radius)
                # a cylinder's origin is the centre of its base (local z = 0)
                d["base" if s.kind == "cylinder" else "centre"] = rounded_list(s.to_world[:3, 3])
            if s.kind == "cylinder":
                d["length_m"] = rounded(np.linalg.norm(s.to_world[:3, 2]))
                d["axis"] = rounded_list(s.normal())
            if s.kind == "disk":
                d["normal"] = rounded_list(s.normal())
            d["to_world"] = [rounded_list(row) for row in s.to_world]
            shapes.append(d)
        xs = [v for r in self.rooms for v in r["x"]]
        ys = [v for r in self.rooms for v in r["y"]]
        gt = {
            "scene": self.name,
            "description": self.description,
            "units": "SI: metres, m^2, m/s; angles in degrees (yaw)",
            "frame": "world: z up, floor at z = 0; robot pose (x, y, yaw) is the chassis centre, "
                     "yaw from +x towards +y",
            "height_m": self.height,
            "interior_extent_m": {"x": [min(xs), max(xs)], "y": [min(ys), max(ys)],
                                  "z": [0.0, self.height]},
            "rooms": [{"id": r["id"], "x_m": list(r["x"]), "y_m": list(r["y"]),
                       "floor_area_m2": rounded((r["x"][1] - r["x"][0]) * (r["y"][1] - r["y"][0]))}
                      for r in self.rooms],
            "floor_area_m2": rounded(sum(s.area for s in self.shapes if s.role == "floor")),
            "total_area_m2": rounded_area(sum(s.area for s in self.shapes)),
            "materials": per_material,
            "windows": self.windows,
            "camera_placeholder": self.camera(),
            "trajectory": {
                "frame": "world",
                "waypoints": [[rounded(x), rounded(y), rounded(yaw)]
                              for x, y, yaw in self.trajectory],
                "waypoint_format": "[x_m, y_m, yaw_deg] of the robot chassis centre; yaw is "
                                   "unwrapped (continuous between waypoints)",
                "speed_m_s": self.speed,
                "yaw_rate_deg_s": self.yaw_rate,
                "motion": "straight lines at speed_m_s between waypoints with the same yaw; turns "
                          "in place at yaw_rate_deg_s between waypoints at the same position",
            },
            "shapes": shapes,
        }
        objects = self.objects()
        if objects:  # scenes with furniture: per-object bounds and the textures
            gt = {k: v for k, v in gt.items() if k != "shapes"} | {
                "textures": self.textures(), "objects": objects, "shapes": shapes}
        return gt

    def write(self, out_dir: Path, written_by: str = "a mitsonar.scene.building script") -> Path:
        """Write scene.xml, ground_truth.json (and sky.png, texture PNGs) into
        ``out_dir/<name>``; scene.xml's header names ``written_by``. Returns scene.xml's path."""
        d = Path(out_dir) / self.name
        d.mkdir(parents=True, exist_ok=True)
        write_atomic(d / "scene.xml", self.xml(written_by).encode())
        write_atomic(d / "ground_truth.json", (dump_json(self.ground_truth()) + "\n").encode())
        if self.sky:
            write_atomic(d / SKY_FILE, sky_png())
        for name in self.textures():
            write_atomic(d / name, TEXTURES[name]())
        return d / "scene.xml"
