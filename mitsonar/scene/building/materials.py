"""Materials of the scenes: an ``acoustic`` BSDF (an acoustic preset plus the optical BSDF the
camera sees: a plain colour, a procedural texture or glass), and a palette of plain colours."""

from __future__ import annotations

from dataclasses import dataclass

from mitsonar.scene.building.formatting import fmt, fmt_vec
from mitsonar.scene.building.textures import TEXTURES

#: Palette (linear RGB diffuse reflectance).
LIGHT_GREY = (0.72, 0.72, 0.72)
CEILING_WHITE = (0.82, 0.82, 0.82)
CONCRETE_GREY = (0.42, 0.41, 0.40)
ORANGE = (0.85, 0.33, 0.06)
PANEL_WHITE = (0.9, 0.9, 0.9)


@dataclass(frozen=True)
class Material:
    """An ``acoustic`` BSDF: an acoustic preset plus the optical BSDF the camera sees.

    Attributes:
        id: material id in the XML.
        preset: acoustic preset name (``mitsonar.physics.materials.PRESETS``).
        optical: nested Mitsuba BSDF type: 'diffuse', 'thindielectric' or 'dielectric'.
        rgb: diffuse reflectance (linear RGB) for 'diffuse' without a texture.
        ior: interior index of refraction for the dielectrics.
        texture: PNG in the scene folder (a key of ``TEXTURES``) used as the diffuse reflectance
            through a ``bitmap`` texture (8-bit sRGB, repeated), or None for the plain ``rgb``.
        uv_scale: repeats of the texture across a shape's (u, v) parametrisation ([0, 1]^2 over
            a rectangle and over each face of a cube).
    """

    id: str
    preset: str
    optical: str = "diffuse"
    rgb: tuple[float, float, float] = (0.7, 0.7, 0.7)
    ior: float = 1.5
    texture: str | None = None
    uv_scale: tuple[float, float] = (1.0, 1.0)

    def __post_init__(self):
        if self.optical not in ("diffuse", "thindielectric", "dielectric"):
            raise ValueError(f"material '{self.id}': unsupported optical BSDF {self.optical!r}")
        if self.texture is not None and (self.optical != "diffuse" or
                                         self.texture not in TEXTURES):
            raise ValueError(f"material '{self.id}': texture {self.texture!r} needs a diffuse "
                             f"BSDF and one of {sorted(TEXTURES)}")

    def xml(self) -> list[str]:
        """Lines of the material's XML element."""
        lines = [f'<bsdf type="acoustic" id="{self.id}">',
                 f'    <string name="preset" value="{self.preset}"/>']
        if self.optical == "diffuse" and self.texture is not None:
            su, sv = self.uv_scale
            lines += ['    <bsdf type="diffuse">',
                      '        <texture type="bitmap" name="reflectance">',
                      f'            <string name="filename" value="{self.texture}"/>',
                      '            <transform name="to_uv">',
                      f'                <scale x="{fmt(su)}" y="{fmt(sv)}"/>',
                      '            </transform>',
                      '        </texture>',
                      '    </bsdf>']
        elif self.optical == "diffuse":
            lines += ['    <bsdf type="diffuse">',
                      f'        <rgb name="reflectance" value="{fmt_vec(self.rgb)}"/>',
                      '    </bsdf>']
        else:
            lines += [f'    <bsdf type="{self.optical}">',
                      f'        <float name="int_ior" value="{fmt(self.ior)}"/>',
                      '        <float name="ext_ior" value="1"/>',
                      '    </bsdf>']
        lines.append('</bsdf>')
        return lines
