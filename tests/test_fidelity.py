"""Fidelity presets and the automatic choice."""

import numpy as np
import pytest

import mitsonar
from mitsonar.fidelity import PRESETS, choose_fidelity, fidelity
from mitsonar.scene import load_scene


def test_presets_set_the_knobs_and_keep_the_noise_density():
    base = mitsonar.SonarConfig()
    fine = fidelity("fine").apply(base)
    assert fine.trace.rays_per_axis == 48 and fine.sample_rate == 400e3
    # Twice the bandwidth: sqrt(2) the per-sample noise, the same noise after the matched filter.
    assert fine.noise_rms == pytest.approx(base.noise_rms * np.sqrt(2.0))
    assert fidelity("standard").apply(base) == base  # the default configuration
    assert list(PRESETS) == ["draft", "standard", "fine", "multipath"]
    with pytest.raises(ValueError, match="unknown fidelity preset 'ultra'"):
        fidelity("ultra")


def test_a_wall_at_normal_incidence_needs_only_the_draft_level(scene_file):
    """A specular wall is converged with the coarsest grid: the choice stops at 'draft' (depths
    agree with 'fine' to well under 1 mm)."""
    from conftest import IDENTITY, rectangle_xml
    from mitsonar.scene import material_xml

    wall = load_scene(scene_file("wall", material_xml("w", preset="glass", scattering=0.0),
                                 rectangle_xml("w", (0, 0, 2.0))))
    level, runs = choose_fidelity(wall, [IDENTITY], np.array([[0.0, 0.0, 1.0]]), reference="fine")
    assert level.name == "draft"
    assert abs(runs[0].depth[0] - runs[-1].depth[0]) < 1e-3
    assert [r.fidelity.name for r in runs] == ["draft", "standard", "fine"]
