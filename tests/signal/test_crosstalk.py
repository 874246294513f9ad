"""Whose echo it is in an OFDM cycle (mitsonar.signal.crosstalk), and the part balance of codes
behind narrow-band transducers: analytic echoes of point reflectors on the band (no tracer, no
synthesizer)."""

from __future__ import annotations

import numpy as np
import pytest

import mitsonar
from helpers import BROADSIDE, receiver, reflector_spectra
from mitsonar.frames import direction_from_fov_angles
from mitsonar.signal import crosstalk
from mitsonar.signal.looks import Waveforms
from mitsonar.signal.ofdm import code_set

#: One reflector 2 m ahead on broadside [m].
REFLECTOR = np.array([[0.0, 0.0, 2.0]])
#: The 20 kHz broadband transducers (every code gets through), the TCT40 (the default).
BROADBAND = mitsonar.SonarConfig(transducer=mitsonar.Transducer(bandwidth_6db=20e3))


def test_a_code_whose_tone_the_transducers_attenuate_keeps_its_own_echo():
    """Code (36, 40) kHz behind the TCT40: its own echo leaves 3.4 times its amplitude in the
    36 kHz part's matched filter (the 40 kHz half rings into it) and 1.0 in the 40 kHz part's.
    Compared raw, the parts were 0.29 apart and the part balance (0.3) rejected the beam's own
    echo; relative to those gains they agree, and the echo is found at its depth (within 1 cm:
    the TCT40's range resolution is 13 cm)."""
    code = code_set()[7]
    config = mitsonar.SonarConfig()
    rx = receiver(config, mitsonar.DetectionSettings(), (code,))
    assert [rx.part_gain(code, t) for t in code.parts] == [pytest.approx(3.4, rel=0.05),
                                                            pytest.approx(1.0, rel=0.01)]
    band = rx.band
    spectra = reflector_spectra(band, config, REFLECTOR, np.ones((1, 1)), [code], [0.0])
    _, d = rx.process_spectra(spectra, band.start_time, band.n_samples, BROADSIDE[None], None,
                              [code])
    assert d.detected[0] and abs(d.depth[0] - 2.0) <= 0.01, d.depth


@pytest.mark.parametrize("config", [BROADBAND, mitsonar.SonarConfig()], ids=["broadband", "tct40"])
def test_the_separation_of_two_codes_is_a_correlation_coefficient(config):
    """rho_kk'^2 = max |X_kk'(tau)| |X_k'k(-tau)| is at most 1 (Cauchy-Schwarz), 1 on the
    diagonal and symmetric; behind the TCT40 every two codes with a 40 kHz tone are nearly the
    same echo (rho^2 >= 0.95: no test can tell them apart)."""
    codes = code_set()
    rx = receiver(config, mitsonar.DetectionSettings(), codes)
    waves = Waveforms(rx, codes, len(codes))
    table = rx._crosstalk(np.tile(BROADSIDE, (len(codes), 1)), waves, np.zeros(len(codes)))[0]
    rho = crosstalk.separation(table)
    assert np.all(rho <= 1.0 + 1e-6)
    np.testing.assert_allclose(np.diag(rho), 1.0, rtol=1e-6)
    np.testing.assert_allclose(rho, rho.T, rtol=1e-9)
    if config is not BROADBAND:
        forty = [k for k, c in enumerate(codes) if 40e3 in [t.frequency for t in c.parts]]
        assert np.min(rho[np.ix_(forty, forty)] ** 2) >= 0.95


def test_another_codes_echo_inside_a_beam_is_not_its_echo():
    """Two beams of one cycle (broadband transducers): beam A (code (32, 36) kHz) fires at the
    reflector; beam B (code 32 kHz alone), 2 deg beside it and fired three slots later, hears
    its own echo of the reflector 10 times weaker than A's. A's echo leaks into B's decoded
    envelope at 0.57 of its amplitude, from inside B's main lobe (the side-lobe check passes
    it), three slots early: taken as B's, it put B's point 26 cm short of the reflector. Code
    A's leak explains it (ratio 1.04, under the 2 needed: rho^2 = 0.23), so B reports its own
    echo, at the reflector's depth (within 1 cm)."""
    codes = [code_set()[1], code_set()[0]]
    rx = receiver(BROADBAND, mitsonar.DetectionSettings(), codes)
    band = rx.band
    beams = np.stack([BROADSIDE, direction_from_fov_angles(np.radians(2.0), 0.0)])
    offsets = np.array([0.0, 3 * codes[0].slot])
    gains = np.array([[1.0], [0.1]])
    spectra = reflector_spectra(band, BROADBAND, REFLECTOR, gains, codes, offsets).sum(axis=0)
    _, d = rx.process_spectra(spectra, band.start_time, band.n_samples, beams, None, codes,
                              offsets, 2 * BROADBAND.max_range)
    assert d.detected.all()
    np.testing.assert_allclose(d.depth, np.linalg.norm(REFLECTOR[0]), atol=0.01)
