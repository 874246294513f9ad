"""Off-beam echoes re-placed where they arrive from (``DetectionSettings.off_beam``).

A smooth wall seen a few degrees off its normal (about 3 to 18 deg with the TCT40 transducers,
docs/incidence.md) returns its specular echo from the foot of the perpendicular, at the
perpendicular range, whichever way the beam points. It reaches the beam through the transmit
side lobe, merged with the weak diffuse echo of the footprint, and the side-lobe check rightly
rejects it *for that beam's direction*: placed on the beam it would be wrong. The receive array
still measures where it came from. With ``off_beam``, the strongest candidate of a beam whose
every candidate failed (``echoes`` = "first"; with "all", a beam left without any echo) is
examined again where it arrives from:

1. the direction of the side-lobe check's grid (``ghost_grid_step``, +-``ghost_half_span``)
   where the narrow-band delay-and-sum power at its instant, summed over the looks, is largest
   (outside the beam's main lobe, or inside it but off its axis: a wall 4 deg off its normal
   peaks 4 deg off the beam, and the check failed because its axis is weaker than a side lobe
   of that arrival), kept inside the field of view;
2. its instant re-read on the envelope steered there (the strongest sample within one range
   resolution tau_r of the candidate, not on the window's edge, over the threshold): along the
   mirror direction the specular echo dominates, and the diffuse echo of the footprint, which
   arrives later, no longer pulls the peak;
3. the side-lobe check again, now for that direction;
4. in a recording shared by several codes (an OFDM cycle), its re-read level must exceed
   ``clutter_margin`` times what the other codes' echoes leave there through the codes'
   cross-correlation |X| (:func:`cross_talk`). A strong echo of another code of the cycle (a
   wall's mirror echo on the beam facing it) leaks into every code's decoded envelope from
   that beam's direction, fails each beam's side-lobe check, and without this test would be
   re-placed there with the wrong code's firing time, up to a slot spacing of the cycle off in
   range (measured: up to 1.9 m, tests/recon/test_repeated_offbeam.py);
5. then, as every echo: the arrival direction refined within ``ghost_exclusion`` of that
   direction, kept where one plane wave from it explains ``min_coherence`` of the channels'
   power and it lies in the field of view, placed by the bistatic depth (7) along it
   (:func:`mitsonar.signal.placement.report`).

Such an echo is the beam's point (its :class:`~mitsonar.signal.detection.Detections` entry),
flagged ``off_beam`` in :class:`~mitsonar.signal.detection.Echoes`: a map may keep or drop it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mitsonar.physics.array import ArrayGeometry
from mitsonar.physics.beampattern import in_fov
from mitsonar.signal import sidelobe
from mitsonar.signal.crosstalk import leaks, steered_codes
from mitsonar.signal.detection import DetectionSettings


@dataclass(frozen=True)
class Recovered:
    """Off-beam echoes of beams without an accepted echo (R rows).

    Attributes:
        beam: (R,) the beam of each.
        sample: (R,) its sample on the envelope steered to ``centre``.
        centre: (R, 3) unit direction where its power peaks on the side-lobe check's grid.
    """

    beam: np.ndarray
    sample: np.ndarray
    centre: np.ndarray


def recover(processor, allowed, threshold, u, looks, found, strongest, envelopes,
            crosstalk=None) -> Recovered:
    """Off-beam echoes (module docstring, steps 1-4) of the B beams not in ``found`` (their
    indices: the beams with an accepted echo).

    Args:
        processor: the :class:`~mitsonar.signal.receiver.EchoProcessor`.
        allowed: (B, N) where an echo may be (in the listening window, parts balanced).
        threshold: (B, N) the level an echo must exceed [Pa].
        u: (B, 3) beam directions.
        looks: the beams' looks (:class:`~mitsonar.signal.looks.Looks`).
        found: the beams with an accepted echo.
        strongest: (beams, samples) of every beam's strongest candidate (over ``threshold``
            where ``allowed``; :func:`~mitsonar.signal.sidelobe.strongest_echoes`).
        envelopes: (B, N) the beams' decoded envelopes along their axes [Pa].
        crosstalk: in a recording shared by the B beams, |X| (K, K, 2 S + 1) of an echo of
            kind k' decoded for kind k at lags -S..S
            (:class:`~mitsonar.signal.multiecho.Clutter`); None: a recording per beam.
    """
    beamformer = processor.beamformer
    beams, samples = strongest
    lost = ~np.isin(beams, found)
    beams, samples = beams[lost], samples[lost]
    grid = beamformer.ghost_grid
    power = grid_power(beamformer, looks, beams, samples)
    centre = grid[np.argmax(power, axis=1)]
    g = processor.geometry
    keep = in_fov(centre, g.fov_horizontal, g.fov_vertical)
    beams, samples, centre = beams[keep], samples[keep], centre[keep]
    samples, level, loud = steered_peaks(processor, looks, threshold, allowed, beams, samples,
                                         centre)
    beams, samples, centre, level = beams[loud], samples[loud], centre[loud], level[loud]
    passed = sidelobe.passes(beamformer, looks, centre, beams, samples, np.arange(len(beams)))
    if crosstalk is not None:  # the last test: the dearest
        leak = cross_talk(processor, looks, crosstalk, beams[passed], samples[passed],
                          centre[passed], threshold.shape[1])
        passed[passed] = level[passed] > processor.settings.clutter_margin * leak
    return Recovered(beams[passed], samples[passed], centre[passed])


def grid_power(beamformer, looks, beams, samples) -> np.ndarray:
    """(E, G) narrow-band delay-and-sum power of candidates (``beams``, integer ``samples``)
    towards the side-lobe check's G directions, summed over each beam's looks: a sparse product
    per look and carrier."""
    grid = beamformer.ghost_grid
    power = np.zeros((len(beams), len(grid)))
    for _, rows, sets, carriers in looks.each(beams):  # a code's parts (two at most), not beams
        windows = beamformer.windows(looks.channels, sets, samples[rows])
        for carrier in np.unique(carriers):
            mine = carriers == carrier
            beams_out = beamformer.operator(grid, carrier) @ windows[:, mine]
            power[rows[mine]] += np.abs(beams_out.T) ** 2
    return power


def steered_peaks(processor, looks, threshold, allowed, beams, samples, centre):
    """(samples (E,), level (E,) [Pa], loud (E,)): each candidate's instant re-read on its
    beam's envelope steered to ``centre`` (E, 3): the strongest sample within the waveform's
    range resolution of ``samples``, and its level; ``loud`` where that is over ``threshold``
    (B, N), ``allowed`` (B, N) and not on the edge of the span searched (a peak of its own)."""
    if not len(beams):
        return samples, np.zeros(0), np.zeros(0, bool)
    waves = looks.waves
    kind = waves.kind[beams]
    spectra = looks.spectra[beams] if looks.per_beam else looks.spectra[0]
    n = threshold.shape[1]
    steered = processor.band.envelopes(processor.beamformer.beamformed(spectra, centre),
                                       waves.filters[kind], n)
    reach = np.ceil(waves.range_profiles(processor)[1][kind]).astype(np.int64)  # tau_r
    offsets = np.arange(-reach.max(), reach.max() + 1)
    span = samples[:, None] + offsets
    inside = (np.abs(offsets) <= reach[:, None]) & (span >= 0) & (span < n)
    rows = np.arange(len(beams))[:, None]
    values = np.where(inside, steered[rows, np.clip(span, 0, n - 1)], -np.inf)
    best = np.argmax(values, axis=1)
    new = samples + offsets[best]
    edge = np.abs(offsets[best]) == reach
    level = steered[rows[:, 0], new]
    loud = ~edge & (level > threshold[beams, new]) & allowed[beams, new]
    return new, level, loud


def cross_talk(processor, looks, crosstalk, beams, samples, centre, n) -> np.ndarray:
    """(E,) the most that the other codes of a shared recording leave at ``samples`` (E,) of
    ``beams`` (E,) steered to ``centre`` (E, 3) [Pa]: every other beam's code decoded on the
    envelope steered there (where it hears an echo from that direction at full gain), times
    |X| (``crosstalk`` (K, K, 2 S + 1), :class:`~mitsonar.signal.multiecho.Clutter`) at every
    lag -S..S (:func:`~mitsonar.signal.crosstalk.leaks`); ``n`` samples per envelope."""
    codes = steered_codes(processor, looks,
                          processor.beamformer.beamformed(looks.spectra[0], centre), n)
    return leaks(codes, crosstalk, looks.waves.kind[beams], np.arange(len(beams)),
                 samples).max(axis=1, initial=0.0)


def trusted(coherence, arrival, geometry: ArrayGeometry,
            settings: DetectionSettings) -> np.ndarray:
    """(E,) where re-placed echoes are kept: one plane wave from their refined ``arrival``
    (E, 3) explains ``min_coherence`` of the channels' power (``coherence`` (E,)) and it lies
    in the field of view."""
    return (coherence >= settings.min_coherence) \
        & in_fov(arrival, geometry.fov_horizontal, geometry.fov_vertical)


def rows(beams, samples, cells, u, recovered: Recovered | None):
    """The rows of a report: echoes (``beams``, ``samples``), then the off-beam echoes
    ``recovered`` (or none), then the range cells (beams, samples). Returns beams (E,), samples
    (E,), peak (E,) (False for a cell), centre (E, 3) (where each row's arrival direction is
    sought: its beam, or the off-beam echo's direction) and off_beam (E,)."""
    extra = recovered or Recovered(np.zeros(0, np.int64), np.zeros(0, np.int64),
                                   np.zeros((0, 3)))
    counts = (len(beams), len(extra.beam), len(cells[0]))
    beams = np.concatenate([beams, extra.beam, cells[0]])
    samples = np.concatenate([samples, extra.sample, cells[1]])
    peak = np.repeat([True, True, False], counts)
    off_beam = np.repeat([False, True, False], counts)
    centre = u[beams]
    centre[off_beam] = extra.centre
    return beams, samples, peak, centre, off_beam
