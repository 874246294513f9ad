"""Sparse array design: GA constraints and reproducibility (tiny settings), and the shipped layout
against the acceptance criteria (computed here, not read from the file)."""

import json

import numpy as np
import pytest

from mitsonar import ArrayGeometry, ArrayLayout, SonarConfig
from mitsonar.physics.array import APERTURE, MIN_SPACING
from mitsonar.design.evaluation import BeamCriteria, evaluate_layout, uniform_pair
from mitsonar.design.genetic import (DEFAULT_BASELINE, GASettings, LatticeObjective, _repair,
                                     design_arrays, min_joint_spacing)
from mitsonar.design.record import default_layout_path, load_layout_file

#: A few seconds: tiny population, few generations, coarse lattice.
TINY = dict(population=8, generations=4, lattice_step=0.03, elite=2)


@pytest.fixture(scope="module")
def shipped_metrics():
    tx, rx = ArrayLayout.shipped("tx").positions, ArrayLayout.shipped("rx").positions
    return evaluate_layout(tx, rx, widths_over_fov=False)


@pytest.fixture(scope="module")
def uniform_metrics():
    grid = uniform_pair()
    return evaluate_layout(grid[0], grid[1], widths_over_fov=False)


def test_same_seed_same_layout_other_seed_other_layout():
    a = design_arrays(GASettings(seed=11, **TINY))
    b = design_arrays(GASettings(seed=11, **TINY))
    c = design_arrays(GASettings(seed=12, **TINY))
    assert np.array_equal(a.tx.positions, b.tx.positions)
    assert np.array_equal(a.rx.positions, b.rx.positions)
    assert np.array_equal(a.objective_db, b.objective_db)
    assert not np.array_equal(a.tx.positions, c.tx.positions)


@pytest.mark.parametrize("seed", [0, 5])
def test_ga_result_respects_aperture_and_joint_spacing(seed):
    settings = GASettings(seed=seed, init_jitter=8e-3, mutation_start=8e-3,
                          relocate_probability=0.2, **TINY)
    result = design_arrays(settings)
    pair = np.stack([result.tx.positions, result.rx.positions])
    assert np.all(np.abs(pair) <= APERTURE / 2 + 1e-12)
    assert min_joint_spacing(pair, DEFAULT_BASELINE) >= MIN_SPACING
    result.geometry()  # ArrayGeometry validates the 50-element spacing itself
    # The best objective never gets worse (elitism).
    assert np.all(np.diff(result.objective_db) <= 1e-9)


def test_repair_separates_overlapping_elements_or_flags_them():
    rng = np.random.default_rng(3)
    crowded = uniform_pair()[None] + rng.normal(0.0, 6e-3, (64, 2, 25, 2))
    assert np.all(min_joint_spacing(crowded, DEFAULT_BASELINE) < MIN_SPACING)
    fixed, ok = _repair(crowded, DEFAULT_BASELINE, MIN_SPACING, 30)
    assert ok.mean() > 0.95
    assert np.all(min_joint_spacing(fixed[ok], DEFAULT_BASELINE) >= MIN_SPACING - 1e-12)
    assert np.all(np.abs(fixed) <= APERTURE / 2)
    np.testing.assert_array_equal(ok, min_joint_spacing(fixed, DEFAULT_BASELINE) >= MIN_SPACING - 1e-12)


def test_fast_objective_agrees_with_exact_evaluation(shipped_metrics, uniform_metrics):
    """The GA's lattice objective vs the exact evaluation: worst one-way PSLL within 0.75 dB
    (lattice 0.57 deg vs 0.25 deg directions, different steering sets), broadside widths within
    0.02 deg (both are exact cuts)."""
    objective = LatticeObjective(BeamCriteria(), GASettings())
    for pair, metrics in ((uniform_pair(), uniform_metrics),
                          (np.stack([ArrayLayout.shipped("tx").positions,
                                     ArrayLayout.shipped("rx").positions]), shipped_metrics)):
        _, psll_db, widths = objective.evaluate(pair[None])
        assert psll_db[0] == pytest.approx(metrics.worst_psll_db("one_way"), abs=0.75)
        exact = np.stack([metrics.broadside_width["tx"], metrics.broadside_width["rx"]])
        np.testing.assert_allclose(widths[0], exact, atol=np.radians(0.02))


def test_shipped_layout_beats_uniform_by_5_db(shipped_metrics, uniform_metrics):
    """Acceptance: worst PSLL over the 60 x 40 deg FOV at least 5 dB below the uniform layout's,
    for each one-way pattern and for the two-way pattern."""
    uniform = uniform_metrics.worst_psll_db("one_way")
    assert uniform > 0.0  # grating lobes: the uniform beam has side lobes above its main lobe
    for name in ("tx", "rx"):
        assert shipped_metrics.worst_psll_db(name) <= uniform - 5.0
    assert shipped_metrics.worst_psll_db("two_way") <= uniform_metrics.worst_psll_db("two_way") - 5.0


def test_shipped_layout_broadside_width_is_5_deg(shipped_metrics):
    """Acceptance: broadside 3 dB width 5 +- 1 deg, transmit and receive, both cuts."""
    for name in ("tx", "rx"):
        w = np.degrees(shipped_metrics.broadside_width[name])
        assert np.all(np.abs(w - 5.0) <= 1.0), (name, w)


def test_shipped_file_records_what_it_reaches(shipped_metrics, uniform_metrics):
    """The numbers stored beside the positions are the ones recomputed here (to 0.01 dB/deg)."""
    tx, rx, baseline, record = load_layout_file(default_layout_path())
    assert baseline == DEFAULT_BASELINE
    m = record["metrics"]
    for name in ("tx", "rx", "two_way", "one_way"):
        assert m["worst_psll_db"][name] == pytest.approx(shipped_metrics.worst_psll_db(name), abs=0.01)
        assert record["uniform_metrics"]["worst_psll_db"][name] == pytest.approx(
            uniform_metrics.worst_psll_db(name), abs=0.01)
    for name in ("tx", "rx"):
        w = np.degrees(shipped_metrics.broadside_width[name])
        assert m["broadside_width_3db_deg"][name]["horizontal"] == pytest.approx(w[0], abs=0.01)
        assert m["broadside_width_3db_deg"][name]["vertical"] == pytest.approx(w[1], abs=0.01)
    design = record["design"]
    assert isinstance(design["seed"], int) and design["ga_settings"]["seed"] == design["seed"]
    assert GASettings.from_dict(design["ga_settings"]).seed == design["seed"]


def test_echo_simulation_uses_the_shipped_layout():
    data = json.loads(default_layout_path().read_text())
    for config in (SonarConfig(), SonarConfig.preset("paper")):
        g = config.geometry
        np.testing.assert_array_equal(g.tx.positions, np.asarray(data["tx"]))
        np.testing.assert_array_equal(g.rx.positions, np.asarray(data["rx"]))
        assert g.baseline == data["baseline"]
    assert "GA-optimised" in ArrayGeometry().tx.name


def test_settings_are_validated():
    with pytest.raises(ValueError, match="population"):
        GASettings(population=2)
    with pytest.raises(ValueError, match="elite"):
        GASettings(population=8, elite=8)
    with pytest.raises(ValueError, match="seed"):
        GASettings(seed=1.5)
    with pytest.raises(ValueError, match="main_lobe_radius"):
        BeamCriteria(main_lobe_radius=np.nan)


def test_design_cli_writes_a_loadable_layout(tmp_path, capsys):
    from mitsonar.cli import main

    out = tmp_path / "layout.json"
    assert main(["array", "design", "--seed", "2", "--generations", "2", "--population", "6",
                 "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "uniform" in printed and "optimised" in printed and "3 dB width" in printed
    tx, rx, baseline, record = load_layout_file(out)
    assert record["design"]["seed"] == 2 and record["design"]["ga_settings"]["generations"] == 2
    assert len(record["design"]["objective_db_history"]) == 3
    assert main(["array", "design", "--population", "2", "--out", str(out)]) == 2  # clear error
