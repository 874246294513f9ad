"""SonarConfig helpers."""

from dataclasses import fields, replace

import pytest

import mitsonar


def test_with_detection_changes_the_detection_settings_alone():
    """with_detection: the detection settings with the changes (checked as there); every other
    part of the configuration the same object."""
    config = mitsonar.SonarConfig.preset("paper")
    changed = config.with_detection(echoes="cells", ghost_margin=0.0)
    assert changed.detection == replace(config.detection, echoes="cells", ghost_margin=0.0)
    assert all(getattr(changed, f.name) is getattr(config, f.name)
               for f in fields(config) if f.name != "detection")
    with pytest.raises(ValueError, match="echoes"):
        config.with_detection(echoes="most")


def test_the_wide_sweep_needs_transducers_that_pass_it():
    """``with_wide_sweep``: RTIS's 4 ms 20-80 kHz sweep at 250 kHz and five frequency nodes
    behind the paper preset's ideal transducers; the TCT40 class (2 kHz) and the broadband
    transducers (20 kHz) are refused naming what they pass."""
    wide = mitsonar.SonarConfig.preset("paper").with_wide_sweep()
    assert (wide.pulse.start, wide.pulse.stop, wide.pulse.duration) == (20e3, 80e3, 4e-3)
    assert (wide.sample_rate, wide.trace.subbands) == (250e3, 5)
    for config, passes in ((mitsonar.SonarConfig(), "2 kHz"),
                           (mitsonar.SonarConfig().with_drive(broadband=True), "20 kHz")):
        with pytest.raises(ValueError, match=f"20-80 kHz sweep needs .* pass {passes}"):
            config.with_wide_sweep()


def test_a_drive_by_name_and_its_points_rule():
    """``with_drive(chirp=...)``: True and "30-50" the default sweep, "20-80" RTIS's
    (``with_wide_sweep``), None and False the burst, another name refused listing the names;
    images of the 20-80 kHz sweep (an octave and more) keep points by the sub-band trust rule,
    those of 30-50 kHz and of bursts by the default rule."""
    from mitsonar.signal.imaging_settings import (WIDE_SWEEP_SETTINGS, ImagingSettings,
                                                  imaging_settings_for)

    paper = mitsonar.SonarConfig.preset("paper")
    assert paper.with_drive(chirp=True) == paper.with_drive(chirp="30-50") \
        == replace(paper, pulse=mitsonar.Chirp())
    assert paper.with_drive(chirp="20-80") == paper.with_wide_sweep()
    assert paper.with_drive(chirp=None) == paper.with_drive(chirp=False) == paper
    with pytest.raises(ValueError, match="30-50, 20-80"):
        paper.with_drive(chirp="20-60")
    assert imaging_settings_for(paper.with_drive(chirp="20-80").pulse) == WIDE_SWEEP_SETTINGS
    assert imaging_settings_for(mitsonar.Chirp(80e3, 20e3)) == WIDE_SWEEP_SETTINGS  # downward
    for pulse in (mitsonar.Chirp(), paper.pulse):
        assert imaging_settings_for(pulse) == ImagingSettings()
