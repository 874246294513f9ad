"""``mitsonar scenes`` and shipped scene names wherever a scene is asked for, also after a
plain install."""

import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

from mitsonar.cli import main
from mitsonar.cli.arguments import scene_path
from mitsonar.scene.catalog import shipped_scenes
from helpers import ROOT, SCENES

SHIPPED = ["office", "room_glass", "structure", "workshop"]


def test_scenes_lists_the_shipped_scenes(capsys):
    assert list(shipped_scenes()) == SHIPPED
    assert main(["scenes"]) == 0
    out = capsys.readouterr().out
    for name in SHIPPED:
        assert f"{name} " in out and str(SCENES / name / "scene.xml") in out


def test_a_scene_is_a_path_or_a_shipped_name(tmp_path, monkeypatch):
    assert scene_path("room_glass") == SCENES / "room_glass" / "scene.xml"
    monkeypatch.chdir(tmp_path)
    (tmp_path / "room_glass").write_text("<scene/>")  # an existing file wins over a name
    assert scene_path("room_glass") == Path("room_glass")
    assert scene_path("no_such_scene") == Path("no_such_scene")


def test_unknown_scene_lists_the_shipped_ones(tmp_path, capsys):
    assert main(["scan", "no_such_scene", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "no_such_scene: scene file not found" in err and "room_glass" in err


@pytest.mark.slow
def test_installed_wheel_runs_shipped_scenes_by_name_from_anywhere(tmp_path):
    """A plain (non-editable) install: build the wheel, install it alone into a fresh venv that
    sees this environment's dependencies, and run it outside the checkout."""
    source, wheels = tmp_path / "source", tmp_path / "wheels"
    venv, work = tmp_path / "venv", tmp_path / "work"
    work.mkdir()
    for name in ("mitsonar", "plugins", "scenes"):  # a copy: the build leaves the checkout alone
        shutil.copytree(ROOT / name, source / name, ignore=shutil.ignore_patterns("__pycache__"))
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, source / name)
    run = dict(check=True, capture_output=True, text=True)
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(wheels),
                    str(source)], **run)
    (wheel,) = wheels.glob("mitsonar-*.whl")
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], **run)
    python = venv / "bin" / "python"
    subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install", "-q",
                    "--no-deps", str(wheel)], **run)
    site = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_path("
                           "'purelib'))"], **run).stdout.strip()
    deps = {sysconfig.get_path("purelib"), sysconfig.get_path("platlib")}
    (Path(site) / "test_dependencies.pth").write_text("\n".join(sorted(deps)) + "\n")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    mitsonar = str(venv / "bin" / "mitsonar")
    listed = subprocess.run([mitsonar, "scenes"], cwd=work, env=env, **run).stdout
    subprocess.run([str(python), "-c", "from mitsonar.data.ros_schemas import definition; "
                    "definition('mitsonar_msgs/SonarEchoes')"], cwd=work, env=env, **run)
    assert all(name in listed for name in SHIPPED) and str(ROOT) not in listed
    scan = subprocess.run([mitsonar, "scan", "room_glass", "--step", "20", "--fov", "20x10",
                           "--out", "scan"], cwd=work, env=env, **run)
    assert "/1 beams detected" in scan.stdout
    assert (work / "scan" / "echoes.npz").is_file()
    summary = (work / "scan" / "summary.json").read_text()
    assert str(Path(site) / "mitsonar" / "scenes" / "room_glass") in summary
