"""Acoustic paths: the tracer's output and the synthesizer's input.

A path is a complex gain ``a`` [Pa, for the drive pulse] and a delay ``tau`` [s] into one receive
channel; narrow-band merging of a hit's transmit elements adds a first-order term ``b``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from mitsonar.physics.waveforms import phasor


@dataclass(frozen=True)
class Paths:
    """Flat list of acoustic paths.

    A path's analytic spectrum in its channel is exp(-j 2 pi f tau) [a - j 2 pi (f - f_c) b] W(f),
    W the system spectrum of the drive: ``b`` is the first-order term of narrow-band merging
    (:meth:`narrowband`), absent for ordinary paths.

    Attributes:
        gain: (M,) complex gain a [Pa] applied to the analytic drive waveform.
        delay: (M,) delay tau from the virtual firing of the transmit origin [s].
        channel: (M,) receive element index.
        elements: (N_tx, N_rx) when the paths come in per-hit blocks, ordered (hit, transmit
            element, receive element), which :meth:`narrowband` can merge; None otherwise.
        first_order: (M,) complex first-order gains b [Pa s], or None.
        carrier: f_c of the first-order term [Hz].
    """

    gain: np.ndarray
    delay: np.ndarray
    channel: np.ndarray
    elements: tuple[int, int] | None = None
    first_order: np.ndarray | None = None
    carrier: float = 0.0

    def __post_init__(self):
        n = len(self.gain)
        if len(self.delay) != n or len(self.channel) != n:
            raise ValueError("Paths: gain, delay and channel must have the same length")
        if self.first_order is not None and len(self.first_order) != n:
            raise ValueError("Paths: first_order must have one entry per path")
        if self.elements is not None and n % (self.elements[0] * self.elements[1]):
            raise ValueError(f"Paths: {n} paths are not whole blocks of {self.elements} elements")

    @classmethod
    def empty(cls) -> "Paths":
        """No paths."""
        return cls(np.zeros(0, complex), np.zeros(0), np.zeros(0, int))

    def delayed(self, seconds) -> "Paths":
        """The same paths ``seconds`` [s] later (e.g. a beam fired later in an OFDM cycle): a
        scalar, or (M,) one per path."""
        return replace(self, delay=self.delay + seconds)

    def narrowband(self, frequency: float) -> "Paths":
        """Each hit's transmit elements merged into one path per receive channel about
        ``frequency`` [Hz], with a first-order term.

        With tau_i = tau_c + delta_i (tau_c the |gain|-weighted mean delay of the elements), the
        elements' spectrum is W(f) exp(-j 2 pi f tau_c) sum_i c_i exp(-j 2 pi (f - f0) delta_i),
        c_i = a_i exp(-j 2 pi f0 delta_i); to first order in (f - f0) delta_i it is
        W(f) exp(-j 2 pi f tau_c) [A - j 2 pi (f - f0) B], A = sum_i c_i, B = sum_i c_i delta_i:
        the merged path's gain and first-order gain. Exact at f0; the remaining error is second
        order in the delay spread (aperture and steering, up to ~0.1 ms) times the bandwidth.
        Paths without per-hit blocks are returned as they are.
        """
        if self.elements is None:
            return self
        n_tx, n_rx = self.elements
        gain = self.gain.reshape(-1, n_tx, n_rx)
        delay = self.delay.reshape(-1, n_tx, n_rx)
        weight = np.abs(gain)
        total = weight.sum(axis=1)
        centre = np.where(total > 0, np.einsum("hij,hij->hj", weight, delay)
                          / np.where(total > 0, total, 1.0), delay.mean(axis=1))
        offset = delay - centre[:, None, :]
        c = gain * phasor(-2 * np.pi * frequency * offset)  # phases of at most ~60 rad
        channel = self.channel.reshape(-1, n_tx, n_rx)[:, 0, :].ravel()
        return Paths(c.sum(axis=1).ravel(), centre.ravel(), channel,
                     first_order=np.einsum("hij,hij->hj", c, offset).ravel(), carrier=frequency)

    @property
    def paths(self) -> "Paths":
        """These paths (as :attr:`HitPaths.paths <mitsonar.trace.hitpaths.HitPaths.paths>` expands
        factored ones)."""
        return self

    def about(self, carrier: float) -> "Paths":
        """The same paths with the first-order term expressed about ``carrier`` [Hz] (exact:
        a - j 2 pi (f - f1) b = a + j 2 pi (f1 - f2) b - j 2 pi (f - f2) b)."""
        if self.first_order is None:
            return self
        gain = self.gain + 2j * np.pi * (self.carrier - carrier) * self.first_order
        return replace(self, gain=gain, carrier=float(carrier))

    def narrowband_many(self, frequencies) -> list["Paths"]:
        """:meth:`narrowband` about each of ``frequencies`` [Hz]."""
        return [self.narrowband(f) for f in frequencies]

    @classmethod
    def concatenate(cls, parts) -> "Paths":
        """All paths of ``parts``; per-hit blocks are kept when every part has the same ones,
        first-order terms (zero for parts without) re-expressed about 0 Hz unless the parts that
        have them share a carrier."""
        parts = list(parts)
        blocks = {p.elements for p in parts}
        carriers = {p.carrier for p in parts if p.first_order is not None}
        if len(carriers) > 1:
            parts, carriers = [p.about(0.0) for p in parts], {0.0}
        first_order = np.concatenate([np.zeros(len(p), complex) if p.first_order is None
                                      else p.first_order for p in parts]) if carriers else None
        return cls(np.concatenate([p.gain for p in parts]), np.concatenate([p.delay for p in parts]),
                   np.concatenate([p.channel for p in parts]),
                   blocks.pop() if len(blocks) == 1 else None, first_order,
                   carriers.pop() if carriers else 0.0)

    def __len__(self) -> int:
        return len(self.gain)
