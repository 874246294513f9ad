"""Small XML pieces of Mitsuba scenes written in code (tests, experiments): an acoustic material,
rectangles, a sphere, and the scene file around them. Lengths in metres, angles in degrees.

Every shape piece takes the id of its material first and an optional ``shape_id`` last.
"""

from __future__ import annotations

import numpy as np


def material_xml(material: str, reflectance: float | str | None = None, **acoustic) -> str:
    """An ``acoustic`` BSDF ``material`` around a diffuse BSDF of ``reflectance`` (a grey value
    in [0, 1], or "r, g, b"; None: Mitsuba's default); the ``acoustic`` parameters (e.g.
    ``preset="drywall"``, ``impedance=...``) become <string> (text) or <float> elements."""
    params = "".join(f'<{"string" if isinstance(v, str) else "float"} name="{k}" value="{v}"/>'
                     for k, v in acoustic.items())
    diffuse = '<bsdf type="diffuse"/>' if reflectance is None else \
        f'<bsdf type="diffuse"><rgb name="reflectance" value="{reflectance}"/></bsdf>'
    return f'<bsdf type="acoustic" id="{material}">{params}{diffuse}</bsdf>'


def rectangle_xml(material: str, centre, euler_deg=(0, 0, 0), size=(20.0, 20.0),
                  shape_id: str = "") -> str:
    """A rectangle of ``size`` (2,) [m] centred at ``centre`` (3,) [m]: Mitsuba's square in the
    xy plane (normal +z) scaled, turned by ``euler_deg`` about x, then y, then z [deg], moved."""
    rx, ry, rz = euler_deg
    return (f'<shape type="rectangle"{_id(shape_id)}><transform name="to_world">'
            f'<scale x="{size[0] / 2}" y="{size[1] / 2}"/>'
            f'<rotate x="1" angle="{rx}"/><rotate y="1" angle="{ry}"/><rotate z="1" angle="{rz}"/>'
            f'<translate x="{centre[0]}" y="{centre[1]}" z="{centre[2]}"/>'
            f'</transform><ref id="{material}"/></shape>')


def spanned_rectangle_xml(material: str, centre, e1, e2, half, shape_id: str = "") -> str:
    """A rectangle centred at ``centre`` (3,) [m] spanning +-half[0] [m] along e1 and +-half[1]
    [m] along e2 (directions, normalised here); its lit side faces e1 x e2."""
    e1, e2 = (np.asarray(e, float) / np.linalg.norm(e) for e in (e1, e2))
    m = np.column_stack([e1 * half[0], e2 * half[1], np.cross(e1, e2), centre])
    rows = "  ".join(", ".join(f"{x:.9g}" for x in row) for row in m)
    return (f'<shape type="rectangle"{_id(shape_id)}><transform name="to_world">'
            f'<matrix value="{rows}  0, 0, 0, 1"/></transform><ref id="{material}"/></shape>')


def sphere_xml(material: str, centre, radius: float, shape_id: str = "") -> str:
    """A sphere of ``radius`` [m] centred at ``centre`` (3,) [m]."""
    return (f'<shape type="sphere"{_id(shape_id)}><point name="center" x="{centre[0]}" '
            f'y="{centre[1]}" z="{centre[2]}"/><float name="radius" value="{radius}"/>'
            f'<ref id="{material}"/></shape>')


def write_scene(path, *parts) -> str:
    """Write a scene file of the XML ``parts`` (materials, shapes, emitters) at ``path``
    (a pathlib.Path); returns the path as a string."""
    path.write_text('<scene version="3.0.0">\n' + "\n".join(parts) + "\n</scene>\n")
    return str(path)


def _id(shape_id: str) -> str:
    return f' id="{shape_id}"' if shape_id else ""
