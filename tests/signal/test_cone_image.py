"""Receive imaging over each beam's lit cone (DetectionSettings.echoes = "image"): points across
a plane tilted 45 deg, separated reflectors inside one cone, the false-alarm rate on noise alone
against the design, no point where nothing is in the beam."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

import mitsonar
from helpers import (IDENTITY, TILT, TILT_DISTANCE, TILT_NORMAL, noise_beams, side_plate,
                     tilted_footprint, tilted_plane)
from mitsonar.frames import direction_from_fov_angles
from mitsonar.sensors.sonar import PRE_ROLL
from mitsonar.signal.band import Band, Recording
from mitsonar.signal.receiver import EchoProcessor
from mitsonar.signal.synthesis import EchoSynthesizer

#: Broadband transducers, the default receiver otherwise.
CONFIG = mitsonar.SonarConfig(transducer=mitsonar.Transducer(bandwidth_6db=20e3))
#: Three reflectors inside the broadside beam's 3 deg cone (sensor frame [m]), at different
#: ranges, and their path gains [Pa].
REFLECTORS = direction_from_fov_angles(np.radians([-2.0, 2.0, 0.5]),
                                       np.radians([0.0, 1.0, -2.0])) \
    * np.array([1.3, 1.9, 2.6])[:, None]
GAINS = np.array([0.2, 0.15, 0.1])


def _with(config: mitsonar.SonarConfig, mode: str) -> mitsonar.SonarConfig:
    """``config`` with ``DetectionSettings.echoes`` = ``mode``."""
    return replace(config, detection=replace(config.detection, echoes=mode))


def processor(settings: mitsonar.DetectionSettings) -> EchoProcessor:
    """A receiver of ``CONFIG`` with ``settings`` on the band of a scan's recordings."""
    cfg = CONFIG
    band = Band(cfg.pulse, cfg.transducer, cfg.sample_rate, -PRE_ROLL, cfg.record_duration,
                cfg.transducer_response, floor=cfg.band_floor, baseband=cfg.baseband)
    return EchoProcessor(cfg.geometry, band, cfg.medium.speed_of_sound, settings, cfg.noise_rms)


def reflector_recording(band: Band, seed) -> Recording:
    """The recording of the reflectors (exact delays from the transmit origin to each receive
    element, the pulse's echo spectrum) with seeded receiver noise."""
    g, c = CONFIG.geometry, CONFIG.medium.speed_of_sound
    delay = (np.linalg.norm(REFLECTORS, axis=1)[:, None]
             + np.linalg.norm(REFLECTORS[:, None] - g.rx_positions[None], axis=-1)) / c
    shift = np.exp(-2j * np.pi * band.frequencies * (delay[..., None] - band.start_time))
    spectrum = np.einsum("p,pjf->jf", GAINS, shift) * band.system_spectrum()[band.bins]
    return EchoSynthesizer(band).recording(band.to_samples(spectrum), CONFIG.noise_rms,
                                           seed=seed)


def test_separated_reflectors_inside_one_cone():
    """One broadside beam, three reflectors 2 deg off its axis at 1.3, 1.9 and 2.6 m: over 8
    noise seeds "image" finds each within 5 mm every time (measured at most 0.9 mm), and no other
    point (the ghost rate designed for: none; the reflectors stand 20-60 dB over the noise and
    their range side lobes are the clutter rule's). Fails if the peak's grid offset from the
    beam's axis is left out of where it is placed."""
    receiver = processor(mitsonar.DetectionSettings(echoes="image"))
    errors, ghosts = [], 0
    for seed in range(8):
        table = receiver.process_beams([reflector_recording(receiver.band, [5, seed])],
                                       [[0.0, 0.0, 1.0]])[1].echoes
        distance = np.linalg.norm(table.point[:, None] - REFLECTORS[None], axis=-1)
        errors.append(distance.min(axis=0))
        ghosts += int(np.sum(distance.min(axis=1) > 5e-3))
    assert np.max(errors) <= 5e-3, np.max(errors, axis=0)
    assert ghosts == 0


def test_points_across_a_plane_tilted_45_deg(scene_file):
    """A concrete plane at 45 deg through the broadside beam 1.5 m away, broadband transducers
    driven by 4 cycles (2.7 cm of depth resolution; traced at the two frequency nodes its
    10 kHz spectrum needs): "image" places its points within 1 cm of the plane, spanning at
    least 60 % of the transmit beam's -3 dB footprint along the tilt (issue 28) for each of
    seeds 0-3. Measured over seeds 0-7: at most 10.0 mm off the plane, spanning 83-94 % of the
    footprint ("cells" 82-93 %; traced at one node, before the automatic count, "image" spanned
    more than "cells" on average, 70 against 65 % of the -6 dB footprint). Fails if the image's
    peak need not be a peak (a rim direction whose neighbour outside the cone is stronger), or
    without the side-lobe check and the trust."""
    scene = tilted_plane(scene_file)
    config = mitsonar.SonarConfig(transducer=mitsonar.Transducer(bandwidth_6db=20e3),
                                  pulse=mitsonar.Pulse(cycles=4))
    ends = tilted_footprint(config)
    sonar = mitsonar.Sonar(scene, _with(config, "image"))
    spans = []
    for seed in range(4):
        table = sonar.scan(IDENTITY, [[0.0, 0.0, 1.0]], seed=seed).echo_table
        off_plane = np.abs((table.point - [0.0, 0.0, TILT_DISTANCE]) @ TILT_NORMAL)
        along = table.point[:, 0] / np.cos(TILT)  # along the tilt, on the plane [m]
        assert len(table) >= 2 and np.all(off_plane <= 0.01), (along, off_plane)
        near = np.clip(along, *ends)
        spans.append((near.max() - near.min()) / (ends[1] - ends[0]))
    assert min(spans) >= 0.6, spans


def test_noise_alone_gives_the_design_false_alarm_rate():
    """117 beams of receiver noise alone, threshold lowered to 3 x the RMS noise envelope (a
    rate one can count), the side-lobe check and the direction's trust off: the points per beam
    are within a factor of two of the design (ConeImager.expected_false_alarms, the Euler
    characteristic of the excursion set's blobs that peak inside the cone, over the window;
    measured 26 points, 0.79 of the design). With the checks on, noise gives none. Fails against
    the whole Euler characteristic (blobs peaking on the cone's rim counted too: 0.43 of it)."""
    eta = 3.0
    noise, directions, window = noise_beams(processor(mitsonar.DetectionSettings()), CONFIG)
    counted = {}
    for checks in (False, True):
        off = {} if checks else dict(ghost_margin=0.0, min_coherence=0.0, clutter_margin=1e-3)
        settings = mitsonar.DetectionSettings(echoes="image", detection_snr=eta,
                                              detection_floor=1e-9, **off)
        cone_receiver = processor(settings)
        counted[checks] = len(cone_receiver.process_beams(noise, directions)[1].echoes)
    design = cone_receiver._cone.expected_false_alarms(eta, window, CONFIG.geometry.rx_positions)
    rate = counted[False] / len(directions)
    assert 0.5 * design <= rate <= 2 * design, (rate, design, counted)
    assert counted[True] == 0, counted  # the checks reject every noise blob


def test_no_point_where_nothing_is_in_the_beam(scene_file):
    """A smooth metal plate facing the sensor 20 deg to the side, whose specular echo reaches
    the beams that point elsewhere through their side lobes: "image" reports no point in those
    beams, and the plate's own beam gets its point at 1.5 m (within 5 mm). Without both the
    side-lobe check and the direction's trust (either alone suffices here) the beams at 5 deg and
    15 deg report the plate."""
    scene = side_plate(scene_file)
    directions = direction_from_fov_angles(np.radians([-10.0, 0.0, 5.0, 8.0, 20.0, 15.0]),
                                           np.radians([0.0, 0.0, 10.0, 0.0, 0.0, 0.0]))
    sonar = mitsonar.Sonar(scene, _with(mitsonar.SonarConfig(), "image"))
    table = sonar.scan(IDENTITY, directions, seed=1).echo_table
    assert set(table.beam) == {4}, table.beam
    assert np.min(np.abs(table.depth - 1.5)) <= 5e-3
