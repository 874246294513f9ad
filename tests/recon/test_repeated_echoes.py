"""Repeated maps take every echo of each beam (RepeatedMapSpec.echoes), each registered with its
beam's pose."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

import mitsonar
from mitsonar.recon.repeated import RepeatedMapSpec, build_voxel_map, scan_repeated
from mitsonar.recon.voxelmap import VoxelMapSettings
from mitsonar.scene.xml import material_xml, rectangle_xml, sphere_xml, write_scene

#: Voxels far smaller than the points' spacing, no outlier removal: one voxel per point.
EVERY_POINT = VoxelMapSettings(voxel_size=1e-4, outlier_neighbours=0)


@pytest.fixture(scope="module")
def sphere_before_wall(tmp_path_factory):
    """A metal sphere of 3 cm 1.5 m ahead of the sensor head, 3 cm aside, before a rough wall
    2.3 m ahead; the robot creeps towards them (5 cm/s), broadband transducers (the sonar's own
    setting: the first echo only)."""
    path = write_scene(tmp_path_factory.mktemp("sphere") / "sphere.xml",
                       material_xml("t", preset="metal", scattering=0.0),
                       material_xml("w", preset="concrete", scattering=0.6),
                       sphere_xml("t", (1.6, -0.03, 0.5), 0.03),
                       rectangle_xml("w", (2.4, 0.0, 0.5), (0, -90, 0), size=(8.0, 8.0)),
                       '<emitter type="constant"><rgb name="radiance" value="1"/></emitter>')
    sonar = mitsonar.Sonar(path, mitsonar.SonarConfig(
        transducer=mitsonar.Transducer(bandwidth_6db=20e3)))
    trajectory = mitsonar.Trajectory(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]), speed=0.05)
    return sonar, trajectory


@pytest.mark.parametrize("echoes", ["first", "cells"])
def test_the_map_takes_every_echo_at_its_beams_pose(sphere_before_wall, echoes):
    """The spec's echoes replace the sonar's setting: "cells" gives the broadside beam the sphere
    and the wall behind it (depths 1.47 and 2.3 m within 3 cm), "first" one point per detected
    beam; every echo enters the map at its beam's pose (Frame.echo_points_world), "frame"
    registration at the frame's start pose."""
    sonar, trajectory = sphere_before_wall
    spec = RepeatedMapSpec(frames=1, scan_step=np.radians(20.0), image_width=32, spp=1,
                           voxels=EVERY_POINT, echoes=echoes)
    scanned, camera = scan_repeated(sonar, trajectory, spec)
    frame = scanned[0].frame
    table = frame.echo_table
    broadside = int(np.argmin(np.linalg.norm(frame.schedule.directions - [0, 0, 1], axis=1)))
    depths = np.sort(table.depth[table.beam == broadside])
    if echoes == "first":
        assert len(table) == frame.detected.sum() and len(depths) == 1
    else:
        assert len(table) > frame.detected.sum() and len(depths) >= 2
        np.testing.assert_allclose(depths[[0, -1]], [1.47, 2.3], atol=0.03)
    for registration, expected in (("beam", frame.echo_points_world),
                                   ("frame", scanned[0].pose.transform_points(table.point))):
        voxels = build_voxel_map(scanned, camera, RepeatedMapSpec(
            voxels=EVERY_POINT, registration=registration))
        assert voxels.n_input == len(table) == voxels.counts.sum()
        gap, _ = cKDTree(voxels.positions).query(expected)
        assert np.all(gap < 1e-9), registration


def test_bad_echo_mode_is_refused():
    with pytest.raises(ValueError, match="RepeatedMapSpec.echoes must be one of first, all, cells"):
        RepeatedMapSpec(echoes="every")
