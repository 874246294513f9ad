"""Sparse array design by a genetic algorithm: the shipped 5x5 transmit and receive layouts.

The paper (III-B) starts from a uniform 5x5 array in a 10 cm x 10 cm aperture and moves the
elements with a genetic algorithm to minimise the peak side-lobe level (PSLL) inside the field of
view. A uniform 5x5 layout at 2.5 cm pitch (about 2.9 wavelengths at 40 kHz) has full grating
lobes at sin(theta) = lambda / d = 0.34 (20 deg) from the beam, inside a 60 x 40 deg field of view.

Here the transmit and the receive layout are designed together, because they are interleaved on
one board (see :mod:`mitsonar.physics.array`): the receive layout sits ``baseline`` to the right of the
transmit origin, each layout's 25 centres stay within +-5 cm of its own origin, and no two of the
50 elements come closer than the 10 mm can diameter. The genome is the 50 element centres.

Objective (minimised, dB):

    max(PSLL_tx, PSLL_rx) + width_penalty * max(0, max_k |w_k - w_target| - w_tolerance)

* PSLL_tx, PSLL_rx: the worst one-way PSLL of each array over steering directions covering the
  field of view (every other point of the direction-cosine lattice below, about 1.2 deg apart),
  side lobes searched at all lattice directions inside the field of view, element directivity
  included (the main-lobe disc is :attr:`BeamCriteria.main_lobe_radius`, see
  :mod:`mitsonar.physics.beampattern`).
* w_k: the four broadside 3 dB widths (transmit and receive, horizontal and vertical cuts) of the
  one-way patterns; the paper's main lobe is about 5 deg wide.

Why one-way and not two-way: the echo sees the two-way pattern P_tx P_rx, and its PSLL is at most
PSLL_tx + PSLL_rx in dB, so bounding both one-way levels bounds the two-way level too (it is
reported alongside). Optimising the two-way pattern alone would let the two arrays trade side lobes
(a transmit side lobe hidden in a receive null); that holds only for exactly this pairing and
steering, and it leaves strong one-way side lobes: the transmit array alone lights the scene, so a
strong transmit side lobe still puts energy on off-beam reflectors (multipath, cross-talk between
the OFDM codes steered elsewhere) and the receive array alone picks up whatever arrives there.
This is also the paper's criterion (the one-way pattern of its Fig. 3).

Fast objective. The array factor depends only on u - u_s (direction cosines), so on a lattice of
step ``lattice_step`` the worst PSLL over every (steering, direction) pair reduces to one weighted
maximum over the difference lattice: max_q |AF(q)| W(q), where W(q) is the largest directivity
ratio D(u) / D(u_s) over the pairs with u - u_s = q outside the main lobe (precomputed once). The
array factor on that lattice is one matrix product per layout (the phase separates in x and y),
done by ``einsum`` in single precision: many small products through a multi-threaded BLAS stall on
a busy machine. The reported numbers come from the exact evaluation (:func:`evaluate_layout`) on
finer grids and exact steering directions; the lattice objective agrees with it to a few tenths
of a dB.

GA: population of layouts, seeded from the uniform 5x5 pair plus Gaussian jitter (the uniform pair
itself is kept as one individual); elitism; tournament selection; per-element uniform crossover;
Gaussian moves whose size shrinks geometrically over the generations and rare relocations to a
random point of the aperture; a repair step pushes elements that are too close apart (and any child
that stays infeasible is replaced by its parent), so every individual meets the aperture and the
joint spacing. All randomness comes from one ``numpy.random.Generator`` seeded by ``seed``: the same
seed and settings give the same layout (bit for bit on one machine and NumPy build; another CPU's
floating-point rounding may steer the search elsewhere, which is why the result is shipped as data).

Usage::

    mitsonar array design --seed 1            # writes mitsonar/physics/array_layout.json
    mitsonar array plot --out out/array       # figures and tables (mitsonar.design.figures)

    from mitsonar.design.array_design import GASettings, design_arrays, evaluate_layout
    result = design_arrays(GASettings(seed=1))
    metrics = evaluate_layout(result.tx.positions, result.rx.positions)
    metrics.worst_psll_db("one_way"), metrics.broadside_width["tx"]   # dB, rad
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from mitsonar.physics.array import APERTURE, LAYOUT_FILE, MIN_SPACING, ArrayGeometry, ArrayLayout
from mitsonar.physics.beampattern import (cut_directions, fov_grid, in_fov, main_lobe_widths, one_way_pattern,
                          pair_side_lobe_levels)
from mitsonar.physics.medium import Medium
from mitsonar.physics.transducer import Transducer
from mitsonar.validation import check_positive, check_range

#: Distance from the transmit to the receive array origin along sensor +x [m] (half the uniform
#: pitch: the two uniform grids interleave 12.5 mm apart).
DEFAULT_BASELINE = 0.0125
#: Positions are stored rounded to this [m] (1 um).
POSITION_RESOLUTION = 1e-6
#: Elements per layout (5 x 5).
ELEMENTS = 25


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
        check_range("BeamCriteria.main_lobe_radius [rad]", self.main_lobe_radius, 1e-3, np.radians(45))
        check_range("BeamCriteria.target_width [rad]", self.target_width, 1e-3, np.radians(45))
        check_range("BeamCriteria.width_tolerance [rad]", self.width_tolerance, 0.0, self.target_width)
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
        return _named_units(asdict(self), {"fov_horizontal": "rad", "fov_vertical": "rad",
                                           "main_lobe_radius": "rad", "target_width": "rad",
                                           "width_tolerance": "rad", "frequency": "Hz",
                                           "direction_step": "rad", "steering_step": "rad"})


@dataclass(frozen=True)
class GASettings:
    """Genetic-algorithm settings. Lengths in metres.

    Attributes:
        seed: seed of the numpy Generator that drives every random choice.
        population: layouts per generation.
        generations: generations run.
        elite: best layouts copied unchanged into the next generation.
        tournament: layouts compared in each tournament selection.
        crossover_probability: probability that a child mixes two parents (per-element choice).
        mutation_probability: probability that an element moves, per element and child.
        mutation_start: standard deviation of a move in the first generation [m].
        mutation_end: standard deviation of a move in the last generation [m] (geometric decay).
        relocate_probability: probability that an element jumps to a random aperture point.
        init_jitter: standard deviation of the jitter added to the uniform grid at start [m].
        lattice_step: direction-cosine step of the fast objective's lattice (0.01 ~ 0.57 deg).
        steering_stride: every ``steering_stride``-th lattice point is a steering direction.
        width_penalty: objective penalty per radian of broadside 3 dB width outside the band
            [dB/rad] (573 dB/rad = 10 dB per degree).
        spacing_margin: extra spacing kept above MIN_SPACING, so rounding cannot break it [m].
        repair_iterations: relaxation sweeps of the spacing repair.
    """

    seed: int = 1
    population: int = 96
    generations: int = 400
    elite: int = 4
    tournament: int = 3
    crossover_probability: float = 0.7
    mutation_probability: float = 0.12
    mutation_start: float = 3e-3
    mutation_end: float = 0.2e-3
    relocate_probability: float = 0.005
    init_jitter: float = 4e-3
    lattice_step: float = 0.01
    steering_stride: int = 2
    width_penalty: float = 10.0 / np.radians(1.0)
    spacing_margin: float = 20e-6
    repair_iterations: int = 30

    def __post_init__(self):
        for name in ("seed", "population", "generations", "elite", "tournament", "steering_stride",
                     "repair_iterations"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                raise ValueError(f"GASettings.{name} must be an integer, got {value!r}")
        if self.seed < 0:
            raise ValueError(f"GASettings.seed must be >= 0, got {self.seed}")
        if self.population < 4:
            raise ValueError(f"GASettings.population must be >= 4, got {self.population}")
        if self.generations < 1:
            raise ValueError(f"GASettings.generations must be >= 1, got {self.generations}")
        if not 1 <= self.elite < self.population:
            raise ValueError(f"GASettings.elite must lie in [1, population), got {self.elite}")
        if not 1 <= self.tournament <= self.population:
            raise ValueError(f"GASettings.tournament must lie in [1, population], got {self.tournament}")
        if self.steering_stride < 1 or self.repair_iterations < 1:
            raise ValueError("GASettings.steering_stride and repair_iterations must be >= 1")
        for name in ("crossover_probability", "mutation_probability", "relocate_probability"):
            check_range(f"GASettings.{name}", getattr(self, name), 0.0, 1.0)
        for name in ("mutation_start", "mutation_end", "init_jitter"):
            check_range(f"GASettings.{name} [m]", getattr(self, name), 1e-7, APERTURE)
        check_range("GASettings.lattice_step", self.lattice_step, 1e-3, 0.1)
        check_range("GASettings.width_penalty [dB/rad]", self.width_penalty, 0.0, 1e6)
        check_range("GASettings.spacing_margin [m]", self.spacing_margin, 0.0, 1e-3)

    def to_dict(self) -> dict:
        """Settings for the JSON record, keys carrying their unit (``mutation_start_m``)."""
        return _named_units(asdict(self), _GA_UNITS)

    @classmethod
    def from_dict(cls, data: dict) -> "GASettings":
        """Inverse of :meth:`to_dict` (re-run a recorded design)."""
        suffixed = {f"{k}_{u}": k for k, u in _GA_UNITS.items()}
        return cls(**{suffixed.get(k, k): v for k, v in data.items()})


_GA_UNITS = {"mutation_start": "m", "mutation_end": "m", "init_jitter": "m",
             "width_penalty": "db_per_rad", "spacing_margin": "m"}


def _named_units(data: dict, units: dict) -> dict:
    """Rename keys to carry their unit (``frequency`` -> ``frequency_hz``) for the JSON record."""
    out = {}
    for key, value in data.items():
        if isinstance(value, dict):
            value = {k: float(v) for k, v in value.items()}
        elif isinstance(value, (float, np.floating)):
            value = float(value)
        out[f"{key}_{units[key]}" if key in units else key] = value
    return out


# ---- constraints ---------------------------------------------------------------------------------

def uniform_pair(pitch: float = 0.025) -> np.ndarray:
    """(2, 25, 2) the uniform 5x5 transmit and receive layouts (each relative to its origin) [m]."""
    grid = ArrayLayout.uniform(5, pitch).positions
    return np.stack([grid, grid])


def _offsets(baseline: float) -> np.ndarray:
    """(2, 1, 2) origin of the transmit and the receive layout in the sensor plane [m]."""
    return np.array([[[0.0, 0.0]], [[baseline, 0.0]]])


def min_joint_spacing(pairs, baseline: float) -> np.ndarray:
    """Smallest distance [m] between any two of the 50 elements of (..., 2, 25, 2) layout pairs."""
    x = np.asarray(pairs, dtype=float)
    y = (x + _offsets(baseline)).reshape(*x.shape[:-3], -1, 2)
    d = np.linalg.norm(y[..., :, None, :] - y[..., None, :, :], axis=-1)
    d = d + np.where(np.eye(y.shape[-2], dtype=bool), np.inf, 0.0)
    return d.min(axis=(-2, -1))


def _repair(pairs: np.ndarray, baseline: float, spacing: float, iterations: int):
    """Push apart elements closer than ``spacing`` and clip to the aperture, for a batch.

    Each sweep moves both elements of every pair closer than 1.02 ``spacing`` apart along their
    joining line, each by 0.7 of the shortfall (a relaxation over all pairs at once; aiming 2 %
    beyond the limit makes crowded layouts settle in a few sweeps instead of creeping towards
    it), for the layouts that still break the spacing. Returns the repaired (C, 2, 25, 2)
    positions and a (C,) flag: meets spacing and aperture.
    """
    half = APERTURE / 2
    x = np.clip(np.asarray(pairs, dtype=float), -half, half)
    n = 2 * x.shape[2]
    offsets = _offsets(baseline)
    eye = np.eye(n, dtype=bool)
    # Coincident elements get a fixed, antisymmetric push direction (deterministic).
    fallback = np.where(np.arange(n)[:, None] > np.arange(n)[None, :], 1.0, -1.0)
    active = np.arange(len(x))
    for _ in range(iterations):  # relaxation sweeps, each over all pairs of the active layouts
        y = (x[active] + offsets).reshape(len(active), n, 2)
        dx = y[:, :, None, 0] - y[:, None, :, 0]
        dy = y[:, :, None, 1] - y[:, None, :, 1]
        dist = np.sqrt(dx * dx + dy * dy)
        bad = np.where(eye, np.inf, dist).min(axis=(1, 2)) < spacing
        if not bad.any():
            break
        active, dist, dx, dy = active[bad], dist[bad], dx[bad], dy[bad]
        shortfall = np.where(eye, 0.0, np.clip(1.02 * spacing - dist, 0.0, None))
        far = dist > 1e-12
        safe = np.where(far, dist, 1.0)
        ux = np.where(far, dx / safe, fallback)
        uy = np.where(far, dy / safe, 0.0)
        push = 0.7 * np.stack([(shortfall * ux).sum(-1), (shortfall * uy).sum(-1)], axis=-1)
        x[active] = np.clip(x[active] + push.reshape(-1, *x.shape[1:]), -half, half)
    ok = min_joint_spacing(x, baseline) >= spacing - 1e-12
    return x, ok


# ---- fast objective ------------------------------------------------------------------------------

class LatticeObjective:
    """Worst one-way PSLL over the field of view and broadside widths, for many layouts at once.

    See the module docstring. Build once per (criteria, settings); call :meth:`evaluate`.
    """

    def __init__(self, criteria: BeamCriteria, settings: GASettings):
        self.criteria = criteria
        self.settings = settings
        k = criteria.wavenumber
        self.k = k
        step = settings.lattice_step
        ni = int(np.ceil(np.sin(criteria.fov_horizontal / 2) / step))
        nj = int(np.ceil(np.sin(criteria.fov_vertical / 2) / step))
        ii, jj = np.meshgrid(np.arange(-ni, ni + 1), np.arange(-nj, nj + 1), indexing="ij")
        ux, uy = ii * step, jj * step
        r2 = ux**2 + uy**2
        front = r2 < 1.0
        u = np.stack([ux, uy, np.sqrt(np.clip(1.0 - r2, 0.0, None))], axis=-1)
        inside = front & in_fov(u, criteria.fov_horizontal, criteria.fov_vertical)
        d = criteria.transducer.directivity(u[..., 2], k)
        m_i, m_j, m_d = ii[inside], jj[inside], d[inside]
        stride = settings.steering_stride
        steer = inside & (ii % stride == 0) & (jj % stride == 0)
        s_i, s_j, s_d = ii[steer], jj[steer], d[steer]
        # Weight of each lattice difference q = u - u_s: max over pairs of D(u) / D(u_s).
        shape = (4 * ni + 1, 4 * nj + 1)
        qa = (m_i[None, :] - s_i[:, None] + 2 * ni).ravel()
        qb = (m_j[None, :] - s_j[:, None] + 2 * nj).ravel()
        ratio = (m_d[None, :] / s_d[:, None]).ravel()
        weight = np.zeros(shape[0] * shape[1])
        np.maximum.at(weight, qa * shape[1] + qb, ratio)
        weight = weight.reshape(shape)
        weight = np.maximum(weight, weight[::-1, ::-1])  # |AF(q)| = |AF(-q)|: fold
        da = np.arange(-2 * ni, 2 * ni + 1) * step
        db = np.arange(-2 * nj, 2 * nj + 1) * step
        weight[(da[:, None] ** 2 + db[None, :] ** 2) < np.sin(criteria.main_lobe_radius) ** 2] = 0.0
        self.weight = weight[2 * ni:].astype(np.float32)  # keep q_x >= 0
        self.dx = da[2 * ni:]
        self.dy = db
        self.steering_count = int(steer.sum())
        self.direction_count = int(inside.sum())
        # Broadside cuts for the 3 dB width: sin(angle) from 0 to sin(target), 0.05 deg steps, so
        # widths up to twice the target are measured (wider ones count as twice the target).
        t_max = np.sin(criteria.target_width)
        self.t = np.linspace(0.0, t_max, int(np.ceil(np.degrees(criteria.target_width) / 0.05)) + 1)
        self.t_directivity = criteria.transducer.directivity(np.sqrt(1 - self.t**2), k)

    def array_psll(self, positions) -> np.ndarray:
        """Worst one-way PSLL (ratio) over the lattice for layouts (..., N, 2) -> (...,)."""
        p = np.asarray(positions, dtype=float)
        lead = p.shape[:-2]
        p = p.reshape(-1, p.shape[-2], 2)
        ax = self.k * self.dx[None, :, None] * p[:, None, :, 0]  # (B, A, N) phase along x
        ay = self.k * p[:, :, 1, None] * self.dy[None, None, :]  # (B, N, C) phase along y
        # sum_n e^{j(ax + ay)} in real arithmetic; einsum, not BLAS: many small products are
        # slow with a multi-threaded BLAS on a busy machine, and this stays single-threaded.
        # Single precision: |AF| >= 1e-3 matters, float32 sums of 25 unit phasors are good to 1e-6.
        left = np.concatenate([np.cos(ax), np.sin(ax)], axis=-1).astype(np.float32)  # (B, A, 2N)
        cy, sy = np.cos(ay).astype(np.float32), np.sin(ay).astype(np.float32)
        right = np.stack([np.concatenate([cy, -sy], axis=1), np.concatenate([sy, cy], axis=1)])
        re_im = np.einsum("ban,kbnc->kbac", left, right)
        af = np.sqrt(re_im[0] ** 2 + re_im[1] ** 2) / p.shape[1]
        return (af * self.weight).max(axis=(1, 2)).astype(float).reshape(lead)

    def broadside_widths(self, positions) -> np.ndarray:
        """One-way broadside 3 dB widths [rad] (..., 2) (horizontal, vertical) of layouts (..., N, 2).

        Exact cuts (u_x = sin h at v = 0, u_y = sin v at h = 0), linear interpolation of the
        half-power crossing; 2 asin(t_max) when the lobe does not drop that far.
        """
        p = np.asarray(positions, dtype=float)
        phase = self.k * p[..., None, :, :] * self.t[:, None, None]  # (..., T, N, 2)
        af = np.abs(np.exp(1j * phase).sum(axis=-2)) / p.shape[-2]  # (..., T, 2)
        pat = np.moveaxis(af, -2, -1) * self.t_directivity  # (..., 2, T)
        level = 1 / np.sqrt(2)
        below = pat < level
        first = np.where(below.any(-1), np.argmax(below, axis=-1), len(self.t) - 1)
        i1 = np.clip(first, 1, len(self.t) - 1)[..., None]
        p0 = np.take_along_axis(pat, i1 - 1, -1)[..., 0]
        p1 = np.take_along_axis(pat, i1, -1)[..., 0]
        t0, t1 = self.t[i1[..., 0] - 1], self.t[i1[..., 0]]
        frac = np.clip((p0 - level) / np.where(p0 != p1, p0 - p1, 1.0), 0.0, 1.0)
        tc = np.where(below.any(-1), t0 + frac * (t1 - t0), self.t[-1])
        return 2 * np.arcsin(tc)

    def evaluate(self, pairs) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Objective [dB] (P,), worst one-way PSLL [dB] (P,) and widths [rad] (P, 2, 2) of
        (P, 2, 25, 2) layout pairs."""
        psll = self.array_psll(pairs).max(axis=-1)
        widths = self.broadside_widths(pairs)
        c = self.criteria
        excess = np.clip(np.abs(widths - c.target_width) - c.width_tolerance, 0.0, None)
        psll_db = 20 * np.log10(psll)
        return psll_db + self.settings.width_penalty * excess.max(axis=(1, 2)), psll_db, widths


# ---- the genetic algorithm ------------------------------------------------------------------------

@dataclass(frozen=True)
class DesignResult:
    """Outcome of :func:`design_arrays`.

    Attributes:
        tx: transmit layout (relative to the transmit origin).
        rx: receive layout (relative to the receive origin).
        baseline: receive origin along sensor +x [m].
        settings: the GA settings used (seed included).
        criteria: the design criteria.
        objective_db: best objective per generation [dB], (generations + 1,) (entry 0: start).
        psll_db: fast-objective worst one-way PSLL of the result [dB].
        seconds: wall-clock time of the run [s] (information only).
    """

    tx: ArrayLayout
    rx: ArrayLayout
    baseline: float
    settings: GASettings
    criteria: BeamCriteria
    objective_db: np.ndarray
    psll_db: float
    seconds: float

    def geometry(self) -> ArrayGeometry:
        """The sensor head with these layouts (validates spacing and aperture)."""
        return ArrayGeometry(tx=self.tx, rx=self.rx, baseline=self.baseline,
                             fov_horizontal=self.criteria.fov_horizontal,
                             fov_vertical=self.criteria.fov_vertical)


def design_arrays(settings: GASettings = GASettings(), criteria: BeamCriteria = BeamCriteria(),
                  baseline: float = DEFAULT_BASELINE, progress=None) -> DesignResult:
    """Run the genetic algorithm (module docstring) and return the best layout pair.

    Args:
        settings: GA settings and seed.
        criteria: field of view, main-lobe width target, frequency, air, element.
        baseline: receive origin along sensor +x [m].
        progress: optional callable(generation, best_objective_db, best_psll_db) after each
            generation (e.g. a tqdm update).
    """
    check_range("baseline [m]", baseline, 0.0, APERTURE)
    t0 = time.perf_counter()
    s = settings
    rng = np.random.default_rng(s.seed)
    spacing = MIN_SPACING + s.spacing_margin
    start = uniform_pair()
    if min_joint_spacing(start, baseline) < spacing:
        raise ValueError(f"the uniform start layouts overlap at baseline {baseline} m; "
                         f"choose a baseline at least {spacing * 1000:.2f} mm from the grid")
    objective = LatticeObjective(criteria, s)
    half = APERTURE / 2

    pop = start[None] + rng.normal(0.0, s.init_jitter, (s.population,) + start.shape)
    pop[0] = start
    pop, ok = _repair(pop, baseline, spacing, s.repair_iterations)
    pop[~ok] = start  # rare: a jittered start that cannot be repaired restarts from the grid
    fit, psll, _ = objective.evaluate(pop)
    history = [float(fit.min())]
    n_child = s.population - s.elite
    for g in range(s.generations):  # the loop over generations; everything inside is batched
        order = np.argsort(fit, kind="stable")
        elite, elite_fit, elite_psll = pop[order[:s.elite]], fit[order[:s.elite]], psll[order[:s.elite]]
        cand = rng.integers(0, s.population, size=(2, n_child, s.tournament))
        winner = np.take_along_axis(cand, np.argmin(fit[cand], axis=-1)[..., None], -1)[..., 0]
        pa, pb = pop[winner[0]], pop[winner[1]]
        mix = (rng.random(n_child) < s.crossover_probability)[:, None, None, None] \
            & (rng.random((n_child, 2, ELEMENTS, 1)) < 0.5)
        child = np.where(mix, pb, pa)
        frac = g / max(s.generations - 1, 1)
        sigma = s.mutation_start * (s.mutation_end / s.mutation_start) ** frac
        move = rng.random((n_child, 2, ELEMENTS, 1)) < s.mutation_probability
        child = child + move * rng.normal(0.0, sigma, child.shape)
        jump = rng.random((n_child, 2, ELEMENTS, 1)) < s.relocate_probability
        child = np.where(jump, rng.uniform(-half, half, child.shape), child)
        child, ok = _repair(child, baseline, spacing, s.repair_iterations)
        child[~ok] = pa[~ok]
        child_fit, child_psll, _ = objective.evaluate(child)
        pop = np.concatenate([elite, child])
        fit = np.concatenate([elite_fit, child_fit])
        psll = np.concatenate([elite_psll, child_psll])
        history.append(float(fit.min()))
        if progress is not None:
            progress(g + 1, float(fit.min()), float(psll[np.argmin(fit)]))
    best = pop[np.argmin(fit)]
    best = np.round(best / POSITION_RESOLUTION) * POSITION_RESOLUTION
    best_fit, best_psll, _ = objective.evaluate(best[None])
    name = f"GA-optimised interleaved 5x5 pair (seed {s.seed})"
    return DesignResult(tx=ArrayLayout(best[0], name=f"{name} (tx)"),
                        rx=ArrayLayout(best[1], name=f"{name} (rx)"),
                        baseline=float(baseline), settings=s, criteria=criteria,
                        objective_db=np.array(history), psll_db=float(best_psll[0]),
                        seconds=time.perf_counter() - t0)


# ---- exact evaluation -----------------------------------------------------------------------------

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
    psll = {n: 20 * np.log10(np.maximum(r, 1e-12)).reshape(len(v), len(h)) for n, r in ratio.items()}

    def widths(steer, half_span, count):
        angles, u = cut_directions(steer, half_span, count)
        s4 = steer[:, None, None, :]
        tx = one_way_pattern(tx_positions, s4, u, c.transducer, k)
        rx = one_way_pattern(rx_positions, s4, u, c.transducer, k)
        return {n: main_lobe_widths(angles, p) for n, p in (("tx", tx), ("rx", rx), ("two_way", tx * rx))}

    if widths_over_fov:
        width = {n: w.reshape(len(v), len(h), 2)
                 for n, w in widths(flat, np.radians(12.0), 241).items()}
    else:
        width = {n: np.full((len(v), len(h), 2), np.nan) for n in psll}
    broad = {n: w[0] for n, w in widths(np.array([[0.0, 0.0, 1.0]]), np.radians(10.0), 2001).items()}
    return LayoutMetrics(h, v, psll, width, broad)


# ---- the shipped record ---------------------------------------------------------------------------

def default_layout_path() -> Path:
    """Path of the shipped layout file, mitsonar/physics/array_layout.json."""
    return Path(str(resources.files("mitsonar.physics").joinpath(LAYOUT_FILE)))


def layout_record(result: DesignResult, metrics: LayoutMetrics, uniform: LayoutMetrics) -> dict:
    """The JSON record of a design: positions, metrics (optimised and uniform), seed, settings."""
    def pos(layout):
        return [[round(float(x), 6), round(float(y), 6)] for x, y in layout.positions]

    s = result.settings
    return {
        "name": f"GA-optimised interleaved 5x5 pair (seed {s.seed})",
        "note": ("Written by `mitsonar array design` (mitsonar.design.array_design). Positions in metres, "
                 "tx relative to the transmit origin (sensor origin), rx relative to the receive "
                 "origin at (baseline, 0) in the sensor plane. Metrics: exact evaluation over the "
                 "field of view (one-way PSLL of each array, two-way PSLL of the pair, 3 dB widths "
                 "of the one-way patterns)."),
        "baseline": result.baseline,
        "tx": pos(result.tx),
        "rx": pos(result.rx),
        "metrics": metrics.to_dict(),
        "uniform_metrics": uniform.to_dict(),
        "design": {
            "method": "genetic algorithm over the 50 element centres, joint spacing constraint",
            "seed": s.seed,
            "ga_settings": s.to_dict(),
            "criteria": criteria_record(result.criteria),
            "min_spacing_m": MIN_SPACING,
            "aperture_m": APERTURE,
            "fast_objective_worst_psll_db": round(result.psll_db, 3),
            "objective_db_history": [round(float(v), 3) for v in result.objective_db],
            "runtime_s": round(result.seconds, 1),
        },
    }


def criteria_record(criteria: BeamCriteria) -> dict:
    """Criteria for the JSON record; every key carries its unit."""
    d = criteria.to_dict()
    d["medium"] = _named_units(d["medium"], {"temperature": "K", "relative_humidity": "percent",
                                             "pressure": "Pa"})
    d["transducer"] = _named_units(d["transducer"], {"radius": "m", "resonance_frequency": "Hz",
                                                     "bandwidth_6db": "Hz", "source_amplitude": "Pa"})
    d["wavelength_m"] = round(criteria.wavelength, 7)
    d["speed_of_sound_m_per_s"] = round(criteria.medium.speed_of_sound, 4)
    return d


def load_layout_file(path) -> tuple[ArrayLayout, ArrayLayout, float, dict]:
    """(tx, rx, baseline, whole record) from a layout JSON file; clear errors on bad files."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
        tx = ArrayLayout(np.asarray(data["tx"], dtype=float), name=f"{data.get('name', path.name)} (tx)")
        rx = ArrayLayout(np.asarray(data["rx"], dtype=float), name=f"{data.get('name', path.name)} (rx)")
        baseline = float(data["baseline"])
    except FileNotFoundError:
        raise
    except (OSError, json.JSONDecodeError, KeyError, TypeError) as err:
        raise ValueError(f"{path}: not a layout file ({type(err).__name__}: {err})") from None
    ArrayGeometry(tx=tx, rx=rx, baseline=baseline)  # validates the joint spacing
    return tx, rx, baseline, data


def format_summary(metrics: LayoutMetrics, uniform: LayoutMetrics, result: DesignResult | None = None) -> str:
    """Human-readable comparison of uniform and optimised layouts (degrees and dB)."""
    lines = []
    if result is not None:
        s = result.settings
        lines.append(f"GA: seed {s.seed}, population {s.population}, generations {s.generations}, "
                     f"{result.seconds:.0f} s.")
    fov = np.degrees([np.ptp(uniform.steering_horizontal), np.ptp(uniform.steering_vertical)])
    lines.append(f"Worst PSLL over the {fov[0]:.0f} x {fov[1]:.0f} deg field of view (beams steered "
                 "over the field of view, side lobes inside it, element directivity included):")
    for label, m in (("uniform 5x5 @ 25 mm", uniform), ("optimised", metrics)):
        lines.append(f"  {label:20s} transmit {m.worst_psll_db('tx'):6.2f} dB, receive "
                     f"{m.worst_psll_db('rx'):6.2f} dB, two-way {m.worst_psll_db('two_way'):6.2f} dB")
    lines.append(f"  improvement (one-way, worse of TX/RX): "
                 f"{uniform.worst_psll_db('one_way') - metrics.worst_psll_db('one_way'):.2f} dB")
    lines.append("Broadside 3 dB width (horizontal x vertical):")
    for label, m in (("uniform 5x5 @ 25 mm", uniform), ("optimised", metrics)):
        w = {n: np.degrees(m.broadside_width[n]) for n in ("tx", "rx")}
        lines.append(f"  {label:20s} transmit {w['tx'][0]:.2f} x {w['tx'][1]:.2f} deg, receive "
                     f"{w['rx'][0]:.2f} x {w['rx'][1]:.2f} deg")
    return "\n".join(lines)
