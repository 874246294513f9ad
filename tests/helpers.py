"""Helpers shared by the tests: repository paths, small scenes written on the fly, common poses."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import mitsonar

#: The repository's root, and its shipped scenes.
ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "scenes"

HEADER = '<scene version="3.0.0">\n'


def rectangle_xml(material: str, centre, normal_euler_deg=(0, 0, 0), size=(20.0, 20.0),
                  shape_id: str = "") -> str:
    """A rectangle of ``size`` [m] centred at ``centre``, facing -z rotated by Euler angles (deg)."""
    rx, ry, rz = normal_euler_deg
    sid = f' id="{shape_id}"' if shape_id else ""
    return (f'<shape type="rectangle"{sid}><transform name="to_world">'
            f'<scale x="{size[0] / 2}" y="{size[1] / 2}"/>'
            f'<rotate x="1" angle="{rx}"/><rotate y="1" angle="{ry}"/><rotate z="1" angle="{rz}"/>'
            f'<translate x="{centre[0]}" y="{centre[1]}" z="{centre[2]}"/>'
            f'</transform><ref id="{material}"/></shape>')


def sphere_xml(material: str, centre, radius: float) -> str:
    return (f'<shape type="sphere"><point name="center" x="{centre[0]}" y="{centre[1]}" '
            f'z="{centre[2]}"/><float name="radius" value="{radius}"/><ref id="{material}"/></shape>')


def write_scene(path, *parts) -> str:
    path.write_text(HEADER + "\n".join(parts) + "\n</scene>\n")
    return str(path)


#: The sensor sits at the world origin looking along +z (world frame = sensor frame).
IDENTITY = mitsonar.Pose.identity()
BROADSIDE = np.array([0.0, 0.0, 1.0])
