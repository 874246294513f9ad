"""Ray density that follows range and footprint (TraceSettings.max_merge, max_patch_phase):
the patch criterion against exact geometry, merged patches against the fixed grid's echoes on a
near and a far wall, and the arrival bounds of factored paths computed once."""

from dataclasses import replace

import numpy as np
import pytest

import mitsonar
from helpers import BROADSIDE, IDENTITY
from mitsonar.scene.xml import material_xml, rectangle_xml, sphere_xml
from mitsonar.trace.density import block_sizes, patch_phase_error

QUIET = mitsonar.SonarConfig(noise_rms=0.0)
RIGID = {"impedance": 1e12, "scattering": 0.0}
K = 2 * np.pi * 40e3 / 343.0  # carrier wavenumber [rad/m]


def _merged(config, max_merge=4):
    return replace(config, trace=replace(config.trace, max_merge=max_merge))


FIXED = _merged(QUIET, 1)  # the fixed grid: the dense reference


def test_phase_criterion_matches_the_exact_two_way_path_lengths():
    """The criterion's terms against the exact path lengths from the origin to a patch's corners
    (flat patches, normal and 40 deg incidence, ranges 0.3-4 m): within 10 % (the neglected
    terms are higher order in the patch size over the range)."""
    rng = np.random.default_rng(1)
    for t in (0.3, 1.0, 4.0):
        for tilt in (0.0, np.radians(40.0)):
            d = np.array([0.0, 0.0, 1.0])
            normal = np.array([np.sin(tilt), 0.0, -np.cos(tilt)])
            w = rng.uniform(0.005, 0.02, 2)  # cell widths [rad]
            dd1, dd2 = np.array([w[0], 0, 0]), np.array([0, w[1], 0])
            # Exact: the path lengths to the corners of the patch the tracer integrates over
            # (centre t d, edges the cell's differentials projected on the plane).
            edges = [t * (dd - d * (dd @ normal) / (d @ normal)) for dd in (dd1, dd2)]
            corners = [t * d + 0.5 * (s1 * edges[0] + s2 * edges[1])
                       for s1, s2 in ((1, 1), (1, -1), (-1, 1), (-1, -1))]
            lengths = 2 * np.linalg.norm(corners, axis=1)  # two-way from the origin
            linear = 2 * t + 2 * np.array([d @ (0.5 * (s1 * edges[0] + s2 * edges[1]))
                                           for s1, s2 in ((1, 1), (1, -1), (-1, 1), (-1, -1))])
            exact_quadratic = K * np.abs(lengths - linear).max()
            # k_top = k_centre: the quadratic term alone.
            got = patch_phase_error(np.array([t]), d[None], normal[None], dd1[None], dd2[None],
                                    K, K)[0]
            assert got == pytest.approx(exact_quadratic, rel=0.1), (t, tilt)
            # The dispersion term: (k_top - k_c) times the largest two-way linear offset.
            dispersion = patch_phase_error(np.array([t]), d[None], normal[None], dd1[None],
                                           dd2[None], 2 * K, K)[0] - 2 * got
            assert dispersion == pytest.approx(K * np.abs(linear - 2 * t).max(), rel=1e-9)


def test_phase_criterion_counts_curvature_and_grazing_incidence():
    t, d, n = np.array([1.0]), np.array([[0.0, 0.0, 1.0]]), np.array([[0.0, 0.0, -1.0]])
    dd1, dd2 = np.array([[0.01, 0, 0]]), np.array([[0, 0.01, 0]])
    flat = patch_phase_error(t, d, n, dd1, dd2, K, K)[0]
    curved = patch_phase_error(t, d, n, dd1, dd2, K, K, np.array([0.1]))[0]
    # The sagitta term: k |E1 + E2| alpha = k sqrt(2) 1 cm x 0.1.
    assert curved - flat == pytest.approx(K * np.sqrt(2) * 0.01 * 0.1, rel=1e-9)
    grazing = patch_phase_error(t, d, np.array([[1.0, 0.0, 0.0]]), dd1, dd2, K, K)[0]
    assert grazing == np.inf


def test_block_shapes_largest_first():
    assert block_sizes(1) == []
    assert block_sizes(2) == [(2, 2), (1, 2), (2, 1)]
    assert block_sizes(4)[:3] == [(4, 4), (2, 4), (4, 2)]
    with pytest.raises(ValueError, match="max_merge"):
        mitsonar.TraceSettings(max_merge=3)
    with pytest.raises(ValueError, match="max_patch_phase"):
        mitsonar.TraceSettings(max_patch_phase=0.0)


@pytest.fixture(scope="module")
def walls(tmp_path_factory):
    """Rigid walls at normal incidence, near and far: distance -> (fixed, merged) pings."""
    from mitsonar.scene.xml import write_scene

    out = {}
    for distance in (0.5, 4.0):
        path = write_scene(tmp_path_factory.mktemp("wall") / "wall.xml",
                           material_xml("wall", **RIGID),
                           rectangle_xml("wall", (0, 0, distance), size=(30, 30)))
        out[distance] = tuple(mitsonar.Sonar(path, config).ping(IDENTITY, BROADSIDE)
                              for config in (FIXED, _merged(QUIET)))
    return out


@pytest.mark.parametrize("distance", [0.5, 4.0])
def test_merged_echo_matches_the_fixed_grid_on_a_near_and_a_far_wall(walls, distance):
    """Same decision, depth within 0.5 mm, echo energy and peak within 0.5 dB of the fixed
    grid's (measured: 0.05 / 0.17 mm, 0.05 / 0.06 dB, 0.05 / 0.09 dB at 0.5 / 4 m)."""
    fixed, merged = walls[distance]
    assert fixed.detection.detected and merged.detection.detected
    assert abs(merged.detection.depth - fixed.detection.depth) <= 5e-4
    energy = [np.sum(p.envelope ** 2) for p in (fixed, merged)]
    assert abs(10 * np.log10(energy[1] / energy[0])) <= 0.5
    assert abs(20 * np.log10(merged.envelope.max() / fixed.envelope.max())) <= 0.5


def test_near_walls_need_fewer_patches(walls):
    """At 0.5 m the criterion allows blocks of up to 4 x 4 main-lobe cells: a third of the
    fixed grid's patches (measured 340 of 968); at 4 m it allows few (872 of 968)."""
    near, far = (tuple(len(p.trace.hit_points) for p in walls[d]) for d in (0.5, 4.0))
    assert near[1] <= 0.5 * near[0]
    assert far[1] >= 0.8 * far[0]
    assert near[1] < far[1] <= far[0]


def test_merging_spares_a_curved_surface(scene_file):
    """A 10 cm metal sphere 1 m ahead: its normals turn too fast for the criterion (the sagitta
    term), so merging leaves its echo as the fixed grid gives it: same depth within 0.5 mm,
    energy within 0.5 dB."""
    path = scene_file("sphere", material_xml("m", preset="metal", scattering=0.0),
                      sphere_xml("m", (0.0, 0.0, 1.0), 0.1))
    fixed, merged = (mitsonar.Sonar(path, config).ping(IDENTITY, BROADSIDE)
                     for config in (FIXED, _merged(QUIET)))
    assert fixed.detection.detected and merged.detection.detected
    assert abs(merged.detection.depth - fixed.detection.depth) <= 5e-4
    energy = [np.sum(p.envelope ** 2) for p in (fixed, merged)]
    assert abs(10 * np.log10(energy[1] / energy[0])) <= 0.5


def test_arrival_bounds_are_computed_once_and_follow_selection(scene_file):
    path = scene_file("wall", material_xml("wall", **RIGID), rectangle_xml("wall", (0, 0, 1.0)))
    paths = mitsonar.Sonar(path, QUIET).tracer.trace(IDENTITY, BROADSIDE).paths
    earliest, latest = paths.arrivals
    np.testing.assert_array_equal(earliest, paths.tx_delay.min(1) + paths.rx_delay.min(1))
    np.testing.assert_array_equal(latest, paths.tx_delay.max(1) + paths.rx_delay.max(1))
    assert paths.arrivals is paths.arrivals  # cached
    rows = np.argsort(earliest)[::3]
    chosen = paths.select(rows)
    assert "arrivals" in chosen.__dict__  # carried over, not recomputed
    np.testing.assert_array_equal(chosen.arrivals[0], earliest[rows])
    np.testing.assert_array_equal(chosen.arrivals[1], latest[rows])


def test_merged_blocks_keep_the_speckle_of_a_near_rough_wall(scene_file):
    """A concrete wall (scattering 0.1) 0.7 m ahead, 35 beams over the field of view: merged
    blocks sum their cells' diffuse phasors (with their carrier phases to the block's centre),
    so the diffuse echoes stay the fixed grid's realisation: at least 32 of 35 decisions the
    same and amplitudes within 1 dB (median) where both detect (measured 33/35, 0.45 dB;
    another diffuse seed on the fixed grid: 15/35, 1.5 dB)."""
    path = scene_file("rough", material_xml("w", preset="concrete"),
                      rectangle_xml("w", (0, 0, 0.7), size=(20, 20)))
    fixed, merged = (mitsonar.Sonar(path, config) for config in (FIXED, _merged(QUIET)))
    directions = fixed.fov_grid(np.radians(10.0))
    ours, theirs = (s.scan(IDENTITY, directions) for s in (merged, fixed))
    assert np.sum(ours.detected == theirs.detected) >= 32
    both = ours.detected & theirs.detected
    assert np.median(np.abs(20 * np.log10(ours.amplitude[both] / theirs.amplitude[both]))) <= 1.0
