"""Single-ping receive imaging: the receive image of one recording and its points.

One wide transmission lights the whole field of view at once (RTIS / eRTIS); the receive array
then forms beams towards every direction of a grid, all from the same recording.

Grid. Directions on a square grid of direction cosines (u_x, u_y), ``sin(step)`` apart (``step``
at broadside), over the disc |(u_x, u_y)| <= sin(``guard_half_angle``): the whole cone the
transmission lights, not only the field of view, because echoes from anywhere in it reach the
field of view through the receive array's side lobes, and predicting those needs their beams
(below). In direction cosines a beam's main lobe and side lobes have the same shape wherever it
is steered (:mod:`mitsonar.physics.beampattern`), so the grid samples every beam alike. Points
come from the directions inside the field of view only (``ArrayGeometry`` ``fov_horizontal`` x
``fov_vertical``), or a region of it (a sector); the others are their neighbours and the
side-lobe reference.

Image. Delay-and-sum (5) on the signal band and the matched filter (6), as
:class:`~mitsonar.signal.receiver.EchoProcessor` forms one beam (the same steering phases, filter
and scale: an image row equals that beam's envelope), for all D directions x N samples in one
pass: on the square grid the plane-wave phase exp(-j 2 pi f (x_j u_x + y_j u_y) / c) of receive
element j factorises into an x and a y part, so the delay-and-sum of every direction is one
batched matrix product per band bin, (n_y x N_rx) (N_rx x n_x); then one inverse FFT per
direction, in a few large batches of directions to bound memory.

Points. A cell (direction d, sample k) inside the field of view is a point when

1. it exceeds ``detection_snr`` times the RMS noise envelope
   (:meth:`~mitsonar.signal.receiver.EchoProcessor.noise_envelope_rms`; at least
   ``detection_floor``), ``blanking_margin`` times the image of the direct transmitter ->
   receiver path alone and that image plus the threshold (direct-path blanking,
   :func:`~mitsonar.signal.detection.blanking_level`), and lies beyond ``min_range``;
2. it is a range peak: the largest value of its direction within +- one range resolution (the
   full width at half maximum of an echo's matched-filter envelope,
   :attr:`ReceiveImager.range_resolution`), so two echoes of one direction further apart than
   that are two points. Where several elements fire (the array defocused, ``transmit``), an
   echo is a train of their waves' copies: element i's wave travels e_i(u) = c tau_i + lead -
   (p_i - s) . u further towards u than the wave the echoes are placed with
   (:func:`excess_paths`, far field; firing delays tau_i, transmit centre s); over the
   field of view of a 20-80 kHz sweep from a virtual source 0.1 m behind the array the copies
   spread over 37 mm of path (median, up to 67 mm), ten times the sweep's range resolution,
   and each would be a point 0-3 cm behind its reflector. The window is then each direction's
   spread max_i e_i - min_i e_i where longer: one point per train, and two echoes of one
   direction closer than that one point;
3. it is the peak of its receive main lobe: no direction within ``ghost_exclusion`` of d is
   stronger at sample k;
4. it is no side lobe of another return. The receive array's side lobes are real, and with one
   wide transmission nothing (no transmit beam) suppresses them: an echo from d0 also shows, at
   the same instant, in direction d at |AF(d; d0)| (the array factor at the band's centre
   frequency) times its level; for the shipped sparse 5 x 5 array up to -8 dB (peak side lobe)
   and -14 dB on average (mean square 1/N_rx: the array spreads most of an echo's power over
   its side lobes). Two rules, both from the receive pattern:

   * coherent, one return: the cell must exceed ``side_lobe_margin`` times the largest level
     predicted from any grid direction d0 outside its main lobe, max over d0 of
     image(d0, k) |AF(d; d0)|;
   * incoherent, many returns (clutter): several echoes arriving at once (walls, floor and
     ceiling at the same path length, inside the field of view or not) add their side lobes
     with unrelated phases into a Rayleigh-distributed clutter whose power is the image's mean
     power over the grid at that instant. The cell must exceed ``clutter_margin`` times that
     RMS; clutter alone exceeds it with probability exp(-clutter_margin^2) per cell (1.2e-4 at
     the default 3).
   * in range, one return of its own direction: the cell must exceed ``side_lobe_margin`` times
     the largest level any sample k0 of its direction puts into it through the matched
     filter's range side lobes, image(d, k0) |R(k - k0)|, R the normalised envelope of one
     echo's matched-filter output beyond its main lobe (zero up to its first minimum on each
     side). A tone burst has none (its envelope ends with its main lobe); a linear sweep's are
     -13 dB at 1-3 cm and -28 dB at 6-12 cm of range for 30-50 kHz (4 ms, 10 % taper), and
     without this rule put points ~10 cm in front of a wall seen head-on.

5. its direction is trusted: one plane wave from it explains at least ``min_coherence`` of the
   receive channels' power at that instant, the coherence factor |sum_j x_j|^2 /
   (N_rx sum_j |x_j|^2) with x_j channel j matched-filtered, demodulated at the band's carrier,
   read at sample k plus its delay (5) towards d (linearly interpolated between samples) and
   phase-aligned (:meth:`Beamformer.coherence
   <mitsonar.signal.beamforming.Beamformer.coherence>`, the receiver's trust rule on the same
   complex looks; one arrival: 1, a side lobe of a return from d0: about |AF(d; d0)|^2, several
   arrivals at once: the strongest one's share of their power). On receiver noise alone a cell
   at s times the RMS noise envelope has coherence about s^2 / N_rx, so the rule asks noise for
   an SNR of sqrt(min_coherence N_rx) (3.2 with the defaults): below ``detection_snr``, it
   leaves the design false-alarm rate unchanged. With ``coherence_bands`` n > 1 the factor is
   read in n half-overlapping Hann sub-bands of the drive's band and averaged: behind a wide
   sweep the room's echoes carry most of their power at its low end (20-80 kHz in the office:
   85 % below 30 kHz), where the receive beam is widest and echoes arriving together mix most,
   so the whole band's factor is mostly that beam's; in sub-bands each part counts alike.

   Measured on the shipped rooms (docs/imaging.md): a ping's recording holds a few hundred
   range peaks that are the peak of their main lobe, but at nearly every instant the channels
   hear several echoes at once (walls, floor, ceiling and furniture at the same path length,
   within the cone or beyond the field of view), and for 95 % of them the strongest direction
   explains under 30 % of the channels' power; those cells are within 2 cm of a surface 3-6 %
   of the time, the few over 0.4 86-100 % of the time.

Each point is placed as the receiver places a detection with its arrival direction: the
direction refined between grid directions by a parabola through the image power along u_x and
u_y (with ``coherence_peak``: through the coherence of rule 5, within one grid step), the time
of arrival by a parabola through the envelope (a train of copies, rule 2: the power centroid
of the envelope over its window, less the mean of e_i towards the refined direction), and the
point placed by
:func:`mitsonar.signal.placement.place` (near field and curvature corrected, the bistatic depth
(7) solved from the receive origin o_R along the direction, with the baseline from o_R to the
transmit centre, a point source): point = o_R + r u_a.

False alarms. On noise alone the image is the envelope of a complex Gaussian field, stationary
in time and in direction cosines; a cell exceeds the threshold with probability
exp(-detection_snr^2). How many separate peaks do (:meth:`ReceiveImager.expected_false_alarms`)
is the expected Euler characteristic of the field's excursion set above the threshold (Adler and
Taylor; chi-square fields: Worsley 1994), which counts its blobs when the threshold is high:
sum_j L_j rho_j(2 snr^2), with the Lipschitz-Killing curvatures L_j of the searched volume (the
field of view x the listening window, measured in the field's roughness: 2 pi x the echo
spectrum's rms bandwidth in time; in direction cosines the rms wavenumber times the receive
elements' spread) and the densities rho_j of a chi-square field with 2 degrees of freedom.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import maximum_filter1d

from mitsonar.frames import fov_angles
from mitsonar.physics.array import ArrayGeometry
from mitsonar.physics.beampattern import array_factor
from mitsonar.signal.band import Band, Recording
from mitsonar.signal.beamforming import peak_offsets
from mitsonar.signal.cone import expected_blobs
from mitsonar.signal.placement import place
from mitsonar.signal.detection import DetectionSettings, blanking_level, vertex
from mitsonar.signal.imaging_settings import ImagePoints, ImagingSettings
from mitsonar.signal.receiver import EchoProcessor
from mitsonar.validation import check_positive, check_range

#: Directions whose envelopes are transformed together (bounds the complex temporaries).
DIRECTION_BATCH = 256
#: Candidate cells whose side-lobe levels are predicted together (bounds a (batch, D) array).
CANDIDATE_BATCH = 1024
#: Range side lobes below this share of an echo's matched-filter peak count as none (-100 dB):
#: an echo 2e5 times (106 dB) stronger than a cell would be needed for them to decide rule 4,
#: beyond any image's range (noise to the nearest echo: 60-80 dB). A 4 ms 20-80 kHz sweep's lobes
#: fall below it 583 lags from the peak at 250 kHz, so each candidate reads 2 x 583 samples, not
#: the recording's 8 472.
RANGE_LOBE_FLOOR = 1e-5
#: The array's normal.
BROADSIDE = np.array([0.0, 0.0, 1.0])


def coherence_windows(frequencies: np.ndarray, spectrum: np.ndarray, bands: int) -> np.ndarray:
    """(bands, nb) weights of the coherence's sub-bands at ``frequencies`` (nb,) [Hz]: ones for
    one band; else ``bands`` Hann windows spaced w apart, each 2 w wide, over the extent where
    ``spectrum`` (nb,) (magnitudes) is within 6 dB of its peak, w = extent / bands (they sum
    to one between the outer windows' centres)."""
    if bands == 1:
        return np.ones((1, len(frequencies)))
    inside = frequencies[spectrum >= 0.5 * spectrum.max()]
    low, spacing = inside.min(), (inside.max() - inside.min()) / bands
    centres = low + (np.arange(bands) + 0.5) * spacing
    x = (frequencies[None] - centres[:, None]) / (2 * spacing)
    return np.where(np.abs(x) < 0.5, np.cos(np.pi * x) ** 2, 0.0)


def excess_paths(positions: np.ndarray, firing: np.ndarray, lead: float, source,
                 directions: np.ndarray, speed_of_sound: float) -> np.ndarray:
    """(D, N) [m]: how much longer than the wave the echoes are placed with (transmit leg
    |x - ``source``| - ``lead`` [m]) each element's wave travels towards far-field unit
    ``directions`` (D, 3), elements at ``positions`` (N, 3) [m] fired at ``firing`` (N,) [s]:
    c firing_i + lead - (p_i - source) . u."""
    rel = np.asarray(positions, float) - np.asarray(source, float)
    return speed_of_sound * np.asarray(firing, float) + lead - directions @ rel.T


def _range_side_lobes(envelope: np.ndarray) -> np.ndarray:
    """(L + 1,) |R| at lags 0 .. L [samples] of one echo's matched-filter envelope (N,) (its
    peak at lag 0): normalised to its peak, zero over its main lobe (up to its first minimum),
    up to the last lag L where it exceeds :data:`RANGE_LOBE_FLOOR` (none beyond)."""
    lobes = envelope / envelope[0]
    rising = np.diff(lobes) >= 0
    lobes[: int(np.argmax(rising)) + 1 if rising.any() else len(lobes)] = 0.0
    above = np.flatnonzero(lobes > RANGE_LOBE_FLOOR)
    return lobes[: above[-1] + 1 if len(above) else 1].astype(np.float32)


class ReceiveImager:
    """Receive images of recordings on one band, and their points; built once per sensor and
    reused (grid, steering factors, side-lobe table).

    Args:
        geometry: the arrays (receive layout, field of view).
        band: the recordings' band.
        speed_of_sound: c [m/s].
        detection: the receiver settings used here: ``min_range``, ``blanking_margin`` and
            ``ghost_exclusion`` (the half-angle of the receive main lobe).
        noise_rms: receiver noise per sample [Pa] (as for :class:`EchoProcessor`).
        transmit_centre: (3,) where the transmission leaves from, sensor frame [m].
        guard_half_angle: the grid covers the cone of this half-angle about broadside [rad]
            (the transmission's; it must contain the field of view).
        settings: grid step and detection rule.
        region: (h_min, h_max, v_min, v_max) field-of-view angles [rad] of the directions points
            come from (:func:`~mitsonar.frames.fov_angles`); None: the whole field of view.
        transmit: (positions (N_tx, 3) [m], firing delays (N_tx,) [s], lead [m]) of the
            elements that fire, whose wave is placed from ``transmit_centre`` with the transmit
            leg |x - transmit_centre| - lead; None or one element: a point source there (module
            docstring, rule 2).
    """

    def __init__(self, geometry: ArrayGeometry, band: Band, speed_of_sound: float,
                 detection: DetectionSettings, noise_rms: float, transmit_centre,
                 guard_half_angle: float, settings: ImagingSettings = ImagingSettings(),
                 region: tuple | None = None, transmit: tuple | None = None):
        check_range("guard_half_angle [rad]", guard_half_angle, settings.step, np.radians(89))
        self.geometry = geometry
        self.band = band
        self.c = float(speed_of_sound)
        self.detection = detection
        self.settings = settings
        #: Grid spacing in direction cosines.
        self.spacing = float(np.sin(settings.step))
        count = int(np.floor(np.sin(guard_half_angle) / self.spacing))
        axis = np.arange(-count, count + 1) * self.spacing
        uy, ux = np.meshgrid(axis, axis, indexing="ij")
        #: (n, n) shape of the square grid: rows along u_y, columns along u_x.
        self.shape = ux.shape
        #: (9,) index offsets of a grid direction's 3 x 3 neighbourhood, row by row (u_y, u_x).
        self._around = np.array([dy * ux.shape[1] + dx for dy in (-1, 0, 1) for dx in (-1, 0, 1)])
        disc = np.hypot(ux, uy) <= np.sin(guard_half_angle)
        uz = np.sqrt(np.maximum(1.0 - ux**2 - uy**2, 0.0))
        #: (D, 3) the grid's directions (unit vectors inside the guard disc, zeros outside).
        self.directions = np.where(disc[..., None], np.stack([ux, uy, uz], axis=-1), 0.0
                                   ).reshape(-1, 3)
        #: (D,) directions inside the guard disc, and the field of view's among them.
        self.valid = disc.ravel()
        h, v = geometry.fov_horizontal / 2, geometry.fov_vertical / 2
        #: (h_min, h_max, v_min, v_max) [rad]: the field-of-view angles points come from.
        self.region = (-h, h, -v, v) if region is None else tuple(float(a) for a in region)
        if not (-h - 1e-9 <= self.region[0] < self.region[1] <= h + 1e-9
                and -v - 1e-9 <= self.region[2] < self.region[3] <= v + 1e-9):
            raise ValueError(f"region must be (h_min, h_max, v_min, v_max) [rad] in the field of "
                             f"view, got {region}")
        angle_h, angle_v = fov_angles(np.where(self.valid[:, None], self.directions, BROADSIDE))
        #: (D,) the directions points come from: in the guard disc and the region.
        self.in_fov = self.valid & (self.directions[:, 2] > 0) \
            & (angle_h >= self.region[0] - 1e-9) & (angle_h <= self.region[1] + 1e-9) \
            & (angle_v >= self.region[2] - 1e-9) & (angle_v <= self.region[3] + 1e-9)
        edge = np.zeros(self.shape, bool)
        edge[[0, -1], :] = edge[:, [0, -1]] = True
        if np.any(self.in_fov & edge.ravel()):
            raise ValueError("guard_half_angle must exceed the field of view's half-diagonal")
        self._fov_rows = np.flatnonzero(self.in_fov)
        offsets = geometry.rx_positions - geometry.rx_origin
        # Steering factors of (5) on the band: exp(-j 2 pi f x_j u_x / c) (nb, N_rx, n) and
        # exp(-j 2 pi f y_j u_y / c) (nb, n, N_rx), divided by N_rx.
        f = band.frequencies[:, None, None]
        self._along_x = np.exp(-2j * np.pi * f * offsets[None, :, 0, None] * axis / self.c
                               ).astype(np.complex64) / len(offsets)
        self._along_y = np.exp(-2j * np.pi * f * axis[:, None] * offsets[None, None, :, 1]
                               / self.c).astype(np.complex64)
        processor = EchoProcessor(geometry, band, speed_of_sound, detection, noise_rms)
        self._beamformer = processor.beamformer
        #: RMS of the image of receiver noise alone [Pa].
        self.noise_level = processor.noise_envelope_rms()
        self._filter = processor.matched_filter()[0]
        #: (n, nb) the matched filter in each of the coherence's sub-bands (rule 5), and (n,)
        #: the frequencies [Hz] their channels are demodulated at (their centres; one band: the
        #: band's carrier, as the receiver's looks).
        windows = coherence_windows(band.frequencies, np.abs(band.system_spectrum()[band.bins]),
                                    settings.coherence_bands)
        self._coherence_filters = self._filter * windows
        self._coherence_carriers = np.array([band.carrier]) if len(windows) == 1 else \
            windows @ band.frequencies / windows.sum(axis=1)
        self.threshold = max(settings.detection_snr * self.noise_level, settings.detection_floor)
        if self.threshold <= 0:
            raise ValueError("imaging without receiver noise needs ImagingSettings."
                             "detection_floor > 0")
        # One echo's matched-filter envelope at lags 0 .. N - 1 [samples] (even in the lag):
        # the autocorrelation of the system spectrum, its peak at lag 0.
        echo = np.abs(band.to_analytic(np.abs(band.system_spectrum()[band.bins]) ** 2))
        self.range_resolution, self._range_window = self._resolution(echo)
        #: (F,) half-width [samples] of each field-of-view direction's range-peak window: the
        #: range resolution or, where several elements fire, the spread of their waves' paths
        #: towards it if longer (rule 2; ``_train_lags`` the widest's lags); None: the range
        #: resolution everywhere (one element, or a spread within the resolution everywhere).
        self._train = None
        self._transmit = transmit
        if transmit is not None and len(transmit[0]) > 1:
            spread = np.ptp(excess_paths(*transmit, transmit_centre,
                                         self.directions[self._fov_rows], self.c), axis=1)
            train = np.ceil(spread / self.c * band.sample_rate).astype(int)
            if np.any(train > self._range_window):
                self._train = np.maximum(train, self._range_window)
                self._train_lags = np.arange(-int(self._train.max()), int(self._train.max()) + 1)
        self._range_lobes = _range_side_lobes(echo)
        centre, _ = band.band_moments()
        self._main_lobe = np.sin(detection.ghost_exclusion)
        self._side_lobes, self._lobe = self._lobe_tables(offsets, 2 * np.pi * centre / self.c)
        self._transmit_centre = np.asarray(transmit_centre, dtype=float)
        # Path length of the nearest reported range in each direction [m].
        r = detection.min_range
        self._min_path = r + np.linalg.norm(geometry.rx_origin + r * self.directions
                                            - transmit_centre, axis=1)

    def _resolution(self, envelope: np.ndarray) -> tuple[float, int]:
        """(full width at half maximum of an echo's matched-filter envelope (N,) (its peak at
        lag 0) [s], the same in whole samples, at least 1)."""
        below = int(np.argmax(envelope < 0.5 * envelope[0]))
        a, b = envelope[below - 1], envelope[below]
        half = below - 1 + (a - 0.5 * envelope[0]) / (a - b)  # [samples]
        return 2 * half / self.band.sample_rate, max(1, int(round(2 * half)))

    def _lobe_tables(self, offsets, wavenumber: float):
        """(F, D) |AF| from every grid direction into each field-of-view direction (0 within
        its main lobe), and (F, M) the grid directions within its main lobe (self excluded)."""
        n = self.shape[0]
        step = np.arange(-(n - 1), n) * self.spacing  # every difference of two grid directions
        dy, dx = np.meshgrid(step, step, indexing="ij")
        shift = np.stack([dx, dy, np.zeros_like(dx)], axis=-1)
        pattern = array_factor(offsets, np.zeros(3), shift, wavenumber)  # (2n - 1, 2n - 1)
        distance = np.hypot(dx, dy)
        row, col = np.divmod(self._fov_rows, n)
        grid_row, grid_col = np.divmod(np.arange(n * n), n)
        index = (row[:, None] - grid_row + n - 1, col[:, None] - grid_col + n - 1)
        outside = distance[index] >= self._main_lobe
        side_lobes = np.where(outside & self.valid, pattern[index], 0.0).astype(np.float32)
        inside = ~outside & (distance[index] > 0)
        width = int(inside.sum(axis=1).max())
        nearest = np.argsort(~inside, axis=1, kind="stable")[:, :width]
        return side_lobes, nearest

    def envelopes(self, spectra: np.ndarray) -> np.ndarray:
        """Image (D, n_samples) [Pa], float32: the matched-filtered delay-and-sum envelope
        towards every grid direction (zero outside the guard disc) of channel spectra on the
        band (N_rx, nb) (:meth:`Band.band_spectra <mitsonar.signal.band.Band.band_spectra>` of a
        recording, or a synthesised spectrum)."""
        weighted = spectra.T.astype(np.complex64)[:, :, None] * self._along_x  # (nb, N_rx, n)
        beams = np.matmul(self._along_y, weighted).reshape(len(spectra.T), -1).T  # (D, nb)
        out = np.zeros((len(beams), self.band.n_samples), np.float32)
        rows = np.flatnonzero(self.valid)
        out[rows] = self.band.envelopes(beams[rows], self._filter, batch=DIRECTION_BATCH,
                                        dtype=np.float32)  # bounded inverse FFTs
        return out

    def image(self, recording: Recording) -> tuple[np.ndarray, np.ndarray]:
        """(image (D, N) [Pa], channels (N_rx, N) [Pa]) of a recording (:meth:`envelopes` and
        :meth:`channel_signals` of its spectra)."""
        spectra = self.band.band_spectra(recording.samples)
        return self.envelopes(spectra), self.channel_signals(spectra)

    def channel_signals(self, spectra: np.ndarray) -> np.ndarray:
        """(n, N_rx, N) [Pa], complex64: each receive channel matched-filtered in each of the
        coherence's n sub-bands (``coherence_bands``; n = 1: the whole band) and demodulated at
        the band's carrier (analytic, on the image's scale: one plane wave gives every channel
        the magnitude of its beam), of channel spectra on the band (N_rx, nb)."""
        band = self.band
        channels = band.to_analytic(spectra[None] * self._coherence_filters[:, None],
                                    dtype=np.complex64)
        if len(channels) > 1:  # each sub-band about its centre: read between samples finely
            channels *= band.demodulation(self._coherence_carriers, band.start_time,
                                          band.n_samples)[:, None].astype(np.complex64)
        return channels

    def points(self, image: np.ndarray, channels: np.ndarray, start_time: float,
               direct_image: np.ndarray | None = None) -> ImagePoints:
        """The points of an image (D, N) [Pa] and its channels (N_rx, N) [Pa]
        (:meth:`image`), sample 0 ``start_time`` [s] after the transmission (module docstring);
        ``direct_image`` (D, N): the image of the direct path alone, for blanking."""
        s, fs = self.settings, self.band.sample_rate
        fov = self._fov_rows
        sub = image[fov]
        n = image.shape[1]
        path = self.c * (start_time + np.arange(n) / fs)
        level = self.threshold if direct_image is None \
            else blanking_level(self.threshold, direct_image[fov], self.detection.blanking_margin)
        window = path[None, :] >= self._min_path[fov, None]
        window[:, [0, -1]] = False
        above = (sub > level) & window
        passed = {"threshold": int(above.sum())}
        peaks = sub >= maximum_filter1d(sub, 2 * self._range_window + 1, axis=1, mode="constant")
        row, k = np.nonzero(above & peaks)
        if self._train is not None:
            keep = self._train_peaks(sub, row, k)
            row, k = row[keep], k[keep]
        passed["range_peak"] = len(row)
        value = sub[row, k]
        keep = value >= image[self._lobe[row], k[:, None]].max(axis=1, initial=0.0)
        row, k, value = row[keep], k[keep], value[keep]
        passed["main_lobe_peak"] = len(row)
        keep = value > s.side_lobe_margin * self._side_lobe_levels(image, row, k)
        row, k, value = row[keep], k[keep], value[keep]
        passed["side_lobe"] = len(row)
        keep = value > s.side_lobe_margin * self._range_side_lobe_levels(sub, row, k)
        row, k, value = row[keep], k[keep], value[keep]
        passed["range_side_lobe"] = len(row)
        # RMS over the grid at each instant (rows outside the guard disc are 0), (N,).
        clutter = np.sqrt(np.einsum("dn,dn->n", image, image, dtype=float) / self.valid.sum())
        keep = value > s.clutter_margin * clutter[k]
        row, k, value = row[keep], k[keep], value[keep].astype(float)
        passed["clutter"] = len(row)
        d = fov[row]
        coherence = self.coherence(channels, d, k)
        keep = coherence >= s.min_coherence
        d, k, value, coherence, row = d[keep], k[keep], value[keep], coherence[keep], row[keep]
        passed["trusted"] = len(d)
        offsets = self._coherence_peak_offsets(channels, d, k, coherence) if s.coherence_peak \
            else self._peak_offsets(image, d, k)
        apparent = self.directions[d, :2] + self.spacing * offsets
        sample = k + vertex(image[d, k - 1], value, image[d, k + 1]) if self._train is None \
            else self._train_samples(sub, row, k, apparent)
        length = self.c * (start_time + sample / fs)
        points, arrival = place(self.geometry, length, apparent, self._transmit_centre)
        snr = value / self.noise_level if self.noise_level > 0 else np.full(len(value), np.inf)
        return ImagePoints(points, arrival, length, value, snr, coherence,
                           np.stack([d, k], axis=1), passed)

    def _train_window(self, sub: np.ndarray, row: np.ndarray, k: np.ndarray):
        """(lags (L,) [samples], (P, L) the image's field-of-view rows ``sub`` at rows ``row``,
        samples k + lags, 0 outside each row's range-peak window, +- ``_train[row]``)."""
        lags = self._train_lags
        at = k[:, None] + lags
        inside = (np.abs(lags) <= self._train[row, None]) & (at >= 0) & (at < sub.shape[1])
        return lags, np.where(inside, sub[row[:, None], np.clip(at, 0, sub.shape[1] - 1)], 0)

    def _train_peaks(self, sub: np.ndarray, row: np.ndarray, k: np.ndarray) -> np.ndarray:
        """(P,) whether cells (field-of-view direction ``row``, sample k) of the image's
        field-of-view rows ``sub`` are the largest of their range-peak window."""
        keep = np.ones(len(row), bool)
        for first in range(0, len(row), CANDIDATE_BATCH):  # bounded (batch, lags) gathers
            rows = slice(first, first + CANDIDATE_BATCH)
            near = self._train_window(sub, row[rows], k[rows])[1]
            keep[rows] = sub[row[rows], k[rows]] >= near.max(axis=1)
        return keep

    def _train_samples(self, sub: np.ndarray, row: np.ndarray, k: np.ndarray,
                       apparent: np.ndarray) -> np.ndarray:
        """(P,) fractional samples at which the wave the points are placed with reached them
        (several transmit elements, rule 2): the power centroid of each point's direction
        over its range-peak window about sample k, less the elements' mean excess path towards
        its measured ``apparent`` direction (P, 2) (direction cosines)."""
        lags, near = self._train_window(sub, row, k)
        power = near.astype(float) ** 2
        u = np.column_stack([apparent, np.sqrt(np.maximum(1 - np.sum(apparent**2, axis=1), 0))])
        excess = excess_paths(*self._transmit, self._transmit_centre, u, self.c).mean(axis=1)
        return k + power @ lags / power.sum(axis=1) - excess / self.c * self.band.sample_rate

    def coherence(self, channels: np.ndarray, d: np.ndarray, k: np.ndarray) -> np.ndarray:
        """(P,) share of the channels' power at cells (grid direction d, sample k) that one plane
        wave from d explains (:meth:`Beamformer.coherence
        <mitsonar.signal.beamforming.Beamformer.coherence>` of ``channels`` (n, N_rx, N) from
        :meth:`channel_signals`, the mean over its n sub-bands: 1 for a single arrival; NaN
        where the channels are silent)."""
        count = len(d)
        if not count:
            return np.zeros(0)
        bands = len(channels)  # every (sub-band, cell) a look of its own
        return self._beamformer.coherence(
            channels, np.repeat(np.arange(bands), count),
            np.repeat(self._coherence_carriers, count), np.arange(bands * count),
            np.tile(k.astype(float), bands), np.tile(self.directions[d], (bands, 1))
        ).reshape(bands, count).mean(axis=0)

    def _peak_offsets(self, image: np.ndarray, d: np.ndarray, k: np.ndarray) -> np.ndarray:
        """(P, 2) offsets [grid steps] along u_x and u_y of the main-lobe peaks around grid
        directions d at samples k: the vertex of the quadratic through the log of the image at d
        and its 8 neighbours (exact for a Gaussian lobe, whose axes need not be the grid's), or,
        where that has no maximum within a step, of the parabolas along each axis."""
        near = np.log(np.maximum(image[d[:, None] + self._around, k[:, None]], 1e-30))
        return peak_offsets(near.astype(float).reshape(-1, 3, 3))

    def _coherence_peak_offsets(self, channels: np.ndarray, d: np.ndarray, k: np.ndarray,
                                centre: np.ndarray) -> np.ndarray:
        """(P, 2) offsets [grid steps] of the coherence's peak (:meth:`coherence` of ``channels``;
        ``centre`` (P,) its value at d) around grid directions d at samples k: the vertex of the
        quadratic through its log at d and its 8 neighbours, as :meth:`_peak_offsets` reads the
        image (a neighbour outside the guard disc or where the channels are silent counts as
        1e-6), within one step: d is the image's peak, not always the coherence's, whose vertex
        may lie beyond the neighbours."""
        around = d[:, None] + self._around  # (P, 9)
        ring = np.delete(np.arange(9), 4)  # the 8 neighbours; the centre is known
        near = np.empty(around.shape)
        near[:, 4] = centre
        near[:, ring] = self.coherence(channels, around[:, ring].ravel(),
                                       np.repeat(k, 8)).reshape(-1, 8)
        near = np.where(self.valid[around] & np.isfinite(near), near, 1e-6)
        return np.clip(peak_offsets(np.log(np.maximum(near, 1e-6)).reshape(-1, 3, 3)), -1.0, 1.0)

    def _side_lobe_levels(self, image: np.ndarray, row: np.ndarray, k: np.ndarray) -> np.ndarray:
        """(P,) the largest side-lobe level that a grid direction outside the main lobe of cell
        (field-of-view direction ``row``, sample k) puts into it: max over d0 of
        image(d0, k) |AF(d; d0)|."""
        out = np.zeros(len(row))
        for first in range(0, len(row), CANDIDATE_BATCH):  # bounded (batch, D) products
            rows = slice(first, first + CANDIDATE_BATCH)
            out[rows] = (image[:, k[rows]].T * self._side_lobes[row[rows]]).max(axis=1)
        return out

    def _range_side_lobe_levels(self, sub: np.ndarray, row: np.ndarray,
                                k: np.ndarray) -> np.ndarray:
        """(P,) the largest range side-lobe level that any sample k0 of field-of-view direction
        ``row`` puts into its sample k: max over k0 of sub(row, k0) |R(k - k0)| (``sub``: the
        image's field-of-view rows), k0 within the lobes' extent (:func:`_range_side_lobes`)."""
        out = np.zeros(len(row))
        reach = len(self._range_lobes) - 1
        lags = np.arange(-reach, reach + 1)
        lobes = self._range_lobes[np.abs(lags)]
        n = sub.shape[1]
        for first in range(0, len(row), CANDIDATE_BATCH):  # bounded (batch, 2 L + 1) products
            rows = slice(first, first + CANDIDATE_BATCH)
            at = k[rows, None] + lags
            near = sub[row[rows, None], np.clip(at, 0, n - 1)] * lobes
            out[rows] = np.where((at >= 0) & (at < n), near, 0.0).max(axis=1, initial=0.0)
        return out

    def expected_false_alarms(self, n_samples: int, start_time: float,
                              detection_snr: float | None = None) -> float:
        """Expected number of points per image of receiver noise alone (module docstring): the
        expected Euler characteristic of the excursion set above ``detection_snr`` (default: the
        settings') times the RMS noise envelope, over the region and the listening window
        (from the minimum range to the last of ``n_samples`` samples from ``start_time`` [s])."""
        snr = self.settings.detection_snr if detection_snr is None else detection_snr
        check_positive("detection_snr", snr)
        band, g = self.band, self.geometry
        first = np.mean(self._min_path[self.in_fov]) / self.c - start_time  # [s] from sample 0
        duration = (n_samples - 1) / band.sample_rate - first
        h0, h1, v0, v1 = np.tan(self.region)
        corners = np.array([(h0, v0), (h1, v0), (h1, v1), (h0, v1), (h0, v0)])
        steps = np.linspace(0.0, 1.0, 256, endpoint=False)[:, None, None]
        outline = (corners[:-1] + steps * (corners[1:] - corners[:-1])).transpose(1, 0, 2)
        outline = outline.reshape(-1, 2)  # tangents of the angles, around the field of view
        u = outline / np.sqrt(1.0 + np.sum(outline**2, axis=1, keepdims=True))
        return expected_blobs(snr, u, duration, band, g.rx_positions, self.c)
