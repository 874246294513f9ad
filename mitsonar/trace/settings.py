"""The acoustic trace's settings: the ray grid and its refinement, the scattering model, the
transmit weights and the frequency nodes (:class:`TraceSettings`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mitsonar.validation import check_finite, check_positive, check_range


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
        shared_ray_step: angle between neighbouring rays of a trace shared by several beams
            (:meth:`AcousticTracer.trace_union`) outside the beams' main lobes [rad]; within
            ``refine_radius`` of a beam axis ``refine`` times denser. The default, 2 deg and
            0.67 deg in the main lobes, is as dense as a beam's own grid (2.5 deg outside its
            main lobe, 0.43-0.6 deg within 4 deg of its axis).
        max_merge: largest block of max_merge x max_merge neighbouring cells (a power of 2) merged
            into one patch where the patch criterion allows (:mod:`mitsonar.trace.density`:
            ray density that follows range and footprint); 1 (the default) keeps the fixed
            grid. Opt-in: it moves a few borderline decisions (the merged scatterers sit at
            their block's centre) and bought no measurable time (docs/performance.md).
        max_patch_phase: the patch criterion: the largest phase error of the patch model at a
            patch's corners at the band's top frequency [rad].
        subbands: frequency nodes at which element patterns, patch integrals and air
            absorption are evaluated, spread evenly over the band (the wider of the drive's and
            the transducers' bandwidths), the paths' gains interpolated linearly between them
            (:mod:`~mitsonar.trace.subbands`); 1: once, at the drive's centre, which holds over
            narrow bands (the TCT40's 2 kHz; across 30-50 kHz a rigid wall's echo spectrum is
            then +2.2/-2.6 dB off the image source at the band's edges, two nodes bring it
            within 0.4 dB, docs/physics.md). "auto" (the default): the fewest that keep every
            echo spectrum within ``subband_tolerance`` (:func:`frequency_gains`, resolved by
            :meth:`SonarConfig.resolved_trace <mitsonar.sensors.sonar.SonarConfig.resolved_trace>`):
            1 for tone bursts, 2 for a 30-50 kHz sweep, 3-4 for 20-80 kHz. Costs about that
            many times the synthesis.
        subband_tolerance: the automatic choice's largest RMS error of an echo's spectrum,
            relative to an echo from broadside (0.05: -26 dB).
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
    shared_ray_step: float = np.radians(2.0)
    max_merge: int = 1
    max_patch_phase: float = np.pi / 8
    subbands: int | str = "auto"
    subband_tolerance: float = 0.05

    @property
    def traced_half_angle(self) -> float:
        """Half-angle about the beam axis of what is traced [rad]: the cone (physical model) or
        the extent of the reflector grid (paper model)."""
        if self.model == "physical":
            return self.cone_half_angle
        return float(np.arctan(np.tan(self.paper_spacing) * (self.paper_grid - 1) / 2))

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
        check_range("TraceSettings.shared_ray_step [rad]", self.shared_ray_step, 1e-3, 0.2)
        if self.max_merge not in (1, 2, 4, 8, 16):
            raise ValueError(f"TraceSettings.max_merge must be 1, 2, 4, 8 or 16, "
                             f"got {self.max_merge}")
        check_range("TraceSettings.max_patch_phase [rad]", self.max_patch_phase, 1e-3, np.pi)
        if self.subbands != "auto" and (isinstance(self.subbands, str) or int(
                self.subbands) != self.subbands or not 1 <= self.subbands <= 16):
            raise ValueError(f"TraceSettings.subbands must be 'auto' or an integer in 1..16, "
                             f"got {self.subbands!r}")
        check_range("TraceSettings.subband_tolerance", self.subband_tolerance, 1e-4, 1.0)
        if self.transmit_weights is not None:
            weights = tuple(float(w) for w in np.ravel(self.transmit_weights))
            check_finite("TraceSettings.transmit_weights", np.array(weights))
            if not any(weights):
                raise ValueError("TraceSettings.transmit_weights: no element transmits (all 0)")
            object.__setattr__(self, "transmit_weights", weights)
