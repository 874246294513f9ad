"""Varied rooms (``mitsonar.scene.varied``): deterministic in their seed, and each of the first
ten loads cleanly, has glass, furniture and lights, and a default trajectory inside the room,
clear of walls and objects, that starts facing a wall."""

from __future__ import annotations

import hashlib
import json
import re
import warnings

import numpy as np
import pytest

import mitsonar
from mitsonar.frames import Pose, direction_from_fov_angles
from mitsonar.scene.loading import DefaultMaterialWarning, mitsuba
from mitsonar.scene.rays import rays
from mitsonar.scene.varied.room import varied_room, write_varied_rooms
from mitsonar.scenes import generate

SEEDS = range(10)
#: Least distance from the robot's path to walls and object footprints [m].
CLEARANCE = 0.8
#: Heights of the horizontal probe rays (robot body and sensor head) [m].
PROBE_HEIGHTS = (0.05, 0.3, 0.55)


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    out = tmp_path_factory.mktemp("varied")
    write_varied_rooms(out, SEEDS)
    return out


@pytest.fixture(scope="module")
def loaded(folder):
    """seed -> (AcousticScene, ground truth), loaded on first use."""
    cache = {}

    def get(seed):
        if seed not in cache:
            path = folder / f"varied_{seed}"
            with warnings.catch_warnings():
                warnings.simplefilter("error", DefaultMaterialWarning)
                scene = mitsonar.load_scene(path / "scene.xml")
            cache[seed] = scene, json.loads((path / "ground_truth.json").read_text())
        return cache[seed]

    return get


def _cast(scene, origins, directions):
    """First hits: distance (inf on a miss), normal (N, 3) and the id of the shape hit."""
    mi = mitsuba()
    import drjit as dr

    si = scene.scene.ray_intersect(rays(origins, directions))
    valid = np.asarray(si.is_valid(), dtype=bool)
    t = np.where(valid, np.asarray(si.t, dtype=float), np.inf)
    index = {int(r): k for k, r in enumerate(scene.registry_ids)}
    reg = np.asarray(dr.reinterpret_array(mi.UInt32, si.shape), dtype=np.int64)
    ids = [scene.shape_ids[index[int(r)]] if v else "" for r, v in zip(reg, valid)]
    return t, np.asarray(si.n, dtype=float).T, ids


def _path_points(waypoints, step=0.05) -> np.ndarray:
    """(M, 2) plan points along the trajectory's polyline, ``step`` [m] apart or closer."""
    wp = np.asarray(waypoints, dtype=float)[:, :2]
    pts = [wp[0]]
    for a, b in zip(wp[:-1], wp[1:]):
        n = max(int(np.ceil(np.linalg.norm(b - a) / step)), 1)
        pts += [a + (b - a) * k / n for k in range(1, n + 1)]
    return np.array(pts)


def _probe(scene, xy, n_dirs=72):
    """Horizontal rays in ``n_dirs`` directions at each PROBE_HEIGHTS from plan points (M, 2):
    distances (M, K), normals (M, K, 3), shape ids (M, K) and directions (K, 3)."""
    ang = np.arange(n_dirs) * 2 * np.pi / n_dirs
    dirs = np.tile(np.column_stack([np.cos(ang), np.sin(ang), np.zeros(n_dirs)]),
                   (len(PROBE_HEIGHTS), 1))
    z = np.repeat(PROBE_HEIGHTS, n_dirs)
    origins = np.concatenate([np.column_stack([np.full(len(z), x), np.full(len(z), y), z])
                              for x, y in xy])
    t, n, ids = _cast(scene, origins, np.tile(dirs, (len(xy), 1)))
    m = len(xy)
    return t.reshape(m, -1), n.reshape(m, -1, 3), np.array(ids).reshape(m, -1), dirs


def test_same_seed_writes_identical_bytes(tmp_path):
    write_varied_rooms(tmp_path / "a", [7])
    write_varied_rooms(tmp_path / "b", [7])
    files = sorted(p.name for p in (tmp_path / "a" / "varied_7").iterdir())
    assert {"scene.xml", "ground_truth.json"} <= set(files)
    assert files == sorted(p.name for p in (tmp_path / "b" / "varied_7").iterdir())
    for name in files:
        assert (tmp_path / "a" / "varied_7" / name).read_bytes() == \
            (tmp_path / "b" / "varied_7" / name).read_bytes(), name


def test_different_seeds_differ(folder):
    for name in ("scene.xml", "ground_truth.json"):
        digests = {hashlib.sha256((folder / f"varied_{s}" / name).read_bytes()).hexdigest()
                   for s in SEEDS}
        assert len(digests) == len(SEEDS), name
    assert varied_room(3).name == "varied_3"


@pytest.mark.parametrize("seed", SEEDS)
def test_loads_with_exact_ground_truth(folder, loaded, seed):
    """Shapes and their areas as Mitsuba has them; every material and texture written is used."""
    scene, gt = loaded(seed)
    assert gt["scene"] == f"varied_{seed}"
    xml = (folder / f"varied_{seed}" / "scene.xml").read_text()
    assert sorted(re.findall(r'<bsdf type="acoustic" id="([^"]+)">', xml)) == \
        sorted(gt["materials"])
    used = sorted({m["texture"] for m in gt["materials"].values() if "texture" in m})
    assert gt["textures"] == used
    pngs = sorted(p.name for p in (folder / f"varied_{seed}").glob("*.png"))
    assert pngs == sorted(used + (["sky.png"] if gt["windows"] else []))
    by_id = {s["id"]: s for s in gt["shapes"]}
    assert sorted(scene.shape_ids) == sorted(by_id)
    for shape in scene.scene.shapes():
        area = float(np.asarray(shape.surface_area()).ravel()[0])
        assert by_id[shape.id()]["area_m2"] == pytest.approx(area, rel=1e-6), shape.id()


@pytest.mark.parametrize("seed", SEEDS)
def test_has_glass_furniture_and_lights(loaded, seed):
    scene, gt = loaded(seed)
    glass = [s for s in gt["shapes"] if s["preset"] == "glass"]
    assert glass, "no window and no glass partition"
    assert {gt["materials"][s["material"]]["optical"] for s in glass} == {"thindielectric"}
    assert {s["role"] for s in glass} <= {"window", "furniture"}
    assert len(gt["windows"]) == sum(s["role"] == "window" for s in glass)
    pieces = [o for o in gt["objects"] if o["role"] == "furniture" and o["id"] != "partition"
              and not o["id"].startswith("lamp_")]
    assert pieces, "no furniture"
    assert any(s["role"] == "light" for s in gt["shapes"])
    assert len(scene.scene.emitters()) >= 1


@pytest.mark.parametrize("seed", SEEDS)
def test_trajectory_inside_and_clear(loaded, seed):
    """Every waypoint inside the room (every horizontal ray meets a surface, walls from their
    front);
    every point of the path CLEARANCE or more from any surface at the probe heights and, in
    plan, from every object's footprint."""
    scene, gt = loaded(seed)
    wp = np.asarray(gt["trajectory"]["waypoints"], dtype=float)
    assert wp[0].tolist() == [0.0, 0.0, 0.0]
    t, n, ids, dirs = _probe(scene, wp[:, :2])
    assert np.all(np.isfinite(t)), "a waypoint sees out of the room"
    shell = np.isin(ids, [s["id"] for s in gt["shapes"]
                          if s["role"] in ("wall", "interior_wall", "floor", "ceiling")])
    front = np.einsum("mkc,kc->mk", n, dirs) < 0
    assert np.all(front | ~shell), "a waypoint sees the room's shell from behind"
    pts = _path_points(wp)
    t, _, _, _ = _probe(scene, pts)
    k = int(np.argmin(t.min(axis=1)))
    assert t[k].min() >= CLEARANCE, f"path point {pts[k]} is {t[k].min():.3f} m from a surface"
    for obj in gt["objects"]:
        x0, x1, y0, y1 = obj["footprint_xy_m"]
        dx = np.maximum(np.maximum(x0 - pts[:, 0], pts[:, 0] - x1), 0.0)
        dy = np.maximum(np.maximum(y0 - pts[:, 1], pts[:, 1] - y1), 0.0)
        assert np.hypot(dx, dy).min() >= CLEARANCE, obj["id"]


@pytest.mark.parametrize("seed", SEEDS)
def test_first_waypoint_faces_a_wall(loaded, seed):
    """The sensor's boresight at the first waypoint meets a wall within 10 m, and from some
    waypoint every window and the partition lie in the sonar's 60 x 40 deg field of view."""
    scene, gt = loaded(seed)
    roles = {s["id"]: s["role"] for s in gt["shapes"]}
    wp = gt["trajectory"]["waypoints"]
    pose = Pose.sensor_on_robot(wp[0][0], wp[0][1], np.radians(wp[0][2]))
    boresight = pose.transform_vectors(direction_from_fov_angles(np.zeros(1), np.zeros(1)))
    assert np.allclose(boresight, [[1.0, 0.0, 0.0]], atol=1e-9)
    t, _, ids = _cast(scene, pose.translation[None], boresight)
    assert roles[ids[0]] in ("wall", "interior_wall") and t[0] < 10.0, (ids[0], t[0])
    h, v = np.meshgrid(np.radians(np.arange(-30, 31, 5)), np.radians(np.arange(-20, 21, 5)))
    u = direction_from_fov_angles(h.ravel(), v.ravel())
    seen = set()
    for x, y, yaw in wp:
        pose = Pose.sensor_on_robot(x, y, np.radians(yaw))
        seen |= set(_cast(scene, np.tile(pose.translation, (len(u), 1)),
                          pose.transform_vectors(u))[2])
    glass = {s["id"] for s in gt["shapes"] if s["preset"] == "glass"}
    windows = {w["id"] for w in gt["windows"]}
    assert windows <= seen
    assert not glass - windows or glass & seen - windows, "the partition is never in view"


def test_generate_writes_varied_rooms(tmp_path, capsys):
    assert generate.main(["--varied", "2", "--out", str(tmp_path)]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["varied_0", "varied_1"]
    assert (tmp_path / "varied_1" / "scene.xml").read_text().count("varied_room(1)") == 1
    with pytest.raises(SystemExit):
        generate.main(["--varied", "2"])  # without --out it would write among the shipped
