"""Helpers shared by the tests: repository paths and common poses (scene XML pieces are in
``mitsonar.scene.xml``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import mitsonar

#: The repository's root, and its shipped scenes.
ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "scenes"

#: The sensor sits at the world origin looking along +z (world frame = sensor frame).
IDENTITY = mitsonar.Pose.identity()
BROADSIDE = np.array([0.0, 0.0, 1.0])


# ---- MCAP recordings (tests/data/test_*mcap*.py, tests/cli/test_scenes_mcap_cli.py) ----
def read_mcap(path) -> list:
    """(topic, log time [ns], decoded message) of every message of an MCAP file, in time order."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        return [(channel.topic, message.log_time, decoded)
                for _, channel, message, decoded in reader.iter_decoded_messages()]


def ros_pose(p) -> mitsonar.Pose:
    """Pose of a decoded geometry_msgs Pose or Transform."""
    from scipy.spatial.transform import Rotation

    t = getattr(p, "position", None) or p.translation
    q = getattr(p, "orientation", None) or p.rotation
    return mitsonar.Pose(Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix(), [t.x, t.y, t.z])


def tf_tree(read, ns) -> dict:
    """child -> (parent, parent_from_child) of /tf_static and the /tf messages at ``ns``."""
    tree = {}
    for topic, time, m in read:
        if topic == "/tf_static" or (topic == "/tf" and time == ns):
            for tf in m.transforms:
                tree[tf.child_frame_id] = (tf.header.frame_id, ros_pose(tf.transform))
    return tree


def world_from(tree, frame) -> mitsonar.Pose:
    """World-from-``frame`` pose through a :func:`tf_tree`."""
    pose = mitsonar.Pose.identity()
    while frame != "world":
        frame, parent_from_child = tree[frame]
        pose = parent_from_child @ pose
    return pose


# ---- Receiver noise alone (tests/signal/test_echoes.py, tests/signal/test_cone_image.py) ----
def noise_beams(receiver, config, count: int = 117):
    """(``count`` seeded recordings of ``config``'s receiver noise alone on ``receiver``'s band,
    one per beam; the beams' directions, the 5 deg grid; the listening window [s] from the
    minimum range to the recording's end, to a few samples), for false-alarm counts."""
    from mitsonar.signal.synthesis import EchoSynthesizer

    band = receiver.band
    synth = EchoSynthesizer(band)
    noise = [synth.recording(np.zeros((config.geometry.rx.count, band.n_samples)),
                             config.noise_rms, seed=[11, b]) for b in range(count)]
    window = band.n_samples / band.sample_rate + band.start_time \
        - 2 * receiver.settings.min_range / receiver.c
    return noise, config.geometry.fov_grid(np.radians(5.0)), window


# ---- A plane tilted 45 deg across the broadside beam (tests/signal/test_echoes.py, ...) ----
#: Its tilt about y [rad], unit normal, and distance along the beam [m].
TILT = np.radians(45.0)
TILT_NORMAL = np.array([np.sin(TILT), 0.0, np.cos(TILT)])
TILT_DISTANCE = 1.5


def tilted_plane(scene_file):
    """The scene of a 3 m concrete square tilted ``TILT`` about y, ``TILT_DISTANCE`` along the
    broadside beam (``scene_file``: the conftest fixture)."""
    from mitsonar.scene.xml import material_xml, rectangle_xml

    return scene_file("tilted", material_xml("w", preset="concrete"),
                      rectangle_xml("w", (0, 0, TILT_DISTANCE), (0, 45, 0), size=(3.0, 3.0)))


def tilted_footprint(config, level: float = 2 ** -0.5) -> np.ndarray:
    """(2,) ends [m] along the tilt, on the plane z = d - x, of the broadside transmit beam's
    footprint at ``level`` of its peak (amplitude; default -3 dB) at the pulse's frequency."""
    from mitsonar.frames import direction_from_fov_angles
    from mitsonar.physics.beampattern import main_lobe_width, one_way_pattern

    g, k = config.geometry, 2 * np.pi * config.pulse.frequency / config.medium.speed_of_sound
    angles = np.radians(np.linspace(-10.0, 10.0, 2001))
    half = main_lobe_width(angles, one_way_pattern(
        g.tx_positions, BROADSIDE, direction_from_fov_angles(angles, 0.0 * angles),
        config.transducer, k), level) / 2
    side = np.sin([-half, half])
    return TILT_DISTANCE * side / (side + np.cos(half)) / np.cos(TILT)


#: Half the edge of ``side_plate``'s square plate [m].
SIDE_PLATE_HALF = 0.4


def side_plate(scene_file):
    """The scene of a smooth 80 cm square metal plate facing the sensor 1.5 m away, 20 deg to
    the side (it spans 5-35 deg; ``scene_file``: the conftest fixture)."""
    from mitsonar.frames import direction_from_fov_angles
    from mitsonar.scene.xml import material_xml, spanned_rectangle_xml

    centre = 1.5 * direction_from_fov_angles(np.radians(20.0), 0.0)
    normal = -centre / np.linalg.norm(centre)
    across = np.cross([0.0, 1.0, 0.0], normal)
    return scene_file("plate", material_xml("m", preset="metal", scattering=0.0),
                      spanned_rectangle_xml("m", centre, across, np.cross(normal, across),
                                            (SIDE_PLATE_HALF, SIDE_PLATE_HALF)))


# ---- Analytic echoes of point reflectors (tests/signal/test_echoes.py, test_crosstalk.py) ----
def reflector_spectra(band, config, reflectors, gains, waveforms, offsets) -> np.ndarray:
    """(B, N_rx, nb) analytic spectra on ``band`` of ``config``'s receive array: beam b's
    ``reflectors`` (P, 3) [m] with path gains ``gains[b]`` (P,) [Pa], driven by
    ``waveforms[b]`` fired at ``offsets[b]`` [s] (exact delays, transmit origin to each receive
    element)."""
    g, c = config.geometry, config.medium.speed_of_sound
    delay = (np.linalg.norm(reflectors, axis=1)[:, None]
             + np.linalg.norm(reflectors[:, None] - g.rx_positions[None], axis=-1)) / c
    delay = delay[None, ..., None] + np.reshape(offsets, (-1, 1, 1, 1)) - band.start_time
    shift = np.exp(-2j * np.pi * band.frequencies * delay)
    echo = np.stack([band.system_spectrum(w)[band.bins] for w in waveforms])
    return np.einsum("bp,bpjf->bjf", gains, shift) * echo[:, None, :]


def receiver(config, settings, codes=()):
    """An :class:`~mitsonar.signal.receiver.EchoProcessor` of ``config`` with detection
    ``settings``, on the band of a scan's recordings, or of an OFDM cycle's when ``codes`` are
    given (their parts' matched filters too)."""
    from mitsonar.sensors.sonar import PRE_ROLL
    from mitsonar.signal.band import Band
    from mitsonar.signal.receiver import EchoProcessor

    waveforms = tuple(codes) + tuple(t for c in codes for t in c.parts)
    duration = PRE_ROLL + len(codes) * codes[0].slot + 30e-3 if codes else config.record_duration
    band = Band(config.pulse, config.transducer, config.sample_rate, -PRE_ROLL, duration,
                config.transducer_response, floor=config.band_floor, baseband=config.baseband,
                waveforms=waveforms)
    return EchoProcessor(config.geometry, band, config.medium.speed_of_sound, settings,
                         config.noise_rms)
