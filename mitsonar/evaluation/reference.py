"""References for validation: exact image-source echoes, and the direct summation of (1)(3).

For a rigid infinite plane, Kirchhoff's integral equals the field of the transmit array's mirror
image, so the specular echo is known exactly: one path per (transmit, receive) element pair from
the image of the transmit element, with both piston directivities, spherical spreading over the
unfolded length, air absorption and the reflection coefficient. Used by the tests and the
validation experiments as the reference the ray tracer must reproduce.
"""

from __future__ import annotations

import numpy as np

from mitsonar.trace.paths import Paths


def plane_images(tx_positions, distance: float) -> np.ndarray:
    """Mirror images (N, 3) of element positions in the plane z = distance (sensor frame)."""
    return np.asarray(tx_positions, dtype=float) * [1, 1, -1] + [0.0, 0.0, 2.0 * distance]


def image_paths(config, direction, tx_images, reflection: complex = 1.0,
                frequency: float | None = None) -> Paths:
    """Paths from transmit-element images (N_tx, 3) to every receive element, their gains at
    ``frequency`` [Hz] (default: the drive's centre).

    The element directivity is evaluated at the angle of arrival, which equals the angle of
    departure for images by mirror planes parallel to the array or by a 180-degree rotation
    about an axis in such a plane (the double image of a dihedral corner).

    Args:
        config: a :class:`~mitsonar.sensors.sonar.SonarConfig`.
        direction: (3,) beam direction (sets the firing delays).
        tx_images: (N_tx, 3) image positions, sensor frame [m].
        reflection: product of the pressure reflection coefficients along the path.
    """
    g, element, medium = config.geometry, config.transducer, config.medium
    v = g.rx_positions[None] - np.asarray(tx_images, dtype=float)[:, None]
    length = np.linalg.norm(v, axis=-1)
    frequency = config.pulse.frequency if frequency is None else frequency
    k = float(medium.wavenumber(frequency))
    attenuation = medium.amplitude_attenuation(length, frequency) \
        if config.trace.air_absorption else 1.0
    gain = (element.source_amplitude * reflection * element.directivity(-v[..., 2] / length, k) ** 2
            * attenuation / length
            * np.exp(1j * (g.tx_phase_offsets[:, None] + g.rx_phase_offsets[None, :])))
    c = medium.speed_of_sound
    delay = g.steering_delays(np.asarray(direction, dtype=float), c)[:, None] + length / c
    return Paths(gain.ravel(), delay.ravel(), np.tile(np.arange(g.rx.count), g.tx.count))


def direct_summation(paths: Paths, pulse, n_channels: int, times) -> np.ndarray:
    """Plain time-domain evaluation of (1)(3): sum_p Re{a_p e(t - tau_p) e^{j(w (t - tau_p) - pi/2)}},
    the accuracy oracle of the fast synthesis (``pulse`` needs ``analytic(t)``).

    Loops over chunks of samples only to bound memory; (channels, len(times)).
    """
    out = np.zeros((n_channels, len(times)))
    for start in range(0, len(times), 256):
        t = np.asarray(times[start:start + 256])
        wave = pulse.analytic(t[None, :] - paths.delay[:, None])  # (M, T)
        contrib = (paths.gain[:, None] * wave).real
        np.add.at(out[:, start:start + 256], paths.channel, contrib)
    return out
