"""Receive imaging (mitsonar.signal.imaging) on synthesised point reflectors and on noise alone.

Echoes are synthesised from exact spherical-wave paths (transmit element -> reflector -> each
receive element), so the tests check the image, the detection rule and the placement against
known reflectors, without the tracer.
"""

import numpy as np
import pytest

import mitsonar
from mitsonar.frames import direction_from_fov_angles
from mitsonar.sensors.imaging_sonar import DEFOCUSED, TransmitSettings
from mitsonar.sensors.sonar import PRE_ROLL
from mitsonar.signal.band import Band
from mitsonar.signal.imaging import RANGE_LOBE_FLOOR, ReceiveImager, coherence_windows
from mitsonar.signal.imaging_settings import WIDE_SWEEP_SETTINGS, ImagingSettings
from mitsonar.signal.receiver import EchoProcessor
from mitsonar.signal.synthesis import EchoSynthesizer
from mitsonar.trace.paths import Paths

CONFIG = mitsonar.SonarConfig()
GEOMETRY = CONFIG.geometry
C = CONFIG.medium.speed_of_sound
#: The transmit element nearest the transmit origin (ImagingSonar's default transmission).
TRANSMITTER = GEOMETRY.tx_positions[2]
#: Path gain of the reflectors [Pa]: SNR ~150 against the default receiver noise.
GAIN = 1e-2


@pytest.fixture(scope="module")
def chain():
    """(band, synthesizer, imager) of the default configuration, grid over a 45 deg cone."""
    cfg = CONFIG
    band = Band(cfg.pulse, cfg.transducer, cfg.sample_rate, -PRE_ROLL, cfg.record_duration,
                cfg.transducer_response, floor=cfg.band_floor, baseband=cfg.baseband)
    imager = ReceiveImager(GEOMETRY, band, C, cfg.detection, cfg.noise_rms, TRANSMITTER,
                           np.radians(45))
    return band, EchoSynthesizer(band), imager


def _reflectors(points, gain=GAIN) -> Paths:
    """Exact paths of point reflectors (P, 3) [m], sensor frame, lit by TRANSMITTER."""
    points = np.asarray(points, dtype=float)
    rx = GEOMETRY.rx_positions
    delay = (np.linalg.norm(points - TRANSMITTER, axis=1)[:, None]
             + np.linalg.norm(points[:, None] - rx[None], axis=-1)) / C
    gains = np.broadcast_to(np.reshape(gain, (-1, 1)), delay.shape).astype(complex)
    return Paths(gains.ravel(), delay.ravel(), np.tile(np.arange(len(rx)), len(points)))


def _image(chain, paths, seed, imager=None):
    band, synth, default = chain
    imager = imager or default
    noiseless = np.zeros((GEOMETRY.rx.count, band.n_samples), complex) if paths is None \
        else band.to_samples(synth.group_spectrum(paths, None, GEOMETRY.rx.count))
    recording = synth.recording(noiseless, CONFIG.noise_rms, seed=seed)
    image, channels = imager.image(recording)
    return image, imager.points(image, channels, recording.start_time)


def _targets(horizontal_deg, vertical_deg, ranges):
    """Points at ``ranges`` [m] from the receive origin towards field-of-view angles [deg]."""
    u = direction_from_fov_angles(np.radians(horizontal_deg), np.radians(vertical_deg))
    return GEOMETRY.rx_origin + np.asarray(ranges)[:, None] * u


def test_an_image_row_is_the_receivers_beam(chain):
    """The separable delay-and-sum on the direction-cosine grid against the receiver's
    (EchoProcessor.noiseless_envelopes) towards the same directions, on noise: the same
    envelopes within the single precision of the steering factors."""
    band, synth, imager = chain
    recording = synth.recording(np.zeros((GEOMETRY.rx.count, band.n_samples), complex),
                                CONFIG.noise_rms, seed=3)
    spectra = band.band_spectra(recording.samples)
    rows = np.flatnonzero(imager.valid)[::97]
    processor = EchoProcessor(GEOMETRY, band, C, CONFIG.detection, CONFIG.noise_rms)
    beams = processor.noiseless_envelopes(spectra, imager.directions[rows])
    image = imager.envelopes(spectra)
    np.testing.assert_allclose(image[rows], beams, rtol=0, atol=2e-6 * beams.max())
    assert not image[~imager.valid].any()


def test_point_reflectors_are_placed_within_5_mm(chain):
    """Six reflectors across the field of view at 1.2-3.1 m, two of them in one direction 0.5 m
    apart: six points, each within 5 mm of its reflector (measured <= 4.3 mm: 0.1 deg of
    direction after the near-field correction, 2 mm of range), and no other."""
    targets = _targets([-20, -5, 12, 25, 3, 3], [10, -12, 4, -15, 15, 15],
                       [1.2, 1.9, 2.5, 3.1, 1.5, 2.0])
    for seed in (0, 1):
        _, found = _image(chain, _reflectors(targets), seed)
        error = np.linalg.norm(found.points[:, None] - targets[None], axis=-1)
        assert len(found) == len(targets)
        assert np.all(error.min(axis=1) <= 5e-3), error.min(axis=1)
        assert sorted(error.argmin(axis=1)) == list(range(len(targets)))
        assert np.all(found.snr > 100)  # 2e-2 Pa over the 6.7e-5 Pa noise envelope


def test_two_echoes_of_one_direction_count_once_within_the_range_resolution(chain):
    """Two equal reflectors in one direction: two points when their paths differ by 1.5 range
    resolutions, one when by half of one (the matched-filter envelope's width, 0.38 m of
    path, 0.19 m of range)."""
    _, _, imager = chain
    resolution = imager.range_resolution * C / 2  # [m] of range
    for apart, expected in ((1.5, 2), (0.5, 1)):
        targets = _targets([8, 8], [-6, -6], [1.6, 1.6 + apart * resolution])
        _, found = _image(chain, _reflectors(targets), seed=2)
        assert len(found) == expected, (apart, len(found))


def test_side_lobes_of_a_strong_return_are_not_points(chain):
    """One strong reflector (SNR ~ 5000): its side lobes rise far above the noise threshold all
    over the image, yet only the reflector is a point (each rule alone rejects them); without
    the side-lobe, clutter and coherence rules its side lobes would be points too (measured:
    16)."""
    band, _, _ = chain
    target = _targets([14], [-9], [1.4])
    _, found = _image(chain, _reflectors(target, gain=0.3), seed=4)
    assert len(found) == 1 and np.linalg.norm(found.points[0] - target[0]) < 5e-3
    bare = ReceiveImager(GEOMETRY, band, C, CONFIG.detection, CONFIG.noise_rms, TRANSMITTER,
                         np.radians(45), ImagingSettings(side_lobe_margin=0, clutter_margin=0,
                                                         min_coherence=0))
    assert len(_image(chain, _reflectors(target, gain=0.3), seed=4, imager=bare)[1]) >= 10


@pytest.mark.parametrize("step_deg", [1.0, 2.0])
def test_noise_alone_gives_the_design_false_alarm_rate(chain, step_deg):
    """Noise-only recordings at a lowered threshold (detection_snr 3; the clutter rule, which on
    noise alone only repeats the threshold, and the coherence rule, which there asks for an SNR
    of sqrt(min_coherence N_rx) = 3.2, off): points per image within a factor of two of
    the design value (expected Euler characteristic of the continuous image, 9.4 per image).
    Measured over 12 images: 1.04 x the design on a 1 deg grid, 0.65 x on the default 2 deg
    grid (peaks between its directions are seen lower)."""
    band, _, _ = chain
    settings = ImagingSettings(step=np.radians(step_deg), detection_snr=3.0, clutter_margin=0,
                               min_coherence=0)
    imager = ReceiveImager(GEOMETRY, band, C, CONFIG.detection, CONFIG.noise_rms, TRANSMITTER,
                           np.radians(40), settings)
    design = imager.expected_false_alarms(band.n_samples, band.start_time)
    counts = [len(_image(chain, None, seed, imager)[1]) for seed in range(12)]
    assert 0.5 * design <= np.mean(counts) <= 2 * design, (np.mean(counts), design)
    # At the default threshold (detection_snr 5) the design is ~5e-6 false points per image.
    assert imager.expected_false_alarms(band.n_samples, band.start_time, 5.0) < 1e-5


def test_bad_settings_are_one_clear_error(chain):
    band, _, _ = chain
    with pytest.raises(ValueError, match="ImagingSettings.step"):
        ImagingSettings(step=0.0)
    with pytest.raises(ValueError, match="clutter_margin"):
        ImagingSettings(clutter_margin=-1.0)
    for bands in (0, 1.5):
        with pytest.raises(ValueError, match="ImagingSettings.coherence_bands"):
            ImagingSettings(coherence_bands=bands)
    with pytest.raises(ValueError, match="detection_floor"):
        ReceiveImager(GEOMETRY, band, C, CONFIG.detection, 0.0, TRANSMITTER, np.radians(45))
    with pytest.raises(ValueError, match="half-diagonal"):
        ReceiveImager(GEOMETRY, band, C, CONFIG.detection, CONFIG.noise_rms, TRANSMITTER,
                      np.radians(30))


def test_coherence_reads_each_channel_at_its_delay_towards_the_direction(chain):
    """The coherence factor against its definition, |sum_j x_j|^2 / (N_rx sum_j |x_j|^2), with
    x_j channel j matched-filtered and delayed exactly (in the frequency domain) by (5) towards
    the grid direction, at cells across a reflector's echo 28 deg off axis (where the channels'
    delays differ most): within 1 % (measured 0.005 %)."""
    band, synth, imager = chain
    target = _targets([28], [-12], [1.8])
    paths = _reflectors(target)
    spectra = synth.group_spectrum(paths, None, GEOMETRY.rx.count)
    image, channels = imager.envelopes(spectra), imager.channel_signals(spectra)
    d = np.argmax(image.max(axis=1))
    k = int(np.argmax(image[d])) + np.array([-2, -1, -0.5, 0, 0.5, 1]) * imager._range_window // 2
    k = k.astype(int)
    offsets = GEOMETRY.rx_positions - GEOMETRY.rx_origin
    delay = offsets @ imager.directions[d] / C  # [s] behind which each channel is read
    steer = np.exp(-2j * np.pi * band.frequencies[None] * delay[:, None])
    exact = band.to_analytic(spectra * steer * imager._filter)[:, k]
    expected = np.abs(exact.sum(axis=0)) ** 2 / (len(offsets) * np.sum(np.abs(exact)**2, axis=0))
    np.testing.assert_allclose(imager.coherence(channels, np.full(len(k), d), k), expected,
                               rtol=1e-2)


def test_echoes_arriving_together_are_not_trusted(chain):
    """One reflector alone: its point's coherence is ~1 (>= 0.95). Two equal reflectors 24 deg
    apart at the same path length: at their instant the channels hear both, one plane wave
    explains about half their power (0.3-0.7 each), so neither is trusted at min_coherence 0.75
    (the side-lobe and clutter rules off). Without the coherence rule both are points (within
    2 cm: each echo's direction is pulled by the other's side lobes, measured 14-18 mm), and so
    are many of their side lobes."""
    band, _, _ = chain
    settings = ImagingSettings(side_lobe_margin=0, clutter_margin=0, min_coherence=0.75)
    imager = ReceiveImager(GEOMETRY, band, C, CONFIG.detection, CONFIG.noise_rms, TRANSMITTER,
                           np.radians(45), settings)
    one = _targets([-12], [0], [2.0])
    _, alone = _image(chain, _reflectors(one), seed=5, imager=imager)
    assert len(alone) == 1 and alone.coherence[0] >= 0.95, alone.coherence
    two = _targets([-12, 12], [0, 0], [2.0, 2.0])
    _, together = _image(chain, _reflectors(two), seed=5, imager=imager)
    assert len(together) == 0, together.coherence
    assert together.passed["clutter"] >= 2
    bare = ReceiveImager(GEOMETRY, band, C, CONFIG.detection, CONFIG.noise_rms, TRANSMITTER,
                         np.radians(45), ImagingSettings(side_lobe_margin=0, clutter_margin=0,
                                                         min_coherence=0))
    _, kept = _image(chain, _reflectors(two), seed=5, imager=bare)
    error = np.linalg.norm(kept.points[:, None] - two[None], axis=-1)  # (P, 2)
    nearest = error.argmin(axis=0)
    assert np.all(error.min(axis=0) < 0.02), error.min(axis=0)  # each pulled by the other's lobes
    assert np.all((0.3 <= kept.coherence[nearest]) & (kept.coherence[nearest] <= 0.75)), \
        kept.coherence[nearest]


def test_the_rules_pass_fewer_cells_in_turn(chain):
    """ImagePoints.passed counts the field of view's cells passing each rule in turn, down to the
    points."""
    _, found = _image(chain, _reflectors(_targets([5, -18], [3, 8], [1.5, 2.4])), seed=6)
    counts = list(found.passed.values())
    assert list(found.passed) == ["threshold", "range_peak", "main_lobe_peak", "side_lobe",
                                  "range_side_lobe", "clutter", "trusted"]
    assert counts == sorted(counts, reverse=True) and counts[-1] == len(found) == 2, counts


def test_a_sector_ping_is_placed_from_its_virtual_source(chain):
    """'sectors': the array steered to a sector and defocused, its elements fired as from a
    virtual source v_s 0.3 m behind the array (exact spherical-wave paths from every transmit
    element). Reflectors across the sector are each placed within 5 mm (measured 0.9-3.2 mm)
    with the transmit leg from the virtual source, |x - v_s| - d_s; from the transmit origin
    instead 5.5-8.5 mm off."""
    band, synth, _ = chain
    emission = TransmitSettings(transmit="sectors").emissions(GEOMETRY, C)[0]  # lower left
    h0, h1, v0, v1 = np.degrees(emission.region)
    targets = _targets([h0 + 3, 0.5 * (h0 + h1), h1 - 3], [v1 - 3, v0 + 4, 0.5 * (v0 + v1)],
                       [1.6, 2.2, 2.8])
    tx, rx = GEOMETRY.tx_positions, GEOMETRY.rx_positions
    delay = emission.firing[None, :, None] + (
        np.linalg.norm(targets[:, None] - tx[None], axis=-1)[:, :, None]
        + np.linalg.norm(targets[:, None] - rx[None], axis=-1)[:, None, :]) / C
    paths = Paths(np.full(delay.size, GAIN, complex), delay.ravel(),
                  np.tile(np.arange(len(rx)), len(targets) * len(tx)))
    errors = {}
    for name, source, lead in (("virtual", emission.source, emission.lead),
                               ("origin", np.zeros(3), 0.0)):
        imager = ReceiveImager(GEOMETRY, band, C, CONFIG.detection, CONFIG.noise_rms, source,
                               np.radians(45), region=emission.region)
        recording = synth.recording(band.to_samples(synth.group_spectrum(
            paths, None, GEOMETRY.rx.count)), CONFIG.noise_rms, seed=7)
        image, channels = imager.image(recording)
        found = imager.points(image, channels, recording.start_time + lead / C)
        error = np.linalg.norm(found.points[:, None] - targets[None], axis=-1)
        assert len(found) == len(targets), (name, len(found))
        errors[name] = error.min(axis=0)
    assert np.all(errors["virtual"] <= 5e-3), errors
    assert errors["origin"].max() > 5e-3, errors


@pytest.fixture(scope="module")
def wide():
    """(band, synthesizer, config) of the ``paper`` preset driven by the 20-80 kHz sweep."""
    cfg = mitsonar.SonarConfig.preset("paper").with_wide_sweep()
    band = Band(cfg.pulse, cfg.transducer, cfg.sample_rate, -PRE_ROLL, cfg.record_duration,
                cfg.transducer_response, floor=cfg.band_floor, baseband=cfg.baseband)
    return band, EchoSynthesizer(band), cfg


def _wide_imager(wide, **settings):
    band, _, cfg = wide
    return ReceiveImager(GEOMETRY, band, C, cfg.detection, cfg.noise_rms, TRANSMITTER,
                         np.radians(45), ImagingSettings(**settings))


def test_coherence_sub_bands_tile_the_sweep_and_are_averaged(wide):
    """``coherence_bands`` = 3 behind the 20-80 kHz sweep: three Hann windows a third of the
    system spectrum's -6 dB extent apart (21.8-78.2 kHz: the sweep's 10 % taper), centred in
    its thirds (within one bin), summing to one between the outer centres (to 1e-12), zero
    beyond a window's width outside the extent; the coherence is the mean of the
    factor's definition in each window, each channel matched-filtered in it and delayed exactly
    (in the frequency domain) towards the grid direction, at cells across a reflector's echo
    28 deg off axis: within 1 % (measured 0.003 %: each sub-band is read demodulated about its
    centre). One reflector alone keeps >= 0.85 at its peak (a single plane wave in every
    sub-band, read at its grid direction, up to 1 deg from its own, where the highest window's
    narrower beam loses most: 0.89); one band: one set of channels."""
    band, synth, _ = wide
    imager = _wide_imager(wide, coherence_bands=3)
    f = band.frequencies
    system = np.abs(band.system_spectrum()[band.bins])
    windows = coherence_windows(f, system, 3)
    np.testing.assert_array_equal(imager._coherence_filters, imager._filter * windows)
    inside = f[system >= 0.5 * system.max()]  # the sweep's -6 dB extent (its 10 % taper)
    low, high = inside.min(), inside.max()
    assert abs(low - 20e3) < 2.5e3 and abs(high - 80e3) < 2.5e3, (low, high)
    step = (high - low) / 3
    centres = f[windows.argmax(axis=1)]
    np.testing.assert_allclose(centres, low + (np.arange(3) + 0.5) * step, atol=f[1] - f[0])
    between = (f >= centres[0] + f[1] - f[0]) & (f <= centres[-1] - (f[1] - f[0]))
    np.testing.assert_allclose(windows.sum(axis=0)[between], 1.0, atol=1e-12)
    assert np.all(windows[:, (f < low - step) | (f > high + step)] == 0)
    spectra = synth.group_spectrum(_reflectors(_targets([28], [-12], [1.8])), None,
                                   GEOMETRY.rx.count)
    image, channels = imager.envelopes(spectra), imager.channel_signals(spectra)
    assert channels.shape[0] == 3
    d = np.argmax(image.max(axis=1))
    k = (int(np.argmax(image[d])) + np.array([-2, -1, 0, 1, 2])).astype(int)
    offsets = GEOMETRY.rx_positions - GEOMETRY.rx_origin
    steer = np.exp(-2j * np.pi * f[None] * (offsets @ imager.directions[d] / C)[:, None])
    exact = band.to_analytic(spectra[None] * steer[None] * imager._coherence_filters[:, None])
    exact = exact[..., k]  # (3, N_rx, cells)
    expected = np.mean(np.abs(exact.sum(axis=1)) ** 2
                       / (len(offsets) * np.sum(np.abs(exact) ** 2, axis=1)), axis=0)
    measured = imager.coherence(channels, np.full(len(k), d), k)
    np.testing.assert_allclose(measured, expected, rtol=1e-2)
    assert measured[2] >= 0.85, measured
    whole = _wide_imager(wide)
    assert whole.channel_signals(spectra).shape[0] == 1


def test_a_defocused_arrays_echo_trains_are_one_point_each(wide):
    """The whole array defocused over the field of view (``DEFOCUSED``: one sector, virtual
    source 0.1 m behind the array) behind the 20-80 kHz sweep: each reflector's echo is a train
    of the 25 elements' copies spread over 6-62 mm of path (exact spherical-wave paths from
    every element). Seven reflectors across the field of view, its corners included: exactly
    seven points, each within 6 mm of its reflector (measured 1.7-5.1 mm: the train's power
    centroid less the elements' mean excess path towards it). Imaged as one element's echoes
    (no ``transmit``) the copies are points of their own: 30 (four a reflector), up to 16 cm
    off."""
    band, synth, cfg = wide
    emission = DEFOCUSED.emissions(GEOMETRY, C)[0]
    h0, h1, v0, v1 = np.degrees(emission.region)
    targets = _targets([h0 + 3, 0, h1 - 3, h0 + 3, h1 - 3, 12, -15],
                       [v1 - 3, 0, v0 + 3, v0 + 3, v1 - 3, -8, 10],
                       [1.6, 2.2, 2.8, 2.0, 2.5, 3.2, 1.9])
    tx, rx = GEOMETRY.tx_positions, GEOMETRY.rx_positions
    delay = emission.firing[None, :, None] + (
        np.linalg.norm(targets[:, None] - tx[None], axis=-1)[:, :, None]
        + np.linalg.norm(targets[:, None] - rx[None], axis=-1)[:, None, :]) / C
    paths = Paths(np.full(delay.size, 1e-3, complex), delay.ravel(),
                  np.tile(np.arange(len(rx)), len(targets) * len(tx)))
    recording = synth.recording(band.to_samples(synth.group_spectrum(
        paths, None, GEOMETRY.rx.count)), cfg.noise_rms, seed=7)
    found = {}
    for name, transmit in (("train", (tx, emission.firing, emission.lead)), ("element", None)):
        imager = ReceiveImager(GEOMETRY, band, C, cfg.detection, cfg.noise_rms, emission.source,
                               DEFOCUSED.cone_half_angle, WIDE_SWEEP_SETTINGS,
                               emission.region, transmit)
        image, channels = imager.image(recording)
        found[name] = imager.points(image, channels, recording.start_time + emission.lead / C)
    error = np.linalg.norm(found["train"].points[:, None] - targets[None], axis=-1)
    assert len(found["train"]) == len(targets), len(found["train"])
    assert sorted(error.argmin(axis=1)) == list(range(len(targets)))
    assert np.all(error.min(axis=1) <= 6e-3), error.min(axis=1)
    assert len(found["element"]) >= 3 * len(targets), len(found["element"])


def test_range_side_lobe_check_reads_only_where_the_lobes_are(wide):
    """Rule 4's range check reads each cell's lags up to where the matched filter's range side
    lobes fall below ``RANGE_LOBE_FLOOR`` (the 20-80 kHz sweep: a few hundred lags of a
    recording of thousands): the table ends at its last lag above the floor, and on a random
    image the levels equal the brute-force max over every sample of the row with the table
    zero beyond its end (cells at both ends of the recording and in between; exactly)."""
    imager = _wide_imager(wide)
    lobes = imager._range_lobes
    n = wide[0].n_samples
    assert lobes[-1] > RANGE_LOBE_FLOOR and 10 < len(lobes) < n // 4, (len(lobes), n)
    rng = np.random.default_rng(3)
    sub = rng.random((4, n)).astype(np.float32)
    row = np.array([0, 1, 2, 3, 0, 1])
    k = np.array([0, 1, n // 2, n - 1, len(lobes) - 2, n - len(lobes)])
    full = np.zeros(n, np.float32)
    full[:len(lobes)] = lobes
    expected = [np.max(sub[r] * full[np.abs(c - np.arange(n))]) for r, c in zip(row, k)]
    np.testing.assert_array_equal(imager._range_side_lobe_levels(sub, row, k), expected)


def test_sub_band_coherence_does_not_trust_echoes_arriving_together(wide):
    """Behind the 20-80 kHz sweep, with the coherence averaged over three sub-bands (the
    side-lobe and clutter rules off): one reflector alone is a point of coherence >= 0.95; two
    equal reflectors 24 deg apart at the same path length are not trusted at 0.8 (one plane
    wave explains about half their power in every sub-band: 0.3-0.75 without the rule). Alone,
    read at its grid direction (up to 1 deg from its own, where the 70 kHz window's narrower
    beam loses most), >= 0.9."""
    off = dict(side_lobe_margin=0, clutter_margin=0, coherence_bands=3)
    band, synth, cfg = wide
    strict, bare = _wide_imager(wide, min_coherence=0.8, **off), \
        _wide_imager(wide, min_coherence=0.0, **off)

    def points(targets, imager):
        noiseless = band.to_samples(synth.group_spectrum(_reflectors(targets), None,
                                                         GEOMETRY.rx.count))
        recording = synth.recording(noiseless, cfg.noise_rms, seed=5)
        image, channels = imager.image(recording)
        return imager.points(image, channels, recording.start_time)

    alone = points(_targets([-12], [0], [2.0]), strict)
    assert len(alone) == 1 and alone.coherence[0] >= 0.9, alone.coherence
    two = _targets([-12, 12], [0, 0], [2.0, 2.0])
    assert len(points(two, strict)) == 0
    kept = points(two, bare)
    nearest = np.linalg.norm(kept.points[:, None] - two[None], axis=-1).argmin(axis=0)
    assert np.all((0.3 <= kept.coherence[nearest]) & (kept.coherence[nearest] <= 0.75)), \
        kept.coherence[nearest]


def test_points_placed_at_the_coherence_peak(wide):
    """``coherence_peak``: behind the 20-80 kHz sweep, with the coherence read in three
    sub-bands, five reflectors across the field of view at 1.2-3.1 m are placed at the peak of
    the coherence around their grid directions, each within 5 mm (measured <= 4.9 mm; from the
    image's peak <= 3.4 mm), and not where the image's peak puts them (neighbours taken in the
    wrong order put them centimetres off)."""
    band, synth, cfg = wide
    targets = _targets([-20, -5, 12, 25, 3], [10, -12, 4, -15, 15], [1.2, 1.9, 2.5, 3.1, 1.5])
    noiseless = band.to_samples(synth.group_spectrum(_reflectors(targets), None,
                                                     GEOMETRY.rx.count))
    recording = synth.recording(noiseless, cfg.noise_rms, seed=3)
    placed = {}
    for peak in (False, True):
        imager = _wide_imager(wide, coherence_bands=3, min_coherence=0.5, coherence_peak=peak)
        image, channels = imager.image(recording)
        found = imager.points(image, channels, recording.start_time)
        error = np.linalg.norm(found.points[:, None] - targets[None], axis=-1)
        assert sorted(error.argmin(axis=1)) == list(range(len(targets))), error.min(axis=1)
        assert np.all(error.min(axis=1) <= 5e-3), (peak, error.min(axis=1))
        placed[peak] = found.points[np.argsort(error.argmin(axis=1))]
    assert np.any(np.linalg.norm(placed[True] - placed[False], axis=1) > 1e-5)


def test_the_coherence_peak_is_sought_within_one_grid_step(wide):
    """The grid direction of a point is the image's peak, not always the coherence's: where the
    coherence keeps rising beyond the 8 neighbours (a Gaussian in direction cosines whose peak
    lies 3 steps away along u_x and 2 along u_y), the offsets stop at one step, and inside the
    neighbourhood they find the peak (0.4 and -0.3 steps: within 1e-9)."""
    imager = _wide_imager(wide, coherence_bands=3, coherence_peak=True)
    d = imager._fov_rows[len(imager._fov_rows) // 2]
    step = imager.spacing

    def fake(channels, rows, k):  # the coherence as a function of direction alone
        peak = imager.directions[d, :2] + step * np.asarray(fake.offset)
        return np.exp(-np.sum((imager.directions[rows, :2] - peak) ** 2, axis=1) / (4 * step) ** 2)

    imager.coherence = fake
    for offset, expected in (((3.0, 2.0), (1.0, 1.0)), ((0.4, -0.3), (0.4, -0.3))):
        fake.offset = offset
        cell = np.array([d])
        got = imager._coherence_peak_offsets(None, cell, np.array([10]), fake(None, cell, None))
        np.testing.assert_allclose(got[0], expected, atol=1e-9)
