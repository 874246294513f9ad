"""Plans of the varied rooms (:mod:`mitsonar.scene.varied`): a rectangular or L-shaped outline,
the robot's loop inside it at a drawn distance from each wall, and the free floor where glass
partitions and furniture may stand (clear of the loop and of the views kept open).

Plan rectangles are (x0, x1, y0, y1) [m]; a segment is a rectangle of zero width. A room is
planned with its south-west corner at the origin and drawn lengths on a 5 cm grid (:func:`grid`),
so the written numbers are short; :mod:`mitsonar.scene.varied` then moves it so that the loop's
start is the world origin (the robot there faces +x and the wall ahead, as in the shipped
scenes).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mitsonar.scene.building.shapes import Interval, Rect2

#: Tolerance of plan comparisons [m] (sums of grid values are not exact in binary).
TOL = 1e-6

#: Grid of drawn lengths and positions [m].
GRID = 0.05
#: Least distance [m] from the robot's path (chassis centre) to any wall or object footprint.
CLEARANCE = 0.8
#: What the generator keeps beyond CLEARANCE [m] (footprints are rounded, blocks snapped).
MARGIN = 0.05
#: Shortest leg of the loop [m].
MIN_LEG = 1.0
#: Distance of the loop from each wall [m]: at least this, plus a drawn depth for furniture.
MIN_INSET = 0.9
#: Offsets [m] of the loop's lines (x of the legs along y, y of the legs along x) from the GRID
#: that walls, windows and furniture lie on: no waypoint is then in line with, or on a 45 deg
#: diagonal from, any of their vertical edges, where a ray could slip between two rectangles.
LOOP_PHASE = (0.01, 0.02)
#: Inward normal of a wall -> the compass side of the room it lines.
_SIDE = {(0, 1): "south", (-1, 0): "east", (0, -1): "north", (1, 0): "west"}


def grid(v: float) -> float:
    """``v`` rounded to the GRID (and to 1e-9, so sums of grid values print short)."""
    return round(round(float(v) / GRID) * GRID, 9) + 0.0


def exact(v: float) -> float:
    """``v`` rounded to 1e-9 m (sums and differences of cm values print short)."""
    return round(float(v), 9) + 0.0


def gap(a: Rect2, b: Rect2) -> float:
    """Plan distance [m] between two rectangles (0 where they touch or overlap)."""
    dx = max(0.0, a[0] - b[1], b[0] - a[1])
    dy = max(0.0, a[2] - b[3], b[2] - a[3])
    return float(np.hypot(dx, dy))


def overlaps(a: Rect2, b: Rect2) -> bool:
    """True where the interiors of two rectangles overlap."""
    return a[0] < b[1] and b[0] < a[1] and a[2] < b[3] and b[2] < a[3]


def segment(a, b) -> Rect2:
    """The plan segment from point a to b as a rectangle."""
    return (min(a[0], b[0]), max(a[0], b[0]), min(a[1], b[1]), max(a[1], b[1]))


def moved(rect: Rect2, dx: float, dy: float) -> Rect2:
    """``rect`` moved by (dx, dy) [m]."""
    return (exact(rect[0] + dx), exact(rect[1] + dx), exact(rect[2] + dy), exact(rect[3] + dy))


@dataclass(frozen=True)
class Wall:
    """An edge of the outline from ``start`` to ``end`` [m], counter-clockwise (the room on its
    left). ``side`` is the outer wall it lies on ('south', 'east', 'north', 'west'), or None
    for a face of the corner block that cuts an L."""

    start: tuple[float, float]
    end: tuple[float, float]
    side: str | None

    @property
    def direction(self) -> tuple[int, int]:
        """Unit direction (+-1, 0) or (0, +-1) from start to end."""
        dx, dy = self.end[0] - self.start[0], self.end[1] - self.start[1]
        return (int(np.sign(dx)), int(np.sign(dy)))

    @property
    def inward(self) -> tuple[int, int]:
        """Unit normal into the room (left of the direction)."""
        dx, dy = self.direction
        return (-dy, dx)

    @property
    def facing(self) -> str:
        """Compass side of the room this wall lines ('north': the room's north wall)."""
        return _SIDE[self.inward]

    @property
    def axis(self) -> str:
        """World axis the wall runs along, 'x' or 'y'."""
        return "x" if self.direction[1] == 0 else "y"

    @property
    def across(self) -> float:
        """The wall face's constant coordinate (y for an 'x' wall) [m]."""
        return self.start[1] if self.axis == "x" else self.start[0]

    @property
    def span(self) -> Interval:
        """(lo, hi) of the coordinate along the wall [m]."""
        k = 0 if self.axis == "x" else 1
        return (min(self.start[k], self.end[k]), max(self.start[k], self.end[k]))

    @property
    def length(self) -> float:
        """Length of the wall's face [m]."""
        return self.span[1] - self.span[0]

    def rect(self) -> Rect2:
        """The wall face as a plan segment."""
        return segment(self.start, self.end)

    def band(self, s: Interval, depth: Interval) -> Rect2:
        """Plan rectangle over ``s`` along the wall, from ``depth[0]`` to ``depth[1]`` [m] in
        front of its face."""
        c = self.across
        sign = self.inward[1] if self.axis == "x" else self.inward[0]
        a, b = sorted((grid(c + sign * depth[0]), grid(c + sign * depth[1])))
        return (*s, a, b) if self.axis == "x" else (a, b, *s)


@dataclass(frozen=True)
class Outline:
    """The room's plan: the rectangle ``outer`` (x0, x1, y0, y1) [m], less ``block`` (the
    corner cut off an L, built as a thick interior wall) where there is one; ``walls`` run
    counter-clockwise from the south-west corner (the first is the south wall); ``rooms`` are
    (id, plan rectangle) covering the floor."""

    outer: Rect2
    block: Rect2 | None
    walls: tuple[Wall, ...]
    rooms: tuple[tuple[str, Rect2], ...]

    def contains(self, rect: Rect2) -> bool:
        """True where ``rect`` lies on the room's floor."""
        x0, x1, y0, y1 = self.outer
        inside = x0 <= rect[0] and rect[1] <= x1 and y0 <= rect[2] and rect[3] <= y1
        return inside and (self.block is None or not overlaps(rect, self.block))

    def shifted(self, dx: float, dy: float) -> Outline:
        """The outline moved by (dx, dy) [m]."""
        def pt(p):
            return (exact(p[0] + dx), exact(p[1] + dy))

        return Outline(moved(self.outer, dx, dy),
                       None if self.block is None else moved(self.block, dx, dy),
                       tuple(Wall(pt(w.start), pt(w.end), w.side) for w in self.walls),
                       tuple((rid, moved(r, dx, dy)) for rid, r in self.rooms))


def draw_outline(rng: np.random.Generator, l_shape_p: float = 0.4) -> Outline:
    """A plan 4-9 m x 3.5-7 m with its south-west corner at the origin; with probability
    ``l_shape_p`` (rooms at least 5 m x 4.5 m) an L: its north-east or north-west corner, 1.2 m
    or more each way, is cut off, leaving both arms at least 3 m wide."""
    w, d = grid(rng.uniform(4.0, 9.0)), grid(rng.uniform(3.5, 7.0))
    outer = (0.0, w, 0.0, d)
    if w < 5.0 or d < 4.5 or rng.random() >= l_shape_p:
        corners = [(0.0, 0.0), (w, 0.0), (w, d), (0.0, d)]
        sides = ["south", "east", "north", "west"]
        return Outline(outer, None, _walls(corners, sides), (("room", outer),))
    cw = grid(rng.uniform(1.2, min(0.5 * w, w - 3.0)))
    cd = grid(rng.uniform(1.2, min(0.5 * d, d - 3.0)))
    xc, yc = (grid(w - cw), grid(d - cd))
    if rng.random() < 0.5:  # north-east corner cut
        corners = [(0.0, 0.0), (w, 0.0), (w, yc), (xc, yc), (xc, d), (0.0, d)]
        sides = ["south", "east", None, None, "north", "west"]
        block, wing = (xc, w, yc, d), (0.0, xc, yc, d)
    else:  # north-west corner cut
        xc = grid(cw)
        corners = [(0.0, 0.0), (w, 0.0), (w, d), (xc, d), (xc, yc), (0.0, yc)]
        sides = ["south", "east", "north", None, None, "west"]
        block, wing = (0.0, xc, yc, d), (xc, w, yc, d)
    rooms = (("main", (0.0, w, 0.0, yc)), ("wing", wing))
    return Outline(outer, block, _walls(corners, sides), rooms)


def _walls(corners, sides) -> tuple[Wall, ...]:
    return tuple(Wall(a, corners[(k + 1) % len(corners)], s)
                 for k, (a, s) in enumerate(zip(corners, sides)))


def _line(wall: Wall, inset: float) -> float:
    """Coordinate [m] of the loop's line ``inset`` [m] in front of ``wall`` (on the GRID), moved
    on by less than GRID onto its LOOP_PHASE."""
    sign = wall.inward[1] if wall.axis == "x" else wall.inward[0]
    cm = round(100 * (wall.across + sign * inset))
    phase = round(100 * LOOP_PHASE[1 if wall.axis == "x" else 0])
    step = round(100 * GRID)
    return (cm + sign * ((sign * (phase - cm)) % step)) / 100


def loop_corners(outline: Outline, insets) -> list[tuple[float, float]] | None:
    """Corners of the loop whose k-th leg runs along wall k, ``insets[k]`` [m] (each at least
    MIN_INSET; a few cm more, see LOOP_PHASE) in front of it (corner k where legs k-1 and k
    meet), or None where a leg would be shorter than MIN_LEG, run against its wall or come
    nearer than MIN_INSET to another wall."""
    walls = outline.walls
    lines = [_line(w, d) for w, d in zip(walls, insets)]
    corners = []
    for k, w in enumerate(walls):
        prev = lines[k - 1]
        corners.append((prev, lines[k]) if w.axis == "x" else (lines[k], prev))
    for k, w in enumerate(walls):
        a, b = corners[k], corners[(k + 1) % len(corners)]
        step = (b[0] - a[0], b[1] - a[1])
        if np.dot(step, w.direction) < MIN_LEG:
            return None
        if any(gap(segment(a, b), other.rect()) < MIN_INSET - TOL for other in walls):
            return None
    return corners


def draw_insets(rng: np.random.Generator, outline: Outline) -> list[float]:
    """Least distance [m] of the loop from each wall before furniture asks for more: MIN_INSET,
    plus up to 0.6 m on about half of the walls."""
    return [grid(MIN_INSET + (rng.uniform(0.0, 0.6) if rng.random() < 0.5 else 0.0))
            for _ in outline.walls]


def loop_legs(corners) -> list[Rect2]:
    """The loop's legs as plan segments."""
    return [segment(a, b) for a, b in zip(corners, corners[1:] + corners[:1])]


def _direction(a, b) -> np.ndarray:
    """Unit direction (2,) from plan point a to b."""
    d = np.subtract(b, a, dtype=float)
    return d / np.linalg.norm(d)


def loop_trajectory(corners, start, looks=()) -> list[tuple[float, float, float]]:
    """Waypoints (x, y, yaw [deg]) once round the loop from ``start`` on its first leg (facing
    +x, the wall ahead): drive to each corner facing the wall ahead, turn on the spot towards
    the next leg (+90 deg, or -90 at the inner corner of an L), and back to ``start``. At each
    of ``looks``, points on the legs, the robot stops, turns left by 90 deg to face something
    inside the loop and turns back."""
    n = len(corners)
    stops = [start] + [corners[k % n] for k in range(1, n + 1)] + [start]
    yaw = 0.0
    out = [(start[0], start[1], yaw)]
    for k, (a, b) in enumerate(zip(stops[:-1], stops[1:])):
        d = _direction(a, b)
        along = [(float(np.dot(np.subtract(p, a), d)), p) for p in looks
                 if abs(d[0] * (p[1] - a[1]) - d[1] * (p[0] - a[0])) < TOL]
        for _, p in sorted(t for t in along if TOL < t[0] < np.dot(np.subtract(b, a), d) - TOL):
            out += [(p[0], p[1], yaw), (p[0], p[1], yaw + 90.0), (p[0], p[1], yaw)]
        out.append((b[0], b[1], yaw))
        if k < n:
            d_out = _direction(b, corners[(k + 2) % n])
            yaw += 90.0 * float(np.sign(d[0] * d_out[1] - d[1] * d_out[0]))
            out.append((b[0], b[1], yaw))
    return out


def look_at(corners, rect: Rect2) -> tuple[float, float] | None:
    """A point on the loop from which the robot, turned left by 90 deg, faces the pane over the
    plan rectangle ``rect`` (thin across its longer axis) at normal incidence: the foot of the
    perpendicular from the pane's centre on the nearest leg parallel to the pane that has the
    pane on its left and meets that perpendicular 0.3 m or more from its ends; None if none."""
    along_x = rect[1] - rect[0] >= rect[3] - rect[2]
    c = np.array([0.5 * (rect[0] + rect[1]), 0.5 * (rect[2] + rect[3])])
    best, point = np.inf, None
    for a, b in zip(corners, corners[1:] + corners[:1]):
        d = _direction(a, b)
        if (abs(d[0]) > 0.5) != along_x:
            continue
        t = float(np.dot(c - a, d))
        side = d[0] * (c[1] - a[1]) - d[1] * (c[0] - a[0])  # > 0: on the left
        if side > 0 and 0.3 <= t <= np.dot(np.subtract(b, a), d) - 0.3 and side < best:
            best, point = side, (exact(a[0] + t * d[0]), exact(a[1] + t * d[1]))
    return point


@dataclass
class FreeFloor:
    """Where furniture may still stand: on the room's floor, CLEARANCE + MARGIN from every leg
    of the loop, outside the ``keep_clear`` rectangles and ``spacing`` [m] from what stands."""

    outline: Outline
    legs: list[Rect2]
    keep_clear: list[Rect2] = field(default_factory=list)
    taken: list[Rect2] = field(default_factory=list)

    def fits(self, rect: Rect2, spacing: float = 0.1) -> bool:
        """True where ``rect`` may stand."""
        return (self.outline.contains(rect)
                and all(gap(rect, leg) >= CLEARANCE + MARGIN - TOL for leg in self.legs)
                and not any(overlaps(rect, k) for k in self.keep_clear)
                and all(gap(rect, t) >= spacing - TOL for t in self.taken))

    def take(self, rect: Rect2) -> Rect2:
        """Mark ``rect`` as taken and return it."""
        self.taken.append(rect)
        return rect

    def inside_loop(self, rng: np.random.Generator) -> tuple[float, float]:
        """A grid point drawn uniformly in the loop's bounding box [m]."""
        x0, x1 = min(r[0] for r in self.legs), max(r[1] for r in self.legs)
        y0, y1 = min(r[2] for r in self.legs), max(r[3] for r in self.legs)
        return grid(rng.uniform(x0, x1)), grid(rng.uniform(y0, y1))

    def facing_legs(self, wall: Wall) -> list[tuple[float, float]]:
        """(lane, distance) of each leg driven towards ``wall`` whose line meets it: the leg's
        coordinate along the wall, and its start's distance from the wall [m]."""
        out = []
        outward = (-wall.inward[0], -wall.inward[1])
        for leg_wall, leg in zip(self.outline.walls, self.legs):
            if leg_wall.direction != outward:
                continue
            if wall.axis == "x":  # the leg runs along y at x = lane
                lane, start = leg[0], leg[2] if outward[1] > 0 else leg[3]
            else:
                lane, start = leg[2], leg[0] if outward[0] > 0 else leg[1]
            if wall.span[0] < lane < wall.span[1]:
                out.append((lane, abs(wall.across - start)))
        return out
