"""Per (patch, element) factors of the acoustic paths, in one frozen Dr.Jit kernel.

For H patches and N array elements (transmit or receive), every pair needs the element's
distance and direction to the patch, its piston directivity, spreading and air absorption, the
obliquity to the patch normal, the two sinc arguments of the patch integral, and (transmit side)
the reflection coefficient at that incidence: a few dozen operations over (H, N) arrays, which
NumPy runs as as many passes over memory. :func:`element_factors` runs them as one Dr.Jit LLVM
kernel, a thread per pair, traced once per variant (``drjit.freeze``) and replayed.
:class:`~mitsonar.trace.tracer.AcousticTracer` assembles :class:`~mitsonar.trace.hitpaths.HitPaths` from them.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from math import factorial

import numpy as np

from mitsonar.jit import backend, freeze, to_jit


@dataclass(frozen=True)
class ElementFactors:
    """Factors of H patches x N elements, each (H, N) (``sinc``: (H, N, 2)).

    Attributes:
        delay: element -> patch travel time, plus the element's firing delay [s].
        specular: element gain (directivity x spreading x absorption x phase offset, x the
            reflection coefficient on the transmit side), zero where the patch faces away [Pa m
            per unit source amplitude].
        cos: cosine between the element -> patch direction and the patch's inward normal.
        sinc: the element's parts of the patch integral's sinc arguments along both edges.
        diffuse: |specular| with the Lambert obliquity sqrt(max(cos, 0)) (phase kept).
    """

    delay: np.ndarray
    specular: np.ndarray
    cos: np.ndarray
    sinc: np.ndarray
    diffuse: np.ndarray


def directivity_series(ka: float, tolerance: float = 1e-15) -> tuple[float, ...]:
    """Coefficients c_m of the piston directivity 2 J1(x) / x = sum_m c_m (-x^2 / 4)^m,
    c_m = 1 / (m! (m + 1)!), up to the term below ``tolerance`` at x = ``ka`` (the largest
    argument, k a sin 90 deg)."""
    if not 0 < ka <= 30:
        raise ValueError(f"k a = {ka:.3g} outside (0, 30]: the directivity series would lose "
                         f"precision (transducer radius x wavenumber)")
    coefficients = []
    m = 0
    while True:
        c = 1.0 / (factorial(m) * factorial(m + 1))
        coefficients.append(c)
        if c * (ka * ka / 4) ** m < tolerance and m > 2:
            return tuple(coefficients)
        m += 1


@cache
def _kernel():
    """The frozen kernel of :func:`element_factors`."""
    import drjit as dr
    Float64, UInt32 = backend().Float64, backend().UInt32

    def factors(hits, elements, phase, firing, visible, mirror, impedance, n_elements,
                series, ka, log_attenuation, inv_c, z_air):
        p, n, a1, a2, departure = hits
        idx = dr.arange(UInt32, dr.width(firing))  # a thread per (patch, element)
        h, e = idx // n_elements, idx % n_elements
        get = lambda v: [dr.gather(Float64, c, h) for c in v]  # noqa: E731
        p, n, a1, a2, departure = get(p), get(n), get(a1), get(a2), get(departure)
        pos = [dr.gather(Float64, c, e) for c in elements]
        # Directivity towards the departure point, from the (unmirrored) element.
        dep = [departure[k] - pos[k] for k in range(3)]
        cos_dep = dep[2] / dr.sqrt(dep[0] * dep[0] + dep[1] * dep[1] + dep[2] * dep[2])
        u = (0.25 * ka * ka) * dr.maximum(1.0 - cos_dep * cos_dep, 0.0)  # (x / 2)^2
        d = Float64(series[-1])
        for c in series[-2::-1]:  # Horner in -u
            d = c - u * d
        d = dr.select(cos_dep >= 0.0, d, 0.0)
        if mirror is not None:  # unfolded bounce: the element mirrored in the first surface
            q, m = get(mirror[0]), get(mirror[1])
            dist = (pos[0] - q[0]) * m[0] + (pos[1] - q[1]) * m[1] + (pos[2] - q[2]) * m[2]
            pos = [pos[k] - 2.0 * dist * m[k] for k in range(3)]
        w = [p[k] - pos[k] for k in range(3)]
        r = dr.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
        w = [x / r for x in w]
        amp = d * dr.exp(log_attenuation * r) / r * visible
        g_re = amp * dr.gather(Float64, phase[0], e)
        g_im = amp * dr.gather(Float64, phase[1], e)
        delay = r * inv_c + firing
        cos = -(w[0] * n[0] + w[1] * n[1] + w[2] * n[2])
        sinc1 = w[0] * a1[0] + w[1] * a1[1] + w[2] * a1[2]
        sinc2 = w[0] * a2[0] + w[1] * a2[1] + w[2] * a2[2]
        facing = dr.maximum(cos, 0.0)
        lambert = dr.sqrt(facing)
        if impedance is not None:  # locally reacting surface: r = (Z cos - Z0) / (Z cos + Z0)
            z_re, z_im = (dr.gather(Float64, x, h) * facing for x in impedance)
            num_re, den_re = z_re - z_air, z_re + z_air
            den2 = den_re * den_re + z_im * z_im
            r_re = (num_re * den_re + z_im * z_im) / den2
            r_im = (z_im * den_re - num_re * z_im) / den2
            s_re, s_im = g_re * r_re - g_im * r_im, g_re * r_im + g_im * r_re
            lambert = lambert * dr.sqrt(r_re * r_re + r_im * r_im)
        else:
            s_re, s_im = g_re, g_im
        ok = cos > 0.0
        return (delay, dr.select(ok, s_re, 0.0), dr.select(ok, s_im, 0.0), cos, sinc1, sinc2,
                g_re * lambert, g_im * lambert)

    # A recording per variant (transmit, receive, mirrored) and per k a: one per frequency node
    # of a wide band (``TraceSettings.subbands``, up to 16), not a re-tracing fault.
    return freeze(factors, warn_after=64)


def element_factors(points, normals, edges, elements, element_gain, ka: float,
                    log_attenuation: float, speed_of_sound: float, departure=None, firing=None,
                    visible=None, mirror=None, impedance=None, z_air: float = 0.0) -> ElementFactors:
    """Factors of every (patch, element) pair.

    Args:
        points, normals: (H, 3) patch centres [m] and unit normals facing the incoming ray.
        edges: (H, 2, 3) patch edges times k / (2 pi) [1] (sinc arguments of np.sinc).
        elements: (N, 3) element positions [m].
        element_gain: (N,) complex gain per element (source amplitude [Pa at 1 m] and phase).
        ka: wavenumber x piston radius [1].
        log_attenuation: air absorption [1/m] (amplitude, natural log; <= 0).
        speed_of_sound: [m/s].
        departure: (H, 3) point the directivity is evaluated towards (default: the patch).
        firing: (H, N) firing delays added to the travel time [s] (transmit side), or None.
        visible: (H, N) 1.0 where the element sees the patch, else 0.0 (receive side), or None.
        mirror: (plane points (H, 3), unit plane normals (H, 3)) to mirror the elements in
            (unfolded bounces), or None.
        impedance: (H,) complex normal impedance of each patch [Pa s/m] (transmit side: the
            reflection coefficient is applied), or None.
        z_air: impedance of air [Pa s/m] (with ``impedance``).
    """
    Float64 = backend().Float64

    points = np.asarray(points, dtype=float)
    n_hits, n_elements = len(points), len(elements)
    if n_hits == 0:
        empty = np.zeros((0, n_elements))
        return ElementFactors(empty, empty.astype(complex), empty, np.zeros((0, n_elements, 2)),
                              empty.astype(complex))
    f64 = lambda a: to_jit(Float64, a)  # noqa: E731
    columns = lambda a: [f64(np.asarray(a, dtype=float)[..., k]) for k in range(3)]  # noqa: E731
    departure = points if departure is None else departure
    hits = (columns(points), columns(normals), columns(edges[:, 0]), columns(edges[:, 1]),
            columns(departure))
    gain = np.asarray(element_gain, dtype=complex)
    pairs = (n_hits, n_elements)
    out = _kernel()(
        hits, columns(elements), (f64(gain.real), f64(gain.imag)),
        f64(np.zeros(pairs) if firing is None else firing),
        f64(np.ones(pairs) if visible is None else visible),
        None if mirror is None else (columns(mirror[0]), columns(mirror[1])),
        None if impedance is None else (f64(np.real(impedance)), f64(np.imag(impedance))),
        n_elements, directivity_series(ka), float(ka), float(log_attenuation),
        1.0 / float(speed_of_sound), float(z_air))
    delay, s_re, s_im, cos, sinc1, sinc2, d_re, d_im = (x.numpy().reshape(n_hits, n_elements)
                                                         for x in out)
    return ElementFactors(delay, s_re + 1j * s_im, cos, np.stack([sinc1, sinc2], axis=-1),
                          d_re + 1j * d_im)
