"""Independent references for the physics tests: image sources and the direct summation of (1)(3)."""

from __future__ import annotations

import numpy as np

from mitsonar.synthesis import Paths


def image_source_paths(sonar, direction, wall_distance: float, reflection: float = 1.0) -> Paths:
    """Exact specular echo of an infinite plane z = wall_distance (sensor frame) by image sources.

    One path per (transmit, receive) element pair: the image of transmit element i in the plane
    radiates to receive element j with both piston directivities, spherical spreading over the
    unfolded length L, air absorption and the reflection coefficient.
    """
    cfg = sonar.config
    g = cfg.geometry
    k = float(cfg.medium.wavenumber(cfg.pulse.frequency))
    c = cfg.medium.speed_of_sound
    tx = g.tx_positions
    image = tx.copy()
    image[:, 2] = 2 * wall_distance - tx[:, 2]
    v = g.rx_positions[None, :, :] - image[:, None, :]  # (N_tx, N_rx, 3) image -> receiver
    length = np.linalg.norm(v, axis=-1)
    cos = -v[..., 2] / length  # same angle at the element and at its image
    trans = cfg.transducer
    absorption = cfg.medium.absorption_db_per_m(cfg.pulse.frequency) if cfg.trace.air_absorption else 0
    gain = (trans.source_amplitude * reflection * trans.directivity(cos, k) ** 2
            * 10 ** (-absorption * length / 20) / length
            * np.exp(1j * (g.tx_phase_offsets[:, None] + g.rx_phase_offsets[None, :])))
    delay = g.steering_delays(np.asarray(direction, float), c)[:, None] + length / c
    channel = np.broadcast_to(np.arange(g.rx.count), length.shape)
    return Paths(gain.ravel(), delay.ravel(), channel.ravel())


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
