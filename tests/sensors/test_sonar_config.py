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
