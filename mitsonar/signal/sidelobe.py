"""The side-lobe check over a beam's looks, and each beam's strongest echo that passes it.

A candidate is accepted unless it arrives from elsewhere: receive beams formed from the same
recording at that instant over +-``ghost_half_span`` show it ``ghost_margin`` stronger outside
the main lobe than along the beam (a side-lobe echo, e.g. the specular return of a tilted wall,
which would give a wrong depth; :meth:`Beamformer.off_beam
<mitsonar.signal.beamforming.Beamformer.off_beam>`). A beam's looks (:mod:`mitsonar.signal.looks`:
a code's parts, or its waveform) are checked one after another: a candidate rejected in one is
not checked in the next. "first" (:func:`strongest_echoes`) checks each beam's strongest
candidate, then the other candidates of the beams whose strongest was rejected: a sparse
product per carrier for each; in a recording shared by several codes, a candidate must also be
its own code's echo rather than another code's (:mod:`mitsonar.signal.crosstalk`).
"""

from __future__ import annotations

import numpy as np

from mitsonar.signal.beamforming import Beamformer
from mitsonar.signal.detection import candidates
from mitsonar.signal.looks import Looks


def passes(beamformer: Beamformer, looks: Looks, directions, beams, samples,
           rows=None) -> np.ndarray:
    """(E,) True where candidate sample ``samples[e]`` of beam ``beams[e]`` arrives along
    ``directions[beams[e]]`` (the beam's direction, (B, 3)), or ``directions[rows[e]]`` if
    ``rows`` are given, in every look (module docstring)."""
    rows = beams if rows is None else rows
    passed = np.ones(len(beams), bool)
    for _, todo, sets, carriers in looks.each(beams, where=passed):
        passed[todo] = ~beamformer.off_beam(looks.channels, sets, samples[todo], carriers,
                                            directions[rows[todo]])
    return passed


def along_beam(beamformer: Beamformer, looks: Looks | None, u, beams, samples):
    """The (beams, samples) of candidates that pass the side-lobe check towards their beams'
    directions ``u`` (B, 3) (all without looks or with ``ghost_margin`` = 0)."""
    if looks is None or beamformer.settings.ghost_margin <= 0:
        return beams, samples
    passed = passes(beamformer, looks, u, beams, samples)
    return beams[passed], samples[passed]


def strongest_echoes(beamformer: Beamformer, looks: Looks | None, envelopes, accepted, u,
                     owned=None):
    """Each beam's strongest candidate that arrives along it (``echoes`` = "first"), from the
    envelopes (B, N) [Pa] where ``accepted`` (B, N) (module docstring): (beams, samples) by
    beam, and (beams, samples) of every beam's strongest candidate before the check. ``owned``:
    in a recording shared by several codes, a function of (beams, samples) (E,) giving (E,)
    whether each is its own code's echo (:func:`~mitsonar.signal.crosstalk.own_code`), asked
    of the candidates that pass the side-lobe check."""
    s = beamformer.settings
    beams, samples, ranks = candidates(envelopes, accepted, s.max_candidates)
    strongest = ranks == 0
    first = beams[strongest], samples[strongest]
    side_lobes = looks is not None and s.ghost_margin > 0
    if side_lobes or owned is not None:
        def check(b, k):
            ok = passes(beamformer, looks, u, b, k) if side_lobes else np.ones(len(b), bool)
            if owned is not None and ok.any():
                ok[ok] = owned(b[ok], k[ok])
            return ok

        # Each beam's strongest candidate first; the others where it fails.
        passed = strongest.copy()
        passed[strongest] = check(*first)
        done = np.zeros(len(envelopes), bool)
        done[beams[passed]] = True
        retry = (ranks > 0) & ~done[beams]
        passed[retry] = check(beams[retry], samples[retry])
        beams, samples = beams[passed], samples[passed]
    found, index = np.unique(beams, return_index=True)  # each beam's strongest left
    return found, samples[index], first
