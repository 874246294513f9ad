"""Receive imaging over each beam's lit cone (``DetectionSettings.echoes`` = "image").

A steered transmit beam lights a cone around its axis and suppresses what lies outside it, so
the receive array, steered across that cone only, images what the beam lights with the two-way
pattern's low side lobes instead of the receive array's alone (single-ping imaging,
:mod:`mitsonar.signal.imaging`). For every beam of a scan or OFDM cycle, after its own matched
filter:

* Grid (:class:`ConeImager`): receive directions u_b + (i, m) s around the beam's axis u_b in
  direction cosines, s = sin(``image_step``), over the disc of radius sin(``image_half_angle``)
  (the cone) plus a guard ring of sqrt(2) s (every cone direction has its 8 neighbours). In
  direction cosines both the transmit and the receive patterns keep their shape wherever they
  are steered, so one offset grid serves every beam (2 deg and 3 deg: 25 directions, 9 inside
  the cone). Delay-and-sum (5) on the band: the planar array's phase
  exp(-j 2 pi f (p_j - o_R) . (u_b + d) / c) is the beam's steering phasor times a phase of the
  offset d alone, the same for every beam, so all directions of B beams are one batched matrix
  product per band bin, (B, N_rx) x (N_rx, G); then the beam's matched filter (6) and one
  inverse FFT per direction (:meth:`ConeImager.envelopes`): the image (B, G, N), each row the
  envelope :class:`~mitsonar.signal.receiver.EchoProcessor` forms towards that direction.
* Peak (:func:`cone_peaks`): at every sample, the largest value of the image over the cone and
  its direction, the beam's profile M (B, N). Echoes and range cells are chosen on M as for
  "cells" (:mod:`mitsonar.signal.multiecho`: over the noise threshold, over ``clutter_margin``
  times the range side lobes of stronger echoes and the other codes' cross-talk, range cells
  every ceil(tau_r) across extended echoes), where that value is a peak: none of its 8
  neighbours, those on the guard ring included, is larger (an echo from outside the cone, lit by
  the transmit side lobes, rises towards the rim: no point). Unlike "cells", the range cells are
  grown from the echoes before the checks below, and each is then checked at its own direction:
  a cell can stay in a run whose echo the side-lobe check rejects (117-beam scans of three
  scenes, broadband and TCT40 transducers, and OFDM frames: 2 of about 450 reported rows,
  cells 1.2 cm from the mesh, as close as the other cells).
* Checks at the peak direction, with the receiver's looks (each part of a code matched-filtered
  and demodulated at its tone): every part of the code there with ``part_balance`` of the
  strongest; the side-lobe check towards the peak direction (no direction of the +-50 deg
  ghost grid outside its receive main lobe ``ghost_margin`` stronger at that instant: a return
  from elsewhere leaking through the receive side lobes); the direction's trust (``coherence``
  >= ``min_coherence``).
* Placement: the direction refined between grid directions by the vertex of the quadratic
  through the log of the image at the peak and its 8 neighbours (:func:`peak_offsets`), then
  placed as every echo is (:func:`mitsonar.signal.placement.place`: near field, curvature,
  bistatic depth (7) from the receive origin o_R along it), as single-ping imaging places its
  points.
* False alarms (:meth:`ConeImager.expected_false_alarms`): receiver noise alone gives the image
  of a complex Gaussian field, stationary in time and direction cosines; the design number of
  points per beam is the expected Euler characteristic of its excursion set above
  ``detection_snr`` over the cone x the listening window (:func:`expected_blobs`), as for
  single-ping images, counting only the blobs that peak inside the cone (its volume term: a
  point needs the image to peak inside the cone, not on its rim). Measured on noise alone
  (``tests/signal/test_cone_image.py``, 117 beams, 3 x the RMS noise envelope, the side-lobe
  check, the clutter rule and the trust off): 0.79 of the design (peaks between the 2 deg grid's
  directions are seen lower); with them on, none.
"""

from __future__ import annotations

import numpy as np

from mitsonar.physics.array import ArrayGeometry
from mitsonar.signal.band import Band
from mitsonar.signal.beamforming import Beamformer, peak_offsets
from mitsonar.signal import multiecho
from mitsonar.signal.detection import DetectionSettings, local_maxima

#: Image rows (beams x directions) transformed together (bounds the complex temporaries).
ROW_BATCH = 256


class ConeImager:
    """Receive images over the lit cones of B beams; built once per receiver.

    Args:
        geometry: the arrays (a planar receive array: every element at the same z).
        band: the recordings' band.
        speed_of_sound: c [m/s].
        settings: ``image_step`` and ``image_half_angle``.
    """

    def __init__(self, geometry: ArrayGeometry, band: Band, speed_of_sound: float,
                 settings: DetectionSettings):
        offsets = geometry.rx_positions - geometry.rx_origin
        if np.ptp(offsets[:, 2]) > 1e-9:
            raise ValueError("DetectionSettings.echoes = 'image' needs a planar receive array")
        self.band = band
        self.c = float(speed_of_sound)
        #: Grid spacing and cone radius in direction cosines.
        self.spacing = float(np.sin(settings.image_step))
        self.radius = float(np.sin(settings.image_half_angle))
        guard = self.radius / self.spacing + np.sqrt(2.0)  # [grid steps]
        h = int(np.floor(guard))
        steps = np.arange(-h, h + 1)
        my, mx = np.meshgrid(steps, steps, indexing="ij")
        kept = np.hypot(mx, my) <= guard + 1e-9
        #: (G, 2) offsets of the grid's directions from a beam's axis, direction cosines.
        self.offsets = np.stack([mx[kept], my[kept]], axis=-1) * self.spacing
        #: (G,) the directions inside the cone (the others are its guard ring).
        self.inside = np.hypot(mx[kept], my[kept]) * self.spacing <= self.radius + 1e-12
        lookup = np.full(mx.shape, -1)
        lookup[kept] = np.arange(kept.sum())
        pad = np.pad(lookup, 1, constant_values=-1)
        #: (G, 3, 3) each direction's neighbours [dy, dx] (-1 beyond the grid; never for the
        #: cone's directions).
        self.neighbours = np.stack([pad[1 + dy:1 + dy + len(steps), 1 + dx:1 + dx + len(steps)]
                                    [kept] for dy in (-1, 0, 1) for dx in (-1, 0, 1)],
                                   axis=-1).reshape(-1, 3, 3)
        # exp(-j 2 pi f (p_j - o_R) . d / c) / N_rx of every offset d, (nb, N_rx, G).
        delays = offsets[:, :2] @ self.offsets.T / self.c  # (N_rx, G) [s]
        self._offset_phases = (np.exp(-2j * np.pi * band.frequencies[:, None, None] * delays)
                               / len(offsets)).astype(np.complex64)

    def envelopes(self, beamformer: Beamformer, spectra: np.ndarray, directions: np.ndarray,
                  filters: np.ndarray, n: int) -> np.ndarray:
        """Image (B, G, n) [Pa], float32: the matched-filtered delay-and-sum envelopes of channel
        spectra on the band, (N_rx, nb) shared or (B, N_rx, nb) one set per beam, towards every
        grid direction around each beam's axis ``directions`` (B, 3), beam b filtered by
        ``filters[b]`` (B, nb)."""
        steered = (spectra * beamformer.steering(directions)).astype(np.complex64)  # (B, N_rx, nb)
        formed = np.matmul(steered.transpose(2, 0, 1), self._offset_phases)  # (nb, B, G)
        bins, count, grid = formed.shape
        image = self.band.envelopes(formed.transpose(1, 2, 0).reshape(count * grid, bins),
                                    np.repeat(filters, grid, axis=0), n, ROW_BATCH, np.float32)
        return image.reshape(count, grid, n)

    def expected_false_alarms(self, detection_snr: float, duration: float,
                              rx_positions: np.ndarray, waveform=None) -> float:
        """Design number of points that receiver noise alone gives a beam over ``duration`` [s]
        of its window at ``detection_snr`` (module docstring): :func:`expected_blobs` over the
        cone, for receive elements at ``rx_positions`` (N_rx, 3) [m] and the matched-filter
        output of ``waveform`` (default: the band's pulse)."""
        angle = np.linspace(0.0, 2 * np.pi, 1024, endpoint=False)
        outline = self.radius * np.stack([np.cos(angle), np.sin(angle)], axis=-1)
        return expected_blobs(detection_snr, outline, duration, self.band, rx_positions, self.c,
                              waveform, interior=True)


def parts_balanced(beamformer: Beamformer, looks, beams: np.ndarray, samples: np.ndarray,
                   directions: np.ndarray, part_balance: float) -> np.ndarray:
    """(E,) True where every part of the code of beam ``beams[e]`` is there at sample
    ``samples[e]`` towards ``directions[e]`` (E, 3) with at least ``part_balance`` of the
    strongest part's beam (a waveform without parts passes): the narrow-band beams of the
    receiver's looks (:class:`~mitsonar.signal.receiver.EchoProcessor`'s, each part
    matched-filtered and demodulated at its tone, relative to what the code's own echo leaves
    there, ``part_gains``), a code's two parts in turn."""
    waves = looks.waves
    table = waves.looks[beams]
    part = np.zeros(table.shape)
    for look, rows, sets, carriers in looks.each(beams):  # a code's parts (two at most)
        part[rows, look] = np.abs(beamformer.aligned(looks.channels, sets, carriers,
                                                     samples[rows], directions[rows]).sum(axis=1)) \
            / waves.part_gains[beams[rows], look]
    weakest = np.where(table >= 0, part, np.inf).min(axis=1)
    return ~waves.has_parts[beams] | (weakest >= part_balance * part.max(axis=1))


def cone_peaks(imager: ConeImager, image: np.ndarray):
    """(profile M (B, N) [Pa], peak direction index (B, N), whether it is a peak (B, N)) of an
    image (B, G, N): at every sample the largest value over the cone, where it lies, and whether
    none of its 8 neighbours (the guard ring's too) is larger."""
    cone = np.flatnonzero(imager.inside)
    best = cone[np.argmax(image[:, cone], axis=1)]
    profile = np.take_along_axis(image, best[:, None, :], axis=1)[:, 0]
    around = imager.neighbours[best].reshape(best.shape + (9,)).transpose(0, 2, 1)  # (B, 9, N)
    peak = profile >= np.take_along_axis(image, around, axis=1).max(axis=1)
    return profile.astype(float), best, peak


def apparent_directions(imager: ConeImager, image: np.ndarray, axes: np.ndarray, beams, samples,
                        best: np.ndarray) -> np.ndarray:
    """(E, 2) direction cosines (u_x, u_y) where the plane-wave beams of rows (beams, samples)
    (E,) peak: the grid direction ``best[beams, samples]`` around axis ``axes[beams]`` (B, 3),
    refined by :func:`peak_offsets` (its 8 neighbours lie in the grid: it is inside the cone)."""
    d = best[beams, samples]
    near = image[beams[:, None, None], imager.neighbours[d], samples[:, None, None]]
    offset = peak_offsets(np.log(np.maximum(near.astype(float), 1e-30)))
    return axes[beams, :2] + imager.offsets[d] + imager.spacing * offset


def expected_blobs(detection_snr: float, outline: np.ndarray, duration: float, band: Band,
                   rx_positions: np.ndarray, speed_of_sound: float, waveform=None,
                   interior: bool = False) -> float:
    """Expected Euler characteristic of the excursion set above ``detection_snr`` times the RMS
    of the delay-and-sum envelope of receiver noise, over the region of direction cosines
    enclosed by ``outline`` (M, 2) (a closed polygon, in order) x ``duration`` [s] (Adler and
    Taylor; chi-square fields: Worsley 1994): the number of its blobs when the threshold is high.
    The field's roughness: 2 pi x the rms bandwidth of ``waveform``'s matched-filter output in
    time; in direction cosines the mean square wavenumber times the covariance of the receive
    elements' positions ``rx_positions`` (N_rx, 3) [m] in the array plane. ``interior``: only
    the blobs that peak inside the region x window, its top term L_3 rho_3 (the lower terms
    count the blobs that peak on its boundary)."""
    centre, rms_bandwidth = band.band_moments(waveform)
    time_length = max(duration, 0.0) * 2 * np.pi * rms_bandwidth  # L_1 of the window
    metric = (2 * np.pi / speed_of_sound) ** 2 * (centre**2 + rms_bandwidth**2) \
        * np.cov(np.asarray(rx_positions)[:, :2].T, bias=True)
    w = np.asarray(outline, dtype=float) @ np.linalg.cholesky(metric)  # |w|: metric length
    x, y = w[:, 0], w[:, 1]
    area = 0.5 * abs(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))
    half_perimeter = 0.5 * np.sum(np.linalg.norm(w - np.roll(w, -1, axis=0), axis=1))
    # Lipschitz-Killing curvatures of (region) x (window), and the EC densities of a chi-square
    # field with 2 degrees of freedom at t = 2 snr^2.
    lkc = [1.0, half_perimeter + time_length, area + half_perimeter * time_length,
           area * time_length]
    t = 2 * float(detection_snr) ** 2
    tail = np.exp(-t / 2)
    density = [tail, np.sqrt(t) * tail / np.sqrt(2 * np.pi), (t - 1) * tail / (2 * np.pi),
               np.sqrt(t) * (t - 3) * tail / (2 * np.pi) ** 1.5]
    return float(lkc[3] * density[3] if interior else np.dot(lkc, density))


def cone_echoes(imager: ConeImager, image: np.ndarray, threshold: np.ndarray, window: np.ndarray,
                resolution: np.ndarray, clutter, margin: float):
    """Echoes and range cells of B beams from their images (B, G, N) (module docstring), before
    the checks at their directions: (profile M (B, N) [Pa], (beams, samples) of the echoes,
    (beams, samples) of the range cells, peak direction index (B, N)). ``threshold`` (B, N)
    [Pa], ``window`` (B, N) the listening window; ``resolution``, ``clutter``, ``margin`` as in
    :func:`~mitsonar.signal.multiecho.echo_peaks`."""
    profile, best, inside = cone_peaks(imager, image)
    loud = profile > threshold
    found, resolved = multiecho.echo_peaks(profile, local_maxima(profile) & loud,
                                           window & inside, resolution, clutter, margin)
    cells = multiecho.range_cells(profile, window & loud, inside, resolved, found, resolution,
                                  clutter, margin)
    return profile, found, cells, best
