"""Scans and OFDM frames carry every echo their beams report (DetectionSettings.echoes): the echo
table beside the per-beam detections, its arrays, and its points in the world frame."""

import numpy as np
import pytest

import mitsonar
from mitsonar.frames import direction_from_fov_angles
from mitsonar.scene.xml import material_xml, rectangle_xml, sphere_xml, write_scene
from mitsonar.sensors.ofdm_sonar import OfdmSonar

#: Broadband transducers (20 kHz at -6 dB), so that every OFDM code gets through.
BROADBAND = mitsonar.Transducer(bandwidth_6db=20e3)


@pytest.fixture(scope="module")
def sphere_before_wall(tmp_path_factory):
    """A metal sphere of 3 cm 1.4 m ahead, 1.5 deg off the axis, before a rough concrete wall
    2.2 m ahead; and four beams: the sphere's (it hears the wall and the sphere) and three on the
    wall."""
    path = write_scene(tmp_path_factory.mktemp("sphere") / "sphere.xml",
                       material_xml("t", preset="metal", scattering=0.0),
                       material_xml("w", preset="concrete", scattering=0.6),
                       sphere_xml("t", 1.4 * direction_from_fov_angles(np.radians(1.5), 0.0), 0.03),
                       rectangle_xml("w", (0, 0, 2.2), size=(8.0, 8.0)))
    directions = direction_from_fov_angles(np.radians([0.0, -10.0, 10.0, 0.0]),
                                           np.radians([0.0, 0.0, 5.0, -10.0]))
    return path, directions


def _assert_rank_zero_rows_are_the_beams(table, detected, points_sensor):
    """Rank 0 of every beam is its per-beam detection; rows sorted by beam."""
    first = table.rank == 0
    np.testing.assert_array_equal(table.beam[first], np.flatnonzero(detected))
    np.testing.assert_array_equal(table.point[first], points_sensor[detected])
    assert np.all(np.diff(table.beam) >= 0)


def test_a_scan_carries_every_echo_and_its_arrays(sphere_before_wall):
    """echoes = "all": the sphere's beam reports the sphere and the wall behind it (depths 1.37 m
    and 2.2 m within 2 cm); the echo table's points in the world frame are the scan pose's
    transform of its sensor-frame points; ``arrays()`` (echoes.npz) holds the table column by
    column as ``echo_*``."""
    path, directions = sphere_before_wall
    sonar = mitsonar.Sonar(path, mitsonar.SonarConfig(
        transducer=BROADBAND, detection=mitsonar.DetectionSettings(echoes="all")))
    turn = np.radians(1.0)  # about y, then moved: the sphere stays in the first beam
    pose = mitsonar.Pose(np.array([[np.cos(turn), 0, np.sin(turn)], [0, 1, 0],
                                   [-np.sin(turn), 0, np.cos(turn)]]), [0.02, -0.03, 0.0])
    scan = sonar.scan(pose, directions, seed=2)
    table = scan.echo_table
    _assert_rank_zero_rows_are_the_beams(table, scan.detected, scan.points_sensor)
    np.testing.assert_allclose(np.sort(table.depth[table.beam == 0]), [1.37, 2.2], atol=0.02)
    np.testing.assert_allclose(scan.echo_points_world, pose.transform_points(table.point))
    arrays = scan.arrays()
    for name in ("beam", "rank", "peak", "depth", "point", "direction", "amplitude", "snr",
                 "coherence", "time_of_arrival", "path_length"):
        np.testing.assert_array_equal(arrays[f"echo_{name}"], getattr(table, name))
    assert arrays["echoes"].shape[0] == len(directions)  # the recordings keep their key


@pytest.mark.parametrize("mode", ["first", "all"])
def test_a_frame_carries_every_echo_with_its_beams_pose(sphere_before_wall, mode):
    """An OFDM frame fired while the sensor moves towards the wall at 0.5 m/s: each echo's pose
    is its beam's firing pose, and its world point that pose's transform of its sensor-frame
    point. With echoes = "first" the table is the detected beams; with "all" the sphere's beam
    has two (each beam traced in its own cone; with shared hits the wall's mirror echo, heard
    through the side lobes, adds echoes)."""
    path, directions = sphere_before_wall
    sonar = mitsonar.Sonar(path, mitsonar.SonarConfig(
        transducer=BROADBAND, detection=mitsonar.DetectionSettings(echoes=mode)))
    ofdm = OfdmSonar(sonar, shared_hits=False)
    frame = ofdm.frame(ofdm.schedule(directions),
                       lambda t: mitsonar.Pose(np.eye(3), [0.0, 0.0, 0.5 * t]), seed=1)
    table = frame.echo_table
    _assert_rank_zero_rows_are_the_beams(table, frame.detected, frame.points_sensor)
    poses = frame.echo_world_from_sensor
    np.testing.assert_array_equal(poses, frame.world_from_sensor[table.beam])
    expected = [mitsonar.Pose(m[:3, :3], m[:3, 3]).transform_points(p[None])[0]
                for m, p in zip(poses, table.point)]
    np.testing.assert_allclose(frame.echo_points_world, np.reshape(expected, (-1, 3)),
                               rtol=0, atol=1e-12)
    per_beam = np.bincount(table.beam, minlength=len(directions))
    assert per_beam[0] == (1 if mode == "first" else 2) and frame.detected.sum() >= 2
