"""Parameters of surfel scanning (:class:`SurfelSettings`), read by every stage of
:mod:`mitsonar.recon.surfels`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mitsonar.recon.lines import SLOPE_SIGMA
from mitsonar.validation import (check_image_width, check_positive, check_positive_integer,
                                 check_range)

@dataclass(frozen=True)
class SurfelSettings:
    """Parameters of surfel scanning; pixel quantities refer to the working ``image_width``.

    Attributes:
        image_width: camera image width [pixels] (the 1600 x 1200 camera scaled down).
        spp: camera samples per pixel (8 with the camera's denoiser; FLD needs 32 or more on raw
            path-traced images).
        min_length: shortest line segment kept [pixels]; None: the paper's 50 px at 1600 px,
            scaled to ``image_width``.
        slope_sigma: scale of the shading-slope creases the line detector also finds [pixels]
            (:func:`~mitsonar.recon.lines.slope_strength`); None: steps of brightness only, as
            the paper's FLD.
        verify_threshold: largest distance of the measured centroid from the plane of the three
            other measured points for a surfel to be registered [m] (paper: 0.15 m).
        min_spread: smallest :func:`~mitsonar.recon.surfels.scanning.spread_ratio` of a
            registered surfel (package docstring).
        merge_angle: coarse gate: largest angle between the normals of one plane group [rad],
            widened by ``merge_sigmas`` standard errors of the two normals.
        merge_sigmas: surfels share a plane when all their points lie within this many expected
            errors (``range_sigma``, ``angle_sigma``) of it and one plane fits them no worse
            than a plane each beyond the chi^2 (3 degrees of freedom) quantile this many normal
            deviates cover (package docstring).
        max_normal_error: a plane group whose normal's standard error exceeds this [rad] (a
            small noisy surfel, or a few small ones close together) claims no image region: no
            plane is grown from it until check echoes pin it down (varied_4 with region surfels:
            two surfels of one pose, 6.5 deg, grew a plane 21 deg off the wall, 9 % within 2 cm).
        max_link_error: a surfel or group whose normal's standard error exceeds this [rad]
            links no others into one group (:func:`~mitsonar.recon.surfels.planes._links`).
        barrier_extension: how far each segment is extended at both ends when drawn as a
            region barrier [pixels] (closes small gaps at junctions).
        barrier_width: thickness of the drawn barriers [pixels].
        junction_gap: barrier segments that stop at most this short of a junction with another
            segment are extended to it [pixels] (:func:`~mitsonar.recon.lines.close_junctions`).
        bridge_gap: collinear pieces of one line with gaps up to this fraction of the image
            width between them are bridged in the barriers, and a bridged line is extended to
            the next line or the crop's border by up to its own length, at most this fraction
            of the width (:func:`~mitsonar.recon.surfels.growing.barriers`).
        stride: grid step of the back-projected pixels [pixels].
        max_range: farthest back-projected map point from the camera [m]; None: the sonar's
            ``SonarConfig.max_range``, beyond which no check ping can confirm or refute a grown
            plane (a floor grown through a doorway onto the wall behind it reached 10 m); no
            limit where planes are grown without a sonar
            (:func:`~mitsonar.recon.surfels.map.build_map` called directly).
        below_floor: how far below the floor the robot drives on (z = 0 of the world frame, the
            plane of its wheels, where ``Pose.sensor_on_robot`` puts them) a back-projected map
            point may lie [m]; None: no limit. The camera sees nothing through the floor, so a
            plane grown there came through a crease the line detector missed (varied_9: a wall's
            plane grown over the floor pixels below a faint wall-floor crease, down to 0.97 m
            under the floor, 22 % of the map). The margin keeps the map's own floor plane,
            measured a few cm off, whole.
        shadow_offset: distance across a segment at which its two sides are sampled [pixels].
        remove_shadows: remove shadow lines (segments with one plane on both sides) and the
            surfels built on them; False keeps every segment (for comparison).
        max_iterations: cap on the regroup/refit iterations.
        seed: seeds the images and the pings.
        fill_spacing: angular spacing of the fill pings inside a registered surfel [rad] (about
            one beam footprint, 5 deg: neighbouring footprints barely overlap, so their range
            errors are nearly independent).
        fill_margin: smallest angle between a fill ping and the surfel's two line segments [rad]
            (the footprint's half-width, 2.5 deg, plus 0.5 deg for the line's pixel error).
        max_fill: most fill pings per surfel (0: the paper's four pings only).
        refine: refine the planes jointly with the crease constraints (package docstring).
        check_spacing: angular spacing of the check pings over the grown planes [rad] (0: no
            check pings, planes fill their claimed regions unchecked as in the paper).
        region_surfels: every region of a pose's image that no plane claims gets a candidate
            surfel of its own, pinged and verified like the others
            (:func:`~mitsonar.recon.surfels.growing.region_triangles`); False (default): only
            the paper's triangles between segments meeting at a junction. Off by default: it
            doubles room_glass's completeness over the first 8 s at the same accuracy, but on
            generated rooms a floor plane of two region surfels seen at grazing incidence was
            tilted 0.8 deg and 2 cm low (varied_9: 95.8 -> 57.9 % within 2 cm).
        ground: hold to the floor the robot drives on (z = 0 of the world frame, where its
            wheels are) every plane group whose surfel, fill and check echoes fit it as well as
            their own plane (:func:`~mitsonar.recon.surfels.planes.on_ground`): a floor fitted
            to echoes at grazing incidence and pulled by the image creases came out tilted
            (varied_9, region surfels: 0.6 deg, 62 % of its points within 2 cm, its echoes
            within 2 mm of the floor). The check echoes join the test only with ``refine``,
            which gathers them. The surfels whose own echoes fit the ground are grouped
            among themselves, apart from the others (a small one would join planes through far
            surfels that its extent cannot refute). False: every plane as fitted, every surfel
            grouped alike.
        min_refutations: a plane group is refuted (its surfels dropped) when at least this many
            check echoes in the regions it claims lie on none of their planes and they outnumber
            the echoes on it (:func:`~mitsonar.recon.surfels.map.refuted_groups`).
        fit_significance: a plane group is also refuted when the check echoes on its plane
            scatter about it more than their expected errors allow: the p-value of their chi^2
            (sum of squared distances in expected errors, a degree of freedom per echo) is
            below this (:func:`~mitsonar.recon.surfels.map.refuted_groups`); 0: no such test.
        range_sigma, angle_sigma: a point at range r seen at incidence theta is expected off
            its plane by sqrt(range_sigma^2 + (r tan(angle_sigma) sin(theta))^2) [m]: the echo's
            range belongs to a direction up to a fraction of the footprint off the beam axis
            (1 deg: 2-3.5 cm measured at 2-2.5 m and 20-75 deg incidence), plus the timing error.
        crease_sigma: expected error of a detected line [pixels].
        crease_gate: crease constraints whose sonar-only residual exceeds this [pixels] are not
            used (an occlusion edge or a segment between two unrelated planes).
    """

    image_width: int = 400
    spp: int = 8
    min_length: float | None = None
    slope_sigma: float | None = SLOPE_SIGMA
    verify_threshold: float = 0.15
    min_spread: float = 0.5
    merge_angle: float = np.radians(10.0)
    merge_sigmas: float = 3.0
    max_normal_error: float = np.radians(5.0)
    max_link_error: float = np.radians(20.0)
    barrier_extension: float = 4.0
    barrier_width: int = 3
    junction_gap: float = 25.0
    bridge_gap: float = 0.25
    stride: int = 2
    max_range: float | None = None
    below_floor: float | None = 0.05
    shadow_offset: float = 5.0
    remove_shadows: bool = True
    max_iterations: int = 20
    seed: int = 0
    fill_spacing: float = np.radians(5.0)
    fill_margin: float = np.radians(3.0)
    max_fill: int = 8
    refine: bool = True
    check_spacing: float = np.radians(5.0)
    region_surfels: bool = False
    ground: bool = True
    min_refutations: int = 3
    fit_significance: float = 1e-3
    range_sigma: float = 0.005
    angle_sigma: float = np.radians(1.0)
    crease_sigma: float = 1.0
    crease_gate: float = 30.0

    def __post_init__(self):
        if int(self.max_fill) != self.max_fill or self.max_fill < 0:
            raise ValueError(
                f"SurfelSettings.max_fill must be an integer >= 0, got {self.max_fill}")
        for name in ("fill_spacing", "fill_margin", "range_sigma", "angle_sigma", "crease_sigma",
                     "crease_gate"):
            check_positive(f"SurfelSettings.{name}", getattr(self, name))
        check_image_width("SurfelSettings.image_width", self.image_width)
        for name in ("spp", "barrier_width", "stride", "max_iterations", "min_refutations"):
            check_positive_integer(f"SurfelSettings.{name}", getattr(self, name))
        if self.min_length is not None:
            check_positive("SurfelSettings.min_length [pixels]", self.min_length)
        if self.slope_sigma is not None:
            check_positive("SurfelSettings.slope_sigma [pixels]", self.slope_sigma)
        check_positive("SurfelSettings.verify_threshold [m]", self.verify_threshold)
        check_range("SurfelSettings.min_spread", self.min_spread, 0.0, 1.0)
        check_range("SurfelSettings.fit_significance", self.fit_significance, 0.0, 1.0)
        check_range("SurfelSettings.merge_angle [rad]", self.merge_angle, 0.0, np.pi / 2)
        check_positive("SurfelSettings.merge_sigmas", self.merge_sigmas)
        check_range("SurfelSettings.max_normal_error [rad]", self.max_normal_error, 0.0, np.pi / 2)
        check_range("SurfelSettings.max_link_error [rad]", self.max_link_error, 0.0, np.pi / 2)
        check_range("SurfelSettings.barrier_extension [pixels]", self.barrier_extension, 0, np.inf)
        check_range("SurfelSettings.junction_gap [pixels]", self.junction_gap, 0, np.inf)
        check_range("SurfelSettings.bridge_gap", self.bridge_gap, 0, np.inf)
        check_range("SurfelSettings.check_spacing [rad]", self.check_spacing, 0, np.pi / 2)
        if self.max_range is not None:
            check_positive("SurfelSettings.max_range [m]", self.max_range)
        if self.below_floor is not None:
            check_range("SurfelSettings.below_floor [m]", self.below_floor, 0, np.inf)
        check_positive("SurfelSettings.shadow_offset [pixels]", self.shadow_offset)

    @property
    def segment_min_length(self) -> float:
        """Shortest segment kept at ``image_width`` [pixels]."""
        if self.min_length is not None:
            return float(self.min_length)
        return 50.0 * self.image_width / 1600.0
