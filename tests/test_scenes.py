"""Shipped scenes: they load cleanly, their ground truth matches the geometry Mitsuba sees, the
windows are glass for the sonar and transparent for the camera, and the default trajectories
stay inside the rooms, clear of the walls."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

import mitsonar  # noqa: F401  (configures Dr.Jit's LLVM before Mitsuba loads)
from mitsonar.materials import preset
from mitsonar.scene import DefaultMaterialWarning, load_scene, mitsuba
from mitsonar.scenes import generate

SCENES_DIR = Path(generate.__file__).resolve().parent
NAMES = sorted(generate.SCENES)
#: Relative tolerance on areas (Mitsuba computes them in float32).
AREA_RTOL = 1e-6
#: Required clearance between the robot's centre and any obstacle [m].
CLEARANCE = 0.5
#: Heights at which obstacles are probed (the robot body and sensor head) [m].
PROBE_HEIGHTS = (0.05, 0.3, 0.55)


def _load(name):
    with warnings.catch_warnings():
        warnings.simplefilter("error", DefaultMaterialWarning)
        scene = load_scene(SCENES_DIR / name / "scene.xml")
    gt = json.loads((SCENES_DIR / name / "ground_truth.json").read_text())
    return scene, gt


@pytest.fixture(scope="module", params=NAMES)
def shipped(request):
    scene, gt = _load(request.param)
    return request.param, scene, gt


# ---- checks (return lists of problems, so the negative tests below can exercise them) --------
def area_problems(scene, gt) -> list[str]:
    """Shapes whose ground-truth area differs from Mitsuba's surface_area(), id mismatches,
    and per-material totals that are not the sum of their shapes."""
    problems = []
    by_id = {s["id"]: s for s in gt["shapes"]}
    ids = [s.id() for s in scene.scene.shapes()]
    if len(set(ids)) != len(ids) or set(ids) != set(by_id) or len(by_id) != len(gt["shapes"]):
        problems.append(f"shape ids differ: scene {sorted(ids)} vs ground truth {sorted(by_id)}")
    totals: dict[str, float] = {}
    for shape in scene.scene.shapes():
        area = float(np.asarray(shape.surface_area()).ravel()[0])
        entry = by_id.get(shape.id())
        if entry is None:
            continue
        totals[entry["material"]] = totals.get(entry["material"], 0.0) + area
        if abs(entry["area_m2"] - area) > AREA_RTOL * area:
            problems.append(f"{shape.id()}: ground truth {entry['area_m2']} m^2, "
                            f"Mitsuba {area} m^2")
    for mat, total in totals.items():
        listed = gt["materials"].get(mat, {}).get("area_m2", np.nan)
        if not abs(listed - total) <= AREA_RTOL * total:
            problems.append(f"material {mat}: ground truth {listed} m^2, shapes sum to {total} m^2")
    return problems


def _cast(scene, origins, directions):
    """First hits of rays (world frame): distance t (inf on a miss), geometric normal (N, 3) and
    the id of the shape hit ('' on a miss)."""
    mi = mitsuba()
    import drjit as dr

    o = np.asarray(origins, dtype=float)
    d = np.asarray(directions, dtype=float)
    ray = mi.Ray3f(mi.Point3f(*[mi.Float(o[:, k]) for k in range(3)]),
                   mi.Vector3f(*[mi.Float(d[:, k]) for k in range(3)]))
    si = scene.scene.ray_intersect(ray)
    valid = np.asarray(si.is_valid(), dtype=bool)
    t = np.where(valid, np.asarray(si.t, dtype=float), np.inf)
    normals = np.asarray(si.n, dtype=float).T
    registry = {int(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(s))[0]): s.id()
                for s in scene.scene.shapes()}
    hit = np.asarray(dr.reinterpret_array(mi.UInt32, si.shape), dtype=np.int64)
    ids = np.array([registry.get(int(h), "") if v else "" for h, v in zip(hit, valid)])
    return t, normals, ids


def _probe(scene, xy, n_dirs=360):
    """Horizontal rays from the plan points ``xy`` (M, 2) at every PROBE_HEIGHTS: (t, n, ids, d)
    each of shape (M, heights x n_dirs, ...)."""
    xy = np.atleast_2d(np.asarray(xy, dtype=float))
    ang = np.arange(n_dirs) * 2 * np.pi / n_dirs
    dirs = np.stack([np.cos(ang), np.sin(ang), np.zeros_like(ang)], axis=-1)
    dirs = np.tile(dirs, (len(PROBE_HEIGHTS), 1))
    z = np.repeat(PROBE_HEIGHTS, n_dirs)
    origins = np.concatenate([np.column_stack([np.full(len(z), x), np.full(len(z), y), z])
                              for x, y in xy])
    d = np.tile(dirs, (len(xy), 1))
    t, n, ids = _cast(scene, origins, d)
    k = len(z)
    return t.reshape(len(xy), k), n.reshape(len(xy), k, 3), ids.reshape(len(xy), k), dirs


def trajectory_problems(scene, gt) -> list[str]:
    """Waypoints outside the closed rooms, closer than CLEARANCE to an obstacle anywhere along
    the path, or not facing a wall."""
    roles = {s["id"]: s["role"] for s in gt["shapes"]}
    traj = gt["trajectory"]
    wp = np.asarray(traj["waypoints"], dtype=float)
    problems = []
    if wp.ndim != 2 or wp.shape[1] != 3 or len(wp) < 2 or not np.all(np.isfinite(wp)):
        return [f"waypoints must be a list of >= 2 finite [x, y, yaw_deg], got {traj['waypoints']}"]
    if not (0 < traj["speed_m_s"] <= 2.0):
        problems.append(f"speed {traj['speed_m_s']} m/s is not a robot's")
    # inside: every horizontal ray hits a surface within the building from its front side
    t, n, _, dirs = _probe(scene, wp[:, :2], n_dirs=72)
    front = np.einsum("mkc,kc->mk", n, dirs) < 0
    for k, (x, y, yaw) in enumerate(wp):
        if not (np.all(np.isfinite(t[k])) and np.all(front[k])):
            problems.append(f"waypoint {k} ({x}, {y}) is not inside a closed room")
    # clearance along the whole path, sampled every 5 cm
    pts = [wp[0, :2]]
    for a, b in zip(wp[:-1, :2], wp[1:, :2]):
        steps = max(int(np.ceil(np.linalg.norm(b - a) / 0.05)), 1)
        pts += [a + (b - a) * s / steps for s in range(1, steps + 1)]
    pts = np.array(pts)
    t, _, ids, _ = _probe(scene, pts)
    nearest = t.min(axis=1)
    bad = np.nonzero(nearest < CLEARANCE)[0]
    if len(bad):
        k = bad[0]
        j = int(np.argmin(t[k]))
        problems.append(f"path point ({pts[k, 0]:.2f}, {pts[k, 1]:.2f}) is {nearest[k]:.2f} m from "
                        f"'{ids[k, j]}' (< {CLEARANCE} m); {len(bad)} such points")
    # facing a wall: the sensor head's boresight hits a wall or window
    yaw = np.radians(wp[:, 2])
    head = np.column_stack([wp[:, 0] + 0.1 * np.cos(yaw), wp[:, 1] + 0.1 * np.sin(yaw),
                            np.full(len(wp), 0.5)])
    ahead = np.column_stack([np.cos(yaw), np.sin(yaw), np.zeros(len(wp))])
    t, _, ids = _cast(scene, head, ahead)
    for k in range(len(wp)):
        if roles.get(ids[k]) not in ("wall", "interior_wall", "window") or not t[k] < 8.0:
            problems.append(f"waypoint {k} {wp[k].tolist()} does not face a wall "
                            f"(boresight hits '{ids[k]}' at {t[k]:.2f} m)")
    return problems


# ---- tests on every shipped scene ------------------------------------------------------------
def test_shipped_scene_list():
    assert "room_glass" in NAMES
    for name in NAMES:
        assert (SCENES_DIR / name / "scene.xml").is_file(), f"{name}: run scenes/generate.py"


@pytest.mark.parametrize("name", NAMES)
def test_loads_without_default_material(name):
    mitsuba()  # the plugin module needs Mitsuba's variant set before it is imported
    from mitsonar.plugins.acoustic import AcousticBSDF

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = load_scene(SCENES_DIR / name / "scene.xml")
    assert not [w for w in caught if issubclass(w.category, DefaultMaterialWarning)]
    assert all(isinstance(s.bsdf(), AcousticBSDF) for s in scene.scene.shapes())
    assert len(scene.scene.sensors()) == 1


def test_ground_truth_areas_match_mitsuba(shipped):
    _, scene, gt = shipped
    assert area_problems(scene, gt) == []


def test_materials_match_presets(shipped):
    """Each shape's acoustic material is the preset the ground truth names, under its id."""
    _, scene, gt = shipped
    by_id = {s["id"]: s for s in gt["shapes"]}
    for k, sid in enumerate(scene.shape_ids):
        mat = scene.materials[scene.shape_material[k]]
        entry = by_id[sid]
        ref = preset(entry["preset"])
        assert mat.name == entry["material"]
        assert (mat.impedance, mat.absorption, mat.scattering, mat.transparent) == \
            (ref.impedance, ref.absorption, ref.scattering, ref.transparent), sid
        assert gt["materials"][entry["material"]]["preset"] == entry["preset"]


def test_trajectory_inside_and_clear(shipped):
    name, scene, gt = shipped
    assert trajectory_problems(scene, gt) == []
    wp = gt["trajectory"]["waypoints"]
    assert wp[0] == [0.0, 0.0, 0.0], f"{name}: the trajectory starts at the demo pose (origin)"
    x0, x1 = gt["interior_extent_m"]["x"]
    y0, y1 = gt["interior_extent_m"]["y"]
    for x, y, _ in wp:
        assert x0 + CLEARANCE <= x <= x1 - CLEARANCE and y0 + CLEARANCE <= y <= y1 - CLEARANCE


def test_windows_are_glass_and_transparent(shipped):
    """Sonar: glass preset, not acoustically transparent. Camera: a BSDF without diffuse or
    glossy parts whose transmission is a delta (dielectric) or straight through (thin
    dielectric: Mitsuba flags that as a null component), and a ray really passes straight
    through (thin glass)."""
    mi = mitsuba()
    _, scene, gt = shipped
    windows = [s for s in gt["shapes"] if s["role"] == "window"]
    assert {w["id"] for w in gt["windows"]} == {s["id"] for s in windows}
    shapes = {s.id(): s for s in scene.scene.shapes()}
    glass = preset("glass")
    for w in windows:
        bsdf = shapes[w["id"]].bsdf()
        assert w["preset"] == "glass"
        assert bsdf.acoustic.impedance == glass.impedance and not bsdf.acoustic.transparent
        flags = bsdf.nested.flags()
        assert mi.has_flag(flags, mi.BSDFFlags.DeltaTransmission) or \
            mi.has_flag(flags, mi.BSDFFlags.Null)
        assert not mi.has_flag(flags, mi.BSDFFlags.Diffuse | mi.BSDFFlags.Glossy)
        assert str(bsdf.nested).split("[")[0] in ("ThinDielectric", "SmoothDielectric")
        # a ray at the pane's centre, 30 deg off its normal, goes straight through
        corners = np.array(w["corners"])
        centre = corners.mean(axis=0)
        normal = np.array(w["normal"])
        d = -normal * np.cos(np.radians(30)) + (corners[1] - corners[0]) / np.linalg.norm(
            corners[1] - corners[0]) * np.sin(np.radians(30))
        t, _, ids = _cast(scene, [centre - d], [d])
        assert ids[0] == w["id"] and abs(t[0] - 1.0) < 1e-4
        ray = mi.Ray3f(mi.Point3f(*[float(v) for v in centre - d]),
                       mi.Vector3f(*[float(v) for v in d]))
        si = scene.scene.ray_intersect(ray)
        bs, weight = bsdf.sample(mi.BSDFContext(), si, 0.99, mi.Point2f(0.5, 0.5))
        out = np.asarray(si.to_world(bs.wo), dtype=float).ravel()
        assert np.allclose(out, d, atol=1e-5), "transmitted ray is not straight through"
        assert np.allclose(np.asarray(weight, dtype=float).ravel(), 1.0, atol=1e-4)


def test_every_window_is_in_a_scan_from_the_trajectory(shipped):
    """Each window lies in the sonar's 60 x 40 deg field of view from some waypoint."""
    from mitsonar.frames import Pose, direction_from_fov_angles

    _, scene, gt = shipped
    h, v = np.meshgrid(np.radians(np.arange(-30, 31, 5)), np.radians(np.arange(-20, 21, 5)))
    u = direction_from_fov_angles(h.ravel(), v.ravel())
    seen = set()
    for x, y, yaw in gt["trajectory"]["waypoints"]:
        pose = Pose.sensor_on_robot(x, y, np.radians(yaw))
        _, _, ids = _cast(scene, np.tile(pose.translation, (len(u), 1)), pose.transform_vectors(u))
        seen |= set(ids)
    assert {w["id"] for w in gt["windows"]} <= seen


# ---- room_glass specifics --------------------------------------------------------------------
def test_room_glass_layout():
    scene, gt = _load("room_glass")
    assert len(gt["windows"]) == 2
    assert gt["floor_area_m2"] == pytest.approx(45.0, rel=0.05)
    assert gt["height_m"] == pytest.approx(2.6)
    by_role = {}
    for s in gt["shapes"]:
        by_role.setdefault(s["role"], set()).add(s["preset"])
    assert by_role["floor"] == {"concrete"}
    assert by_role["wall"] <= {"drywall", "plaster"}
    assert by_role["window"] == {"glass"}


def test_room_glass_demo_pose_faces_window_at_2_to_4_m():
    """From the demo pose (robot at the origin facing +x) the wall ahead is 2-4 m from the sensor
    head, and beams a few degrees up pass through a real hole in it: the first hit is the glass
    pane, and behind the pane there is nothing but sky."""
    scene, _ = _load("room_glass")
    head = np.array([0.1, 0.0, 0.5])
    t, _, ids = _cast(scene, [head], [[1.0, 0.0, 0.0]])
    assert ids[0].startswith("wall_east") and 2.0 <= t[0] <= 4.0
    up = np.radians(np.arange(8, 20, 2))
    dirs = np.column_stack([np.cos(up), np.zeros_like(up), np.sin(up)])
    t, _, ids = _cast(scene, np.tile(head, (len(up), 1)), dirs)
    assert list(ids) == ["window_east"] * len(up)
    beyond = head + dirs * (t[:, None] + 1e-3)
    t2, _, ids2 = _cast(scene, beyond, dirs)
    assert np.all(np.isinf(t2)), f"something behind the window: {ids2}"


# ---- the checks themselves can fail ----------------------------------------------------------
def test_area_check_catches_a_wrong_area():
    scene, gt = _load("room_glass")
    gt["shapes"][3]["area_m2"] *= 1 + 1e-5
    problems = area_problems(scene, gt)
    assert len(problems) == 1 and gt["shapes"][3]["id"] in problems[0]
    scene, gt = _load("room_glass")
    gt["materials"]["floor_concrete"]["area_m2"] += 0.01
    assert any("floor_concrete" in p for p in area_problems(scene, gt))


def test_trajectory_check_catches_bad_waypoints():
    scene, gt = _load("room_glass")
    good = gt["trajectory"]["waypoints"]
    for bad, what in [([[0.0, 0.0, 0.0], [2.7, 0.0, 0.0]], "m from"),        # 0.3 m from a wall
                      ([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0]], "not inside"),   # outside
                      ([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 90.0]], None)]:
        gt["trajectory"]["waypoints"] = bad
        problems = trajectory_problems(scene, gt)
        if what is None:
            assert problems == []
        else:
            assert any(what in p for p in problems), problems
    gt["trajectory"]["waypoints"] = good
    assert trajectory_problems(scene, gt) == []


# ---- the generator ---------------------------------------------------------------------------
def test_generator_reproduces_shipped_files(tmp_path):
    """Shipped files are what the generator writes (regenerate after editing it), byte for byte."""
    generate.generate(tmp_path)
    for name in NAMES:
        for new in sorted((tmp_path / name).iterdir()):
            old = SCENES_DIR / name / new.name
            assert old.is_file() and old.read_bytes() == new.read_bytes(), \
                f"{old} is stale: run python scenes/generate.py"


def test_rect_minus_partitions_the_rectangle():
    outer = (0.0, 4.0, 0.0, 3.0)
    holes = [(1.0, 2.0, 0.5, 1.5), (1.5, 3.0, 2.0, 3.5), (-1.0, 0.5, 1.0, 2.0)]
    pieces = generate.rect_minus(outer, holes)
    area = sum((b - a) * (d - c) for a, b, c, d in pieces)
    hole_area = 1.0 * 1.0 + 1.5 * 1.0 + 0.5 * 1.0  # clipped to the outer rectangle
    assert area == pytest.approx(12.0 - hole_area)
    # pieces cover no hole and do not overlap: test a grid of points
    u, v = np.meshgrid(np.linspace(0.0137, 3.9837, 97), np.linspace(0.0137, 2.9837, 73))
    count = sum(((u > a) & (u < b) & (v > c) & (v < d)).astype(int) for a, b, c, d in pieces)
    in_hole = sum(((u > a) & (u < b) & (v > c) & (v < d)).astype(int) for a, b, c, d in holes) > 0
    assert np.all(count[in_hole] == 0) and np.all(count[~in_hole] == 1)


def test_box_area_matches_mitsuba():
    mi = mitsuba()
    shape = generate.box("b", (1.0, 2.0, 0.4), (1.2, 0.6, 0.8), "m", "furniture", "b", yaw_deg=30)
    cube = mi.load_dict({"type": "cube", "to_world": mi.ScalarTransform4f(shape.to_world)})
    area = float(np.asarray(cube.surface_area()).ravel()[0])
    assert shape.area == pytest.approx(2 * (1.2 * 0.6 + 0.6 * 0.8 + 1.2 * 0.8))
    assert area == pytest.approx(shape.area, rel=AREA_RTOL)
