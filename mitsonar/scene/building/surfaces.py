"""Plane surfaces with holes: an axis-aligned rectangle minus holes as non-overlapping
rectangles (:func:`rect_minus`), and vertical faces and horizontal surfaces (walls, floors,
ceilings) built from the pieces as Mitsuba rectangles."""

from __future__ import annotations

import numpy as np

from mitsonar.scene.building.shapes import TOL, Interval, Rect2, Shape, rectangle


def _complement(lo: float, hi: float, covered: list[Interval]) -> list[Interval]:
    """Parts of [lo, hi] not covered by the intervals."""
    free, at = [], lo
    for a, b in sorted(covered):
        if a > at + TOL:
            free.append((at, min(a, hi)))
        at = max(at, b)
    if hi > at + TOL:
        free.append((at, hi))
    return free


def rect_minus(outer: Rect2, holes: list[Rect2]) -> list[Rect2]:
    """Axis-aligned rectangle minus axis-aligned holes, as non-overlapping rectangles (u0, u1,
    v0, v1): strips along u cut at every hole edge, neighbouring strips with the same free v
    intervals merged. Deterministic order (u, then v)."""
    u0, u1, v0, v1 = outer
    clipped = [(max(a, u0), min(b, u1), max(c, v0), min(d, v1)) for a, b, c, d in holes]
    clipped = [h for h in clipped if h[1] > h[0] + TOL and h[3] > h[2] + TOL]
    cuts = sorted({u0, u1, *(h[0] for h in clipped), *(h[1] for h in clipped)})
    strips: list[tuple[float, float, list[Interval]]] = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        if b - a <= TOL:
            continue
        mid = 0.5 * (a + b)
        free = _complement(v0, v1, [(h[2], h[3]) for h in clipped if h[0] < mid < h[1]])
        if strips and strips[-1][2] == free and abs(strips[-1][1] - a) <= TOL:
            strips[-1] = (strips[-1][0], b, free)
        else:
            strips.append((a, b, free))
    return [(a, b, c, d) for a, b, free in strips for c, d in free]


def plan_axes(axis: str):
    """Unit vectors (along, across) of a wall running along world 'x' or 'y'."""
    if axis == "x":
        return np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    if axis == "y":
        return np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0])
    raise ValueError(f"wall axis must be 'x' or 'y', got {axis!r}")


def vertical_face(prefix: str, axis: str, across: float, s_range: Interval, z_range: Interval,
                  facing: int, material: str, role: str, holes: list[Rect2] = (),
                  group: str | None = None) -> list[Shape]:
    """A vertical face in the plane (across-coordinate = ``across``) of a wall running along
    ``axis``, spanning ``s_range`` along it and ``z_range`` in height, minus ``holes`` given as
    (s0, s1, z0, z1); normal towards +across (``facing=+1``) or -across (-1). Pieces are named
    prefix_1, prefix_2, ... (or just prefix if the face is whole); ``group`` defaults to prefix."""
    t, w = plan_axes(axis)
    z = np.array([0.0, 0.0, 1.0])
    pieces = rect_minus((*s_range, *z_range), list(holes))
    shapes = []
    for k, (s0, s1, z0, z1) in enumerate(pieces):
        centre = t * 0.5 * (s0 + s1) + w * across + z * 0.5 * (z0 + z1)
        hu, hv = t * 0.5 * (s1 - s0), z * 0.5 * (z1 - z0)
        if np.dot(np.cross(hu, hv), w) * facing < 0:
            hu, hv = hv, hu
        name = prefix if len(pieces) == 1 else f"{prefix}_{k + 1}"
        shapes.append(rectangle(name, centre, hu, hv, material, role, group or prefix))
    return shapes


def horizontal_surface(prefix: str, outer: Rect2, z: float, facing: int, material: str,
                       role: str, holes: list[Rect2] = (), group: str | None = None) -> list[Shape]:
    """A horizontal surface at height ``z`` over ``outer`` = (x0, x1, y0, y1) minus ``holes``,
    normal +z (``facing=+1``, floors) or -z (-1, ceilings)."""
    shapes = []
    pieces = rect_minus(outer, list(holes))
    for k, (x0, x1, y0, y1) in enumerate(pieces):
        hu, hv = np.array([0.5 * (x1 - x0), 0, 0]), np.array([0, 0.5 * (y1 - y0), 0])
        if facing < 0:
            hu, hv = hv, hu
        name = prefix if len(pieces) == 1 else f"{prefix}_{k + 1}"
        shapes.append(rectangle(name, (0.5 * (x0 + x1), 0.5 * (y0 + y1), z), hu, hv, material,
                                role, group or prefix))
    return shapes
