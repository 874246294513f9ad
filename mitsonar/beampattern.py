"""Far-field beam patterns of planar arrays: element directivity times array factor.

All functions are vectorised over directions (any leading shape) and elements; no Python loops.
Directions are unit vectors in the array frame (array in XY, normal +z).
"""

from __future__ import annotations

import numpy as np

from .frames import direction_from_fov_angles
from .transducer import Transducer


def array_factor(positions, steer, directions, wavenumber: float) -> np.ndarray:
    """Normalised array factor |AF| in [0, 1].

    AF(u) = |sum_i exp(j k p_i . (u - u_s))| / N for element centres ``positions`` (N, 2|3) [m],
    steering direction ``steer`` (3,), ``directions`` (..., 3), wavenumber k [rad/m].
    """
    p = np.asarray(positions, dtype=float)
    p = p[:, :2]
    du = np.asarray(directions, dtype=float)[..., :2] - np.asarray(steer, dtype=float)[:2]
    phase = wavenumber * (du @ p.T)  # (..., N)
    return np.abs(np.exp(1j * phase).sum(axis=-1)) / len(p)


def one_way_pattern(positions, steer, directions, transducer: Transducer, wavenumber: float) -> np.ndarray:
    """Element directivity times array factor, (...,), peak 1 at broadside steering."""
    d = np.asarray(directions, dtype=float)
    return transducer.directivity(d[..., 2], wavenumber) * array_factor(positions, steer, d, wavenumber)


def two_way_pattern(tx_positions, rx_positions, steer, directions, transducer: Transducer,
                    wavenumber: float) -> np.ndarray:
    """Transmit pattern times receive pattern, both steered to ``steer`` (what an echo sees)."""
    return (one_way_pattern(tx_positions, steer, directions, transducer, wavenumber)
            * one_way_pattern(rx_positions, steer, directions, transducer, wavenumber))


def main_lobe_width(angles, pattern, level: float = 1 / np.sqrt(2)) -> float:
    """Full width [same unit as ``angles``] of the lobe around the maximum of a 1-D cut.

    The crossings of ``level`` times the peak on either side of the maximum are found by linear
    interpolation. For an amplitude pattern the default level (1/sqrt 2) is the 3 dB width.
    Raises ValueError when the lobe does not fall below the level inside the cut.
    """
    a = np.asarray(angles, dtype=float)
    p = np.asarray(pattern, dtype=float)
    i = int(np.argmax(p))
    target = level * p[i]
    below = p < target
    left = np.nonzero(below[:i])[0]
    right = np.nonzero(below[i:])[0]
    if len(left) == 0 or len(right) == 0:
        raise ValueError("the main lobe does not fall below the requested level inside the cut")
    l0 = left[-1]
    r0 = i + right[0]
    a_left = np.interp(target, [p[l0], p[l0 + 1]], [a[l0], a[l0 + 1]])
    a_right = np.interp(target, [p[r0], p[r0 - 1]], [a[r0], a[r0 - 1]])
    return float(a_right - a_left)


def horizontal_cut(steer_horizontal: float, half_span: float, count: int,
                   vertical: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Horizontal angles [rad] (count,) around ``steer_horizontal`` and their directions (count, 3)."""
    h = steer_horizontal + np.linspace(-half_span, half_span, count)
    return h, direction_from_fov_angles(h, np.full_like(h, vertical))
