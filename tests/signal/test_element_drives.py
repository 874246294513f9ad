"""Synthesis of shared hits from the transmit elements' drives
(:meth:`EchoSynthesizer.element_spectrum`) against each beam's own steered synthesis of the same
paths."""

import numpy as np

import mitsonar
from helpers import IDENTITY
from mitsonar.frames import direction_from_fov_angles
from mitsonar.scene.xml import material_xml, rectangle_xml
from mitsonar.sensors.ofdm_sonar import OfdmSonar


def test_element_drives_give_each_beams_steered_synthesis(scene_file):
    """A wall 2.5 m ahead, 4 beams fired up to 28 ms late (their echoes run past the
    recording's end, which a synthesis on the band's period would wrap onto its start): the
    cycle's recording from the elements' drives equals the sum of the beams' own syntheses of
    the same paths, steered and cut at the recording's end, within 1e-3 of the peak (measured
    9e-5; on the band's period: 0.11) but for the last 2 % of the recording (its end, which
    the beams' band-limited syntheses smear)."""
    path = scene_file("wall", material_xml("w", preset="concrete"),
                      rectangle_xml("w", (0, 0, 2.5)))
    sonar = mitsonar.Sonar(path, mitsonar.SonarConfig(
        transducer=mitsonar.Transducer(bandwidth_6db=20e3)))
    ofdm = OfdmSonar(sonar, shared_hits=True)
    directions = direction_from_fov_angles(np.radians([-20.0, 0.0, 10.0, 25.0]),
                                           np.radians([0.0, 10.0, -10.0, 5.0]))
    tracer = sonar.tracer
    paths = tracer.patch_paths(tracer.trace_union(IDENTITY, directions, seed=3), IDENTITY)
    delays = sonar.config.geometry.steering_delays(directions, tracer.c) \
        + np.array([0.0, 9e-3, 19e-3, 28e-3])[:, None]
    codes = list(ofdm.codes[:4])
    shared = ofdm.synth.element_spectrum(paths, codes, delays)
    beams = ofdm.synth.groups_spectrum([(paths.delayed(d), c) for d, c in zip(delays, codes)],
                                       sonar.config.geometry.rx.count)
    ours, theirs = (ofdm.band.to_samples(s) for s in (shared, beams))
    kept = int(0.98 * ours.shape[1])
    assert np.abs(theirs).max() > 0
    assert np.abs(ours - theirs)[:, :kept].max() <= 1e-3 * np.abs(theirs).max()
