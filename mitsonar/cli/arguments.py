"""Argument types and options shared by the commands: degrees and robot poses at this boundary,
SI inside."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from mitsonar.sensors.trajectory import Trajectory


def parse_pose(text: str) -> tuple[float, float, float]:
    """'x,y,yaw' with x, y [m] and yaw [deg] -> (x, y, yaw [rad])."""
    try:
        x, y, yaw = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"pose must be 'x,y,yaw_deg', got {text!r}") from None
    if not np.all(np.isfinite([x, y, yaw])):
        raise argparse.ArgumentTypeError(f"pose must be finite, got {text!r}")
    return x, y, np.radians(yaw)


def parse_fov(text: str) -> tuple[float, float]:
    """'60x40' [deg] -> (horizontal, vertical) [rad]."""
    try:
        h, v = (float(t) for t in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"fov must be 'HxV' in degrees, got {text!r}") from None
    if not (0 < h < 180 and 0 < v < 180):
        raise argparse.ArgumentTypeError(f"fov angles must lie in (0, 180) degrees, got {text!r}")
    return np.radians(h), np.radians(v)


def add_trajectory_argument(parser) -> None:
    """The ``--trajectory PATH.json`` option of commands that move along a scene's trajectory."""
    parser.add_argument("--trajectory", type=Path, default=None,
                        help="trajectory JSON ({'waypoints': [[x_m, y_m, yaw_deg], ...], "
                             "'speed_m_s', 'yaw_rate_deg_s'}; default: the one in the scene's "
                             "ground_truth.json)")


def trajectory_from_args(args) -> Trajectory:
    """``args.trajectory`` if given, else the default trajectory of ``args.scene``."""
    if args.trajectory is not None:
        return Trajectory.from_file(args.trajectory)
    return Trajectory.from_scene(args.scene)
