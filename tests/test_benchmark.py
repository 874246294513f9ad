"""The benchmark's profile: its stages are disjoint and account for the whole run."""

import importlib.util
import sys

import numpy as np

import mitsonar
from helpers import ROOT, SCENES

RUN = ROOT / "benchmarks" / "run.py"


def load_benchmark():
    spec = importlib.util.spec_from_file_location("benchmark_run", RUN)
    module = importlib.util.module_from_spec(spec)
    sys.modules["benchmark_run"] = module
    spec.loader.exec_module(module)
    return module


def test_profile_stages_are_disjoint(capsys):
    bench = load_benchmark()
    sonar = mitsonar.Sonar(str(SCENES / "room_glass" / "scene.xml"))
    pose = mitsonar.Pose.sensor_on_robot(0.0, 0.0, 0.0)
    dirs = sonar.fov_grid(np.radians(30.0))[:3]
    rows = bench.profile(lambda: sonar.scan(pose, dirs), len(dirs), len(dirs), "pings/s")
    assert [name for name, _ in rows[:-1]] == [name for name, _, _ in bench.STAGES]
    seconds = np.array([t for _, t in rows])
    # Every stage ran, and none is counted twice: the remainder ("other") is what no stage
    # covers, so it would go negative if two stages shared time (cProfile's own timer rounding
    # is ~1 us per call, far below 1 % of a ping).
    assert np.all(np.isfinite(seconds)) and np.all(seconds[:-1] > 0)
    assert seconds[-1] >= -0.01 * seconds.sum()
    assert len(capsys.readouterr().out.splitlines()) == len(rows)
