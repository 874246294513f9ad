"""Ground-truth meshes and reconstruction metrics against hand-computed cases."""

import json
import warnings

import numpy as np
import pytest

import mitsonar
from mitsonar.cli import main
from mitsonar.io import write_ply
from mitsonar.evaluation.metrics import (Scores, error_jumps, evaluate, point_to_mesh, sample_surface,
                              visible_from)
from helpers import SCENES
from mitsonar.scene.loading import SceneError
from mitsonar.scene.mesh import scene_mesh
from mitsonar.scene.xml import material_xml, rectangle_xml

TRANSMITTING = {"dielectric", "thindielectric", "roughdielectric"}


def optical_material(mat_id: str, optical: str, preset: str = "glass") -> str:
    return (f'<bsdf type="acoustic" id="{mat_id}"><string name="preset" value="{preset}"/>'
            f'<bsdf type="{optical}"/></bsdf>')


def plane_mesh(scene_file, size=(2.0, 2.0)):
    """A rectangle of ``size`` [m] centred at the origin in the plane z = 0, normal +z."""
    path = scene_file("plane", material_xml("wall", preset="drywall"),
                      rectangle_xml("wall", (0, 0, 0), size=size, shape_id="plane"))
    return scene_mesh(mitsonar.load_scene(path))


def grid(x_range, y_range, step):
    """Points (N, 3) on a regular grid in z = 0 with cell centres inside the ranges [m]."""
    xs = np.arange(x_range[0] + step / 2, x_range[1], step)
    ys = np.arange(y_range[0] + step / 2, y_range[1], step)
    xx, yy = np.meshgrid(xs, ys)
    return np.stack([xx.ravel(), yy.ravel(), np.zeros(xx.size)], axis=1)


@pytest.mark.parametrize("name", ["room_glass", "structure", "workshop", "office"])
def test_scene_mesh_areas_and_glass_match_ground_truth_json(name):
    gt = json.loads((SCENES / name / "ground_truth.json").read_text())
    mesh = scene_mesh(mitsonar.load_scene(SCENES / name / "scene.xml"))
    area = np.bincount(mesh.triangle_shape, mesh.triangle_areas(), minlength=len(mesh.shape_ids))
    expected = {s["id"]: (s["area_m2"], s["type"]) for s in gt["shapes"]}
    for sid, a in zip(mesh.shape_ids, area):
        ref, kind = expected[sid]
        # meshes are exact (float32 vertices); tessellated disks are the worst at 0.16 % low
        tol = 2e-3 if kind in ("disk", "cylinder", "sphere") else 1e-5
        assert a == pytest.approx(ref, rel=tol), sid
    assert area.sum() == pytest.approx(gt["total_area_m2"], rel=1e-4)
    names = np.array([m.name for m in mesh.materials])[mesh.shape_material]
    for mat, entry in gt["materials"].items():
        assert area[names == mat].sum() == pytest.approx(entry["area_m2"], rel=2e-3), mat
    glass = {str(n) for n in names[mesh.shape_transparent]}
    assert glass == {m for m, e in gt["materials"].items() if e["optical"] in TRANSMITTING}


def test_optically_transparent_follows_the_nested_bsdf(scene_file):
    kinds = ["dielectric", "thindielectric", "roughdielectric", "null", "diffuse", "conductor",
             "plastic"]
    parts = [optical_material(k, k) for k in kinds]
    parts += [rectangle_xml(k, (0, 0, i), shape_id=f"s_{k}") for i, k in enumerate(kinds)]
    mesh = scene_mesh(mitsonar.load_scene(scene_file("optics", *parts)))
    flags = dict(zip(mesh.shape_ids, mesh.shape_transparent))
    assert [k for k in kinds if flags[f"s_{k}"]] == ["dielectric", "thindielectric",
                                                     "roughdielectric", "null"]


def test_analytic_shapes_are_tessellated_in_place_and_unknown_ones_named(scene_file, tmp_path):
    path = scene_file("round", material_xml("m", preset="metal"),
                      '<shape type="sphere" id="ball"><point name="center" x="1" y="2" z="3"/>'
                      '<float name="radius" value="0.5"/><ref id="m"/></shape>')
    mesh = scene_mesh(mitsonar.load_scene(path))
    r = np.linalg.norm(mesh.vertices - [1, 2, 3], axis=1)
    assert np.allclose(r, 0.5, atol=1e-6)  # vertices on the sphere, so chords lie inside it
    c = mesh.vertices[mesh.triangles].mean(axis=1) - [1, 2, 3]
    assert np.all(np.einsum("ij,ij->i", mesh.triangle_normals(), c) > 0)  # normals outwards
    (tmp_path / "hose.txt").write_text("0 0 0 0.05\n0 0 1 0.05\n")
    curve = scene_file("curve", f'<shape type="linearcurve" id="hose"><string name="filename" '
                                f'value="{tmp_path / "hose.txt"}"/></shape>')
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = mitsonar.load_scene(curve)
    with pytest.raises(SceneError, match="'hose' of type LinearCurve"):
        scene_mesh(scene)


def test_surface_samples_one_per_square_centimetre_seeded_and_uniform(scene_file):
    mesh = plane_mesh(scene_file, size=(2.0, 1.0))
    a = sample_surface(mesh, spacing=0.01, seed=3)
    assert abs(len(a.points) - 20000) <= 2  # one per cm^2, stratified per triangle
    assert np.array_equal(a.points, sample_surface(mesh, 0.01, seed=3).points)
    assert not np.array_equal(a.points[:100], sample_surface(mesh, 0.01, seed=4).points[:100])
    assert np.all(np.abs(a.points[:, 0]) <= 1) and np.all(np.abs(a.points[:, 1]) <= 0.5)
    share = np.mean(a.points[:, 0] < -0.2)  # 40 % of the area; binomial sigma 0.0035
    assert share == pytest.approx(0.4, abs=0.011)


@pytest.mark.parametrize("d", [0.005, 0.015, 0.025, 0.05])
def test_plane_offset_by_d_has_every_distance_d(scene_file, d):
    mesh = plane_mesh(scene_file)
    pts = grid((-1, 1), (-1, 1), 0.01) + [0, 0, d]
    dist, signed, _, foot = point_to_mesh(pts, mesh)
    assert np.allclose(dist, d, atol=1e-5) and np.allclose(signed, d, atol=1e-5)
    assert np.allclose(foot[:, 2], 0, atol=1e-6)
    below = point_to_mesh(pts - [0, 0, 2 * d], mesh)[1]
    assert np.allclose(below, -d, atol=1e-5)  # behind the normal: negative
    r = evaluate(pts, mesh)
    # samples are at most sqrt(d^2 + (0.707 cm)^2) from a grid point: covered iff that <= 2 cm
    covered = np.hypot(d, 0.00707) <= 0.02
    assert r.overall.accuracy == (1.0 if d < 0.02 else 0.0)
    assert r.overall.completeness == (1.0 if covered else 0.0)
    assert r.overall.mean_distance == pytest.approx(d, abs=1e-5)
    assert r.overall.p90_distance == pytest.approx(d, abs=1e-5)
    assert r.overall.consistency < 1e-5  # a uniform offset is perfectly consistent


def test_partial_reconstruction_of_forty_percent(scene_file):
    mesh = plane_mesh(scene_file, size=(2.0, 1.0))
    pts = grid((-1, -0.2), (-0.5, 0.5), 0.005)  # exactly on 40 % of the 2 m^2 rectangle
    r = evaluate(pts, mesh, threshold=0.02)
    # Samples within 2 cm of the covered part: 0.4 plus the 2 cm rim along its 1 m edge,
    # 0.02 m^2 / 2 m^2 = 0.01. Sampling tolerance: 3 binomial sigma of 20000 samples = 0.0105.
    assert r.overall.completeness == pytest.approx(0.4 + 0.01, abs=0.0105)
    assert r.overall.accuracy == 1.0
    assert r.overall.fscore == pytest.approx(2 * r.overall.completeness / (1 + r.overall.completeness))
    samples = sample_surface(mesh)
    seen = samples.points[:, 0] < -0.2
    masked = evaluate(pts, mesh, samples=samples, observable=seen)
    assert masked.overall.samples == seen.sum() and masked.overall.completeness == 1.0


def test_fscore_is_the_harmonic_mean_of_precision_and_recall():
    d = np.array([0.001, 0.01, 0.019, 0.03])  # 3 of 4 within 2 cm: P = 0.75
    covered = np.array([True, False, True, False])  # R = 0.5
    s = Scores.of(d, np.full(4, np.nan), covered, 0.02)
    assert (s.accuracy, s.completeness) == (0.75, 0.5)
    assert s.fscore == pytest.approx(2 * 0.75 * 0.5 / 1.25)  # 0.6
    assert Scores.of(np.array([0.5]), np.array([0.0]), np.array([False]), 0.02).fscore == 0.0
    empty = Scores.of(np.zeros(0), np.zeros(0), covered, 0.02)
    assert np.isnan(empty.accuracy) and np.isnan(empty.fscore) and empty.completeness == 0.5
    assert empty.to_dict()["accuracy"] is None and "mean_distance_m" in empty.to_dict()


def jumps_of(pts, mesh):
    _, signed, tri, foot = point_to_mesh(pts, mesh)
    return error_jumps(foot, signed, mesh.triangle_normals()[tri])


def test_consistency_separates_smooth_offsets_from_per_patch_jumps(scene_file):
    mesh = plane_mesh(scene_file)
    base = grid((-1, 1), (-1, 1), 0.01)
    smooth = base + np.c_[np.zeros((len(base), 2)), 0.01 + 0.004 * base[:, 0]]
    j_smooth = jumps_of(smooth, mesh)
    patch = np.floor(base[:, :2] / 0.2).astype(int) @ [1000, 1]  # 20 cm patches
    _, inverse = np.unique(patch, return_inverse=True)
    offsets = np.random.default_rng(0).uniform(-0.02, 0.02, inverse.max() + 1)[inverse]
    j_patch = jumps_of(base + np.c_[np.zeros((len(base), 2)), offsets], mesh)
    assert np.nanmean(j_smooth) < 1e-4  # the 4 mm/m tilt changes by < 0.1 mm over a neighbourhood
    assert np.nanmean(j_patch) > 5e-4 and np.nanpercentile(j_patch, 99) > 5e-3
    assert np.nanpercentile(j_patch, 99) > 50 * np.nanpercentile(j_smooth, 99)
    # Two frames over the same surface, registered 2 cm apart: neighbours are found by their
    # feet on the surface, so the frames interleave and every point jumps by about 1 cm.
    layers = np.vstack([base + [0, 0, 0.01], base - [0, 0, 0.01]])
    assert np.nanmean(jumps_of(layers, mesh)) == pytest.approx(0.01, abs=2e-3)
    sigma = 0.01
    noise = np.random.default_rng(1).normal(0, sigma, len(base))
    noisy = base + np.c_[np.zeros((len(base), 2)), noise]
    assert np.nanmean(jumps_of(noisy, mesh)) == pytest.approx(2 * sigma / np.sqrt(np.pi), rel=0.05)


def test_per_material_and_glass_breakdown(scene_file):
    path = scene_file("window", material_xml("wall", preset="drywall"),
                      optical_material("pane", "thindielectric"),
                      rectangle_xml("wall", (0, 0, 0), size=(2.0, 1.0), shape_id="w"),
                      rectangle_xml("pane", (0, 0, 1), size=(1.0, 1.0), shape_id="g"))
    mesh = scene_mesh(mitsonar.load_scene(path))
    pts = np.vstack([grid((-1, 1), (-0.5, 0.5), 0.01),  # the whole wall, exactly
                     grid((-0.5, 0.5), (-0.5, 0.5), 0.01) + [0, 0, 1.03]])  # glass, 3 cm off
    r = evaluate(pts, mesh)
    wall, pane = r.per_material["wall"], r.per_material["pane"]
    assert (wall.points, wall.accuracy, wall.completeness) == (20000, 1.0, 1.0)
    assert (pane.points, pane.accuracy, pane.completeness) == (10000, 0.0, 0.0)
    assert pane.mean_distance == pytest.approx(0.03, abs=1e-5)
    assert r.per_optics["transparent"] == pane and r.per_optics["opaque"] == wall
    assert r.transparent_materials == ["pane"]
    assert r.overall.accuracy == pytest.approx(2 / 3)
    assert r.overall.completeness == pytest.approx(2 / 3, abs=0.01)  # 2 of 3 m^2
    rows = r.table_rows()
    assert [row["group"] for row in rows] == ["all", "optics:opaque", "optics:transparent",
                                              "material:pane", "material:wall"]
    json.dumps(r.to_dict(), allow_nan=False)
    assert "| pane | 10000 |" in r.markdown()


def test_visible_from_hides_samples_behind_a_partition(scene_file):
    path = scene_file("partition", material_xml("m", preset="concrete"),
                      rectangle_xml("m", (0, 0, 0), size=(4.0, 2.0), shape_id="floor"),
                      rectangle_xml("m", (0, 0, 1), (0, 90, 0), size=(2.0, 2.0), shape_id="wall"))
    scene = mitsonar.load_scene(path)
    samples = sample_surface(scene_mesh(scene), spacing=0.05)
    on_floor = np.abs(samples.points[:, 2]) < 1e-6
    seen = visible_from(scene, samples.points, [[-1.0, 0.0, 0.5]])
    assert np.all(seen[on_floor] == (samples.points[on_floor, 0] < 0))  # the wall hides x > 0
    assert not visible_from(scene, samples.points, [[-1.0, 0.0, 0.5]], max_range=0.1).any()
    both = visible_from(scene, samples.points, [[-1.0, 0.0, 0.5], [1.0, 0.0, 0.5]])
    assert both[on_floor].all()


def test_evaluate_rejects_bad_input(scene_file):
    mesh = plane_mesh(scene_file)
    with pytest.raises(ValueError, match="reconstructed points"):
        evaluate(np.array([[0.0, np.nan, 0.0]]), mesh)
    with pytest.raises(ValueError, match="threshold"):
        evaluate(np.zeros((1, 3)), mesh, threshold=0.0)
    with pytest.raises(ValueError, match="observable mask"):
        evaluate(np.zeros((1, 3)), mesh, observable=np.ones(3, dtype=bool))
    nothing = evaluate(np.zeros((0, 3)), mesh, spacing=0.05).overall
    assert nothing.completeness == 0.0 and np.isnan(nothing.accuracy) and nothing.points == 0


def test_cli_evaluate_writes_metrics_table_and_picture(scene_file, tmp_path, capsys):
    path = scene_file("cli", material_xml("wall", preset="drywall"),
                      rectangle_xml("wall", (0, 0, 0), size=(1.0, 1.0)))
    pts = grid((-0.5, 0.5), (-0.5, 0.5), 0.01) + [0, 0, 0.005]
    pts[:1000, 2] = 0.05  # 10 % of the points 5 cm off
    write_ply(tmp_path / "recon.ply", pts)
    out = tmp_path / "eval"
    assert main(["evaluate", str(tmp_path / "recon.ply"), path, "--out", str(out)]) == 0
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["threshold_m"] == 0.02
    assert metrics["overall"]["accuracy"] == pytest.approx(0.9)
    assert metrics["per_material"]["wall"]["points"] == 10000
    assert (out / "errors.png").stat().st_size > 10000
    assert (out / "metrics.csv").read_text().startswith("group,points,samples,accuracy")
    assert "| all | 10000 |" in capsys.readouterr().out
    assert main(["evaluate", str(tmp_path / "missing.ply"), path]) == 2
    assert "missing.ply: point cloud file not found" in capsys.readouterr().err
