"""Fidelity levels: the knobs that trade simulation speed for accuracy, as named presets, and an
automatic choice that models no more than the scene needs.

Knobs: the ray grid (``rays_per_axis``), sub-ray refinement at silhouettes and curved surfaces
(``refine``; patches merged where range and footprint allow, ``max_merge``, are kept as the
base configuration sets them, and the reference level traces the fixed grid), visibility of
every receive element (``shadow_rays``), specular multipath (``max_bounces``), the recording's sample rate, complex baseband recordings and the spectral
floor of their band (``baseband``, ``band_floor``), merging of the transmit elements for
narrow-band signals (``narrowband_bandwidth``, see :class:`~mitsonar.sensors.sonar.SonarConfig`), and the
camera's samples per pixel. Presets, cheapest first:

========== ============= ====== ====== ======== ======== ========= ========== ======== ======
preset     rays_per_axis refine shadow bounces  sample   baseband  band floor merge    camera
                                rays            rate                          below    spp
========== ============= ====== ====== ======== ======== ========= ========== ======== ======
draft      16            1      no     1        160 kHz  auto      1e-3       5 kHz    4
standard   32            3      yes    1        200 kHz  auto      3e-4       5 kHz    16
fine       48            3      yes    1        400 kHz  no        1e-5       (exact)  64
multipath  48            3      yes    2        400 kHz  no        1e-5       (exact)  64
========== ============= ====== ====== ======== ======== ========= ========== ======== ======

("auto": complex baseband whenever the band is at most 0.35 x the sample rate wide, as it is
behind the resonant transducers.)

``standard`` is :class:`~mitsonar.sensors.sonar.SonarConfig`'s default. :func:`choose_fidelity` pings
sample beams of a scene at every preset up to a reference and returns the cheapest that is as
accurate against the scene's ground truth (its detected points as close to the true surfaces,
as many beams detected): converged, so more rays would not make it more accurate.
``experiments/speed_accuracy.py`` charts time against accuracy for each preset.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from mitsonar.sensors.sonar import Sonar, SonarConfig
from mitsonar.validation import check_positive


@dataclass(frozen=True)
class Fidelity:
    """One fidelity level (see the module docstring for the presets).

    Attributes:
        name: preset name.
        rays_per_axis: ray grid per beam is rays_per_axis^2.
        refine: sub-rays per axis at silhouettes and curved surfaces (1 disables).
        shadow_rays: test the visibility of every receive element from every hit.
        max_bounces: 1 (single scattering) or 2 (plus one specular bounce).
        sample_rate: sample rate of real recordings [Hz] (>= 4x the carrier).
        baseband: complex baseband recordings (None: when the band is narrow; see
            :class:`~mitsonar.sensors.sonar.SonarConfig`).
        band_floor: the recorded band keeps the echo spectrum down to this fraction of its peak.
        narrowband_bandwidth: merge transmit elements behind transducers up to this -6 dB
            bandwidth [Hz] (0: every element pair exactly).
        camera_spp: camera samples per pixel.
    """

    name: str
    rays_per_axis: int
    refine: int
    shadow_rays: bool
    max_bounces: int
    sample_rate: float
    baseband: bool | None
    band_floor: float
    narrowband_bandwidth: float
    camera_spp: int

    def apply(self, config: SonarConfig) -> SonarConfig:
        """``config`` with this level's trace settings and recording form; the per-sample noise
        is rescaled with the sample rate so that the noise spectral density stays the same."""
        trace = replace(config.trace, rays_per_axis=self.rays_per_axis, refine=self.refine,
                        shadow_rays=self.shadow_rays, max_bounces=self.max_bounces)
        noise = config.noise_rms * np.sqrt(self.sample_rate / config.sample_rate)
        return replace(config, trace=trace, sample_rate=self.sample_rate, noise_rms=noise,
                       baseband=self.baseband, band_floor=self.band_floor,
                       narrowband_bandwidth=self.narrowband_bandwidth)


PRESETS: dict[str, Fidelity] = {f.name: f for f in (
    Fidelity("draft", 16, 1, False, 1, 160e3, None, 1e-3, 5000.0, 4),
    Fidelity("standard", 32, 3, True, 1, 200e3, None, 3e-4, 5000.0, 16),
    Fidelity("fine", 48, 3, True, 1, 400e3, False, 1e-5, 0.0, 64),
    Fidelity("multipath", 48, 3, True, 2, 400e3, False, 1e-5, 0.0, 64),
)}


def fidelity(name: str) -> Fidelity:
    """The preset called ``name``."""
    if name not in PRESETS:
        raise ValueError(f"unknown fidelity preset {name!r}; choose one of {sorted(PRESETS)}")
    return PRESETS[name]


@dataclass(frozen=True)
class FidelityRun:
    """Beams pinged at one fidelity level.

    Attributes:
        fidelity: the level.
        depth: (B,) depth per beam [m], NaN where nothing was detected.
        seconds_per_ping: mean wall-clock time of one ping, end to end [s].
        surface_distance: (B,) distance of each beam's detected point to the nearest surface of
            the scene's ground-truth mesh [m], NaN where nothing was detected.
    """

    fidelity: Fidelity
    depth: np.ndarray
    seconds_per_ping: float
    surface_distance: np.ndarray

    @property
    def detected_fraction(self) -> float:
        """Fraction of beams with a detection."""
        return float(np.mean(np.isfinite(self.depth)))

    def surface_error(self) -> tuple[float, float]:
        """(median, 90th percentile) distance of the detected points to the true surfaces [m]
        (NaN, NaN without detections): the level's accuracy against the ground truth."""
        d = self.surface_distance[np.isfinite(self.surface_distance)]
        if len(d) == 0:
            return np.nan, np.nan
        return float(np.median(d)), float(np.percentile(d, 90))

    def depth_error(self, reference: "FidelityRun") -> tuple[float, float, float]:
        """(median |depth difference| [m] and 90th percentile over beams both detect, fraction of
        beams whose detection decision differs) against a reference run, beam by beam."""
        both = np.isfinite(self.depth) & np.isfinite(reference.depth)
        diff = np.abs(self.depth[both] - reference.depth[both])
        flips = float(np.mean(np.isfinite(self.depth) != np.isfinite(reference.depth)))
        if not both.any():
            return np.nan, np.nan, flips
        return float(np.median(diff)), float(np.percentile(diff, 90)), flips

    def agrees_with(self, reference: "FidelityRun", tolerance: float, max_flips: float) -> bool:
        """As accurate as ``reference`` against the ground truth: the median distance of the
        detected points to the true surfaces at most ``tolerance`` [m] above the reference's,
        and the fraction of beams detected within ``max_flips`` of the reference's."""
        if abs(self.detected_fraction - reference.detected_fraction) > max_flips:
            return False
        ours, theirs = self.surface_error()[0], reference.surface_error()[0]
        if np.isnan(theirs):  # the reference detects nothing: the fractions decide
            return True
        return bool(ours <= theirs + tolerance)


def ping_at(scene, config: SonarConfig, level: Fidelity, poses, directions, seed: int = 0,
            mesh=None) -> FidelityRun:
    """Scan the directions (B, 3) from every pose at one level (one :class:`Sonar` for all; the
    scene is loaded once by the caller) and measure the detected points against the scene's
    ground-truth ``mesh`` (default: :func:`~mitsonar.scene.mesh.scene_mesh` of it). Per-beam arrays
    are (len(poses) * B,), pose-major."""
    from mitsonar.evaluation.metrics import point_to_mesh
    from mitsonar.scene.mesh import scene_mesh

    sonar = Sonar(scene, level.apply(config))
    sonar.ping(poses[0], directions[0], seed=seed)  # compile the kernels outside the timing
    start = time.perf_counter()
    scans = [sonar.scan(pose, directions, seed=seed) for pose in poses]
    seconds = time.perf_counter() - start
    depth = np.concatenate([scan.depth for scan in scans])
    distance = np.full(len(depth), np.nan)
    distance[np.concatenate([scan.detected for scan in scans])] = point_to_mesh(
        np.concatenate([scan.points_world for scan in scans]),
        scene_mesh(sonar.scene) if mesh is None else mesh)[0]
    return FidelityRun(level, depth, seconds / len(depth), distance)


def choose_fidelity(scene, poses, directions, config: SonarConfig | None = None,
                    reference: str = "fine", depth_tolerance: float = 2e-3,
                    max_flips: float = 0.05, seed: int = 0):
    """The cheapest preset as accurate as ``reference`` on sample beams of this scene, judged
    against the scene's ground truth (:meth:`FidelityRun.agrees_with`): its detected points lie
    as close to the true surfaces (median distance within ``depth_tolerance`` of the
    reference's) and it detects as many beams (fractions within ``max_flips``). More rays, a
    higher rate or exact element pairs would not make the result more accurate.

    Not beam by beam: the diffuse echoes of different ray grids are different speckle
    realisations (the roughness phase is drawn per ray patch), which pick different reflectors
    within a beam; both are on the surfaces, so depths differ by centimetres beam by beam while
    the accuracy is the same (docs/performance.md, fidelity presets).

    Args:
        scene: a loaded :class:`~mitsonar.scene.loading.AcousticScene`.
        poses: sample world-from-sensor poses (e.g. a few along the trajectory).
        directions: (B, 3) sample beam directions.
        config: base configuration (default: :class:`SonarConfig`'s default).
        reference: the preset taken as converged (on the fixed ray grid, whatever the
            configuration's ``max_merge``).
        depth_tolerance: largest increase of the median distance to the true surfaces [m].
        max_flips: largest difference in the fraction of beams detected.
        seed: seeds the pings (the same at every level).

    Returns:
        (chosen :class:`Fidelity`, list of :class:`FidelityRun` from cheapest to the reference).
    """
    from mitsonar.scene.mesh import scene_mesh

    check_positive("depth_tolerance [m]", depth_tolerance)
    if not 0 <= max_flips < 1:
        raise ValueError(f"max_flips must be in [0, 1), got {max_flips}")
    config = config or SonarConfig()
    order = list(PRESETS)
    levels = [PRESETS[name] for name in order[: order.index(fidelity(reference).name) + 1]]
    mesh = scene_mesh(scene)
    # The reference traces the fixed grid: patches merged by range and footprint
    # (TraceSettings.max_merge) are judged against it, not taken as converged.
    fixed = replace(config, trace=replace(config.trace, max_merge=1))
    runs = [ping_at(scene, fixed if level is levels[-1] else config, level, poses, directions,
                    seed, mesh) for level in levels]
    for run in runs:
        if run.agrees_with(runs[-1], depth_tolerance, max_flips):
            return run.fidelity, runs
    return runs[-1].fidelity, runs
