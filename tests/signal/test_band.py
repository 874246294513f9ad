"""The band: conversions between recorded samples and spectra on the band, in both recording
forms, and the waveforms it serves."""

import numpy as np
import pytest

import mitsonar
from mitsonar.sensors.sonar import PRE_ROLL
from mitsonar.signal.band import Band
from mitsonar.signal.ofdm import Code
from mitsonar.signal.synthesis import EchoSynthesizer
from mitsonar.trace.paths import Paths


def _band(baseband: bool = False, waveforms=()) -> Band:
    """The default sensor's band for echoes out to 3 m, serving ``waveforms`` too."""
    cfg = mitsonar.SonarConfig(max_range=3.0)
    return Band(cfg.pulse, cfg.transducer, cfg.sample_rate, -PRE_ROLL, cfg.record_duration,
                floor=1e-5, waveforms=waveforms, baseband=baseband)


@pytest.mark.parametrize("baseband", [False, True])
def test_samples_and_band_spectra_convert_into_each_other(baseband):
    """to_samples is the real part of to_analytic (a half-length inverse FFT), or to_analytic
    itself for baseband, and band_spectra inverts it on the band (echoes of 40 random paths
    well inside the recording)."""
    band = _band(baseband)
    assert band.baseband == baseband and bool(band.carrier) == baseband
    assert band.frequencies.shape == (band.bins.stop - band.bins.start,)
    rng = np.random.default_rng(2)
    n = 40
    paths = Paths(rng.normal(size=n) + 1j * rng.normal(size=n), rng.uniform(2e-3, 12e-3, n),
                  rng.integers(0, 3, n))
    spectrum = EchoSynthesizer(band).group_spectrum(paths, None, 3)
    analytic = band.to_analytic(spectrum)
    samples = band.to_samples(spectrum)
    assert samples.shape == (3, band.n_samples)
    expected = analytic if baseband else analytic.real
    assert np.abs(samples - expected).max() < 1e-12 * np.abs(analytic).max()
    error = np.abs(band.band_spectra(samples) - spectrum).max() / np.abs(spectrum).max()
    assert error < 1e-5, error  # measured 2.4e-6 (both): band-limited tails beyond the end


def test_a_waveform_wider_than_the_band_is_an_error_naming_the_fix():
    """A waveform wider than the band was built for is an error naming the fix, not a silently
    truncated spectrum; passed in ``waveforms``, the band spans it."""
    code = Code(32e3, 48e3)
    with pytest.raises(ValueError, match="waveforms="):
        _band().system_spectrum(code)
    wide = _band(waveforms=(code,))
    w = wide.system_spectrum(code)
    assert np.any(w[wide.bins]) and not np.any(w[: wide.bins.start]) \
        and not np.any(w[wide.bins.stop:])
