"""Echo synthesis: acoustic paths -> channel impulse responses -> per-microphone recordings.

A path is a complex gain ``a`` [Pa, for the drive pulse] and a delay ``tau`` [s] into one receive
channel. The analytic recording of a channel is sum_p a_p w(t - tau_p), where w is the analytic
system waveform: the drive pulse through the transmitter and receiver responses. Its real part is
the recorded pressure.

Fast synthesis (band-limited, exact for these signals): every path, shifted down in frequency by
the band's centre f_d (a phasor exp(-j 2 pi f_d tau_p)), is spread onto the sample grid with a
short Gaussian kernel (a type-1 non-uniform FFT); one FFT per channel gives
sum_p a_p exp(-j 2 pi f tau_p) times the kernel's transform at f - f_d, which is divided out
inside the signal band and multiplied by the system spectrum W(f). After the shift the kernel
resolves half the band's width instead of its top frequency, so it is narrower. Cost: paths x
kernel taps + one FFT per channel, instead of paths x samples for the direct summation (kept in
the tests as the oracle).
Fractional delays are exact up to the stated tolerance, far below one sample.

Paths come in three kinds, each with its gridding kernel (the taps are common, :func:`_spread`):
flat :class:`~mitsonar.trace.paths.Paths`; patches' element pairs in factored form
(:class:`~mitsonar.trace.hitpaths.HitPaths`), gridded pair by pair from their factors; and
narrow-band merged ones (:class:`~mitsonar.trace.hitpaths.MergedHits`), straight from the merge
kernel. A wide band's paths (:class:`~mitsonar.trace.subbands.Subbands`, gains at several
frequency nodes) are synthesised set by set, each driven through its node's hat weight
(:class:`~mitsonar.signal.band.SubBand`).

Recordings, real or complex baseband, and the spectra on the band that synthesis produces are
those of a :class:`~mitsonar.signal.band.Band` (its module docstring), which also holds the
system spectra; the synthesizer adds the gridding kernel and the receiver noise.
"""

from __future__ import annotations

import numpy as np
import scipy.fft as sfft

from mitsonar.jit import backend, to_jit
from mitsonar.physics.waveforms import phasor
from mitsonar.signal.band import Band, Recording, SubBand, code_response, node_groups
from mitsonar.signal.gridding import fixed_point_scale, folded, pair_kernel, spread_kernel
from mitsonar.trace.hitpaths import HitPaths, MergedHits
from mitsonar.trace.paths import Paths
from mitsonar.trace.subbands import Subbands


#: Drive spectra kept by a synthesizer (~1 MB each).
DRIVES_KEPT = 64
#: Factored path sets gridded by one launch of the pair kernel while their rows hold at most
#: about this many samples: an OFDM cycle's beams of few patches (the paper model's) share one,
#: a broadband beam's rows (25 x 8 600 samples) get their own, its grid in cache.
PAIR_BATCH_SAMPLES = 1 << 19


class EchoSynthesizer:
    """Fast band-limited synthesis of recordings from paths, on a :class:`Band`.

    Construct once and reuse: the gridding kernel is precomputed; the band holds the system
    spectra.

    Args:
        band: the recordings' band (sample grid, recording window, waveforms).
        tolerance: relative accuracy of the kernel (aliasing and truncation); default a tenth of
            the band's ``floor``, below the band's own error.
    """

    def __init__(self, band: Band, tolerance: float | None = None):
        self.band = band
        nu = (np.arange(band.bins.start, band.bins.stop) - band.shift_bin) / band.n_grid
        nu_max = np.abs(nu).max()
        #: Relative accuracy of the gridding kernel.
        self.tolerance = tolerance = 0.1 * band.floor if tolerance is None else tolerance
        # Gaussian kernel (sigma in samples): aliasing from the images at fs - f stays below the
        # tolerance, and truncation stays below it after the deconvolution gain at nu_max (f
        # relative to f_d).
        log_tol = np.log(1.0 / tolerance)
        self.sigma = float(np.sqrt(log_tol / (2 * np.pi**2 * (1 - 2 * nu_max))))
        deconv_gain = np.exp(2 * np.pi**2 * self.sigma**2 * nu_max**2)
        self.half_width = int(np.ceil(self.sigma * np.sqrt(2 * np.log(deconv_gain / tolerance))))
        self._deconvolution = 1.0 / self._kernel_transform(nu)  # over the band
        self._drives: dict = {}

    def _kernel_transform(self, nu):
        """Transform of the Gaussian gridding kernel at ``nu`` [cycles per sample] from f_d."""
        return self.sigma * np.sqrt(2 * np.pi) * np.exp(-2 * np.pi**2 * self.sigma**2 * nu**2)

    def narrowband_groups(self, paths, waveform=None) -> list:
        """(paths, waveform) groups that synthesise ``paths`` (:class:`Paths` with per-hit blocks,
        or :class:`~mitsonar.trace.hitpaths.HitPaths`) driven by ``waveform`` with each
        hit's transmit elements merged (``paths.narrowband``) about the recorded centre
        frequency of each tone of the waveform (an OFDM code's ``parts``, else itself).

        Factored paths are merged as :class:`~mitsonar.trace.hitpaths.MergedHits`, leaving out
        the patches whose every pair arrives after the recording's end (more than half of an
        office ping's): merged paths are only ever delayed later (an OFDM beam fired later in
        its cycle), which cannot bring them back into the recording."""
        band = self.band
        waveform = band.pulse if waveform is None else waveform
        if isinstance(paths, Subbands):
            return [group for part, weighted in node_groups(paths, waveform)
                    for group in self.narrowband_groups(part, weighted)]
        tones = getattr(waveform, "parts", (waveform,))
        centres = [band.band_moments(t)[0] for t in tones]
        if not isinstance(paths, HitPaths):
            return list(zip(paths.narrowband_many(centres), tones))
        end = band.start_time + (band.n_samples + self.half_width) / band.sample_rate
        late = paths.arrivals[0] >= end
        return list(zip((paths.select(~late) if late.any() else paths).merged(centres), tones))

    def impulse_grid(self, paths: Paths | HitPaths, n_channels: int,
                     per_pair: bool = False, period: int | None = None) -> np.ndarray:
        """Spread paths, shifted down by the band centre f_d (:attr:`Band.shift_bin`), onto the
        (n_channels, n_grid) sample grid (at :attr:`Band.sample_rate`) with the Gaussian kernel
        g: bin m of the grid's FFT holds bin m + shift_bin of the spectrum, times the kernel's
        transform.

        A first-order term b about f_c goes onto the same grid with the kernel's derivative,
        b (j 2 pi (f_c - f_d) g(x) - fs g'(x)), whose transform is -j 2 pi (f - f_c) times g's:
        one grid and one FFT carry both terms of a narrow-band merged path. Factored
        :class:`~mitsonar.trace.hitpaths.HitPaths` are gridded pair by pair from their factors
        (:func:`pair_kernel`), never expanded into arrays of every pair.

        Runs as one Dr.Jit kernel (an add of a (re, im) packet per kernel tap into a copy of the
        grid per core, :data:`~mitsonar.signal.gridding.GRID_REDUCE`), compiled once per grid width and reused.
        Contributions are accumulated as 64-bit fixed-point integers, whose sum does not depend
        on the order the threads add them in: the same paths give bit-identical recordings. The
        grid is returned in single precision (complex64: its rounding, ~6e-8 of the largest
        sample, is far below the band floor; its FFTs take half the time). Paths whose kernel
        lies wholly outside the recording are left out. ``per_pair``: factored paths on a row
        per element pair (:meth:`_pair_grids`); ``period``: a period longer than n_grid.
        """
        if isinstance(paths, HitPaths):
            return self._pair_grids([paths], n_channels, per_pair, period)[0]
        if isinstance(paths, MergedHits):
            return self._merged_grid(paths, n_channels)
        import drjit as dr
        Float64, Int64 = backend().Float64, backend().Int64

        band = self.band
        fs, hw = band.sample_rate, self.half_width
        period = band.n_grid if period is None else period
        u = (np.asarray(paths.delay) - band.start_time) * fs
        keep = (u > -hw) & (u < band.n_samples + hw)
        channel = np.asarray(paths.channel)[keep]
        if len(channel) and (channel.min() < 0 or channel.max() >= n_channels):
            raise ValueError(f"path channel out of range 0..{n_channels - 1}")
        gain = np.asarray(paths.gain)[keep]
        inv_var = 1.0 / self.sigma**2
        omega = 2 * np.pi * (paths.carrier - band.fft_frequencies[band.shift_bin])  # [rad/s]
        # |j omega g(x) - fs g'(x)| <= |omega| + fs |x| / sigma^2 over the taps, |x| <= hw + 1.
        slope = None if paths.first_order is None else np.asarray(paths.first_order)[keep]
        bound = np.abs(gain) if slope is None else \
            np.abs(gain) + np.abs(slope) * (abs(omega) + fs * (hw + 1) * inv_var)
        scale = float(fixed_point_scale(np.max(bound, initial=0.0)))
        if len(channel) == 0 or scale == 0.0:
            return np.zeros((n_channels, period), dtype=np.complex64)
        first_order = None if slope is None else (
            to_jit(Float64, slope.real * scale), to_jit(Float64, slope.imag * scale),
            dr.opaque(Float64, omega))  # a variable, not a literal: one kernel for all carriers
        gains = (to_jit(Float64, gain.real * scale), to_jit(Float64, gain.imag * scale))
        u = u[keep]
        origin, width = self._window(u.min(), u.max())
        acc = spread_kernel()(n_channels * width, to_jit(Float64, u),
                               to_jit(Int64, channel * width - origin), gains, first_order,
                               dr.opaque(Float64, band.shift_bin / band.n_grid), hw, inv_var,
                               fs * inv_var, True)
        return folded(acc.numpy().reshape(n_channels, -1, 2), scale, period, origin)

    def _merged_grid(self, paths: MergedHits, n_channels: int) -> np.ndarray:
        """:meth:`impulse_grid` of narrow-band merged paths held as Dr.Jit arrays."""
        import drjit as dr
        Float64, Int64 = backend().Float64, backend().Int64

        band = self.band
        fs, hw, inv_var = band.sample_rate, self.half_width, 1.0 / self.sigma**2
        if paths.receivers > n_channels:
            raise ValueError(f"path channel out of range 0..{n_channels - 1}")
        first, last = ((t + paths.offset - band.start_time) * fs for t in paths.span)
        omega = 2 * np.pi * (paths.frequency - band.fft_frequencies[band.shift_bin])  # [rad/s]
        # The bound of flat paths' (impulse_grid), from the merge's bounds on |a| and |b|.
        scale = float(fixed_point_scale(paths.peaks[0] + paths.peaks[1]
                                         * (abs(omega) + fs * (hw + 1) * inv_var)))
        if len(paths) == 0 or scale == 0.0 or last <= -hw or first >= band.n_samples + hw:
            return np.zeros((n_channels, band.n_grid), dtype=np.complex64)
        # Per-beam offset, scale and window as variables: as literals, new kernels every beam.
        offset, factor = (dr.opaque(Float64, x) for x in (paths.offset - band.start_time, scale))
        u = (paths.centre + offset) * fs
        (a_re, a_im), (b_re, b_im) = paths.gain, paths.first_order
        first, last = max(first, -hw), min(last, band.n_samples + hw)
        origin, width = self._window(first, last)
        gains = (Float64(a_re) * factor, Float64(a_im) * factor)
        first_order = (Float64(b_re) * factor, Float64(b_im) * factor, dr.opaque(Float64, omega))
        row = Int64(paths.channel) * dr.opaque(Int64, width) - dr.opaque(Int64, origin)
        acc = spread_kernel()(n_channels * width, u, row, gains, first_order,
                               dr.opaque(Float64, band.shift_bin / band.n_grid), hw, inv_var,
                               fs * inv_var, (u > -hw) & (u < band.n_samples + hw))
        return folded(acc.numpy().reshape(n_channels, -1, 2), scale, band.n_grid, origin)

    def _window(self, first: float, last: float) -> tuple[int, int]:
        """(origin, width) of the kernels' grid rows for paths at positions ``first`` ..
        ``last`` [samples] (within -half_width .. n_samples + half_width): column c of a row
        holds sample origin + c. The width is a power of two (each width is a kernel recording
        of its own) where that is narrower than the whole recording and its kernel margins:
        paths spanning a short time, such as direct paths, make small grids."""
        origin, width = self._windows(np.array([first]), np.array([last]))
        return int(origin[0]), int(width[0])

    def _windows(self, first: np.ndarray, last: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`_window` (origin, width) (S,) of path sets at ``first`` .. ``last`` (S,)."""
        hw = self.half_width
        span = (np.floor(last) - np.floor(first)).astype(np.int64) + 2 * hw + 1
        width = np.left_shift(1, np.frexp(span - 1)[1]).astype(np.int64)  # power of 2 >= span
        full = width >= self.band.n_samples + 4 * hw
        return (np.where(full, -2 * hw, np.floor(first).astype(np.int64) - hw),
                np.where(full, self.band.n_samples + 4 * hw, width))

    def _demodulation(self, u: np.ndarray) -> np.ndarray:
        """exp(-j 2 pi f_d u) (complex64) at positions ``u`` [samples], f_d the band centre."""
        cycles = self.band.shift_bin / self.band.n_grid * u
        return phasor(-2 * np.pi * (cycles - np.floor(cycles)))

    def impulse_grids(self, sets, n_channels: int) -> np.ndarray:
        """:meth:`impulse_grid` (S, n_channels, n_grid) of factored paths' sets (_pair_grids)."""
        return self._pair_grids(sets, n_channels)

    def _pair_grids(self, sets, n_channels: int, per_pair: bool = False,
                    period: int | None = None, by_arrival: bool = False) -> np.ndarray:
        """:meth:`impulse_grid` (S, rows, period) of sets of factored paths (:class:`HitPaths`
        with the same element counts) by :func:`pair_kernel`, each as gridded alone (bit for
        bit: its own window, fixed-point scale and sums), the sets' windows and scales as array
        operations over all patches, and one launch for as many sets as ``PAIR_BATCH_SAMPLES``
        allows, each set on rows of its own. With ``per_pair``, a row per element pair
        (N_tx x n_channels rows, transmit element major), on a period of ``period`` samples
        (default the band's n_grid; at least its n_samples + 4 x half_width); with
        ``by_arrival``, the recorded patches gridded in order of arrival."""
        Float64, Int64, UInt32 = backend().Float64, backend().Int64, backend().UInt32

        band = self.band
        fs, hw = band.sample_rate, self.half_width
        n_tx, n_rx = sets[0].elements
        if n_rx > n_channels:
            raise ValueError(f"path channel out of range 0..{n_channels - 1}")
        n_rows = n_tx * n_channels if per_pair else n_channels
        period = band.n_grid if period is None else period
        grids = np.zeros((len(sets), n_rows, period), dtype=np.complex64)
        paths = HitPaths.concatenate(sets)
        owner = np.repeat(np.arange(len(sets)), [len(p.tx_delay) for p in sets])
        earliest, latest = ((t - band.start_time) * fs for t in paths.arrivals)
        keep = np.flatnonzero((latest > -hw) & (earliest < band.n_samples + hw))  # a pair in
        if by_arrival:
            keep = keep[np.argsort(earliest[keep], kind="stable")]
        if not by_arrival and len(keep) == len(owner):
            keep = slice(None)  # every patch in its order: views, not copies, of the factors
        owner, earliest, latest = owner[keep], earliest[keep], latest[keep]
        peak, first, last = np.zeros((3, len(sets))) + [[0.0], [np.inf], [-np.inf]]
        np.maximum.at(peak, owner, paths.gain_bound()[keep])
        np.minimum.at(first, owner, earliest)
        np.maximum.at(last, owner, latest)
        scale = fixed_point_scale(peak)
        gridded = scale > 0.0  # sets with a recorded pair of some gain
        origin, width = self._windows(np.maximum(np.where(gridded, first, 0.0), -hw),
                                      np.minimum(np.where(gridded, last, 0.0),
                                                 band.n_samples + hw))
        size = np.where(gridded, n_rows * width, 0)
        launch = (np.cumsum(size) - size) // PAIR_BATCH_SAMPLES
        tx_u = (paths.tx_delay[keep] - band.start_time) * fs  # a pair's position: tx_u + rx_u
        rx_u = paths.rx_delay[keep] * fs
        tx_factor = self._demodulation(tx_u)
        rx_factor = scale[owner][:, None] * self._demodulation(rx_u)
        specular = not paths.specular_free  # point reflectors: the diffuse term alone
        for group in np.unique(launch[gridded]):  # launches (one for small sets)
            members = np.flatnonzero(gridded & (launch == group))
            start = np.zeros(len(sets), np.int64)
            start[members] = np.cumsum(size[members]) - size[members]
            mine = np.flatnonzero(np.isin(owner, members))
            if mine.size < owner.size:
                tx, rx = paths.kernel_factors(np.arange(len(paths.tx_delay))[keep][mine],
                                              tx_factor[mine], rx_factor[mine], specular)
            else:
                tx, rx = paths.kernel_factors(keep, tx_factor, rx_factor, specular)
            total = int(size[members].sum())
            thread = to_jit(UInt32, np.arange(mine.size * n_rx, dtype=np.uint32))
            whose = owner[mine]
            acc = pair_kernel()(1 << (total - 1).bit_length(), thread, tx, rx,
                                 to_jit(Float64, tx_u[mine]), to_jit(Float64, rx_u[mine]), n_tx,
                                 n_rx, to_jit(Int64, width[whose]),
                                 to_jit(Int64, start[whose] - origin[whose]), hw,
                                 1.0 / self.sigma**2, band.n_samples,
                                 int(n_channels * width[members[0]]) if per_pair else 0)
            flat = acc.numpy()
            for k in members:  # each set's rows onto its period
                rows_k = flat[2 * start[k]: 2 * (start[k] + size[k])].reshape(n_rows, -1, 2)
                folded(rows_k, scale[k], period, int(origin[k]), grids[k])
        return grids

    def analytic(self, paths: Paths, n_channels: int, waveform=None) -> np.ndarray:
        """Noiseless :meth:`Band.to_analytic` recordings (n_channels, n_samples) of paths driven
        by ``waveform`` (default: the band's pulse)."""
        return self.analytic_sum([(paths, waveform)], n_channels)

    def analytic_sum(self, groups, n_channels: int) -> np.ndarray:
        """:meth:`analytic` of several path sets, each with its own waveform: [(paths, waveform)]."""
        return self.band.to_analytic(self.groups_spectrum(groups, n_channels))

    def groups_spectrum(self, groups, n_channels: int) -> np.ndarray:
        """Summed analytic spectrum on the band (n_channels, nb) of [(paths, waveform)] groups;
        spectra of several calls add up to their joint recording (see :meth:`Band.to_samples`).

        The paths of each distinct waveform go onto an impulse grid of their own (a grid of
        n_channels rows stays in cache, where one grid for the ten code tones of an OFDM cycle
        made the gridding 30 % slower); factored paths of every waveform are gridded together
        (:meth:`impulse_grids`), and the grids transformed by one batched FFT.
        """
        band = self.band
        by_waveform: dict = {}
        for paths, waveform in groups:
            waveform = band.pulse if waveform is None else waveform
            for part, weighted in (node_groups(paths, waveform) if isinstance(paths, Subbands)
                                   else [(paths, waveform)]):
                by_waveform.setdefault(weighted, []).append(part)
        if not by_waveform:
            return np.zeros((n_channels, len(band.frequencies)), complex)
        kinds = []  # per waveform: each kind of paths (and merge frequency), gridded by its kernel
        for parts in by_waveform.values():
            same: dict = {}
            for p in parts:
                same.setdefault((type(p), getattr(p, "frequency", None)), []).append(p)
            kinds.append([kind.concatenate(members) for (kind, _), members in same.items()])
        factored = [p for each in kinds for p in each if isinstance(p, HitPaths)]
        hit_grids = self.impulse_grids(factored, n_channels) if factored else ()
        if len(factored) == len(kinds) and all(len(each) == 1 for each in kinds):
            grids = hit_grids  # one factored set per waveform: an OFDM cycle's beams
        else:
            hits = iter(hit_grids)
            grids = np.stack([sum(next(hits) if isinstance(p, HitPaths) else
                                  self.impulse_grid(p, n_channels) for p in each)
                              for each in kinds])
        filters = np.stack([band.system_spectrum(w)[band.bins] for w in by_waveform]) \
            * self._deconvolution
        spectra = sfft.fft(grids, axis=-1, workers=-1)[..., band.grid_bins] * filters[:, None]
        return np.sum(spectra, axis=0)  # waveform after waveform

    def drive_spectra(self, waveforms, delays, frequencies) -> np.ndarray:
        """System spectra (..., N_tx, F) at ``frequencies`` (F,) [Hz] of transmit elements that
        each fire every waveform b of ``waveforms`` (B) with its own delay ``delays[..., b, e]``
        (..., B, N_tx) [s] (a beam's steering and firing time; leading axes: recordings apart):
        sum_b W_b(f) exp(-j 2 pi f delays[..., b, e]), W_b the system response
        (:meth:`Band.system_response`) left out below the band's floor, as
        :meth:`Band.system_spectrum` leaves it. Kept for one recording's delays (B, N_tx) per
        (waveforms, delays, frequencies): frames repeat their schedule."""
        delays = np.asarray(delays, dtype=float)
        cached = delays.ndim == 2  # one recording's (a frame's cycle); a scan's pings are not kept
        key = (tuple(waveforms), delays.tobytes(),
               np.asarray(frequencies, dtype=float).tobytes()) if cached else None
        if cached and key in self._drives:
            return self._drives[key]
        band = self.band
        spectra = []
        for w in waveforms:  # the cycle's codes
            response = code_response(band, w, frequencies)
            floor = band.floor * np.abs(band.system_spectrum(w)).max()
            spectra.append(np.where(np.abs(response) > floor, response, 0.0))
        phases = np.exp(-2j * np.pi * delays[..., None] * frequencies)
        drives = np.einsum("bf,...bef->...ef", np.array(spectra), phases)
        if cached:
            if len(self._drives) >= DRIVES_KEPT:
                self._drives.clear()
            self._drives[key] = drives
        return drives

    def element_spectrum(self, paths: HitPaths, waveforms, delays) -> np.ndarray:
        """Analytic spectrum on the band (N_rx, nb) of the recording of unsteered factored
        ``paths`` (transmit delays: travel times) when every transmit element e fires each
        waveform b of ``waveforms`` with delay ``delays[b, e]`` (B, N_tx) [s]: sum_e G_em(f)
        D_e(f) (:meth:`drive_spectra`), with G_em the channel from element e to receive element
        m through the patches, gridded once on a row per element pair (:func:`pair_kernel`)
        whatever the number of waveforms (:meth:`driven_samples`), the recording's samples put
        onto the band (:meth:`Band.band_spectra`)."""
        samples = next(self.driven_samples([paths], waveforms, np.asarray(delays)[None]))
        return self.band.band_spectra(samples[0])

    def driven_samples(self, sets, waveforms, delays, batch: int = 1):
        """Noiseless recorded samples of P recordings through unsteered path ``sets``
        (factored :class:`HitPaths`, whose elements give N_tx x N_rx, and :class:`Paths` on a
        channel per element pair, transmit element major, e.g. the unsteered direct paths; or
        :class:`Subbands` of them, part by part) when in recording p every transmit element e
        fires each waveform b of ``waveforms`` (B) with delay ``delays[p, b, e]`` (P, B, N_tx)
        [s] (a ping's steering; a cycle's codes' steering and firing times): sum_e G_em(f)
        D_pe(f) (:meth:`drive_spectra`), the channels G_em from element e to receive element m
        gridded once on a row per element pair (:func:`pair_kernel`) whatever the number of
        waveforms and recordings. Yields them ``batch`` recordings at a time, (batch, N_rx,
        n_samples) arrays in order: the memory a batch needs.

        The drives' delays carry echoes later; on the band's period they would wrap onto the
        recording's start. So the rows are gridded on a period longer by the largest delay, the
        channels driven and summed on its bins within the band, and the recording's samples
        taken from them (an inverse transform, the echoes cut at the recording's end as a
        recording cuts them)."""
        if isinstance(sets[0], Subbands):
            parts = [self.driven_samples([s.parts[k] for s in sets],
                                         [SubBand(w, sets[0].nodes, k) for w in waveforms],
                                         delays, batch) for k in range(len(sets[0].parts))]
            yield from (sum(pieces) for pieces in zip(*parts))
            return
        band = self.band
        fs = band.sample_rate
        n_tx, n_rx = next(p.elements for p in sets if isinstance(p, HitPaths))
        delays = np.asarray(delays, dtype=float)
        period = sfft.next_fast_len(
            band.n_grid + int(np.ceil(max(float(np.max(delays)), 0.0) * fs)))
        nu = np.fft.fftfreq(period)  # [cycles per sample] from the band's centre f_d
        centre = band.fft_frequencies[band.shift_bin]
        frequencies = centre + nu * fs
        step = fs / period
        inside = np.flatnonzero((frequencies > band.frequencies[0] - step)
                                & (frequencies < band.frequencies[-1] + step))
        # Patches in order of arrival: the kernel's threads (a block of consecutive patches per
        # core) then add into a narrow band of columns of the N_tx x N_rx rows, which stays in
        # cache (in the trace's order they span the whole recording: measured 5x slower).
        grid = sum(self._pair_grids([p], n_rx, per_pair=True, period=period, by_arrival=True)[0]
                   if isinstance(p, HitPaths) else
                   self.impulse_grid(p, n_tx * n_rx, period=period) for p in sets)
        # (F, N_tx, N_rx): a matrix per bin, for the drives' products
        channels = np.moveaxis(sfft.fft(grid, axis=-1, workers=-1)[:, inside], -1, 0).reshape(
            -1, n_tx, n_rx)
        scale = band.n_grid / band.n_fft / self._kernel_transform(nu[inside])
        # a(t) exp(-j 2 pi f_d (t - t0)) at the recording's samples (t0 its start)
        turn = np.exp(-2j * np.pi * centre * band.start_time) if band.baseband else \
            np.exp(2j * np.pi * centre * np.arange(band.n_samples) / fs)
        for first in range(0, len(delays), batch):
            # one recording's delays as (B, N_tx), which drive_spectra keeps for the next frame
            drives = self.drive_spectra(waveforms, delays[first] if len(delays) == 1 else
                                        delays[first:first + batch], frequencies[inside]) * scale
            drives = drives.reshape(-1, n_tx, len(inside))  # (P, N_tx, F)
            full = np.zeros((len(drives), n_rx, period), complex)
            full[..., inside] = np.moveaxis(np.moveaxis(drives, -1, 0) @ channels, 0, -1)
            shifted = sfft.ifft(full, axis=-1, workers=-1)[..., : band.n_samples]
            yield shifted * turn if band.baseband else (shifted * turn).real

    def group_spectrum(self, paths: Paths, waveform, n_channels: int) -> np.ndarray:
        """Analytic spectrum on the band (n_channels, nb) of ``paths`` driven by ``waveform``."""
        return self.groups_spectrum([(paths, waveform)], n_channels)

    def synthesize(self, paths: Paths, n_channels: int, noise_rms: float = 0.0,
                   seed=None, waveform=None) -> Recording:
        """Recording of ``n_channels`` channels with additive white Gaussian receiver noise.

        Args:
            paths: the acoustic paths.
            n_channels: number of receive channels.
            noise_rms: noise standard deviation per real sample at the band's
                ``reference_rate`` [Pa] (see :meth:`recording`); needs ``seed`` when > 0.
            seed: seed of the noise generator (same seed, same recording).
            waveform: drive waveform (default: the band's pulse).
        """
        spectrum = self.group_spectrum(paths, waveform, n_channels)
        return self.recording(self.band.to_samples(spectrum), noise_rms, seed)

    def band_noise(self, n_channels: int, noise_rms: float, seed) -> np.ndarray:
        """Seeded receiver noise drawn straight on the band: spectra (n_channels, nb) of the
        white noise of :meth:`recording` (``noise_rms`` [Pa] per sample at ``reference_rate``,
        real or baseband alike) as :meth:`Band.band_spectra` gives them for a recording as long
        as the period: independent circular complex Gaussian bins of E|X|^2 = 4 n_fft
        noise_rms^2 (a real recording's rfft bins, doubled; baseband: the same density).

        The recording's noise lasts its n_samples, this noise the whole period (n_grid samples):
        their band-limited samples, and their matched-filter outputs, have the same statistics
        except within a matched filter's length of the recording's ends, where the recording's
        are weaker (the filter reaches into its silent guard samples).
        (The per-channel path needs 2 n_channels x n_samples normals and two transforms per
        channel; this one 2 n_channels x nb normals and none.)"""
        shape = (n_channels, len(self.band.frequencies))
        if noise_rms <= 0:
            return np.zeros(shape, complex)
        if seed is None:
            raise ValueError("noise_rms > 0 needs an explicit seed")
        noise = np.random.default_rng(seed).normal(
            0.0, noise_rms * np.sqrt(2 * self.band.n_fft), (2,) + shape)
        return noise[0] + 1j * noise[1]

    def recording(self, channels: np.ndarray, noise_rms: float = 0.0, seed=None) -> Recording:
        """Recording of channels (n_channels, n_samples) [Pa] (real recordings keep the real part
        of analytic ones), plus seeded white receiver noise of ``noise_rms`` [Pa] per sample of
        a real recording at the band's ``reference_rate``. Baseband noise has the same density
        on the band:
        complex, sqrt(2 sample_rate / reference_rate) ``noise_rms`` in each part."""
        band = self.band
        samples = channels if band.baseband else channels.real
        if noise_rms > 0:
            if seed is None:
                raise ValueError("noise_rms > 0 needs an explicit seed")
            rng = np.random.default_rng(seed)
            if band.baseband:
                sigma = noise_rms * np.sqrt(2 * band.sample_rate / band.reference_rate)
                noise = rng.normal(0.0, sigma, (2,) + samples.shape)
                samples = samples + (noise[0] + 1j * noise[1])
            else:
                samples = samples + rng.normal(0.0, noise_rms, samples.shape)
        return Recording(samples, band.sample_rate, band.start_time, band.carrier)
