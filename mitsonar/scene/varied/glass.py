"""Glass and daylight of the varied rooms (:mod:`mitsonar.scene.varied`): windows in the outer
walls, a free-standing glass partition, and a sun shining in through a window.

Glass is placed where the sonar can see it near normal incidence: a window's centre, or a
partition in front of a wall, lies near the line of a leg of the loop driven towards that wall
(within 20 deg of straight ahead from the leg's start); a partition may also stand free inside
the loop, beside a leg where the robot stops and turns to face it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mitsonar.scene.building.lights import SUN_IRRADIANCE
from mitsonar.scene.building.openings import Opening
from mitsonar.scene.building.shapes import Rect2
from mitsonar.scene.varied.plan import CLEARANCE, MARGIN, FreeFloor, Wall, exact, grid, look_at

#: Half-angle [deg] about a leg's line within which glass is placed (near-normal echoes).
NEAR_NORMAL_DEG = 20.0
#: Depth [m] of the feet of a glass partition (its footprint across the pane).
PARTITION_DEPTH = 0.3
#: Depth [m] of the band kept in front of a wall for a partition (0.3 m or more from the wall).
PARTITION_BAND = 0.9


@dataclass(frozen=True)
class Window:
    """A window drawn for outer wall ``wall``: (s0, s1) along it, sill and top heights [m]."""

    wall: Wall
    s: tuple[float, float]
    sill: float
    top: float

    def opening(self, window_id: str, pane: str, ds: float = 0.0) -> Opening:
        """The window as an opening of its wall, moved by ``ds`` [m] along it."""
        return Opening(window_id, exact(self.s[0] + ds), exact(self.s[1] + ds), self.sill,
                       self.top, pane)


def _near_lane(rng, floor: FreeFloor, wall: Wall, width: float, margin: float):
    """A centre along ``wall`` [m] for glass ``width`` [m] wide, near the line of a leg driven
    towards it and ``margin`` [m] from the wall's ends, or None."""
    lo, hi = wall.span[0] + margin + width / 2, wall.span[1] - margin - width / 2
    lanes = floor.facing_legs(wall)
    if not lanes or hi < lo:
        return None
    lane, distance = lanes[rng.integers(len(lanes))]
    reach = max(0.3, distance * np.tan(np.radians(NEAR_NORMAL_DEG)))
    a, b = max(lo, lane - reach), min(hi, lane + reach)
    return grid(rng.uniform(a, b)) if a <= b else None


def draw_windows(rng: np.random.Generator, floor: FreeFloor, height: float, count: int,
                 insets: list[float]) -> list[Window]:
    """Up to ``count`` windows in the outer walls (2 m long or more), 0.8-2 m wide, 0.4 m or more
    apart, sills 0.7-1 m (0.35 m on a quarter of them, glass at the sensor's height, though
    not in the wall the robot faces at the start), tops 1.9-2.3 m (0.25 m under the ceiling at
    most). The floor between each and the loop (``insets`` [m] per wall) is kept clear."""
    walls = [k for k, w in enumerate(floor.outline.walls)
             if w.side is not None and w.length >= 2.0]
    windows: list[Window] = []
    for _ in range(4 * count):
        if len(windows) == count:
            break
        k = walls[rng.integers(len(walls))]
        wall = floor.outline.walls[k]
        width = grid(rng.uniform(0.8, min(2.0, wall.length - 1.0)))
        c = _near_lane(rng, floor, wall, width, 0.4)
        if c is None:
            continue
        s = (grid(c - width / 2), grid(c + width / 2))
        if any(o.wall == wall and s[0] < o.s[1] + 0.4 and o.s[0] < s[1] + 0.4 for o in windows):
            continue
        low = rng.random() < 0.25 and wall != floor.outline.walls[1]
        sill = 0.35 if low else grid(rng.uniform(0.7, 1.0))
        top = grid(rng.uniform(1.9, min(2.3, height - 0.25)))
        windows.append(Window(wall, s, sill, top))
        floor.keep_clear.append(wall.band((s[0] - 0.2, s[1] + 0.2), (0.0, insets[k])))
    return windows


def draw_partition(rng: np.random.Generator, floor: FreeFloor, corners, height: float,
                   insets: list[float], wall: int | None):
    """A glass partition 0.9-1.6 m wide and 1.5-2.1 m tall (0.3 m under the ceiling at most):
    (plan rectangle (PARTITION_DEPTH deep), height [m], point on the loop to look at it from
    or None), taken from ``floor``; or None. In front of the wall of index ``wall`` (0.3 m or
    more from it, parallel to it, across the line of a leg driven towards it) where that is not
    None and it fits there; else free inside the loop (``corners``), along x or y, where a leg
    passes it at normal incidence (the robot stops there and turns to it: the look point; the
    floor between them is kept clear); else in front of any wall."""
    width = grid(rng.uniform(0.9, 1.6))
    top = grid(rng.uniform(1.5, min(2.1, height - 0.3)))
    walls = floor.outline.walls
    tries = (["wall"] * 30 if wall is not None else []) + ["free"] * 60 + ["any wall"] * 30
    for kind in tries:
        look = None
        if kind == "free":
            cx, cy = floor.inside_loop(rng)
            hx, hy = (width / 2, PARTITION_DEPTH / 2)
            if rng.random() < 0.5:
                hx, hy = hy, hx
            rect = (grid(cx - hx), grid(cx + hx), grid(cy - hy), grid(cy + hy))
            look = look_at(corners, rect)
            if look is None:
                continue
        else:
            k = wall if kind == "wall" else int(rng.integers(len(walls)))
            room = insets[k] - CLEARANCE - MARGIN - PARTITION_DEPTH
            c = _near_lane(rng, floor, walls[k], width, 0.1)
            if c is None or room < 0.3:
                continue
            d = grid(rng.uniform(0.3, room))
            rect = walls[k].band((grid(c - width / 2), grid(c + width / 2)),
                                 (d, d + PARTITION_DEPTH))
        if floor.fits(rect, spacing=0.3):
            if look is not None:
                floor.keep_clear.append(_between(rect, look))
            return floor.take(rect), top, look
    return None


def _between(rect: Rect2, point) -> Rect2:
    """The plan rectangle swept by ``rect`` towards ``point`` (which lies across its thin side)."""
    return (min(rect[0], point[0]), max(rect[1], point[0]), min(rect[2], point[1]),
            max(rect[3], point[1]))


def draw_sun(rng: np.random.Generator, windows: list[Window]):
    """(direction of travel, irradiance [W/m^2]) of a sun shining in through one of the windows
    (azimuth within 50 deg of that wall's outward normal, 20-50 deg above the horizon, 0.7-1.2
    times the shipped sun's irradiance)."""
    wall = windows[rng.integers(len(windows))].wall
    out = np.degrees(np.arctan2(-wall.inward[1], -wall.inward[0]))
    az = np.radians(out + rng.uniform(-50.0, 50.0))
    el = np.radians(rng.uniform(20.0, 50.0))
    towards_sun = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    scale = rng.uniform(0.7, 1.2)
    return (tuple(round(float(v), 3) + 0.0 for v in -towards_sun),
            tuple(round(float(v) * scale, 3) for v in SUN_IRRADIANCE))
