"""Beam patterns against analytic references: piston element, grating lobes, widths, PSLL."""

import numpy as np
import pytest
from scipy.special import j1

from mitsonar import ArrayLayout, Medium, Transducer, direction_from_fov_angles
from mitsonar.physics.beampattern import (array_factor, cut_widths, fov_grid, main_lobe_width,
                                  main_lobe_widths, one_way_pattern, pair_side_lobe_levels,
                                  peak_side_lobe_levels, steered_array_factors, steered_patterns,
                                  two_way_pattern)

K = float(Medium().wavenumber(40e3))
LAMBDA = 2 * np.pi / K
BROADSIDE = np.array([0.0, 0.0, 1.0])


def test_single_element_pattern_is_the_piston_formula():
    """One element at the origin: pattern = 2 J1(k a sin t) / (k a sin t), to 1e-12."""
    element = Transducer()
    theta = np.radians(np.linspace(0.01, 89.99, 2000))
    phi = np.radians(37.0)
    u = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1)
    x = K * element.radius * np.sin(theta)
    analytic = 2 * j1(x) / x
    single = np.zeros((1, 2))
    np.testing.assert_allclose(one_way_pattern(single, BROADSIDE, u, element, K), analytic,
                               rtol=0, atol=1e-12)
    # Any steering of a single element leaves the pattern unchanged.
    steer = direction_from_fov_angles(np.radians(20.0), np.radians(-10.0))
    np.testing.assert_allclose(steered_patterns(single, steer[None], u, element, K)[0], analytic,
                               rtol=0, atol=1e-12)


@pytest.mark.parametrize("steer_deg", [0.0, 12.0])
def test_uniform_grating_lobe_at_sin_theta_lambda_over_d(steer_deg):
    """Uniform 5x5 at d = 25 mm: full grating lobe (|AF| = 1) at sin(t) = sin(t_s) - lambda/d.

    Tolerance 0.01 deg on the lobe direction (cut sampled every 0.001 deg), 1e-6 on its height.
    """
    d = 0.025
    layout = ArrayLayout.uniform(5, d)
    steer = np.radians(steer_deg)
    expected = np.arcsin(np.sin(steer) - LAMBDA / d)
    h = expected + np.radians(np.linspace(-3, 3, 6001))
    u = np.stack([np.sin(h), np.zeros_like(h), np.cos(h)], -1)  # horizontal cut at vertical 0
    s = np.array([np.sin(steer), 0.0, np.cos(steer)])
    af = array_factor(layout.positions, s, u, K)
    assert np.degrees(abs(h[np.argmax(af)] - expected)) < 0.01
    assert af.max() == pytest.approx(1.0, abs=1e-6)
    assert np.degrees(np.arcsin(LAMBDA / d)) == pytest.approx(20.07, abs=0.01)  # inside the FOV


def test_matrix_and_broadcast_array_factors_agree():
    rng = np.random.default_rng(4)
    p = rng.uniform(-0.05, 0.05, (25, 2))
    _, _, steers = fov_grid(np.radians(60), np.radians(40), np.radians(10))
    steers = steers.reshape(-1, 3)
    _, _, dirs = fov_grid(np.radians(90), np.radians(60), np.radians(3))
    dirs = dirs.reshape(-1, 3)
    fast = steered_array_factors(p, steers, dirs, K)
    slow = array_factor(p, steers[:, None, :], dirs[None], K)
    np.testing.assert_allclose(fast, slow, atol=1e-12)
    element = Transducer()
    q = rng.uniform(-0.05, 0.05, (25, 2))
    two = steered_patterns(p, steers, dirs, element, K, rx_positions=q)
    np.testing.assert_allclose(two, two_way_pattern(p, q, steers[:, None, :], dirs[None], element, K),
                               atol=1e-12)


def test_main_lobe_widths_of_a_cosine_and_batched_form():
    x = np.linspace(-np.pi / 2, np.pi / 2, 20001)
    # cos(x) = 1/sqrt(2) at +-pi/4: 3 dB width pi/2 (linear interpolation error < 1e-7).
    assert main_lobe_width(x, np.cos(x)) == pytest.approx(np.pi / 2, abs=1e-7)
    shifted = np.stack([np.cos(x - 0.3), np.cos(2 * x), np.ones_like(x)])
    w = main_lobe_widths(x, shifted)
    np.testing.assert_allclose(w[:2], [np.pi / 2, np.pi / 4], atol=1e-7)
    assert np.isnan(w[2])
    with pytest.raises(ValueError, match="does not fall"):
        main_lobe_width(x, np.ones_like(x))


def test_broadside_width_of_uniform_array_matches_array_factor_zero():
    """Uniform 5x5, 25 mm: 3 dB half-width where |sin(5 x)/(5 sin x)| = 1/sqrt 2, x = k d s / 2."""
    from scipy.optimize import brentq

    d = 0.025
    xc = brentq(lambda x: np.sin(5 * x) / (5 * np.sin(x)) - 1 / np.sqrt(2), 1e-3, 0.6)
    element = Transducer()
    # The element directivity narrows it a little: solve D(s) AF(s) = 1/sqrt 2 instead.
    s = brentq(lambda s: element.directivity(np.sqrt(1 - s**2), K)
               * np.sin(5 * K * d * s / 2) / (5 * np.sin(K * d * s / 2)) - 1 / np.sqrt(2),
               1e-4, 2 * xc / (K * d))
    w = cut_widths(ArrayLayout.uniform(5, d).positions, BROADSIDE[None], element, K,
                   np.radians(6.0), 12001)[0]
    np.testing.assert_allclose(w, 2 * np.arcsin(s), atol=np.radians(0.001))


def test_uniform_broadside_psll_is_the_grating_lobe_times_directivity():
    """The strongest side lobe of the uniform broadside beam inside the 60 x 40 deg FOV is the
    horizontal grating lobe, |AF| = 1 at sin t = lambda/d, so PSLL = D(t) (to 0.02 dB; the
    vertical one lies just outside, at 20.07 deg > 20 deg)."""
    element = Transducer()
    d = 0.025
    _, _, dirs = fov_grid(np.radians(60), np.radians(40), np.radians(0.1))
    layout = ArrayLayout.uniform(5, d).positions
    psll = peak_side_lobe_levels(layout, BROADSIDE[None], dirs.reshape(-1, 3), element, K,
                                 np.radians(6.0))[0]
    expected = element.directivity(np.sqrt(1 - (LAMBDA / d) ** 2), K)
    assert 20 * np.log10(psll) == pytest.approx(20 * np.log10(expected), abs=0.02)


def test_pair_psll_matches_separate_calls_and_two_way_bound():
    rng = np.random.default_rng(7)
    tx, rx = rng.uniform(-0.05, 0.05, (2, 25, 2))
    element = Transducer()
    _, _, steers = fov_grid(np.radians(60), np.radians(40), np.radians(10))
    _, _, dirs = fov_grid(np.radians(60), np.radians(40), np.radians(1))
    steers, dirs = steers.reshape(-1, 3), dirs.reshape(-1, 3)
    pair = pair_side_lobe_levels(tx, rx, steers, dirs, element, K, np.radians(6), block_size=5000)
    np.testing.assert_allclose(pair["tx"], peak_side_lobe_levels(tx, steers, dirs, element, K,
                                                                 np.radians(6)), rtol=1e-12)
    np.testing.assert_allclose(pair["two_way"], peak_side_lobe_levels(
        tx, steers, dirs, element, K, np.radians(6), rx_positions=rx), rtol=1e-12)
    # Two-way side lobes never exceed the product of the one-way ones.
    assert np.all(pair["two_way"] <= pair["tx"] * pair["rx"] * (1 + 1e-12))
