"""Gridding factored element pairs (HitPaths) from their factors against gridding their expansion
into every pair: the same grid, whatever the patch size, range or steering."""

import numpy as np
import pytest

import mitsonar
from mitsonar.frames import direction_from_fov_angles
from mitsonar.physics.transducer import Transducer
from mitsonar.scene.xml import material_xml, rectangle_xml, write_scene
from mitsonar.trace.paths import Paths
from helpers import IDENTITY

#: Broadband transducers: every element pair is synthesised (no narrow-band merge).
BROADBAND = mitsonar.SonarConfig(transducer=Transducer(bandwidth_6db=20e3), noise_rms=0.0)


@pytest.fixture(scope="module")
def walls(tmp_path_factory):
    """A wall 0.6 m ahead (patches in the array's near field) and one 4.5 m ahead, tilted 60 deg
    (large far patches: their patch integrals' sinc arguments reach ~200)."""
    near = write_scene(tmp_path_factory.mktemp("near") / "near.xml",
                       material_xml("wall", preset="drywall"), rectangle_xml("wall", (0, 0, 0.6)))
    far = write_scene(tmp_path_factory.mktemp("far") / "far.xml",
                      material_xml("wall", preset="drywall"),
                      rectangle_xml("wall", (0, 0, 4.5), euler_deg=(0, 60, 0)))
    return near, far


def _relative_difference(a, b) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


@pytest.mark.parametrize("which", [0, 1])
def test_factored_pairs_grid_as_their_expansion(walls, which):
    """A steered beam's every element pair: gridded from the factors (single-precision gains,
    double-precision delays) against the expanded pairs (double-precision gains, single-precision
    sinc); measured 1e-7 (near) and 5e-6 (far: the sinc of arguments ~200 rounds differently in
    the two) of the grid's peak apart, tolerance 2e-5 (the synthesis tolerance is 3e-5)."""
    sonar = mitsonar.Sonar(walls[which], BROADBAND)
    synth = sonar.synthesizer
    hits = sonar.tracer.trace(IDENTITY, direction_from_fov_angles(np.radians(-15.0),
                                                                  np.radians(-5.0))).paths
    assert len(hits.tx_delay) > 100
    assert sonar.echo_groups(hits, sonar.config.pulse) == [(hits, sonar.config.pulse)]
    pairs, expanded = synth.impulse_grid(hits, 25), synth.impulse_grid(hits.paths, 25)
    assert _relative_difference(pairs, expanded) < 2e-5


def test_point_reflectors_grid_as_their_expansion(walls):
    """The paper model's point reflectors have no specular term (``HitPaths.specular_free``):
    the kernel forms their pairs' gains from the diffuse factors alone; whole array
    transmitting, ideal transducers, every pair gridded, against the expanded pairs (the same
    2e-5 of the grid's peak as above), and a physical model's hits are not specular-free."""
    config = mitsonar.SonarConfig.preset("paper")
    sonar = mitsonar.Sonar(walls[0], config)
    hits = sonar.tracer.trace(IDENTITY, direction_from_fov_angles(np.radians(10.0), 0.0)).paths
    assert hits.specular_free and len(hits.tx_delay) == 25 and np.abs(hits.diffuse).max() > 0
    pairs = sonar.synthesizer.impulse_grid(hits, 25)
    assert _relative_difference(pairs, sonar.synthesizer.impulse_grid(hits.paths, 25)) < 2e-5
    physical = mitsonar.Sonar(walls[0], BROADBAND).tracer.trace(IDENTITY, [0.0, 0.0, 1.0]).paths
    assert not physical.specular_free


def test_factored_and_flat_paths_share_a_synthesis(walls):
    """Factored echoes and flat direct paths driven by one waveform (one spectrum), against the
    same paths all flat; and patches partly or wholly after the recording's end, which the
    factored gridding leaves out by patch before its kernel and by pair inside it."""
    sonar = mitsonar.Sonar(walls[1], BROADBAND)
    synth, band = sonar.synthesizer, sonar.band
    hits = sonar.tracer.trace(IDENTITY, direction_from_fov_angles(0.0, 0.0)).paths
    direct = sonar.tracer.direct_paths(np.array([0.0, 0.0, 1.0]))
    pulse = sonar.config.pulse
    joint = synth.groups_spectrum([(hits, pulse), (direct, pulse)], 25)
    flat = synth.groups_spectrum([(Paths.concatenate([hits.paths, direct]), pulse)], 25)
    assert _relative_difference(joint, flat) < 1e-5
    end = band.start_time + band.n_samples / band.sample_rate
    arrival = hits.tx_delay.mean(axis=1) + hits.rx_delay.mean(axis=1)
    late = hits.delayed(end - np.median(arrival))  # about half the patches after the end
    first = (late.tx_delay.min(axis=1) + late.rx_delay.min(axis=1) - end) * band.sample_rate
    assert 0.2 < np.mean(first > synth.half_width) < 0.8
    assert _relative_difference(synth.impulse_grid(late, 25),
                                synth.impulse_grid(late.paths, 25)) < 1e-5
    assert not np.any(synth.impulse_grid(hits.delayed(end), 25))


def test_merged_hits_grid_as_their_paths(walls):
    """Narrow-band merged paths straight from the merge kernel (MergedHits: Dr.Jit arrays, two
    beams delayed and joined as an OFDM cycle joins them) against the same paths copied out as
    flat Paths: the same numbers (measured no difference; tolerance 1e-6 of the peak)."""
    from mitsonar.sensors.ofdm_sonar import OfdmSonar

    sonar = mitsonar.Sonar(walls[0], mitsonar.SonarConfig(noise_rms=0.0))
    synth = OfdmSonar(sonar).synth
    code = OfdmSonar(sonar).codes[7]
    beams = [sonar.tracer.trace(IDENTITY, direction_from_fov_angles(np.radians(a), 0.0)).paths
             for a in (-10.0, 12.0)]
    groups = [(p.delayed(offset), tone) for offset, hits in zip((0.0, 1e-3), beams)
              for p, tone in sonar.echo_groups(hits, code, synth)]
    assert len(groups) == 4 and sum(len(p) for p, _ in groups) == 2 * sum(
        len(h.tx_delay) * 25 for h in beams)
    merged = synth.groups_spectrum(groups, 25)
    flat = synth.groups_spectrum([(p.paths, tone) for p, tone in groups], 25)
    assert _relative_difference(merged, flat) < 1e-6


def test_patches_after_the_recording_are_left_out_of_the_merge(walls):
    """A tilted wall reaching past the recording's end (4 m range; half its patches, measured
    594 of 1144): the merge leaves them out and the synthesis is that of every patch merged and
    gridded; merged paths refuse to be fired earlier (which would need the patches left out)."""
    sonar = mitsonar.Sonar(walls[1], mitsonar.SonarConfig(noise_rms=0.0, max_range=4.0))
    synth, pulse = sonar.synthesizer, sonar.config.pulse
    hits = sonar.tracer.trace(IDENTITY, direction_from_fov_angles(0.0, 0.0)).paths
    groups = sonar.echo_groups(hits, pulse)
    kept = sum(len(p) for p, _ in groups) // 25
    assert 0.1 < kept / len(hits.tx_delay) < 0.9
    every = synth.group_spectrum(hits.narrowband(groups[0][0].frequency), pulse, 25)
    assert _relative_difference(synth.groups_spectrum(groups, 25), every) < 1e-6
    with pytest.raises(ValueError, match="seconds must be >= 0"):
        groups[0][0].delayed(-1e-3)


def test_path_sets_gridded_together_as_alone(walls, monkeypatch):
    """Several factored path sets gridded together (``impulse_grids``, as an OFDM cycle's beams
    of the paper preset are): each set's grid bit for bit what gridding it alone gives, whether
    the sets share one kernel launch or not (``PAIR_BATCH_SAMPLES`` small), with a set wholly
    after the recording (its grid zero) among them."""
    from mitsonar.signal import synthesis
    sonar = mitsonar.Sonar(walls[0], BROADBAND)
    synth, band = sonar.synthesizer, sonar.band
    traces = sonar.tracer.trace_many([IDENTITY] * 2, sonar.fov_grid(np.radians(30.0))[:2], [0, 1])
    end = band.start_time + band.n_samples / band.sample_rate
    sets = [traces[0].paths, traces[1].paths.delayed(1e-3), traces[0].paths.delayed(end)]
    alone = np.stack([synth.impulse_grid(paths, 25) for paths in sets])
    assert np.any(alone[0]) and np.any(alone[1]) and not np.any(alone[2])
    np.testing.assert_array_equal(synth.impulse_grids(sets, 25), alone)
    monkeypatch.setattr(synthesis, "PAIR_BATCH_SAMPLES", 1)  # a launch per set
    np.testing.assert_array_equal(synth.impulse_grids(sets, 25), alone)
