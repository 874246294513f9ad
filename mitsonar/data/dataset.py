"""Paired camera-image + per-channel echo datasets along robot trajectories.

On disk (format version 1)::

    DIR/dataset.json           spec, calibration, times and poses of every sample
    DIR/samples/000042/        one sample, written to a temporary folder and renamed when whole
        rgb.exr, gray.exr      linear radiance (float32 EXR); rgb.png, gray.png: sRGB previews
        depth.exr              camera z-depth [m] (inf: nothing), float32 EXR
        shape_index.png        16-bit PNG: index+1 into dataset.json's shape_ids (0: nothing)
        echoes.npz             per-microphone echoes of the scan and its detections: every echo
                               of every beam with its attributes (the keys of ``mitsonar
                               scan``'s echoes.npz); with ``scan='image'`` one single-ping
                               receive image as a scan of one transmission (its recording,
                               every point of it a row of the echo table)
        pose.json              time, robot pose (ground truth and odometry), sensor poses
        manifest.json          size and SHA-256 of every file above, written last

Rendering a sample is a pure function of the spec and the sample index (seeds derive from
both), so samples can be rendered in any order, by any number of local processes or by Dask
workers, and give identical files. Finished samples are skipped when a render is resumed; an
interrupted sample leaves only a temporary folder, which the next render removes.

Dask (``dask.distributed``) is the distributed engine: pure Python, installed from PyPI with the
package, runs on a laptop as a ``LocalCluster`` and on clusters through its schedulers
(dask-jobqueue, SSH, Kubernetes) with the same code; Ray would add a large native runtime and
object store that this workload (independent, file-producing tasks) does not need.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass, field
from multiprocessing import get_context
from pathlib import Path

import numpy as np

from mitsonar.sensors.camera import CameraModel, CameraRenderer, srgb8
from mitsonar.sensors.imaging_sonar import ImagingSonar
from mitsonar.io import atomic_path
from mitsonar.physics.waveforms import SWEEPS
from mitsonar.sensors.sonar import Sonar, SonarConfig
from mitsonar.signal.detection import ECHO_MODES
from mitsonar.sensors.trajectory import OdometryDrift, Trajectory, sensor_poses
from mitsonar.validation import check_image_width, check_positive

FORMAT_VERSION = 1
#: What a sample's sonar records (``DatasetSpec.scan``).
SCANS = ("beams", "image")
_FILES = ("rgb.exr", "rgb.png", "gray.exr", "gray.png", "depth.exr", "shape_index.png",
          "echoes.npz", "pose.json")


class DatasetError(ValueError):
    """A dataset folder or one of its files is missing, corrupt or inconsistent."""


@dataclass(frozen=True)
class DatasetSpec:
    """What to render.

    Attributes:
        scene: path of the scene file.
        period: time between samples along the trajectory [s].
        scan_step: spacing of the beam grid over the field of view [rad].
        image_width: camera image width [pixels] (height and field of view follow the camera).
        spp: camera samples per pixel.
        seed: base seed of noise, diffuse phases, odometry drift and the renderer.
        max_samples: keep only the first samples (None: all).
        trajectory: waypoints (K, 3) [m, m, rad]; None takes the scene's default trajectory.
        speed: [m/s] and yaw_rate [rad/s] with an explicit trajectory.
        odometry: odometry drift model.
        sonar_preset: 'default' or 'paper'.
        echoes: which echoes of each beam ``echoes.npz`` records in its echo table, with their
            attributes (``DetectionSettings.echoes``: 'first', 'all', 'cells' or 'image').
        scan: 'beams' (the beam grid over the field of view, ``scan_step``, ``echoes``) or
            'image' (one single-ping receive image per sample, :meth:`ImagingSonar.scan
            <mitsonar.sensors.imaging_sonar.ImagingSonar.scan>`).
        broadband: broadband transducers (20 kHz at -6 dB) instead of the 2 kHz TCT40 class.
        chirp: drive a frequency sweep instead of the tone burst (``SonarConfig.with_drive``):
            '30-50' kHz (needs ``broadband`` or the 'paper' preset) or '20-80' (needs 'paper';
            its images keep points by the sub-band trust rule,
            :func:`~mitsonar.signal.imaging_settings.imaging_settings_for`); None: the burst.
            (True and False, as specs written before the 20-80 kHz sweep hold, read as '30-50'
            and None.)
        shared_hits: the beam scan's beams share one trace and one gridding of the element
            pairs (:meth:`Sonar.scan <mitsonar.sensors.sonar.Sonar.scan>`: each beam carries its
            transmit side lobes); False: each beam in its own cone. (Specs written before it
            read as False.)
    """

    scene: str
    period: float = 1.0
    scan_step: float = np.radians(10.0)
    image_width: int = 400
    spp: int = 16
    seed: int = 0
    max_samples: int | None = None
    trajectory: tuple | None = None
    speed: float = 0.2
    yaw_rate: float = np.radians(30.0)
    odometry: OdometryDrift = field(default_factory=OdometryDrift)
    sonar_preset: str = "default"
    echoes: str = "all"
    scan: str = "beams"
    broadband: bool = False
    chirp: str | None = None
    shared_hits: bool = False

    def __post_init__(self):
        check_positive("DatasetSpec.period [s]", self.period)
        check_positive("DatasetSpec.scan_step [rad]", self.scan_step)
        check_image_width("DatasetSpec.image_width", self.image_width)
        if self.max_samples is not None and self.max_samples < 1:
            raise ValueError(f"DatasetSpec.max_samples must be >= 1, got {self.max_samples}")
        if self.echoes not in ECHO_MODES:
            raise ValueError(f"DatasetSpec.echoes must be one of {', '.join(ECHO_MODES)}, "
                             f"got {self.echoes!r}")
        if self.scan not in SCANS:
            raise ValueError(f"DatasetSpec.scan must be one of {', '.join(SCANS)}, "
                             f"got {self.scan!r}")
        if self.shared_hits and self.scan != "beams":
            raise ValueError(f"DatasetSpec.shared_hits applies to the beam scan (scan='beams'), "
                             f"not to scan={self.scan!r}")
        if isinstance(self.chirp, bool):
            object.__setattr__(self, "chirp", "30-50" if self.chirp else None)
        if self.chirp is not None and self.chirp not in SWEEPS:
            raise ValueError(f"DatasetSpec.chirp must be None or one of {', '.join(SWEEPS)}, "
                             f"got {self.chirp!r}")
        self.sonar_config()  # a sweep the transducers cannot pass is refused here
        if self.trajectory is not None:
            object.__setattr__(self, "trajectory", tuple(map(tuple, np.asarray(self.trajectory, float))))

    def to_json(self) -> dict:
        data = asdict(self)
        data["odometry"] = asdict(self.odometry)
        return data

    @classmethod
    def from_json(cls, data: dict) -> "DatasetSpec":
        data = dict(data)
        data["odometry"] = OdometryDrift(**data["odometry"])
        return cls(**data)

    def sonar_config(self) -> SonarConfig:
        """The sonar's configuration: ``sonar_preset``, ``broadband``, ``chirp``, recording
        ``echoes``."""
        return SonarConfig.preset(self.sonar_preset).with_drive(
            self.broadband, self.chirp).with_detection(echoes=self.echoes)

    def build_trajectory(self) -> Trajectory:
        if self.trajectory is None:
            return Trajectory.from_scene(self.scene)
        return Trajectory(np.array(self.trajectory), self.speed, self.yaw_rate)

    def timeline(self):
        """Times (T,), ground-truth robot poses (T, 3) and odometry robot poses (T, 3)."""
        times, truth = self.build_trajectory().sample(self.period)
        if self.max_samples is not None:
            times, truth = times[: self.max_samples], truth[: self.max_samples]
        odometry = self.odometry.apply(truth, seed=_derive_seed(self.seed, "odometry"))
        return times, truth, odometry


def _normalised(spec_json) -> dict | None:
    """A dataset.json's spec as this version writes it (e.g. ``chirp`` true -> '30-50'); None
    where it is not a spec this version reads."""
    try:
        return DatasetSpec.from_json(spec_json).to_json()
    except (TypeError, ValueError, KeyError, AttributeError):
        return None


def _derive_seed(seed: int, *parts) -> int:
    text = "/".join(str(p) for p in (seed,) + parts).encode()
    return int.from_bytes(hashlib.sha256(text).digest()[:4], "little")


class _Renderer:
    """Scene, sonar and camera of one spec, loaded once per process."""

    def __init__(self, spec: DatasetSpec):
        self.spec = spec
        self.sonar = Sonar(spec.scene, spec.sonar_config())
        self.camera = CameraRenderer(self.sonar.scene,
                                     CameraModel(spp=spec.spp).at_resolution(spec.image_width))
        self.times, self.truth, self.odometry = spec.timeline()
        self.directions = self.sonar.fov_grid(spec.scan_step)
        self.imaging = ImagingSonar(self.sonar) if spec.scan == "image" else None

    def render(self, out: Path, index: int) -> None:
        """Write sample ``index`` into ``out/samples`` atomically."""
        final = out / "samples" / f"{index:06d}"
        if (final / "manifest.json").exists():
            return
        mi = self.sonar.tracer.mi
        pose = sensor_poses(self.truth[index: index + 1])[0]
        seed = _derive_seed(self.spec.seed, "sample", index)
        images = self.camera.render(pose, seed=seed)
        scan = self.sonar.scan(pose, self.directions, seed=seed,
                               shared_hits=self.spec.shared_hits) if self.imaging is None \
            else self.imaging.scan(pose, seed=seed)
        tmp = Path(tempfile.mkdtemp(dir=out / "samples", prefix=f".{index:06d}."))
        try:
            mi.Bitmap(images.rgb).write(str(tmp / "rgb.exr"))
            mi.Bitmap(images.gray[..., None]).write(str(tmp / "gray.exr"))
            mi.Bitmap(images.depth[..., None]).write(str(tmp / "depth.exr"))
            _write_png(tmp / "rgb.png", images.rgb)
            _write_png(tmp / "gray.png", images.gray)
            import cv2

            cv2.imwrite(str(tmp / "shape_index.png"), (images.shape_index + 1).astype(np.uint16))
            with open(tmp / "echoes.npz", "wb") as f:
                np.savez_compressed(f, **scan.arrays())
            odom = sensor_poses(self.odometry[index: index + 1])[0]
            (tmp / "pose.json").write_text(json.dumps({
                "index": index, "time_s": float(self.times[index]),
                "robot_pose_truth": self.truth[index].tolist(),
                "robot_pose_odometry": self.odometry[index].tolist(),
                "world_from_sensor_truth": pose.matrix().tolist(),
                "world_from_sensor_odometry": odom.matrix().tolist()}, indent=1))
            manifest = {name: {"bytes": (tmp / name).stat().st_size, "sha256": _sha256(tmp / name)}
                        for name in _FILES}
            (tmp / "manifest.json").write_text(json.dumps(manifest, indent=1))
            os.chmod(tmp, 0o755)
            os.replace(tmp, final)
        finally:
            if tmp.exists():
                shutil.rmtree(tmp)


def _write_png(path: Path, linear) -> None:
    import cv2

    img = srgb8(linear)
    cv2.imwrite(str(path), img[..., ::-1] if img.ndim == 3 else img)


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


_WORKER: dict = {}


def _renderer(spec_json: dict) -> "_Renderer":
    """This process's renderer for a spec, loaded once and reused."""
    key = json.dumps(spec_json, sort_keys=True)
    if key not in _WORKER:
        _WORKER.clear()
        _WORKER[key] = _Renderer(DatasetSpec.from_json(spec_json))
    return _WORKER[key]


def _worker_render(spec_json: dict, out: str, index: int) -> int:
    """Task run in a worker process (local pool or Dask): render one sample, reuse the loads."""
    _renderer(spec_json).render(Path(out), index)
    return index


def _metadata(spec: DatasetSpec, renderer: "_Renderer | None" = None) -> dict:
    times, truth, odometry = spec.timeline()
    cfg = spec.sonar_config()
    cam = CameraModel(spp=spec.spp).at_resolution(spec.image_width)
    g = cfg.geometry
    from mitsonar.frames import Pose
    from mitsonar.scene.loading import load_scene

    shape_ids = renderer.sonar.scene.shape_ids if renderer else load_scene(spec.scene).shape_ids
    return {
        "format_version": FORMAT_VERSION, "spec": spec.to_json(), "samples": len(times),
        "times_s": times.tolist(), "robot_poses_truth": truth.tolist(),
        "robot_poses_odometry": odometry.tolist(), "shape_ids": list(shape_ids),
        "calibration": {
            "camera_intrinsics_px": cam.intrinsics().tolist(), "image_size": [cam.width, cam.height],
            "camera_from_sensor": cam.camera_from_sensor().matrix().tolist(),
            "robot_from_sensor": Pose.sensor_mount().matrix().tolist(),
            "tx_positions_m": g.tx_positions.tolist(), "rx_positions_m": g.rx_positions.tolist(),
            "baseline_m": g.baseline, "sample_rate_hz": cfg.sample_rate,
            "speed_of_sound_m_s": cfg.medium.speed_of_sound,
            "medium": asdict(cfg.medium), "pulse": asdict(cfg.pulse)},
    }


def render_dataset(spec: DatasetSpec, out, workers: int = 1, scheduler: str | None = None,
                   progress=None) -> Path:
    """Render (or resume) a dataset into ``out``; returns its path.

    Args:
        spec: what to render.
        out: output folder (created; an existing dataset of the same spec is resumed).
        workers: local worker processes (1: in this process).
        scheduler: address of a Dask scheduler, or 'local' for a Dask LocalCluster with
            ``workers`` processes; None uses a local process pool.
        progress: called with the index of every finished sample.
    """
    out = Path(out)
    (out / "samples").mkdir(parents=True, exist_ok=True)
    spec_json = spec.to_json()
    local = scheduler is None and workers <= 1  # then this process renders: load the scene once
    meta = _metadata(spec, _renderer(spec_json) if local else None)
    meta_path = out / "dataset.json"
    if meta_path.exists():
        old = json.loads(meta_path.read_text())
        if _normalised(old.get("spec")) != meta["spec"]:
            raise DatasetError(f"{out}: holds a dataset of another spec; choose another folder")
    else:
        with atomic_path(meta_path) as tmp:
            tmp.write_text(json.dumps(meta, indent=1))
    for stale in (out / "samples").glob(".*"):  # folders of samples interrupted mid-write
        shutil.rmtree(stale, ignore_errors=True)
    todo = [i for i in range(meta["samples"])
            if not (out / "samples" / f"{i:06d}" / "manifest.json").exists()]
    notify = progress or (lambda _: None)
    if scheduler is not None:
        from dask.distributed import Client, LocalCluster, as_completed

        environment = dict(os.environ)  # Dask's nannies write their workers' variables
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None) if scheduler == "local" else None
        try:
            with Client(cluster if cluster is not None else scheduler) as client:
                futures = client.map(_worker_render, [spec_json] * len(todo), [str(out)] * len(todo),
                                     todo, pure=False)
                for future in as_completed(futures):
                    notify(future.result())
        finally:
            if cluster is not None:
                cluster.close()
            _restore_environment(environment)
    elif workers > 1:
        with ProcessPoolExecutor(workers, mp_context=get_context("spawn")) as pool:
            for index in pool.map(_worker_render, [spec_json] * len(todo), [str(out)] * len(todo), todo):
                notify(index)
    else:
        for index in todo:
            notify(_worker_render(spec_json, str(out), index))
    return out


def _restore_environment(environment: dict) -> None:
    """Put ``os.environ`` back to ``environment``. A Dask nanny sets its workers' variables
    (``OMP_NUM_THREADS=1``, ``MALLOC_TRIM_THRESHOLD_=65536``, ...) in the calling process's
    environment and leaves them there, so every process started later would inherit them: one
    thread per library and glibc returning memory to the system at every free (a benchmark run
    after a Dask render took 1.8x as long, most of it system time)."""
    for name in set(os.environ) - set(environment):
        del os.environ[name]
    os.environ.update(environment)


@dataclass(frozen=True)
class Sample:
    """One sample of a dataset (see the module docstring for the files)."""

    index: int
    rgb: np.ndarray
    gray: np.ndarray
    depth: np.ndarray
    shape_index: np.ndarray
    echoes: dict
    pose: dict


class Dataset:
    """A rendered dataset folder: ``len(ds)``, ``ds[i]`` -> :class:`Sample`, ``ds.meta``."""

    def __init__(self, path):
        self.path = Path(path)
        meta_path = self.path / "dataset.json"
        try:
            self.meta = json.loads(meta_path.read_text())
        except (OSError, ValueError) as err:
            raise DatasetError(f"{meta_path}: cannot read the dataset description ({err})") from None
        if self.meta.get("format_version") != FORMAT_VERSION:
            raise DatasetError(f"{meta_path}: format version {self.meta.get('format_version')}, "
                               f"expected {FORMAT_VERSION}")

    def __len__(self) -> int:
        return int(self.meta["samples"])

    def complete(self) -> bool:
        """True when every sample has been written."""
        return all((self.path / "samples" / f"{i:06d}" / "manifest.json").exists() for i in range(len(self)))

    def __getitem__(self, index: int) -> Sample:
        if not 0 <= index < len(self):
            raise IndexError(f"sample {index} outside 0..{len(self) - 1}")
        folder = self.path / "samples" / f"{index:06d}"
        try:
            manifest = json.loads((folder / "manifest.json").read_text())
        except (OSError, ValueError):
            raise DatasetError(f"{folder}: sample {index} is missing or unfinished") from None
        for name, entry in manifest.items():
            file = folder / name
            if not file.exists() or file.stat().st_size != entry["bytes"] or _sha256(file) != entry["sha256"]:
                raise DatasetError(f"{file}: truncated or corrupt (does not match manifest.json)")
        from mitsonar.scene.loading import mitsuba

        mi = mitsuba()
        import cv2

        with np.load(folder / "echoes.npz") as data:
            echoes = {k: data[k] for k in data.files}
        return Sample(index=index,
                      rgb=np.array(mi.Bitmap(str(folder / "rgb.exr"))),
                      gray=np.array(mi.Bitmap(str(folder / "gray.exr"))),
                      depth=np.array(mi.Bitmap(str(folder / "depth.exr"))),
                      shape_index=cv2.imread(str(folder / "shape_index.png"),
                                             cv2.IMREAD_UNCHANGED).astype(np.int32) - 1,
                      echoes=echoes, pose=json.loads((folder / "pose.json").read_text()))


def open_dataset(path) -> Dataset:
    """Open a rendered dataset folder."""
    return Dataset(path)
