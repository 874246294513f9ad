"""The experiment scripts run end to end in their quick settings, so they cannot rot."""

import csv
import importlib.util
import sys

import numpy as np
import pytest
from helpers import ROOT, SCENES

EXPERIMENTS = ROOT / "experiments"


def load_experiment(name: str):
    """The module of experiments/<name>.py."""
    spec = importlib.util.spec_from_file_location(name, EXPERIMENTS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


def run_experiment(name: str, *argv) -> None:
    assert load_experiment(name).main(list(argv)) == 0


def test_wall_validation_two_distances(tmp_path):
    run_experiment("wall_validation", "--distances", "0.5,2", "--out", str(tmp_path))
    rows = list(csv.DictReader((tmp_path / "wall_validation.csv").open()))
    assert [float(r["distance_m"]) for r in rows] == [0.5, 2.0]
    for r in rows:  # docs/validation.md's bounds: 5 mm and 1 dB (measured < 0.4 mm, < 0.02 dB)
        assert abs(float(r["depth_error_mm"])) < 5 and abs(float(r["amplitude_vs_image_db"])) < 1
    assert (tmp_path / "wall_validation.png").stat().st_size > 10_000


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
    for r in rows:  # against the ground truth: measured 4-11 mm
        assert 0 < float(r["median_surface_distance_mm"]) < 30
    assert (tmp_path / "speed_accuracy.png").stat().st_size > 10_000


@pytest.mark.slow
def test_comparison_quick(tmp_path):
    """Every sensor reconstructs both scenes, the sonar with both presets; only the sonar puts
    points on room_glass's windows; completeness is measured along the drive, the sonar's
    field of view bounding its repeated map's."""
    run_experiment("comparison", "--quick", "--out", str(tmp_path))
    rows = {(r["scene"], r["sensor"], r["preset"]): r
            for r in csv.DictReader((tmp_path / "comparison.csv").open())}
    assert set(rows) == {(s, k, p) for s in ("room_glass", "workshop")
                         for k, p in (("sonar", "default"), ("sonar", "paper"),
                                      ("lidar", ""), ("depth_camera", ""))}
    for (scene, key, preset), r in rows.items():
        assert float(r["driven_s"]) == 0.3
        for column in ("completeness_pct", "completeness_voxel_pct"):
            assert 0.0 <= float(r[column]) <= 100.0
        if key != "sonar":
            assert int(r["points"]) > 0 and 0.0 <= float(r["accuracy_pct"]) <= 100.0
            assert float(r["completeness_voxel_pct"]) > 0.0
        assert (tmp_path / scene / f"{key}{'_' + r['mode'] + '_' + preset if preset else ''}"
                                   f".ply").stat().st_size > 0
        if scene == "workshop":  # no glass: nothing to score
            assert np.isnan(float(r["glass_completeness_pct"])) and int(r["glass_points"]) == 0
            if key == "sonar":  # repeated mode maps what its field of view covers, no more
                assert float(r["completeness_pct"]) <= float(r["sonar_in_view_pct"]) + 1.0
        assert 0.0 < float(r["sonar_in_view_pct"]) < 100.0
    for key in ("lidar", "depth_camera"):  # they look through the windows
        r = rows["room_glass", key, ""]
        assert int(r["glass_points"]) <= 0.001 * int(r["points"])
        assert float(r["glass_completeness_pct"]) < 5
    sonar = rows["room_glass", "sonar", "paper"]
    assert int(sonar["glass_points"]) > 0 and float(sonar["glass_accuracy_pct"]) > 50
    assert float(sonar["glass_completeness_pct"]) > max(
        float(rows["room_glass", k, ""]["glass_completeness_pct"]) for k in ("lidar", "depth_camera"))
    curves = list(csv.DictReader((tmp_path / "completeness.csv").open()))
    assert len(curves) == 2 * len(rows)  # two checkpoints each
    for first, last in zip(curves[::2], curves[1::2]):  # the map only grows along the drive
        assert float(first["distance_m"]) < float(last["distance_m"])
        assert float(first["completeness_pct"]) <= float(last["completeness_pct"]) + 1e-9
    for name in ("comparison.png", "completeness.png"):
        assert (tmp_path / name).stat().st_size > 30_000
    materials = list(csv.DictReader((tmp_path / "per_material.csv").open()))
    assert {"window_glass", "wall_drywall"} <= {r["material"] for r in materials
                                                if r["scene"] == "room_glass"}
    assert "glass complete" in (tmp_path / "comparison.md").read_text()


@pytest.mark.slow
@pytest.mark.parametrize("scan,preset,mode", [
    ("chirp", "default", "repeated-chirp"), ("chirp_wide", "paper", "repeated-chirp-wide"),
    ("chirp_wide_bands", "paper", "repeated-chirp-wide-bands"),
    ("chirp_wide_defocused", "paper", "repeated-chirp-wide-defocused")])
def test_comparison_repeated_mode_with_chirp_images_quick(tmp_path, scan, preset, mode):
    """``--repeated-scan chirp`` (30-50 kHz), ``chirp_wide`` (20-80 kHz), ``chirp_wide_bands``
    (its trust rule read in sub-bands) and ``chirp_wide_defocused`` (those sent by the whole array
    defocused): repeated mode maps from single-ping images driven by the
    sweep; the row reads its mode, its map is not empty and stays within the sonar's field of
    view."""
    run_experiment("comparison", "--quick", "--scenes", "workshop", "--presets", preset,
                   "--baselines", "none", "--repeated-scan", scan, "--out", str(tmp_path))
    (row,) = csv.DictReader((tmp_path / "comparison.csv").open())
    assert (row["sensor"], row["mode"], row["preset"]) == ("sonar", mode, preset)
    assert int(row["points"]) > 0 and float(row["completeness_voxel_pct"]) > 0
    assert float(row["completeness_pct"]) <= float(row["sonar_in_view_pct"]) + 1.0
    assert (tmp_path / "workshop" / f"sonar_{mode}_{preset}.ply").stat().st_size > 0


def test_comparison_refuses_the_wide_sweep_behind_physical_transducers(tmp_path, capsys):
    """The 20-80 kHz sweep needs the paper preset's ideal transducers: with the default preset
    in the run the comparison stops at once with one line naming the options, exit 2."""
    with pytest.raises(SystemExit) as stop:
        load_experiment("comparison").main(["--repeated-scan", "chirp_wide", "--out",
                                            str(tmp_path)])
    assert stop.value.code == 2
    assert "--repeated-scan chirp_wide needs --presets paper" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())


#: Columns issue 24 asks of docs/results/comparison.csv.
ISSUE_COLUMNS = ("scene", "sensor", "preset", "points", "accuracy_pct", "completeness_pct",
                 "completeness_voxel_pct", "fscore_pct", "glass_completeness_pct",
                 "median_error_cm", "p90_error_cm", "glass_accuracy_pct", "frames", "driven_s",
                 "wall_s")


def test_comparison_scores_every_sensor_alike(scene_file):
    """A cloud equal to the ground-truth samples is complete for any sensor key, at 2 cm and at
    the voxel size, and the rows carry the issue's columns."""
    import mitsonar
    from mitsonar.evaluation.metrics import sample_surface
    from mitsonar.scene.mesh import scene_mesh
    from mitsonar.scene.xml import material_xml, rectangle_xml

    comparison = load_experiment("comparison")
    path = scene_file("plane", material_xml("wall", preset="drywall"),
                      rectangle_xml("wall", (0, 0, 0), size=(2.0, 1.0), shape_id="plane"))
    mesh = scene_mesh(mitsonar.load_scene(path))
    samples = sample_surface(mesh, 0.02, seed=0)
    truth = (mesh, samples, np.ones(len(samples.points), bool), np.array([0.5, 1.0]))
    half = samples.points[samples.points[:, 0] < 0]
    recs = [comparison.score(key, mode, preset, [half, samples.points], len(samples.points), 3,
                             1.0, truth)
            for key, mode, preset in (("sonar", "surfel", "paper"), ("sonar", "repeated", "default"),
                                      ("lidar", "", ""), ("depth_camera", "", ""))]
    info = {"driven": 1.0, "sonar_in_view": 0.25}
    rows = [comparison.summary_row("plane", info, r, recs[2]) for r in recs]
    for r, row in zip(recs, rows):
        assert set(ISSUE_COLUMNS) <= set(row) and row["sonar_in_view_pct"] == 25.0
        assert row["accuracy_pct"] == 100.0 and row["completeness_pct"] == 100.0
        assert row["completeness_voxel_pct"] == rows[0]["completeness_voxel_pct"] > 99.0
        np.testing.assert_allclose(r.curve.completeness, [r.curve.completeness[0], 1.0])
        assert 0.45 < r.curve.completeness[0] < 0.55
    assert rows[0]["completeness_of_lidar_pct"] == rows[1]["completeness_of_lidar_pct"] == 100.0


@pytest.mark.slow
def test_small_objects_quick(tmp_path):
    """Rates and fractions are proper; the optical sensors see a 20 cm box and a pole at 1.5 m,
    and the sonar's wide beam sees no more of a 5 cm box than of a 20 cm one."""
    run_experiment("small_objects", "--quick", "--out", str(tmp_path))
    rows = list(csv.DictReader((tmp_path / "small_objects.csv").open()))
    assert len(rows) == 2 * 2 * 3  # shapes x sizes x sensors
    by = {(r["shape"], float(r["size_m"]), r["sensor"]): r for r in rows}
    for r in rows:
        assert 0.0 <= float(r["detection_rate"]) <= 1.0 and int(r["trials"]) == 2
        c = float(r["completeness"])
        assert np.isnan(c) or 0.0 <= c <= 1.0
    for key in ("lidar", "depth_camera"):
        for shape in ("box", "pole"):
            assert float(by[shape, 0.2, key]["detection_rate"]) == 1.0
        assert float(by["box", 0.2, key]["accuracy"]) > 0.8
    sonar_small, sonar_large = by["box", 0.05, "sonar"], by["box", 0.2, "sonar"]
    assert float(sonar_small["detection_rate"]) <= float(sonar_large["detection_rate"])
    assert float(by["box", 0.2, "depth_camera"]["completeness"]) > float(sonar_large["completeness"])
    assert (tmp_path / "small_objects.png").stat().st_size > 30_000
    assert "detection %" in (tmp_path / "small_objects.md").read_text()


@pytest.mark.slow
def test_shadow_lines_quick(tmp_path):
    """The shadow edge at 0.6 m is found in all three poses; with removal on it is removed in
    every one and no crease is, and the three faces come out as three planes within 1 deg;
    with removal off nothing is removed (measured: 0.05 deg on, 0.07 deg off)."""
    run_experiment("shadow_lines", "--quick", "--out", str(tmp_path))
    rows = {r["removal"]: r for r in csv.DictReader((tmp_path / "shadow_lines.csv").open())}
    assert set(rows) == {"on", "off"}
    for r in rows.values():
        assert int(r["detected"]) == 3 and int(r["creases_removed"]) == 0
        assert int(r["planes"]) == 3 and float(r["normal_error_deg"]) < 1.0
        assert 0.0 <= float(r["completeness"]) <= 1.0 and float(r["accuracy"]) > 0.9
    assert int(rows["on"]["removed"]) == 3 and int(rows["off"]["removed"]) == 0
    assert int(rows["on"]["shadow_surfels"]) == 0
    assert (tmp_path / "shadow_lines.png").stat().st_size > 30_000
    assert "removed in poses" in (tmp_path / "shadow_lines.md").read_text()


@pytest.mark.slow
def test_imaging_quick(tmp_path):
    """Every preset and strategy has a row; the scans run at their own rates (a sweep of B
    pings a listening time each, an OFDM frame, an image a listening time); one simulation's echo
    sets nest (first within all within cells), and so do the imaging trust thresholds' points;
    the chirp images run where the preset's transducers pass the sweep, a sweep's length later."""
    import mitsonar
    from mitsonar.evaluation.coverage import SURFACE_CLASSES
    from mitsonar.sensors.ofdm_sonar import OfdmSonar

    run_experiment("imaging", "--quick", "--out", str(tmp_path))
    experiment = load_experiment("imaging")
    config_for, chirps = experiment.config_for, experiment.CHIRP_SCANS
    presets = ("default", "broadband", "paper")
    rows = {(r["preset"], r["strategy"]): r
            for r in csv.DictReader((tmp_path / "imaging.csv").open())}
    trusts = ("", "_trust_0.35", "_trust_0.5")
    strategies = [f"{scan}_{e}" for scan in ("sequential", "ofdm")
                  for e in ("first", "all", "cells")] + ["ofdm_trusted", "ofdm_image"] \
        + [f"imaging{t}" for t in trusts]
    chirped = {(p, f"{scan}{t}"): scan for scan, (allowed, _) in chirps.items()
               for p in allowed for t in trusts}
    assert {p for p, _ in chirped} == {"broadband", "paper"}
    assert set(rows) == {(p, s) for p in presets for s in strategies} | set(chirped)
    office = mitsonar.load_scene(SCENES / "office" / "scene.xml")
    periods = {}  # the sensor's own frame time per preset and scan [s]
    for preset in presets:
        config = config_for(preset)
        grid = config.geometry.fov_grid(np.radians(20.0))
        periods[preset] = {"sequential": len(grid) * config.record_duration,
                           "ofdm": OfdmSonar(mitsonar.Sonar(office, config)).schedule(grid)
                           .frame_duration,
                           "imaging": config.record_duration}
    for (preset, strategy), r in rows.items():
        if (preset, strategy) in chirped:  # an image of the sonar reconfigured for its sweep
            period = chirps[chirped[preset, strategy]][1](config_for(preset)).record_duration
            assert period > periods[preset]["imaging"]  # the sweep outlasts the burst
        else:
            period = periods[preset][r["scan"]]
        number = {k: float(v) for k, v in r.items() if k not in ("scene", "strategy", "preset",
                                                                  "scan", "echoes")}
        assert 0 <= number["accuracy_pct"] <= 100 and 0 <= number["completeness_5cm_pct"] <= 100
        assert 0 < number["vlp16_completeness_5cm_pct"] <= 100
        assert number["frames_simulated"] == number["frames_total"] >= 1  # stride 1
        assert number["frame_rate_hz"] == pytest.approx(1 / period, rel=1e-5)
        # by surface class: the shares tile the observable surface, and each whole figure is
        # its classes' completeness weighted by their shares (within the CSV's 6 significant
        # digits per value: 1e-3 of a percent)
        shares = {c: number[f"{c}_share_pct"] / 100 for c in SURFACE_CLASSES}
        assert sum(shares.values()) == pytest.approx(1.0)
        for whole, part in (("completeness_5cm_pct", "completeness"),
                            ("vlp16_completeness_5cm_pct", "vlp16"),
                            ("sonar_in_view_pct", "in_view")):
            assert sum(w * number[f"{c}_{part}_pct"] for c, w in shares.items() if w > 0) \
                == pytest.approx(number[whole], abs=1e-3), (preset, strategy, whole)
    for preset in presets:
        for scan in ("sequential", "ofdm"):
            points = [int(rows[preset, f"{scan}_{e}"]["points"]) for e in ("first", "all", "cells")]
            assert points == sorted(points) and points[-1] > 0, (preset, scan, points)
    assert int(rows["paper", "ofdm_all"]["points"]) > int(rows["paper", "ofdm_first"]["points"])
    images = [(p, "imaging") for p in presets] \
        + sorted({(p, scan) for (p, _), scan in chirped.items()})
    for preset, scan in images:  # the same images: a stricter trust threshold keeps a subset
        default = experiment.TRUST.get(scan, experiment.ImagingSettings()).min_coherence
        names = {default: "", 0.35: "_trust_0.35", 0.5: "_trust_0.5"}
        points = [int(rows[preset, f"{scan}{names[t]}"]["points"]) for t in sorted(names)]
        assert points == sorted(points, reverse=True), (preset, scan, points)
    assert (tmp_path / "imaging.png").stat().st_size > 30_000
    assert (tmp_path / "imaging_surfaces.png").stat().st_size > 10_000
    assert "completeness 5 cm" in (tmp_path / "imaging.md").read_text()
    assert "vertical: share / in view / VLP-16 / sonar %" in (tmp_path / "imaging.md").read_text()


def test_imaging_trust_sets_keep_each_thresholds_points():
    """One image's points per trust threshold: ``imaging`` at the default 0.4 and each
    ``imaging_trust_<t>`` exactly the points whose coherence reaches t."""
    from types import SimpleNamespace

    sets = load_experiment("imaging").imaging_trust_sets
    coherence = np.array([0.3, 0.35, 0.39, 0.4, 0.49, 0.5, 0.9])
    points = np.arange(len(coherence) * 3, dtype=float).reshape(-1, 3)
    got = sets(SimpleNamespace(points_world=points, coherence=coherence))
    assert set(got) == {"imaging", "imaging_trust_0.35", "imaging_trust_0.5"}
    for name, first in (("imaging_trust_0.35", 1), ("imaging", 3), ("imaging_trust_0.5", 5)):
        assert np.array_equal(got[name], points[first:]), name
    # the sub-band trust rule's scan: its own default threshold (0.2) keeps every point here
    scan = "imaging_chirp_wide_bands"
    got = sets(SimpleNamespace(points_world=points, coherence=coherence), scan)
    assert set(got) == {scan, f"{scan}_trust_0.35", f"{scan}_trust_0.5"}
    assert np.array_equal(got[scan], points) and np.array_equal(got[f"{scan}_trust_0.5"],
                                                               points[5:])


def test_imaging_echo_sets_of_one_frame(scene_file):
    """The chart's echo sets of an OFDM frame simulated with echoes = "cells": "all" is exactly
    the frame that echoes = "all" gives (the sphere's beam hears the sphere and the wall), and
    "first" its rank-0 rows (a sphere before a rough wall, broadband transducers, moving at
    0.5 m/s)."""
    import mitsonar
    from mitsonar.frames import direction_from_fov_angles
    from mitsonar.scene.xml import material_xml, rectangle_xml, sphere_xml
    from mitsonar.sensors.ofdm_sonar import OfdmSonar

    echo_sets = load_experiment("imaging").echo_sets
    path = scene_file("sphere", material_xml("t", preset="metal", scattering=0.0),
                      material_xml("w", preset="concrete", scattering=0.6),
                      sphere_xml("t", 1.4 * direction_from_fov_angles(np.radians(1.5), 0.0), 0.03),
                      rectangle_xml("w", (0, 0, 2.2), (0, 30, 0), size=(8.0, 8.0)))
    directions = direction_from_fov_angles(np.radians([0.0, -10.0, 10.0, 15.0]),
                                           np.radians([0.0, 0.0, 5.0, -10.0]))
    frames = {}
    for mode in ("all", "cells"):
        sonar = mitsonar.Sonar(path, mitsonar.SonarConfig(
            transducer=mitsonar.Transducer(bandwidth_6db=20e3),
            detection=mitsonar.DetectionSettings(echoes=mode)))
        ofdm = OfdmSonar(sonar)
        frames[mode] = ofdm.frame(ofdm.schedule(directions),
                                  lambda t: mitsonar.Pose(np.eye(3), [0.0, 0.0, 0.5 * t]), seed=3)
    every = frames["all"]
    sets = echo_sets(frames["cells"].echo_table, frames["cells"].echo_points_world)
    np.testing.assert_array_equal(sets["all"], every.echo_points_world)
    np.testing.assert_array_equal(sets["first"],
                                  every.echo_points_world[every.echo_table.rank == 0])
    assert len(sets["first"]) < len(sets["all"]) <= len(sets["cells"])


def test_tables_keep_counts_exact(tmp_path):
    """Integers (point counts beyond 1e6) are written in full, floats to 6 significant digits."""
    from mitsonar.io import write_table

    write_table(tmp_path / "t.csv", [{"name": "a", "points": 3_042_690, "n": np.int64(1_387_758),
                                      "flag": True, "x": 1 / 3}], ["| md |"])
    row = next(csv.DictReader((tmp_path / "t.csv").open()))
    assert row == {"name": "a", "points": "3042690", "n": "1387758", "flag": "1", "x": "0.333333"}
    assert (tmp_path / "t.md").read_text() == "| md |\n"


def test_incidence_quick(tmp_path):
    """Both presets have rows; each preset's bins of all materials count every beam whose axis
    hits a surface in range once; fractions and shares are proper; the crossing table is
    written."""
    run_experiment("incidence", "--quick", "--out", str(tmp_path))
    rows = list(csv.DictReader((tmp_path / "incidence.csv").open()))
    beams = list(csv.DictReader((tmp_path / "incidence_beams.csv").open()))
    for preset in ("default", "paper"):
        mine = [r for r in beams if r["preset"] == preset]
        assert len(mine) == 3 * 35  # 3 poses x the 10 deg grid
        in_range = [r for r in mine if float(r["axis_range_m"]) <= 5.0]
        total = [r for r in rows if r["preset"] == preset and r["material"] == "all materials"]
        assert sum(int(r["beams"]) for r in total) == len(in_range) > 0
        assert sum(int(r["detected"]) for r in total) == sum(r["detected"] == "1" for r in in_range)
        for r in in_range:  # the nearest surface in the cone is no farther than the axis's
            assert float(r["cone_range_m"]) <= float(r["axis_range_m"]) + 1e-6
    for r in rows:
        assert 0 <= float(r["detected_pct"]) <= 100
        assert int(r["detected"]) == 0 or 0 <= float(r["within_2cm_pct"]) <= 100
    assert {"wall_drywall", "window_glass"} <= {r["material"] for r in rows}
    assert (tmp_path / "incidence.png").stat().st_size > 30_000
    assert "detected < 50 % at" in (tmp_path / "incidence.md").read_text()


def test_incidence_ground_truth_of_a_tilted_wall(scene_file):
    """A flat wall 2 m ahead turned by 30 deg about the vertical, beams across it in the
    horizontal plane at h = -20..20 deg: the axis hits it at incidence |30 deg - h| and range
    D cos 30 / cos(30 deg - h) (float32 ray casting: within 0.1 mm and 1e-4 rad); the nearest
    point of the -3 dB cone is where the cone's edge is turned farthest towards the normal,
    D cos 30 / cos(|30 deg - h| - w), with w the offset towards the normal at which the beam's
    two-way pattern falls to 1/sqrt(2) of its peak on a fine horizontal cut (0.0025 deg): the
    cone, sampled every CONE_STEP, reaches w less at most one step (0.5 mm allowed beside)."""
    import mitsonar
    from mitsonar.frames import direction_from_fov_angles
    from mitsonar.physics.beampattern import HALF_POWER, two_way_pattern
    from mitsonar.scene.xml import material_xml, rectangle_xml

    incidence = load_experiment("incidence")
    tilt, distance = np.radians(30.0), 2.0
    path = scene_file("wall", material_xml("wall", preset="drywall"),
                      rectangle_xml("wall", (0, 0, distance), (0, 30, 0), size=(30.0, 30.0)))
    sonar = mitsonar.Sonar(path)
    h = np.radians([-20.0, -10.0, 0.0, 10.0, 20.0])
    beams = direction_from_fov_angles(h, np.zeros_like(h))
    truth = incidence.beam_truth(sonar.tracer, mitsonar.Pose.identity(), beams,
                                 incidence.beam_cones(sonar.config, beams))
    angle = np.abs(tilt - h)
    assert [sonar.scene.materials[m].name for m in truth.material] == ["wall"] * len(h)
    np.testing.assert_allclose(truth.incidence, angle, atol=1e-4)
    np.testing.assert_allclose(truth.axis_range, distance * np.cos(tilt) / np.cos(angle),
                               atol=1e-4)
    g, config = sonar.config.geometry, sonar.config
    k = float(config.medium.wavenumber(config.pulse.frequency))
    towards = np.radians(np.arange(0.0, 6.0, 0.0025))  # offsets towards the normal (+h)
    pattern = two_way_pattern(g.tx_positions, g.rx_positions, beams[:, None],
                              direction_from_fov_angles(h[:, None] + towards, 0.0 * towards),
                              config.transducer, k)
    edge = towards[np.argmax(pattern < HALF_POWER * pattern.max(axis=1, keepdims=True), axis=1)]
    assert np.all((edge > np.radians(1.0)) & (edge < np.radians(3.0)))  # ~3.5 deg wide beams
    near = distance * np.cos(tilt) / np.cos(angle - edge)
    far = distance * np.cos(tilt) / np.cos(angle - edge + incidence.CONE_STEP)
    assert np.all((truth.cone_range >= near - 5e-4) & (truth.cone_range <= far + 5e-4)), (
        truth.cone_range, near, far)


def test_incidence_bins_and_crossing():
    """Beams binned by preset, material and 5 deg incidence bins centred on multiples of 5 deg:
    counts, detected fraction,
    median errors and the share within 2 cm of hand-made beams; misses and beams beyond the
    recorded range are left out; the 50 % crossings (falling, then rising) interpolate between
    the centres of the bins counted."""
    incidence = load_experiment("incidence")
    deg = np.radians
    beams = {"preset": np.array(["default"] * 6), "scene": np.array(["s"] * 6),
             "material": np.array([0, 0, 0, 0, -1, 0]),
             "incidence": deg([1.0, 2.0, 6.0, 7.0, np.nan, 2.0]),
             "axis_range": np.array([1.0, 2.0, 1.5, 1.5, np.inf, 6.0]),
             "cone_range": np.array([1.0, 1.9, 1.4, 1.45, np.inf, 5.9]),
             "detected": np.array([True, True, True, False, False, True]),
             "depth": np.array([1.01, 1.95, 1.45, np.nan, np.nan, 6.0]),
             "surface_distance": np.array([0.005, 0.03, 0.01, np.nan, np.nan, 0.0]),
             "max_range": np.full(6, 5.0)}
    labels = np.array(["wall"] * 4 + [""] + ["wall"])
    rows = incidence.bin_rows(beams, labels, deg(5.0))
    wall = {r["incidence_deg"]: r for r in rows if r["material"] == "wall"}
    assert sorted(wall) == [0.0, 5.0]
    np.testing.assert_allclose([(wall[c]["incidence_lo_deg"], wall[c]["incidence_hi_deg"])
                                for c in (0.0, 5.0)], [(0.0, 2.5), (2.5, 7.5)])
    assert [r["beams"] for r in rows if r["material"] == "all materials"] == [2, 2]
    first, second = wall[0.0], wall[5.0]
    assert (first["beams"], first["detected"], first["detected_pct"]) == (2, 2, 100.0)
    assert first["axis_error_median_mm"] == pytest.approx(30.0)  # |1.01 - 1|, |1.95 - 2|
    assert first["cone_error_median_mm"] == pytest.approx(30.0)  # 10 and 50 mm
    assert first["surface_error_median_mm"] == pytest.approx(17.5)
    assert first["within_2cm_pct"] == 50.0
    assert (second["beams"], second["detected_pct"]) == (2, 50.0)
    assert second["axis_error_median_mm"] == pytest.approx(50.0)
    synthetic = [{"incidence_deg": centre, "beams": n, "detected_pct": pct} for centre, n, pct in
                 ((0.0, 40, 100.0), (5.0, 40, 80.0), (10.0, 5, 10.0), (15.0, 40, 40.0),
                  (20.0, 40, 90.0))]
    assert incidence.crossings(synthetic, 20) == pytest.approx([5.0 + 0.3 / 0.4 * 10.0, 16.0])
    assert incidence.crossings(synthetic, 1) == pytest.approx([5.0 + 0.3 / 0.7 * 5.0, 16.0])
    assert incidence.crossings(synthetic[:2], 20) == []
    assert incidence.crossings(synthetic[3:], 20) == pytest.approx([-np.inf, 16.0])
    assert incidence._loss_text(synthetic, 20) == "12.5-16.0"
    assert incidence._loss_text(synthetic[3:], 20) == "<=15.0-16.0"


def test_incidence_variants_change_one_thing():
    """The diagnostic variants are the default with broadband transducers, with the side-lobe
    check off, or with off-beam echoes kept, and nothing else."""
    from dataclasses import replace

    import mitsonar

    config = load_experiment("incidence").sonar_config
    default = mitsonar.SonarConfig()
    same = [("default", default), ("paper", mitsonar.SonarConfig.preset("paper")),
            ("default_broadband",
             replace(default, transducer=mitsonar.Transducer(bandwidth_6db=20e3))),
            ("default_no_sidelobe_check",
             replace(default, detection=replace(default.detection, ghost_margin=0.0))),
            ("default_off_beam",
             replace(default, detection=replace(default.detection, off_beam=True)))]
    for name, expected in same:  # repr: the configs hold arrays
        assert repr(config(name)) == repr(expected), name
    assert repr(config("default_broadband")) != repr(default)


@pytest.mark.slow
def test_surfel_coverage_quick(tmp_path):
    """The coverage diagnostic drives room_glass's first 0.3 s: per frame the candidates and
    their fates add up, per kind of surface the funnel narrows (in view >= proposed >=
    registered)."""
    run_experiment("surfel_coverage", "--quick", "--out", str(tmp_path))
    frames = list(csv.DictReader((tmp_path / "surfel_coverage_frames.csv").open()))
    assert frames and all(r["scene"] == "room_glass" for r in frames)
    for r in frames:
        fates = sum(int(r[k]) for k in ("no_echo_1", "no_echo_2", "no_echo_3", "no_echo_4",
                                        "verification", "spread", "shadow", "refuted",
                                        "registered"))
        assert fates == int(r["candidates"])
    kinds = {r["kind"]: r for r in csv.DictReader((tmp_path / "surfel_coverage.csv").open())}
    assert {"all", "wall", "floor", "ceiling"} <= set(kinds)
    for r in kinds.values():
        assert float(r["reachable_pct"]) >= float(r["proposed_pct"]) >= \
            float(r["registered_pct"]) >= 0


def test_incidence_variant_with_shared_hits(tmp_path):
    """The default's scans with shared hits (every beam with its transmit side lobes) run as a
    variant of their own: every beam of the quick poses, the default's configuration."""
    import mitsonar

    incidence = load_experiment("incidence")
    assert incidence.main(["--quick", "--presets", "default_shared_hits",
                           "--out", str(tmp_path)]) == 0
    beams = list(csv.DictReader((tmp_path / "incidence_beams.csv").open()))
    assert {r["preset"] for r in beams} == {"default_shared_hits"} and len(beams) == 3 * 35
    assert repr(incidence.sonar_config("default_shared_hits")) == repr(mitsonar.SonarConfig())
