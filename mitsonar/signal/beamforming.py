"""Delay-and-sum (5) of the receive array, for many beams at once.

* On the signal band: the plane-wave delays t_j^B(psi) = -(p_j - o_R) . u / c relative to the
  receive origin o_R, applied exactly as phase ramps exp(j 2 pi f t_j^B) to the channels' spectra
  (fractional delays without interpolation error).
* Narrow band, on short windows of channels demodulated at a carrier: each channel read at its
  delay by linear interpolation and phase-aligned at the carrier, as a sparse operator acting on
  the windows. This is what the side-lobe check and the arrival direction of
  :mod:`mitsonar.signal.receiver` read at the instants of the candidates: one sparse product for
  every window of a carrier.
"""

from __future__ import annotations

import numpy as np
from scipy import sparse

from mitsonar.frames import direction_from_fov_angles, fov_angles
from mitsonar.physics.array import ArrayGeometry
from mitsonar.physics.waveforms import phasor
from mitsonar.signal.band import Band
from mitsonar.signal.detection import DetectionSettings, vertex

#: Rounding above :meth:`Beamformer.off_beam`'s bound that a grid direction's beam may show
#: (single-precision phasors: | |phase| - 1 | < 2e-7; sums of 50 terms: ~1e-14), allowed for.
BOUND_ROUNDING = 1e-6
#: Bytes of steering phasors a :class:`Beamformer` keeps (:meth:`Beamformer.steering`): a
#: 117-beam OFDM schedule's five cycles take 88 MB (paper preset) or 78 MB (default), formed
#: again every frame; a few MB more for off-beam directions.
STEERING_KEPT = 160 * 2**20


def dot(a, b) -> np.ndarray:
    """Dot products of 3-vectors (..., 3), broadcast, summed term by term: a pair of vectors gets
    the same value whatever the batch around it (a BLAS kernel may not)."""
    a, b = np.asarray(a), np.asarray(b)
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


class Beamformer:
    """Delay-and-sum towards directions: steering phasors on the band and narrow-band operators
    on windows; built once per sensor configuration.

    Args:
        geometry: the arrays.
        band: the recordings' band (its frequencies and sample rate).
        speed_of_sound: c [m/s].
        settings: the side-lobe check's grid and main lobe, the arrival-direction step.
    """

    def __init__(self, geometry: ArrayGeometry, band: Band, speed_of_sound: float,
                 settings: DetectionSettings):
        self.band = band
        self.c = float(speed_of_sound)
        self.settings = settings
        self._offsets = geometry.rx_positions - geometry.rx_origin  # (N_rx, 3) [m]
        #: W [samples] of the windows: the largest receive delay (5), rounded up, + 1.
        self.window_lag = int(np.ceil(np.linalg.norm(self._offsets, axis=1).max() / self.c
                                      * band.sample_rate)) + 1
        # Side-lobe check: a ``ghost_grid_step`` grid over +-``ghost_half_span`` in both
        # field-of-view angles, the same for every beam, and its delay-and-sum per carrier [Hz].
        h = np.arange(-settings.ghost_half_span, settings.ghost_half_span + 1e-9,
                      settings.ghost_grid_step)
        hh, vv = np.meshgrid(h, h, indexing="ij")
        self.ghost_grid = direction_from_fov_angles(hh, vv).reshape(-1, 3)
        # Its every third direction along each axis, checked first (:meth:`off_beam`).
        self._coarse = np.arange(len(self.ghost_grid)).reshape(len(h), len(h))[::3, ::3].ravel()
        self._ghost_operators = {}  # (carrier [Hz], coarse) -> operator
        self._ghost_reach = None  # (N_rx, L) window samples the grid reads (:meth:`off_beam`)
        self._steering = {}  # directions' bytes -> phasors, oldest first

    def receive_delays(self, directions) -> np.ndarray:
        """Plane-wave delays t_j^B(psi) of (5) [s], (..., N_rx) for directions (..., 3): channel
        j is read at t + t_j^B."""
        return -dot(np.asarray(directions, dtype=float)[..., None, :], self._offsets) / self.c

    def steering(self, directions) -> np.ndarray:
        """Phasors exp(j 2 pi f t_j^B) (B, N_rx, nb) at the band's frequencies f for directions
        (B, 3) (complex64, :func:`~mitsonar.physics.waveforms.phasor`, read only); kept for
        the latest ``STEERING_KEPT`` bytes of directions asked for (an OFDM schedule's cycles
        are formed again every frame)."""
        directions = np.ascontiguousarray(directions, dtype=float)
        key = directions.tobytes()
        if key not in self._steering:
            delays = self.receive_delays(directions)  # (B, N_rx) [s]
            phasors = np.empty(delays.shape + self.band.frequencies.shape, np.complex64)
            for j in range(delays.shape[1]):  # a channel at a time: small temporaries
                phasors[:, j] = phasor(2 * np.pi * self.band.frequencies * delays[:, j, None])
            phasors.setflags(write=False)
            held = sum(p.nbytes for p in self._steering.values())
            for old in list(self._steering):  # the oldest out first (a few entries)
                if held + phasors.nbytes <= STEERING_KEPT:
                    break
                held -= self._steering.pop(old).nbytes
            self._steering[key] = phasors
        return self._steering[key]

    def beamformed(self, spectra: np.ndarray, directions) -> np.ndarray:
        """Delay-and-sum (B, nb) of channel spectra on the band, (N_rx, nb) shared by all beams
        or (B, N_rx, nb) one set per beam, towards directions (B, 3): summed channel by channel
        (no (B, N_rx, nb) product held at once)."""
        steering = self.steering(directions)
        total = spectra[..., 0, :] * steering[:, 0]
        term = np.empty_like(total)
        for j in range(1, steering.shape[1]):
            total += np.multiply(spectra[..., j, :], steering[:, j], out=term)
        total /= steering.shape[1]
        return total

    def operator(self, directions, carriers, fractions=0.0, blocks=None) -> sparse.csr_matrix:
        """Narrow-band delay-and-sum towards directions (R, 3) as a sparse matrix acting on
        windows of L = 2 W + 2 samples per channel (:meth:`windows`), one row per direction.

        Row r reads block ``blocks[r]`` (default 0) of the stacked windows, a column of N_rx x L
        numbers: channels demodulated at ``carriers[r]`` [Hz] ((R,) or a scalar) whose window
        starts W samples before sample k; it gives the beam at sample k + ``fractions[r]``
        ((R,) or a scalar), each channel read at its delay (5) by linear interpolation and
        phase-aligned at the carrier. W covers the largest delay. Shape (R, n_blocks N_rx L).
        """
        return self._matrix(*self._weights(self.receive_delays(directions), carriers, fractions,
                                           blocks))

    def _matrix(self, data, columns, blocks) -> sparse.csr_matrix:
        """:meth:`operator` of its rows (:meth:`_weights`)."""
        rows, n_rx = len(data), data.shape[1] // 2
        n_blocks = int(blocks.max(initial=0)) + 1
        return sparse.csr_matrix((data.ravel(), columns.ravel(), np.arange(rows + 1) * 2 * n_rx),
                                 shape=(rows, n_blocks * n_rx * (2 * self.window_lag + 2)))

    def _weights(self, delays, carriers, fractions, blocks):
        """The rows of :meth:`operator` towards directions of receive delays ``delays`` (R, N_rx)
        [s] (:meth:`receive_delays`; other arguments as there): weights (R, 2 N_rx) and columns
        (R, 2 N_rx), (1 - frac) and frac at columns c, c + 1 for each channel in turn, and the
        blocks (R,)."""
        fs = self.band.sample_rate
        rows, n_rx = delays.shape
        q = np.reshape(fractions, (-1, 1)) + delays * fs
        length = 2 * self.window_lag + 2
        i0 = np.floor(q).astype(np.int64)
        frac = q - i0
        blocks = np.zeros(rows, np.int64) if blocks is None else np.asarray(blocks, np.int64)
        cols = (np.arange(n_rx) * length + self.window_lag)[None, :] + i0 \
            + (blocks * n_rx * length)[:, None]
        # < 30 rad: phase error < 2e-6 rad
        phase = phasor(2 * np.pi * np.reshape(carriers, (-1, 1)) * delays)
        data = np.empty(phase.shape + (2,), np.result_type(frac, phase))  # no temporaries
        np.multiply(1 - frac, phase, out=data[..., 0])
        np.multiply(frac, phase, out=data[..., 1])
        columns = np.empty(cols.shape + (2,), cols.dtype)
        columns[..., 0] = cols
        np.add(cols, 1, out=columns[..., 1])
        return data.reshape(rows, -1), columns.reshape(rows, -1), blocks

    def windows(self, channels: np.ndarray, sets, samples) -> np.ndarray:
        """(N_rx x L, E) windows for :meth:`operator`: column e holds channel set ``sets[e]`` of
        ``channels`` (S, N_rx, N) from W samples before integer sample ``samples[e]`` (zeros
        beyond the recording)."""
        n = channels.shape[-1]
        index = np.asarray(samples, np.int64)[:, None] \
            + np.arange(-self.window_lag, self.window_lag + 2)  # (E, L)
        picked = channels[np.asarray(sets)[:, None, None],
                          np.arange(channels.shape[1])[None, :, None],
                          np.clip(index, 0, n - 1)[:, None, :]]  # (E, N_rx, L)
        picked = np.where(((index >= 0) & (index < n))[:, None, :], picked, 0)
        return picked.transpose(1, 2, 0).reshape(-1, len(index))

    def off_beam(self, channels: np.ndarray, sets, samples, carriers, directions) -> np.ndarray:
        """Side-lobe check of E windows: (E,) True where, at integer sample ``samples[e]`` of
        channel set ``sets[e]`` of ``channels`` (S, N_rx, N) demodulated at ``carriers[e]``
        [Hz], some direction of the ghost grid outside the main lobe of ``directions[e]`` (E, 3)
        is ``ghost_margin`` times stronger than that direction. Every third direction of the grid
        along each axis is tried first, the whole grid only where none of them is (the same
        decisions, a ninth of the work for most rejections: on room_glass's OFDM frame the
        coarse grid finds 703 of 705). A sparse product per carrier for each. Windows where no
        direction can beat the beam are not formed at all: a direction's beam is at most the
        sum over channels of the largest magnitude each holds among the samples the grid reads
        (interpolation weights of sum 1, unit phasors), so where ``ghost_margin`` times the
        beam exceeds that sum (``BOUND_ROUNDING`` allowed for) the answer is False without the
        grid (the same decisions; most echoes that arrive along their beam).
        """
        s = self.settings
        directions = np.asarray(directions, dtype=float)
        carriers = np.asarray(carriers, dtype=float)
        windows = self.windows(channels, sets, samples)  # (N_rx L, E)
        entries = np.arange(len(carriers))
        beam = np.abs(self.operator(directions, carriers, blocks=entries)
                      @ windows.T.ravel())
        reach = self.ghost_reach()
        magnitude = np.abs(windows).reshape(reach.shape + (-1,))
        bound = np.where(reach[..., None], magnitude, 0.0).max(axis=1).sum(axis=0)
        doubtful = bound * (1 + BOUND_ROUNDING) > s.ghost_margin * beam  # may be off the beam
        off = np.zeros(len(carriers), bool)
        for coarse in (True, False):
            grid = self.ghost_grid[self._coarse] if coarse else self.ghost_grid
            for carrier in np.unique(carriers[doubtful & ~off]):
                mine = entries[(carriers == carrier) & doubtful & ~off]
                if (carrier, coarse) not in self._ghost_operators:  # the same for every beam
                    self._ghost_operators[carrier, coarse] = self.operator(grid, carrier)
                ghosts = np.abs(self._ghost_operators[carrier, coarse] @ windows[:, mine])
                outside = dot(grid[:, None, :], directions[mine]) < np.cos(s.ghost_exclusion)
                off[mine] = np.where(outside, ghosts, 0.0).max(axis=0) \
                    > s.ghost_margin * beam[mine]
        return off

    def ghost_reach(self) -> np.ndarray:
        """(N_rx, L) which samples of each channel's window (:meth:`windows`) some direction of
        the side-lobe check's grid reads (a channel near the receive origin reads few)."""
        if self._ghost_reach is None:
            columns = self._weights(self.receive_delays(self.ghost_grid), 0.0, 0.0, None)[1]
            reach = np.zeros(len(self._offsets) * (2 * self.window_lag + 2), bool)
            reach[columns.ravel()] = True
            self._ghost_reach = reach.reshape(len(self._offsets), -1)
        return self._ghost_reach

    def arrival_directions(self, channels: np.ndarray, sets, carriers, beams, samples,
                           directions) -> np.ndarray:
        """Unit vectors (D, 3) of the strongest arrivals at (fractional) ``samples`` (D,) within
        ``ghost_exclusion`` of the beam ``directions`` (D, 3): narrow-band delay-and-sum power
        on an ``arrival_step`` grid of field-of-view angles around each beam, the maximum refined
        by the quadratic through its log-power and its 8 neighbours (:func:`peak_offsets`).
        Beam ``beams[e]`` sums the power of its looks e: channel
        set ``sets[e]`` of ``channels`` (S, N_rx, N) demodulated at ``carriers[e]`` [Hz] (E,),
        in the order given. One sparse product for all."""
        s = self.settings
        directions = np.asarray(directions, dtype=float)
        beams = np.asarray(beams, np.int64)
        h0, v0 = fov_angles(directions)
        half = int(np.floor(s.ghost_exclusion / s.arrival_step))
        offsets = np.arange(-half, half + 1) * s.arrival_step
        side = len(offsets)
        grid = direction_from_fov_angles((h0[:, None] + offsets)[:, :, None],
                                         (v0[:, None] + offsets)[:, None, :])  # (D, G, G, 3)
        grid = grid.reshape(len(directions), side * side, 3)
        k = np.floor(samples).astype(np.int64)
        fractions = samples - k
        delays = self.receive_delays(grid)  # (D, G^2, N_rx) [s]: once per beam, not per look
        per_look = side * side
        operator = self._matrix(*self._weights(
            delays[beams].reshape(-1, delays.shape[-1]), np.repeat(carriers, per_look),
            np.repeat(fractions[beams], per_look), np.repeat(np.arange(len(beams)), per_look)))
        looks = np.abs(operator @ self.windows(channels, sets, k[beams]).T.ravel()) ** 2
        power = np.zeros(grid.shape[:2])
        np.add.at(power, beams, looks.reshape(len(beams), -1))
        power = np.where(dot(grid, directions[:, None, :]) >= np.cos(s.ghost_exclusion), power, 0.0)
        best = np.argmax(power, axis=1)
        i, j = np.divmod(best, side)
        # Zero-padded around the grid: a maximum on its edge has no parabola (vertex 0).
        power = np.pad(power.reshape(-1, side, side), ((0, 0), (1, 1), (1, 1)))
        d = np.arange(len(directions))
        peak = power[d, i + 1, j + 1]
        # The vertex of the quadratic through the log-power around the maximum (the lobe's axes
        # need not be the grid's: parabolas along each axis err by up to 0.6 mrad); on the
        # grid's edge, the parabola along the other axis.
        rows = i[:, None, None] + np.arange(3)[None, None, :]
        cols = j[:, None, None] + np.arange(3)[None, :, None]
        joint = peak_offsets(np.log(np.maximum(power[d[:, None, None], rows, cols], 1e-300)))
        inner_h, inner_v = (0 < i) & (i < side - 1), (0 < j) & (j < side - 1)
        along_h = np.where(inner_h & inner_v, joint[:, 0], np.where(
            inner_h, vertex(power[d, i, j + 1], peak, power[d, i + 2, j + 1]), 0.0))
        along_v = np.where(inner_h & inner_v, joint[:, 1], np.where(
            inner_v, vertex(power[d, i + 1, j], peak, power[d, i + 1, j + 2]), 0.0))
        return direction_from_fov_angles(h0 + offsets[i] + s.arrival_step * along_h,
                                         v0 + offsets[j] + s.arrival_step * along_v)

    def aligned(self, channels: np.ndarray, sets, carriers, samples, directions) -> np.ndarray:
        """(E, N_rx) channel values of E looks: channel set ``sets[e]`` of ``channels`` (S, N_rx,
        N) demodulated at ``carriers[e]`` [Hz], each channel read at (fractional) sample
        ``samples[e]`` plus its delay (5) towards ``directions[e]`` (E, 3) and phase-aligned,
        as :meth:`operator` reads them (their sum is the beam)."""
        k = np.floor(samples).astype(np.int64)
        data, columns, _ = self._weights(self.receive_delays(directions), carriers, samples - k,
                                         None)
        # Only the two samples each channel interpolates between, not its whole window:
        # column c of channel j's window is sample k - W + c - j L.
        n_rx, n = channels.shape[1], channels.shape[-1]
        length = 2 * self.window_lag + 2
        index = k[:, None, None] - self.window_lag + columns.reshape(len(k), n_rx, 2) \
            - (np.arange(n_rx) * length)[None, :, None]  # (E, N_rx, 2)
        values = channels[np.asarray(sets)[:, None, None], np.arange(n_rx)[None, :, None],
                          np.clip(index, 0, n - 1)]
        values = np.where((index >= 0) & (index < n), values, 0)
        return (data.reshape(values.shape) * values).sum(axis=-1)

    def coherence(self, channels: np.ndarray, sets, carriers, beams, samples,
                  directions) -> np.ndarray:
        """(D,) fraction of the receive channels' power at (fractional) ``samples`` (D,)
        explained by one plane wave from ``directions`` (D, 3): |sum_j x_j|^2 / (N_rx sum_j
        |x_j|^2) with x_j of :meth:`aligned`, numerator and denominator each summed over the
        looks e of beam ``beams[e]`` (channel set ``sets[e]`` demodulated at ``carriers[e]``
        [Hz], as in :meth:`arrival_directions`); NaN where the channels are silent."""
        beams = np.asarray(beams, np.int64)
        x = self.aligned(channels, sets, carriers, np.asarray(samples)[beams],
                         np.asarray(directions)[beams])
        beam, total = np.zeros((2, len(directions)))
        np.add.at(beam, beams, np.abs(x.sum(axis=1)) ** 2)
        np.add.at(total, beams, x.shape[1] * np.sum(np.abs(x) ** 2, axis=1))
        return np.divide(beam, total, out=np.full(len(total), np.nan), where=total > 0)


def peak_offsets(near: np.ndarray) -> np.ndarray:
    """(P, 2) offsets [grid steps] along u_x and u_y of the main-lobe peaks of log-powers ``near``
    (P, 3, 3) [p, y, x] around a grid direction: the vertex of the quadratic through the 9
    values (exact for a Gaussian lobe, whose axes need not be the grid's), or, where that has no
    maximum within a step, of the parabolas along each axis."""
    gx = 0.5 * (near[:, 1, 2] - near[:, 1, 0])
    gy = 0.5 * (near[:, 2, 1] - near[:, 0, 1])
    hxx = near[:, 1, 2] - 2 * near[:, 1, 1] + near[:, 1, 0]
    hyy = near[:, 2, 1] - 2 * near[:, 1, 1] + near[:, 0, 1]
    hxy = 0.25 * (near[:, 2, 2] - near[:, 2, 0] - near[:, 0, 2] + near[:, 0, 0])
    det = hxx * hyy - hxy**2
    safe = np.where(det > 0, det, 1.0)
    joint = np.stack([(hxy * gy - hyy * gx) / safe, (hxy * gx - hxx * gy) / safe], axis=-1)
    axes = np.stack([vertex(near[:, 1, 0], near[:, 1, 1], near[:, 1, 2]),
                     vertex(near[:, 0, 1], near[:, 1, 1], near[:, 2, 1])], axis=-1)
    maximum = (det > 0) & (hxx < 0) & np.all(np.abs(joint) <= 1.0, axis=-1)
    return np.where(maximum[:, None], joint, axes)
