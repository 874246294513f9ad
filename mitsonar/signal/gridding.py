"""Gridding kernels of the fast synthesis (:mod:`mitsonar.signal.synthesis`): Dr.Jit kernels
that spread paths with a Gaussian kernel onto fixed-point sample grids, frozen once per shape and
replayed, and the conversion of their fixed-point rows into complex grids.
"""

from __future__ import annotations

from functools import cache

import numpy as np

from mitsonar.jit import backend, freeze
from mitsonar.trace.hitpaths import pair_gain

#: The gridding kernels add into a copy of the grid per core, merged after (Dr.Jit's Expand
#: reduction), each tap's (re, im) as one packet of two adjacent integers: measured on one beam's
#: 4e5-1.9e6 element pairs (20 kHz transducers, 25 x 8 600 samples) 5x faster than two scatters
#: per tap and 20x faster than atomic adds into one grid. The copies cost a grid's memory per
#: core (3.4 MB for a broadband OFDM beam's 25 channels); Dr.Jit's CUDA backend adds atomically.
GRID_REDUCE = "Expand"

def spread(acc, pos, row, gain, first_order, rotation, half_width: int, inv_var: float,
            rate_inv_var: float, active=True):
    """Inside a gridding kernel: add paths at positions ``pos`` [samples, Float64] with the
    Gaussian kernel onto the Int64 fixed-point grid ``acc`` of interleaved (re, im) samples, at
    sample ``row + floor(pos) + k`` for taps k in -half_width .. half_width (``row``: the path's
    row start minus the row's first sample, :meth:`~mitsonar.signal.synthesis.EchoSynthesizer._window`).

    ``gain`` (re, im) is in grid units; ``first_order`` None or (re, im, carrier - f_d [rad/s])
    (kernel derivative, see :meth:`~mitsonar.signal.synthesis.EchoSynthesizer.impulse_grid`); ``rotation`` None or the
    shift f_d [cycles per sample] to demodulate gains and first-order terms by
    exp(-j 2 pi f_d pos); ``active`` masks paths out.
    """
    import drjit as dr
    Float64, Int64, UInt32 = backend().Float64, backend().Int64, backend().UInt32
    Array2i64 = backend().Array2i64

    if rotation is not None:
        cycles = rotation * pos
        sin, cos = dr.sincos(-2 * np.pi * (cycles - dr.floor(cycles)))  # exp(-j 2 pi f_d tau)

        def rotated(re, im):
            return re * cos - im * sin, re * sin + im * cos

        gain = rotated(*gain)
        if first_order is not None:
            first_order = rotated(*first_order[:2]) + (first_order[2],)
    base = Int64(dr.floor(pos))
    frac = pos - Float64(base)  # in [0, 1)
    # Fast Gaussian gridding: g(k - frac) = exp(-k^2 / 2 sigma^2) exp(k frac / sigma^2)
    # exp(-frac^2 / 2 sigma^2): two exponentials per path serve every tap k (powers of
    # exp(frac / sigma^2) by multiplication; relative rounding ~1e-15 per tap).
    common = dr.exp(-0.5 * inv_var * dr.square(frac))
    growth = dr.exp(inv_var * frac)
    power = {0: common}
    for k in range(1, half_width + 1):
        power[k] = power[k - 1] * growth
        power[-k] = power[1 - k] / growth
    mode = getattr(dr.ReduceMode, GRID_REDUCE)
    for k in range(-half_width, half_width + 1):  # kernel taps (a fixed, small count)
        weight = power[k] * float(np.exp(-0.5 * k * k * inv_var))
        value_re, value_im = gain
        if first_order is not None:  # b (j omega + fs x / sigma^2), x = k - frac
            slope_re, slope_im, omega = first_order
            x = rate_inv_var * (k - frac)
            value_re = value_re + slope_re * x - slope_im * omega
            value_im = value_im + slope_im * x + slope_re * omega
        dr.scatter_reduce(dr.ReduceOp.Add, acc, Array2i64(Int64(dr.round(weight * value_re)),
                                                          Int64(dr.round(weight * value_im))),
                          UInt32(row + base + k), active=active, mode=mode)


@cache
def spread_kernel():
    """The gridding kernel of :meth:`~mitsonar.signal.synthesis.EchoSynthesizer.impulse_grid` for flat :class:`~mitsonar.trace.paths.Paths`,
    frozen (``drjit.freeze``): traced once per kernel shape, then replayed without Python tracing
    whatever the path count.

    Arguments: the flat grid's size, positions (M,) [samples], row offsets (M,) (of ``spread``),
    (re, im) gains, None or (re, im, carrier - f_d [rad/s]) of the first-order terms,
    the shift f_d [cycles per sample], half_width [taps], 1/sigma^2, fs/sigma^2, a mask of the
    paths to spread (or True). Returns the Int64 grid of interleaved (re, im). (Each grid size
    is a separate recording: the grids are made inside, as scatter targets passed in would be
    replayed at the recorded size.)
    """
    import drjit as dr
    Int64 = backend().Int64

    def grid(size, pos, row, gain, first_order, shift, half_width, inv_var, rate_inv_var,
             active):
        acc = dr.zeros(Int64, 2 * size)
        spread(acc, pos, row, gain, first_order, shift, half_width, inv_var, rate_inv_var,
                active)
        return acc

    # One recording per grid size and kernel shape (a few per synthesizer; sessions that build
    # several synthesizers, e.g. fidelity levels and OFDM, make dozens): not a re-tracing fault.
    return freeze(grid, warn_after=256)


@cache
def pair_kernel():
    """The gridding kernel of :meth:`~mitsonar.signal.synthesis.EchoSynthesizer.impulse_grid` for factored
    :class:`~mitsonar.trace.hitpaths.HitPaths`, frozen: one thread per (patch, receive element)
    forms the gains of its N_tx element pairs from the factors (:func:`pair_gain`, single
    precision) and spreads them, so the H x N_tx x N_rx pairs never exist as arrays.

    Arguments: the flat grid's size, thread indices 0 .. H x N_rx - 1, the 7 transmit and 7
    receive factors, or 2 and 2 without a specular term (:meth:`HitPaths.kernel_factors`,
    already demodulated and in grid units; each layout a recording of its own),
    transmit positions (H x N_tx,) and receive offsets (H x N_rx,) [samples] (a pair's position
    is their sum), N_tx, N_rx, each patch's row length and the flat index of its rows' sample 0
    (H,) (several path sets, each on rows of its own, share a launch), half_width, 1/sigma^2,
    the recording's sample count, and the offset between transmit elements' rows (0: a row per
    receive element; N_rx x the row length: a row per element pair, transmit element major).
    Returns the Int64 grid of interleaved (re, im).
    """
    import drjit as dr
    Float32, Float64, Int64 = backend().Float32, backend().Float64, backend().Int64

    def spread_pairs(size, thread, tx, rx, tx_pos, rx_pos, n_tx, n_rx, stride, row_offset,
                     half_width, inv_var, n_samples, element_stride):
        acc = dr.zeros(Int64, 2 * size)
        patch = thread // n_rx
        row = Int64(thread - patch * n_rx) * dr.gather(Int64, stride, patch) \
            + dr.gather(Int64, row_offset, patch)
        rx_values = [dr.gather(Float32, x, thread) for x in rx]
        rx_u = dr.gather(Float64, rx_pos, thread)
        for i in range(n_tx):  # the patch's transmit elements (unrolled)
            tx_values = [dr.gather(Float32, x, patch * n_tx + i) for x in tx]
            gain = tuple(Float64(g) for g in pair_gain(tx_values, rx_values))
            pos = dr.gather(Float64, tx_pos, patch * n_tx + i) + rx_u
            spread(acc, pos, row + i * element_stride if element_stride else row, gain, None,
                    None, half_width, inv_var, 0.0,
                    active=(pos > -half_width) & (pos < n_samples + half_width))
        return acc

    return freeze(spread_pairs, warn_after=256)


def fixed_point_scale(peak):
    """Scale of the grids' fixed point for contributions up to ``peak`` (a float, or an array
    of several grids' peaks; 0 where the peak is): a quantum of 2^-36 of the largest one. Up to
    2^25 terms of that size cannot overflow int64, and the rounding (1.5e-11 relative per term)
    is far below the synthesis tolerance."""
    peak = np.asarray(peak, dtype=float)
    return np.where(peak > 0.0, 2.0 ** (36 - np.ceil(np.log2(np.where(peak > 0.0, peak, 1.0)))),
                    0.0)


def folded(padded: np.ndarray, scale: float, n_grid: int, origin: int,
            grid: np.ndarray | None = None) -> np.ndarray:
    """The (n_rows, n_grid) complex64 grid (``grid``, or a new one) of a kernel's fixed-point
    rows (n_rows, width, 2) of interleaved (re, im) over ``scale`` (a power of two): column c holds
    sample (origin + c) modulo n_grid, added onto the period in contiguous pieces (a few)."""
    if grid is None:
        grid = np.zeros((len(padded), n_grid), dtype=np.complex64)
    values = padded.astype(np.float32).view(np.complex64)[..., 0]  # (re, im) pairs as complex
    values *= np.float32(1.0 / scale)
    column = 0
    while column < values.shape[1]:
        first = (origin + column) % n_grid
        n = min(values.shape[1] - column, n_grid - first)
        grid[:, first:first + n] += values[:, column:column + n]
        column += n
    return grid
