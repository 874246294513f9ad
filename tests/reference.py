"""The accuracy oracle of the synthesis: the plain time-domain summation of (1)(3)."""

from __future__ import annotations

import numpy as np

from mitsonar.synthesis import Paths


def direct_summation(paths: Paths, pulse, n_channels: int, times) -> np.ndarray:
    """Plain time-domain evaluation of (1)(3): sum_p Re{a_p e(t - tau_p) e^{j(w (t - tau_p) - pi/2)}}.

    Loops over chunks of samples only to bound memory; (channels, len(times)).
    """
    out = np.zeros((n_channels, len(times)))
    for start in range(0, len(times), 256):
        t = np.asarray(times[start:start + 256])
        wave = pulse.analytic(t[None, :] - paths.delay[:, None])  # (M, T)
        contrib = (paths.gain[:, None] * wave).real
        np.add.at(out[:, start:start + 256], paths.channel, contrib)
    return out
