"""Looks of the varied rooms (:mod:`mitsonar.scene.varied`): wall colours and textures, floor
and ceiling finishes (each an acoustic preset of :mod:`mitsonar.physics.materials`) and the
ceiling lights.

Wall schemes: 'pale' (one pale, near-uniform colour on every wall: little contrast at the
creases for the camera, the hard case), 'pale tints' (a slightly different pale colour per
wall), 'accent' (pale walls and one coloured), 'colours' (a colour per wall), 'concrete' (bare
concrete, its texture showing panel joints) and 'wood' (pale walls with one or two panelled in
wood). Textures go on whole walls only (walls without windows), floors only in rectangular rooms:
a material's texture repeats over each piece of a surface, so a surface cut in pieces would show
it at different scales.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mitsonar.scene.building.lights import PANEL_RADIANCE, STRIP_RADIANCE
from mitsonar.scene.building.materials import ORANGE, Material
from mitsonar.scene.building.shapes import Rect2
from mitsonar.scene.building.spec import SceneSpec
from mitsonar.scene.building.surfaces import vertical_face
from mitsonar.scene.varied.plan import Outline, Wall, grid

#: Mid colours of painted walls (linear RGB).
HUES = ((0.42, 0.55, 0.72), (0.55, 0.68, 0.52), (0.76, 0.64, 0.48), (0.66, 0.36, 0.26),
        (0.80, 0.62, 0.25), ORANGE, (0.18, 0.45, 0.46), (0.58, 0.50, 0.68), (0.30, 0.32, 0.36),
        (0.78, 0.52, 0.52))
#: Wall scheme -> how the description names it.
WALL_SCHEMES = {"pale": "pale", "pale tints": "pale tinted", "accent": "pale and one coloured",
                "colours": "coloured", "concrete": "bare", "wood": "pale"}
_WALL_SCHEME_P = (0.3, 0.15, 0.2, 0.15, 0.1, 0.1)
#: Floor finish -> (acoustic preset, texture or None, texture repeat (u, v) [m], plain colours).
FLOORS = {
    "concrete": ("concrete", "concrete_floor.png", (2.0, 2.0),
                 ((0.42, 0.41, 0.40), (0.32, 0.32, 0.31), (0.50, 0.49, 0.46))),
    "carpet": ("fabric", "carpet.png", (1.0, 1.0),
               ((0.30, 0.34, 0.42), (0.35, 0.30, 0.28), (0.25, 0.28, 0.25), (0.45, 0.45, 0.45))),
    "wood": ("wood", "wood_oak.png", (0.4, 2.0), ((0.45, 0.30, 0.18), (0.30, 0.19, 0.11))),
    "vinyl": ("concrete", None, (1.0, 1.0), ((0.70, 0.68, 0.62), (0.62, 0.64, 0.66))),
}
_FLOOR_P = (0.3, 0.25, 0.25, 0.2)
#: Ceiling finish -> (acoustic preset, plain colours).
CEILINGS = {"plaster": ("plaster", ((0.82, 0.82, 0.82), (0.86, 0.85, 0.82))),
            "concrete": ("concrete", ((0.55, 0.55, 0.54), (0.62, 0.61, 0.60))),
            "acoustic tiles": ("foam", ((0.78, 0.78, 0.76), (0.82, 0.82, 0.82)))}
_CEILING_P = (0.6, 0.2, 0.2)
#: Wall textures: file, acoustic preset, repeat (across the grain or u, along it or v) [m].
_WALL_TEXTURES = {"concrete": ("concrete_floor.png", "concrete", (2.0, 2.0)),
                  "wood": ("wood_oak.png", "wood", (0.5, 2.5))}
#: Ceiling light kinds: (plan size (long, short) [m], radiance [W/(m^2 sr)]).
LIGHT_KINDS = {"panel": ((1.2, 0.6), PANEL_RADIANCE), "square": ((0.6, 0.6), PANEL_RADIANCE),
               "strip": ((1.6, 0.3), STRIP_RADIANCE)}


@dataclass(frozen=True)
class Surfaces:
    """Material ids of the room's surfaces (registered in the spec) and a phrase on them.

    Attributes:
        walls: outer wall side ('south', ...) -> material id.
        block: material of the faces of an L's corner block ('' without one).
        floor, ceiling: material ids.
        summary: e.g. "pale drywall walls, carpet floor, plaster ceiling".
    """

    walls: dict[str, str]
    block: str
    floor: str
    ceiling: str
    summary: str


def _rgb(v) -> tuple[float, float, float]:
    return tuple(round(float(min(max(c, 0.02), 0.95)), 3) for c in v)


def _pale(rng: np.random.Generator) -> tuple[float, float, float]:
    """A pale, near-neutral colour (0.70-0.86, tinted by 2.5 % at most)."""
    return _rgb(rng.uniform(0.70, 0.86) + rng.uniform(-0.025, 0.025, 3))


def _pick(rng: np.random.Generator, colours):
    """One of ``colours``, its brightness varied by -15..+10 %."""
    return _rgb(np.asarray(colours[rng.integers(len(colours))]) * rng.uniform(0.85, 1.1))


def _face_uv(wall: Wall, height: float, repeat) -> tuple[float, float]:
    """Texture repeats (u, v) over the whole face of ``wall`` (``height`` [m] tall) for one
    repeat every ``repeat`` = (along u, along v) [m]: u runs along the wall or up it, as
    :func:`mitsonar.scene.building.surfaces.vertical_face` orients the rectangle."""
    facing = wall.inward[1] if wall.axis == "x" else wall.inward[0]
    face = vertical_face("probe", wall.axis, wall.across, wall.span, (0.0, height), facing,
                         "probe", "wall")[0]
    u_up = abs(face.to_world[2, 0]) > 0.0
    extent = (height, wall.length) if u_up else (wall.length, height)
    return (round(extent[0] / repeat[0], 3), round(extent[1] / repeat[1], 3))


def draw_surfaces(rng: np.random.Generator, spec: SceneSpec, outline: Outline,
                  windowed: set[str]) -> Surfaces:
    """Draw and register the materials of walls, floor and ceiling; ``windowed``: the sides of
    outer walls with windows (never textured)."""
    scheme = tuple(WALL_SCHEMES)[rng.choice(len(WALL_SCHEMES), p=_WALL_SCHEME_P)]
    paint = ("drywall", "plaster", "concrete")[rng.choice(3, p=(0.6, 0.25, 0.15))]
    outer = [w for w in outline.walls if w.side is not None]
    plain = [w for w in outer if w.side not in windowed]
    base = _pale(rng)
    colours = {w.side: base for w in outer}
    textured: dict[str, str] = {}
    if scheme == "pale tints":
        colours = {w.side: _pale(rng) for w in outer}
    elif scheme == "accent":
        colours[outer[rng.integers(len(outer))].side] = _pick(rng, HUES)
    elif scheme == "colours":
        colours = {w.side: _pick(rng, HUES) for w in outer}
    elif scheme == "concrete":
        colours = {w.side: _rgb([rng.uniform(0.45, 0.6)] * 3) for w in outer}
        textured = {w.side: "concrete" for w in plain}
    elif scheme == "wood" and plain:
        chosen = rng.permutation(len(plain))[:rng.integers(1, min(2, len(plain)) + 1)]
        textured = {plain[k].side: "wood" for k in sorted(chosen)}
    preset = "concrete" if scheme == "concrete" else paint
    walls = {}
    for w in outer:
        if w.side in textured:
            file, tex_preset, repeat = _WALL_TEXTURES[textured[w.side]]
            mat = Material(f"wall_{w.side}_{textured[w.side]}", tex_preset, texture=file,
                           uv_scale=_face_uv(w, spec.height, repeat))
        elif scheme == "pale":
            mat = Material("wall_paint", preset, rgb=base)
        else:
            mat = Material(f"wall_{w.side}_paint", preset, rgb=colours[w.side])
        walls[w.side] = spec.material(mat)
    block = "" if outline.block is None else spec.material(
        Material("wall_block_paint", preset, rgb=colours[outer[0].side]))
    floor, floor_name = _floor(rng, spec, outline)
    ceiling_name = tuple(CEILINGS)[rng.choice(len(CEILINGS), p=_CEILING_P)]
    ceiling_preset, ceiling_colours = CEILINGS[ceiling_name]
    ceiling = spec.material(Material(f"ceiling_{ceiling_preset}", ceiling_preset,
                                     rgb=_pick(rng, ceiling_colours)))
    walls_phrase = f"{WALL_SCHEMES[scheme]} {preset} walls"
    if scheme == "wood":
        walls_phrase += f" ({len(textured)} panelled in wood)"
    return Surfaces(walls, block, floor, ceiling,
                    f"{walls_phrase}, {floor_name} floor, {ceiling_name} ceiling")


def _floor(rng: np.random.Generator, spec: SceneSpec, outline: Outline) -> tuple[str, str]:
    """(material id, phrase) of a drawn floor finish."""
    name = tuple(FLOORS)[rng.choice(len(FLOORS), p=_FLOOR_P)]
    preset, texture, repeat, colours = FLOORS[name]
    if texture is not None and outline.block is None and rng.random() < 0.6:
        x0, x1, y0, y1 = outline.outer
        if name == "wood" and rng.random() < 0.5:
            texture = "wood_walnut.png"
        scale = (round((x1 - x0) / repeat[0], 3), round((y1 - y0) / repeat[1], 3))
        mat = Material(f"floor_{name}_textured", preset, texture=texture, uv_scale=scale)
        return spec.material(mat), f"textured {name}"
    return spec.material(Material(f"floor_{name}", preset, rgb=_pick(rng, colours))), name


def draw_lights(rng: np.random.Generator, outline: Outline) -> list[tuple[Rect2, tuple]]:
    """Ceiling lights (plan rectangle, radiance): one kind per room ('panel', 'square' or
    'strip'), on a grid of up to 3 x 2 per plan rectangle (one per 2.5 m or more each way, one
    fewer each way at times), some left out (at least one stays), their radiance scaled by
    0.6-1.3."""
    kind = tuple(LIGHT_KINDS)[rng.integers(len(LIGHT_KINDS))]
    (long, short), radiance = LIGHT_KINDS[kind]
    scale = rng.uniform(0.6, 1.3)
    radiance = tuple(round(v * scale, 3) for v in radiance)
    along_x = rng.random() < 0.5
    hx, hy = (long / 2, short / 2) if along_x else (short / 2, long / 2)
    lights = []
    for _, (x0, x1, y0, y1) in outline.rooms:
        most_x = min(3, max(1, int((x1 - x0) // 2.5)))
        most_y = min(2, max(1, int((y1 - y0) // 2.5)))
        nx = int(rng.integers(max(1, most_x - 1), most_x + 1))
        ny = int(rng.integers(max(1, most_y - 1), most_y + 1))
        for i in range(nx):
            for j in range(ny):
                cx = grid(x0 + (i + 0.5) * (x1 - x0) / nx)
                cy = grid(y0 + (j + 0.5) * (y1 - y0) / ny)
                rect = (grid(cx - hx), grid(cx + hx), grid(cy - hy), grid(cy + hy))
                fits = rect[0] >= x0 + 0.2 and rect[1] <= x1 - 0.2 and \
                    rect[2] >= y0 + 0.2 and rect[3] <= y1 - 0.2
                if fits and (not lights or rng.random() >= 0.15):
                    lights.append((rect, radiance))
    return lights
