"""Every echo a beam hears (DetectionSettings.echoes): the first-echo setting against the
single-detection path, echoes of two reflectors, points across an oblique plane, the false-alarm
rate on noise alone, no point where nothing is in the beam.

The first-echo check uses recordings of point reflectors built from their exact spectra on the
band (no tracer, no synthesizer), so that its reference holds whatever synthesis becomes."""

from __future__ import annotations

import numpy as np
import pytest

import mitsonar
from helpers import (IDENTITY, TILT, TILT_DISTANCE, TILT_NORMAL, noise_beams, receiver,
                     reflector_spectra, side_plate, tilted_footprint, tilted_plane)
from mitsonar.frames import direction_from_fov_angles
from mitsonar.scene.xml import material_xml, sphere_xml, write_scene
from mitsonar.signal import multiecho
from mitsonar.signal.multiecho import expected_false_alarms
from mitsonar.signal.band import Band, Recording
from mitsonar.signal.detection import local_maxima
from mitsonar.signal.ofdm import code_set
from mitsonar.signal.receiver import EchoProcessor

#: Broadband transducers (every OFDM code gets through), the default receiver otherwise.
CONFIG = mitsonar.SonarConfig(transducer=mitsonar.Transducer(bandwidth_6db=20e3))
#: Six reflectors (sensor frame [m]) and their path gains on a beam's axis [Pa]; the third is
#: strong enough to leak into every beam through the side lobes.
REFLECTORS = direction_from_fov_angles(np.radians([0.0, 2.0, 20.0, -10.0, 9.0, -12.0]),
                                       np.radians([0.0, -1.5, 5.0, 8.0, -10.0, 7.0])) \
    * np.array([1.2, 2.0, 1.6, 2.6, 1.9, 3.1])[:, None]
GAINS = np.array([0.3, 0.1, 8.0, 0.2, 0.05, 0.02])
#: Seven beams: on reflectors, between them, and on none.
BEAMS = direction_from_fov_angles(np.radians([0.0, 2.0, 20.0, -10.0, 10.0, 25.0, -11.0]),
                                  np.radians([0.0, -1.5, 5.0, 8.0, -10.0, 15.0, 8.0]))
#: The codes of the seven beams of the cycle (indices into the paper's code set).
CYCLE_CODES = (1, 7, 13, 19, 23, 5, 11)
#: Trust by the arrival direction alone (the chart's ``ofdm_trusted``): no side-lobe check along
#: the beam axis, the direction's coherence and the lit cone instead.
TRUSTED = dict(ghost_margin=0.0, arrival_cone=np.radians(3.0))


def processor(settings: mitsonar.DetectionSettings, codes=()) -> EchoProcessor:
    """A receiver of ``CONFIG`` with ``settings``, on the band of a scan's recordings, or of an
    OFDM cycle's when ``codes`` are given (:func:`receiver`)."""
    return receiver(CONFIG, settings, codes)


def beam_gains() -> np.ndarray:
    """(B, P) path gains: a Gaussian transmit lobe of 5 deg at -3 dB over a -26 dB floor."""
    cosine = BEAMS @ REFLECTORS.T / np.linalg.norm(REFLECTORS, axis=1)
    angle = np.arccos(np.clip(cosine, -1.0, 1.0))
    return GAINS * np.maximum(np.exp(-np.log(2) * (angle / np.radians(2.5)) ** 2), 0.05)


def spectra(band: Band, gains, waveforms, offsets) -> np.ndarray:
    """(B, N_rx, nb) analytic spectra on the band: beam b's reflectors with ``gains[b]`` (P,),
    driven by ``waveforms[b]`` fired at ``offsets[b]`` [s] (:func:`reflector_spectra`)."""
    return reflector_spectra(band, CONFIG, REFLECTORS, gains, waveforms, offsets)


def noisy(band: Band, spectrum: np.ndarray, seed) -> Recording:
    """The recording of one set of channel spectra (N_rx, nb) with ``CONFIG.noise_rms`` of
    seeded receiver noise, drawn as the synthesizer draws it."""
    samples = band.to_samples(spectrum)
    rng = np.random.default_rng(seed)
    if band.baseband:
        sigma = CONFIG.noise_rms * np.sqrt(2 * band.sample_rate / band.reference_rate)
        noise = rng.normal(0.0, sigma, (2,) + samples.shape)
        samples = samples + noise[0] + 1j * noise[1]
    else:
        samples = samples + rng.normal(0.0, CONFIG.noise_rms, samples.shape)
    return Recording(samples, band.sample_rate, band.start_time, band.carrier)


def scan_detections(settings=mitsonar.DetectionSettings()):
    """Detections of the seven beams pinged one after another (a recording each)."""
    receiver = processor(settings)
    band = receiver.band
    s = spectra(band, beam_gains(), [None] * len(BEAMS), np.zeros(len(BEAMS)))
    return receiver.process_beams([noisy(band, x, [7, b]) for b, x in enumerate(s)], BEAMS)[1]


def cycle_detections(settings=mitsonar.DetectionSettings()):
    """Detections of the seven beams as one OFDM cycle (one recording, codes 0.5 ms apart)."""
    codes = code_set()
    picked = [codes[k] for k in CYCLE_CODES]
    receiver = processor(settings, codes)
    band = receiver.band
    offsets = np.arange(len(BEAMS)) * codes[0].slot
    recording = noisy(band, spectra(band, beam_gains(), picked, offsets).sum(axis=0), 9)
    return receiver.process_beams(recording, BEAMS, None, picked, offsets,
                                  2 * CONFIG.max_range)[1]
NAN = np.nan
#: What the single-detection path of main (dfe6196, before ``DetectionSettings.echoes``) gave
#: for the seven beams of :func:`scan_detections` and :func:`cycle_detections`: depth [m], point
#: (flattened (7, 3)) [m], amplitude [Pa] and time of arrival [s] (NaN: no detection). Recorded
#: by running these two functions with main's mitsonar on the import path. The depths and points
#: were recorded again when every echo came to be placed by one function
#: (:func:`mitsonar.signal.placement.place`; branch placefix): the scan's points moved from 6-8 mm
#: beside their reflectors to within 0.3 mm; the decisions, amplitudes and times did not move.
MAIN_FIRST_ECHOES = {
    "scan": dict(
        depth=[1.1997307845712366, 1.9998578505248445, 1.599819011036545, 2.599888732992141,
            1.8998590210107746, NAN, 2.5998248875060166],
        point=[-8.336726658371776e-06, -9.305838343983601e-05, 1.1997307809331856,
            0.06980197183643462, -0.052419898270440385, 1.9979517665096207, 0.545145598509699,
            0.13095413469031372, 1.4983618251633888, -0.44717192275885187, 0.35636523205747,
            2.5362299810577627, 0.2927593403493785, -0.3259477476011022, 1.848652031667394, NAN,
            NAN, NAN, -0.4471467164922852, 0.356334453954156, 2.536173301758189],
        amplitude=[0.2734190740964434, 0.0967307431967495, 7.657777557581475,
            0.19629212981094438, 0.03826026646695137, 0.008977640753826645, 0.1750813971992406],
        time_of_arrival=[0.00699471874740794, 0.011654560701533, 0.009312650604047385,
            0.015158097009312893, 0.011067561892552686, NAN, 0.015157724808714853],
    ),
    "cycle": dict(
        depth=[1.200798228804946, 1.1992881103200839, 1.599742732794656, 2.5998120894392014,
            1.899930260870165, NAN, 2.599815837998194],
        point=[-0.0002558158495155564, -0.00019998319324542106, 1.2007981849028873,
            3.3742854057602217e-06, -5.640270569257454e-05, 1.199288108989023, 0.545210479612535,
            0.13100051682547634, 1.4982527185496584, -0.44691621708117807, 0.35645454870389875,
            2.5361839345781636, 0.2923195044072997, -0.325969349267509, 1.8487910338519495, NAN,
            NAN, NAN, -0.4471573342510237, 0.356323371900936, 2.5361637101277426],
        amplitude=[0.27998563474086435, 0.0850101231160273, 7.655848975885767,
            0.19502020877000986, 0.03666663372370102, 0.06331222122645694, 0.17560608034423625],
        time_of_arrival=[0.007000943336795441, 0.006992140136120816, 0.009312204095686614,
            0.015157647059544753, 0.011067985665583185, NAN, 0.015157672250286417],
    ),
}

#: Columns of the echo table that Detections also has.
SHARED = ("time_of_arrival", "path_length", "depth", "point", "direction", "amplitude")


def _assert_rank_zero_is_the_detections(detections):
    """The table's rank-0 rows hold the detected beams' Detections, bit for bit; rows are sorted
    by beam and rank, ranks count 0, 1, ... per beam, echoes before cells."""
    t = detections.echoes
    first = t.rank == 0
    np.testing.assert_array_equal(t.beam[first], np.flatnonzero(detections.detected))
    for name in SHARED:
        np.testing.assert_array_equal(getattr(t, name)[first],
                                      getattr(detections, name)[detections.detected])
    np.testing.assert_array_equal(t.rank, np.arange(len(t)) - np.searchsorted(t.beam, t.beam))
    assert np.all(np.diff(t.beam) >= 0) and np.all(t.peak[first])
    later = np.diff(t.beam) == 0
    assert not np.any(later & ~t.peak[:-1] & t.peak[1:])  # no echo after a cell


@pytest.mark.parametrize("detections", [scan_detections, cycle_detections],
                         ids=["scan", "cycle"])
def test_the_first_echo_setting_reproduces_the_single_detection_path(detections):
    """echoes = "first" (the default) against the decisions main's single-detection path took on
    the same recordings (MAIN_FIRST_ECHOES): the same beams detected (NaN where none), every
    value within 1e-9 of it relative (bit for bit on the machine that recorded them; another
    CPU's vector maths differs by an ULP: 1.2e-16 relative on an AVX2-only AMD EPYC, 5e-12 on
    the CUDA backend), and the table holds exactly the detected beams."""
    d = detections()
    for name, expected in MAIN_FIRST_ECHOES[detections.__name__.split("_")[0]].items():
        np.testing.assert_allclose(np.ravel(getattr(d, name)), expected, rtol=1e-9, atol=0.0,
                                   equal_nan=True)  # NaN (no detection) only where expected
    _assert_rank_zero_is_the_detections(d)
    assert len(d.echoes) == d.detected.sum() and np.all(d.echoes.peak)


@pytest.mark.parametrize("mode", ["all", "cells"])
def test_every_echo_of_point_reflectors(mode):
    """The first two beams light the reflectors at 1.2 m and 2.0 m (2.3 deg apart): each hears
    both, within 1 mm of their depths (measured 0.3 mm); the strongest is the Detections
    entry."""
    d = scan_detections(mitsonar.DetectionSettings(echoes=mode))
    _assert_rank_zero_is_the_detections(d)
    t = d.echoes
    truth = np.linalg.norm(REFLECTORS[:2], axis=1)
    for beam in (0, 1):
        depths = np.sort(t.depth[t.beam == beam])
        assert len(depths) == 2, depths
        np.testing.assert_allclose(depths, truth, rtol=0, atol=1e-3)


@pytest.fixture(scope="module")
def two_spheres(tmp_path_factory):
    """Two metal spheres in the broadside beam of the default sensor (TCT40, 13.8 cm of depth
    resolution): 4 cm radius at 1.3 m, 1.8 deg to one side, and 8 cm at 2.3 m, 1.8 deg to the
    other (clear of the first's shadow). Returns the scene and their depths |c| - a [m]."""
    centres = direction_from_fov_angles(np.radians([1.8, -1.8]), np.radians([0.0, 0.5])) \
        * np.array([[1.3], [2.3]])
    radii = np.array([0.04, 0.08])
    path = tmp_path_factory.mktemp("spheres") / "spheres.xml"
    scene = write_scene(
        path, material_xml("t", preset="metal", scattering=0.0),
        *(sphere_xml("t", c, a) for c, a in zip(centres, radii)))
    return scene, np.linalg.norm(centres, axis=1) - radii


@pytest.mark.parametrize("trust", [{}, TRUSTED], ids=["side-lobe check", "trusted"])
def test_two_reflectors_in_one_beam_give_two_echoes(two_spheres, trust):
    """echoes = "all": both spheres, each within 5 mm of its depth (measured 0.03 and 1.4 mm),
    with the side-lobe check or trusted by their arrival directions alone (:data:`TRUSTED`);
    "first": the strongest only (the near sphere, 2.6x stronger)."""
    scene, depths = two_spheres
    tables = {}
    for mode in ("first", "all"):
        sonar = mitsonar.Sonar(scene, mitsonar.SonarConfig(
            detection=mitsonar.DetectionSettings(echoes=mode, **trust)))
        tables[mode] = sonar.scan(IDENTITY, [[0.0, 0.0, 1.0]], seed=1).echo_table
    every, first = tables["all"], tables["first"]
    assert len(every) == 2 and np.all(every.peak), every.depth
    np.testing.assert_allclose(every.depth, depths, rtol=0, atol=5e-3)
    assert len(first) == 1 and first.depth[0] == pytest.approx(depths[0], abs=5e-3)
    assert first.amplitude[0] == every.amplitude[0] > every.amplitude[1]


@pytest.mark.parametrize("trust", [{}, TRUSTED], ids=["side-lobe check", "trusted"])
def test_points_across_a_plane_tilted_45_deg(scene_file, trust):
    """echoes = "cells" (with the side-lobe check, or :data:`TRUSTED`), a concrete plane at
    45 deg through the broadside beam 1.5 m away, broadband transducers driven by 4 cycles
    (2.7 cm of depth resolution, so the transmit beam's -3 dB footprint, 17 cm along the tilt,
    spans 4 resolution cells). Points inside the footprint lie within 1 cm of the plane, and
    those within 1 cm span at least 60 % of it. Beyond it (the lobe's edges, where the beam's
    slope biases the arrival direction towards its axis) they lie within 2 cm. Measured over
    seeds 0-9, both settings: 3-6 points, span 42-122 % (trusted 42-107 %; seed 0 over 60 %),
    inside the footprint at most 4.5 mm off, outside 19.3 mm."""
    scene = tilted_plane(scene_file)
    config = mitsonar.SonarConfig(transducer=mitsonar.Transducer(bandwidth_6db=20e3),
                                  pulse=mitsonar.Pulse(cycles=4),
                                  detection=mitsonar.DetectionSettings(echoes="cells", **trust))
    table = mitsonar.Sonar(scene, config).scan(IDENTITY, [[0.0, 0.0, 1.0]], seed=0).echo_table
    off_plane = np.abs((table.point - [0.0, 0.0, TILT_DISTANCE]) @ TILT_NORMAL)
    along = table.point[:, 0] / np.cos(TILT)  # position along the tilt, on the plane [m]
    ends = tilted_footprint(config)  # the transmit beam's -3 dB footprint along the tilt
    inside = (along >= ends[0]) & (along <= ends[1])
    assert inside.sum() >= 2 and np.all(off_plane[inside] <= 0.01), (along, off_plane)
    assert np.all(off_plane <= 0.02), off_plane
    near = along[off_plane <= 0.01]
    assert near.max() - near.min() >= 0.6 * (ends[1] - ends[0]), (near, ends)


def test_noise_alone_gives_the_design_false_alarm_rate():
    """117 beams of receiver noise alone in one batched call, echoes = "all", threshold lowered
    to 2 x the RMS noise envelope (a rate one can count): with the side-lobe check and the
    direction's trust off, the false echoes per beam are within a factor of two of the design
    value N eta exp(-eta^2) (multiecho; measured 0.87 of it, 156 echoes); with them on, noise
    gives no echo (measured: none), nor with the trust alone (:data:`TRUSTED`)."""
    eta = 2.0
    receiver = processor(mitsonar.DetectionSettings())
    noise, directions, window = noise_beams(receiver, CONFIG)
    design = expected_false_alarms(eta, receiver.band.band_moments()[1], window)
    counted = {}
    for checks, off in (("off", dict(ghost_margin=0.0, min_coherence=0.0)), ("on", {}),
                        ("trusted", TRUSTED)):
        settings = mitsonar.DetectionSettings(echoes="all", detection_snr=eta,
                                              detection_floor=1e-9, **off)
        counted[checks] = len(processor(settings).process_beams(noise, directions)[1].echoes)
    rate = counted["off"] / len(directions)
    assert 0.5 * design <= rate <= 2 * design, (rate, design)
    for checks in ("on", "trusted"):
        assert counted[checks] <= counted["off"] and counted[checks] / len(directions) <= design


def test_no_point_where_nothing_is_in_the_beam(scene_file):
    """A smooth metal plate facing the sensor 20 deg to the side: its specular echo reaches the
    beams that point elsewhere through their side lobes, up to 1100 x the noise threshold. Every
    setting reports no point in those beams, and the plate's own beam gets its point at 1.5 m
    (within 5 mm); so does trust by the arrival direction alone (:data:`TRUSTED`)."""
    scene = side_plate(scene_file)
    directions = direction_from_fov_angles(np.radians([-10.0, 0.0, 5.0, 8.0, 20.0]),
                                           np.radians([0.0, 0.0, 10.0, 0.0, 0.0]))
    settings = [dict(echoes=mode) for mode in ("first", "all", "cells")] \
        + [dict(echoes=mode, **TRUSTED) for mode in ("all", "cells")]
    for detection in settings:
        sonar = mitsonar.Sonar(scene, mitsonar.SonarConfig(
            detection=mitsonar.DetectionSettings(**detection)))
        table = sonar.scan(IDENTITY, directions, seed=1).echo_table
        np.testing.assert_array_equal(table.beam, [4])
        assert table.depth[0] == pytest.approx(1.5, abs=5e-3)


def test_the_lit_cone_keeps_arrivals_from_inside_it(scene_file):
    """The plate 20 deg to the side, beams 2.5-7 deg from it (13-17.5 deg): without the side-lobe
    check and the lit cone, the beams 5-7 deg away report its echo at the rim of the arrival
    search (6 deg off their axes: the direction cut short, the point misplaced), coherent
    enough to be trusted (measured 0.94). With the lit cone (:data:`TRUSTED`, 3 deg) every
    point's arrival lies inside it, and the beams reporting one are those the side-lobe check
    keeps (measured: the beam 2.5 deg away, its arrival 2.7 deg off its axis, and the plate's
    own; a beam 3 deg away measures 3.2 deg since placement's joint log-power refinement, on
    the cone's edge)."""
    scene = side_plate(scene_file)
    directions = direction_from_fov_angles(np.radians([13.0, 14.0, 15.0, 16.0, 17.5, 20.0]),
                                           np.zeros(6))
    tables = {}
    for name, trust in (("none", dict(ghost_margin=0.0)), ("cone", TRUSTED), ("check", {})):
        sonar = mitsonar.Sonar(scene, mitsonar.SonarConfig(
            detection=mitsonar.DetectionSettings(echoes="cells", **trust)))
        table = sonar.scan(IDENTITY, directions, seed=1).echo_table
        off_axis = np.arccos(np.clip(np.sum(table.direction * directions[table.beam], axis=1),
                                     -1.0, 1.0))
        tables[name] = table.beam, off_axis
    beams, off_axis = tables["none"]
    assert np.all(np.isin([0, 1, 2], beams)), beams
    assert np.all(off_axis[beams <= 2] >= np.radians(5.9)), np.degrees(off_axis)
    beams, off_axis = tables["cone"]
    assert np.all(off_axis <= TRUSTED["arrival_cone"]), np.degrees(off_axis)
    np.testing.assert_array_equal(beams, tables["check"][0])


def test_bad_echo_settings_are_refused():
    with pytest.raises(ValueError, match="echoes"):
        mitsonar.DetectionSettings(echoes="every")
    with pytest.raises(ValueError, match="arrival_step"):
        mitsonar.DetectionSettings(echoes="cells", arrival_step=0.0)
    with pytest.raises(ValueError, match="min_coherence"):
        mitsonar.DetectionSettings(min_coherence=1.5)
    with pytest.raises(ValueError, match="clutter_margin"):
        mitsonar.DetectionSettings(clutter_margin=0.0)
    with pytest.raises(ValueError, match="arrival_cone"):
        mitsonar.DetectionSettings(arrival_cone=-0.1)


def test_range_cells_cross_extended_echoes_not_the_ringing_of_point_echoes():
    """The echo and cell choice (multiecho) on envelopes built from the pulse's own range
    profile |R| (A |R(t - t0)| is what a point echo leaves): beam 0 a point echo, beam 1 an
    extended one (point echoes at every sample over 8 resolutions, 1 down to 0.9). The point
    echo is one echo and no cell: its ringing is its own. The extended echo is one echo at its
    strongest sample and a cell every ceil(tau_r) samples across the rest of it, none nearer
    than tau_r to the echo nor beyond tau_r past its end."""
    receiver = processor(mitsonar.DetectionSettings())
    lobes, resolution = receiver.range_profile()
    n, start = 1200, 300
    length = int(8 * resolution)
    lag = np.abs(np.arange(n)[:, None] - np.arange(start, start + length))
    weight = np.linspace(1.0, 0.9, length)
    envelopes = np.stack([lobes[np.abs(np.arange(n) - start)],
                          np.max(weight * lobes[lag], axis=1)]) + 1e-6
    above = envelopes > 1e-3
    peaks = local_maxima(envelopes)
    clutter, tau = multiecho.Clutter(lobes[None], np.zeros(2, np.int64)), np.full(2, resolution)
    echoes, resolved = multiecho.echo_peaks(envelopes, peaks & above, above, tau, clutter, 2.0)
    np.testing.assert_array_equal(echoes[0], [0, 1])
    np.testing.assert_array_equal(echoes[1], [start, start])
    beams, samples = multiecho.range_cells(envelopes, above, above, resolved, echoes, tau,
                                           clutter, 2.0)
    assert np.all(beams == 1) and np.all(np.sort(samples) % int(np.ceil(resolution)) == 0)
    assert samples.min() >= start + resolution
    assert samples.max() <= start + length + resolution
    assert len(samples) >= length / np.ceil(resolution) - 2, samples
