"""Whose echo it is, in a recording shared by several codes (an OFDM cycle).

Every code of a cycle is decoded from the same channels, so an echo of code k' shows in code k's
decoded envelope too, through their cross-correlation envelope |X_kk'| (the table of
:meth:`EchoProcessor._crosstalk <mitsonar.signal.receiver.EchoProcessor._crosstalk>`: an echo
of kind k' of amplitude a decoded for kind k leaves a |X_kk'(tau)| at lag tau). Where that echo
also arrives from inside beam b's main lobe (a reflector lit by another beam's transmit side
lobe, beside beam b's axis), beam b's side-lobe check cannot reject it: it does come from
there, only at another code's firing time, and placed with beam b's it lands a slot spacing of
the cycle or more off in range (measured: 1.58 m in a 35-beam TCT40 frame facing a wall,
tests/recon/test_repeated_offbeam.py; tests/signal/test_crosstalk.py). The code tells it, where
the transducers let the codes differ.

* Leaks (:func:`leaks`): what each other code k' leaves at sample t of code k's envelope steered
  to a direction: the envelope of k' steered there, read where its own filter peaks (t - tau),
  times |X_kk'(tau)|, the most over the lags.
* Separation of two codes (:func:`separation`): rho_kk'^2 = max over tau of
  |X_kk'(tau)| |X_k'k(-tau)| (<= 1 by Cauchy-Schwarz: the squared correlation coefficient of the
  two expected echoes). An echo of code k of amplitude a leaves rho^2 a through k' and back; an
  echo of code k' leaves in code k all that code k sees of it. So the ratio of code k's level
  to the leak of k' is 1/rho^2 for code k's own echo and about 1 for the other code's.
* The test (:func:`own_code`, "first" in a shared recording, with the side-lobe check: a beam
  whose strongest candidate fails it takes its next): the candidate's level must exceed the
  leak of every other code of the cycle that it can tell apart from its own
  (rho_kk'^2 <= 1 / ``clutter_margin``) by f = min(``clutter_margin``, 1 / (rho^2
  sqrt(``clutter_margin``))): a code's own echo, which leaks back rho^2 of itself, clears f by
  sqrt(``clutter_margin``) or more; another code's echo, which leaks about all of itself, is
  taken for that code's up to f = ``clutter_margin``, the clutter rule of "all"
  (:mod:`mitsonar.signal.multiecho`) and of off-beam echoes. Not less: an echo lit through
  another beam's transmit side lobe has its tones weighted otherwise than the code's, and in
  the 35-beam frame above it left 1.7 times the leak its nominal |X| gives (0.72 Pa against
  0.38 Pa, rho^2 = 0.30: the geometric middle 1/rho = 1.84 kept it). Not more: 25 spheres in
  one cycle behind broadband transducers (tests/signal/test_ofdm.py) return their own echoes
  1.9-2.0 times their round-trip leaks (rho^2 0.42-0.47), which ``clutter_margin`` alone
  rejected. Behind the TCT40 the 32 and 48 kHz tones are 26 dB down: every code with a 40 kHz
  tone is nearly the same echo (rho^2 0.95-1.0; no test can tell them apart: there the
  side-lobe check and the schedule's spread of codes in time and angle are all there is), and
  the others differ from them by rho^2 0.2-0.9; the 20 kHz broadband transducers separate
  most pairs (rho^2 0.1-0.8).
* Measured (12 OFDM frames of 117 beams, TCT40, a drywall wall 1.5-2.3 m ahead facing the
  sensor or turned 8 deg, seeds 0-2): points more than 5 cm off the wall, 16 of 49 before;
  with the part balance relative to each part's gain (:meth:`EchoProcessor.part_gain
  <mitsonar.signal.receiver.EchoProcessor.part_gain>`) 13 of 83; with this test too, none
  (1 of 72, 0.83 m off, after merging with the batched trace and synthesis). Its cost
  (docs/physics.md): genuine echoes rejected in `paper` frames, some against other beams'
  direct paths, which the blanking already handles.
"""

from __future__ import annotations

import numpy as np


def steered_codes(processor, looks, steered: np.ndarray, n: int,
                  needed: np.ndarray | None = None) -> np.ndarray:
    """(D, K, n) [Pa] every kind of the cycle's waveforms (``looks.waves``) decoded on the
    shared recording's delay-and-sum spectra ``steered`` (D, nb) (its beams towards D
    directions); only where ``needed`` (D, K) if given (zeros elsewhere)."""
    waves = looks.waves
    kinds = len(waves.kinds)
    rows, kind = np.nonzero(np.ones((len(steered), kinds), bool) if needed is None else needed)
    codes = np.zeros((len(steered), kinds, n))
    codes[rows, kind] = processor.band.envelopes(steered[rows], waves.filters[kind], n)
    return codes


def leaks(codes: np.ndarray, crosstalk: np.ndarray, kind: np.ndarray, rows: np.ndarray,
          samples: np.ndarray) -> np.ndarray:
    """(E, K) [Pa] the most that each kind k' leaves at ``samples`` (E,) of kind ``kind`` (E,)'s
    envelope steered as row ``rows`` (E,) of ``codes`` (D, K, n) (:func:`steered_codes`):
    code k' read at every lag -S..S before the sample, times |X| (``crosstalk`` (K, K, 2 S + 1),
    :class:`~mitsonar.signal.multiecho.Clutter`); 0 for the row's own kind."""
    kinds, n = codes.shape[1:]
    span = crosstalk.shape[-1] // 2
    lags = np.arange(-span, span + 1)
    at = samples[:, None] - lags  # (E, L) the other code's echo, where its own filter peaks
    every = np.arange(kinds)
    source = np.where(((at >= 0) & (at < n))[:, None, :],
                      codes[rows[:, None, None], every[None, :, None],
                            np.clip(at, 0, n - 1)[:, None, :]], 0.0)  # (E, K, L)
    leak = (source * crosstalk[kind]).max(axis=-1, initial=0.0)  # |X| (E, K, L)
    return np.where(every[None, :] != kind[:, None], leak, 0.0)


def separation(crosstalk: np.ndarray) -> np.ndarray:
    """(K, K) rho_kk' (module docstring) of the kinds of ``crosstalk`` (K, K, 2 S + 1)."""
    return np.sqrt((crosstalk * crosstalk.transpose(1, 0, 2)[..., ::-1]).max(axis=-1))


def own_code(level: np.ndarray, leaked: np.ndarray, rho: np.ndarray, kind: np.ndarray,
             clutter_margin: float) -> np.ndarray:
    """(E,) True where candidates of kind ``kind`` (E,) at ``level`` (E,) [Pa] are their own
    code's echoes rather than another's (module docstring): over min(``clutter_margin``,
    1 / (rho_kk'^2 sqrt(``clutter_margin``))) times ``leaked`` (E, K) [Pa] (:func:`leaks`) for
    every kind k' with rho_kk'^2 <= 1 / ``clutter_margin`` (``rho`` (K, K),
    :func:`separation`)."""
    rho2 = rho[kind] ** 2  # (E, K)
    with np.errstate(divide="ignore"):  # orthogonal codes (rho = 0): the margin
        factor = np.minimum(clutter_margin, 1.0 / (rho2 * np.sqrt(clutter_margin)))
    return np.all(~told_apart(rho, kind, clutter_margin) | (factor * leaked < level[:, None]),
                  axis=1)


def told_apart(rho: np.ndarray, kind: np.ndarray, clutter_margin: float) -> np.ndarray:
    """(E, K) the kinds k' that :func:`own_code` tells apart from kinds ``kind`` (E,):
    rho_kk'^2 <= 1 / ``clutter_margin`` (``rho`` (K, K), :func:`separation`); the only
    kinds whose leaks it reads, besides a kind's own (whose leak is 0)."""
    return rho[kind] ** 2 <= 1.0 / clutter_margin
