"""Every echo of a beam (``DetectionSettings.echoes`` = "all" or "cells"), for B beams at once.

Multibeam echosounders report several detections per beam, and phase-measuring ones a sounding
for every instant of an echo, placed at the angle the receive array measures then. This module
chooses those instants; :class:`~mitsonar.signal.receiver.EchoProcessor` checks them (parts,
side lobes), places them (arrival direction, bistatic depth (7)) and reports them
(:class:`~mitsonar.signal.detection.Echoes`).

* Range resolution tau_r: the full width at -3 dB of the envelope that one echo leaves after the
  matched filter, the autocorrelation envelope |R(tau)| of the expected echo (drive through both
  transducer responses, :meth:`Band.system_spectrum
  <mitsonar.signal.band.Band.system_spectrum>`): |R| = |IFFT |W(f)|^2| on the band, normalised
  to R(0) = 1, read between samples by linear interpolation (:func:`range_profile`). The TCT40
  pulse: 0.76 ms (13 cm of depth at 343 m/s); the paper preset's ideal transducers: 0.29 ms
  (5.0 cm); 20 kHz broadband transducers: 0.34 ms (5.8 cm), their OFDM codes 0.14 ms (2.4 cm).
* Echoes ("all", :func:`echo_peaks`): the local maxima of a beam's envelope in its window over
  the receiver's threshold (``detection_snr`` x the RMS noise envelope, ``detection_floor``,
  direct-path blanking) with no stronger local maximum within tau_r, and over the local clutter
  (:class:`Clutter`): ``clutter_margin`` times what the stronger echoes of the recording leave
  there, their range side lobes and ringing A_j |R(t - t_j)| (what a point echo of amplitude
  A_j leaves at that lag) and, in an OFDM cycle, the other codes' cross-talk. A cell-averaging
  CFAR would also suppress the extended echoes that "cells" is after; this clutter follows the
  waveforms exactly. Echoes outside the window count as clutter too. Each echo must then have
  its parts balanced and pass the side-lobe check (:mod:`~mitsonar.signal.receiver`).
* Range cells ("cells", :func:`range_cells`): the echoes, plus every sample on a grid of
  ceil(tau_r) samples that lies in a run of the envelope over the threshold holding an accepted
  echo, at least tau_r from every accepted echo, over the clutter of every stronger resolved
  maximum or grid sample (an extended echo is a chain of such cells; the ringing of a point echo
  is not: it is explained by the echo), with its parts balanced and passing the side-lobe check.
  A cell is read at its sample (no parabola: it is no peak) along the arrival direction
  measured at that instant. Speckle: an oblique diffuse surface already gives an echo about
  every tau_r, so cells add points only where its envelope stays flat for over 2 tau_r.
* Trust (both settings): an echo or cell is kept only if its arrival direction is trustworthy:
  at least ``min_coherence`` of the receive channels' power at that instant is explained by one
  plane wave from it (:meth:`Beamformer.coherence
  <mitsonar.signal.beamforming.Beamformer.coherence>`; one arrival: 1; an echo eta times the
  noise envelope: (eta^2 + 1) / (eta^2 + N_rx); receiver noise alone: 1 / N_rx = 0.04; several
  arrivals at once, such as two surfaces at one range or cross-talk over an echo, lower). On
  one OFDM frame each of room_glass and office (paper preset; 20 kHz transducers), 59-75 % of
  the echoes of coherence under 0.5 were within 2 cm of the mesh, 58-92 % of those in 0.5-0.6,
  90-100 % of those over 0.6 (the default ``min_coherence``). With ``arrival_cone`` the
  direction must also lie inside the cone the beam's transmit beam lights. A trusted direction
  already passes the side-lobe check there (docs/imaging.md): with ``ghost_margin`` 0 the two
  trust it alone.
* False-alarm rate (:func:`expected_false_alarms`): receiver noise alone gives a Rayleigh
  envelope of RMS sigma (:meth:`EchoProcessor.noise_envelope_rms
  <mitsonar.signal.receiver.EchoProcessor.noise_envelope_rms>`), over eta sigma with probability
  exp(-eta^2) per sample; it rises through eta sigma 2 sqrt(pi) b eta exp(-eta^2) times a
  second (Rice), b the rms bandwidth of the matched-filter output (:meth:`Band.band_moments
  <mitsonar.signal.band.Band.band_moments>`). Each rise is one echo at most, so a window of T
  seconds, N = 2 sqrt(pi) b T independent cells, gives N eta exp(-eta^2) false echoes per beam
  (design value): with the default eta = 5, 3e-9 for the TCT40 pulse (b = 364 Hz, T = 32 ms),
  2e-8 for the paper preset's (3.3 kHz, 29 ms). Measured on noise alone at eta = 2 (TCT40,
  117 beams, the side-lobe check and the trust off; ``tests/signal/test_echoes.py``): 0.87 of
  the design value. Rough spectra (the paper preset's rectangular pulse, whose rms bandwidth
  its spectral tails set) rise through the threshold several times per echo: measured, half the
  design value. With the side-lobe check and the trust on, noise gave no echo at all (noise
  arrives from every direction at once); a range cell of noise needs an echo in its run.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import maximum_filter1d

#: Level of the autocorrelation envelope that sets the range resolution (-3 dB).
RESOLUTION_LEVEL = 2 ** -0.5


def range_profile(band, waveform=None) -> tuple[np.ndarray, float]:
    """(|R| (n_samples,), tau_r [samples]) of ``waveform`` (default: the band's pulse) on
    ``band`` (a :class:`~mitsonar.signal.band.Band`): the envelope one echo leaves after the
    matched filter at lags of 0, 1, ... samples of the recording, normalised to 1 at lag 0, and
    its full width at :data:`RESOLUTION_LEVEL` (module docstring)."""
    w = band.system_spectrum(waveform)[band.bins]
    lobes = np.abs(band.to_analytic(np.abs(w) ** 2))
    lobes /= lobes[0]
    below = int(np.argmax(lobes < RESOLUTION_LEVEL))
    half = below - 1 + (lobes[below - 1] - RESOLUTION_LEVEL) / (lobes[below - 1] - lobes[below])
    return lobes, 2.0 * half


def expected_false_alarms(detection_snr: float, rms_bandwidth, duration) -> np.ndarray:
    """Design number of echoes that receiver noise alone gives in a window of ``duration`` [s]
    over ``detection_snr`` times the RMS noise envelope, for a matched-filter output of
    ``rms_bandwidth`` [Hz]: 2 sqrt(pi) b T eta exp(-eta^2) (module docstring)."""
    eta = float(detection_snr)
    return 2 * np.sqrt(np.pi) * np.asarray(rms_bandwidth) * np.asarray(duration) \
        * eta * np.exp(-eta**2)


class Clutter:
    """What the echoes of a beam's recording leave in its decoded envelope, besides themselves.

    * Range side lobes and ringing: an echo of amplitude A_j leaves A_j |R(t - t_j)| in its own
      beam (:func:`range_profile`).
    * Cross-talk, in a recording shared with other beams (an OFDM cycle): another beam b' lights
      the same reflectors, and its code leaks into this beam's matched filter through their
      cross-correlation envelope |X|. An echo j of this beam is also lit by b''s transmit
      pattern (its array factor towards this beam's axis, T) and arrives again b''s firing
      offset later: it leaves A_j T |X(t - t_j - offset)| (:meth:`__call__`). An echo j' of
      beam b' reaches this beam through its receive pattern (its array factor towards b''s
      axis, R_x): it leaves A_j' R_x |X(t - t_j')| (:meth:`leaks`).

    Args:
        side_lobes: (K, N) |R| of each waveform kind by lag (:func:`range_profile`).
        kind: (B,) each beam's kind.
        cross: None (a recording per beam), or (lobes, transmit, receive, firing): |X|
            (K, K, 2 S + 1) of an echo of kind k' decoded for kind k at lags -S..S; T and R_x
            (B, B) of beam b' for beam b (0 on the diagonal, :func:`array_gains`); each beam's
            firing time (B,) [samples].
    """

    def __init__(self, side_lobes: np.ndarray, kind: np.ndarray, cross=None):
        self.side_lobes = side_lobes
        self.kind = kind
        self.cross = cross

    def __call__(self, beams: np.ndarray, lags: np.ndarray) -> np.ndarray:
        """(P,) level relative to its amplitude that an echo of beam ``beams[p]`` leaves
        ``lags[p]`` samples after it (signed) in its own envelope. The other beams' leaks are
        looked up only for the beams fired within S samples of that lag (a few: codes are fired
        a slot apart)."""
        kind = self.kind[beams]
        own = self.side_lobes[kind, np.minimum(np.abs(lags), self.side_lobes.shape[1] - 1)]
        if self.cross is None:
            return own
        lobes, transmit, _, firing = self.cross
        order = np.argsort(firing)
        when = firing[beams] + lags  # where the other beams' echoes of that reflector start
        other, shifted, inside = _within(firing[order], when, lobes.shape[-1] // 2)
        other = order[other]
        leak = transmit[beams[:, None], other] * lobes[kind[:, None], self.kind[other], shifted]
        return np.maximum(own, np.where(inside, leak, 0.0).max(axis=-1, initial=0.0))

    def leaks(self, beams: np.ndarray, samples: np.ndarray, sources) -> np.ndarray:
        """(Q,) the most that the echoes ``sources`` = (beams, samples, amplitudes) of the other
        beams leave at samples ``samples`` (Q,) of beams ``beams`` (Q,) [Pa] (0 without
        cross-talk)."""
        if self.cross is None:
            return np.zeros(len(beams))
        lobes, _, receive, _ = self.cross
        order = np.argsort(sources[1], kind="stable")
        src_beams, src_samples, src_amplitude = (np.asarray(x)[order] for x in sources)
        index, shifted, inside = _within(src_samples, samples, lobes.shape[-1] // 2)
        other = src_beams[index]
        leak = src_amplitude[index] * receive[beams[:, None], other] \
            * lobes[self.kind[beams][:, None], self.kind[other], shifted]
        return np.where(inside & (other != beams[:, None]), leak, 0.0).max(axis=-1, initial=0.0)


def _within(times: np.ndarray, at: np.ndarray, span: int):
    """For sorted ``times`` (S,) and queries ``at`` (Q,) [samples]: the indices (Q, M) of the
    times within ``span`` of each query, the lags at - time + span clipped to [0, 2 span], and
    where an index is one of them."""
    first = np.searchsorted(times, at - span, "left")
    last = np.searchsorted(times, at + span, "right")
    index = first[:, None] + np.arange(int((last - first).max(initial=0)))  # (Q, M)
    index = np.minimum(index, len(times) - 1)
    shifted = np.rint(at[:, None] - times[index]).astype(np.int64) + span
    inside = (first[:, None] + np.arange(index.shape[1]) < last[:, None]) \
        & (shifted >= 0) & (shifted <= 2 * span)
    return index, np.clip(shifted, 0, 2 * span), inside


def array_gains(positions: np.ndarray, directions: np.ndarray,
                frequencies: np.ndarray, speed_of_sound: float) -> np.ndarray:
    """(B, B) normalised array factor |sum_i exp(j k' p_i . (u_b - u_b'))| / N of beam b'
    (steered to u_b', at its frequency f' (B,) [Hz], k' = 2 pi f' / c) towards beam b's
    direction u_b, from element positions (N, 3) [m]; 0 on the diagonal (:class:`Clutter`)."""
    k = 2 * np.pi * np.asarray(frequencies, dtype=float) / speed_of_sound
    difference = directions[:, None, :] - directions[None, :, :]  # (B, B', 3)
    phase = k[None, :, None] * (difference @ np.asarray(positions, dtype=float).T)
    gains = np.abs(np.exp(1j * phase).sum(axis=-1)) / len(positions)
    np.fill_diagonal(gains, 0.0)
    return gains


def echo_peaks(envelopes: np.ndarray, sources: np.ndarray, accepted: np.ndarray,
               resolution: np.ndarray, clutter: Clutter, margin: float):
    """Echoes of B beams (module docstring) before the side-lobe check.

    Args:
        envelopes: (B, N) [Pa].
        sources: (B, N) the local maxima over the threshold (in the window or not).
        accepted: (B, N) where an echo may be (in the window, its parts balanced).
        resolution: (B,) tau_r of each beam's waveform [samples].
        clutter: what an echo leaves at a lag from it.
        margin: ``clutter_margin``.

    Returns (beams, samples) of the echoes, by beam and then by decreasing amplitude, and where
    the resolved maxima are, (B, N): the sources with no stronger one within tau_r.
    """
    peaks = np.where(sources, envelopes, 0.0)
    resolved = sources & (peaks >= _window_max(peaks, np.floor(resolution).astype(np.int64)))
    beams, samples = _by_strength(envelopes, resolved)
    amplitude = envelopes[beams, samples]
    lobes = np.maximum(_lobes(beams, samples, amplitude, beams, samples, amplitude, clutter),
                       clutter.leaks(beams, samples, (beams, samples, amplitude)))
    keep = (amplitude > margin * lobes) & accepted[beams, samples]
    return (beams[keep], samples[keep]), resolved


def range_cells(envelopes: np.ndarray, above: np.ndarray, accepted: np.ndarray,
                resolved: np.ndarray, echoes, resolution: np.ndarray, clutter: Clutter,
                margin: float):
    """Range cells of B beams across their accepted echoes (module docstring), before the
    side-lobe check and the direction's trust.

    Args:
        envelopes, accepted, resolution, clutter, margin: as in :func:`echo_peaks`.
        above: (B, N) the envelope over the threshold inside the window.
        resolved: (B, N) the resolved maxima (:func:`echo_peaks`).
        echoes: (beams, samples) of the accepted echoes, sorted by beam.

    Returns (beams, samples) of the cells, by beam and then by decreasing amplitude.
    """
    count, n = envelopes.shape
    spacing = np.ceil(resolution).astype(np.int64)
    grid = above & (np.arange(n) % spacing[:, None] == 0)
    # Runs of ``above``, numbered from 1 across all beams (a gap column ends every beam's last).
    padded = np.concatenate([above, np.zeros((count, 1), bool)], axis=1).ravel()
    starts = padded & ~np.concatenate([[False], padded[:-1]])
    run = (np.cumsum(starts) * padded).reshape(count, n + 1)[:, :n]
    lit = np.zeros(run.max() + 1, bool)
    lit[run[echoes[0], echoes[1]]] = True
    lit[0] = False
    near_echo = np.zeros(envelopes.shape)
    near_echo[echoes] = 1.0
    near_echo = _window_max(near_echo, spacing - 1) > 0  # closer than tau_r to an echo
    beams, samples = _by_strength(envelopes, grid & accepted & lit[run] & ~near_echo)
    amplitude = envelopes[beams, samples]
    src_beams, src_samples = np.nonzero(resolved | grid)
    lobes = _lobes(beams, samples, amplitude, src_beams, src_samples,
                   envelopes[src_beams, src_samples], clutter)
    resolved_beams, resolved_samples = np.nonzero(resolved)
    lobes = np.maximum(lobes, clutter.leaks(beams, samples, (
        resolved_beams, resolved_samples, envelopes[resolved_beams, resolved_samples])))
    keep = amplitude > margin * lobes
    return beams[keep], samples[keep]


def _window_max(values: np.ndarray, half: np.ndarray) -> np.ndarray:
    """(B, N) the largest of ``values`` (B, N) within ``half[b]`` samples of each sample (zero
    beyond the ends); one running maximum per distinct half-width (per waveform kind)."""
    out = np.empty(values.shape)
    for width in np.unique(half):
        rows = half == width
        out[rows] = maximum_filter1d(values[rows], 2 * int(width) + 1, axis=1, mode="constant")
    return out


def _by_strength(envelopes: np.ndarray, mask: np.ndarray):
    """(beams, samples) where ``mask`` (B, N), by beam and then by decreasing envelope."""
    beams, samples = np.nonzero(mask)
    order = np.lexsort((-envelopes[beams, samples], beams))
    return beams[order], samples[order]


def _lobes(beams, samples, amplitude, src_beams, src_samples, src_amplitude,
           clutter: Clutter) -> np.ndarray:
    """(Q,) the most that the sources (S,) (beams, samples, amplitudes; sorted by beam) of each
    query's beam stronger than it leave at the queries (beams, samples, amplitude) (Q,),
    A_j ``clutter`` [Pa]: (Q, K) pairs, K the most sources of a beam."""
    count = max(int(beams.max(initial=-1)), int(src_beams.max(initial=-1))) + 1
    slot = np.arange(len(src_beams)) - np.searchsorted(src_beams, src_beams)
    width = int(slot.max(initial=0)) + 1
    at = np.zeros((count, width), np.int64)
    level = np.zeros((count, width))  # padding: never stronger
    at[src_beams, slot] = src_samples
    level[src_beams, slot] = src_amplitude
    lag = samples[:, None] - at[beams]
    source_level = level[beams]
    query, source = np.nonzero(source_level > amplitude[:, None])
    leaves = np.zeros(lag.shape)
    leaves[query, source] = source_level[query, source] * clutter(beams[query],
                                                                  lag[query, source])
    return leaves.max(axis=1, initial=0.0)
