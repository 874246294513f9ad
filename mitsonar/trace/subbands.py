"""Paths of a wide band: the same paths with their gains evaluated at several frequencies.

An element's piston pattern, a patch's integral and air absorption depend on frequency; over a
narrow band they are evaluated once, at the drive's centre. Over a wide sweep (RTIS's 20-80 kHz)
the pattern at the field of view's edge changes by tens of dB, so the tracer
(``TraceSettings.subbands``) evaluates them at K frequency nodes spread over the band and returns
the K path sets, which share their delays, as :class:`Subbands`. The synthesizer drives set k
with the drive's spectrum times the k-th hat weight of the nodes
(:class:`~mitsonar.signal.band.SubBand`): every path's gain is interpolated linearly in frequency
between the nodes and held at the end nodes' values beyond them.

How many nodes (``TraceSettings.subbands = "auto"``, :func:`nodes_needed`): the fewest whose
interpolated gains keep every echo's spectrum within ``TraceSettings.subband_tolerance`` of the
exact one, as the RMS over the band weighted by the system spectrum (drive and transducer
responses), relative to an echo from broadside: a tone burst's narrow spectrum needs one node
behind any transducer, a 30-50 kHz sweep two, RTIS's 20-80 kHz three to four
(docs/physics.md).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np


def subband_nodes(centre: float, half_width: float, count: int) -> np.ndarray:
    """``count`` frequency nodes [Hz] evenly spread over the band ``centre`` +- ``half_width``
    [Hz] (both ends included); one node: the centre."""
    if count == 1:
        return np.array([float(centre)])
    return np.linspace(centre - half_width, centre + half_width, count)


def hat_weights(nodes, frequencies) -> np.ndarray:
    """(K, F) weights of nodes (K,) [Hz] at ``frequencies`` (F,) [Hz]: linear interpolation
    between neighbouring nodes, 1 for the end nodes beyond them; every column sums to 1."""
    nodes = np.asarray(nodes, dtype=float)
    f = np.asarray(frequencies, dtype=float)
    eye = np.eye(len(nodes))
    return np.stack([np.interp(f, nodes, row) for row in eye]) if len(nodes) > 1 \
        else np.ones((1, len(f)))


def nodes_needed(gain, centre: float, half_width: float, frequencies, weight,
                 tolerance: float, most: int = 16) -> int:
    """Fewest frequency nodes (:func:`subband_nodes` over ``centre`` +- ``half_width`` [Hz])
    whose linear interpolation (:func:`hat_weights`) of ``gain`` keeps every echo spectrum
    within ``tolerance`` of the exact one; ``most``, with a warning naming the error it leaves,
    if none does.

    Args:
        gain: function of frequencies (F,) [Hz] giving the paths' gains (A, F) at them, for A
            cases (angles, path lengths); case 0 is the reference the errors are relative to.
        frequencies: (F,) [Hz] where the echoes have energy.
        weight: (F,) the system spectrum's magnitude there.
        tolerance: largest RMS error over ``frequencies``, weighted by ``weight``, relative to
            the reference case's weighted RMS gain.
    """
    f = np.asarray(frequencies, dtype=float)
    w = np.asarray(weight, dtype=float) ** 2
    exact = gain(f)
    scale = np.sum(w * np.abs(exact[0]) ** 2)
    for count in range(1, most + 1):
        nodes = subband_nodes(centre, half_width, count)
        error = np.sum(w * np.abs(gain(nodes) @ hat_weights(nodes, f) - exact) ** 2, axis=-1)
        if np.sqrt(error.max() / scale) <= tolerance:
            return count
    warnings.warn(f"TraceSettings.subbands: {most} frequency nodes leave an echo spectrum "
                  f"{np.sqrt(error.max() / scale):.3g} off (subband_tolerance {tolerance:g})",
                  stacklevel=2)
    return most


@dataclass(frozen=True)
class Subbands:
    """K path sets (:class:`~mitsonar.trace.hitpaths.HitPaths` or
    :class:`~mitsonar.trace.paths.Paths`, one kind) with the same delays and channels, their
    gains evaluated at ``nodes`` (K,) [Hz] (module docstring).

    Attributes:
        parts: the K path sets, in the order of ``nodes``.
        nodes: increasing frequencies [Hz].
    """

    parts: tuple
    nodes: tuple

    def __post_init__(self):
        if len(self.parts) != len(self.nodes) or len(self.parts) < 2:
            raise ValueError(f"Subbands: {len(self.parts)} path sets for {len(self.nodes)} "
                             f"nodes (at least 2 of each, as many sets as nodes)")

    def each(self, change) -> "Subbands":
        """The path sets, each ``change``d (a function of one set)."""
        return Subbands(tuple(change(p) for p in self.parts), self.nodes)

    @classmethod
    def concatenate(cls, parts) -> "Subbands":
        """The paths of all ``parts`` (Subbands on the same nodes), node by node."""
        parts = list(parts)
        if len(parts) == 1:
            return parts[0]
        kind = type(parts[0].parts[0])
        return cls(tuple(kind.concatenate([p.parts[k] for p in parts])
                         for k in range(len(parts[0].nodes))), parts[0].nodes)

    def select(self, rows) -> "Subbands":
        """The patches (or paths) ``rows`` of every set."""
        return self.each(lambda p: p.select(rows))

    def delayed(self, seconds) -> "Subbands":
        """Every set ``seconds`` [s] later (as the sets' own ``delayed``)."""
        return self.each(lambda p: p.delayed(seconds))

    @property
    def elements(self):
        """The sets' element counts (N_tx, N_rx)."""
        return self.parts[0].elements

    @property
    def patches(self) -> int:
        """Patches per set (of :class:`~mitsonar.trace.hitpaths.HitPaths`)."""
        return self.parts[0].patches

    @property
    def arrivals(self):
        """The sets' (earliest, latest) arrival per patch [s] (shared by every node)."""
        return self.parts[0].arrivals

    def __len__(self) -> int:
        """Paths per set."""
        return len(self.parts[0])
