"""Shipped scenes: they load cleanly, their ground truth matches the geometry Mitsuba sees, the
windows are glass for the sonar and transparent for the camera, closed objects are closed, and
the default trajectories stay inside the rooms, clear of the walls and of the furniture's
footprints."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

import mitsonar  # noqa: F401  (configures Dr.Jit's LLVM before Mitsuba loads)
from mitsonar.physics.materials import preset
from mitsonar.scene.building.shapes import box
from mitsonar.scene.building.surfaces import rect_minus
from mitsonar.scene.loading import DefaultMaterialWarning, load_scene, mitsuba
from mitsonar.scenes import generate

SCENES_DIR = Path(generate.__file__).resolve().parent
NAMES = sorted(generate.SCENES)
#: Relative tolerance on areas (Mitsuba computes them in float32).
AREA_RTOL = 1e-6
#: Required clearance between the robot's centre and any obstacle [m].
CLEARANCE = 0.5
#: Heights at which obstacles are probed (the robot body and sensor head) [m].
PROBE_HEIGHTS = (0.05, 0.3, 0.55)
#: What the sensor's boresight may hit at a waypoint (something worth scanning, within 8 m).
FACING_ROLES = ("wall", "interior_wall", "window", "furniture", "small_object")
#: Roles a shape may have.
ROLES = ("wall", "interior_wall", "window", "floor", "ceiling", "light", "furniture",
         "small_object")


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


def _path_points(wp, step=0.05) -> np.ndarray:
    """(M, 2) plan points along the polyline of the waypoints, every ``step`` [m] or closer."""
    wp = np.asarray(wp, dtype=float)
    pts = [wp[0, :2]]
    for a, b in zip(wp[:-1, :2], wp[1:, :2]):
        steps = max(int(np.ceil(np.linalg.norm(b - a) / step)), 1)
        pts += [a + (b - a) * s / steps for s in range(1, steps + 1)]
    return np.array(pts)


def trajectory_problems(scene, gt) -> list[str]:
    """Waypoints outside the closed rooms, closer than CLEARANCE to an obstacle anywhere along
    the path, or not facing a wall or furniture within 8 m."""
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
    pts = _path_points(wp)
    t, _, ids, _ = _probe(scene, pts)
    nearest = t.min(axis=1)
    bad = np.nonzero(nearest < CLEARANCE)[0]
    if len(bad):
        k = bad[0]
        j = int(np.argmin(t[k]))
        problems.append(f"path point ({pts[k, 0]:.2f}, {pts[k, 1]:.2f}) is {nearest[k]:.2f} m from "
                        f"'{ids[k, j]}' (< {CLEARANCE} m); {len(bad)} such points")
    # facing a wall or furniture: the sensor head's boresight hits one within 8 m
    yaw = np.radians(wp[:, 2])
    head = np.column_stack([wp[:, 0] + 0.1 * np.cos(yaw), wp[:, 1] + 0.1 * np.sin(yaw),
                            np.full(len(wp), 0.5)])
    ahead = np.column_stack([np.cos(yaw), np.sin(yaw), np.zeros(len(wp))])
    t, _, ids = _cast(scene, head, ahead)
    for k in range(len(wp)):
        if roles.get(ids[k]) not in FACING_ROLES or not t[k] < 8.0:
            problems.append(f"waypoint {k} {wp[k].tolist()} does not face a wall or furniture "
                            f"(boresight hits '{ids[k]}' at {t[k]:.2f} m)")
    return problems


def footprint_problems(gt) -> list[str]:
    """Path points closer than CLEARANCE (in plan) to the footprint of a furniture piece or small
    object. Horizontal probes miss a table top above them; the footprint does not."""
    pts = _path_points(gt["trajectory"]["waypoints"])
    problems = []
    for obj in gt.get("objects", []):
        x0, x1, y0, y1 = obj["footprint_xy_m"]
        dx = np.maximum(np.maximum(x0 - pts[:, 0], pts[:, 0] - x1), 0.0)
        dy = np.maximum(np.maximum(y0 - pts[:, 1], pts[:, 1] - y1), 0.0)
        d = np.hypot(dx, dy)
        k = int(np.argmin(d))
        if d[k] < CLEARANCE:
            problems.append(f"path point ({pts[k, 0]:.2f}, {pts[k, 1]:.2f}) is {d[k]:.2f} m from "
                            f"the footprint of '{obj['id']}' (< {CLEARANCE} m)")
    return problems


def object_problems(scene, gt) -> list[str]:
    """Objects whose shapes are missing, carry another group or role, or whose bounds differ
    from the union of Mitsuba's bounding boxes of their shapes; shapes of furniture or small
    objects that no object lists; roles outside ROLES."""
    problems = []
    mitsuba_shapes = {s.id(): s for s in scene.scene.shapes()}
    by_id = {s["id"]: s for s in gt["shapes"]}
    listed = set()
    for obj in gt.get("objects", []):
        lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
        for sid in obj["shapes"]:
            listed.add(sid)
            entry = by_id.get(sid)
            if entry is None or sid not in mitsuba_shapes:
                problems.append(f"object '{obj['id']}': shape '{sid}' is missing")
                continue
            if entry["group"] != obj["id"] or entry["role"] != obj["role"]:
                problems.append(f"object '{obj['id']}': shape '{sid}' is {entry['role']} of "
                                f"'{entry['group']}'")
            bbox = mitsuba_shapes[sid].bbox()
            lo = np.minimum(lo, np.asarray(bbox.min, dtype=float).ravel())
            hi = np.maximum(hi, np.asarray(bbox.max, dtype=float).ravel())
        got = [lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]]
        want = list(obj["footprint_xy_m"]) + list(obj["z_m"])
        if not np.allclose(got, want, atol=1e-5):
            problems.append(f"object '{obj['id']}': bounds {want} in the ground truth, Mitsuba's "
                            f"{np.round(got, 6).tolist()}")
    for s in gt["shapes"]:
        if s["role"] not in ROLES:
            problems.append(f"shape '{s['id']}': unknown role '{s['role']}'")
        if s["role"] in ("furniture", "small_object") and s["id"] not in listed:
            problems.append(f"shape '{s['id']}' ({s['role']}) belongs to no object")
    return problems


def closed_problems(gt) -> list[str]:
    """Cylinders (Mitsuba's are open tubes) without a disk cap of their radius at each end,
    facing outwards, in the same object."""
    problems = []
    disks = [s for s in gt["shapes"] if s["type"] == "disk"]
    for c in (s for s in gt["shapes"] if s["type"] == "cylinder"):
        axis, base = np.array(c["axis"]), np.array(c["base"])
        for end, normal in ((base, -axis), (base + c["length_m"] * axis, axis)):
            if not any(d["group"] == c["group"] and abs(d["radius_m"] - c["radius_m"]) < 1e-9
                       and np.allclose(d["centre"], end, atol=1e-9)
                       and np.allclose(d["normal"], normal, atol=1e-9) for d in disks):
                problems.append(f"cylinder '{c['id']}': no cap at {np.round(end, 4).tolist()}")
    return problems


def glass_problems(scene, gt) -> list[str]:
    """Shapes with the acoustic glass preset that are not windows, windows that are not glass,
    and glass whose optical BSDF is not a thin dielectric (in the ground truth and as loaded)."""
    shapes = {s.id(): s for s in scene.scene.shapes()}
    problems = []
    for s in gt["shapes"]:
        is_glass, is_window = s["preset"] == "glass", s["role"] == "window"
        if is_glass != is_window:
            problems.append(f"shape '{s['id']}': preset {s['preset']}, role {s['role']}")
        if is_glass or is_window:
            optical = gt["materials"][s["material"]]["optical"]
            nested = str(shapes[s["id"]].bsdf().nested).split("[")[0]
            if optical != "thindielectric" or nested != "ThinDielectric":
                problems.append(f"shape '{s['id']}': glass seen as {optical} / {nested}")
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


def test_trajectory_clear_of_footprints(shipped):
    _, _, gt = shipped
    assert footprint_problems(gt) == []


def test_objects_match_mitsuba(shipped):
    _, scene, gt = shipped
    assert object_problems(scene, gt) == []


def test_cylinders_are_closed(shipped):
    _, _, gt = shipped
    assert closed_problems(gt) == []


def test_glass_is_thin_dielectric_windows(shipped):
    _, scene, gt = shipped
    assert glass_problems(scene, gt) == []


def test_textures_are_shipped_and_used(shipped):
    """Each texture the ground truth lists is a PNG in the scene folder that a material of the
    scene file reads through a bitmap texture."""
    name, _, gt = shipped
    xml = (SCENES_DIR / name / "scene.xml").read_text()
    used = {m["texture"] for m in gt["materials"].values() if "texture" in m}
    assert used == set(gt.get("textures", []))
    for tex in used:
        assert (SCENES_DIR / name / tex).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert f'<string name="filename" value="{tex}"/>' in xml


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


# ---- workshop and office specifics ----------------------------------------------------------
def _extents(obj) -> list[float]:
    """Sorted (smallest first) extents [m] of an object's bounding box."""
    x0, x1, y0, y1 = obj["footprint_xy_m"]
    z0, z1 = obj["z_m"]
    return sorted([x1 - x0, y1 - y0, z1 - z0])


def _groups(gt, role) -> dict[str, dict]:
    return {o["id"]: o for o in gt["objects"] if o["role"] == role}


def test_workshop_layout():
    scene, gt = _load("workshop")
    ext = gt["interior_extent_m"]
    assert (ext["x"][1] - ext["x"][0], ext["y"][1] - ext["y"][0]) == pytest.approx((8.0, 6.0))
    assert gt["height_m"] == pytest.approx(3.0) and gt["windows"] == []
    presets = {}
    for s in gt["shapes"]:
        presets.setdefault(s["role"], set()).add(s["preset"])
    assert presets["floor"] == presets["wall"] == {"concrete"}
    furniture = _groups(gt, "furniture")
    for gid in ("bench_1", "bench_2", "bench_3", "shelf_1", "shelf_2", "cabinet", "machine",
                "drum"):
        assert gid in furniture, gid
    assert furniture["shelf_1"]["z_m"][1] >= 2.0  # tall shelves
    # benches: wood tops on metal legs
    by_id = {s["id"]: s for s in gt["shapes"]}
    for k in (1, 2, 3):
        assert by_id[f"bench_{k}_top"]["preset"] == "wood"
        assert {by_id[f"bench_{k}_leg_{j}"]["preset"] for j in range(1, 5)} == {"metal"}
    # boxes on the shelves
    shelf_x = [furniture[f"shelf_{k}"]["footprint_xy_m"][:2] for k in (1, 2)]
    on_shelves = [o for gid, o in furniture.items() if gid.startswith(("box_", "bin_"))
                  and any(a <= o["footprint_xy_m"][0] <= b for a, b in shelf_x)]
    assert len(on_shelves) >= 6
    # 20-40 tools of 2-15 cm (the thinnest 1 cm), on the benches and shelves (above 0.1 m)
    tools = _groups(gt, "small_object")
    assert 20 <= len(tools) <= 40
    for gid, o in tools.items():
        e = _extents(o)
        assert e[0] >= 0.01 - 1e-4 and 0.02 - 1e-4 <= e[2] <= 0.15 + 1e-4, (gid, e)
        assert o["z_m"][0] >= 0.1, gid
    kinds = {by_id[sid]["type"] for o in tools.values() for sid in o["shapes"]}
    assert {"cube", "cylinder", "disk", "sphere"} <= kinds
    # coloured or textured: several distinct diffuse colours and at least one texture
    assert len(gt["textures"]) >= 2 and "floor_concrete" in {
        m for m, v in gt["materials"].items() if "texture" in v}


def test_office_layout():
    scene, gt = _load("office")
    ext = gt["interior_extent_m"]
    assert (ext["x"][1] - ext["x"][0], ext["y"][1] - ext["y"][0]) == pytest.approx((12.0, 9.0))
    assert gt["height_m"] == pytest.approx(2.8)
    presets = {}
    for s in gt["shapes"]:
        presets.setdefault(s["role"], set()).add(s["preset"])
    assert presets["floor"] == {"fabric"} and presets["window"] == {"glass"}
    # several small windows, each at most 1 m^2, in holes of the outer walls
    assert len(gt["windows"]) >= 3
    for w in gt["windows"]:
        assert w["width_m"] * w["height_m"] <= 1.0 and w["wall"].startswith("wall_")
    furniture = _groups(gt, "furniture")
    by_id = {s["id"]: s for s in gt["shapes"]}
    sofas = [o for gid, o in furniture.items() if gid.startswith("sofa_")]
    assert len(sofas) == 2
    assert all(by_id[sid]["preset"] == "fabric" for o in sofas for sid in o["shapes"])
    chairs = [o for gid, o in furniture.items() if gid.startswith("chair_")]
    desks = [o for gid, o in furniture.items() if gid.startswith("desk_")]
    monitors = [o for gid, o in furniture.items() if gid.startswith("monitor_")]
    assert len(chairs) == len(desks) == len(monitors) >= 6
    for c in chairs:
        parts = {sid.rsplit("_", 1)[-1] if "_leg_" not in sid else "leg" for sid in c["shapes"]}
        assert parts == {"seat", "back", "leg"}, c["id"]
    cups = [o for gid, o in _groups(gt, "small_object").items() if gid.startswith("cup_")]
    assert len(cups) >= 8
    for cup in cups:
        e = _extents(cup)
        assert 0.06 <= e[0] and e[2] <= 0.12, (cup["id"], e)
    # the key look's lights, the ceiling panels and the sky seen through the windows
    emitters = [str(e).split("[")[0] for e in scene.scene.emitters()]
    assert {"KeyLight", "AmbientLight", "EnvironmentMapEmitter", "AreaLight"} <= set(emitters)


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


def test_footprint_check_catches_a_path_under_a_table_top():
    """0.3 m beside bench_1's top, 0.87 m from its legs: the horizontal probes (all below the
    top) see nothing near, the footprint check does."""
    scene, gt = _load("workshop")
    assert footprint_problems(gt) == []
    gt["trajectory"]["waypoints"] = [[-1.7, -1.5, 270.0], [-1.7, -1.85, 270.0]]
    problems = footprint_problems(gt)
    assert "'bench_1' (< 0.5 m)" in problems[0] and "is 0.30 m" in problems[0]
    assert not [p for p in trajectory_problems(scene, gt) if " m from " in p]


def test_object_and_closure_checks_catch_errors():
    scene, gt = _load("office")
    obj = next(o for o in gt["objects"] if o["id"] == "sofa_1")
    obj["footprint_xy_m"][0] -= 0.01
    assert any("'sofa_1': bounds" in p for p in object_problems(scene, gt))
    scene, gt = _load("office")
    obj = next(o for o in gt["objects"] if o["id"] == "desk_1")
    obj["shapes"].remove("desk_1_leg_3")
    assert any("'desk_1_leg_3'" in p and "no object" in p for p in object_problems(scene, gt))
    _, gt = _load("office")
    gt["shapes"] = [s for s in gt["shapes"] if s["id"] != "cup_3_cap1"]
    problems = closed_problems(gt)
    assert len(problems) == 1 and "'cup_3'" in problems[0]


def test_glass_check_catches_errors():
    scene, gt = _load("office")
    assert glass_problems(scene, gt) == []
    gt["materials"]["window_glass"]["optical"] = "dielectric"
    assert len(glass_problems(scene, gt)) == len(gt["windows"])
    scene, gt = _load("office")
    next(s for s in gt["shapes"] if s["id"] == "cup_1")["preset"] = "glass"
    assert any("'cup_1'" in p for p in glass_problems(scene, gt))


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
    pieces = rect_minus(outer, holes)
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
    shape = box("b", (1.0, 2.0, 0.4), (1.2, 0.6, 0.8), "m", "furniture", "b", yaw_deg=30)
    cube = mi.load_dict({"type": "cube", "to_world": mi.ScalarTransform4f(shape.to_world)})
    area = float(np.asarray(cube.surface_area()).ravel()[0])
    assert shape.area == pytest.approx(2 * (1.2 * 0.6 + 0.6 * 0.8 + 1.2 * 0.8))
    assert area == pytest.approx(shape.area, rel=AREA_RTOL)
