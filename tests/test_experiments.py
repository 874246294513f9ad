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
