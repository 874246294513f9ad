"""Datasets: exact round trip, interrupted renders, corruption, parallel and distributed renders."""

import filecmp
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from mitsonar.data.dataset import DatasetError, DatasetSpec, _Renderer, open_dataset, render_dataset
from helpers import SCENES

ROOM = str(SCENES / "room_glass" / "scene.xml")
# Two samples, three beams each, tiny images: seconds, not minutes.
SPEC = DatasetSpec(ROOM, period=2.0, scan_step=np.radians(30), image_width=24, spp=2, max_samples=2)


def _same_tree(a: Path, b: Path) -> bool:
    for folder in sorted(p.name for p in (a / "samples").iterdir()):
        cmp = filecmp.dircmp(a / "samples" / folder, b / "samples" / folder)
        if cmp.diff_files or cmp.left_only or cmp.right_only:
            return False
        if not all(filecmp.cmp(a / "samples" / folder / f, b / "samples" / folder / f, shallow=False)
                   for f in cmp.common_files):
            return False
    return json.loads((a / "dataset.json").read_text()) == json.loads((b / "dataset.json").read_text())


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    return render_dataset(SPEC, tmp_path_factory.mktemp("ds") / "reference")


def test_write_read_round_trip_is_exact(reference):
    ds = open_dataset(reference)
    assert len(ds) == 2 and ds.complete()
    renderer = _Renderer(SPEC)
    sample = ds[1]
    pose = sample.pose
    from mitsonar.sensors.trajectory import sensor_poses
    from mitsonar.data.dataset import _derive_seed

    sensor = sensor_poses(np.array([pose["robot_pose_truth"]]))[0]
    seed = _derive_seed(SPEC.seed, "sample", 1)
    images = renderer.camera.render(sensor, seed=seed)
    scan = renderer.sonar.scan(sensor, renderer.directions, seed=seed)
    assert np.array_equal(sample.rgb, images.rgb) and np.array_equal(sample.gray, images.gray)
    assert np.array_equal(sample.depth, images.depth)
    assert np.array_equal(sample.shape_index, images.shape_index)
    assert np.array_equal(sample.echoes["echoes"], scan.echoes)
    assert np.array_equal(sample.echoes["depth"], scan.depth, equal_nan=True)
    assert renderer.sonar.config.detection.echoes == SPEC.echoes == "all"
    table = scan.echo_table.arrays("echo_")  # every echo, with its attributes
    assert len(table["echo_beam"]) >= scan.detected.sum() > 0
    for name, value in table.items():
        assert np.array_equal(sample.echoes[name], value, equal_nan=value.dtype.kind == "f")
    np.testing.assert_allclose(np.array(pose["world_from_sensor_truth"]), sensor.matrix())
    calib = ds.meta["calibration"]
    assert calib["image_size"] == [24, 18] and len(calib["rx_positions_m"]) == 25


def test_killed_render_resumes_to_the_same_dataset(reference, tmp_path):
    """A render killed (SIGKILL) while it writes its second sample resumes to the same dataset
    as an uninterrupted one, and leaves no partial sample behind."""
    out = tmp_path / "resumed"
    here = Path(__file__).parent
    code = ("import sys; sys.path[:0] = [%r, %r]; from test_dataset import SPEC; "
            "from mitsonar.data.dataset import render_dataset; render_dataset(SPEC, %r)"
            % (str(here), str(here.parent), str(out)))
    log = tmp_path / "render.log"  # a file, not a pipe: a full pipe would stall the render
    with open(log, "w") as stderr:
        proc = subprocess.Popen([sys.executable, "-c", code], stderr=stderr)
    deadline = time.time() + 120
    while not (out / "samples" / "000000" / "manifest.json").exists():
        if proc.poll() is not None:  # it must still be rendering when its first sample is done
            pytest.fail(f"the render ended (exit {proc.returncode}) before its first sample: "
                        f"{log.read_text()[-2000:]}")
        assert time.time() < deadline, "no first sample in 120 s"
        time.sleep(0.01)
    os.kill(proc.pid, signal.SIGKILL)  # in the middle of the second sample
    proc.wait()
    assert not (out / "samples" / "000001").exists()
    render_dataset(SPEC, out)
    assert _same_tree(reference, out)
    assert not [p for p in (out / "samples").iterdir() if p.name.startswith(".")]


def test_truncated_file_is_reported_by_name(reference, tmp_path):
    import shutil

    copy = tmp_path / "copy"
    shutil.copytree(reference, copy)
    echoes = copy / "samples" / "000000" / "echoes.npz"
    echoes.write_bytes(echoes.read_bytes()[:-100])
    ds = open_dataset(copy)
    with pytest.raises(DatasetError, match="echoes.npz"):
        ds[0]
    assert ds[1].echoes["echoes"].shape[1] == 25  # other samples stay readable
    with pytest.raises(DatasetError, match="another spec"):
        render_dataset(DatasetSpec(ROOM, period=1.0, max_samples=1), copy)


@pytest.mark.slow
def test_local_processes_and_dask_cluster_give_the_same_dataset(reference, tmp_path):
    """... and the Dask cluster leaves the caller's environment as it was (its nannies set
    ``OMP_NUM_THREADS`` and ``MALLOC_TRIM_THRESHOLD_`` there for their workers, which every
    process started later inherited)."""
    assert _same_tree(reference, render_dataset(SPEC, tmp_path / "pool", workers=2))
    before = dict(os.environ)
    assert _same_tree(reference, render_dataset(SPEC, tmp_path / "dask", workers=2, scheduler="local"))
    assert dict(os.environ) == before


def test_image_samples_hold_one_single_ping_image_and_export(tmp_path):
    """``scan='image'``: each sample's echoes.npz is one single-ping receive image as a scan of
    one transmission (``ImagingSonar.scan``, the same seed): its recording (1, 25, N) and every
    point of it as a row of the echo table, strongest first; the MCAP export carries them (one
    detections cloud with every point, one echoes message). A sweep behind the TCT40 class is
    refused when the spec is made."""
    from mitsonar.data.dataset import _derive_seed
    from mitsonar.data.dataset_mcap import export_dataset
    from mitsonar.data.ros_messages import cloud_columns
    from mitsonar.sensors.trajectory import sensor_poses
    from helpers import read_mcap

    spec = DatasetSpec(ROOM, period=2.0, image_width=24, spp=2, max_samples=1, scan="image",
                       broadband=True, chirp=True)
    ds = open_dataset(render_dataset(spec, tmp_path / "images"))
    sample = ds[0]
    renderer = _Renderer(spec)
    sensor = sensor_poses(np.array([sample.pose["robot_pose_truth"]]))[0]
    scan = renderer.imaging.scan(sensor, seed=_derive_seed(spec.seed, "sample", 0))
    e = sample.echoes
    assert e["echoes"].shape[:2] == (1, 25) and np.array_equal(e["echoes"], scan.echoes)
    assert len(e["echo_beam"]) > 0 and np.all(e["echo_beam"] == 0)
    np.testing.assert_array_equal(e["echo_rank"], np.arange(len(e["echo_beam"])))
    assert np.all(np.diff(e["echo_amplitude"]) <= 0)  # strongest first
    np.testing.assert_array_equal(e["echo_point"], scan.echo_table.point)
    np.testing.assert_array_equal(e["points_sensor"][0], e["echo_point"][0])
    export_dataset(tmp_path / "images", tmp_path / "images.mcap")
    read = read_mcap(tmp_path / "images.mcap")
    (cloud,) = [m for topic, _, m in read if topic == "/sonar/detections"]
    assert len(cloud_columns(cloud)["x"]) == len(e["echo_beam"])
    assert sum(topic == "/sonar/echoes" for topic, _, _ in read) == 1
    with pytest.raises(ValueError, match="sweep"):
        DatasetSpec(ROOM, scan="image", chirp=True)
    with pytest.raises(ValueError, match="scan"):
        DatasetSpec(ROOM, scan="sweep")


def test_sweeps_by_name_and_specs_written_with_a_boolean_chirp(tmp_path):
    """``chirp`` names the sweep: '20-80' needs the paper preset and its images keep points by
    the sub-band trust rule; specs written before it hold true or false, which read as '30-50'
    and None, so a folder of such a dataset resumes (its dataset.json's spec matches) and one of
    another spec is still refused."""
    from mitsonar.data.dataset import _normalised
    from mitsonar.signal.imaging_settings import WIDE_SWEEP_SETTINGS, ImagingSettings

    spec = DatasetSpec(ROOM, broadband=True, chirp=True, max_samples=1)
    assert spec.chirp == "30-50" and DatasetSpec(ROOM, chirp=False).chirp is None
    old = {**spec.to_json(), "chirp": True}
    assert DatasetSpec.from_json(old) == spec and _normalised(old) == spec.to_json()
    assert _normalised({**old, "broadband": False}) is None  # 30-50 kHz behind the TCT40 class
    assert _normalised({**old, "period": 2.0}) != spec.to_json()
    with pytest.raises(ValueError, match="20-80 kHz sweep needs"):
        DatasetSpec(ROOM, scan="image", chirp="20-80")
    with pytest.raises(ValueError, match="30-50, 20-80"):
        DatasetSpec(ROOM, scan="image", chirp="wide", sonar_preset="paper")
    wide = _Renderer(DatasetSpec(ROOM, scan="image", chirp="20-80", sonar_preset="paper",
                                 max_samples=1, image_width=16, spp=1))
    assert wide.imaging.imager.settings == WIDE_SWEEP_SETTINGS
    assert _Renderer(DatasetSpec(ROOM, scan="image", chirp="30-50", sonar_preset="paper",
                                 max_samples=1, image_width=16,
                                 spp=1)).imaging.imager.settings == ImagingSettings()


def test_shared_hits_samples_hold_the_shared_scan_and_old_specs_read_as_per_beam(tmp_path):
    """``shared_hits``: a sample's echoes are the scan with shared hits from its pose and seed,
    bit for bit (not the per-beam scan's); a spec written before the field reads as False, so
    its folder still resumes; with single-ping images it is refused."""
    from mitsonar.data.dataset import _derive_seed, _normalised
    from mitsonar.sensors.trajectory import sensor_poses

    spec = DatasetSpec(ROOM, period=2.0, scan_step=np.radians(30), image_width=16, spp=1,
                       max_samples=1, shared_hits=True)
    sample = open_dataset(render_dataset(spec, tmp_path / "shared"))[0]
    renderer = _Renderer(spec)
    sensor = sensor_poses(np.array([sample.pose["robot_pose_truth"]]))[0]
    seed = _derive_seed(spec.seed, "sample", 0)
    shared, per_beam = (renderer.sonar.scan(sensor, renderer.directions, seed=seed,
                                            shared_hits=s).echoes for s in (True, False))
    assert np.array_equal(sample.echoes["echoes"], shared)
    assert not np.array_equal(shared, per_beam)
    old = {key: value for key, value in SPEC.to_json().items() if key != "shared_hits"}
    assert DatasetSpec.from_json(old) == SPEC and _normalised(old) == SPEC.to_json()
    with pytest.raises(ValueError, match="shared_hits applies to the beam scan"):
        DatasetSpec(ROOM, scan="image", shared_hits=True)
