"""Echo synthesis against the direct summation of (1)(3), and the receive chain on known inputs."""

import numpy as np
import pytest

import mitsonar
from mitsonar.signal.detection import bistatic_depth
from mitsonar.trace.paths import Paths
from helpers import BROADSIDE, IDENTITY
from mitsonar.scene.xml import material_xml, rectangle_xml, write_scene
from mitsonar.evaluation.reference import direct_summation


@pytest.fixture(scope="module")
def wall_path(tmp_path_factory):
    return write_scene(tmp_path_factory.mktemp("wall") / "wall.xml",
                       material_xml("wall", preset="drywall"), rectangle_xml("wall", (0, 0, 1.0)))


def test_fast_synthesis_equals_direct_summation(wall_path):
    """Same paths (the paper model's 25 reflectors x 625 element pairs), ideal transducers."""
    cfg = mitsonar.SonarConfig(trace=mitsonar.TraceSettings(model="paper"), transducer_response=False,
                               sample_rate=400e3, noise_rms=0.0, max_range=1.5, baseband=False,
                               band_floor=1e-5)
    sonar = mitsonar.Sonar(wall_path, cfg)
    paths = sonar.tracer.trace(IDENTITY, BROADSIDE).paths
    fast = sonar.synthesizer.synthesize(paths, 25)
    oracle = direct_summation(paths, cfg.pulse, 25, fast.times)
    error = np.abs(fast.samples - oracle).max() / np.abs(oracle).max()
    assert error <= 3e-4, error  # measured 9.3e-5


def test_first_order_terms_match_their_spectrum(wall_path):
    """Paths with first-order terms b about carriers f_c (narrow-band merging), gridded with the
    kernel's derivative, against their spectrum evaluated bin by bin on the band,
    exp(-j 2 pi f tau) [a - j 2 pi (f - f_c) b] W(f); two carriers share one grid."""
    sonar = mitsonar.Sonar(wall_path, mitsonar.SonarConfig(noise_rms=0.0))
    synth = sonar.synthesizer
    rng = np.random.default_rng(5)
    n = 40
    delay = rng.uniform(1e-3, 20e-3, n)
    gain = rng.normal(size=n) + 1j * rng.normal(size=n)
    first_order = (rng.normal(size=n) + 1j * rng.normal(size=n)) * 1e-4  # [Pa s], ~0.1 ms spreads
    channel = rng.integers(0, 3, n)
    parts = [Paths(gain[k], delay[k], channel[k], first_order=first_order[k], carrier=carrier)
             for k, carrier in ((slice(0, 20), 39e3), (slice(20, n), 41e3))]
    fast = synth.groups_spectrum([(p, None) for p in parts], 3)
    band = sonar.band
    f = band.frequencies
    spectrum = np.zeros((3, len(f)), complex)
    for p in parts:
        terms = np.exp(-2j * np.pi * f[None] * (p.delay[:, None] - band.start_time)) \
            * (p.gain[:, None] - 2j * np.pi * (f[None] - p.carrier) * p.first_order[:, None])
        np.add.at(spectrum, p.channel, terms)
    exact = spectrum * band.system_spectrum()[band.bins]
    error = np.abs(fast - exact).max() / np.abs(exact).max()
    assert synth.tolerance == pytest.approx(3e-5) and error < synth.tolerance, error  # measured 2e-5


def test_noiseless_envelope_equals_the_envelope_of_the_recording(wall_path):
    """EchoProcessor.noiseless_envelope (from the summed analytic spectrum, as OFDM blanking and
    cross-talk use it) against envelope() of the synthesised noiseless recording of a wall echo
    on a steered beam: the same where the echo lies inside the recording."""
    from mitsonar.frames import direction_from_fov_angles

    u = direction_from_fov_angles(np.radians(8.0), np.radians(-4.0))
    sonar = mitsonar.Sonar(wall_path, mitsonar.SonarConfig(noise_rms=0.0))
    groups = sonar.echo_groups(sonar.tracer.trace(IDENTITY, u).paths, sonar.config.pulse)
    spectrum = sonar.synthesizer.groups_spectrum(groups, 25)
    recording = sonar.synthesizer.recording(sonar.band.to_analytic(spectrum))
    expected = sonar.processor.envelope(recording, u)
    got = sonar.processor.noiseless_envelope(spectrum, u)
    assert got.shape == expected.shape
    error = np.abs(got - expected).max() / expected.max()
    assert error < 1e-6, error  # measured 5.4e-7 (seed 0)


def test_resonant_response_attenuates_off_resonance_tones(wall_path):
    """A long tone burst reaches steady state: its level scales by |H(f)|^2 (TX and RX)."""
    levels = {}
    for f in (40e3, 32e3, 48e3):
        pulse = mitsonar.Pulse(frequency=f, cycles=200 * f / 40e3)  # 5 ms
        cfg = mitsonar.SonarConfig(pulse=pulse, noise_rms=0.0, max_range=1.0, baseband=False)
        sonar = mitsonar.Sonar(wall_path, cfg)
        rec = sonar.synthesizer.synthesize(Paths(np.array([1.0 + 0j]), np.array([1e-3]), np.array([0])), 1)
        # Steady state: 2 ms after the start (the switch-on transient rings at 40 kHz with a
        # 0.28 ms time constant) until 0.5 ms before the end; peak = sqrt(2) x RMS.
        window = (rec.times > 3e-3) & (rec.times < 5.5e-3)
        levels[f] = np.sqrt(2 * np.mean(rec.samples[0, window] ** 2))
    h = mitsonar.Transducer().frequency_response
    for f in (32e3, 48e3):
        assert levels[f] / levels[40e3] == pytest.approx(abs(h(f)) ** 2, rel=0.01)


def _single_path_recording(sonar, delay, gain=2.0 + 1.0j):
    n = sonar.config.geometry.rx.count
    paths = Paths(np.full(n, gain), np.full(n, delay), np.arange(n))
    return sonar.synthesizer.synthesize(paths, n)


def test_matched_filter_recovers_gain_and_fractional_delay(wall_path):
    sonar = mitsonar.Sonar(wall_path, mitsonar.SonarConfig(noise_rms=0.0))
    fs = sonar.config.sample_rate
    for delay in (4.0e-3, 4.0e-3 + 0.37 / fs, 9.123456e-3):
        rec = _single_path_recording(sonar, delay)
        env = sonar.processor.envelope(rec, BROADSIDE)
        det = sonar.processor.detect(env, rec.start_time, BROADSIDE)
        assert det.amplitude == pytest.approx(abs(2.0 + 1.0j), rel=1e-3)
        assert abs(det.time_of_arrival - delay) * fs < 0.02  # well below one sample


@pytest.mark.parametrize("baseband", [False, True])
def test_noise_threshold_matches_noise_statistics(wall_path, baseband):
    """The envelope of receiver noise alone, real or baseband recordings (same noise density on
    the band), against EchoProcessor.noise_envelope_rms: 16 recordings (~60 independent envelope
    samples each, away from the ends), so the estimate's own scatter is ~2 %."""
    sonar = mitsonar.Sonar(wall_path, mitsonar.SonarConfig(noise_rms=0.01, baseband=baseband))
    assert sonar.band.baseband == baseband
    power = []
    for seed in range(16):
        rec = sonar.synthesizer.synthesize(Paths.empty(), 25, noise_rms=0.01, seed=seed)
        env = sonar.processor.envelope(rec, BROADSIDE)
        middle = slice(len(env) // 10, -len(env) // 10)
        power.append(np.mean(env[middle] ** 2))
        det = sonar.processor.detect(env, rec.start_time, BROADSIDE)
        assert not det.detected and np.isnan(det.depth) and np.all(np.isnan(det.point))
    rms = np.sqrt(np.mean(power))
    assert rms == pytest.approx(sonar.processor.noise_envelope_rms(), rel=0.06)  # 0.99, 1.03


def test_bistatic_depth_inverts_the_geometry():
    rng = np.random.default_rng(0)
    b = np.array([0.0125, 0.0, 0.0])
    u = rng.normal(size=(100, 3))
    u[:, 2] = np.abs(u[:, 2]) + 1
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    d = rng.uniform(0.2, 6.0, 100)
    x = d[:, None] * u
    l = d + np.linalg.norm(x - b, axis=1)
    np.testing.assert_allclose(bistatic_depth(l, 0.0125, u @ b / 0.0125), d, rtol=1e-12)


def test_noise_needs_a_seed_and_is_reproducible(wall_path):
    sonar = mitsonar.Sonar(wall_path, mitsonar.SonarConfig(noise_rms=0.01))
    empty = Paths(np.zeros(0, complex), np.zeros(0), np.zeros(0, int))
    with pytest.raises(ValueError, match="seed"):
        sonar.synthesizer.synthesize(empty, 25, noise_rms=0.01)
    a = sonar.synthesizer.synthesize(empty, 25, noise_rms=0.01, seed=3).samples
    b = sonar.synthesizer.synthesize(empty, 25, noise_rms=0.01, seed=3).samples
    c = sonar.synthesizer.synthesize(empty, 25, noise_rms=0.01, seed=4).samples
    assert np.array_equal(a, b) and not np.array_equal(a, c)


def test_baseband_recording_equals_direct_summation(wall_path):
    """The pressure of a complex baseband recording, Re(samples exp(j 2 pi carrier t)) (paper
    model's paths, ideal transducers), against the direct summation of (1)(3) at the baseband
    sample times."""
    cfg = mitsonar.SonarConfig(trace=mitsonar.TraceSettings(model="paper"), transducer_response=False,
                               sample_rate=400e3, noise_rms=0.0, max_range=1.5, baseband=True,
                               band_floor=1e-5)
    sonar = mitsonar.Sonar(wall_path, cfg)
    synth = sonar.synthesizer
    paths = sonar.tracer.trace(IDENTITY, BROADSIDE).paths
    fast = synth.synthesize(paths, 25)
    assert fast.carrier == sonar.band.carrier > 0 and np.iscomplexobj(fast.samples)
    assert fast.sample_rate < cfg.sample_rate
    t = fast.times
    oracle = direct_summation(paths, cfg.pulse, 25, t)
    pressure = (fast.samples * np.exp(2j * np.pi * fast.carrier * t)).real
    error = np.abs(pressure - oracle).max() / np.abs(oracle).max()
    assert error <= 3e-4, error  # measured 8.0e-5, as real recordings at 400 kHz


@pytest.mark.parametrize("azimuth_deg, elevation_deg", [(0.0, 0.0), (15.0, 0.0), (20.0, 10.0)])
def test_narrowband_element_merge_matches_the_element_pair_sum(wall_path, azimuth_deg, elevation_deg):
    """Each hit's 25 transmit elements merged about the carrier (Paths.narrowband, with its
    first-order term) against the synthesis of all 625 element pairs, on the same traced paths of
    a steered beam, no noise: the TCT40 pulse and an OFDM code's tones, and the depth."""
    from mitsonar.frames import direction_from_fov_angles
    from mitsonar.signal.ofdm import Code
    from mitsonar.sensors.ofdm_sonar import OfdmSonar

    u = direction_from_fov_angles(np.radians(azimuth_deg), np.radians(elevation_deg))
    sonar = mitsonar.Sonar(wall_path, mitsonar.SonarConfig(noise_rms=0.0))
    paths = sonar.tracer.trace(IDENTITY, u).paths
    synth = OfdmSonar(sonar).synth  # serves the pulse and the codes' bands
    for waveform, tolerance in ((sonar.config.pulse, 0.015), (Code(36e3, 44e3), 0.08)):
        groups = sonar.echo_groups(paths, waveform, synth)
        assert sum(len(p) for p, _ in groups) <= len(paths) // 6  # merged: 2 x 25 per hit and tone
        exact = synth.analytic(paths, 25, waveform)
        error = np.abs(synth.analytic_sum(groups, 25) - exact).max() / np.abs(exact).max()
        assert error < tolerance, (waveform, error)  # measured <= 0.8 % and <= 5 %
    pairs = mitsonar.Sonar(sonar.scene, mitsonar.SonarConfig(noise_rms=0.0, narrowband_bandwidth=0.0))
    exact, merged = pairs.ping(IDENTITY, u).detection, sonar.ping(IDENTITY, u).detection
    assert merged.detected == exact.detected
    assert merged.detected or azimuth_deg > 0  # the steered beams' echo arrives off-beam
    if merged.detected:
        assert abs(merged.depth - exact.depth) < 1e-3, (merged.depth, exact.depth)  # measured 2e-7 m


def test_broadband_transducers_are_not_merged(wall_path):
    """With 20 kHz transducers the echoes are too broad for merging (measured error 15-40 % on
    steered beams): every element pair is synthesised."""
    from mitsonar.signal.ofdm import Code
    from mitsonar.physics.transducer import Transducer

    sonar = mitsonar.Sonar(wall_path, mitsonar.SonarConfig(transducer=Transducer(bandwidth_6db=20e3)))
    paths = sonar.tracer.trace(IDENTITY, BROADSIDE).paths
    code = Code(36e3, 44e3)
    assert sonar.echo_groups(paths, code) == [(paths, code)]


def test_fused_narrowband_merge_equals_the_expanded_merge(wall_path):
    """HitPaths.narrowband (one Dr.Jit kernel over patches x receive elements, single precision)
    against Paths.narrowband of the same paths expanded to every element pair (NumPy), on a
    steered beam of the physical model and on the paper's point reflectors."""
    from mitsonar.frames import direction_from_fov_angles

    u = direction_from_fov_angles(np.radians(12.0), np.radians(-5.0))
    for preset in ("default", "paper"):
        sonar = mitsonar.Sonar(wall_path, mitsonar.SonarConfig.preset(preset))
        hit_paths = sonar.tracer.trace(IDENTITY, u).paths
        assert len(hit_paths) == len(hit_paths.tx_delay) * 625
        fused, expanded = hit_paths.narrowband(40e3), hit_paths.paths.narrowband(40e3)
        np.testing.assert_array_equal(fused.channel, expanded.channel)
        assert fused.carrier == expanded.carrier == 40e3
        assert np.abs(fused.delay - expanded.delay).max() < 1e-9  # [s]; measured 2e-11
        for a, b in ((fused.gain, expanded.gain), (fused.first_order, expanded.first_order)):
            assert np.abs(a - b).max() < 1e-5 * np.abs(b).max()  # measured 9e-7
