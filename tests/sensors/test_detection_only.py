"""The detection-only path of OFDM frames (``OfdmSonar.frame(..., channels=False)``): decoded
from the channels' spectra on the band with the receiver noise drawn there, against the
per-channel path (recordings, time-domain noise, channel transforms) on the same frames."""

import numpy as np
import pytest

import mitsonar
from mitsonar.frames import direction_from_fov_angles
from mitsonar.scene.xml import material_xml, rectangle_xml, sphere_xml, write_scene
from mitsonar.sensors.ofdm_sonar import OfdmSonar

#: Broadband transducers (20 kHz at -6 dB), so that every OFDM code gets through.
BROADBAND = mitsonar.Transducer(bandwidth_6db=20e3)


@pytest.fixture(scope="module")
def sphere_and_walls(tmp_path_factory):
    """A metal sphere of 3 cm 1.4 m ahead before a rough concrete wall 2.2 m ahead and a smooth
    side wall tilted towards the sensor (its specular return reaches beams through side lobes);
    five beams, one on the sphere."""
    path = write_scene(tmp_path_factory.mktemp("detection_only") / "scene.xml",
                       material_xml("t", preset="metal", scattering=0.0),
                       material_xml("w", preset="concrete", scattering=0.6),
                       sphere_xml("t", 1.4 * direction_from_fov_angles(np.radians(1.5), 0.0), 0.03),
                       rectangle_xml("w", (0, 0, 2.2), size=(8.0, 8.0)),
                       rectangle_xml("t", (1.2, 0, 1.5), euler_deg=(0, -105, 0),
                                     size=(3.0, 3.0)))
    directions = direction_from_fov_angles(np.radians([0.0, -10.0, 10.0, 0.0, 20.0]),
                                           np.radians([0.0, 0.0, 5.0, -10.0, 0.0]))
    return path, directions


def _frames(path, directions, mode, noise_rms, seed=1, shared_hits=False):
    """The frame on both paths; each beam traced in its own cone unless ``shared_hits``."""
    sonar = mitsonar.Sonar(path, mitsonar.SonarConfig(
        transducer=BROADBAND, noise_rms=noise_rms,
        detection=mitsonar.DetectionSettings(echoes=mode)))
    ofdm = OfdmSonar(sonar, shared_hits=shared_hits)
    schedule = ofdm.schedule(directions)
    pose_at = lambda t: mitsonar.Pose(np.eye(3), [0.0, 0.0, 0.5 * t])  # noqa: E731
    return (ofdm.frame(schedule, pose_at, seed=seed, channels=channels)
            for channels in (True, False))


def _assert_same_decisions(per_channel, detection_only, tolerance):
    """Same detections on every beam, the same echoes (beam by beam) in the echo tables, depths
    within ``tolerance`` [m]."""
    np.testing.assert_array_equal(detection_only.detected, per_channel.detected)
    np.testing.assert_allclose(detection_only.depth, per_channel.depth, rtol=0, atol=tolerance)
    a, b = per_channel.echo_table, detection_only.echo_table
    np.testing.assert_array_equal(b.beam, a.beam)
    np.testing.assert_array_equal(b.peak, a.peak)
    np.testing.assert_allclose(b.depth, a.depth, rtol=0, atol=tolerance)


@pytest.mark.parametrize("shared_hits", [False, True])
@pytest.mark.parametrize("mode", ["first", "all", "cells"])
def test_noiseless_frames_decide_the_same_on_both_paths(sphere_and_walls, mode, shared_hits):
    """Without noise the two paths differ only where the recording cuts echoes at its end and in
    its single-precision samples: the same decisions on every beam and every echo, depths within
    1 mm (measured: 5e-7 mm here, 3e-5 mm on room_glass's 117-beam frame), with each beam traced
    in its own cone or with shared hits (where the tilted wall's mirror echo, heard through
    every beam's side lobes, leaves one beam detected in "all" and "cells", four echoes)."""
    per_channel, detection_only = _frames(*sphere_and_walls, mode, noise_rms=0.0,
                                          shared_hits=shared_hits)
    assert per_channel.detected.sum() >= 1 + (not shared_hits)
    assert len(per_channel.echo_table) >= 3
    _assert_same_decisions(per_channel, detection_only, 1e-3)


def test_noisy_frames_decide_the_same_where_the_echoes_stand_far_above_the_noise(
        sphere_and_walls):
    """With receiver noise (50 times the default level, seed 1) the paths draw different
    realisations of it, so they agree only where the decisions are robust: these echoes stand
    68 to 1 000 times over the noise envelope, where noise moves the time of arrival by about
    tau_r / SNR (measured: depths 0.04 mm apart) and no candidate sits near the threshold or
    the side-lobe margin. (At 100 times the default level the 20 deg beam's side-lobe check,
    on the tilted wall's speckle, flips with the realisation on either path.) Same decisions,
    depths within 1 mm."""
    path, directions = sphere_and_walls
    per_channel, detection_only = _frames(path, directions, "first", noise_rms=0.05)
    snr = per_channel.echo_table.snr
    assert per_channel.detected.sum() >= 3 and 30 < np.min(snr) and np.max(snr) < 2e3
    _assert_same_decisions(per_channel, detection_only, 1e-3)
