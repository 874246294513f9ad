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
