"""Completeness along a drive: the same coverage as the metrics, distances driven, the figure."""

import numpy as np
import pytest

import mitsonar
from mitsonar.evaluation.coverage import (SURFACE_CLASSES, Curve, covered_by_class,
                                          covered_fraction, distance_driven, in_sensor_view,
                                          save_completeness_figure, surface_classes)
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


def test_surface_classes_by_normal_and_height():
    """Horizontal within 25 deg of the vertical (either orientation of the normal), split at
    the sensor head's height; vertical within 25 deg of the horizontal plane; sloped between."""
    tilt = np.radians([0.0, 180.0, 24.0, 26.0, 45.0, 64.0, 66.0, 90.0, 114.0, 0.0])
    normals = np.column_stack([np.sin(tilt), np.zeros_like(tilt), np.cos(tilt)])
    heights = np.array([0.0, 0.0, 0.3, 0.3, 1.0, 1.0, 1.0, 1.0, 1.0, 2.5])
    names = [SURFACE_CLASSES[k] for k in surface_classes(normals, heights, sensor_height=0.5)]
    assert names == ["below", "below", "below", "sloped", "sloped", "sloped", "vertical",
                     "vertical", "vertical", "above"]
    with pytest.raises(ValueError, match="2 heights"):
        surface_classes(normals, heights[:2], 0.5)


def test_covered_by_class_weights_back_to_the_whole():
    classes = np.array([0, 0, 0, 0, 2, 2, 3])
    covered = np.array([1, 1, 0, 0, 1, 0, 0], bool)
    share = covered_by_class(covered, classes)
    assert share["below"] == 0.5 and share["vertical"] == 0.5 and share["sloped"] == 0.0
    assert np.isnan(share["above"])  # no ceiling samples: not 0 %
    weights = {name: np.mean(classes == k) for k, name in enumerate(SURFACE_CLASSES)}
    total = sum(weights[n] * share[n] for n in SURFACE_CLASSES if weights[n] > 0)
    assert total == pytest.approx(covered.mean())
    with pytest.raises(ValueError, match="6 classes"):
        covered_by_class(covered, classes[:6])


def test_in_sensor_view_is_the_field_of_view_in_range_and_in_sight(scene_file):
    """A sensor 1 m above a floor looking straight down sees the floor's points whose field-of-
    view angles lie within 30 x 20 deg (|x| <= tan 30 deg, |y| <= tan 20 deg), within its range,
    not hidden by a plate 0.5 m below it; a second pose adds its own."""
    path = scene_file("floor", material_xml("m", preset="concrete"),
                      rectangle_xml("m", (0, 0, 0), size=(4.0, 2.0), shape_id="floor"),
                      rectangle_xml("m", (0.3, 0, 0.5), size=(0.1, 0.1), shape_id="plate"))
    scene = mitsonar.load_scene(path)
    samples = sample_surface(scene_mesh(scene), spacing=0.02)
    floor = np.abs(samples.points[:, 2]) < 1e-6
    x, y = samples.points[floor, :2].T
    down = np.diag([1.0, -1.0, -1.0])  # sensor x along world x, its z (forward) down
    fov = (np.radians(60.0), np.radians(40.0))
    seen = in_sensor_view(scene, samples.points, [mitsonar.Pose(down, [0, 0, 1.0])], *fov, 5.0)
    inside = (np.abs(x) <= np.tan(np.radians(30.0))) & (np.abs(y) <= np.tan(np.radians(20.0)))
    hidden = (np.abs(x - 0.6) < 0.09) & (np.abs(y) < 0.09)  # the plate's shadow, 0.2 x 0.2 m
    clear = ~((np.abs(x - 0.6) < 0.11) & (np.abs(y) < 0.11))
    assert np.all(seen[floor][clear] == inside[clear])
    assert not seen[floor][hidden].any() and hidden.any()
    near = in_sensor_view(scene, samples.points, [mitsonar.Pose(down, [0, 0, 1.0])], *fov, 1.1)
    np.testing.assert_array_equal(near[floor], seen[floor] & (x ** 2 + y ** 2 + 1 <= 1.21))
    two = in_sensor_view(scene, samples.points, [mitsonar.Pose(down, [0, 0, 1.0]),
                                                 mitsonar.Pose(down, [-1.5, 0, 1.0])], *fov, 5.0)
    assert np.all(two[floor][clear] == (inside | ((np.abs(x + 1.5) <= np.tan(np.radians(30.0)))
                                                  & (np.abs(y) <= np.tan(np.radians(20.0)))))[clear])


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
