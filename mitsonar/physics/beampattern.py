"""Far-field beam patterns of planar arrays: element directivity times array factor.

All functions are vectorised over directions (any leading shape), steering directions and
elements; no Python loops over them (the PSLL evaluation only splits the steering directions into
blocks to bound memory). Directions are unit vectors in the array frame (array in XY, normal +z).

The array factor of element centres p_i steered to u_s, seen from direction u, is

    AF(u; u_s) = |sum_i exp(j k p_i . (u - u_s))| / N,

so it depends on u - u_s only (its projection on the array plane): the same lobe structure slides
over the direction-cosine plane as the beam is steered. The one-way pattern multiplies it with the
piston directivity D(u) of one element; the two-way (transmit x receive) pattern is the product of
the transmit and the receive one-way patterns, both steered to u_s (what a beamformed echo sees).

Side-lobe metrics. The main lobe of a beam steered to u_s is taken as the disc
|u_xy - u_s,xy| < sin(main_lobe_radius) in direction cosines (the region is the same for every
steering direction because the array factor only shifts). The peak side-lobe level (PSLL) is the
largest pattern value at directions inside the field of view outside that disc, relative to the
pattern at u_s.
"""

from __future__ import annotations

import numpy as np

from mitsonar.frames import direction_from_fov_angles, fov_angles
from mitsonar.physics.transducer import Transducer

#: Half-power level of an amplitude pattern (-3.01 dB).
HALF_POWER = 1 / np.sqrt(2)


def array_factor(positions, steer, directions, wavenumber: float) -> np.ndarray:
    """Normalised array factor |AF| in [0, 1].

    AF(u) = |sum_i exp(j k p_i . (u - u_s))| / N for element centres ``positions`` (N, 2|3) [m],
    steering direction ``steer`` (3,) (or any shape broadcastable against ``directions``),
    ``directions`` (..., 3), wavenumber k [rad/m]. For many steering directions over one grid,
    :func:`steered_array_factors` is much cheaper.
    """
    p = np.asarray(positions, dtype=float)
    p = p[:, :2]
    du = np.asarray(directions, dtype=float)[..., :2] - np.asarray(steer, dtype=float)[..., :2]
    phase = wavenumber * (du @ p.T)  # (..., N)
    return np.abs(np.exp(1j * phase).sum(axis=-1)) / len(p)


def steered_array_factors(positions, steers, directions, wavenumber: float) -> np.ndarray:
    """|AF| for every pair of steering direction and direction, by one matrix product.

    Args:
        positions: (N, 2|3) element centres [m].
        steers: (S, 3) steering directions.
        directions: (M, 3) directions.
        wavenumber: k [rad/m].

    Returns:
        (S, M) normalised array factors: AF(u_m; u_s) = |conj(E_s) . E_m| / N with
        E = exp(j k p . u) the (S|M, N) steering vectors.
    """
    p = np.asarray(positions, dtype=float)[:, :2]
    es = np.exp(-1j * wavenumber * (np.asarray(steers, dtype=float)[..., :2] @ p.T))
    ed = np.exp(1j * wavenumber * (np.asarray(directions, dtype=float)[..., :2] @ p.T))
    return np.abs(es @ ed.T) / len(p)


def one_way_pattern(positions, steer, directions, transducer: Transducer, wavenumber: float) -> np.ndarray:
    """Element directivity times array factor, (...,), peak 1 at broadside steering."""
    d = np.asarray(directions, dtype=float)
    return transducer.directivity(d[..., 2], wavenumber) * array_factor(positions, steer, d, wavenumber)


def two_way_pattern(tx_positions, rx_positions, steer, directions, transducer: Transducer,
                    wavenumber: float) -> np.ndarray:
    """Transmit pattern times receive pattern, both steered to ``steer`` (what an echo sees)."""
    return (one_way_pattern(tx_positions, steer, directions, transducer, wavenumber)
            * one_way_pattern(rx_positions, steer, directions, transducer, wavenumber))


def steered_patterns(positions, steers, directions, transducer: Transducer, wavenumber: float,
                     rx_positions=None) -> np.ndarray:
    """One-way (or, with ``rx_positions``, two-way) amplitude patterns, (S, M).

    Row s is the pattern of the beam steered to ``steers[s]`` (S, 3) at ``directions`` (M, 3):
    D(u) AF_tx(u; u_s), times D(u) AF_rx(u; u_s) for the two-way pattern.
    """
    d = np.asarray(directions, dtype=float)
    elem = transducer.directivity(d[..., 2], wavenumber)
    out = elem * steered_array_factors(positions, steers, d, wavenumber)
    if rx_positions is not None:
        out *= elem * steered_array_factors(rx_positions, steers, d, wavenumber)
    return out


def main_lobe_width(angles, pattern, level: float = HALF_POWER) -> float:
    """Full width [same unit as ``angles``] of the lobe around the maximum of a 1-D cut.

    The crossings of ``level`` times the peak on either side of the maximum are found by linear
    interpolation. For an amplitude pattern the default level (1/sqrt 2) is the 3 dB width.
    Raises ValueError when the lobe does not fall below the level inside the cut.
    """
    width = main_lobe_widths(angles, np.asarray(pattern, dtype=float)[None, :], level)[0]
    if not np.isfinite(width):
        raise ValueError("the main lobe does not fall below the requested level inside the cut")
    return float(width)


def main_lobe_widths(angles, patterns, level: float = HALF_POWER) -> np.ndarray:
    """Batched :func:`main_lobe_width` along the last axis; NaN where a lobe does not fall below
    ``level`` times its peak inside the cut.

    Args:
        angles: (..., K) or (K,) increasing angles of the cuts.
        patterns: (..., K) amplitude patterns.
        level: crossing level relative to each cut's peak.

    Returns:
        (...,) full widths [unit of ``angles``].
    """
    p = np.asarray(patterns, dtype=float)
    a = np.broadcast_to(np.asarray(angles, dtype=float), p.shape)
    k = p.shape[-1]
    idx = np.arange(k)
    peak = np.argmax(p, axis=-1)[..., None]
    target = level * np.take_along_axis(p, peak, axis=-1)
    below = p < target
    left = np.max(np.where(below & (idx < peak), idx, -1), axis=-1)[..., None]
    right = np.min(np.where(below & (idx > peak), idx, k), axis=-1)[..., None]
    ok = (left >= 0) & (right < k)
    l0 = np.clip(left, 0, k - 2)
    r0 = np.clip(right, 1, k - 1)

    def crossing(i0, i1):
        p0, p1 = np.take_along_axis(p, i0, -1), np.take_along_axis(p, i1, -1)
        a0, a1 = np.take_along_axis(a, i0, -1), np.take_along_axis(a, i1, -1)
        t = (target - p0) / np.where(p1 != p0, p1 - p0, 1.0)
        return a0 + t * (a1 - a0)

    width = crossing(r0, r0 - 1) - crossing(l0, l0 + 1)
    return np.where(ok, width, np.nan)[..., 0]

def fov_grid(fov_horizontal: float, fov_vertical: float, step: float):
    """Regular grid of field-of-view angles including the edges.

    Args:
        fov_horizontal, fov_vertical: full field of view [rad].
        step: grid step [rad]; the edges are always included (the last step may be shorter).

    Returns:
        horizontal (H,) and vertical (V,) angles [rad] and the directions (V, H, 3).
    """
    def axis(full):
        n = int(np.ceil(full / step - 1e-9))
        return np.linspace(-full / 2, full / 2, n + 1)

    h, v = axis(fov_horizontal), axis(fov_vertical)
    hh, vv = np.meshgrid(h, v, indexing="xy")
    return h, v, direction_from_fov_angles(hh, vv)


def in_fov(directions, fov_horizontal: float, fov_vertical: float) -> np.ndarray:
    """Boolean (...,): directions (..., 3) inside the (closed) field of view, in front (z > 0)."""
    u = np.asarray(directions, dtype=float)
    h, v = fov_angles(u)
    return (np.abs(h) <= fov_horizontal / 2 + 1e-9) & (np.abs(v) <= fov_vertical / 2 + 1e-9) \
        & (u[..., 2] > 0)


def peak_side_lobe_levels(positions, steers, directions, transducer: Transducer, wavenumber: float,
                          main_lobe_radius: float, rx_positions=None,
                          block_size: int = 4_000_000) -> np.ndarray:
    """Peak side-lobe level of the beam steered to each of ``steers``, as an amplitude ratio.

    PSLL(u_s) = max over the ``directions`` outside the main-lobe disc of P(u; u_s) / P(u_s; u_s),
    with P the one-way (two-way with ``rx_positions``) pattern of :func:`steered_patterns`.
    Pass the directions of a fine grid over the field of view to get the PSLL "inside the FOV".

    Args:
        positions: (N, 2|3) (transmit) element centres [m].
        steers: (S, 3) steering directions.
        directions: (M, 3) directions searched for side lobes.
        transducer: element model (directivity).
        wavenumber: k [rad/m].
        main_lobe_radius: angular radius of the excluded main lobe [rad] (as sin in direction
            cosines, see the module docstring).
        rx_positions: (N_rx, 2|3) receive element centres for the two-way PSLL.
        block_size: largest S x M block evaluated at once (memory bound only).

    Returns:
        (S,) PSLL as a ratio (20 log10 for dB); 0 if no direction lies outside the main lobe.
    """
    if rx_positions is None:
        return pair_side_lobe_levels(positions, positions, steers, directions, transducer,
                                     wavenumber, main_lobe_radius, block_size)["tx"]
    return pair_side_lobe_levels(positions, rx_positions, steers, directions, transducer,
                                 wavenumber, main_lobe_radius, block_size)["two_way"]


def pair_side_lobe_levels(tx_positions, rx_positions, steers, directions, transducer: Transducer,
                          wavenumber: float, main_lobe_radius: float,
                          block_size: int = 4_000_000) -> dict:
    """:func:`peak_side_lobe_levels` of the transmit, the receive and the two-way pattern at once
    (the array factors are computed once and shared).

    Returns:
        {'tx': (S,), 'rx': (S,), 'two_way': (S,)} PSLL as amplitude ratios.
    """
    s = np.asarray(steers, dtype=float).reshape(-1, 3)
    d = np.asarray(directions, dtype=float).reshape(-1, 3)
    r2 = np.sin(main_lobe_radius) ** 2
    elem = transducer.directivity(d[:, 2], wavenumber)
    peak = transducer.directivity(s[:, 2], wavenumber)
    per_block = max(1, block_size // max(len(d), 1))
    out = {name: np.empty(len(s)) for name in ("tx", "rx", "two_way")}
    for start in range(0, len(s), per_block):  # blocks of steering directions: memory only
        blk = slice(start, start + per_block)
        outside = np.sum((d[None, :, :2] - s[blk, None, :2]) ** 2, axis=-1) >= r2
        tx = elem * steered_array_factors(tx_positions, s[blk], d, wavenumber) * outside
        rx = elem * steered_array_factors(rx_positions, s[blk], d, wavenumber) * outside
        out["tx"][blk] = tx.max(axis=1) / peak[blk]
        out["rx"][blk] = rx.max(axis=1) / peak[blk]
        out["two_way"][blk] = (tx * rx).max(axis=1) / peak[blk] ** 2
    return out


def cut_directions(steers, half_span: float, count: int):
    """Horizontal and vertical cuts of field-of-view angles through each steering direction.

    Args:
        steers: (S, 3) steering directions.
        half_span: half length of each cut [rad].
        count: samples per cut.

    Returns:
        angles (S, 2, K) [rad] (the horizontal angle along cut 0, the vertical along cut 1) and
        the directions (S, 2, K, 3).
    """
    s = np.asarray(steers, dtype=float).reshape(-1, 3)
    hs, vs = fov_angles(s)
    offset = np.linspace(-half_span, half_span, count)
    h = np.stack([hs[:, None] + offset, np.broadcast_to(hs[:, None], (len(s), count))], axis=1)
    v = np.stack([np.broadcast_to(vs[:, None], (len(s), count)), vs[:, None] + offset], axis=1)
    return np.stack([h[:, 0], v[:, 1]], axis=1), direction_from_fov_angles(h, v)


def cut_widths(positions, steers, transducer: Transducer, wavenumber: float, half_span: float,
               count: int = 401, rx_positions=None) -> np.ndarray:
    """3 dB widths of steered beams along the horizontal and vertical field-of-view angles.

    For each steering direction the pattern is sampled along the horizontal angle (vertical angle
    fixed) and along the vertical angle (horizontal fixed) through the steering direction, over
    +-``half_span`` [rad] with ``count`` samples (:func:`cut_directions`), and
    :func:`main_lobe_widths` measures the lobe.

    Args:
        positions: (N, 2|3) (transmit) element centres [m].
        steers: (S, 3) steering directions.
        rx_positions: receive element centres for the two-way width (optional).

    Returns:
        (S, 2) widths [rad]: column 0 horizontal, column 1 vertical (NaN if the cut is too short).
    """
    angles, u = cut_directions(steers, half_span, count)
    steer = np.asarray(steers, dtype=float).reshape(-1, 3)[:, None, None, :]
    pattern = one_way_pattern(positions, steer, u, transducer, wavenumber)
    if rx_positions is not None:
        pattern = pattern * one_way_pattern(rx_positions, steer, u, transducer, wavenumber)
    return main_lobe_widths(angles, pattern)
