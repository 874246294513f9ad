"""The benchmark's profile: its stages are disjoint and account for the whole run; the scene
of its Sionna RT peer line."""

import importlib.util
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import mitsonar
from helpers import ROOT, SCENES


def load_benchmark(name: str = "run"):
    """The module benchmarks/<name>.py."""
    spec = importlib.util.spec_from_file_location(f"benchmark_{name}",
                                                  ROOT / "benchmarks" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[f"benchmark_{name}"] = module
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("shared_hits", [False, True], ids=["per beam", "shared hits"])
def test_profile_stages_are_disjoint(capsys, shared_hits):
    bench = load_benchmark()
    sonar = mitsonar.Sonar(str(SCENES / "room_glass" / "scene.xml"))
    pose = mitsonar.Pose.sensor_on_robot(0.0, 0.0, 0.0)
    dirs = sonar.fov_grid(np.radians(30.0))[:3]
    rows = bench.profile(lambda: sonar.scan(pose, dirs, shared_hits=shared_hits), len(dirs),
                         len(dirs), "pings/s")
    assert [name for name, _ in rows[:-1]] == [name for name, _, _ in bench.STAGES]
    seconds = np.array([t for _, t in rows])
    # Every stage ran (but the narrow-band merge with shared hits, which grid every element
    # pair), and none is counted twice: the remainder ("other") is what no stage covers, so it
    # would go negative if two stages shared time (cProfile's own timer rounding is ~1 us per
    # call, far below 1 % of a ping).
    merge = [name for name, _ in rows].index("narrow-band merge kernel")
    ran = np.delete(seconds[:-1], merge) if shared_hits else seconds[:-1]
    assert np.all(np.isfinite(seconds)) and np.all(ran > 0)
    assert seconds[merge] == 0 if shared_hits else seconds[merge] > 0
    assert seconds[-1] >= -0.01 * seconds.sum()
    assert len(capsys.readouterr().out.splitlines()) == len(rows)


def test_peer_scene_is_the_scene_file():
    """Sionna RT's scene (no Sionna needed): every shape of room_glass with an ITU radio material
    per acoustic preset; the office's disks, cylinders and spheres (not meshes) left out."""
    peer = load_benchmark("peer_sionna")
    xml, left_out = peer.radio_scene_xml(str(SCENES / "room_glass" / "scene.xml"))
    root = ET.fromstring(xml)
    assert left_out == 0 and len(root.findall("shape")) == 30
    assert {b.get("type") for b in root.iter("bsdf")} == {"itu-radio-material"}
    types = {b.find("string[@name='type']").get("value") for b in root.iter("bsdf")}
    assert types == {"plasterboard", "concrete", "glass"}
    _, left_out = peer.radio_scene_xml(str(SCENES / "office" / "scene.xml"))
    office = ET.parse(SCENES / "office" / "scene.xml").getroot().findall("shape")
    assert left_out == sum(s.get("type") in ("disk", "cylinder", "sphere") for s in office) > 0
