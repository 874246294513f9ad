"""The signal band: the sample grid, recording window and spectra shared by synthesis and reception.

Recordings are real pressure at the sample rate, or (``baseband``) complex baseband: the analytic
recording a(t) demodulated by the band centre f_d, a(t) exp(-j 2 pi f_d t), sampled at the band's
own rate (about twice its width, a few times fewer numbers than the real recording). The pressure
is Re(samples exp(j 2 pi f_d t)) at the sample times t. Both are exact on the band; the band keeps
the system spectrum down to ``floor`` of its peak (leaving out the rest changes the echoes by
2-4 times that, relative to the peak echo). Spectra are handed around on the band only, as
(..., nb) arrays of the analytic recording's spectrum (bins :attr:`Band.bins` of the frequency
grid), whatever the recording's form: :meth:`Band.to_samples` and :meth:`Band.band_spectra`
convert between them and the recorded samples.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.fft as sfft

from mitsonar.caching import kept
from mitsonar.physics.transducer import Transducer
from mitsonar.trace.subbands import Subbands, hat_weights
from mitsonar.validation import check_finite, check_positive

#: Complex baseband recordings are sampled at this many times the band's width.
BASEBAND_OVERSAMPLING = 2
#: Automatic choice: baseband when its sample rate is at most this fraction of the real one. (The
#: real form's impulse grid and receive chain are complex at the full rate too; measured: OFDM
#: frames at 0.65 of the rate 13 % faster, pings at 0.17 of it 30 %.)
BASEBAND_AUTO = 0.7
#: The band keeps frequencies below this share of the reference sample rate; the drive's
#: spectrum above it is left out (:class:`~mitsonar.sensors.sonar.SonarConfig` refuses drives
#: whose band reaches it).
BAND_TOP = 0.4
#: Bytes of complex grid inverse-transformed at a time (:meth:`Band.to_analytic`): a few rows
#: that stay in the processor's cache (measured: the 600 envelopes of a paper-preset cycle's
#: code-ownership test, 8 800 samples each, 2.6x faster 32 rows at a time than all at once).
TRANSFORM_BYTES = 4 * 2**20
#: Codes' system responses kept by :func:`code_response` for the whole process (~54 kB each;
#: a 117-beam OFDM frame asks for ~80).
RESPONSES_KEPT = 256
#: Demodulation tables kept by :meth:`Band.demodulation` (an OFDM schedule's cycles ask for
#: theirs every frame).
DEMODULATIONS_KEPT = 16

_responses: dict = {}


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


class Band:
    """The band of a sensor's recordings, for one fixed recording window: sample grid, band bins,
    recording form, the system spectra of the waveforms, and the conversions between recorded
    samples and spectra on the band. Construct once and share (synthesizer, receiver); each
    waveform's system spectrum is computed once.

    Args:
        pulse: the default drive waveform (anything with ``spectrum(f)``, ``duration`` and
            ``frequency``, e.g. :class:`~mitsonar.physics.waveforms.Pulse` or an OFDM code).
        transducer: element model; its response is applied twice (transmit and receive) when
            ``transducer_response`` is true.
        sample_rate: sample rate of real recordings [Hz]; it sets the frequency grid (n_fft bins
            of sample_rate / n_fft) and the noise reference in both forms.
        start_time: time of the first sample [s] (negative to record the firing itself).
        duration: recording length [s].
        transducer_response: apply H_tx H_rx (false: ideal flat transducers, as in (1)(3)).
        floor: spectral components of the system waveform below this fraction of its peak
            are left out (they are far below the receiver noise).
        waveforms: further waveforms the band must serve (the bins span all their bands).
        baseband: record complex baseband at ``BASEBAND_OVERSAMPLING`` times the band's width
            (module docstring) instead of real pressure at ``sample_rate``; None: whenever that
            rate is at most ``BASEBAND_AUTO`` x ``sample_rate``.

    Attributes of the recordings: ``sample_rate`` [Hz] (the band's rate with ``baseband``),
    ``n_samples``, ``start_time`` [s] and ``carrier`` [Hz] (0 for real recordings).
    """

    def __init__(self, pulse, transducer: Transducer, sample_rate: float, start_time: float,
                 duration: float, transducer_response: bool = True, floor: float = 1e-5,
                 waveforms=(), baseband: bool | None = False):
        check_positive("sample_rate [Hz]", sample_rate)
        check_positive("duration [s]", duration)
        check_finite("start_time [s]", start_time)
        self.pulse = pulse
        self.transducer = transducer
        self.transducer_response = transducer_response
        self.floor = floor
        self.reference_rate = float(sample_rate)
        self.start_time = float(start_time)
        n_real = int(np.ceil(duration * sample_rate))
        # Guard samples so that the ringing of the last echoes does not wrap onto the first ones.
        ringing = 14 * transducer.decay_time if transducer_response else 0.0
        longest = max(w.duration for w in (pulse,) + tuple(waveforms))
        guard = int(np.ceil((longest + ringing) * sample_rate)) + 64
        #: Size of the frequency grid, of real recordings' transforms and of their period.
        self.n_fft = sfft.next_fast_len(n_real + guard)
        #: (n_fft,) frequencies of the FFT bins [Hz].
        self.fft_frequencies = np.fft.fftfreq(self.n_fft, 1.0 / sample_rate)
        self._spectra = {}
        self._moments = {}  # waveform -> (centre, rms bandwidth) [Hz]
        self.bins = None
        nonzero = np.flatnonzero(np.any([self.system_spectrum(w) != 0
                                         for w in (pulse,) + tuple(waveforms)], axis=0))
        #: FFT bins (a slice of :attr:`fft_frequencies`) spanning the bands of every waveform
        #: served: spectra are zero outside, so filtering and beamforming are computed here only.
        self.bins = slice(int(nonzero[0]), int(nonzero[-1]) + 1)
        #: (nb,) frequencies of the band's bins [Hz].
        self.frequencies = self.fft_frequencies[self.bins]
        #: FFT bin of the band's centre f_d.
        self.shift_bin = (self.bins.start + self.bins.stop - 1) // 2
        band_bins = np.arange(self.bins.start, self.bins.stop)
        if baseband is None:
            baseband = BASEBAND_OVERSAMPLING * len(band_bins) <= BASEBAND_AUTO * self.n_fft
        #: True: recordings are complex baseband; False: real pressure.
        self.baseband = bool(baseband)
        #: Samples per period of the recording (and of the synthesizer's impulse grid): n_fft
        #: for real recordings, ``BASEBAND_OVERSAMPLING`` x the band's bins for baseband (same
        #: period, same bins).
        self.n_grid = sfft.next_fast_len(BASEBAND_OVERSAMPLING * len(band_bins)) if baseband \
            else self.n_fft
        #: Sample rate of the recordings [Hz].
        self.sample_rate = self.reference_rate * self.n_grid / self.n_fft
        self.n_samples = int(np.ceil(duration * self.sample_rate)) if baseband else n_real
        #: Demodulation frequency of the recordings [Hz]: f_d for baseband, 0 for real pressure.
        self.carrier = float(self.fft_frequencies[self.shift_bin]) if baseband else 0.0
        #: (nb,) bins of the band on an n_grid transform of a signal shifted down by f_d.
        self.grid_bins = (band_bins - self.shift_bin) % self.n_grid
        # The recording's transform bins of the band, with the factor from the grid's spectrum
        # to a(t) exp(-j 2 pi carrier t) (module docstring), as runs of contiguous bins, (grid
        # slice, band slice): one for real recordings, two for baseband (the band wraps around
        # the grid's bin 0); NumPy writes slices several times faster than index arrays.
        output = self.grid_bins if baseband else band_bins
        edges = np.concatenate([[0], np.flatnonzero(np.diff(output) != 1) + 1, [len(output)]])
        self._output_runs = [(slice(int(output[a]), int(output[b - 1]) + 1), slice(int(a), int(b)))
                             for a, b in zip(edges[:-1], edges[1:])]
        self._demodulations = {}  # (frequencies, start time, n) -> (T, n) phasors
        self._output_scale = self.n_grid / self.n_fft \
            * np.exp(-2j * np.pi * self.carrier * self.start_time)

    def system_spectrum(self, waveform=None) -> np.ndarray:
        """Analytic spectrum W(f) (n_fft,) of the expected echo of a unit path (drive x H_tx x
        H_rx) on the FFT grid, scaled per sample; zero outside the band. Cached per waveform
        (default: the pulse); a waveform not given to the constructor must lie within
        :attr:`bins`. A :class:`SubBand`'s is its drive's times the node's hat weight."""
        waveform = self.pulse if waveform is None else waveform
        if waveform not in self._spectra and isinstance(waveform, SubBand):
            # the drive's spectrum, cut at its floor, through the node's weight
            self._spectra[waveform] = self.system_spectrum(waveform.waveform) * hat_weights(
                waveform.nodes, self.fft_frequencies)[waveform.index]
        if waveform not in self._spectra:
            f = self.fft_frequencies
            positive = f > 0
            w = np.zeros(self.n_fft, dtype=complex)
            w[positive] = self.system_response(waveform, f[positive])
            kept = (np.abs(w) > self.floor * np.abs(w).max()) \
                & (np.abs(f) < BAND_TOP * self.reference_rate)
            w = np.where(kept, w, 0.0)
            if self.bins is not None \
                    and (np.any(w[: self.bins.start]) or np.any(w[self.bins.stop:])):
                raise ValueError(f"waveform {waveform!r} has a wider band than the band was "
                                 f"built for; pass it in Band(waveforms=...)")
            self._spectra[waveform] = w
        return self._spectra[waveform]

    def system_response(self, waveform, frequencies) -> np.ndarray:
        """The system spectrum's values at positive ``frequencies`` [Hz] (any grid), before the
        band's floor: 2 x the drive's spectrum per sample at the reference rate, through both
        transducer responses."""
        w = 2.0 * waveform.spectrum(frequencies) * self.reference_rate
        if self.transducer_response:
            w = w * self.transducer.frequency_response(frequencies) ** 2
        return w

    def band_moments(self, waveform=None) -> tuple[float, float]:
        """Centre (power-weighted mean) and rms bandwidth [Hz] of the system spectrum of
        ``waveform``: what the receiver records, the drive through both transducer responses;
        computed once per waveform (the synthesis asks for every tone of every cycle)."""
        waveform = self.pulse if waveform is None else waveform
        if waveform not in self._moments:
            f = self.fft_frequencies
            power = np.abs(self.system_spectrum(waveform)) ** 2
            centre = float(np.sum(f * power) / np.sum(power))
            self._moments[waveform] = (
                centre, float(np.sqrt(np.sum((f - centre) ** 2 * power) / np.sum(power))))
        return self._moments[waveform]

    @property
    def transform_rows(self) -> int:
        """Rows that :meth:`to_analytic` inverse-transforms at a time (``TRANSFORM_BYTES``)."""
        return max(1, TRANSFORM_BYTES // (16 * self.n_grid))

    def to_analytic(self, spectrum: np.ndarray, dtype=complex) -> np.ndarray:
        """Analytic recording (..., n_samples), demodulated by :attr:`carrier`, of analytic
        spectra on the band (..., nb): a(t) exp(-j 2 pi carrier t) at the sample times; an
        inverse FFT per row, :attr:`transform_rows` rows at a time, in the precision of
        ``dtype`` (complex or np.complex64: half the transform's work, ~6e-8 relative)."""
        rows = spectrum.reshape(-1, spectrum.shape[-1])
        out = np.empty((len(rows), self.n_samples), dtype=dtype)
        step = self.transform_rows
        for first in range(0, len(rows), step):  # a few MiB at a time: in the cache
            chunk = rows[first: first + step] * self._output_scale
            full = np.zeros((len(chunk), self.n_grid), dtype=dtype)
            for grid, band in self._output_runs:  # slices: several times faster than indices
                full[:, grid] = chunk[:, band]
            out[first: first + step] = sfft.ifft(full, axis=-1, workers=-1,
                                                 overwrite_x=True)[:, : self.n_samples]
        return out.reshape(spectrum.shape[:-1] + (self.n_samples,))

    def demodulation(self, frequencies: np.ndarray, start_time: float, n: int) -> np.ndarray:
        """(T, n) exp(-j 2 pi (f_t - :attr:`carrier`) t) at n sample times from ``start_time``
        [s]: what turns the analytic recordings into channels demodulated at ``frequencies``
        (T,) [Hz] (:class:`~mitsonar.signal.looks.Looks`); kept for ``DEMODULATIONS_KEPT`` sets of
        arguments (an OFDM schedule's cycles ask for theirs every frame; read only)."""
        frequencies = np.asarray(frequencies, dtype=float)
        key = (frequencies.tobytes(), float(start_time), int(n))

        def table():
            times = start_time + np.arange(n) / self.sample_rate
            phasors = np.exp(-2j * np.pi * (frequencies - self.carrier)[:, None] * times)
            phasors.setflags(write=False)
            return phasors
        return kept(self._demodulations, key, DEMODULATIONS_KEPT, table)

    def envelopes(self, spectra: np.ndarray, filters: np.ndarray, n: int | None = None,
                  batch: int | None = None, dtype=float) -> np.ndarray:
        """Envelopes |a(t)| (R, n) [Pa] of spectra on the band (R, nb) matched-filtered by
        ``filters``, (nb,) for every row or (R, nb) one per row: an inverse FFT per row
        (:meth:`to_analytic`), ``batch`` rows at a time (default: :attr:`transform_rows`;
        bounds the complex temporaries), kept as ``dtype``; ``n`` samples (default:
        :attr:`n_samples`)."""
        n = self.n_samples if n is None else n
        count = len(spectra)
        batch = batch or self.transform_rows
        out = np.empty((count, n), dtype)
        for first in range(0, count, batch):
            rows = slice(first, first + batch)
            weights = filters if np.ndim(filters) == 1 else filters[rows]
            out[rows] = np.abs(self.to_analytic(spectra[rows] * weights)[:, :n])
        return out

    def band_spectra(self, samples: np.ndarray) -> np.ndarray:
        """Analytic spectra on the band (..., nb) of recorded samples (..., n_samples), real or
        baseband as this band records them: the inverse of :meth:`to_samples` on the band (the
        recording's end cuts echoes that outlast it)."""
        if self.baseband:
            return sfft.fft(samples, n=self.n_grid, axis=-1, workers=-1)[..., self.grid_bins] \
                / self._output_scale
        return 2.0 * sfft.rfft(samples, n=self.n_fft, axis=-1, workers=-1)[..., self.bins]

    def to_samples(self, spectrum: np.ndarray) -> np.ndarray:
        """Noiseless recorded samples (n_channels, n_samples) of a summed analytic spectrum on the
        band (n_channels, nb): complex baseband (:meth:`to_analytic`), or the real pressure [Pa]
        by a half-length inverse FFT (the spectrum lives at positive frequencies below fs / 2)."""
        if self.baseband:
            return self.to_analytic(spectrum)
        half = np.zeros((len(spectrum), self.n_fft // 2 + 1), dtype=complex)
        half[:, self.bins] = 0.5 * spectrum
        return sfft.irfft(half, n=self.n_fft, axis=-1, workers=-1)[:, : self.n_samples]


def code_response(band: Band, waveform, frequencies) -> np.ndarray:
    """``band.system_response(waveform, frequencies)`` (:meth:`Band.system_response`), kept per
    (waveform, frequencies, reference rate, transducer) for the whole process: every cycle of a
    frame fires codes again, and a new Sonar (a new synthesizer) on the same settings asks for
    the same ones."""
    frequencies = np.asarray(frequencies, dtype=float)
    key = (waveform, frequencies.tobytes(), band.reference_rate, band.transducer,
           band.transducer_response)
    return kept(_responses, key, RESPONSES_KEPT,
                lambda: band.system_response(waveform, frequencies))


@dataclass(frozen=True)
class SubBand:
    """A drive waveform seen through the ``index``-th hat weight of frequency ``nodes`` [Hz]
    (:func:`~mitsonar.trace.subbands.hat_weights`): the drive of the path set whose gains were
    evaluated at that node (:class:`~mitsonar.trace.subbands.Subbands`). The K sub-bands' spectra
    add up to the drive's.

    Attributes:
        waveform: the drive (a Pulse, Chirp or OFDM code).
        nodes: the nodes [Hz], increasing.
        index: which node.
    """

    waveform: object
    nodes: tuple
    index: int

    def spectrum(self, frequencies) -> np.ndarray:
        """The drive's spectrum times this node's weight at ``frequencies`` [Hz]."""
        return self.waveform.spectrum(frequencies) \
            * hat_weights(self.nodes, frequencies)[self.index]

    @property
    def parts(self) -> tuple:
        """The drive's tones (an OFDM code's ``parts``), each through this weight."""
        return tuple(SubBand(p, self.nodes, self.index)
                     for p in getattr(self.waveform, "parts", (self.waveform,)))

    @property
    def duration(self) -> float:
        """The drive's duration [s]."""
        return self.waveform.duration

    @property
    def frequency(self) -> float:
        """The drive's centre frequency [Hz]."""
        return self.waveform.frequency


def node_groups(paths: Subbands, waveform) -> list:
    """[(paths, waveform)] of a wide band's path sets: set k driven by ``waveform`` through
    node k's hat weight."""
    return [(part, SubBand(waveform, paths.nodes, k)) for k, part in enumerate(paths.parts)]
