"""Sparse array design by a genetic algorithm: the shipped 5x5 transmit and receive layouts.

The paper (III-B) starts from a uniform 5x5 array in a 10 cm x 10 cm aperture and moves the
elements with a genetic algorithm to minimise the peak side-lobe level (PSLL) inside the field of
view. A uniform 5x5 layout at 2.5 cm pitch (about 2.9 wavelengths at 40 kHz) has full grating
lobes at sin(theta) = lambda / d = 0.34 (20 deg) from the beam, inside a 60 x 40 deg field of view.

Here the transmit and the receive layout are designed together, because they are interleaved on
one board (see :mod:`mitsonar.physics.array`): the receive layout sits ``baseline`` to the right
of the transmit origin, each layout's 25 centres stay within +-5 cm of its own origin, and no two
of the 50 elements come closer than the 10 mm can diameter. The genome is the 50 element centres.

Objective (minimised, dB):

    max(PSLL_tx, PSLL_rx) + width_penalty * max(0, max_k |w_k - w_target| - w_tolerance)

* PSLL_tx, PSLL_rx: the worst one-way PSLL of each array over steering directions covering the
  field of view (every other point of the direction-cosine lattice below, about 1.2 deg apart),
  side lobes searched at all lattice directions inside the field of view, element directivity
  included (the main-lobe disc is
  :attr:`mitsonar.design.evaluation.BeamCriteria.main_lobe_radius`, see
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
a busy machine. The reported numbers come from the exact evaluation
(:func:`mitsonar.design.evaluation.evaluate_layout`) on finer grids and exact steering directions;
the lattice objective agrees with it to a few tenths of a dB.

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

    from mitsonar.design.evaluation import evaluate_layout
    from mitsonar.design.genetic import GASettings, design_arrays
    result = design_arrays(GASettings(seed=1))
    metrics = evaluate_layout(result.tx.positions, result.rx.positions)
    metrics.worst_psll_db("one_way"), metrics.broadside_width["tx"]   # dB, rad
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import numpy as np

from mitsonar.design.evaluation import BeamCriteria, named_units, uniform_pair
from mitsonar.physics.array import APERTURE, MIN_SPACING, ArrayGeometry, ArrayLayout
from mitsonar.physics.beampattern import in_fov
from mitsonar.validation import check_range

#: Distance from the transmit to the receive array origin along sensor +x [m] (half the uniform
#: pitch: the two uniform grids interleave 12.5 mm apart).
DEFAULT_BASELINE = 0.0125
#: Positions are stored rounded to this [m] (1 um).
POSITION_RESOLUTION = 1e-6
#: Elements per layout (5 x 5).
ELEMENTS = 25


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
            raise ValueError("GASettings.tournament must lie in [1, population], "
                             f"got {self.tournament}")
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
        return named_units(asdict(self), _GA_UNITS)

    @classmethod
    def from_dict(cls, data: dict) -> "GASettings":
        """Inverse of :meth:`to_dict` (re-run a recorded design)."""
        suffixed = {f"{k}_{u}": k for k, u in _GA_UNITS.items()}
        return cls(**{suffixed.get(k, k): v for k, v in data.items()})


_GA_UNITS = {"mutation_start": "m", "mutation_end": "m", "init_jitter": "m",
             "width_penalty": "db_per_rad", "spacing_margin": "m"}


# ---- constraints ---------------------------------------------------------------------------------

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
        """Broadside one-way 3 dB widths [rad] (..., 2) (horizontal, vertical), layouts (..., N, 2).

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


# ---- the genetic algorithm -----------------------------------------------------------------------

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
        top = order[:s.elite]
        elite, elite_fit, elite_psll = pop[top], fit[top], psll[top]
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
