"""The per (patch, element) factor kernel against the same formulas written out in NumPy."""

import numpy as np
import pytest

import mitsonar
from mitsonar.trace.element_factors import directivity_series, element_factors


def _numpy_factors(points, normals, edges, elements, gain, transducer, k, log_att, c,
                   departure, firing, visible, mirror, impedance, z_air):
    """The factors of every pair, one formula at a time (the oracle)."""
    pos = np.broadcast_to(elements, (len(points),) + elements.shape)
    dep = departure[:, None] - pos
    d = transducer.directivity(dep[..., 2] / np.linalg.norm(dep, axis=-1), k)
    if mirror is not None:
        q, m = mirror
        dist = np.sum((pos - q[:, None]) * m[:, None], axis=-1)
        pos = pos - 2 * dist[..., None] * m[:, None]
    w = points[:, None] - pos
    r = np.linalg.norm(w, axis=-1)
    w = w / r[..., None]
    g = d * np.exp(log_att * r) / r * visible * gain[None]
    cos = -np.sum(w * normals[:, None], axis=-1)
    sinc = np.stack([np.sum(w * edges[:, None, i], axis=-1) for i in range(2)], axis=-1)
    refl = np.ones_like(g)
    if impedance is not None:
        zc = impedance[:, None] * np.maximum(cos, 0)
        refl = (zc - z_air) / (zc + z_air)
    specular = np.where(cos > 0, g * refl, 0)
    diffuse = g * np.abs(refl) * np.sqrt(np.maximum(cos, 0))
    return r / c + firing, specular, cos, sinc, diffuse


@pytest.mark.parametrize("side", ["transmit", "receive", "mirrored"])
def test_factor_kernel_matches_numpy_formulas_within_1e_12(side):
    rng = np.random.default_rng(5)
    h, geometry = 300, mitsonar.SonarConfig().geometry
    elements = geometry.tx_positions if side != "receive" else geometry.rx_positions
    n = len(elements)
    points = rng.normal(size=(h, 3)) + [0, 0, 3]
    normals = rng.normal(size=(h, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    edges = rng.normal(size=(h, 2, 3)) * 2
    gain = 4.8 * np.exp(1j * rng.uniform(0, 2 * np.pi, n))
    transducer, k, c = mitsonar.Transducer(), 733.0, 343.0
    departure = points if side != "mirrored" else rng.normal(size=(h, 3)) + [0, 0, 1]
    firing = rng.uniform(0, 1e-4, (h, n)) if side != "receive" else np.zeros((h, n))
    visible = (rng.uniform(size=(h, n)) > 0.2).astype(float) if side == "receive" else np.ones((h, n))
    mirror = (departure, normals[::-1]) if side == "mirrored" else None
    impedance = rng.uniform(400, 1e6, h) * np.exp(1j * rng.uniform(-0.5, 0.5, h)) \
        if side != "receive" else None
    kwargs = dict(departure=departure if side == "mirrored" else None,
                  firing=firing if side != "receive" else None,
                  visible=visible if side == "receive" else None, mirror=mirror,
                  impedance=impedance, z_air=413.0)
    got = element_factors(points, normals, edges, elements, gain, k * transducer.radius, -0.15, c,
                          **kwargs)
    expected = _numpy_factors(points, normals, edges, elements, gain, transducer, k, -0.15, c,
                              departure, firing, visible, mirror, impedance, 413.0)
    for name, want in zip(("delay", "specular", "cos", "sinc", "diffuse"), expected):
        have = getattr(got, name)
        assert have.shape == want.shape, name
        np.testing.assert_allclose(have, want, rtol=0, atol=1e-12 * np.abs(want).max(), err_msg=name)
    assert np.any(got.cos < 0) and np.any(got.specular == 0)  # patches facing away are covered


def test_directivity_series_matches_the_bessel_form_within_1e_13():
    transducer, k = mitsonar.Transducer(), 733.0
    ka = k * transducer.radius
    cos = np.linspace(0, 1, 2001)
    u = 0.25 * ka**2 * (1 - cos**2)
    series = sum(c * (-u) ** m for m, c in enumerate(directivity_series(ka)))
    np.testing.assert_allclose(series, transducer.directivity(cos, k), rtol=0, atol=1e-13)
    with pytest.raises(ValueError, match="k a"):
        directivity_series(80.0)
