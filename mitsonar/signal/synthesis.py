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

Recordings are real pressure at the sample rate, or (``baseband``) complex baseband: the analytic
recording a(t) demodulated by the band centre, a(t) exp(-j 2 pi f_d t), sampled at the band's own
rate (about twice its width, a few times fewer numbers than the real recording). The pressure is
Re(samples exp(j 2 pi f_d t)) at the sample times t. Both are exact on the band; the band keeps the
system spectrum down to ``band_threshold`` of its peak (leaving out the rest changes the echoes by
2-4 times that, relative to the peak echo). Spectra are handed around on the band only, as (..., nb)
arrays of the analytic recording's spectrum (bins :attr:`EchoSynthesizer.band` of the frequency
grid), whatever the recording's form.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cache

import numpy as np
import scipy.fft as sfft

from mitsonar.jit import to_jit
from mitsonar.physics.transducer import Transducer
from mitsonar.trace.paths import Paths
from mitsonar.validation import check_finite, check_positive


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
    from drjit.llvm import Float64, Int64, UInt32

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


#: Complex baseband recordings are sampled at this many times the band's width.
BASEBAND_OVERSAMPLING = 2
#: Automatic choice: baseband when its sample rate is at most this fraction of the real one. (The
#: real form's impulse grid and receive chain are complex at the full rate too; measured: OFDM
#: frames at 0.65 of the rate 13 % faster, pings at 0.17 of it 30 %.)
BASEBAND_AUTO = 0.7


@dataclass(frozen=True)
class Recording:
    """Sampled echoes of all receive channels.

    Attributes:
        samples: (N_rx, N) received pressure [Pa] (receiver response included), real; or complex
            baseband when ``carrier`` > 0: the pressure is Re(samples exp(j 2 pi carrier t)).
        sample_rate: [Hz].
        start_time: time of sample 0 relative to the virtual firing of the transmit origin [s].
        carrier: demodulation frequency of complex baseband samples [Hz] (0: real pressure).
    """

    samples: np.ndarray
    sample_rate: float
    start_time: float
    carrier: float = 0.0

    @property
    def times(self) -> np.ndarray:
        """(N,) sample times [s]."""
        return self.start_time + np.arange(self.samples.shape[-1]) / self.sample_rate


class EchoSynthesizer:
    """Fast band-limited synthesis of recordings from paths, for one fixed recording window.

    Construct once and reuse: the kernel and each waveform's system spectrum are precomputed.

    Args:
        pulse: the default drive waveform (anything with ``spectrum(f)``, ``duration`` and
            ``frequency``, e.g. :class:`~mitsonar.physics.waveforms.Pulse` or an OFDM code).
        transducer: element model; its response is applied twice (transmit and receive) when
            ``transducer_response`` is true.
        sample_rate: sample rate of real recordings [Hz]; it sets the frequency grid (n_fft bins
            of sample_rate / n_fft) and the noise reference (:meth:`recording`) in both forms.
        start_time: time of the first sample [s] (negative to record the firing itself).
        duration: recording length [s].
        transducer_response: apply H_tx H_rx (false: ideal flat transducers, as in (1)(3)).
        tolerance: relative accuracy of the kernel (aliasing and truncation); default a tenth of
            ``band_threshold``, below the band's own error.
        band_threshold: spectral components of the system waveform below this fraction of its
            peak are left out (they are far below the receiver noise).
        waveforms: further waveforms the synthesizer must serve (their bands set the kernel).
        baseband: record complex baseband at ``BASEBAND_OVERSAMPLING`` times the band's width
            (module docstring) instead of real pressure at ``sample_rate``; None: whenever that
            rate is at most ``BASEBAND_AUTO`` x ``sample_rate``.

    Attributes of the recordings made: ``sample_rate`` [Hz] (the band's rate with ``baseband``),
    ``n_samples``, ``start_time`` [s] and ``carrier`` [Hz] (0 for real recordings).
    """

    def __init__(self, pulse, transducer: Transducer, sample_rate: float, start_time: float,
                 duration: float, transducer_response: bool = True, tolerance: float | None = None,
                 band_threshold: float = 1e-5, waveforms=(), baseband: bool | None = False):
        check_positive("sample_rate [Hz]", sample_rate)
        check_positive("duration [s]", duration)
        check_finite("start_time [s]", start_time)
        self.pulse = pulse
        self.transducer = transducer
        self.transducer_response = transducer_response
        self.band_threshold = band_threshold
        self.reference_rate = float(sample_rate)
        self.start_time = float(start_time)
        n_real = int(np.ceil(duration * sample_rate))
        # Guard samples so that the ringing of the last echoes does not wrap onto the first ones.
        ringing = 14 * transducer.decay_time if transducer_response else 0.0
        longest = max(w.duration for w in (pulse,) + tuple(waveforms))
        guard = int(np.ceil((longest + ringing) * sample_rate)) + 64
        #: Size of the frequency grid, of real recordings' transforms and of their period.
        self.n_fft = sfft.next_fast_len(n_real + guard)
        self._freq = np.fft.fftfreq(self.n_fft, 1.0 / sample_rate)
        self._spectra = {}
        self.band = None
        nonzero = np.flatnonzero(np.any([self.system_spectrum(w) != 0
                                         for w in (pulse,) + tuple(waveforms)], axis=0))
        #: FFT bins (a slice of :attr:`frequencies`) spanning the bands of every waveform served:
        #: spectra are zero outside, so filtering and beamforming are computed here only.
        self.band = slice(int(nonzero[0]), int(nonzero[-1]) + 1)
        #: FFT bin of the band's centre f_d, by which paths are shifted down before gridding.
        self.shift_bin = (self.band.start + self.band.stop - 1) // 2
        band_bins = np.arange(self.band.start, self.band.stop)
        if baseband is None:
            baseband = BASEBAND_OVERSAMPLING * len(band_bins) <= BASEBAND_AUTO * self.n_fft
        #: True: recordings are complex baseband; False: real pressure.
        self.baseband = bool(baseband)
        #: Samples per period of the impulse grid and of the recording: n_fft for real recordings,
        #: ``BASEBAND_OVERSAMPLING`` x the band's bins for baseband (same period, same bins).
        self.n_grid = sfft.next_fast_len(BASEBAND_OVERSAMPLING * len(band_bins)) if baseband \
            else self.n_fft
        #: Sample rate of the recordings [Hz].
        self.sample_rate = self.reference_rate * self.n_grid / self.n_fft
        self.n_samples = int(np.ceil(duration * self.sample_rate)) if baseband else n_real
        #: Demodulation frequency of the recordings [Hz]: f_d for baseband, 0 for real pressure.
        self.carrier = float(self._freq[self.shift_bin]) if baseband else 0.0
        # Grid FFT bins of the band, and the recording's transform bins of the band with the
        # factor from the grid's spectrum to a(t) exp(-j 2 pi carrier t) (module docstring).
        self._grid_bins = (band_bins - self.shift_bin) % self.n_grid
        self._output_bins = self._grid_bins if baseband else band_bins
        self._output_scale = self.n_grid / self.n_fft \
            * np.exp(-2j * np.pi * self.carrier * self.start_time)
        nu = (band_bins - self.shift_bin) / self.n_grid
        nu_max = np.abs(nu).max()
        #: Relative accuracy of the gridding kernel.
        self.tolerance = tolerance = 0.1 * band_threshold if tolerance is None else tolerance
        # Gaussian kernel (sigma in samples): aliasing from the images at fs - f stays below the
        # tolerance, and truncation stays below it after the deconvolution gain at nu_max (f
        # relative to f_d).
        log_tol = np.log(1.0 / tolerance)
        self.sigma = float(np.sqrt(log_tol / (2 * np.pi**2 * (1 - 2 * nu_max))))
        deconv_gain = np.exp(2 * np.pi**2 * self.sigma**2 * nu_max**2)
        self.half_width = int(np.ceil(self.sigma * np.sqrt(2 * np.log(deconv_gain / tolerance))))
        kernel_ft = self.sigma * np.sqrt(2 * np.pi) * np.exp(-2 * np.pi**2 * self.sigma**2 * nu**2)
        self._deconvolution = 1.0 / kernel_ft  # over the band

    @property
    def frequencies(self) -> np.ndarray:
        """(n_fft,) frequencies of the FFT bins [Hz]."""
        return self._freq

    def system_spectrum(self, waveform=None) -> np.ndarray:
        """Analytic spectrum W(f) of the expected echo of a unit path (drive x H_tx x H_rx) on
        the FFT grid, scaled per sample; zero outside the band. Cached per waveform; a waveform
        not given to the constructor must lie within :attr:`band`."""
        waveform = self.pulse if waveform is None else waveform
        if waveform not in self._spectra:
            f = self._freq
            positive = f > 0
            w = np.zeros(self.n_fft, dtype=complex)
            w[positive] = 2.0 * waveform.spectrum(f[positive]) * self.reference_rate
            if self.transducer_response:
                w[positive] *= self.transducer.frequency_response(f[positive]) ** 2
            band = (np.abs(w) > self.band_threshold * np.abs(w).max()) & (np.abs(f) < 0.4 * self.reference_rate)
            w = np.where(band, w, 0.0)
            if self.band is not None and (np.any(w[: self.band.start]) or np.any(w[self.band.stop:])):
                raise ValueError(f"waveform {waveform!r} has a wider band than the synthesizer was "
                                 f"built for; pass it in EchoSynthesizer(waveforms=...)")
            self._spectra[waveform] = w
        return self._spectra[waveform]

    def band_moments(self, waveform=None) -> tuple[float, float]:
        """Centre (power-weighted mean) and rms bandwidth [Hz] of the system spectrum of
        ``waveform``: what the receiver records, the drive through both transducer responses."""
        power = np.abs(self.system_spectrum(waveform)) ** 2
        centre = float(np.sum(self._freq * power) / np.sum(power))
        return centre, float(np.sqrt(np.sum((self._freq - centre) ** 2 * power) / np.sum(power)))

    def narrowband_groups(self, paths, waveform=None) -> list:
        """(paths, waveform) groups that synthesise ``paths`` (:class:`Paths` with per-hit blocks,
        or :class:`~mitsonar.trace.hitpaths.HitPaths`) driven by ``waveform`` with each
        hit's transmit elements merged (``paths.narrowband``) about the recorded centre
        frequency of each tone of the waveform (an OFDM code's ``parts``, else itself)."""
        waveform = self.pulse if waveform is None else waveform
        tones = getattr(waveform, "parts", (waveform,))
        return list(zip(paths.narrowband_many([self.band_moments(t)[0] for t in tones]), tones))

    def impulse_grid(self, paths: Paths, n_channels: int) -> np.ndarray:
        """Spread paths, shifted down by the band centre f_d (:attr:`shift_bin`), onto the
        (n_channels, n_grid) sample grid (at :attr:`sample_rate`) with the Gaussian kernel g: bin
        m of the grid's FFT holds bin m + shift_bin of the spectrum, times the kernel's transform.

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
        from drjit.llvm import Float64, Int64

        fs, n_grid = self.sample_rate, self.n_grid
        u = (np.asarray(paths.delay) - self.start_time) * fs
        keep = (u > -self.half_width) & (u < self.n_samples + self.half_width)
        channel = np.asarray(paths.channel)[keep]
        if len(channel) and (channel.min() < 0 or channel.max() >= n_channels):
            raise ValueError(f"path channel out of range 0..{n_channels - 1}")
        gain = np.asarray(paths.gain)[keep]
        inv_var = 1.0 / self.sigma**2
        omega = 2 * np.pi * (paths.carrier - self._freq[self.shift_bin])  # [rad/s]
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
                               dr.opaque(Float64, self.shift_bin / n_grid), n_grid,
                               self.half_width, inv_var, fs * inv_var)
        grid = np.empty((n_channels, n_grid), dtype=np.complex64)
        np.multiply(acc[0].numpy().reshape(grid.shape), 1.0 / scale, out=grid.real)
        np.multiply(acc[1].numpy().reshape(grid.shape), 1.0 / scale, out=grid.imag)
        return grid

    def analytic(self, paths: Paths, n_channels: int, waveform=None) -> np.ndarray:
        """Noiseless :meth:`to_analytic` recordings (n_channels, n_samples) of paths driven by
        ``waveform`` (default: the synthesizer's pulse)."""
        return self.analytic_sum([(paths, waveform)], n_channels)

    def analytic_sum(self, groups, n_channels: int) -> np.ndarray:
        """:meth:`analytic` of several path sets, each with its own waveform: [(paths, waveform)]."""
        return self.to_analytic(self.groups_spectrum(groups, n_channels))

    def groups_spectrum(self, groups, n_channels: int) -> np.ndarray:
        """Summed analytic spectrum on the band (n_channels, nb) of [(paths, waveform)] groups;
        spectra of several calls add up to their joint recording (see :meth:`to_samples`).

        All groups go onto one impulse grid with a block of channels per distinct waveform (one
        kernel launch), transformed by one batched FFT.
        """
        by_waveform: dict = {}
        for paths, waveform in groups:
            by_waveform.setdefault(self.pulse if waveform is None else waveform, []).append(paths)
        waveforms = list(by_waveform)
        stacked = Paths.concatenate([replace(p.paths, channel=p.channel + k * n_channels, elements=None)
                                     for k, w in enumerate(waveforms) for p in by_waveform[w]])
        grid = self.impulse_grid(stacked, len(waveforms) * n_channels)
        spectra = sfft.fft(grid, axis=-1, workers=-1).reshape(len(waveforms), n_channels, self.n_grid)
        filters = np.stack([self.system_spectrum(w)[self.band] for w in waveforms]) * self._deconvolution
        spectrum = spectra[0][:, self._grid_bins] * filters[0]
        for k in range(1, len(waveforms)):  # a few waveforms (einsum is 2x slower here)
            spectrum += spectra[k][:, self._grid_bins] * filters[k]
        return spectrum

    def group_spectrum(self, paths: Paths, waveform, n_channels: int) -> np.ndarray:
        """Analytic spectrum on the band (n_channels, nb) of the echoes of ``paths`` driven by
        ``waveform``."""
        return self.groups_spectrum([(paths, waveform)], n_channels)

    def to_analytic(self, spectrum: np.ndarray) -> np.ndarray:
        """Analytic recording (..., n_samples), demodulated by :attr:`carrier`, of analytic spectra
        on the band (..., nb): a(t) exp(-j 2 pi carrier t) at the sample times."""
        full = np.zeros(spectrum.shape[:-1] + (self.n_grid,), dtype=complex)
        full[..., self._output_bins] = spectrum * self._output_scale
        return sfft.ifft(full, axis=-1, workers=-1)[..., : self.n_samples]

    def band_spectra(self, samples: np.ndarray) -> np.ndarray:
        """Analytic spectra on the band (..., nb) of recorded samples (..., n_samples), real or
        baseband as this synthesizer records them: the inverse of :meth:`to_samples` on the band
        (the recording's end cuts echoes that outlast it)."""
        if self.baseband:
            return sfft.fft(samples, n=self.n_grid, axis=-1, workers=-1)[..., self._output_bins] \
                / self._output_scale
        return 2.0 * sfft.rfft(samples, n=self.n_fft, axis=-1, workers=-1)[..., self.band]

    def to_samples(self, spectrum: np.ndarray) -> np.ndarray:
        """Noiseless recorded samples (n_channels, n_samples) of a summed analytic spectrum on the
        band (n_channels, nb): complex baseband (:meth:`to_analytic`), or the real pressure [Pa]
        by a half-length inverse FFT (the spectrum lives at positive frequencies below fs / 2)."""
        if self.baseband:
            return self.to_analytic(spectrum)
        half = np.zeros((len(spectrum), self.n_fft // 2 + 1), dtype=complex)
        half[:, self.band] = 0.5 * spectrum
        return sfft.irfft(half, n=self.n_fft, axis=-1, workers=-1)[:, : self.n_samples]

    def synthesize(self, paths: Paths, n_channels: int, noise_rms: float = 0.0,
                   seed=None, waveform=None) -> Recording:
        """Recording of ``n_channels`` channels with additive white Gaussian receiver noise.

        Args:
            paths: the acoustic paths.
            n_channels: number of receive channels.
            noise_rms: noise standard deviation per real sample at ``reference_rate`` [Pa] (see
                :meth:`recording`); needs ``seed`` when > 0.
            seed: seed of the noise generator (same seed, same recording).
            waveform: drive waveform (default: the synthesizer's pulse).
        """
        return self.recording(self.to_samples(self.group_spectrum(paths, waveform, n_channels)),
                              noise_rms, seed)

    def recording(self, channels: np.ndarray, noise_rms: float = 0.0, seed=None) -> Recording:
        """Recording of channels (n_channels, n_samples) [Pa] (real recordings keep the real part
        of analytic ones), plus seeded white receiver noise of ``noise_rms`` [Pa] per sample of
        a real recording at ``reference_rate``. Baseband noise has the same density on the band:
        complex, sqrt(2 sample_rate / reference_rate) ``noise_rms`` in each part."""
        samples = channels if self.baseband else channels.real
        if noise_rms > 0:
            if seed is None:
                raise ValueError("noise_rms > 0 needs an explicit seed")
            rng = np.random.default_rng(seed)
            if self.baseband:
                sigma = noise_rms * np.sqrt(2 * self.sample_rate / self.reference_rate)
                noise = rng.normal(0.0, sigma, (2,) + samples.shape)
                samples = samples + (noise[0] + 1j * noise[1])
            else:
                samples = samples + rng.normal(0.0, noise_rms, samples.shape)
        return Recording(samples, self.sample_rate, self.start_time, self.carrier)
