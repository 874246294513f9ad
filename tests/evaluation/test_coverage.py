"""Completeness along a drive: the same coverage as the metrics, distances driven, the figure."""

import numpy as np
import pytest

import mitsonar
from mitsonar.evaluation.coverage import (Curve, covered_fraction, distance_driven,
                                          save_completeness_figure)
from mitsonar.evaluation.metrics import evaluate, sample_surface
from mitsonar.evaluation.topviews import Panel, SceneView, save_top_views
from mitsonar.scene.mesh import scene_mesh
from mitsonar.scene.xml import material_xml, rectangle_xml
from mitsonar.sensors.trajectory import Trajectory


def test_covered_fraction_is_the_metrics_completeness(scene_file):
    path = scene_file("plane", material_xml("wall", preset="drywall"),
                      rectangle_xml("wall", (0, 0, 0), size=(2.0, 1.0), shape_id="plane"))
    mesh = scene_mesh(mitsonar.load_scene(path))
    samples = sample_surface(mesh, 0.02, seed=0)
    half = samples.points[samples.points[:, 0] < 0] + [0.0, 0.0, 0.01]  # 1 cm above half
    expected = evaluate(half, mesh, samples=samples).overall.completeness
    assert covered_fraction(half, samples.points, 0.02) == expected
    assert expected == pytest.approx(0.5, abs=0.03)
    assert covered_fraction(half, samples.points, 0.005) == 0.0  # 1 cm off: beyond 5 mm
    assert covered_fraction(np.zeros((0, 3)), samples.points, 0.02) == 0.0
    assert np.isnan(covered_fraction(half, np.zeros((0, 3)), 0.02))


def test_distance_driven_counts_driving_not_turning():
    # 2 m along +x at 0.5 m/s (4 s), then a quarter turn on the spot, then 1 m along +y.
    trajectory = Trajectory(np.array([[0, 0, 0], [2, 0, 0], [2, 0, np.pi / 2], [2, 1, np.pi / 2]]),
                            speed=0.5, yaw_rate=np.radians(30.0))
    turn = (np.pi / 2) / np.radians(30.0)
    times = [1.0, 4.0, 4.0 + turn, 4.0 + turn + 1.0]
    np.testing.assert_allclose(distance_driven(trajectory, times), [0.5, 2.0, 2.0, 2.5],
                               atol=1e-9)


def test_figures_are_written(tmp_path):
    curve = Curve("sensor", np.array([0.5, 1.0]), np.array([0.1, 0.2]), np.array([0.2, 0.4]))
    save_completeness_figure(tmp_path / "c.png", {"a": [curve], "b": [curve]}, 0.02, 0.05)
    assert (tmp_path / "c.png").stat().st_size > 10_000
    pts = np.random.default_rng(0).uniform(0, 2, size=(500, 3))
    view = SceneView(2.5, {"x": (0, 2), "y": (0, 2)}, np.array([[1.0, 1.0, 0.3]]), pts)
    save_top_views(tmp_path / "t.png", {"a": (view, [Panel("p", pts, pts[:, 0] / 20),
                                                     Panel("q", pts[:0], pts[:0, 0], "empty")])},
                   "title")
    assert (tmp_path / "t.png").stat().st_size > 10_000
