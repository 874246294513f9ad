"""Fidelity presets and the automatic choice."""

import numpy as np
import pytest

import mitsonar
from mitsonar.evaluation.fidelity import PRESETS, choose_fidelity, fidelity
from mitsonar.scene.loading import load_scene
from helpers import SCENES


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
    from helpers import IDENTITY
    from mitsonar.scene.xml import material_xml, rectangle_xml

    wall = load_scene(scene_file("wall", material_xml("w", preset="glass", scattering=0.0),
                                 rectangle_xml("w", (0, 0, 2.0))))
    level, runs = choose_fidelity(wall, [IDENTITY], np.array([[0.0, 0.0, 1.0]]), reference="fine")
    assert level.name == "draft"
    assert abs(runs[0].depth[0] - runs[-1].depth[0]) < 1e-3
    assert [r.fidelity.name for r in runs] == ["draft", "standard", "fine"]


def test_merged_patches_are_judged_against_the_fixed_grid(scene_file):
    """With patches merged by range and footprint (TraceSettings.max_merge=4) the choice still
    stops at 'draft' on a specular wall, and its reference level traced the fixed grid (the
    same depths as a 'fine' run without merging)."""
    from dataclasses import replace

    from helpers import IDENTITY
    from mitsonar.evaluation.fidelity import ping_at
    from mitsonar.scene.xml import material_xml, rectangle_xml

    wall = load_scene(scene_file("wall", material_xml("w", preset="glass", scattering=0.0),
                                 rectangle_xml("w", (0, 0, 0.6))))
    base = mitsonar.SonarConfig()
    merging = replace(base, trace=replace(base.trace, max_merge=4))
    directions = np.array([[0.0, 0.0, 1.0], [0.05, 0.0, 1.0]])
    level, runs = choose_fidelity(wall, [IDENTITY], directions, config=merging, reference="fine")
    assert level.name == "draft"
    fixed = ping_at(wall, base, PRESETS["fine"], [IDENTITY], directions)
    np.testing.assert_array_equal(runs[-1].depth, fixed.depth)
    merged = ping_at(wall, merging, PRESETS["fine"], [IDENTITY], directions)
    assert not np.array_equal(merged.depth, fixed.depth)  # merging changed the fine level
    assert np.nanmax(np.abs(merged.depth - fixed.depth)) < 1e-3


def test_diffuse_scene_judged_against_the_ground_truth():
    """room_glass: the draft and standard levels pick different diffuse reflectors beam by beam
    (speckle realisations of different ray grids: depths centimetres apart), yet their points lie
    as close to the true surfaces and they detect as many beams, so the choice stops at draft."""

    from mitsonar.sensors.trajectory import sensor_poses

    path = SCENES / "room_glass" / "scene.xml"
    trajectory = mitsonar.Trajectory.from_scene(path)
    poses = sensor_poses(trajectory.poses_at(np.linspace(0, trajectory.duration, 5)[1:-1]))
    directions = mitsonar.ArrayGeometry().fov_grid(np.radians(10.0))
    level, (draft, standard) = choose_fidelity(load_scene(path), poses, directions,
                                               reference="standard")
    assert level.name == "draft"
    assert draft.depth_error(standard)[0] > 0.02  # [m] beam by beam; measured 125 mm
    for run in (draft, standard):  # measured 5.8 and 5.6 mm; 73 % of 105 beams each
        assert run.surface_error()[0] < 0.01


def test_agreement_is_median_surface_distance_and_detected_fraction():
    from mitsonar.evaluation.fidelity import FidelityRun

    def run(distances_mm):
        d = np.array(distances_mm, dtype=float) / 1e3  # NaN: no detection
        return FidelityRun(PRESETS["draft"], np.where(np.isfinite(d), 2.0, np.nan), 0.01, d)

    nan = np.nan
    reference = run([4, 4, 4, 4, 4, 4, 4, 4, 4, nan])
    assert run([5, 5, 5, 5, 5, 9, 9, 9, 1, nan]).agrees_with(reference, 2e-3, 0.05)  # median 5 mm
    assert not run([7, 7, 7, 7, 7, 7, 1, 1, 1, nan]).agrees_with(reference, 2e-3, 0.05)
    assert not run([4, 4, 4, 4, 4, 4, 4, 4, nan, nan]).agrees_with(reference, 2e-3, 0.05)
    assert run([4, 4, 4, 4, 4, 4, 4, 4, nan, nan]).agrees_with(reference, 2e-3, 0.1)
    assert run([1, 1, 1, 1, 1, 1, 1, 1, 1, nan]).agrees_with(reference, 2e-3, 0.0)  # better
    assert run([nan] * 3).agrees_with(run([nan] * 3), 2e-3, 0.0)
