"""Placing and reporting the echoes each beam's receiver chose (time of arrival, arrival
direction, depth (7), trust), as :class:`~mitsonar.signal.detection.Echoes` and
:class:`~mitsonar.signal.detection.Detections`.

* Time of arrival at each echo's sample, refined by a parabola through the three samples around
  a peak (a range cell is read at its sample: it is no peak).
* Arrival direction (``arrival_step`` > 0; beyond the paper, which places every point on the
  beam axis): where along the transmit beam's lit lobe the echo at that instant comes from, read
  from the receive array (:meth:`Beamformer.arrival_directions
  <mitsonar.signal.beamforming.Beamformer.arrival_directions>`, summed over the looks), or
  where a beam's cone image peaks ("image", :func:`mitsonar.signal.cone.place`); its trust, the
  fraction of the channels' power one plane wave from it explains (:meth:`Beamformer.coherence
  <mitsonar.signal.beamforming.Beamformer.coherence>`).
* Depth by the bistatic (7), from the receive origin along the arrival direction ("first"), from
  the receive array's phase centre (every echo), or on the beam axis without one
  (:mod:`mitsonar.signal.receiver`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from mitsonar.signal import cone, offbeam
from mitsonar.signal.beamforming import dot
from mitsonar.signal.detection import Detections, Echoes, bistatic_depth, bistatic_point, vertex


def report(processor, envelopes, threshold, window, start_time, transmit, u, waves, looks,
           beams, samples, cells, apparent=None, moved=None) -> Detections:
    """:class:`Detections` and :class:`Echoes` of B beams from the echoes their receiver chose
    (module docstring): each placed and, with ``echoes`` = "all", "cells" or "image", kept
    where its direction is trustworthy (``min_coherence``, ``arrival_cone``); rows by beam
    and then by decreasing amplitude.

    Args:
        processor: the receiver (:class:`~mitsonar.signal.receiver.EchoProcessor`).
        envelopes: (B, N) [Pa] ("image": the cone images' profiles).
        threshold: (B, N) the level an echo must exceed [Pa].
        window: (B, N) the listening window.
        start_time: time of sample 0 [s].
        transmit: (B,) when each beam was fired [s].
        u: (B, 3) beam directions.
        waves: the beams' waveforms (:class:`~mitsonar.signal.looks.Waveforms`).
        looks: their looks (:class:`~mitsonar.signal.looks.Looks`), or None (every echo on
            its beam's axis).
        beams, samples: (E,) the echoes, by beam and then by decreasing amplitude.
        cells: (beams, samples) of the range cells.
        apparent: (E, 2) "image"'s directions, echoes then cells
            (:func:`~mitsonar.signal.cone.place`).
        moved: off-beam echoes (:class:`~mitsonar.signal.offbeam.Recovered`), or None.
    """
    s, g = processor.settings, processor.geometry
    fs = processor.band.sample_rate
    count = len(envelopes)
    beams, k, peak, centre, off_beam = offbeam.rows(beams, samples, cells, u, moved)
    refined = np.where(peak & ~off_beam, vertex(envelopes[beams, k - 1], envelopes[beams, k],
                                                envelopes[beams, k + 1]), 0.0)
    sample = k + refined
    toa = start_time - transmit[beams] + sample / fs
    l = processor.c * toa
    coherence = np.full(len(beams), np.nan)
    if looks is not None and (s.arrival_step > 0 or apparent is not None) and len(beams):
        look, row = np.nonzero(waves.looks[beams].T >= 0)  # every row's first look first
        sets = looks.sets(beams[row], look)
        carriers = waves.carriers[waves.looks[beams[row], look]]
        arrival = processor.beamformer.arrival_directions(
            looks.channels, sets, carriers, row, sample, centre) if apparent is None \
            else cone.unit_direction(apparent)  # where the plane-wave beams peak
        coherence = processor.beamformer.coherence(looks.channels, sets, carriers, row,
                                                   sample, arrival)
        if apparent is not None:  # (7) from the receive origin, near field corrected
            point, arrival = cone.place(g, np.zeros(3), l, apparent)
        elif s.echoes == "first":  # placed from the receive origin, as ever
            receive_range = bistatic_depth(l, g.baseline,
                                           -dot(arrival, g.rx_origin) / g.baseline)
            point = g.rx_origin + receive_range[:, None] * arrival
        else:  # from the receive array's phase centre, where the arrival is measured
            point = bistatic_point(l, arrival, g.rx_positions.mean(axis=0), np.zeros(3),
                                   g.rx_origin)
    else:
        arrival = u[beams]
        cos_b = dot(u, g.rx_origin) / g.baseline
        point = bistatic_depth(l, g.baseline, cos_b[beams])[:, None] * arrival
    # The single-detection path trusts every direction; the others those that one plane wave
    # explains, and echoes without a measured direction (on the beam axis, as the paper).
    trusted = np.where(off_beam, offbeam.trusted(coherence, arrival, g, s),
                       (s.echoes == "first") | (coherence >= s.min_coherence)
                       | (peak & np.isnan(coherence)))
    if s.echoes != "first" and s.arrival_cone is not None:  # inside the lit cone
        trusted &= off_beam | (dot(arrival, u[beams]) >= np.cos(s.arrival_cone))
    noise = waves.noise[waves.kind[beams]]
    with np.errstate(divide="ignore"):  # no receiver noise: infinite SNR
        snr = envelopes[beams, k] / noise
    table = Echoes(beam=beams, rank=np.zeros(len(beams), np.int64), peak=peak,
                   amplitude=envelopes[beams, k], snr=snr, time_of_arrival=toa,
                   path_length=l, depth=np.linalg.norm(point, axis=-1), point=point,
                   direction=arrival, coherence=coherence, off_beam=off_beam)
    rows = np.flatnonzero(trusted)
    rows = rows[np.lexsort((-table.amplitude[rows], ~peak[rows], beams[rows]))]
    table, k = table.take(rows), k[rows]
    rank = np.arange(len(rows)) - np.searchsorted(table.beam, table.beam)
    table = replace(table, rank=rank)
    every = np.arange(count)
    k_max = np.argmax(np.where(window, envelopes, -np.inf), axis=1)
    out = dict(detected=np.zeros(count, bool), time_of_arrival=np.full(count, np.nan),
               path_length=np.full(count, np.nan), depth=np.full(count, np.nan),
               point=np.full((count, 3), np.nan), direction=np.full((count, 3), np.nan),
               amplitude=envelopes[every, k_max], threshold=threshold[every, k_max])
    first = rank == 0
    found = table.beam[first]
    for name, value in (("detected", True), ("time_of_arrival", table.time_of_arrival),
                        ("path_length", table.path_length), ("depth", table.depth),
                        ("point", table.point), ("direction", table.direction),
                        ("amplitude", table.amplitude),
                        ("threshold", threshold[table.beam, k])):
        out[name][found] = value if np.ndim(value) == 0 else value[first]
    return Detections(**out, echoes=table)
