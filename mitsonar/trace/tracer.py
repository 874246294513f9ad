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

The ray grid, casts, refinement and shadow rays (steps 1-2, visibility) are
:class:`~mitsonar.trace.casting.RayCaster`'s, which the tracer extends with the scattering.
After the intersections, per-hit geometry is NumPy and the per (hit, element) factors one Dr.Jit
kernel (:mod:`~mitsonar.trace.element_factors`), kept factored per transmit and receive element
(:class:`~mitsonar.trace.hitpaths.HitPaths`); no Python loop runs over rays, paths or samples.
:meth:`AcousticTracer.trace_many` runs every step once for the hits of a batch of beams (each with
its own pose and seed), which pays the per-call costs once.
:meth:`AcousticTracer.trace_union` traces the union of several beams' cones once, as world-frame
patches (:class:`HitPatches`) whose unsteered paths :meth:`AcousticTracer.patch_paths` computes for
any nearby pose of the array (an OFDM cycle's shared hits).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from mitsonar.frames import Pose, orthonormal_basis
from mitsonar.physics.array import APERTURE, ArrayGeometry
from mitsonar.physics.medium import Medium
from mitsonar.physics.transducer import Transducer
from mitsonar.physics.waveforms import Chirp, Pulse
from mitsonar.scene.loading import AcousticScene
from mitsonar.trace.casting import (_EPS, RayCaster, _length, _rotate, _rows_dot, _unit,
                                    ray_differentials)
from mitsonar.trace.element_factors import element_factors
from mitsonar.trace.hitpaths import HitPaths
from mitsonar.trace.paths import Paths
from mitsonar.trace.settings import TraceSettings
from mitsonar.trace.subbands import Subbands, subband_nodes


@dataclass(frozen=True)
class TraceResult:
    """Paths of one beam and the reflectors that produced them.

    Attributes:
        paths: all echo paths (crosstalk not included), factored per element pair; with
            ``TraceSettings.subbands`` > 1, one such set per frequency node (:class:`Subbands`).
        hit_points: (H, 3) first-bounce reflector positions in the sensor frame [m].
        hit_materials: (H,) material index per hit (into ``AcousticScene.materials``).
        ray_count: rays traced for this beam.
    """

    paths: HitPaths | Subbands
    hit_points: np.ndarray
    hit_materials: np.ndarray
    ray_count: int



@dataclass(frozen=True)
class HitPatches:
    """First-bounce surface patches of a trace shared by several beams
    (:meth:`AcousticTracer.trace_union`), in the world frame, so that element factors can be
    computed for any pose of the array nearby (:meth:`AcousticTracer.patch_paths`).

    Attributes:
        points: (H, 3) patch centres [m].
        normals: (H, 3) unit normals, facing the rays that hit them.
        edges: (H, 2, 3) patch edges [m].
        materials: (H,) material index (into ``AcousticScene.materials``).
        weight: (H,) weight of the union of the beams' cones (1 inside, fading at its edge).
        roughness: (H,) unit phasors of the diffuse parts.
        pose: the world-from-sensor pose traced from.
        ray_count: rays traced.
    """

    points: np.ndarray
    normals: np.ndarray
    edges: np.ndarray
    materials: np.ndarray
    weight: np.ndarray
    roughness: np.ndarray
    pose: Pose
    ray_count: int


def band_half_width(transducer: Transducer, pulse: Pulse | Chirp) -> float:
    """Half the band the trace models around the drive's centre [Hz]: half the wider of the
    transducers' and the drive's bandwidths (its frequency nodes span it)."""
    return 0.5 * max(transducer.bandwidth_6db, pulse.bandwidth)


def frequency_gains(transducer: Transducer, medium: Medium, settings: TraceSettings,
                    max_angle: float, longest_path: float):
    """What the tracer evaluates per frequency node, as a function of frequencies (F,) [Hz]
    giving gains (A, F): the two-way element pattern at 0 .. ``max_angle`` [rad] off the
    element normal, air absorption over 0 .. ``longest_path`` [m] (if modelled) and the
    physical model's j k of the patch integral (case 0: broadside, no path; for
    :func:`~mitsonar.trace.subbands.nodes_needed`)."""
    angle = np.linspace(0.0, max_angle, 33)[:, None, None]
    path = np.linspace(0.0, longest_path, 3)[None, :, None]

    def gain(frequencies):
        k = medium.wavenumber(np.asarray(frequencies, dtype=float))
        out = transducer.directivity(np.cos(angle), k) ** 2 * np.ones_like(path)
        if settings.air_absorption:
            out = out * 10.0 ** (-medium.absorption_db_per_m(frequencies) * path / 20.0)
        if settings.model == "physical":
            out = out * k
        return out.reshape(-1, out.shape[-1])
    return gain


class AcousticTracer(RayCaster):
    """Traces beams through one loaded scene; build once, call :meth:`trace` per beam.

    Args:
        scene: the loaded acoustic scene.
        geometry: arrays of the sensor head.
        transducer: element model (directivity, source level).
        medium: air.
        pulse: drive waveform (its centre frequency sets the wavenumber of the patch integrals).
        settings: fidelity and model choices.
    """

    def __init__(self, scene: AcousticScene, geometry: ArrayGeometry, transducer: Transducer,
                 medium: Medium, pulse: Pulse | Chirp, settings: TraceSettings = TraceSettings()):
        half = band_half_width(transducer, pulse)
        top = pulse.frequency + half  # the band's top
        self.k = float(medium.wavenumber(pulse.frequency))
        super().__init__(scene, geometry, settings, (self.k, float(medium.wavenumber(top))))
        self.transducer = transducer
        self.medium = medium
        self.c = medium.speed_of_sound
        z_air = medium.impedance
        self._z_air = z_air
        if settings.subbands == "auto":
            raise ValueError("TraceSettings.subbands 'auto' is resolved by "
                             "SonarConfig.resolved_trace before tracing")
        #: Frequency nodes of the element patterns, patch integrals and absorption [Hz]
        #: (``TraceSettings.subbands``).
        self.nodes = tuple(float(f) for f in
                           subband_nodes(pulse.frequency, half, settings.subbands))
        self._node_k = [float(medium.wavenumber(f)) for f in self.nodes]
        # air absorption at each node [1/m], amplitude, natural log
        self._node_log_attenuation = [
            -float(medium.absorption_db_per_m(f)) * np.log(10.0) / 20.0
            if settings.air_absorption else 0.0 for f in self.nodes]
        mats = scene.materials
        self._scattering = np.array([m.scattering for m in mats])
        self._z2 = np.array([m.normal_impedance(z_air) for m in mats])
        s = settings
        self._weights = None if s.transmit_weights is None else np.array(s.transmit_weights)
        if self._weights is not None and len(self._weights) != geometry.tx.count:
            raise ValueError(f"TraceSettings.transmit_weights: {len(self._weights)} weights for "
                             f"{geometry.tx.count} transmit elements")
        #: The transmit elements that fire (weight not 0): the only ones traced.
        self._transmitting = np.arange(geometry.tx.count) if self._weights is None \
            else np.flatnonzero(self._weights)

    # ---- physics ---------------------------------------------------------------------------
    def _reflection(self, mats, cos_incidence):
        """Pressure reflection coefficient r(theta) per hit (locally reacting surface)."""
        zc = self._z2[mats] * np.maximum(cos_incidence, 0.0)  # mats broadcasts against cos
        return (zc - self._z_air) / (zc + self._z_air)

    def _patch_edges(self, d_in, normals, dd1, dd2, t_unfold) -> np.ndarray:
        """(H, 2, 3) edges of the patches [m]: the rays' cells (differentials dd1, dd2 (H, 3) of
        the unit directions d_in, unfolded path lengths t_unfold (H,)) projected on the tangent
        planes of the hits (zero for the paper model's point reflectors)."""
        edges = np.zeros((len(d_in), 2, 3))
        if self.settings.model == "physical":
            d_dot_n = _rows_dot(d_in, normals)[:, None]
            for k, dd in enumerate((dd1, dd2)):
                edges[:, k] = t_unfold[:, None] * (dd - d_in * _rows_dot(dd, normals)[:, None] / d_dot_n)
        return edges

    def _scatter(self, points, normals, mats, edges, mirror, steering, extra_gain, visible,
                 roughness) -> HitPaths | Subbands:
        """Paths re-radiated by patches at every frequency node (:meth:`_scatter_at`): one
        :class:`HitPaths`, or :class:`Subbands` of them."""
        parts = [self._scatter_at(k, log_attenuation, points, normals, mats, edges, mirror,
                                  steering, extra_gain, visible, roughness)
                 for k, log_attenuation in zip(self._node_k, self._node_log_attenuation)]
        return parts[0] if len(parts) == 1 else Subbands(tuple(parts), self.nodes)

    def _scatter_at(self, k: float, log_attenuation: float, points, normals, mats, edges, mirror,
                    steering, extra_gain, visible, roughness) -> HitPaths:
        """Paths re-radiated by patches at wavenumber ``k`` [rad/m] with air absorption
        ``log_attenuation`` [1/m] (see module docstring). All other inputs are per hit
        (``edges``: (H, 2, 3) from :meth:`_patch_edges`; ``roughness``: (H,) unit phasors of the
        diffuse part, see :meth:`_roughness`; ``mirror``: None, or the plane (points, normals)
        (H, 3) the transmit array is mirrored in for unfolded bounces; ``steering``: (H, N_tx)
        firing delays [s], or None: unsteered).

        Incidence and emergence angles, reflection coefficients and the phase gradient of the
        patch integral are evaluated per transmit and receive element
        (:func:`~mitsonar.trace.element_factors.element_factors`), which keeps the patch sum exact at
        short range where the elements see a patch from different directions.
        """
        g = self.geometry
        physical = self.settings.model == "physical"
        area = _length(np.cross(edges[:, 0], edges[:, 1]))
        # Patch integral of exp(-j k (r_i + r_j)) over the parallelogram: A sinc(.) sinc(.), the
        # phase gradient being w_i + v_j; the sinc arguments split into TX and RX parts.
        edges = edges * (0.5 * k / np.pi)  # np.sinc(x) = sin(pi x) / (pi x)
        common = dict(ka=k * self.transducer.radius, log_attenuation=log_attenuation,
                      speed_of_sound=self.c)
        on = self._transmitting  # elements of weight 0 are left out (:meth:`_weighted`)
        tx = element_factors(points, normals, edges, g.tx_positions[on],
                             self.transducer.source_amplitude * np.exp(1j * g.tx_phase_offsets[on]),
                             departure=None if mirror is None else mirror[0],
                             firing=None if steering is None else steering[:, on],
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
        specular = 1j * k / (4 * np.pi) * area * np.sqrt(1 - s) * extra_gain
        # Lambert: |r| sqrt(s A cos_in cos_out / pi), with a random phase per patch (surface
        # roughness; constant over the narrow band of the pulse), so it shares the delays.
        diffuse = np.sqrt(s * area / np.pi) * extra_gain * roughness
        return HitPaths(tx.delay, rx.delay, tx.specular, rx.specular, specular, tx.cos, rx.cos,
                        tx.sinc, rx.sinc, tx.diffuse, rx.diffuse, diffuse)

    # ---- public ----------------------------------------------------------------------------
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
        grids = (n_beams,) + self._grid[0].shape
        refinable = None if s.model == "paper" else np.broadcast_to(self._refinable, grids)
        (a, b, wa, wb, d, norm_v, t, p_w, n_w, mats, beam), ray_count, fixed = self._cast_grid(
            rotation, translation, u, e1, e2,
            tuple(np.broadcast_to(x, grids) for x in self._grid), refinable)
        hit = np.isfinite(t) & (mats >= 0)
        hb = beam[hit]
        rot_h, trans_h = rotation[hb], translation[hb]
        x = _rotate(rot_h, p_w[hit] - trans_h, inverse=True)
        n = _unit(_rotate(rot_h, n_w[hit], inverse=True))
        d_h = d[hit]
        n = np.where(_rows_dot(d_h, n)[:, None] > 0, -n, n)  # face the incoming ray
        mats_h = mats[hit]
        taper = self._taper(a[hit], b[hit])
        visible = self._visibility(rot_h, trans_h, x, n)
        dd1, dd2 = ray_differentials(d_h, norm_v[hit], e1[hb], e2[hb], wa[hit], wb[hit])
        steering = g.steering_delays(u, self.c)[hb]  # (H, N_tx)
        rngs = [np.random.default_rng(seed) for seed in seeds]
        edges = self._patch_edges(d_h, n, dd1, dd2, t[hit])
        roughness = self._hit_roughness(fixed, t, hit, mats_h, hb, rngs)
        parts = [(hb, self._scatter(x, n, mats_h, edges, None, steering, taper.astype(complex),
                                    visible, roughness))]
        if s.max_bounces == 2 and s.model == "physical":
            parts += self._second_bounce(rotation, translation, hb, x, n, mats_h, d_h, dd1, dd2,
                                         t[hit], taper, steering, rngs)
        if self._weights is not None:
            parts = [(part_beam, self._weighted(part)) for part_beam, part in parts]
        results = []
        bounds = [np.searchsorted(part_beam, np.arange(n_beams + 1)) for part_beam, _ in parts]
        for k in range(n_beams):  # split into beams (hits are ordered by beam)
            rows = [slice(bound[k], bound[k + 1]) for bound in bounds]
            paths = type(parts[0][1]).concatenate([part.select(r)
                                                   for (_, part), r in zip(parts, rows)])
            results.append(TraceResult(paths, x[rows[0]], mats_h[rows[0]], int(ray_count[k])))
        return results

    def shares_hits(self) -> bool:
        """Whether :meth:`trace_union` serves these settings: the physical model, single
        scattering, every transmit element at weight 1 (the paper's point reflectors are placed
        per beam; specular multipath and weights are traced per beam)."""
        s = self.settings
        return s.model == "physical" and s.max_bounces == 1 and self._weights is None

    def trace_union(self, sensor_pose: Pose, directions, seed: int = 0) -> HitPatches:
        """Trace the union of the cones around beam directions (B, 3) (sensor frame) once, for
        beams that share their hits: what a beam's echo depends on is the scene seen from the
        pose, its steering only weights the elements. The grid is regular in angle, cells of
        ``shared_ray_step``, each split into ``refine`` x ``refine`` rays within
        ``refine_radius`` of a beam axis (the main lobes, where a beam's own grid is densest).

        Args:
            sensor_pose: world-from-sensor pose.
            directions: the beam directions whose cones are traced.
            seed: seed of the diffuse phases (same seed, same patches).
        """
        if not self.shares_hits():
            raise ValueError("trace_union needs the physical model, max_bounces=1 and no "
                             "transmit_weights")
        u = _unit(np.asarray(directions, dtype=float).reshape(-1, 3))
        u0, e1, e2, grid, refinable = self._union_grid(u, self.settings.shared_ray_step)
        rotation, translation = sensor_pose.rotation, sensor_pose.translation
        (a, b, wa, wb, d, norm_v, t, p_w, n_w, mats, _), ray_count, fixed = self._cast_grid(
            rotation[None], translation[None], u0[None], e1[None], e2[None], grid, refinable,
            dense=refinable)
        hit = np.isfinite(t) & (mats >= 0)
        d_h, mats_h = d[hit], mats[hit]
        dd1, dd2 = ray_differentials(d_h, norm_v[hit], e1, e2, wa[hit], wb[hit])
        world = lambda v: v @ rotation.T  # noqa: E731  (rows rotated into the world frame)
        d_w = world(d_h)
        n = _unit(n_w[hit])
        n = np.where(_rows_dot(d_w, n)[:, None] > 0, -n, n)  # face the incoming ray
        edges = self._patch_edges(d_w, n, world(dd1), world(dd2), t[hit])
        roughness = self._hit_roughness(fixed, t, hit, mats_h, np.zeros(len(mats_h), int),
                                        [np.random.default_rng(seed)])
        return HitPatches(p_w[hit], n, edges, mats_h, self._union_weight(d_h @ u.T), roughness,
                          sensor_pose, int(ray_count[0]))

    def patch_paths(self, patches: HitPatches, sensor_pose: Pose) -> HitPaths | Subbands:
        """Unsteered paths (transmit delays: travel times) of shared ``patches`` through every
        element pair of the array at ``sensor_pose``: element factors and receive visibility
        computed for that pose, the patches as traced (the array may have moved since)."""
        rotation, translation = sensor_pose.rotation, sensor_pose.translation
        x = (patches.points - translation) @ rotation  # into the sensor frame
        n = patches.normals @ rotation
        count = len(x)
        visible = self._visibility(np.broadcast_to(rotation, (count, 3, 3)),
                                   np.broadcast_to(translation, (count, 3)), x, n)
        return self._scatter(x, n, patches.materials, patches.edges @ rotation, None, None,
                             patches.weight.astype(complex), visible, patches.roughness)

    def _weighted(self, paths: HitPaths | Subbands) -> HitPaths | Subbands:
        """``paths`` (of the transmitting elements alone, :meth:`_scatter_at`) with transmit
        element i's factors times ``transmit_weights[i]``."""
        if isinstance(paths, Subbands):
            return paths.each(self._weighted)
        w = self._weights[self._transmitting]
        return replace(paths, tx_specular=paths.tx_specular * w,
                       tx_diffuse=paths.tx_diffuse * w)

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

    def _hit_roughness(self, fixed, t, hit, mats, beam, rngs) -> np.ndarray:
        """(H,) diffuse phasors of the hits ``hit`` (mask over the traced rays, of ranges ``t``
        [m]; materials ``mats`` and beams ``beam`` (H,)): :meth:`_roughness`, or where blocks of
        cells were merged (``fixed``, from :meth:`_cast_grid`), drawn for the fixed grid's hits
        as without merging and summed per block with amplitudes sqrt(wa wb / their sum) and the
        carrier phases of their two-way ranges to the block's centre: the coherent sum of the
        block's scatterers, the same speckle realisation."""
        if fixed is None:
            return self._roughness(mats, beam, rngs)
        grid, t_cells, materials, area, stands = fixed
        on = np.isfinite(t_cells) & (materials >= 0)
        stands, area = stands[on], area[on]
        phasor = self._roughness(materials[on], grid[on], rngs) \
            * np.exp(-2j * self.k * (t_cells[on] - t[stands]))
        amplitude = np.sqrt(area / np.bincount(stands, weights=area, minlength=len(hit))[stands])
        total = (np.bincount(stands, weights=amplitude * phasor.real, minlength=len(hit))
                 + 1j * np.bincount(stands, weights=amplitude * phasor.imag, minlength=len(hit)))
        return total[hit]

    def _second_bounce(self, rotation, translation, beam, x1, n1, mats1, d1, dd1, dd2, t1, taper,
                       steering, rngs) -> list[tuple[np.ndarray, HitPaths]]:
        """Specular continuation of every first-bounce ray, scattered at its second hit:
        [(beam of each second hit, paths)], or [] when no ray hits again."""
        reflect = lambda v: v - 2 * _rows_dot(v, n1)[:, None] * n1  # noqa: E731
        d2 = reflect(d1)
        rot, trans = rotation[beam], translation[beam]
        start = _rotate(rot, x1 + _EPS * n1) + trans
        t, p_w, n_w, mats, _ = self.intersect(start, _rotate(rot, d2))
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
        edges = self._patch_edges(d2h, n2, refl(dd1[hit]), refl(dd2[hit]),
                                  t1[hit] + t[hit] + _EPS)
        return [(beam[hit], self._scatter(
            x2, n2, mats2, edges, (x1[hit], n1h), steering[hit],
            (taper[hit] * r1).astype(complex), visible, self._roughness(mats2, beam[hit], rngs)))]

    def direct_paths(self, direction=None) -> Paths | Subbands:
        """Direct transmitter -> receiver paths (cross-talk) for a beam steered to
        ``direction``, at every frequency node (:class:`Subbands` of them for more than one).
        Without a direction: unsteered (delays: travel times), on a channel per element pair
        (transmit element major, as :meth:`EchoSynthesizer.ping_samples
        <mitsonar.signal.synthesis.EchoSynthesizer.ping_samples>` grids them)."""
        g = self.geometry
        v = g.rx_positions[None, :, :] - g.tx_positions[:, None, :]  # (N_tx, N_rx, 3)
        r = np.linalg.norm(v, axis=-1)
        cos = np.clip(v[..., 2] / r, 0.0, 1.0)  # grazing along the baffle
        if direction is None:
            delay = r / self.c
            channel = np.arange(r.size).reshape(r.shape)
        else:
            delay = g.steering_delays(_unit(np.asarray(direction, dtype=float)), self.c)[:, None] \
                + r / self.c
            channel = np.broadcast_to(np.arange(g.rx.count), r.shape)
        on = np.ones(g.tx.count, bool) if self._weights is None else self._weights != 0
        weight = np.ones(g.tx.count) if self._weights is None else self._weights
        parts = []
        for k, log_attenuation in zip(self._node_k, self._node_log_attenuation):
            d = self.transducer.directivity(cos, k)
            gain = (self.settings.crosstalk_gain * self.transducer.source_amplitude * d * d
                    * np.exp(log_attenuation * r) / r * weight[:, None]
                    * np.exp(1j * (g.tx_phase_offsets[:, None] + g.rx_phase_offsets[None, :])))
            parts.append(Paths(gain[on].ravel(), delay[on].ravel(), channel[on].ravel()))
        return parts[0] if len(parts) == 1 else Subbands(tuple(parts), self.nodes)
