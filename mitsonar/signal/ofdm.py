"""OFDM multi-beam frames (paper III-C, III-E, Fig. 6): codes and schedule.

Codes. Five tones 32-48 kHz, 4 kHz apart. A code is an ordered pair of tones (f_a, f_b) sent as
one T = 0.5 ms slot: f_a for the first half, f_b for the second (the paper's "25 combinations in
pairs", Fig. 6a). Each half holds a whole number of periods, so two different tones are
orthogonal over a half by (9) (Delta f T/2 = 1 and (2 f1 + Delta f) T/2 integers): codes that
differ in both halves are orthogonal, codes that share one half correlate at 1/2 when aligned;
their echoes are separated by time (each code fires in its own slot) and by direction
(beamforming), and what leaks between them is measured (``crosstalk_db``).

Schedule. Beams are fired one code per slot: a cycle sends up to 25 codes back to back
(12.5 ms) and then listens for the farthest echo (30 ms for 5 m); the next cycle starts after
that. Echoes of codes fired one or two slots apart overlap most at the receiver, so beams fired
that close are spread far apart in angle (a stride permutation of the grid); within a cycle,
beams fired in consecutive slots and beams closer than 8 deg (inside each other's main-lobe
exclusion) get codes that share no tone. A 60 x 40 deg field of view at 5 deg has 13 x 9 = 117 beams: 4 full cycles of
42.5 ms and one of 17 codes (8.5 + 30 ms), 208.5 ms per frame (4.8 Hz). The schedule is data
(direction, code, transmit time and cycle of every beam), so other grids and code sets work.

Simulation and decoding live in :mod:`mitsonar.sensors.ofdm_sonar`. All beams of a cycle are superposed in one per-channel recording: each beam is
traced from the sensor pose at its own transmit time (the robot moves during a frame), driven by
its code through the transducer response, and the direct cross-talk of every code is included.
Decoding: for each code, matched filter with its own waveform, delay-and-sum toward its
direction, detection relative to its transmit time inside the listening window, depth by (7).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mitsonar.physics.waveforms import spectrum_of
from mitsonar.validation import check_positive

#: The paper's tones [Hz].
PAPER_TONES = (32e3, 36e3, 40e3, 44e3, 48e3)
#: Code slot T [s].
PAPER_SLOT = 0.5e-3
#: Listening time after a cycle's last code [s] (farthest echo of 5 m, rounded up as the paper).
PAPER_LISTEN = 30e-3


@dataclass(frozen=True)
class Tone:
    """A sine tone of ``frequency`` [Hz] from ``start`` [s] for ``length`` [s]: one half of a
    :class:`Code`, on the code's clock (so both halves' matched filters peak at the same instant)."""

    frequency: float
    start: float
    length: float

    @property
    def duration(self) -> float:
        return self.start + self.length

    def waveform(self, t) -> np.ndarray:
        """The real drive at times t [s]."""
        t = np.asarray(t, dtype=float)
        on = (t >= self.start) & (t <= self.duration)
        return np.where(on, np.sin(2 * np.pi * self.frequency * (t - self.start)), 0.0)

    def spectrum(self, frequency) -> np.ndarray:
        return spectrum_of(self, frequency)


@dataclass(frozen=True)
class Code:
    """An OFDM code: tone ``first`` [Hz] for the first half of a ``slot`` [s], ``second`` after."""

    first: float
    second: float
    slot: float = PAPER_SLOT

    @property
    def duration(self) -> float:
        return self.slot

    @property
    def frequency(self) -> float:
        """Centre frequency [Hz] (wavenumber of the patch integrals)."""
        return 0.5 * (self.first + self.second)

    @property
    def parts(self) -> tuple[Tone, ...]:
        """The tones the receiver checks an echo for separately (see processing): the two halves,
        or one tone over the whole slot when both halves are the same tone."""
        half = self.slot / 2
        if self.first == self.second:
            return (Tone(self.first, 0.0, self.slot),)
        return Tone(self.first, 0.0, half), Tone(self.second, half, half)

    def waveform(self, t) -> np.ndarray:
        """The real drive at times t [s]."""
        return sum(part.waveform(t) for part in self.parts)

    def spectrum(self, frequency) -> np.ndarray:
        return spectrum_of(self, frequency)


def check_orthogonal(tones, slot: float) -> None:
    """Raise ValueError naming the first pair of tones not orthogonal over a half slot by (9)."""
    half = slot / 2
    tones = np.asarray(tones, dtype=float)
    for i in range(len(tones)):
        for j in range(i + 1, len(tones)):
            f1, f2 = sorted((tones[i], tones[j]))
            df = f2 - f1
            for name, value in (("Delta f T", df * half), ("(2 f1 + Delta f) T", (2 * f1 + df) * half)):
                if abs(value - round(value)) > 1e-9 or round(value) == 0:
                    raise ValueError(f"tones {f1:.0f} Hz and {f2:.0f} Hz are not orthogonal over "
                                     f"T = {half * 1e3:.3f} ms: {name} = {value:.4f} is not a "
                                     "non-zero integer (equation (9))")


def code_set(tones=PAPER_TONES, slot: float = PAPER_SLOT) -> list[Code]:
    """All ordered pairs of the tones as codes (25 for five tones), after checking (9)."""
    check_positive("code slot [s]", slot)
    check_orthogonal(tones, slot)
    return [Code(float(a), float(b), slot) for a in tones for b in tones]


def assign_codes(directions, codes, neighbour_angle: float = np.radians(8.0)) -> np.ndarray:
    """Code index (n,) for beams (n, 3) listed in firing order, each code used once, with as few
    as possible tone-sharing codes between beams fired in consecutive slots or closer than
    ``neighbour_angle`` [rad]: deterministic steepest-descent over code swaps."""
    u = np.asarray(directions, dtype=float)
    n = len(u)
    if n > len(codes):
        raise ValueError(f"{n} beams in a cycle but only {len(codes)} codes")
    tones = [{c.first, c.second} for c in codes]
    clash = np.array([[bool(a & b) for b in tones] for a in tones], dtype=int)
    linked = (u @ u.T) > np.cos(neighbour_angle)
    idx = np.arange(n - 1)
    linked[idx, idx + 1] = linked[idx + 1, idx] = True  # consecutive slots
    np.fill_diagonal(linked, False)
    assign = np.arange(n)
    spare = np.arange(n, len(codes))  # unused codes can be swapped in too
    pool = np.concatenate([assign, spare])
    while True:  # one best swap per round; the conflict count falls every round
        current = pool[:n]
        cost = (clash[np.ix_(current, current)] * linked).sum() / 2
        best, best_pair = cost, None
        for a in range(n):
            for b in range(a + 1, len(pool)):
                trial = pool.copy()
                trial[a], trial[b] = trial[b], trial[a]
                t = trial[:n]
                c = (clash[np.ix_(t, t)] * linked).sum() / 2
                if c < best:
                    best, best_pair = c, (a, b)
        if best_pair is None:
            return pool[:n]
        a, b = best_pair
        pool[a], pool[b] = pool[b], pool[a]


def interleaved_order(directions) -> np.ndarray:
    """Firing order of beams (B, 3): a stride permutation that keeps beams fired within two slots
    of each other as far apart in angle as possible, so what leaks between their codes arrives
    from outside each other's main lobes."""
    u = np.asarray(directions, dtype=float)
    n = len(u)
    if n < 3:
        return np.arange(n)
    best, best_order = -1.0, np.arange(n)
    for stride in range(1, n):
        if np.gcd(stride, n) != 1:
            continue
        order = (np.arange(n) * stride) % n
        d = u[order]
        closest = min(np.min(np.sum(d[k:] * d[:-k], axis=1)) for k in (1, 2))
        separation = np.arccos(np.clip(closest, -1, 1))
        if separation > best + 1e-12:
            best, best_order = separation, order
    return best_order


def code_correlation(codes, sample_rate: float = 1e6) -> np.ndarray:
    """Normalised zero-lag correlation matrix (C, C) of the code waveforms."""
    t = np.arange(0.0, codes[0].slot, 1.0 / sample_rate)
    w = np.array([c.waveform(t) for c in codes])
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    return w @ w.T


@dataclass(frozen=True)
class Schedule:
    """When and where every beam of a frame is sent.

    Attributes:
        directions: (B, 3) beam directions, sensor frame.
        code_index: (B,) index into ``codes``.
        transmit_time: (B,) firing time from the start of the frame [s].
        cycle: (B,) cycle number.
        cycle_start: (n_cycles,) start of each cycle [s].
        frame_duration: time until the last cycle has finished listening [s].
        listen: listening time after each cycle's last code [s].
        codes: the code set.
    """

    directions: np.ndarray
    code_index: np.ndarray
    transmit_time: np.ndarray
    cycle: np.ndarray
    cycle_start: np.ndarray
    frame_duration: float
    listen: float
    codes: tuple

    @classmethod
    def build(cls, directions, codes, listen: float = PAPER_LISTEN, interleave: bool = True) -> "Schedule":
        """Schedule beams towards ``directions`` (B, 3), ``len(codes)`` per cycle, one per slot.

        With ``interleave`` the firing order is :func:`interleaved_order` and codes are given by
        :func:`assign_codes` per cycle; otherwise beams and codes go in the given order. Arrays
        are indexed by the beam's position in ``directions`` either way.
        """
        dirs = np.asarray(directions, dtype=float).reshape(-1, 3)
        check_positive("listening time [s]", listen)
        codes = list(codes)
        n_codes = len(codes)
        slot = codes[0].slot
        fire = interleaved_order(dirs) if interleave else np.arange(len(dirs))
        rank = np.empty(len(dirs), dtype=int)
        rank[fire] = np.arange(len(dirs))  # firing position of each beam
        cycle, position = rank // n_codes, rank % n_codes
        code_index = position.copy()
        if interleave:  # per cycle: neighbours in time or in angle get tone-disjoint codes
            for c in range(int(cycle.max()) + 1):
                members = fire[c * n_codes:(c + 1) * n_codes]  # this cycle's beams, firing order
                code_index[members] = assign_codes(dirs[members], codes)
        n_cycles = int(cycle.max()) + 1
        cycle_period = n_codes * slot + listen
        cycle_start = np.arange(n_cycles) * cycle_period
        last = len(dirs) - (n_cycles - 1) * n_codes
        frame = float(cycle_start[-1] + last * slot + listen)
        return cls(dirs, code_index, cycle_start[cycle] + position * slot, cycle, cycle_start, frame,
                   float(listen), tuple(codes))
