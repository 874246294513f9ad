"""Single-ping receive imaging, a scanning strategy beside the sequential scan and OFDM.

    import mitsonar
    sonar = mitsonar.Sonar("scenes/room_glass/scene.xml")
    imaging = mitsonar.ImagingSonar(sonar)
    image = imaging.image(mitsonar.Pose.sensor_on_robot(x=0.0, y=0.0, yaw=0.0), seed=0)
    image.points_world                                # (P, 3), every point of one ping

Each image is one listening cycle: one wide transmission, then the recording
(``SonarConfig.record_duration``, 34.0 ms by default, 30.4 ms with the ``paper`` preset), from
which the receive array forms beams towards a grid over the whole field of view
(:mod:`mitsonar.signal.imaging`). The sequential scan and an OFDM frame instead steer the
transmit array to one direction at a time (5 cycles, 208.5 ms for 117 directions).

Transmission (``TransmitSettings.transmit``):

* ``'element'`` (default): the transmit element nearest the transmit origin alone, as RTIS
  does. Its piston beam lights the field of view smoothly (half amplitude at 42.5 deg), so
  nothing in the field of view sits in an illumination null; the price is the transmit gain:
  the steered array's 25 elements add coherently on its beam, 28 dB more than one element.
* ``'array'``: all 25 elements at once, unsteered (no firing delays). On broadside the array
  adds coherently (25x); elsewhere its elements add with the phases of the sparse layout's
  array factor, a speckle-like pattern of lobes and nulls over the field of view (its side
  lobes, about 5x one element's amplitude on average): more energy, uneven illumination.
* ``'sectors'``: every element, one sector of the field of view per ping: the array steered to
  the sector's centre and defocused (each element fires when a spherical wave from a virtual
  source ``virtual_source`` behind the transmit origin, on the sector's axis, would reach it),
  so its beam widens from 4.6 deg to about the sector. The field of view is tiled by
  ``sectors`` (3 x 2: 20 x 20 deg each); a frame is one ping per sector, one listening cycle
  each. Fewer surfaces return echoes at any instant than under one element's beam, so more of
  the cells pass the coherence rule (docs/imaging.md). One sector (:data:`DEFOCUSED`) is the
  whole array defocused over the whole field of view: 14 dB more than one element there.

Rays are traced over a cone of ``cone_half_angle`` (60 deg: the field of view's 34 deg
half-diagonal plus the directions whose echoes reach it through the receive side lobes), with
cells of equal angle (``TraceSettings.ray_density='uniform'``); the paper's point-reflector model
takes its reflectors 1.25 deg apart over the same cone.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from mitsonar.frames import Pose, direction_from_fov_angles
from mitsonar.sensors.sonar import Scan, Sonar
from mitsonar.signal.band import Recording
from mitsonar.signal.detection import Echoes
from mitsonar.signal.imaging import ReceiveImager
from mitsonar.signal.imaging_settings import ImagePoints, ImagingSettings, imaging_settings_for
from mitsonar.trace.settings import TraceSettings
from mitsonar.trace.tracer import AcousticTracer
from mitsonar.validation import check_range

#: The axis of the traced cone: the array's normal, towards which no element has a firing delay.
BROADSIDE = np.array([0.0, 0.0, 1.0])
#: Element-pair paths synthesised together (bounds memory where every pair is synthesised: the
#: whole array transmitting, broadband transducers).
PATH_BATCH = 2**21


@dataclass(frozen=True)
class TransmitSettings:
    """The wide transmission of an image and how it is traced.

    Attributes:
        transmit: 'element' (the transmit element nearest the transmit origin), 'array' (every
            transmit element, unsteered) or 'sectors' (every element, steered and defocused to
            one sector of the field of view per ping).
        cone_half_angle: half-angle of the traced cone around broadside [rad].
        rays_per_axis: rays per axis of the traced grid (physical model; the paper model places
            its reflectors ``paper_spacing`` apart instead).
        sectors: sectors across the field of view, horizontally and vertically ('sectors').
        virtual_source: distance [m] behind the transmit origin, on a sector's axis, of the
            point the defocused wave diverges from ('sectors'; the beam's width is about the
            aperture over it: 10 cm / 0.3 m, 19 deg).
    """

    transmit: str = "element"
    cone_half_angle: float = np.radians(60.0)
    rays_per_axis: int = 128
    sectors: tuple = (3, 2)
    virtual_source: float = 0.3

    def __post_init__(self):
        if self.transmit not in ("element", "array", "sectors"):
            raise ValueError(f"TransmitSettings.transmit must be 'element', 'array' or "
                             f"'sectors', got {self.transmit!r}")
        if len(self.sectors) != 2 or any(int(n) != n or n < 1 for n in self.sectors):
            raise ValueError(f"TransmitSettings.sectors must be two integers >= 1, "
                             f"got {self.sectors}")
        check_range("TransmitSettings.virtual_source [m]", self.virtual_source, 1e-3, 1e3)
        check_range("TransmitSettings.cone_half_angle [rad]", self.cone_half_angle, 1e-3,
                    np.radians(80))
        if int(self.rays_per_axis) != self.rays_per_axis or self.rays_per_axis < 4:
            raise ValueError(f"TransmitSettings.rays_per_axis must be an integer >= 4, "
                             f"got {self.rays_per_axis}")

    def weights(self, tx_positions: np.ndarray) -> np.ndarray:
        """(N_tx,) amplitude weights of the transmit elements at ``tx_positions`` (N_tx, 3) [m]."""
        if self.transmit != "element":
            return np.ones(len(tx_positions))
        weights = np.zeros(len(tx_positions))
        weights[np.argmin(np.linalg.norm(tx_positions, axis=1))] = 1.0
        return weights

    def emissions(self, geometry, speed_of_sound: float) -> list["Emission"]:
        """The emission of each ping of a frame: one from the transmitting elements' centre
        unless 'sectors'; then ping s (a ``sectors`` tiling of the field of view, row by row, a_s
        the centre of its sector) fires element i at (|p_i - v_s| - d_s) / c, the time a
        spherical wave from v_s = -``virtual_source`` a_s would reach it (d_s: the distance from
        v_s to the nearest element, which fires at 0); its points come from its sector only
        (beyond it, lit by the defocused array's side lobes, echoes do not keep that timing)."""
        weights = self.weights(geometry.tx_positions)
        if self.transmit != "sectors":
            centre = np.abs(weights) @ geometry.tx_positions / np.sum(np.abs(weights))
            return [Emission(centre, np.zeros(len(weights)), 0.0)]
        n_h, n_v = self.sectors
        h = geometry.fov_horizontal * (np.arange(n_h + 1) / n_h - 0.5)  # sector edges [rad]
        v = geometry.fov_vertical * (np.arange(n_v + 1) / n_v - 0.5)
        out = []
        for j in range(n_v):  # a few sectors
            for i in range(n_h):
                axis = direction_from_fov_angles(0.5 * (h[i] + h[i + 1]), 0.5 * (v[j] + v[j + 1]))
                source = -self.virtual_source * axis  # the transmit origin is the sensor's
                distance = np.linalg.norm(geometry.tx_positions - source, axis=1)
                out.append(Emission(source, (distance - distance.min()) / speed_of_sound,
                                    float(distance.min()), (h[i], h[i + 1], v[j], v[j + 1])))
        return out

    def trace_settings(self, trace: TraceSettings, weights: np.ndarray) -> TraceSettings:
        """``trace`` changed for this transmission: its cone, uniform rays (refined wherever
        the cone reaches) or, for the paper model, point reflectors over the cone."""
        if trace.model == "paper":
            count = int(np.ceil(np.tan(self.cone_half_angle) / np.tan(trace.paper_spacing)))
            return replace(trace, paper_grid=2 * count + 1, transmit_weights=tuple(weights))
        return replace(trace, cone_half_angle=self.cone_half_angle, ray_density="uniform",
                       rays_per_axis=self.rays_per_axis, refine_radius=self.cone_half_angle,
                       transmit_weights=tuple(weights))


#: Every element in one ping, defocused over the whole field of view from a virtual source 0.1 m
#: behind the array: the most even of 0.05-0.3 m over the 60 x 40 deg field of view behind a
#: 20-80 kHz sweep (9.5-18.6 dB over one element, 14.3 dB on average: the 25 elements' power;
#: docs/imaging.md, "Transmission").
DEFOCUSED = TransmitSettings(transmit="sectors", sectors=(1, 1), virtual_source=0.1)
#: The transmissions a user picks by name (``mitsonar map repeated --transmit``).
TRANSMISSIONS = {"element": TransmitSettings(), "defocused": DEFOCUSED}


@dataclass(frozen=True)
class Emission:
    """One ping's transmission: its wave leaves ``source`` as if from one point.

    Attributes:
        source: (3,) where the wave diverges from, sensor frame [m] (behind the array for
            'sectors').
        firing: (N_tx,) firing delay of each transmit element [s].
        lead: the wave's path from ``source`` to where it is at time 0 [m]: the transmit leg of
            an echo from x is |x - source| - lead.
        region: (h_min, h_max, v_min, v_max) field-of-view angles [rad] of the directions the
            ping reports points from, where it lights the scene as the emission says (its
            sector); None: the whole field of view.
    """

    source: np.ndarray
    firing: np.ndarray
    lead: float
    region: tuple | None = None


@dataclass(frozen=True)
class Image:
    """One single-ping image: its P points and, if kept, the image itself.

    Attributes:
        pose: world-from-sensor pose of the ping.
        points_sensor: (P, 3) reflectors in the sensor frame [m].
        direction: (P, 3) unit arrival directions, sensor frame (from the receive origin).
        path_length: (P,) the emission's source -> reflector -> receive origin [m].
        amplitude: (P,) image value at each point [Pa].
        snr: (P,) amplitude over the RMS noise envelope.
        coherence: (P,) share of the channels' power one plane wave from each point's direction
            explains (the trust criterion,
            :class:`~mitsonar.signal.imaging_settings.ImagingSettings` ``min_coherence``).
        passed: cells of the field of view passing each rule in turn
            (:class:`~mitsonar.signal.imaging_settings.ImagePoints`).
        directions: (D, 3) the receive directions of the grid over the transmitted cone
            (:class:`~mitsonar.signal.imaging.ReceiveImager`; zeros in its corners).
        envelopes: (D, N) the image [Pa] (None unless asked for).
        times: (N,) times of its samples after the transmission [s].
        recording: the per-channel recording it was formed from (None unless asked for).
    """

    pose: Pose
    points_sensor: np.ndarray
    direction: np.ndarray
    path_length: np.ndarray
    amplitude: np.ndarray
    snr: np.ndarray
    coherence: np.ndarray
    passed: dict
    directions: np.ndarray
    envelopes: np.ndarray | None
    times: np.ndarray
    recording: Recording | None = None

    @property
    def points_world(self) -> np.ndarray:
        """(P, 3) the points in the world frame, equation (12)."""
        return self.pose.transform_points(self.points_sensor)

    def __len__(self) -> int:
        return len(self.points_sensor)


class ImagingSonar:
    """Single-ping receive images with a :class:`~mitsonar.sensors.sonar.Sonar`'s scene,
    configuration, band and synthesizer (module docstring).

    Args:
        sonar: the scene and sensor configuration.
        settings: the receive grid and detection rule; None: the rule for the sonar's drive
            (:func:`~mitsonar.signal.imaging_settings.imaging_settings_for`: the trust rule read
            in sub-bands for a sweep over an octave, as 20-80 kHz; else ``ImagingSettings()``).
        transmit: the transmission and its trace.
    """

    def __init__(self, sonar: Sonar, settings: ImagingSettings | None = None,
                 transmit: TransmitSettings = TransmitSettings()):
        self.sonar = sonar
        self.transmit = transmit
        cfg = sonar.config
        if settings is None:
            settings = imaging_settings_for(cfg.pulse)
        g = cfg.geometry
        half_diagonal = g.fov_half_diagonal
        if transmit.cone_half_angle <= half_diagonal:
            raise ValueError(f"TransmitSettings.cone_half_angle must exceed the field of view's "
                             f"half-diagonal ({np.degrees(half_diagonal):.1f} deg)")
        weights = transmit.weights(g.tx_positions)
        self.tracer = AcousticTracer(sonar.scene, g, cfg.transducer, cfg.medium, cfg.pulse,
                                     cfg.resolved_trace(transmit.trace_settings(cfg.trace, weights),
                                                        transmit.cone_half_angle))
        self._transmitting = weights != 0  # the elements the traced paths keep
        #: The emission of each ping of a frame (one unless 'sectors').
        self.emissions = transmit.emissions(g, cfg.medium.speed_of_sound)
        self.imagers = [ReceiveImager(g, sonar.band, cfg.medium.speed_of_sound, cfg.detection,
                                      cfg.noise_rms, e.source, transmit.cone_half_angle, settings,
                                      e.region, (g.tx_positions[self._transmitting],
                                                 e.firing[self._transmitting], e.lead))
                        for e in self.emissions]
        self.imager = self.imagers[0]
        # The direct path is the same in every frame: its spectrum per ping once, and for
        # blanking the largest of their images.
        direct = self.tracer.direct_paths(BROADSIDE)
        n_rx = g.rx.count
        self._direct_spectra = [sonar.synthesizer.group_spectrum(
            direct.delayed(np.repeat(e.firing[self._transmitting], n_rx)), None, n_rx)
            for e in self.emissions]
        self.direct_image = np.max([self.imager.envelopes(d) for d in self._direct_spectra],
                                   axis=0)

    @property
    def cycle_time(self) -> float:
        """Time one image takes the sensor: the listening cycle, ``record_duration`` [s]."""
        return self.sonar.config.record_duration

    @property
    def pings_per_frame(self) -> int:
        """Pings of a frame, one per listening cycle: one per sector ('sectors'), else one."""
        return len(self.emissions)

    def image(self, pose: Pose, seed: int = 0, keep_envelopes: bool = False,
              ping: int = 0, keep_recording: bool = False) -> Image:
        """Transmit once from ``pose`` (world-from-sensor) and image the recording.

        Args:
            pose: the sensor's pose.
            seed: seeds the diffuse phases and the receiver noise (same seed, same image).
            keep_envelopes: keep the image itself (D x N values) in :attr:`Image.envelopes`.
            ping: which ping of a frame (its sector with 'sectors'), in [0, pings_per_frame).
            keep_recording: keep the per-channel recording in :attr:`Image.recording`.
        """
        if not (int(ping) == ping and 0 <= ping < self.pings_per_frame):
            raise ValueError(f"ping must be an integer in [0, {self.pings_per_frame}), got {ping}")
        sonar, cfg = self.sonar, self.sonar.config
        paths = self.tracer.trace(pose, BROADSIDE, seed=seed).paths
        emission, imager = self.emissions[ping], self.imagers[ping]
        paths = paths.delayed(emission.firing[self._transmitting])
        n_rx = cfg.geometry.rx.count
        spectrum = self._direct_spectra[ping].copy()
        hits = max(1, PATH_BATCH // (paths.elements[0] * n_rx))
        for first in range(0, paths.patches, hits):  # bounded batches of element pairs
            part = paths.select(slice(first, first + hits))
            spectrum += sonar.synthesizer.groups_spectrum(sonar.echo_groups(part, cfg.pulse), n_rx)
        recording = sonar.synthesizer.recording(sonar.band.to_samples(spectrum), cfg.noise_rms,
                                                seed=[seed, 1])
        envelopes, channels = imager.image(recording)
        # Sample 0 lies lead / c later on the wave from the emission's source.
        found: ImagePoints = imager.points(envelopes, channels, recording.start_time
                                           + emission.lead / cfg.medium.speed_of_sound,
                                           self.direct_image)
        return Image(pose, found.points, found.direction, found.path_length, found.amplitude,
                     found.snr, found.coherence, found.passed, imager.directions,
                     envelopes if keep_envelopes else None, recording.times,
                     recording if keep_recording else None)

    def echo_table(self, image: Image, ping: int = 0) -> Echoes:
        """The points of ``image`` (of ping ``ping``) as an echo table of one transmission
        (beam 0), strongest first: every point a peak with its arrival direction, time of
        arrival (path length / c from the emission) and depth (its distance from the
        emission's source)."""
        order = np.argsort(-image.amplitude, kind="stable")
        count = len(order)
        points = image.points_sensor[order]
        return Echoes(np.zeros(count, int), np.arange(count), np.ones(count, bool),
                      image.amplitude[order], image.snr[order],
                      image.path_length[order] / self.sonar.config.medium.speed_of_sound,
                      image.path_length[order],
                      np.linalg.norm(points - self.emissions[ping].source, axis=1), points,
                      image.direction[order], image.coherence[order], np.zeros(count, bool))

    def scan(self, pose: Pose, seed: int = 0, ping: int = 0) -> Scan:
        """One image (:meth:`image`) as a :class:`~mitsonar.sensors.sonar.Scan` of one
        transmission, the format of ``mitsonar scan``'s and datasets' ``echoes.npz``: its
        recording as the beam's echoes (1, N_rx, N), its points as the echo table
        (:meth:`echo_table`), the strongest as the beam's detection, the direction of the
        emission's axis (broadside, or its sector's centre) as the beam's."""
        image = self.image(pose, seed=seed, ping=ping, keep_recording=True)
        table = self.echo_table(image, ping)
        found = len(table.beam) > 0
        region = self.emissions[ping].region
        axis = BROADSIDE if region is None else direction_from_fov_angles(
            0.5 * (region[0] + region[1]), 0.5 * (region[2] + region[3]))
        rec = image.recording
        return Scan(pose, np.reshape(axis, (1, 3)), np.array([found]),
                    np.array([table.depth[0] if found else np.nan]),
                    np.array([table.amplitude[0] if found else 0.0]),
                    table.point[:1] if found else np.full((1, 3), np.nan), table,
                    rec.samples[None].astype(np.complex64 if rec.carrier else np.float32),
                    rec.sample_rate, rec.start_time, rec.carrier)
