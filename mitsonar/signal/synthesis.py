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

Recordings, real or complex baseband, and the spectra on the band that synthesis produces are
those of a :class:`~mitsonar.signal.band.Band` (its module docstring), which also holds the
system spectra; the synthesizer adds the gridding kernel and the receiver noise.
"""

from __future__ import annotations

from functools import cache

import numpy as np
import scipy.fft as sfft

from mitsonar.jit import backend, to_jit
from mitsonar.signal.band import Band, Recording
from mitsonar.trace.paths import Paths


@cache
def _spread_kernel():
    """The gridding kernel of :meth:`EchoSynthesizer.impulse_grid`, frozen (``drjit.freeze``):
    traced once per kernel shape, then replayed without Python tracing whatever the path count.

    Arguments: the flat grid's size, positions (M,) [samples], row offsets (M,) into the flat
    grid, (re, im) gains, None or (re, im, carrier - f_d [rad/s]) of the first-order terms, the
    shift f_d [cycles per sample], the grid's period n_grid [samples], half_width [taps],
    1/sigma^2, fs/sigma^2. Returns the (re, im) Int64 grids. (Each grid size is a separate
    recording: the grids are made inside, as scatter targets passed in would be replayed at the
    recorded size.)
    """
    import drjit as dr
    Float64, Int64, UInt32 = backend().Float64, backend().Int64, backend().UInt32

    def spread(size, pos, row, gain, first_order, shift, n_grid, half_width, inv_var, rate_inv_var):
        acc = (dr.zeros(Int64, size), dr.zeros(Int64, size))
        cycles = shift * pos
        sin, cos = dr.sincos(-2 * np.pi * (cycles - dr.floor(cycles)))  # exp(-j 2 pi f_d tau)

        def shifted(re, im):
            return re * cos - im * sin, re * sin + im * cos

        gain = shifted(*gain)
        if first_order is not None:
            first_order = shifted(*first_order[:2]) + (first_order[2],)
        base = Int64(dr.floor(pos))
        frac = pos - Float64(base)  # in [0, 1)
        # Fast Gaussian gridding: g(k - frac) = exp(-k^2 / 2 sigma^2) exp(k frac / sigma^2)
        # exp(-frac^2 / 2 sigma^2): two exponentials per path serve every tap k (powers of
        # exp(frac / sigma^2) by multiplication; relative rounding ~1e-15 per tap).
        common = dr.exp(-0.5 * inv_var * dr.square(frac))
        growth = dr.exp(inv_var * frac)
        power = {0: common}
        for k in range(1, half_width + 1):
            power[k] = power[k - 1] * growth
            power[-k] = power[1 - k] / growth
        for k in range(-half_width, half_width + 1):  # kernel taps (a fixed, small count)
            weight = power[k] * float(np.exp(-0.5 * k * k * inv_var))
            value_re, value_im = gain
            if first_order is not None:  # b (j omega + fs x / sigma^2), x = k - frac
                slope_re, slope_im, omega = first_order
                x = rate_inv_var * (k - frac)
                value_re = value_re + slope_re * x - slope_im * omega
                value_im = value_im + slope_im * x + slope_re * omega
            flat = UInt32(row + (base + (k + n_grid)) % n_grid)
            # Plain atomic adds, not Dr.Jit's default for grids this small (a copy per core,
            # merged after): measured faster for every preset (standard pings' merged paths
            # 3.6 -> 2.4 ms, fine's element pairs 205 -> 131 ms, paper 16 -> 15 ms per ping);
            # slower only where a few point reflectors put thousands of paths on the same
            # samples at 400 kHz (the benchmark's direct-summation case: 2.5 -> 4.7 ms).
            for part, value in zip(acc, (value_re, value_im)):
                dr.scatter_reduce(dr.ReduceOp.Add, part, Int64(dr.round(weight * value)), flat,
                                  mode=dr.ReduceMode.Direct)
        return acc

    # One recording per grid size and kernel shape (a few per synthesizer; sessions that build
    # several synthesizers, e.g. fidelity levels and OFDM, make dozens): not a re-tracing fault.
    return dr.freeze(spread, warn_after=256)


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
        kernel_ft = self.sigma * np.sqrt(2 * np.pi) * np.exp(-2 * np.pi**2 * self.sigma**2 * nu**2)
        self._deconvolution = 1.0 / kernel_ft  # over the band

    def narrowband_groups(self, paths, waveform=None) -> list:
        """(paths, waveform) groups that synthesise ``paths`` (:class:`Paths` with per-hit blocks,
        or :class:`~mitsonar.trace.hitpaths.HitPaths`) driven by ``waveform`` with each
        hit's transmit elements merged (``paths.narrowband``) about the recorded centre
        frequency of each tone of the waveform (an OFDM code's ``parts``, else itself)."""
        waveform = self.band.pulse if waveform is None else waveform
        tones = getattr(waveform, "parts", (waveform,))
        centres = [self.band.band_moments(t)[0] for t in tones]
        return list(zip(paths.narrowband_many(centres), tones))

    def impulse_grid(self, paths: Paths, n_channels: int) -> np.ndarray:
        """Spread paths, shifted down by the band centre f_d (:attr:`Band.shift_bin`), onto the
        (n_channels, n_grid) sample grid (at :attr:`Band.sample_rate`) with the Gaussian kernel
        g: bin m of the grid's FFT holds bin m + shift_bin of the spectrum, times the kernel's
        transform.

        A first-order term b about f_c goes onto the same grid with the kernel's derivative,
        b (j 2 pi (f_c - f_d) g(x) - fs g'(x)), whose transform is -j 2 pi (f - f_c) times g's:
        one grid and one FFT carry both terms of a narrow-band merged path.

        Runs as one Dr.Jit LLVM kernel (a scatter-add per kernel tap), compiled once and reused.
        Contributions are accumulated as 64-bit fixed-point integers, whose sum does not depend
        on the order the threads add them in: the same paths give bit-identical recordings. The
        grid is returned in single precision (complex64: its rounding, ~6e-8 of the largest
        sample, is far below the band floor; its FFTs take half the time).
        """
        import drjit as dr
        Float64, Int64 = backend().Float64, backend().Int64

        band = self.band
        fs, n_grid = band.sample_rate, band.n_grid
        u = (np.asarray(paths.delay) - band.start_time) * fs
        keep = (u > -self.half_width) & (u < band.n_samples + self.half_width)
        channel = np.asarray(paths.channel)[keep]
        if len(channel) and (channel.min() < 0 or channel.max() >= n_channels):
            raise ValueError(f"path channel out of range 0..{n_channels - 1}")
        gain = np.asarray(paths.gain)[keep]
        inv_var = 1.0 / self.sigma**2
        omega = 2 * np.pi * (paths.carrier - band.fft_frequencies[band.shift_bin])  # [rad/s]
        # |j omega g(x) - fs g'(x)| <= |omega| + fs |x| / sigma^2 over the taps, |x| <= half_width + 1.
        slope = None if paths.first_order is None else np.asarray(paths.first_order)[keep]
        bound = np.abs(gain) if slope is None else \
            np.abs(gain) + np.abs(slope) * (abs(omega) + fs * (self.half_width + 1) * inv_var)
        peak = float(np.max(bound, initial=0.0))
        if len(channel) == 0 or peak == 0.0:
            return np.zeros((n_channels, n_grid), dtype=np.complex64)
        # Quantum 2^-36 of the largest contribution: up to 2^25 terms of that size cannot overflow
        # int64, and the rounding (1.5e-11 relative per term) is far below the synthesis tolerance.
        scale = 2.0 ** (36 - np.ceil(np.log2(peak)))
        first_order = None if slope is None else (
            to_jit(Float64, slope.real * scale), to_jit(Float64, slope.imag * scale),
            dr.opaque(Float64, omega))  # a variable, not a literal: one kernel for all carriers
        gains = (to_jit(Float64, gain.real * scale), to_jit(Float64, gain.imag * scale))
        acc = _spread_kernel()(n_channels * n_grid, to_jit(Float64, u[keep]),
                               to_jit(Int64, channel) * n_grid, gains, first_order,
                               dr.opaque(Float64, band.shift_bin / n_grid), n_grid,
                               self.half_width, inv_var, fs * inv_var)
        grid = np.empty((n_channels, n_grid), dtype=np.complex64)
        np.multiply(acc[0].numpy().reshape(grid.shape), 1.0 / scale, out=grid.real)
        np.multiply(acc[1].numpy().reshape(grid.shape), 1.0 / scale, out=grid.imag)
        return grid

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

        The paths of each distinct waveform go onto an impulse grid of their own (one kernel
        launch and one batched FFT per waveform: a grid of n_channels rows stays in cache, where
        one grid for the ten code tones of an OFDM cycle made the gridding 30 % slower).
        """
        band = self.band
        by_waveform: dict = {}
        for paths, waveform in groups:
            by_waveform.setdefault(band.pulse if waveform is None else waveform, []).append(paths)
        spectrum = np.zeros((n_channels, len(band.frequencies)), complex)
        for waveform, parts in by_waveform.items():
            grid = self.impulse_grid(Paths.concatenate([p.paths for p in parts]), n_channels)
            spectrum += sfft.fft(grid, axis=-1, workers=-1)[:, band.grid_bins] \
                * (band.system_spectrum(waveform)[band.bins] * self._deconvolution)
        return spectrum

    def group_spectrum(self, paths: Paths, waveform, n_channels: int) -> np.ndarray:
        """Analytic spectrum on the band (n_channels, nb) of the echoes of ``paths`` driven by
        ``waveform``."""
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
