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

Rays are traced over a cone of ``cone_half_angle`` (60 deg: the field of view's 34 deg
half-diagonal plus the directions whose echoes reach it through the receive side lobes), with
cells of equal angle (``TraceSettings.ray_density='uniform'``); the paper's point-reflector model
takes its reflectors 1.25 deg apart over the same cone.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from mitsonar.frames import Pose
from mitsonar.sensors.sonar import Sonar
from mitsonar.signal.imaging import ImagePoints, ImagingSettings, ReceiveImager
from mitsonar.trace.tracer import AcousticTracer, TraceSettings
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
        transmit: 'element' (the transmit element nearest the transmit origin) or 'array' (every
            transmit element, unsteered).
        cone_half_angle: half-angle of the traced cone around broadside [rad].
        rays_per_axis: rays per axis of the traced grid (physical model; the paper model places
            its reflectors ``paper_spacing`` apart instead).
    """

    transmit: str = "element"
    cone_half_angle: float = np.radians(60.0)
    rays_per_axis: int = 128

    def __post_init__(self):
        if self.transmit not in ("element", "array"):
            raise ValueError(f"TransmitSettings.transmit must be 'element' or 'array', "
                             f"got {self.transmit!r}")
        check_range("TransmitSettings.cone_half_angle [rad]", self.cone_half_angle, 1e-3,
                    np.radians(80))
        if int(self.rays_per_axis) != self.rays_per_axis or self.rays_per_axis < 4:
            raise ValueError(f"TransmitSettings.rays_per_axis must be an integer >= 4, "
                             f"got {self.rays_per_axis}")

    def weights(self, tx_positions: np.ndarray) -> np.ndarray:
        """(N_tx,) amplitude weights of the transmit elements at ``tx_positions`` (N_tx, 3) [m]."""
        if self.transmit == "array":
            return np.ones(len(tx_positions))
        weights = np.zeros(len(tx_positions))
        weights[np.argmin(np.linalg.norm(tx_positions, axis=1))] = 1.0
        return weights

    def trace_settings(self, trace: TraceSettings, weights: np.ndarray) -> TraceSettings:
        """``trace`` changed for this transmission: its cone, uniform rays (refined wherever
        the cone reaches) or, for the paper model, point reflectors over the cone."""
        if trace.model == "paper":
            count = int(np.ceil(np.tan(self.cone_half_angle) / np.tan(trace.paper_spacing)))
            return replace(trace, paper_grid=2 * count + 1, transmit_weights=tuple(weights))
        return replace(trace, cone_half_angle=self.cone_half_angle, ray_density="uniform",
                       rays_per_axis=self.rays_per_axis, refine_radius=self.cone_half_angle,
                       transmit_weights=tuple(weights))


@dataclass(frozen=True)
class Image:
    """One single-ping image: its P points and, if kept, the image itself.

    Attributes:
        pose: world-from-sensor pose of the ping.
        points_sensor: (P, 3) reflectors in the sensor frame [m].
        direction: (P, 3) unit arrival directions, sensor frame (from the receive origin).
        amplitude: (P,) image value at each point [Pa].
        snr: (P,) amplitude over the RMS noise envelope.
        coherence: (P,) share of the channels' power one plane wave from each point's direction
            explains (the trust criterion, :class:`~mitsonar.signal.imaging.ImagingSettings`
            ``min_coherence``).
        passed: cells of the field of view passing each rule in turn
            (:class:`~mitsonar.signal.imaging.ImagePoints`).
        directions: (D, 3) the receive directions of the grid over the transmitted cone
            (:class:`~mitsonar.signal.imaging.ReceiveImager`; zeros in its corners).
        envelopes: (D, N) the image [Pa] (None unless asked for).
        times: (N,) times of its samples after the transmission [s].
    """

    pose: Pose
    points_sensor: np.ndarray
    direction: np.ndarray
    amplitude: np.ndarray
    snr: np.ndarray
    coherence: np.ndarray
    passed: dict
    directions: np.ndarray
    envelopes: np.ndarray | None
    times: np.ndarray

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
        settings: the receive grid and detection rule.
        transmit: the transmission and its trace.
    """

    def __init__(self, sonar: Sonar, settings: ImagingSettings = ImagingSettings(),
                 transmit: TransmitSettings = TransmitSettings()):
        self.sonar = sonar
        self.transmit = transmit
        cfg = sonar.config
        g = cfg.geometry
        half_diagonal = np.arctan(np.hypot(np.tan(g.fov_horizontal / 2),
                                           np.tan(g.fov_vertical / 2)))
        if transmit.cone_half_angle <= half_diagonal:
            raise ValueError(f"TransmitSettings.cone_half_angle must exceed the field of view's "
                             f"half-diagonal ({np.degrees(half_diagonal):.1f} deg)")
        weights = transmit.weights(g.tx_positions)
        self.tracer = AcousticTracer(sonar.scene, g, cfg.transducer, cfg.medium, cfg.pulse,
                                     transmit.trace_settings(cfg.trace, weights))
        centre = np.abs(weights) @ g.tx_positions / np.sum(np.abs(weights))
        self.imager = ReceiveImager(g, sonar.band, cfg.medium.speed_of_sound, cfg.detection,
                                    cfg.noise_rms, centre, transmit.cone_half_angle, settings)
        # The direct path is the same in every image: its spectrum and image (blanking) once.
        self._direct_spectrum = sonar.synthesizer.group_spectrum(
            self.tracer.direct_paths(BROADSIDE), None, g.rx.count)
        self.direct_image = self.imager.envelopes(self._direct_spectrum)

    @property
    def cycle_time(self) -> float:
        """Time one image takes the sensor: the listening cycle, ``record_duration`` [s]."""
        return self.sonar.config.record_duration

    def image(self, pose: Pose, seed: int = 0, keep_envelopes: bool = False) -> Image:
        """Transmit once from ``pose`` (world-from-sensor) and image the recording.

        Args:
            pose: the sensor's pose.
            seed: seeds the diffuse phases and the receiver noise (same seed, same image).
            keep_envelopes: keep the image itself (D x N values) in :attr:`Image.envelopes`.
        """
        sonar, cfg = self.sonar, self.sonar.config
        paths = self.tracer.trace(pose, BROADSIDE, seed=seed).paths
        n_rx = cfg.geometry.rx.count
        spectrum = self._direct_spectrum.copy()
        hits = max(1, PATH_BATCH // (paths.elements[0] * n_rx))
        for first in range(0, len(paths.tx_delay), hits):  # bounded batches of element pairs
            part = paths.select(slice(first, first + hits))
            spectrum += sonar.synthesizer.groups_spectrum(sonar.echo_groups(part, cfg.pulse), n_rx)
        recording = sonar.synthesizer.recording(sonar.band.to_samples(spectrum), cfg.noise_rms,
                                                seed=[seed, 1])
        envelopes, channels = self.imager.image(recording)
        found: ImagePoints = self.imager.points(envelopes, channels, recording.start_time,
                                                self.direct_image)
        return Image(pose, found.points, found.direction, found.amplitude, found.snr,
                     found.coherence, found.passed, self.imager.directions,
                     envelopes if keep_envelopes else None, recording.times)
