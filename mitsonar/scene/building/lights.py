"""Light: area-light panels set into the ceiling, a directional sun falling through the windows
(sunlit patches with sharp shadow edges, the paper's "shadow lines") and a sky/ground
environment map seen through them."""

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
