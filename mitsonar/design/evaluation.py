"""Exact beam evaluation of a transmit/receive layout pair, and what a good layout is.

:class:`BeamCriteria` holds the field of view, the main-lobe exclusion, the 3 dB width target, the
frequency, the air and the element; :func:`evaluate_layout` steers both one-way patterns over the
field of view and returns their PSLL and 3 dB widths (:class:`LayoutMetrics`, dB and radians);
:func:`uniform_pair` is the uniform 5x5 reference the design starts from and is compared with.
The genetic algorithm (:mod:`mitsonar.design.genetic`) searches with a faster lattice objective;
the numbers it reports come from here.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from mitsonar.physics.array import ArrayLayout
from mitsonar.physics.beampattern import (cut_directions, fov_grid, main_lobe_widths,
                                          one_way_pattern, pair_side_lobe_levels)
from mitsonar.physics.medium import Medium
from mitsonar.physics.transducer import Transducer
from mitsonar.validation import check_positive, check_range


@dataclass(frozen=True)
class BeamCriteria:
    """What a good layout is, and the grids the exact evaluation uses. SI units, radians.

    Attributes:
        fov_horizontal: full horizontal field of view [rad].
        fov_vertical: full vertical field of view [rad].
        main_lobe_radius: angular radius of the main lobe excluded from the side-lobe search
            [rad] (6 deg: about the first-null radius of a filled aperture whose 3 dB width is
            5 deg, 1.2x that width).
        target_width: broadside 3 dB width aimed at [rad].
        width_tolerance: half-width of the accepted band around ``target_width`` [rad].
        frequency: design frequency [Hz].
        medium: air (sets the wavelength).
        transducer: element model (piston directivity).
        direction_step: grid step of the directions searched for side lobes, exact evaluation [rad].
        steering_step: grid step of the steering directions over the field of view, exact
            evaluation [rad] (edges included).
    """

    fov_horizontal: float = np.radians(60.0)
    fov_vertical: float = np.radians(40.0)
    main_lobe_radius: float = np.radians(6.0)
    target_width: float = np.radians(5.0)
    width_tolerance: float = np.radians(0.5)
    frequency: float = 40_000.0
    medium: Medium = field(default_factory=Medium)
    transducer: Transducer = field(default_factory=Transducer)
    direction_step: float = np.radians(0.25)
    steering_step: float = np.radians(2.5)

    def __post_init__(self):
        for name in ("fov_horizontal", "fov_vertical"):
            check_range(f"BeamCriteria.{name} [rad]", getattr(self, name), 1e-3, np.radians(170.0))
        check_range("BeamCriteria.main_lobe_radius [rad]", self.main_lobe_radius, 1e-3,
                    np.radians(45))
        check_range("BeamCriteria.target_width [rad]", self.target_width, 1e-3, np.radians(45))
        check_range("BeamCriteria.width_tolerance [rad]", self.width_tolerance, 0.0,
                    self.target_width)
        check_positive("BeamCriteria.frequency [Hz]", self.frequency)
        check_range("BeamCriteria.direction_step [rad]", self.direction_step, 1e-4, np.radians(5))
        check_range("BeamCriteria.steering_step [rad]", self.steering_step, 1e-3, np.radians(30))

    @property
    def wavenumber(self) -> float:
        """k [rad/m] at the design frequency."""
        return float(self.medium.wavenumber(self.frequency))

    @property
    def wavelength(self) -> float:
        """lambda [m] at the design frequency."""
        return self.medium.speed_of_sound / self.frequency

    def to_dict(self) -> dict:
        """Criteria for the JSON record, keys carrying their unit (``frequency_hz``)."""
        return named_units(asdict(self), {"fov_horizontal": "rad", "fov_vertical": "rad",
                                           "main_lobe_radius": "rad", "target_width": "rad",
                                           "width_tolerance": "rad", "frequency": "Hz",
                                           "direction_step": "rad", "steering_step": "rad"})


def named_units(data: dict, units: dict) -> dict:
    """Rename keys to carry their unit (``frequency`` -> ``frequency_hz``) for the JSON record."""
    out = {}
    for key, value in data.items():
        if isinstance(value, dict):
            value = {k: float(v) for k, v in value.items()}
        elif isinstance(value, (float, np.floating)):
            value = float(value)
        out[f"{key}_{units[key]}" if key in units else key] = value
    return out


def uniform_pair(pitch: float = 0.025) -> np.ndarray:
    """(2, 25, 2) the uniform 5x5 transmit and receive layouts (each relative to its origin) [m]."""
    grid = ArrayLayout.uniform(5, pitch).positions
    return np.stack([grid, grid])


@dataclass(frozen=True)
class LayoutMetrics:
    """Exact beam metrics of a transmit/receive pair over the field of view.

    Attributes:
        steering_horizontal: (H,) horizontal angles of the steering grid [rad].
        steering_vertical: (V,) vertical angles of the steering grid [rad].
        psll_db: name ('tx', 'rx', 'two_way') -> (V, H) PSLL of the beam steered there [dB].
        width: name -> (V, H, 2) 3 dB widths (horizontal, vertical cut) of that beam [rad].
        broadside_width: name -> (2,) broadside 3 dB widths (horizontal, vertical) [rad], from a
            0.01 deg cut.
    """

    steering_horizontal: np.ndarray
    steering_vertical: np.ndarray
    psll_db: dict
    width: dict
    broadside_width: dict

    def worst_psll_db(self, name: str) -> float:
        """Worst PSLL over the steering grid [dB] of 'tx', 'rx', 'two_way' or 'one_way' (the
        worse of transmit and receive)."""
        if name == "one_way":
            return max(self.worst_psll_db("tx"), self.worst_psll_db("rx"))
        return float(np.max(self.psll_db[name]))

    def broadside_psll_db(self, name: str) -> float:
        """PSLL of the broadside beam [dB]."""
        iv = int(np.argmin(np.abs(self.steering_vertical)))
        ih = int(np.argmin(np.abs(self.steering_horizontal)))
        return float(self.psll_db[name][iv, ih])

    def to_dict(self) -> dict:
        """Summary for the JSON record (dB and degrees, labelled)."""
        out = {"worst_psll_db": {n: round(self.worst_psll_db(n), 2)
                                 for n in ("tx", "rx", "two_way", "one_way")},
               "broadside_psll_db": {n: round(self.broadside_psll_db(n), 2)
                                     for n in ("tx", "rx", "two_way")},
               "broadside_width_3db_deg": {n: {"horizontal": round(float(np.degrees(w[0])), 3),
                                               "vertical": round(float(np.degrees(w[1])), 3)}
                                           for n, w in self.broadside_width.items()},
               "max_width_3db_over_fov_deg": {n: (round(float(np.degrees(np.nanmax(w))), 3)
                                                  if np.any(np.isfinite(w)) else None)
                                              for n, w in self.width.items()}}
        return out


def evaluate_layout(tx_positions, rx_positions, criteria: BeamCriteria = BeamCriteria(),
                    widths_over_fov: bool = True) -> LayoutMetrics:
    """Exact PSLL and 3 dB widths of a transmit/receive pair, steered over the field of view.

    Steering directions: a grid of ``criteria.steering_step`` over the field of view (edges
    included). Side lobes are searched over a grid of ``criteria.direction_step`` over the field
    of view. Widths: horizontal and vertical cuts through each steered beam (+-12 deg, 0.1 deg
    samples; skipped, NaN, when ``widths_over_fov`` is False), and 0.01 deg cuts at broadside.
    """
    c = criteria
    k = c.wavenumber
    h, v, steers = fov_grid(c.fov_horizontal, c.fov_vertical, c.steering_step)
    _, _, dirs = fov_grid(c.fov_horizontal, c.fov_vertical, c.direction_step)
    flat = steers.reshape(-1, 3)
    ratio = pair_side_lobe_levels(tx_positions, rx_positions, flat, dirs.reshape(-1, 3),
                                  c.transducer, k, c.main_lobe_radius)
    psll = {n: 20 * np.log10(np.maximum(r, 1e-12)).reshape(len(v), len(h))
            for n, r in ratio.items()}

    def widths(steer, half_span, count):
        angles, u = cut_directions(steer, half_span, count)
        s4 = steer[:, None, None, :]
        tx = one_way_pattern(tx_positions, s4, u, c.transducer, k)
        rx = one_way_pattern(rx_positions, s4, u, c.transducer, k)
        return {n: main_lobe_widths(angles, p)
                for n, p in (("tx", tx), ("rx", rx), ("two_way", tx * rx))}

    if widths_over_fov:
        width = {n: w.reshape(len(v), len(h), 2)
                 for n, w in widths(flat, np.radians(12.0), 241).items()}
    else:
        width = {n: np.full((len(v), len(h), 2), np.nan) for n in psll}
    broad = {n: w[0]
             for n, w in widths(np.array([[0.0, 0.0, 1.0]]), np.radians(10.0), 2001).items()}
    return LayoutMetrics(h, v, psll, width, broad)
