"""A dithered beam grid (RepeatedMapSpec.dither): consecutive OFDM frames steer between each
other's beams, so a drive samples the field of view more finely than one grid."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

import mitsonar
from mitsonar.physics.array import dither_offsets
from mitsonar.recon.repeated import RepeatedMapSpec, scan_repeated
from mitsonar.scene.xml import material_xml, rectangle_xml, write_scene

STEP = np.radians(20.0)


def test_dither_offsets_split_each_step_evenly_and_visit_every_part_each_n_frames():
    """n x n offsets: each axis at the centres of n equal parts of a step, every pair once, and
    each n consecutive offsets (from the first) visit every part of both axes; n = 1 is no
    offset."""
    np.testing.assert_array_equal(dither_offsets(STEP, 1), [[0.0, 0.0]])
    for n in (2, 3, 4):
        offsets = dither_offsets(STEP, n)
        parts = (np.arange(n) + 0.5) / n * STEP - STEP / 2
        assert len({tuple(np.round(o, 12)) for o in offsets}) == n * n
        for axis in (0, 1):
            np.testing.assert_allclose(np.sort(np.unique(offsets[:, axis].round(12))), parts)
        for block in offsets.reshape(n, n, 2):  # every n frames: each part of each axis once
            for axis in (0, 1):
                np.testing.assert_allclose(np.sort(block[:, axis]), parts)
    with pytest.raises(ValueError, match="dither"):
        dither_offsets(STEP, 1.5)


def test_a_shifted_grid_stays_in_the_field_of_view():
    """Shifted by up to half a step, the grid keeps its beams; those moved past an edge stay on
    it. Offsets beyond half a step are refused."""
    geometry = mitsonar.ArrayGeometry()
    base = geometry.fov_grid(np.radians(5.0))
    np.testing.assert_array_equal(geometry.fov_grid(np.radians(5.0), (0.0, 0.0)), base)
    half_h, half_v = geometry.fov_horizontal / 2, geometry.fov_vertical / 2
    for offset in dither_offsets(np.radians(5.0), 4):
        grid = geometry.fov_grid(np.radians(5.0), offset)
        assert grid.shape == base.shape
        geometry.check_in_fov(grid)
        h, v = mitsonar.frames.fov_angles(grid)
        inner = (np.abs(h) < half_h - 1e-9) & (np.abs(v) < half_v - 1e-9)
        h0, v0 = mitsonar.frames.fov_angles(base)
        np.testing.assert_allclose(h[inner] - h0[inner], offset[0], atol=1e-9)
        np.testing.assert_allclose(v[inner] - v0[inner], offset[1], atol=1e-9)
    with pytest.raises(ValueError, match="half"):
        geometry.fov_grid(np.radians(5.0), (np.radians(3.0), 0.0))


@pytest.fixture(scope="module")
def wall_ahead(tmp_path_factory):
    """A rough concrete wall 2 m ahead of the sensor head (8 x 8 m), the robot creeping towards
    it at 1 cm/s, the ``paper`` preset (the wall echoes at every beam's incidence)."""
    path = write_scene(tmp_path_factory.mktemp("wall") / "wall.xml",
                       material_xml("w", preset="concrete", scattering=0.6),
                       rectangle_xml("w", (2.1, 0.0, 0.5), (0, -90, 0), size=(8.0, 8.0)),
                       '<emitter type="constant"><rgb name="radiance" value="1"/></emitter>')
    sonar = mitsonar.Sonar(path, mitsonar.SonarConfig.preset("paper"))
    trajectory = mitsonar.Trajectory(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]), speed=0.01)
    return sonar, trajectory


def test_a_dithered_grid_maps_the_wall_between_the_fixed_grids_beams(wall_ahead):
    """Four frames: with the fixed grid most of every frame's points fall within 1 cm of the
    first frame's (the robot moves 2 mm a frame); dithered over 2 x 2 offsets, each frame steers
    its beams between the first's (every point 10 cm or more from them: the offsets are 5-10 deg
    apart, 12-54 cm on the wall), with the fixed grid's codes and firing order. Every point lies
    on the wall within 2 cm either way."""
    sonar, trajectory = wall_ahead
    clouds = {}
    for dither in (1, 2):
        spec = RepeatedMapSpec(frames=4, scan_step=STEP, dither=dither, image_width=32, spp=1)
        scanned, _ = scan_repeated(sonar, trajectory, spec)
        base = scanned[0].frame.schedule
        for k, s in enumerate(scanned):
            schedule = s.frame.schedule
            offsets = dither_offsets(STEP, dither)
            expected = sonar.config.geometry.fov_grid(STEP, offsets[k % len(offsets)])
            np.testing.assert_allclose(schedule.directions, expected, atol=1e-12)
            np.testing.assert_array_equal(schedule.code_index, base.code_index)
            np.testing.assert_array_equal(schedule.transmit_time, base.transmit_time)
        clouds[dither] = [s.frame.echo_points_world for s in scanned]
        for cloud in clouds[dither]:
            assert len(cloud) >= 6
            np.testing.assert_allclose(cloud[:, 0], 2.1, atol=0.02)
    first = cKDTree(clouds[1][0])
    for cloud in clouds[1][1:]:
        assert np.median(first.query(cloud)[0]) < 0.01
    first = cKDTree(clouds[2][0])
    for cloud in clouds[2][1:]:
        assert np.min(first.query(cloud)[0]) > 0.1
