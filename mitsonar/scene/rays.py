"""Mitsuba ray batches from NumPy arrays, for every stage that casts rays in a loaded scene."""

from __future__ import annotations

import numpy as np

from mitsonar.jit import to_jit
from mitsonar.scene.loading import mitsuba


def rays(origins, directions, max_distance=None):
    """A Mitsuba ``Ray3f`` batch from origins (N, 3) or one origin (3,) and unit directions
    (N, 3) [m], world frame; ``max_distance`` (N,) [m] optional. Inputs are copied aligned
    (:func:`to_jit`)."""
    mi = mitsuba()
    d = np.asarray(directions, dtype=float).reshape(-1, 3)
    o = np.broadcast_to(np.asarray(origins, dtype=float), d.shape)
    point = mi.Point3f(*[to_jit(mi.Float, o[:, k]) for k in range(3)])
    vector = mi.Vector3f(*[to_jit(mi.Float, d[:, k]) for k in range(3)])
    if max_distance is None:
        return mi.Ray3f(point, vector)
    return mi.Ray3f(point, vector, to_jit(mi.Float, max_distance), mi.Float(0.0), [])
