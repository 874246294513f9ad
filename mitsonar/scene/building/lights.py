"""Light: area-light panels set into the ceiling, a directional sun falling through the windows
(sunlit patches with sharp shadow edges, the paper's "shadow lines") and a sky/ground
environment map seen through them; or the key light, fill and ambient of the ``key`` look.

Two looks (:data:`LIGHTINGS`):

* ``key`` (default): the lighting of the paper's Gazebo worlds. A directional key light from
  high on one side and a weaker fill from the other (plugin ``key_light``: the building's walls
  and ceiling cast no shadows of them, furniture does), a constant ambient term (plugin
  ``ambient_light``) and the ceiling panels, rendered with direct light only (Mitsuba's
  ``direct`` integrator; the camera follows it): each flat surface is lit evenly by the cosine
  of its angle to the lights, so walls facing different ways and the floor differ in
  brightness at their creases (:data:`KEY_DIRECTION`).
* ``ceiling``: the ceiling panels, the sun through the windows and light bouncing around the
  room (path tracing): a realistic look in which two adjacent walls of one paint often meet with
  no step in brightness.
"""

from __future__ import annotations

import numpy as np

from mitsonar.scene.building.formatting import fmt, fmt_vec
from mitsonar.scene.building.shapes import Rect2, Shape, rectangle
from mitsonar.scene.building.textures import srgb_png

#: Radiance of a ceiling light panel [W/(m^2 sr)], warm white.
PANEL_RADIANCE = (14.0, 13.0, 11.5)
#: Fluorescent strip radiance [W/(m^2 sr)], cool white.
STRIP_RADIANCE = (16.0, 16.0, 15.0)
#: Sun: direction the light travels (the sun stands at azimuth 39 deg from +x towards +y, 35 deg
#: above the horizon, so it shines into both windows of room_glass) and its irradiance [W/m^2]
#: normal to the rays.
SUN_DIRECTION = (-0.55, -0.45, -0.5)
SUN_IRRADIANCE = (6.0, 5.6, 5.0)

#: Scene lighting looks (module docstring); the first is the default.
LIGHTINGS = ("key", "ceiling")
#: Key light: direction the light travels, from 55 deg above the horizon at azimuth 30 deg from
#: +x towards +y, and its irradiance [W/m^2] normal to the rays (a floor of albedo 0.7, the
#: palest drawn, shows 0.75: images stay below 1 without tone mapping). With the fill and the
#: ambient term below, a wall facing +x, +y, -x, -y and the floor get 0.65, 0.44, 0.31, 0.43 and
#: 1.35 times the key's irradiance: adjacent walls differ by factors 1.38-1.51, and the floor, the
#: brightest, differs from every wall by a factor 1.19 or more for floors 1 to 2.5 times darker
#: than the walls (directions and strengths chosen on a grid for the largest smallest factor;
#: direct light only, ceiling panels aside).
KEY_DIRECTION = (-0.4967, -0.2868, -0.8192)
KEY_IRRADIANCE = 2.5
#: Fill light: from 50 deg above the horizon at azimuth 240 deg, half the key's irradiance.
FILL_DIRECTION = (0.3214, 0.5567, -0.766)
FILL_IRRADIANCE = 1.25
#: Ambient irradiance [W/m^2] (every surface, whatever its orientation): 0.15 of the key's.
AMBIENT_IRRADIANCE = 0.375


def ceiling_lights(lights: list[tuple[Rect2, tuple]], height: float,
                   material: str) -> list[Shape]:
    """Area-light panels ``light_1``, ``light_2``, ... flush with the ceiling at ``height`` [m]
    (in the holes :func:`mitsonar.scene.building.shell.enclosure` left): per panel its plan
    rectangle (x0, x1, y0, y1) [m] and radiance (linear RGB) [W/(m^2 sr)]."""
    return [rectangle(f"light_{k + 1}", (0.5 * (x0 + x1), 0.5 * (y0 + y1), height),
                      (0, 0.5 * (y1 - y0), 0), (0.5 * (x1 - x0), 0, 0), material, "light",
                      f"light_{k + 1}", radiance=radiance)
            for k, ((x0, x1, y0, y1), radiance) in enumerate(lights)]


def sun_xml(direction, irradiance) -> list[str]:
    """XML lines of a directional sun: ``direction`` the light travels, ``irradiance`` [W/m^2]
    (linear RGB) normal to the rays."""
    return ['<!-- sun: parallel light entering through the windows (sunlit patches '
            'with sharp shadow edges) -->',
            '<emitter type="directional" id="sun">',
            f'    <vector name="direction" value="{fmt_vec(direction)}"/>',
            f'    <rgb name="irradiance" value="{fmt_vec(irradiance)}"/>',
            '</emitter>']


#: Path length of direct light only: the camera ray's hit and one ray to a light.
DIRECT_DEPTH = 2


def direct_light_integrator(scene) -> dict | None:
    """Where a loaded ``mi.Scene``'s file asks for Mitsuba's ``direct`` integrator (the ``key``
    look), the integrator (a ``load_dict`` dictionary) that renders its direct light: ``volpath``
    to depth 2, whose passes through glass (null interactions) are no bounces, so what stands
    behind a glass partition is lit as what stands in front of it (``direct`` and ``path``
    leave it black); None for scenes in another look."""
    own = scene.integrator()  # None where the scene file names none
    if own is not None and own.class_name() == "DirectIntegrator":
        return {"type": "volpath", "max_depth": DIRECT_DEPTH}
    return None


def key_lights_xml(rooms) -> list[str]:
    """XML lines of the ``key`` look's key light, fill and ambient term; ``rooms``: the room
    boxes (x0, x1, y0, y1, z0, z1) [m] whose walls and ceiling cast no shadows of them."""
    boxes = "; ".join(" ".join(fmt(v) for v in box) for box in rooms)
    out = ['<!-- key look (the paper\'s Gazebo worlds): key light and fill, parallel, whose '
           'shadows only what stands in a room casts, and a constant ambient term -->']
    for name, direction, irradiance in (("key", KEY_DIRECTION, KEY_IRRADIANCE),
                                        ("fill", FILL_DIRECTION, FILL_IRRADIANCE)):
        out += [f'<emitter type="key_light" id="{name}_light">',
                f'    <vector name="direction" value="{fmt_vec(direction)}"/>',
                f'    <rgb name="irradiance" value="{fmt_vec([irradiance] * 3)}"/>',
                f'    <string name="rooms" value="{boxes}"/>',
                '</emitter>']
    return out + ['<emitter type="ambient_light" id="ambient_light">',
                  f'    <rgb name="irradiance" value="{fmt_vec([AMBIENT_IRRADIANCE] * 3)}"/>',
                  '</emitter>']


#: Environment map file, beside scene.xml.
SKY_FILE = "sky.png"
#: Multiplier on the sky image's linear values (envmap ``scale``).
SKY_SCALE = 1.5
_SKY_ZENITH = np.array([0.25, 0.42, 0.80])
_SKY_HORIZON = np.array([0.80, 0.86, 0.92])
_GROUND_NEAR = np.array([0.20, 0.22, 0.14])
_GROUND_HORIZON = np.array([0.34, 0.36, 0.30])


def sky_pixels(width: int = 128, height: int = 64) -> np.ndarray:
    """Linear RGB (height, width, 3) lat-long image: sky gradient above the horizon, ground
    below (Mitsuba envmap convention, top row = zenith after the +90 deg rotation about x)."""
    elevation = np.pi / 2 - (np.arange(height) + 0.5) / height * np.pi
    s = np.sin(elevation)[:, None]
    sky = _SKY_HORIZON + (_SKY_ZENITH - _SKY_HORIZON) * np.sqrt(np.clip(s, 0, 1))
    ground = _GROUND_HORIZON + (_GROUND_NEAR - _GROUND_HORIZON) * np.sqrt(np.clip(-s, 0, 1))
    row = np.where(s > 0, sky, ground)
    return np.repeat(row[:, None, :], width, axis=1)


def sky_png() -> bytes:
    """The sky image as an 8-bit sRGB PNG (deterministic bytes)."""
    lin = np.clip(sky_pixels(), 0.0, 1.0)
    srgb = np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * lin ** (1 / 2.4) - 0.055)
    return srgb_png(srgb)


def sky_xml() -> list[str]:
    """XML lines of the sky environment map (``SKY_FILE`` beside the scene)."""
    return ['<!-- sky above the horizon, ground below it; seen through the windows -->',
            '<emitter type="envmap" id="sky">',
            f'    <string name="filename" value="{SKY_FILE}"/>',
            f'    <float name="scale" value="{fmt(SKY_SCALE)}"/>',
            '    <transform name="to_world">',
            '        <rotate x="1" angle="90"/>',
            '    </transform>',
            '</emitter>']
