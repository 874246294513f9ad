"""The experiment scripts run end to end in their quick settings, so they cannot rot."""

import csv
import importlib.util
from pathlib import Path

import numpy as np
import pytest

EXPERIMENTS = Path(__file__).resolve().parents[1] / "experiments"


def run_experiment(name: str, *argv) -> None:
    spec = importlib.util.spec_from_file_location(name, EXPERIMENTS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.main(list(argv)) == 0


@pytest.mark.slow
def test_ofdm_motion_quick(tmp_path):
    run_experiment("ofdm_motion", "--quick", "--out", str(tmp_path))
    rows = list(csv.DictReader((tmp_path / "ofdm_motion.csv").open()))
    assert [float(r["speed_m_s"]) for r in rows] == [0.1, 1.5]
    for r in rows:
        assert int(r["points"]) > 0
        assert np.isfinite(float(r["thickness_frame_m"])) and np.isfinite(float(r["thickness_beam_m"]))
    assert (tmp_path / "ofdm_motion.png").stat().st_size > 10_000
    assert "thickness" in (tmp_path / "ofdm_motion.md").read_text()


@pytest.mark.slow
def test_material_reflectivity_quick(tmp_path):
    """The impedance sweep follows (4) within 1 % (the physics test is test_echo_physics)."""
    run_experiment("material_reflectivity", "--quick", "--out", str(tmp_path))
    rows = list(csv.DictReader((tmp_path / "impedance.csv").open()))
    measured = np.array([float(r["energy_reflection_measured"]) for r in rows])
    np.testing.assert_allclose(measured, [float(r["energy_reflection_eq4"]) for r in rows], rtol=0.01)
    incidence = list(csv.DictReader((tmp_path / "incidence.csv").open()))
    assert {r["material"] for r in incidence} >= {"glass", "foam"}
    assert (tmp_path / "material_reflectivity.png").stat().st_size > 10_000


@pytest.mark.slow
def test_speed_accuracy_quick(tmp_path):
    run_experiment("speed_accuracy", "--quick", "--out", str(tmp_path))
    rows = list(csv.DictReader((tmp_path / "speed_accuracy.csv").open()))
    assert [r["level"] for r in rows] == ["draft", "standard", "fine", "paper model"]
    assert all(float(r["ms_per_ping"]) > 0 for r in rows)
    assert float(rows[2]["median_depth_diff_mm"]) == 0.0  # the reference against itself
    assert (tmp_path / "speed_accuracy.png").stat().st_size > 10_000
