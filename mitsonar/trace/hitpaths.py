"""Echo paths of surface patches through every element pair, kept in factored form.

A beam's H patches reach N_rx receive elements through N_tx transmit elements: H x N_tx x N_rx
paths (~900 000 for a standard ping). Most of each path's gain factorises into a transmit and a
receive part; only the patch integral couples them (its phase gradient is the sum of both
directions). :class:`HitPaths` stores the factors, (H, N_tx) and (H, N_rx) arrays, and

* gives each pair's gain inside Dr.Jit kernels (:func:`pair_gain`): where every pair is
  synthesised (``fine`` fidelity, broadband transducers) the synthesizer grids them from the
  factors; :attr:`HitPaths.paths` expands them into flat :class:`~mitsonar.trace.paths.Paths`
  for references only;
* merges each patch's transmit elements narrow-band (:meth:`HitPaths.narrowband`, the same merge
  as :meth:`Paths.narrowband`) in one fused Dr.Jit kernel, one thread per patch and group of
  receive elements, without ever forming the H x N_tx x N_rx arrays; the merged paths
  (:class:`MergedHits`) stay Dr.Jit arrays until they are gridded.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cache, cached_property

import drjit as dr
import numpy as np

from mitsonar.jit import backend, concat, freeze, to_jit
from mitsonar.trace.paths import Paths


def sinc(x):
    """np.sinc in single precision: within 1e-7 of the peak for |x| < 1e3 and ~10x faster."""
    x = np.asarray(x, dtype=np.float32)
    pix = np.float32(np.pi) * x
    small = np.abs(x) < 1e-4
    return np.where(small, np.float32(1.0), np.sin(pix) / np.where(small, np.float32(1.0), pix))


@dataclass(frozen=True)
class HitPaths:
    """Paths of H patches, factored per transmit element i and receive element j:

        gain[h, i, j] = tx_specular[h, i] rx_specular[h, j] specular[h]
                        (tx_cos[h, i] + rx_cos[h, j])
                        sinc(tx_sinc[h, i, 0] + rx_sinc[h, j, 0]) sinc(tx_sinc[h, i, 1] + rx_sinc[h, j, 1])
                      + tx_diffuse[h, i] rx_diffuse[h, j] diffuse[h]
        delay[h, i, j] = tx_delay[h, i] + rx_delay[h, j]

    (np.sinc convention). Gains are complex [Pa] for the drive pulse, delays [s] from the virtual
    firing of the transmit origin; the expanded paths are ordered (patch, transmit, receive).

    Attributes:
        tx_delay, rx_delay: (H, N_tx), (H, N_rx) [s].
        tx_specular, rx_specular, specular: (H, N_tx), (H, N_rx), (H,) complex factors of the
            specular (physical-optics) term.
        tx_cos, rx_cos: (H, N_tx), (H, N_rx) cosines of incidence and emergence (obliquity).
        tx_sinc, rx_sinc: (H, N_tx, 2), (H, N_rx, 2) parts of the patch integral's sinc arguments
            along the patch's two edges.
        tx_diffuse, rx_diffuse, diffuse: (H, N_tx), (H, N_rx), (H,) complex factors of the
            diffuse (or point-reflector) term.
    """

    tx_delay: np.ndarray
    rx_delay: np.ndarray
    tx_specular: np.ndarray
    rx_specular: np.ndarray
    specular: np.ndarray
    tx_cos: np.ndarray
    rx_cos: np.ndarray
    tx_sinc: np.ndarray
    rx_sinc: np.ndarray
    tx_diffuse: np.ndarray
    rx_diffuse: np.ndarray
    diffuse: np.ndarray

    @classmethod
    def point_reflectors(cls, tx_gain, tx_delay, rx_gain, rx_delay, gain) -> "HitPaths":
        """Paths with gain tx_gain[h, i] rx_gain[h, j] gain[h] and no patch integral."""
        h, n_tx = np.shape(tx_gain)
        n_rx = np.shape(rx_gain)[1]
        zeros = np.zeros
        return cls(np.asarray(tx_delay, float), np.asarray(rx_delay, float),
                   zeros((h, n_tx), complex), zeros((h, n_rx), complex), zeros(h, complex),
                   zeros((h, n_tx)), zeros((h, n_rx)), zeros((h, n_tx, 2)), zeros((h, n_rx, 2)),
                   np.asarray(tx_gain, complex), np.asarray(rx_gain, complex),
                   np.asarray(gain, complex))

    @classmethod
    def concatenate(cls, parts) -> "HitPaths":
        """The patches of all ``parts`` (same element counts); a single part is returned as it is."""
        parts = list(parts)
        if len(parts) == 1:
            return parts[0]
        return cls(*(np.concatenate([getattr(p, name) for p in parts])
                     for name in cls.__dataclass_fields__))

    def select(self, rows) -> "HitPaths":
        """The patches ``rows`` (an index, slice or mask over the H patches); their
        :attr:`arrivals`, where already computed, are carried over."""
        out = HitPaths(*(getattr(self, name)[rows] for name in self.__dataclass_fields__))
        if "arrivals" in self.__dict__:
            out.__dict__["arrivals"] = tuple(x[rows] for x in self.arrivals)
        return out

    @cached_property
    def arrivals(self) -> tuple[np.ndarray, np.ndarray]:
        """(earliest, latest) (H,) delays [s] of each patch's element pairs, computed once."""
        return (self.tx_delay.min(axis=1) + self.rx_delay.min(axis=1),
                self.tx_delay.max(axis=1) + self.rx_delay.max(axis=1))

    @property
    def elements(self) -> tuple[int, int]:
        """(N_tx, N_rx)."""
        return self.tx_delay.shape[1], self.rx_delay.shape[1]

    @property
    def patches(self) -> int:
        """H."""
        return len(self.tx_delay)

    def __len__(self) -> int:
        n_tx, n_rx = self.elements
        return len(self.tx_delay) * n_tx * n_rx

    def gains(self) -> np.ndarray:
        """(H, N_tx, N_rx) complex path gains [Pa]."""
        patch = sinc(self.tx_sinc[:, :, None, 0] + self.rx_sinc[:, None, :, 0]) \
            * sinc(self.tx_sinc[:, :, None, 1] + self.rx_sinc[:, None, :, 1])
        specular = self.specular[:, None, None] * (self.tx_cos[:, :, None] + self.rx_cos[:, None, :]) \
            * patch
        return self.tx_specular[:, :, None] * self.rx_specular[:, None, :] * specular \
            + self.tx_diffuse[:, :, None] * self.rx_diffuse[:, None, :] * self.diffuse[:, None, None]

    @cached_property
    def paths(self) -> Paths:
        """Every element pair as a flat :class:`Paths` (H x N_tx x N_rx paths)."""
        n_tx, n_rx = self.elements
        delay = self.tx_delay[:, :, None] + self.rx_delay[:, None, :]
        channel = np.broadcast_to(np.arange(n_rx), delay.shape)
        return Paths(self.gains().ravel(), delay.ravel(), channel.ravel(), (n_tx, n_rx))

    @property
    def gain(self) -> np.ndarray:
        return self.paths.gain

    @property
    def delay(self) -> np.ndarray:
        return self.paths.delay

    @property
    def channel(self) -> np.ndarray:
        return self.paths.channel

    def gain_bound(self) -> np.ndarray:
        """(H,) bound on each patch's pair gains |gain[h, i, j]| [Pa] (|sinc| <= 1)."""
        peak = lambda a: np.abs(a).max(axis=1, initial=0.0)  # noqa: E731
        return peak(self.tx_specular) * peak(self.rx_specular) * np.abs(self.specular) \
            * (peak(self.tx_cos) + peak(self.rx_cos)) \
            + peak(self.tx_diffuse) * peak(self.rx_diffuse) * np.abs(self.diffuse)

    def delayed(self, seconds) -> "HitPaths":
        """The same paths ``seconds`` [s] later (still factored): a scalar, or (N_tx,) per
        transmit element (its firing time)."""
        return replace(self, tx_delay=self.tx_delay + seconds)

    @property
    def specular_free(self) -> bool:
        """Whether no pair has a specular term (every ``specular`` factor 0, as for the paper's
        point reflectors): the diffuse term alone is each pair's gain."""
        return not np.any(self.specular)

    def kernel_factors(self, rows=slice(None), tx_factor=None, rx_factor=None,
                       specular: bool = True) -> tuple[list, list]:
        """The gain factors of patches ``rows`` (an index or slice; default all) as
        single-precision Dr.Jit arrays for :func:`pair_gain`: 7 transmit factors (H x N_tx,)
        (specular re, im, diffuse re, im, cosine, sinc arguments) and 7 receive factors
        (H x N_rx,) with the patch's own factors folded in; every pair's gain times
        ``tx_factor[h, i] rx_factor[h, j]`` where given (complex (H, N_tx) and (H, N_rx) arrays
        for those rows, e.g. demodulating phasors). No copy of the other factors is made.
        ``specular=False`` (for :attr:`specular_free` paths): the diffuse factors (re, im)
        alone, 2 and 2."""
        Float32 = backend().Float32

        def term(tx, rx, patch):  # a term's factors for rows, the patch's folded into rx
            tx = tx[rows] if tx_factor is None else tx[rows] * tx_factor
            rx = rx[rows] if rx_factor is None else rx[rows] * rx_factor
            return tx, rx * patch[rows, None]

        tx_d, rx_d = term(self.tx_diffuse, self.rx_diffuse, self.diffuse)
        if not specular:
            return ([to_jit(Float32, x) for x in (tx_d.real, tx_d.imag)],
                    [to_jit(Float32, x) for x in (rx_d.real, rx_d.imag)])
        tx_s, rx_s = term(self.tx_specular, self.rx_specular, self.specular)
        tx_sinc, rx_sinc = self.tx_sinc[rows], self.rx_sinc[rows]
        tx = [to_jit(Float32, x) for x in (tx_s.real, tx_s.imag, tx_d.real, tx_d.imag,
                                           self.tx_cos[rows], tx_sinc[..., 0], tx_sinc[..., 1])]
        rx = [to_jit(Float32, x) for x in (rx_s.real, rx_s.imag, rx_d.real, rx_d.imag,
                                           self.rx_cos[rows], rx_sinc[..., 0], rx_sinc[..., 1])]
        return tx, rx

    def narrowband(self, frequency: float) -> Paths:
        """Each patch's transmit elements merged into one path per receive element about
        ``frequency`` [Hz], with first-order terms: :meth:`Paths.narrowband` of the expanded
        paths, computed in single precision by one fused kernel."""
        return self.narrowband_many([frequency])[0]

    def narrowband_many(self, frequencies) -> list[Paths]:
        """:meth:`narrowband` about each of ``frequencies`` [Hz] (an OFDM code's tones), in one
        kernel: the element-pair gains are formed once for all of them."""
        return [merged.paths for merged in self.merged(frequencies)]

    def merged(self, frequencies) -> list["MergedHits"]:
        """:meth:`narrowband_many` as it leaves the merge kernel: Dr.Jit arrays, not copied
        into NumPy until asked for (the synthesizer grids them as they are)."""
        Float32, Float64, UInt32 = backend().Float32, backend().Float64, backend().UInt32

        n_tx, n_rx = self.elements
        n_hits = len(self.tx_delay)
        if n_hits == 0:
            return [MergedHits((Float32(), Float32()), (Float32(), Float32()), Float64(),
                               UInt32(), np.zeros(0, int), float(f), n_rx, (0.0, 0.0), (0.0, 0.0))
                    for f in frequencies]
        # Transmit delays relative to their patch mean (|tau| <~ 0.2 ms): exact in single precision.
        tx_mean = self.tx_delay.mean(axis=1, keepdims=True)
        tx, rx = self.kernel_factors()
        tx.append(to_jit(Float32, self.tx_delay - tx_mean))
        # Opaque carriers: variables, not literals, so one kernel serves every tone.
        omegas = [dr.opaque(Float32, -2.0 * np.pi * f) for f in frequencies]
        group = next(g for g in range(min(MERGE_GROUP, n_rx), 0, -1) if n_rx % g == 0)
        # Thread indices passed in: a size computed inside a frozen function is fixed when traced.
        thread = np.arange(n_hits * n_rx // group, dtype=np.uint32)
        outputs = _merge_kernel()(to_jit(UInt32, thread), tx, rx, omegas, n_tx, n_rx, group)
        # Thread t's output j is the path of flat (patch, element) t * group + j: the outputs
        # are kept in that order, j after j.
        element = (thread[None, :] * group + np.arange(group)[:, None]).ravel()

        joined = concat(outputs)
        centre = to_jit(Float64, (self.rx_delay + tx_mean).ravel()[element]) \
            + Float64(joined[0])
        channel = to_jit(UInt32, element % n_rx)
        # A merged path's delay lies within its pairs' (its centre is their weighted mean);
        # |a| <= sum_i |g_i| and |b| <= sum_i |g_i| |tau_i - m|, m between the tau_i.
        span = (float(self.arrivals[0].min()), float(self.arrivals[1].max()))
        bound = n_tx * self.gain_bound()
        peaks = (float(bound.max()), float(np.max(bound * np.ptp(self.tx_delay, axis=1))))
        return [MergedHits(joined[k:k + 2], joined[k + 2:k + 4], centre,
                           channel, element, float(frequency), n_rx, span, peaks)
                for k, frequency in zip(range(1, 4 * len(frequencies), 4), frequencies)]


@dataclass(frozen=True, eq=False)
class MergedHits:
    """Narrow-band merged paths (:meth:`HitPaths.merged`) about one frequency, one per patch and
    receive element, as Dr.Jit arrays: a :class:`Paths` whose arrays stay where the merge
    kernel left them until the synthesizer grids them.

    Attributes:
        gain: (re, im) Float32 arrays (M,) of the merged gains a [Pa].
        first_order: (re, im) Float32 arrays (M,) of the first-order gains b [Pa s].
        centre: Float64 (M,) delays [s], before ``offset``.
        channel: UInt32 (M,) receive element index.
        element: (M,) NumPy index of each path in (patch, receive element) order.
        frequency: the merge's centre, the carrier of the first-order terms [Hz].
        receivers: N_rx; channels are 0 .. N_rx - 1.
        span: (earliest, latest) delay [s] a path can have, before ``offset``.
        peaks: bounds on |a| [Pa] and |b| [Pa s] over the paths.
        offset: added to every delay [s] (:meth:`delayed`).
    """

    gain: tuple
    first_order: tuple
    centre: object
    channel: object
    element: np.ndarray
    frequency: float
    receivers: int
    span: tuple[float, float]
    peaks: tuple[float, float]
    offset: float = 0.0

    @classmethod
    def concatenate(cls, parts) -> "MergedHits":
        """The paths of all ``parts``, merged about the same frequency."""
        parts = list(parts)
        if len({p.frequency for p in parts}) != 1:
            raise ValueError("MergedHits.concatenate: parts merged about different frequencies")
        parts = [p for p in parts if len(p)] or parts[:1]
        if len(parts) == 1:
            return parts[0]

        # Offsets as variables, not literals (a kernel each otherwise; see jit.concat).
        joined = concat((*p.gain, *p.first_order, p.centre + dr.opaque(type(p.centre), p.offset),
                         p.channel) for p in parts)
        starts = np.cumsum([0] + [len(p) for p in parts[:-1]])
        return cls(joined[0:2], joined[2:4], joined[4], joined[5],
                   np.concatenate([p.element + start for p, start in zip(parts, starts)]),
                   parts[0].frequency, max(p.receivers for p in parts),
                   (min(p.span[0] + p.offset for p in parts),
                    max(p.span[1] + p.offset for p in parts)),
                   tuple(max(p.peaks[k] for p in parts) for k in range(2)))

    def __len__(self) -> int:
        return len(self.element)

    def delayed(self, seconds: float) -> "MergedHits":
        """The same paths ``seconds`` [s] later (>= 0: the synthesizer leaves out the patches
        that arrive after its recording, which an earlier firing would bring back)."""
        if not seconds >= 0:
            raise ValueError(f"MergedHits.delayed: seconds must be >= 0, got {seconds}")
        return replace(self, offset=self.offset + seconds)

    @cached_property
    def paths(self) -> Paths:
        """These paths as :class:`Paths`, in (patch, receive element) order."""
        order = np.argsort(self.element, kind="stable")
        values = [x.numpy()[order] for x in (*self.gain, *self.first_order, self.centre)]
        return Paths(values[0].astype(float) + 1j * values[1], values[4] + self.offset,
                     self.channel.numpy()[order].astype(int),
                     first_order=values[2].astype(float) + 1j * values[3],
                     carrier=self.frequency)


#: Receive elements per thread of the merge kernel: each thread loads its patch's transmit factors
#: once for this many receive elements (gathers dominated the kernel with one per thread).
MERGE_GROUP = 5


@cache
def _merge_kernel():
    """The fused kernel of :meth:`HitPaths.narrowband_many`, frozen (``drjit.freeze``): traced
    once per (tone count, element counts, group), then replayed without Python tracing.

    Arguments: thread indices 0 .. H x N_rx / g - 1, the 8 transmit factors (H x N_tx,) and 7
    receive factors (H x N_rx,) as listed there, the tones' -2 pi f [rad/s], N_tx, N_rx, the
    group g of receive elements per thread. Returns per receive element of the group a tuple:
    the mean delay offset [s], then (a_re, a_im, b_re, b_im) per tone, each (H x N_rx / g,).
    """
    Float32 = backend().Float32

    def merge(thread, tx, rx, omegas, n_tx, n_rx, group):
        tx_row = thread // (n_rx // group) * n_tx
        # The patch's transmit factors and per-tone phasors exp(j omega tau_i), loaded once.
        tx_values = [[dr.gather(Float32, x, tx_row + i) for x in tx] for i in range(n_tx)]
        phasors = [[dr.sincos(omega * values[7]) for values in tx_values] for omega in omegas]
        outputs = []
        for j in range(group):  # receive element thread * group + j (unrolled)
            rx_values = [dr.gather(Float32, x, thread * group + j) for x in rx]
            gains = [pair_gain(values[:7], rx_values) + (values[7],)  # (unrolled)
                     for values in tx_values]
            weight = [dr.sqrt(g_re * g_re + g_im * g_im) for g_re, g_im, _ in gains]
            total = sum(weight)
            mean_tau = dr.select(total > 0, sum(w * t for w, (_, _, t) in zip(weight, gains))
                                 / dr.select(total > 0, total, 1.0), 0.0)
            out = [mean_tau]
            # exp(j omega (tau_i - m)) = exp(j omega tau_i) exp(-j omega m): the first factor per
            # (patch, transmit element), the second per receive element, so no sine per element
            # pair: A = Q sum g_i P_i, B = Q (sum g_i P_i tau_i - m sum g_i P_i),
            # P_i = exp(j omega tau_i), Q = exp(-j omega m).
            for omega, tone_phasors in zip(omegas, phasors):
                s0_re = s0_im = s1_re = s1_im = Float32(0.0)
                for (g_re, g_im, tau_i), (p_im, p_re) in zip(gains, tone_phasors):
                    c_re, c_im = g_re * p_re - g_im * p_im, g_re * p_im + g_im * p_re
                    s0_re, s0_im = s0_re + c_re, s0_im + c_im
                    s1_re, s1_im = s1_re + c_re * tau_i, s1_im + c_im * tau_i
                e_im, e_re = dr.sincos(-omega * mean_tau)
                r_re, r_im = s1_re - mean_tau * s0_re, s1_im - mean_tau * s0_im
                out += [s0_re * e_re - s0_im * e_im, s0_re * e_im + s0_im * e_re,
                        r_re * e_re - r_im * e_im, r_re * e_im + r_im * e_re]
            outputs.append(tuple(out))
        return outputs

    return freeze(merge)


def pair_gain(tx_values, rx_values):
    """Gain (re, im) of one element pair inside a Dr.Jit kernel, from the 7 transmit factors
    and the 7 receive factors of :meth:`HitPaths.kernel_factors` (gathered for the pair), or
    from their 2 and 2 diffuse factors (``specular=False``: no sines, a fifth of the gathers)."""
    if len(tx_values) == 2:
        (u_re, u_im), (v_re, v_im) = tx_values, rx_values
        return u_re * v_re - u_im * v_im, u_re * v_im + u_im * v_re
    p_re, p_im, u_re, u_im, c, a1, a2 = tx_values
    q_re, q_im, v_re, v_im, d, b1, b2 = rx_values
    patch = (c + d) * _sinc_dr(a1 + b1) * _sinc_dr(a2 + b2)
    return ((p_re * q_re - p_im * q_im) * patch + u_re * v_re - u_im * v_im,
            (p_re * q_im + p_im * q_re) * patch + u_re * v_im + u_im * v_re)


def _sinc_dr(x):
    """sinc(x) = sin(pi x) / (pi x) on Dr.Jit arrays (1 near 0)."""
    pix = np.pi * x
    small = dr.abs(x) < 1e-4
    return dr.select(small, 1.0, dr.sin(pix) / dr.select(small, 1.0, pix))
