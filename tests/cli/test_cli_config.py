"""Command line, configuration files and the native-library set-up."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

import mitsonar
from mitsonar import _native
from mitsonar.cli import main
from mitsonar.scene.xml import material_xml, rectangle_xml


@pytest.fixture
def small_scene(scene_file):
    # A wall 2 m ahead of the sensor when the robot stands at the origin facing +x.
    wall = rectangle_xml("w", (2.1, 0.0, 0.5), (0, -90, 0), size=(10, 10))
    return scene_file("small", material_xml("w", preset="concrete"), wall)


def test_scan_command_writes_outputs(small_scene, tmp_path, capsys):
    out = tmp_path / "scan"
    code = main(["scan", small_scene, "--pose", "0,0,0", "--fov", "20x10", "--step", "10",
                 "--out", str(out)])
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    # Beams at -10, 0, +10 deg: the smooth wall answers at normal incidence; at 10 deg its
    # specular return arrives through the side lobes and is rejected, not misranged.
    assert summary["beams"] == 3 and summary["detected"] >= 1
    data = np.load(out / "echoes.npz")
    # Complex baseband (the default behind resonant transducers) about the band's centre.
    assert data["echoes"].shape[:2] == (3, 25) and data["echoes"].dtype == np.complex64
    assert 35e3 < data["carrier_frequency"] < 45e3 and data["sample_rate"] < 100e3
    assert data["detected"][1] and np.isnan(data["depth"][~data["detected"]]).all()
    ply = (out / "points.ply").read_text().splitlines()
    assert f"element vertex {summary['detected']}" in ply
    points = np.loadtxt(ply[ply.index("end_header") + 1:], ndmin=2)
    np.testing.assert_allclose(points[:, 0], 2.1, atol=0.01)  # the wall plane x = 2.1 m (world)
    assert (out / "scan.png").stat().st_size > 10_000
    assert f"{summary['detected']}/3 beams" in capsys.readouterr().out


def test_scan_command_with_shared_hits(small_scene, tmp_path):
    """``--shared-hits``: one trace of the field of view for every ping; the wall answers at
    normal incidence, within 1 cm of its plane, and the summary says the hits were shared."""
    out = tmp_path / "shared"
    assert main(["scan", small_scene, "--fov", "20x10", "--step", "10", "--shared-hits",
                 "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["shared_hits"] and summary["beams"] == 3
    data = np.load(out / "echoes.npz")
    assert data["detected"][1]
    ply = (out / "points.ply").read_text().splitlines()
    points = np.loadtxt(ply[ply.index("end_header") + 1:], ndmin=2)
    np.testing.assert_allclose(points[:, 0], 2.1, atol=0.01)


@pytest.mark.parametrize("args,message", [
    (["--pose", "0,nan,0"], "pose"), (["--fov", "80x10"], "field of view"),
    (["--step", "-5"], "step")])
def test_scan_command_reports_bad_input(small_scene, tmp_path, capsys, args, message):
    argv = ["scan", small_scene, "--out", str(tmp_path / "o")] + args
    try:
        code = main(argv)
    except SystemExit as exit_:  # argparse rejects malformed values itself
        code = exit_.code
    assert code == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "o" / "echoes.npz").exists()


def test_scan_command_names_a_bad_scene_file(tmp_path, capsys):
    bad = tmp_path / "bad.xml"
    bad.write_text("<scene version='3.0.0'><shape type='cube'>")
    assert main(["scan", str(bad), "--out", str(tmp_path / "o")]) == 2
    assert "bad.xml" in capsys.readouterr().err


def test_toml_config_overrides_and_rejects_unknown_keys(tmp_path):
    good = tmp_path / "sonar.toml"
    good.write_text('preset = "paper"\nnoise_rms = 0.002\n[medium]\nrelative_humidity = 80.0\n'
                    '[trace]\nrays_per_axis = 24\n')
    cfg = mitsonar.SonarConfig.from_toml(good)
    assert cfg.trace.model == "paper" and cfg.trace.rays_per_axis == 24
    assert cfg.noise_rms == 0.002 and cfg.medium.relative_humidity == 80.0
    bad = tmp_path / "bad.toml"
    bad.write_text("[medium]\nhumidity = 80\n")
    with pytest.raises(ValueError, match="bad.toml.*humidity"):
        mitsonar.SonarConfig.from_toml(bad)
    worse = tmp_path / "worse.toml"
    worse.write_text("[trace]\nrays_per_axis = -3\n")
    with pytest.raises(ValueError, match="worse.toml.*rays_per_axis"):
        mitsonar.SonarConfig.from_toml(worse)


def test_llvm_selection_respects_user_and_fails_clearly(monkeypatch, tmp_path):
    monkeypatch.setenv("DRJIT_LIBLLVM_PATH", "/opt/my/libLLVM.so")
    assert _native.configure_llvm() == "/opt/my/libLLVM.so"
    monkeypatch.delenv("DRJIT_LIBLLVM_PATH")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    fake = tmp_path / "libLLVM-fake.so"
    fake.write_text("not a library")
    monkeypatch.setattr(_native, "_llvm_candidates", lambda: [str(fake)])
    with pytest.raises(_native.NativeLibraryError, match="libLLVM-fake.so"):
        _native.configure_llvm()


def test_importing_drjit_first_is_warned_about():
    """Dr.Jit loads its libLLVM at import: imported before mitsonar it may have taken one that
    aborts on 'fminimum' kernels, which the user is told about, with the library to set."""
    env = {k: v for k, v in os.environ.items() if k != "DRJIT_LIBLLVM_PATH"}
    run = subprocess.run([sys.executable, "-c", "import drjit, mitsonar"], env=env,
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0
    assert "drjit was imported before mitsonar" in run.stderr
    assert "DRJIT_LIBLLVM_PATH=" in run.stderr
    quiet = subprocess.run([sys.executable, "-c", "import mitsonar, drjit"], env=env,
                           capture_output=True, text=True, timeout=120)
    assert quiet.returncode == 0 and "imported before mitsonar" not in quiet.stderr


def test_open3d_imports_with_the_shipped_libusb():
    o3d = _native.import_open3d()
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.zeros((3, 3))))
    assert len(cloud.points) == 3


def test_map_repeated_command_writes_a_coloured_voxel_map(scene_file, tmp_path, capsys):
    """Repeated-scanning map along a trajectory file: one OFDM frame of 9 beams on a wall."""
    wall = rectangle_xml("w", (2.1, 0.0, 0.5), (0, -90, 0), size=(10, 10))
    light = ('<emitter type="constant"><rgb name="radiance" value="1"/></emitter>')
    scene = scene_file("wall", material_xml("w", preset="concrete"), wall, light)
    (tmp_path / "path.json").write_text(json.dumps({
        "waypoints": [[0, 0, 0], [1, 0, 0]], "speed_m_s": 0.2, "yaw_rate_deg_s": 30}))
    out = tmp_path / "map"
    assert main(["map", "repeated", scene, "--out", str(out), "--frames", "1", "--step", "20",
                 "--trajectory", str(tmp_path / "path.json"), "--broadband"]) == 0
    ply = (out / "voxel_map.ply").read_text().splitlines()
    n = int(next(line.split()[-1] for line in ply if line.startswith("element vertex")))
    points = np.loadtxt(ply[ply.index("end_header") + 1:], ndmin=2)
    assert n >= 1 and np.all(np.abs(points[:, 0] - 2.1) <= 0.05)  # voxels on the wall (5 cm grid)
    assert (out / "voxel_map.png").stat().st_size > 10_000
    assert "voxels" in capsys.readouterr().out
