"""Acoustic ray tracing on Dr.Jit's LLVM backend: from a steered beam to acoustic paths.

For one beam direction u (sensor frame):

1. Rays leave the transmit origin on a grid over a cone of half-angle ``cone_half_angle`` around
   u. The grid is regular in a warped tangent-plane coordinate whose density follows the
   transmit beam (dense in the main lobe, ``importance_floor`` of that outside), so each ray owns
   an exactly known cell of solid angle: deterministic importance sampling, no Monte-Carlo noise.
   A wide transmission (``ray_density='uniform'``) takes cells of equal angle along both axes.
2. ``scene.ray_intersect`` finds the reflector of every ray (acoustically transparent surfaces are
   stepped through). Each hit is a surface patch: the ray's cell projected on the local tangent
   plane (from analytic ray differentials), with the material of the shape hit.
3. The incident field on the patch is the coherent sum of the 25 transmit elements, each with its
   steering delay t_i^D, phase phi_i, piston directivity, spherical spreading and air absorption
   (and amplitude weight: ``transmit_weights``, e.g. one element alone, or the whole array traced
   towards broadside, where every steering delay is 0: unsteered).
4. Re-radiation to every receive element (visibility by shadow rays):
   * specular part, physical optics (Kirchhoff) over the patch: j k / (4 pi) r(theta)
     (cos theta_i + cos theta_o) times the patch integral of the linear phase, A sinc sinc, times
     sqrt(1 - s). Summed over patches this reproduces the image-source echo of a flat wall and
     the weak return of a tilted one.
   * diffuse part, Lambert: |r| sqrt(s A cos theta_i cos theta_o / pi), with a random phase per
     patch (surface roughness, constant over the pulse's narrow band) drawn from the ping's seed.
   Contributions fade to zero over the outer ``taper`` of the cone, so the cone's edge radiates
   no artificial edge wave.
5. ``max_bounces=2`` adds specular multipath: specular rays continue once, and the second patch is
   lit by the transmit array mirrored in the first surface (image unfolding, exact for planes).

The paper's model (``model='paper'``) instead takes 5 x 5 point reflectors 1.25 deg apart around
the beam with amplitude alpha beta R (1)(3): alpha the receive aperture's solid angle over 2 pi,
beta ``paper_beta``, R the energy coefficient (4); no air absorption unless asked for.

After the intersections, per-hit geometry is NumPy and the per (hit, element) factors one Dr.Jit
kernel (:mod:`~mitsonar.trace.element_factors`), kept factored per transmit and receive element
(:class:`~mitsonar.trace.hitpaths.HitPaths`); no Python loop runs over rays, paths or samples.
:meth:`AcousticTracer.trace_many` runs every step once for the hits of a batch of beams (each with
its own pose and seed), which pays the per-call costs once.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import drjit as dr
import numpy as np
from scipy.ndimage import binary_dilation

from mitsonar.physics.array import APERTURE, ArrayGeometry
from mitsonar.frames import Pose, orthonormal_basis
from mitsonar.trace.element_factors import element_factors
from mitsonar.trace.hitpaths import HitPaths
from mitsonar.jit import backend, to_jit
from mitsonar.scene.rays import rays
from mitsonar.physics.medium import Medium
from mitsonar.scene.loading import AcousticScene, mitsuba
from mitsonar.physics.waveforms import Pulse
from mitsonar.trace.paths import Paths
from mitsonar.physics.transducer import Transducer
from mitsonar.validation import check_finite, check_positive, check_range

#: Offset of secondary ray origins from a surface [m].
_EPS = 1e-4
#: Acoustically transparent layers a ray may step through.
_MAX_TRANSPARENT_LAYERS = 8


@dataclass(frozen=True)
class TraceSettings:
    """Fidelity and model choices of the acoustic trace.

    Attributes:
        model: 'physical' (physical optics + Lambert) or 'paper' (25 point reflectors).
        rays_per_axis: the ray grid is rays_per_axis^2 over the square around the cone.
        cone_half_angle: half-angle of the traced cone around the beam [rad].
        taper: outer fraction of the cone radius over which contributions fade to 0.
        main_lobe_width: 3 dB width that shapes the ray density [rad].
        importance_floor: ray density outside the main lobe relative to its centre, in (0, 1].
        ray_density: 'beam' (shaped by the two settings above) or 'uniform' (cells of equal
            angle along both tangent axes, for wide transmissions).
        transmit_weights: amplitude weight of each transmit element, (N_tx,) (None: all 1);
            elements of weight 0 stay silent and are left out of the paths.
        refine: cells at silhouettes, material changes, depth jumps or curved surfaces (normals of
            neighbouring cells differing by more than ``refine_normal_angle``) are split into
            refine x refine sub-rays (1 disables refinement).
        refine_normal_angle: normal difference between neighbouring cells that triggers
            refinement [rad].
        refine_radius: only cells within this angle of the beam axis are refined [rad] (further
            out the two-way beam is in its side lobes).
        max_bounces: 1 (single scattering) or 2 (plus one specular bounce before).
        shadow_rays: test the visibility of every receive element from every hit.
        air_absorption: apply ISO 9613-1 absorption along the paths.
        crosstalk_gain: factor on the direct transmitter -> receiver paths (0 disables them).
        paper_spacing: reflector spacing of the paper model [rad].
        paper_grid: reflectors per axis of the paper model.
        paper_beta: the paper's beta (scattered energy fraction).
    """

    model: str = "physical"
    rays_per_axis: int = 32
    cone_half_angle: float = np.radians(20.0)
    taper: float = 0.3
    main_lobe_width: float = np.radians(5.0)
    importance_floor: float = 0.2
    refine: int = 3
    refine_normal_angle: float = np.radians(10.0)
    refine_radius: float = np.radians(6.0)
    max_bounces: int = 1
    shadow_rays: bool = True
    air_absorption: bool = True
    crosstalk_gain: float = 1.0
    paper_spacing: float = np.radians(1.25)
    paper_grid: int = 5
    paper_beta: float = 1.0
    ray_density: str = "beam"
    transmit_weights: tuple | None = None

    def __post_init__(self):
        if self.model not in ("physical", "paper"):
            raise ValueError(f"TraceSettings.model must be 'physical' or 'paper', got {self.model!r}")
        if int(self.rays_per_axis) != self.rays_per_axis or self.rays_per_axis < 4:
            raise ValueError(f"TraceSettings.rays_per_axis must be an integer >= 4, got {self.rays_per_axis}")
        check_range("TraceSettings.cone_half_angle [rad]", self.cone_half_angle, 1e-3, np.radians(80))
        check_range("TraceSettings.taper", self.taper, 0.0, 1.0)
        check_positive("TraceSettings.main_lobe_width [rad]", self.main_lobe_width)
        check_range("TraceSettings.importance_floor", self.importance_floor, 1e-3, 1.0)
        if int(self.refine) != self.refine or not 1 <= self.refine <= 16:
            raise ValueError(f"TraceSettings.refine must be an integer in 1..16, got {self.refine}")
        check_range("TraceSettings.refine_normal_angle [rad]", self.refine_normal_angle, 0.0, np.pi)
        check_range("TraceSettings.refine_radius [rad]", self.refine_radius, 0.0, np.pi / 2)
        if self.max_bounces not in (1, 2):
            raise ValueError(f"TraceSettings.max_bounces must be 1 or 2, got {self.max_bounces}")
        check_range("TraceSettings.crosstalk_gain", self.crosstalk_gain, 0.0, 1e3)
        check_positive("TraceSettings.paper_spacing [rad]", self.paper_spacing)
        check_positive("TraceSettings.paper_beta", self.paper_beta)
        if self.ray_density not in ("beam", "uniform"):
            raise ValueError(f"TraceSettings.ray_density must be 'beam' or 'uniform', "
                             f"got {self.ray_density!r}")
        if self.transmit_weights is not None:
            weights = tuple(float(w) for w in np.ravel(self.transmit_weights))
            check_finite("TraceSettings.transmit_weights", np.array(weights))
            if not any(weights):
                raise ValueError("TraceSettings.transmit_weights: no element transmits (all 0)")
            object.__setattr__(self, "transmit_weights", weights)


@dataclass(frozen=True)
class TraceResult:
    """Paths of one beam and the reflectors that produced them.

    Attributes:
        paths: all echo paths (crosstalk not included), factored per element pair.
        hit_points: (H, 3) first-bounce reflector positions in the sensor frame [m].
        hit_materials: (H,) material index per hit (into ``AcousticScene.materials``).
        ray_count: rays traced for this beam.
    """

    paths: HitPaths
    hit_points: np.ndarray
    hit_materials: np.ndarray
    ray_count: int


def _warped_grid(n: int, half_extent: float, sigma: float, floor: float):
    """Cell centres and widths (n,) of a 1-D grid on [-E, E] with density floor + gauss(sigma)."""
    a = np.linspace(-half_extent, half_extent, 4097)
    density = floor + np.exp(-0.5 * (a / sigma) ** 2)
    cdf = np.concatenate([[0.0], np.cumsum(0.5 * (density[1:] + density[:-1]) * np.diff(a))])
    edges = np.interp(np.linspace(0.0, cdf[-1], n + 1), cdf, a)
    return 0.5 * (edges[1:] + edges[:-1]), np.diff(edges)


def _rows_dot(a, b):
    """Dot products of 3-vectors along the last axis (broadcasting): explicit, which NumPy runs
    several times faster than einsum or matmul over so short an axis."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def _length(v):
    """Lengths of 3-vectors along the last axis (faster than np.linalg.norm there)."""
    return np.sqrt(_rows_dot(v, v))


def _unit(v):
    return v / _length(v)[..., None]


def _rotate(rotation, v, inverse: bool = False):
    """Rows (K, 3) rotated by their own matrices (K, 3, 3) (transposed with ``inverse``)."""
    return np.einsum("kji,kj->ki" if inverse else "kij,kj->ki", rotation, v)


class AcousticTracer:
    """Traces beams through one loaded scene; build once, call :meth:`trace` per beam.

    Args:
        scene: the loaded acoustic scene.
        geometry: arrays of the sensor head.
        transducer: element model (directivity, source level).
        medium: air.
        pulse: drive pulse (its carrier sets the wavenumber of the patch integrals).
        settings: fidelity and model choices.
    """

    def __init__(self, scene: AcousticScene, geometry: ArrayGeometry, transducer: Transducer,
                 medium: Medium, pulse: Pulse, settings: TraceSettings = TraceSettings()):
        self.mi = mitsuba()
        self.scene = scene
        self.geometry = geometry
        self.transducer = transducer
        self.medium = medium
        self.settings = settings
        self.c = medium.speed_of_sound
        self.k = float(medium.wavenumber(pulse.frequency))
        z_air = medium.impedance
        self._z_air = z_air
        absorption = float(medium.absorption_db_per_m(pulse.frequency)) \
            if settings.air_absorption else 0.0
        self._log_attenuation = -absorption * np.log(10.0) / 20.0  # [1/m], amplitude
        mats = scene.materials
        self._scattering = np.array([m.scattering for m in mats])
        self._transparent = np.array([m.transparent for m in mats])
        self._z2 = np.array([m.normal_impedance(z_air) for m in mats])
        s = settings
        if s.model == "paper":
            offsets = (np.arange(s.paper_grid) - (s.paper_grid - 1) / 2) * np.tan(s.paper_spacing)
            aa, bb = np.meshgrid(offsets, offsets, indexing="ij")
            zero = np.zeros_like(aa)
            self._grid = (aa, bb, zero, zero, np.ones(aa.shape, bool))
        else:
            half = np.tan(s.cone_half_angle)
            sigma = 1.5 * np.tan(s.main_lobe_width) / 2.355
            if s.ray_density == "beam":
                centres, widths = _warped_grid(s.rays_per_axis, half, sigma, s.importance_floor)
            else:
                edges = np.tan(np.linspace(-s.cone_half_angle, s.cone_half_angle,
                                           s.rays_per_axis + 1))
                centres, widths = 0.5 * (edges[1:] + edges[:-1]), np.diff(edges)
            aa, bb = np.meshgrid(centres, centres, indexing="ij")
            da, db = np.meshgrid(widths, widths, indexing="ij")
            self._grid = (aa, bb, da, db, np.hypot(aa, bb) <= half)
            self._refinable = np.hypot(aa, bb) <= np.tan(s.refine_radius)
        self._weights = None if s.transmit_weights is None else np.array(s.transmit_weights)
        if self._weights is not None and len(self._weights) != geometry.tx.count:
            raise ValueError(f"TraceSettings.transmit_weights: {len(self._weights)} weights for "
                             f"{geometry.tx.count} transmit elements")

    def _taper(self, a, b):
        """Weight of a ray at tangent-plane offsets (a, b): 1 inside, fading to 0 at the cone edge."""
        s = self.settings
        if s.model == "paper":
            return np.ones_like(a)
        rho = np.hypot(a, b) / np.tan(s.cone_half_angle)
        fade = np.clip((1.0 - rho) / s.taper, 0.0, 1.0) if s.taper > 0 else (rho <= 1).astype(float)
        return np.sin(0.5 * np.pi * fade) ** 2

    # ---- geometry helpers -------------------------------------------------------------------
    def _attenuation(self, distance):
        return np.exp(self._log_attenuation * distance)

    def _intersect(self, origins, directions):
        """First non-transparent hit of rays (world frame).

        Returns t (inf: miss), p, n (world), material index (-1: miss) and shape registry id.
        """
        n_rays = len(origins)
        t_total = np.zeros(n_rays)
        t = np.full(n_rays, np.inf)
        p = np.zeros((n_rays, 3))
        nrm = np.zeros((n_rays, 3))
        mat = np.full(n_rays, -1)
        shape = np.full(n_rays, -1)
        active = np.arange(n_rays)
        o = origins.copy()
        for _ in range(_MAX_TRANSPARENT_LAYERS):  # loop over layers, each vectorised over rays
            si = self.scene.scene.ray_intersect(rays(o[active], directions[active]),
                                                ray_flags=self.mi.RayFlags.Minimal, coherent=False)
            valid_dr = si.is_valid()
            dr.eval(si.t, si.p, si.n, si.shape, valid_dr)  # one kernel launch for all outputs
            valid = np.asarray(valid_dr, dtype=bool)
            registry = np.asarray(dr.reinterpret_array(self.mi.UInt32, si.shape), dtype=np.int64)
            m = np.where(valid, self.scene.material_index(si.shape), -1)
            hit_t = np.asarray(si.t, dtype=float)
            through = valid & (m >= 0) & self._transparent[np.maximum(m, 0)]
            done = ~through
            idx = active[done]
            t[idx] = np.where(valid[done], t_total[idx] + hit_t[done], np.inf)
            p[idx] = np.asarray(si.p, dtype=float).T[done]
            nrm[idx] = np.asarray(si.n, dtype=float).T[done]
            mat[idx] = m[done]
            shape[idx] = np.where(valid[done], registry[done], -1)
            nxt = active[through]
            step = hit_t[through] + _EPS
            t_total[nxt] += step
            o[nxt] = o[nxt] + step[:, None] * directions[nxt]
            active = nxt
            if len(active) == 0:
                break
        return t, p, nrm, mat, shape

    def _shadow_rays(self, starts, rotation, translation):
        """(H x N_rx,) True where the segment from start h (world, (H, 3)) to receive element j
        of hit h's pose (rotation (H, 3, 3), translation (H, 3)) is unobstructed.

        The segments are built in Dr.Jit from the H starts and N_rx elements (no (H x N_rx, 3)
        NumPy temporaries, which cost several times the tests themselves); one any-hit test per
        segment, and only the blocked ones, if the scene has acoustically transparent surfaces,
        traced again through them."""
        Float64, UInt32 = backend().Float64, backend().UInt32

        mi = self.mi
        rx = self.geometry.rx_positions
        n_rx = len(rx)
        index = dr.arange(UInt32, len(starts) * n_rx)
        hit, element = index // n_rx, index % n_rx
        per_hit = lambda column: dr.gather(Float64, to_jit(Float64, column), hit)  # noqa: E731
        elem = [dr.gather(Float64, to_jit(Float64, rx[:, k]), element) for k in range(3)]
        seg = [per_hit(translation[:, a] - starts[:, a])
               + sum(per_hit(rotation[:, a, b]) * elem[b] for b in range(3)) for a in range(3)]
        dist = dr.sqrt(sum(c * c for c in seg))
        d = [c / dist for c in seg]
        origin = [per_hit(starts[:, a]) + _EPS * d[a] for a in range(3)]
        ray = mi.Ray3f(mi.Point3f(*(mi.Float(c) for c in origin)),
                       mi.Vector3f(*(mi.Float(c) for c in d)), mi.Float(dist - 2 * _EPS),
                       mi.Float(0.0), [])
        blocked = self.scene.scene.ray_test(ray)
        if not self._transparent.any():
            dr.eval(blocked)
            return ~np.asarray(blocked, dtype=bool)
        dr.eval(blocked, origin, d, dist)
        visible = ~np.asarray(blocked, dtype=bool)
        recheck = np.flatnonzero(~visible)
        if len(recheck):
            o, v = (np.stack([np.asarray(c)[recheck] for c in x], axis=1) for x in (origin, d))
            visible[recheck] = self._intersect(o, v)[0] >= np.asarray(dist)[recheck] - 2 * _EPS
        return visible

    # ---- physics ---------------------------------------------------------------------------
    def _reflection(self, mats, cos_incidence):
        """Pressure reflection coefficient r(theta) per hit (locally reacting surface)."""
        zc = self._z2[mats] * np.maximum(cos_incidence, 0.0)  # mats broadcasts against cos
        return (zc - self._z_air) / (zc + self._z_air)

    def _scatter(self, points, normals, mats, d_in, dd1, dd2, t_unfold, mirror, steering,
                 extra_gain, visible, roughness) -> HitPaths:
        """Paths re-radiated by patches (see module docstring). All inputs are per hit
        (``roughness``: (H,) unit phasors of the diffuse part, see :meth:`_roughness`;
        ``mirror``: None, or the plane (points, normals) (H, 3) the transmit array is mirrored
        in for unfolded bounces).

        Incidence and emergence angles, reflection coefficients and the phase gradient of the
        patch integral are evaluated per transmit and receive element
        (:func:`~mitsonar.trace.element_factors.element_factors`), which keeps the patch sum exact at
        short range where the elements see a patch from different directions.
        """
        g = self.geometry
        physical = self.settings.model == "physical"
        edges = np.zeros((len(points), 2, 3))
        if physical:  # patch edges on the tangent plane from the ray differentials (unfolded)
            d_dot_n = _rows_dot(d_in, normals)[:, None]
            for k, dd in enumerate((dd1, dd2)):
                edges[:, k] = t_unfold[:, None] * (dd - d_in * _rows_dot(dd, normals)[:, None] / d_dot_n)
        area = _length(np.cross(edges[:, 0], edges[:, 1]))
        # Patch integral of exp(-j k (r_i + r_j)) over the parallelogram: A sinc(.) sinc(.), the
        # phase gradient being w_i + v_j; the sinc arguments split into TX and RX parts.
        edges *= 0.5 * self.k / np.pi  # np.sinc(x) = sin(pi x) / (pi x)
        common = dict(ka=self.k * self.transducer.radius, log_attenuation=self._log_attenuation,
                      speed_of_sound=self.c)
        tx = element_factors(points, normals, edges, g.tx_positions,
                             self.transducer.source_amplitude * np.exp(1j * g.tx_phase_offsets),
                             departure=None if mirror is None else mirror[0], firing=steering,
                             mirror=mirror, impedance=self._z2[mats] if physical else None,
                             z_air=self._z_air, **common)
        rx = element_factors(points, normals, edges, g.rx_positions, np.exp(1j * g.rx_phase_offsets),
                             visible=visible, **common)
        if not physical:
            to_rx = g.rx_origin[None] - points
            r_out = _length(to_rx)
            alpha = APERTURE**2 * np.clip(_rows_dot(to_rx, normals) / r_out, 0, None) \
                / (2 * np.pi * r_out**2)
            energy_r = self._reflection(mats, np.ones(len(mats))) ** 2  # equation (4)
            mid = alpha * self.settings.paper_beta * energy_r * extra_gain
            return HitPaths.point_reflectors(tx.specular, tx.delay, rx.specular, rx.delay, mid)
        s = self._scattering[mats]
        specular = 1j * self.k / (4 * np.pi) * area * np.sqrt(1 - s) * extra_gain
        # Lambert: |r| sqrt(s A cos_in cos_out / pi), with a random phase per patch (surface
        # roughness; constant over the narrow band of the pulse), so it shares the delays.
        diffuse = np.sqrt(s * area / np.pi) * extra_gain * roughness
        return HitPaths(tx.delay, rx.delay, tx.specular, rx.specular, specular, tx.cos, rx.cos,
                        tx.sinc, rx.sinc, tx.diffuse, rx.diffuse, diffuse)

    # ---- public ----------------------------------------------------------------------------
    def _cast(self, rotation, translation, u, e1, e2, beam, a, b):
        """Rays of beams ``beam`` (K,) through tangent-plane offsets (a, b) (K,) around their axes
        u (B, 3) with bases e1, e2 (B, 3); returns directions (sensor frame), |u + a e1 + b e2|
        and the intersection results of :meth:`_intersect`."""
        v = u[beam] + a[:, None] * e1[beam] + b[:, None] * e2[beam]
        norm_v = _length(v)
        d = v / norm_v[:, None]
        world_d = _rotate(rotation[beam], d)
        return d, norm_v, self._intersect(translation[beam], world_d)

    def _refine_mask(self, inside, t, n_w, shape):
        """(..., n, n) cells to split: a 4-neighbour differs in hit, shape, normal or depth;
        grown by one. Leading axes (beams) are independent grids."""
        hit = np.isfinite(t)
        cos_max = np.cos(self.settings.refine_normal_angle)
        refine = np.zeros_like(inside)
        for axis in (-2, -1):  # the two grid directions
            sl_a = (Ellipsis, slice(None, -1), slice(None)) if axis == -2 else (Ellipsis, slice(None, -1))
            sl_b = (Ellipsis, slice(1, None), slice(None)) if axis == -2 else (Ellipsis, slice(1, None))
            both = inside[sl_a] & inside[sl_b]
            both_hit = hit[sl_a] & hit[sl_b]
            depth_a = np.where(hit[sl_a], t[sl_a], 0.0)
            depth_b = np.where(hit[sl_b], t[sl_b], 0.0)
            n_a = n_w[sl_a + (slice(None),)]
            n_b = n_w[sl_b + (slice(None),)]
            differ = (hit[sl_a] != hit[sl_b]) | (shape[sl_a] != shape[sl_b]) | (both_hit & (
                (np.abs(np.sum(n_a * n_b, axis=-1)) < cos_max)
                | (np.abs(depth_a - depth_b) > 0.05 * np.maximum(depth_a, depth_b))))
            differ &= both
            refine[sl_a] |= differ
            refine[sl_b] |= differ
        # Grow by one cell (8-neighbourhood): an edge or corner can cross a cell whose own ray
        # and 4-neighbours all agree.
        grow = np.ones((1,) * (refine.ndim - 2) + (3, 3), bool)
        return binary_dilation(refine, structure=grow) & inside

    def trace(self, sensor_pose: Pose, direction, seed: int = 0) -> TraceResult:
        """Trace one beam steered to ``direction`` (3,) (sensor frame) from ``sensor_pose``.

        Args:
            sensor_pose: world-from-sensor pose.
            direction: unit beam direction in the sensor frame.
            seed: seed of the diffuse phases (same seed, same paths).
        """
        return self.trace_many([sensor_pose], [direction], [seed])[0]

    def trace_many(self, sensor_poses, directions, seeds) -> list[TraceResult]:
        """Trace B beams together; the same results as B calls of :meth:`trace`, but every ray
        cast, shadow-ray test and patch computation runs once for all of them, so the per-call
        costs (kernel launches, the surface-interaction dispatch) are paid once.

        Args:
            sensor_poses: B world-from-sensor poses, one per beam (the robot may move).
            directions: (B, 3) beam directions in each beam's sensor frame.
            seeds: B seeds of the diffuse phases.
        """
        g = self.geometry
        s = self.settings
        u = _unit(np.asarray(directions, dtype=float).reshape(-1, 3))
        n_beams = len(u)
        if len(sensor_poses) != n_beams or len(seeds) != n_beams:
            raise ValueError(f"trace_many: {len(sensor_poses)} poses and {len(seeds)} seeds for "
                             f"{n_beams} directions")
        rotation = np.stack([pose.rotation for pose in sensor_poses])  # (B, 3, 3)
        translation = np.stack([pose.translation for pose in sensor_poses])  # (B, 3)
        basis = [orthonormal_basis(axis) for axis in u]
        e1, e2 = np.array([e for e, _ in basis]), np.array([e for _, e in basis])
        aa, bb, da, db, inside = self._grid
        beam = np.repeat(np.arange(n_beams), aa.size)
        a, b, wa, wb = (np.tile(x.ravel(), n_beams) for x in (aa, bb, da, db))
        d, norm_v, (t, p_w, n_w, mats, shape) = self._cast(rotation, translation, u, e1, e2, beam, a, b)
        keep = np.tile(inside.ravel(), n_beams)
        m = s.refine
        if m > 1 and s.model == "physical":
            grids = (n_beams,) + aa.shape
            split = (self._refine_mask(np.broadcast_to(inside, grids), t.reshape(grids),
                                       n_w.reshape(grids + (3,)), shape.reshape(grids))
                     & self._refinable).ravel()
            if np.any(split):
                keep &= ~split
                frac = (np.arange(m) + 0.5) / m - 0.5
                fa, fb = np.meshgrid(frac, frac, indexing="ij")
                ca = (a[split, None] + fa.ravel()[None] * wa[split, None]).ravel()
                cb = (b[split, None] + fb.ravel()[None] * wb[split, None]).ravel()
                cwa = np.repeat(wa[split] / m, m * m)
                cwb = np.repeat(wb[split] / m, m * m)
                cbeam = np.repeat(beam[split], m * m)
                cd, cnorm, (ct, cp, cn, cmat, _) = self._cast(rotation, translation, u, e1, e2,
                                                              cbeam, ca, cb)
                # Per beam: its kept rays in grid order, then its sub-rays.
                order = np.argsort(np.concatenate([beam[keep], cbeam]), kind="stable")
                a, b, wa, wb, d, norm_v, t, p_w, n_w, mats, beam = (
                    np.concatenate([x[keep], y])[order] for x, y in
                    ((a, ca), (b, cb), (wa, cwa), (wb, cwb), (d, cd), (norm_v, cnorm), (t, ct),
                     (p_w, cp), (n_w, cn), (mats, cmat), (beam, cbeam)))
                keep = np.ones(len(a), bool)
        ray_count = np.bincount(beam[keep], minlength=n_beams)
        hit = keep & np.isfinite(t) & (mats >= 0)
        hb = beam[hit]
        rot_h, trans_h = rotation[hb], translation[hb]
        x = _rotate(rot_h, p_w[hit] - trans_h, inverse=True)
        n = _unit(_rotate(rot_h, n_w[hit], inverse=True))
        d_h = d[hit]
        n = np.where(_rows_dot(d_h, n)[:, None] > 0, -n, n)  # face the incoming ray
        mats_h = mats[hit]
        taper = self._taper(a[hit], b[hit])
        visible = self._visibility(rot_h, trans_h, x, n)
        inv = (1.0 / norm_v[hit])[:, None]
        dd1 = (e1[hb] - d_h * _rows_dot(d_h, e1[hb])[:, None]) * inv * wa[hit][:, None]
        dd2 = (e2[hb] - d_h * _rows_dot(d_h, e2[hb])[:, None]) * inv * wb[hit][:, None]
        steering = g.steering_delays(u, self.c)[hb]  # (H, N_tx)
        rngs = [np.random.default_rng(seed) for seed in seeds]
        parts = [(hb, self._scatter(x, n, mats_h, d_h, dd1, dd2, t[hit], None, steering,
                                    taper.astype(complex), visible, self._roughness(mats_h, hb, rngs)))]
        if s.max_bounces == 2 and s.model == "physical":
            parts += self._second_bounce(rotation, translation, hb, x, n, mats_h, d_h, dd1, dd2,
                                         t[hit], taper, steering, rngs)
        if self._weights is not None:
            parts = [(part_beam, self._weighted(part)) for part_beam, part in parts]
        results = []
        bounds = [np.searchsorted(part_beam, np.arange(n_beams + 1)) for part_beam, _ in parts]
        for k in range(n_beams):  # split into beams (hits are ordered by beam)
            rows = [slice(bound[k], bound[k + 1]) for bound in bounds]
            paths = HitPaths.concatenate([part.select(r) for (_, part), r in zip(parts, rows)])
            results.append(TraceResult(paths, x[rows[0]], mats_h[rows[0]], int(ray_count[k])))
        return results

    def _weighted(self, paths: HitPaths) -> HitPaths:
        """``paths`` with transmit element i's factors times ``transmit_weights[i]``, the
        elements of weight 0 left out."""
        on = np.flatnonzero(self._weights)
        w = self._weights[on]
        return replace(paths, tx_delay=paths.tx_delay[:, on], tx_cos=paths.tx_cos[:, on],
                       tx_sinc=paths.tx_sinc[:, on], tx_specular=paths.tx_specular[:, on] * w,
                       tx_diffuse=paths.tx_diffuse[:, on] * w)

    def _roughness(self, mats, beam, rngs) -> np.ndarray:
        """(H,) unit phasors of the diffuse parts of hits of beams ``beam`` (H,) (ordered by
        beam): uniform random phases drawn from each beam's generator ``rngs[b]`` in hit order,
        ones for beams without diffuse hits (and for the paper model, which has no diffuse part)."""
        out = np.ones(len(mats), dtype=complex)
        if self.settings.model == "paper":
            return out
        bounds = np.searchsorted(beam, np.arange(len(rngs) + 1))
        diffuse = self._scattering[mats] > 0
        for k, rng in enumerate(rngs):  # per beam: one draw for all its hits
            rows = slice(bounds[k], bounds[k + 1])
            if np.any(diffuse[rows]):
                out[rows] = np.exp(2j * np.pi * rng.uniform(0.0, 1.0, bounds[k + 1] - bounds[k]))
        return out

    def _visibility(self, rotation, translation, points, normals) -> np.ndarray:
        """(H, N_rx) 1.0 where receive element j sees hit h, else 0.0; points and normals (H, 3)
        in the sensor frame of poses (rotation (H, 3, 3), translation (H, 3))."""
        rx = self.geometry.rx_positions
        if not self.settings.shadow_rays or len(points) == 0:
            return np.ones((len(points), len(rx)))
        start = _rotate(rotation, points + _EPS * normals) + translation  # (H, 3) world
        visible = self._shadow_rays(start, rotation, translation)
        return visible.reshape(len(points), len(rx)).astype(float)

    def _second_bounce(self, rotation, translation, beam, x1, n1, mats1, d1, dd1, dd2, t1, taper,
                       steering, rngs) -> list[tuple[np.ndarray, HitPaths]]:
        """Specular continuation of every first-bounce ray, scattered at its second hit:
        [(beam of each second hit, paths)], or [] when no ray hits again."""
        reflect = lambda v: v - 2 * _rows_dot(v, n1)[:, None] * n1  # noqa: E731
        d2 = reflect(d1)
        rot, trans = rotation[beam], translation[beam]
        start = _rotate(rot, x1 + _EPS * n1) + trans
        t, p_w, n_w, mats, _ = self._intersect(start, _rotate(rot, d2))
        hit = np.isfinite(t) & (mats >= 0)
        if not np.any(hit):
            return []
        rot, trans = rot[hit], trans[hit]
        x2 = _rotate(rot, p_w[hit] - trans, inverse=True)
        n2 = _unit(_rotate(rot, n_w[hit], inverse=True))
        d2h = d2[hit]
        n2 = np.where(_rows_dot(d2h, n2)[:, None] > 0, -n2, n2)
        m1 = mats1[hit]
        r1 = self._reflection(m1, -_rows_dot(d1[hit], n1[hit])) * np.sqrt(1 - self._scattering[m1])
        visible = self._visibility(rot, trans, x2, n2)
        n1h = n1[hit]
        refl = lambda v: v - 2 * _rows_dot(v, n1h)[:, None] * n1h  # noqa: E731
        mats2 = mats[hit]
        return [(beam[hit], self._scatter(
            x2, n2, mats2, d2h, refl(dd1[hit]), refl(dd2[hit]), t1[hit] + t[hit] + _EPS,
            (x1[hit], n1h), steering[hit], (taper[hit] * r1).astype(complex), visible,
            self._roughness(mats2, beam[hit], rngs)))]

    def direct_paths(self, direction) -> Paths:
        """Direct transmitter -> receiver paths (cross-talk) for a beam steered to ``direction``."""
        g = self.geometry
        u = _unit(np.asarray(direction, dtype=float))
        steering = g.steering_delays(u, self.c)
        v = g.rx_positions[None, :, :] - g.tx_positions[:, None, :]  # (N_tx, N_rx, 3)
        r = np.linalg.norm(v, axis=-1)
        cos = np.clip(v[..., 2] / r, 0.0, 1.0)  # grazing along the baffle
        d = self.transducer.directivity(cos, self.k)
        gain = (self.settings.crosstalk_gain * self.transducer.source_amplitude * d * d
                * self._attenuation(r) / r
                * np.exp(1j * (g.tx_phase_offsets[:, None] + g.rx_phase_offsets[None, :])))
        delay = steering[:, None] + r / self.c
        channel = np.broadcast_to(np.arange(g.rx.count), r.shape)
        if self._weights is not None:  # the transmitting elements, weighted
            on = self._weights != 0
            gain, delay, channel = gain[on] * self._weights[on, None], delay[on], channel[on]
        return Paths(gain.ravel(), delay.ravel(), channel.ravel())
