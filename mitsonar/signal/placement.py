"""Placing and reporting the echoes each beam's receiver chose (time of arrival, arrival
direction, depth (7), trust), as :class:`~mitsonar.signal.detection.Echoes` and
:class:`~mitsonar.signal.detection.Detections`.

* Time of arrival at each echo's sample, refined by a parabola through the three samples around
  a peak (a range cell is read at its sample: it is no peak).
* Arrival direction (``arrival_step`` > 0; beyond the paper, which places every point on the
  beam axis): where along the transmit beam's lit lobe the echo at that instant comes from, read
  from the receive array (:meth:`Beamformer.arrival_directions
  <mitsonar.signal.beamforming.Beamformer.arrival_directions>`, summed over the looks), or
  where a beam's cone image peaks ("image", :mod:`mitsonar.signal.cone`); its trust, the
  fraction of the channels' power one plane wave from it explains (:meth:`Beamformer.coherence
  <mitsonar.signal.beamforming.Beamformer.coherence>`).
* Point (:func:`place`, every echo and range cell of every setting, off-beam echoes and
  single-ping images too): on the bistatic ellipse of the measured path, along the direction the
  receive array measured, corrected for its near field; without an arrival direction, by (7) on
  the beam axis (:mod:`mitsonar.signal.receiver`).

Where a point lies (:func:`place`). The plane-wave delays (5) are referenced to the receive
origin o_R and the steering delays to the transmit origin o_T, so an echo's envelope peaks at
the path o_T -> point -> o_R plus what the arrays' curvature adds: element j of an array hears a
point at range r in direction u later than the plane wave by q_j = (|p_j|^2 - (p_j . u)^2)
/ (2 r) (p_j from the array's reference), and the envelope of their sum peaks at their mean (for
a steered transmit array the same holds for its elements' spherical waves). The plane-wave beams
peak where they best align the receive delays: for a point target, the direction from the
receive array's phase centre (its element centroid c_R, 8 mm from o_R in the shipped layout),
shifted further by the curvature's correlation with the positions; :func:`near_field_shift`
turns the peak into the direction from o_R. The point is then o_R + r u, r from (7) for the
baseline o_R -> o_T and the path less the mean curvature delays. Checked on an analytic point
target (every element pair's exact path, tests/signal/test_placement.py): within 1 mm at
0.7-3 m within 2 deg of the beam axis; placing from o_R along the phase centre's direction, as
the first-echo path did before, put points 6-8 mm aside.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from mitsonar.signal import offbeam
from mitsonar.signal.beamforming import dot
from mitsonar.physics.array import ArrayGeometry
from mitsonar.signal.detection import Detections, Echoes, bistatic_depth, vertex


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
            (:func:`~mitsonar.signal.cone.apparent_directions`).
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
            else unit_direction(apparent)  # where the plane-wave beams peak
        coherence = processor.beamformer.coherence(looks.channels, sets, carriers, row,
                                                   sample, arrival)
        point, arrival = place(g, l, arrival[:, :2])
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


def place(geometry: ArrayGeometry, path_length: np.ndarray, apparent: np.ndarray,
          transmit_centre=None) -> tuple[np.ndarray, np.ndarray]:
    """(points (P, 3) [m], unit directions (P, 3) from the receive origin o_R to them) of echoes
    whose envelopes peak at ``path_length`` (P,) [m] (c x the time of arrival) and whose
    plane-wave beams (5) peak at direction cosines ``apparent`` (P, 2) (module docstring): the
    near field corrected (:func:`near_field_shift`), the mean curvature delays of both arrays
    taken off the path (:func:`curvature_delay`), and (7) solved from o_R along the direction.

    Args:
        geometry: the arrays.
        path_length: (P,) [m].
        apparent: (P, 2).
        transmit_centre: None: a beam steered from the transmit array (delays referenced to the
            transmit origin); or (3,) [m] the point a single-ping transmission leaves from
            (:mod:`mitsonar.signal.imaging`), a point source.
    """
    source = np.zeros(3) if transmit_centre is None else np.asarray(transmit_centre, float)
    baseline = source - geometry.rx_origin
    length = float(np.linalg.norm(baseline))
    unit = baseline / max(length, 1e-300)
    receive = geometry.rx_positions - geometry.rx_origin
    arrival, path = unit_direction(apparent), np.asarray(path_length, dtype=float)
    for _ in range(2):  # (7), the near field and the curvature depend on each other, weakly
        receive_range = bistatic_depth(path, length, dot(arrival, unit))
        arrival = unit_direction(apparent + near_field_shift(geometry, arrival, receive_range))
        path = path_length - curvature_delay(receive, arrival, receive_range)
        if transmit_centre is None:
            point = geometry.rx_origin + receive_range[:, None] * arrival
            transmit_range = np.linalg.norm(point, axis=-1)
            path = path - curvature_delay(geometry.tx_positions,
                                          point / transmit_range[:, None], transmit_range)
    receive_range = bistatic_depth(path, length, dot(arrival, unit))
    return geometry.rx_origin + receive_range[:, None] * arrival, arrival


def curvature_delay(offsets: np.ndarray, direction: np.ndarray, distance: np.ndarray):
    """(P,) [m] the mean over elements at ``offsets`` (N, 3) [m] from an array's reference of
    how much farther a point at ``distance`` (P,) [m] in ``direction`` (P, 3) is than a plane
    wave from there says: (|p_j|^2 - (p_j . u)^2) / (2 r), averaged over j."""
    along = direction @ offsets.T  # (P, N)
    return np.mean(np.sum(offsets**2, axis=1) - along**2, axis=1) / (2 * distance)


def near_field_shift(geometry: ArrayGeometry, direction: np.ndarray,
                     distance: np.ndarray) -> np.ndarray:
    """(P, 2) what to add to the (u_x, u_y) of the peak of the plane-wave beams (5) to get the
    direction of a source at ``distance`` (P,) [m] from the receive origin in ``direction``
    (P, 3). Within the array's far-field distance (2 x (10 cm)^2 / 8.5 mm = 2.3 m) element j
    hears the source q_j = (|p_j|^2 - (p_j . u)^2) / (2 r) later than a plane wave from u; the
    beam that best aligns these delays (least squares) peaks C^-1 cov(p, q) before u (C: the
    covariance of the positions p_j in the array plane). The linear part of q_j is the offset of
    the array's phase centre from o_R: far away the shift is the parallax of that offset."""
    p = geometry.rx_positions[:, :2] - geometry.rx_origin[:2]
    along = direction[:, :2] @ p.T  # (P, N_rx)
    late = (np.sum(p**2, axis=1) - along**2) / (2 * distance[:, None])
    centred = p - p.mean(axis=0)
    covariance = (late - late.mean(axis=1, keepdims=True)) @ centred / len(p)  # (P, 2)
    return np.linalg.solve(np.cov(p.T, bias=True), covariance.T).T


def unit_direction(u_xy: np.ndarray) -> np.ndarray:
    """Unit vectors (P, 3) towards +z with direction cosines ``u_xy`` (P, 2)."""
    return np.concatenate([u_xy, np.sqrt(1.0 - np.sum(u_xy**2, axis=1, keepdims=True))], axis=1)
