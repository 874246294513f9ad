"""Receiver noise drawn on the band (``EchoSynthesizer.band_noise``, the detection-only path of
OFDM frames) against the recording's white noise through the channel transforms."""

import numpy as np

import mitsonar
from mitsonar.frames import direction_from_fov_angles
from mitsonar.scene.xml import material_xml, rectangle_xml
from mitsonar.sensors.ofdm_sonar import OfdmSonar

#: Independent realisations of the 25 channels (each beamformed once).
REALISATIONS = 48


def test_band_noise_gives_the_beamformed_noise_envelope_of_the_recordings(scene_file):
    """The OFDM band (baseband), noise alone, 48 realisations of the 25 channels each beamformed
    towards a different direction and matched-filtered for a code: the RMS envelope away from
    the recording's ends (a code's length) is the same on both paths and equals
    ``noise_envelope_rms``, within 4 % (its spread from seed to seed, measured over 10 seeds:
    0.6 %; a noise variance wrong by a factor of two would put it 41 % off). Different seeds
    give different noise, the same seed the same."""
    sonar = mitsonar.Sonar(scene_file("wall", material_xml("w", preset="concrete"),
                                      rectangle_xml("w", (0, 0, 2.0))))
    ofdm = OfdmSonar(sonar)
    band, synth, processor = ofdm.band, ofdm.synth, ofdm.processor
    n_rx, noise_rms = sonar.config.geometry.rx.count, sonar.config.noise_rms
    code = ofdm.codes[3]
    h, v = np.meshgrid(np.radians(np.linspace(-30, 30, 8)), np.radians(np.linspace(-15, 15, 6)))
    directions = direction_from_fov_angles(h.ravel(), v.ravel())  # (REALISATIONS, 3)
    on_band = synth.band_noise(REALISATIONS * n_rx, noise_rms, seed=5)
    silent = np.zeros((REALISATIONS * n_rx, band.n_samples), complex)
    recorded = band.band_spectra(synth.recording(silent, noise_rms, seed=5).samples)
    edge = int(np.ceil(code.duration * band.sample_rate))
    expected = processor.noise_envelope_rms(code)
    for spectra in (on_band, recorded):
        envelopes = processor.noiseless_envelopes(spectra.reshape(REALISATIONS, n_rx, -1),
                                                  directions, [code] * REALISATIONS)
        rms = np.sqrt(np.mean(envelopes[:, edge:-edge] ** 2))
        assert abs(rms / expected - 1) < 0.04, rms / expected
    again = synth.band_noise(REALISATIONS * n_rx, noise_rms, seed=5)
    np.testing.assert_array_equal(again, on_band)
    assert not np.allclose(synth.band_noise(REALISATIONS * n_rx, noise_rms, seed=6), on_band)
