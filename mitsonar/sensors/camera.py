"""Monocular camera beside the array: pinhole model, equations (10)(11), and Mitsuba rendering.

Camera: MER2-202-60GM/C class, 1600 x 1200 pixels of 4.5 um (7.2 mm x 5.4 mm sensor), with a
6 mm lens chosen so the image covers the array's 60 x 40 deg field of view (horizontal 61.9 deg,
vertical 48.5 deg). The optical centre sits 7.5 cm above the array origin; its axes are the
sensor's (x right, y down, z forward), so the camera-from-sensor extrinsic is a pure translation.
Pixel (i, j) covers u in [i, i+1), v in [j, j+1); the principal point is the image centre.

Rendering uses the same loaded ``mi.Scene`` as the sonar, path traced (``CameraModel.max_depth``)
or, where the scene's own integrator is Mitsuba's ``direct`` (the ``key`` look of
:mod:`mitsonar.scene.building.lights`, like the paper's rasterised Gazebo worlds), with direct
light only (Mitsuba's ``volpath`` to depth 2: passing through glass is no bounce there, so what
stands behind a glass partition is lit as what stands in front of it). Images are rendered in
passes of a power-of-two number of samples per pixel (``render``), averaged in a fixed order, so
a seed gives bit-identical images however many threads render them. A renderer keeps one Mitsuba
camera, moved to each pose through its parameters, and renders a pass by a frozen function
(``drjit.freeze``): the first calls trace Mitsuba's renderer into kernels, later ones replay
them with the new pose and seed, bit for bit the image a plain ``mi.render`` gives. Tracing the
renderer costs ~0.4 s a call on a furnished scene, more than rendering a 320 px image.

The Monte Carlo noise of a path tracer at a few samples per pixel is a rendering artefact, not
camera noise: at 32 spp a lit drywall room shows 15-20 grey levels of it (of 255), more than the
5-15 levels between two walls at a crease, and the line detector loses those creases. By default
the image is therefore denoised with Intel Open Image Denoise (OIDN, the ``RT`` filter, as in
Blender and other production renderers), guided by the albedo and shading-normal images
rendered from the same samples; at 8 spp that leaves under 1 grey level of noise and keeps
creases and shadow edges sharp. ``CameraModel(denoise=False)`` keeps the raw estimate.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from mitsonar.frames import Pose
from mitsonar.jit import count_registry_changes, freeze, registry_changes
from mitsonar.scene.building.lights import direct_light_integrator
from mitsonar.scene.loading import AcousticScene, mitsuba
from mitsonar.validation import check_positive, check_positive_integer

#: Rec. 709 luminance weights for grayscale images from linear RGB.
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


@dataclass(frozen=True)
class CameraModel:
    """Pinhole camera.

    Attributes:
        width, height: image size [pixels].
        pixel_pitch: pixel size [m] (scaled with the resolution so the field of view is kept).
        focal_length: lens focal length [m].
        offset: (3,) optical centre in the sensor frame [m].
        spp: samples per pixel of the path tracer.
        max_depth: path length limit of the path tracer (not used in scenes that ask for
            Mitsuba's ``direct`` integrator: direct light only).
        denoise: denoise the rendered image with OIDN guided by albedo and normals (module
            docstring); False: the raw Monte Carlo estimate.
        frame_rate: frames per second [Hz] while the robot drives (25, DESIGN.md's camera).
    """

    width: int = 1600
    height: int = 1200
    pixel_pitch: float = 4.5e-6
    focal_length: float = 6.0e-3
    offset: np.ndarray = field(default_factory=lambda: np.array([0.0, -0.075, 0.0]))
    spp: int = 16
    max_depth: int = 6
    denoise: bool = True
    frame_rate: float = 25.0

    def __post_init__(self):
        for name in ("width", "height", "spp", "max_depth"):
            check_positive_integer(f"CameraModel.{name}", getattr(self, name))
        check_positive("CameraModel.pixel_pitch [m]", self.pixel_pitch)
        check_positive("CameraModel.focal_length [m]", self.focal_length)
        check_positive("CameraModel.frame_rate [Hz]", self.frame_rate)
        object.__setattr__(self, "offset", np.asarray(self.offset, dtype=float))

    def at_resolution(self, width: int) -> "CameraModel":
        """The same camera and field of view at a lower (or higher) resolution."""
        scale = self.width / width
        return replace(self, width=int(width), height=int(round(self.height / scale)),
                       pixel_pitch=self.pixel_pitch * scale)

    @property
    def focal_pixels(self) -> float:
        """Focal length f in pixels, as in (10)."""
        return self.focal_length / self.pixel_pitch

    @property
    def principal_point(self) -> tuple[float, float]:
        """(u_c, v_c) [pixels]: the image centre."""
        return self.width / 2.0, self.height / 2.0

    @property
    def horizontal_fov(self) -> float:
        """Full horizontal field of view [rad]."""
        return 2.0 * np.arctan(self.width / 2.0 / self.focal_pixels)

    def intrinsics(self) -> np.ndarray:
        """3x3 matrix K (pixels)."""
        uc, vc = self.principal_point
        f = self.focal_pixels
        return np.array([[f, 0.0, uc], [0.0, f, vc], [0.0, 0.0, 1.0]])

    def camera_from_sensor(self) -> Pose:
        """Extrinsic: maps sensor-frame points to the camera frame."""
        return Pose(np.eye(3), -self.offset)

    def world_from_camera(self, sensor_pose: Pose) -> Pose:
        """Camera pose in the world from the world-from-sensor pose."""
        return sensor_pose @ self.camera_from_sensor().inverse()

    def project(self, points_camera) -> np.ndarray:
        """Pixel coordinates (..., 2) of camera-frame points (..., 3) (z > 0)."""
        p = np.asarray(points_camera, dtype=float)
        f = self.focal_pixels
        uc, vc = self.principal_point
        return np.stack([uc + f * p[..., 0] / p[..., 2], vc + f * p[..., 1] / p[..., 2]], axis=-1)

    def pixel_angles(self, u, v) -> tuple[np.ndarray, np.ndarray]:
        """Equations (10)(11): (theta, phi) [rad] of pixel coordinates; phi in [0, 2 pi)."""
        uc, vc = self.principal_point
        du, dv = np.asarray(u, dtype=float) - uc, np.asarray(v, dtype=float) - vc
        theta = np.arctan2(np.hypot(du, dv), self.focal_pixels)
        return theta, np.mod(np.arctan2(dv, du), 2 * np.pi)

    def pixel_rays(self):
        """Unit directions (H, W, 3), camera frame, through every pixel centre."""
        u = np.arange(self.width) + 0.5
        v = np.arange(self.height) + 0.5
        uu, vv = np.meshgrid(u, v)
        uc, vc = self.principal_point
        d = np.stack([(uu - uc) / self.focal_pixels, (vv - vc) / self.focal_pixels,
                      np.ones_like(uu)], axis=-1)
        return d / np.linalg.norm(d, axis=-1, keepdims=True)


def srgb8(linear) -> np.ndarray:
    """8-bit sRGB (uint8, same shape) of linear values in [0, 1] (clipped): the images' PNG
    previews and recordings."""
    srgb = np.where(linear <= 0.0031308, 12.92 * linear,
                    1.055 * np.power(np.maximum(linear, 0), 1 / 2.4) - 0.055)
    return np.clip(np.round(srgb * 255), 0, 255).astype(np.uint8)


def denoise(rgb, albedo, normal) -> np.ndarray:
    """OIDN-denoised (H, W, 3) float32 linear radiance from the Monte Carlo estimate ``rgb``,
    guided by the albedo (H, W, 3) in [0, 1] and shading normals (H, W, 3) in [-1, 1] averaged
    over the same samples (noisy at their edges; OIDN prefilters them)."""
    import pyoidn

    def contiguous(a):
        return np.ascontiguousarray(a, dtype=np.float32)

    return pyoidn.denoise(contiguous(rgb), contiguous(albedo), contiguous(normal), hdr=True)


@dataclass(frozen=True)
class CameraImages:
    """What the camera sees from one pose.

    Attributes:
        rgb: (H, W, 3) linear radiance (float32).
        gray: (H, W) linear luminance (float32).
        depth: (H, W) z-depth of the first surface in the camera frame [m], inf where none.
        shape_index: (H, W) index of the shape seen (into ``AcousticScene.shape_ids``), -1 none.
    """

    rgb: np.ndarray
    gray: np.ndarray
    depth: np.ndarray
    shape_index: np.ndarray


class CameraRenderer:
    """Renders a :class:`CameraModel` in a loaded scene; reuse it for every pose.

    Args:
        scene: the loaded scene.
        model: the camera.
        frozen: render by a frozen pass, recorded once and replayed (module docstring); False:
            Mitsuba's plain render at every call (the same images, each call traced anew).
    """

    def __init__(self, scene: AcousticScene, model: CameraModel = CameraModel(),
                 frozen: bool = True):
        self.mi = mitsuba()
        self.scene = scene
        self.model = model
        path = direct_light_integrator(scene.scene) or {"type": "path",
                                                        "max_depth": model.max_depth}
        # the aov integrator adds albedo (3 channels) and shading normals (3) after the RGB
        self._integrator = self.mi.load_dict(
            {"type": "aov", "aovs": "albedo:albedo,nn:sh_normal", "integrator": path}
            if model.denoise else path)
        # One sensor, moved to each pose through its parameters, and one frozen render pass
        # (module docstring): the same objects every call, so the recorded kernels replay.
        self._camera = self.mi.load_dict(self._sensor_dict())
        self._camera_parameters = self.mi.traverse(self._camera)
        import drjit as dr

        #: Samples per pixel of a pass: the largest power of two dividing spp (:meth:`render`).
        self._chunk = model.spp & -model.spp
        # Recorded anew for another thread count: a recording made on one thread and replayed
        # on several crashes Dr.Jit 1.5. The pass holds no reference to the renderer (no cycle:
        # both are freed as soon as the renderer is dropped, not by a later garbage collection).
        mi, chunk = self.mi, self._chunk
        self._pass = freeze(lambda scene, sensor, integrator, seed: mi.render(
            scene, sensor=sensor, integrator=integrator, spp=chunk, seed=seed),
            state_fn=lambda *_: (dr.thread_count(),)) if frozen else None
        count_registry_changes(self)  # its camera and integrator
        self._registry = None  # registry_changes() when the pass was recorded

    def _sensor_dict(self) -> dict:
        """Mitsuba description of the camera (its pose is set by :meth:`render`)."""
        m = self.model
        return {"type": "perspective", "fov": float(np.degrees(m.horizontal_fov)),
                "fov_axis": "x", "near_clip": 0.01, "far_clip": 1000.0,
                "film": {"type": "hdrfilm", "width": m.width, "height": m.height,
                         "rfilter": {"type": "box"}, "pixel_format": "rgb"},
                "sampler": {"type": "independent", "sample_count": 1}}

    def _to_world(self, camera_pose: Pose):
        """Mitsuba's to_world transform of the camera at ``camera_pose`` (x right, y down)."""
        origin = camera_pose.translation
        forward = camera_pose.transform_vectors([0.0, 0.0, 1.0])
        up = camera_pose.transform_vectors([0.0, -1.0, 0.0])
        return self.mi.ScalarTransform4f().look_at(origin=origin.tolist(),
                                                   target=(origin + forward).tolist(),
                                                   up=up.tolist())

    def render(self, sensor_pose: Pose, seed: int = 0) -> CameraImages:
        """Images from the camera of a sensor head at ``sensor_pose`` (world-from-sensor)."""
        import drjit as dr

        camera_pose = self.model.world_from_camera(sensor_pose)
        self._camera_parameters["to_world"] = self._to_world(camera_pose)
        self._camera_parameters.update()
        base = int(np.random.SeedSequence(seed).generate_state(1)[0] % (2**31))
        channels = 9 if self.model.denoise else 3
        total = np.zeros((self.model.height, self.model.width, channels))
        # Passes of `_chunk` samples per pixel, summed in order. A pixel's samples are adjacent
        # in Mitsuba's wavefront and Dr.Jit's CPU threads take blocks of a power-of-two size:
        # with a power-of-two chunk each pixel is summed by one thread, so the image does not
        # depend on the threads (12 samples in one pass: ~40 pixels of a 320 px image differ
        # between thread counts).
        for k in range(self.model.spp // self._chunk):
            img = self._render_pass(dr.opaque(self.mi.UInt32, base + k))
            total += self._chunk * np.asarray(img, dtype=float)[..., :channels]
        mean = (total / self.model.spp).astype(np.float32)
        rgb = denoise(mean[..., :3], mean[..., 3:6], mean[..., 6:9]) if self.model.denoise \
            else np.ascontiguousarray(mean[..., :3])
        depth, shape_index = self.ground_truth(camera_pose)
        return CameraImages(rgb, (rgb @ LUMINANCE).astype(np.float32), depth, shape_index)

    def _render_pass(self, seed):
        """One pass of the camera as it stands (the frozen one where Dr.Jit can record the
        scene; a scene with nested virtual calls, e.g. an emitter whose radiance is a texture,
        cannot be recorded and is rendered plainly from then on, the same image)."""
        if self._pass is not None:
            if self._registry != registry_changes():  # objects the recording reaches changed
                self._pass.frozen.clear()
                self._registry = registry_changes()
            try:
                return self._pass(self.scene.scene, self._camera, self._integrator, seed)
            except RuntimeError as err:
                if "frozen function" not in str(err):
                    raise
                self._pass = None
        return self.mi.render(self.scene.scene, sensor=self._camera, integrator=self._integrator,
                              spp=self._chunk, seed=seed)

    def ground_truth(self, camera_pose: Pose):
        """Z-depth [m] (inf: nothing) and shape index (-1: nothing) per pixel, (H, W) each."""
        d_cam = self.model.pixel_rays()
        d = camera_pose.transform_vectors(d_cam).reshape(-1, 3)
        t, _, _, index = self.scene.hits.first(np.broadcast_to(camera_pose.translation, d.shape), d)
        shape = (self.model.height, self.model.width)
        depth = (t.reshape(shape) * d_cam[..., 2]).astype(np.float32)
        return depth, index.reshape(shape).astype(np.int32)
