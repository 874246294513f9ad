"""Surfel scanning (section III-D, Fig. 5): verification, regions grown between line segments,
shadow lines, the floor, and reconstructed rendered corners (plane fits and grouping:
test_surfel_planes.py; check pings: test_surfel_checks.py)."""

import numpy as np
import pytest

import mitsonar
from mitsonar.recon.thinning import cell_index
from mitsonar.sensors.camera import CameraModel
from mitsonar.recon.surfels import (PlaneGroups, PoseScan, SurfelSettings, grow_planes,
                                    map_surfels, region_labels, shadow_segments, verify)
from mitsonar.scene.xml import material_xml, spanned_rectangle_xml, write_scene


def test_verification_rejects_a_surfel_straddling_two_planes():
    """Three points on a wall 3 m ahead; the centroid on the wall (accepted) or on a box face
    0.4 m nearer (rejected by the paper's 0.15 m test); a missing echo is rejected too."""
    three = np.array([[-0.2, -0.1, 3.0], [0.2, -0.1, 3.0], [0.0, 0.25, 3.0]])
    points = np.stack([np.vstack([three, [0.0, 0.0, 3.01]]),
                       np.vstack([three, [0.0, 0.0, 2.6]]),
                       np.vstack([three[:2], [np.nan] * 3, [0.0, 0.0, 3.0]])])
    accepted, residual = verify(points, 0.15)
    assert accepted.tolist() == [True, False, False]
    np.testing.assert_allclose(residual[:2], [0.01, 0.4], atol=1e-12)
    assert residual[2] == np.inf
    with pytest.raises(ValueError, match="shape"):
        verify(np.zeros((2, 3, 3)))


def _scan_stub(segments, box=(0, 0, 200, 150)):
    camera = CameraModel().at_resolution(200)
    return PoseScan(mitsonar.Pose.identity(), camera, box, np.asarray(segments, float),
                    np.zeros((0, 3, 2)), np.zeros((0, 2), int), np.zeros((0, 4, 3)),
                    np.zeros(0), np.zeros(0, bool), np.zeros((150, 200)), 0)


def test_regions_and_shadow_lines():
    """A vertical and a horizontal line cut the crop into four regions (the vertical one crosses
    the whole crop; the horizontal ends 4 px short of it but the 4 px extension closes the
    gap); a line with the same single plane on both sides is a shadow line, one between two
    planes or next to an unclaimed region is kept."""
    segments = [[100.5, 0.5, 100.5, 149.5], [0.5, 75.5, 96.5, 75.5], [103.5, 75.5, 199.5, 75.5]]
    regions = region_labels(segments, (0, 0, 200, 150), (150, 200))
    assert regions.max() + 1 == 4
    assert np.all(regions[:, 99:102] == -1)  # 3 px barrier
    corners = regions[[10, 10, 140, 140], [10, 190, 10, 190]]
    assert len(set(corners.tolist())) == 4
    scan = _scan_stub(segments)
    claims = np.zeros((4, 2), int)
    tl, tr, bl, br = corners
    claims[[tl, bl], 0] = 4           # left: plane 0 above and below the horizontal line
    claims[tr, 1] = 4                 # top right: plane 1, bottom right: nobody
    shadow = shadow_segments(scan, regions, claims, offset=5.0)
    # vertical: plane 0 | plane 1 above, nobody below -> kept; left horizontal: 0 | 0 -> shadow
    assert shadow.tolist() == [False, True, False]
    claims[br, 1] = 4
    assert shadow_segments(scan, regions, claims).tolist() == [False, True, True]
    claims[tr, 0] = 1  # two planes claim the top right region: undecided, kept
    assert shadow_segments(scan, regions, claims).tolist() == [False, True, False]


def _along_pixels(camera, pixels, depth):
    """Points (n, 3) [m] seen at pixels (n, 2) at sensor-frame depths z (n,) [m] by ``camera``
    at the identity pose."""
    f, (uc, vc) = camera.focal_pixels, camera.principal_point
    ray = np.column_stack([(pixels[:, 0] - uc) / f, (pixels[:, 1] - vc) / f, np.ones(len(pixels))])
    depth = np.broadcast_to(depth, len(pixels))
    return camera.offset + ray * (depth - camera.offset[2])[:, None]


def _wall_ahead():
    """A plane group z = 2 m (normal towards the sensor at the origin) and one surfel on it left
    of the image's centre."""
    plane = PlaneGroups(np.zeros(1, int), np.array([[0.0, 0.0, -1.0]]), np.array([-2.0]),
                        np.array([[-0.5, 0.0, 2.0]]), np.array([0.01]), 1)
    surfel = np.array([[[-0.6, -0.1, 2.0], [-0.4, -0.1, 2.0], [-0.5, 0.1, 2.0],
                        [-0.5, 0.0, 2.0]]])
    return plane, surfel


def test_barriers_bridge_a_broken_line_and_reach_the_border():
    """A horizontal crease found in three pieces (gaps of 30 and 40 px), its ends 10 px short of
    the crop's sides, leaves the crop one region; the barriers bridge the gaps and extend the
    ends to the border, so the regions above and below it are apart, and no barrier joins
    them. With ``bridge_gap`` 0 and ``junction_gap`` 0 they stay one region."""
    from mitsonar.recon.surfels.growing import barriers

    box = (0, 0, 200, 150)
    pieces = [[10.5, 75.5, 60.5, 75.5], [90.5, 75.5, 120.5, 75.5], [160.5, 75.5, 190.5, 75.5]]
    settings = SurfelSettings(image_width=200)

    def regions(s):
        labels = region_labels(barriers(pieces, box, s), box, (150, 200), 0.0, 3)
        return labels[[10, 140], [100, 100]], labels.max() + 1

    (above, below), count = regions(settings)
    assert count == 2 and above != below
    (above, below), count = regions(SurfelSettings(image_width=200, bridge_gap=0.0,
                                                   junction_gap=0.0))
    assert count == 1 and above == below


@pytest.mark.parametrize("start, regions_found", [(40.5, 2), (120.5, 1)])
def test_barriers_extend_a_long_line_to_the_border_by_its_own_length(start, regions_found):
    """varied_1: a wall-floor crease found from 130 px right of the crop's left side to the
    corner; the floor's region leaked round its end onto the wall. A line 150 px long stopping
    30 px short of the border (beyond ``junction_gap``, 25 px) is extended to it (by up to its
    own length, at most ``bridge_gap`` x the width: 50 px at 200 px); a 70 px line stopping 110
    px short is not, and the crop stays one region."""
    from mitsonar.recon.surfels.growing import barriers

    box = (10, 0, 200, 150)
    line = [[start, 75.5, 190.5, 75.5]]
    settings = SurfelSettings(image_width=200)
    labels = region_labels(barriers(line, box, settings), box, (150, 200), 0.0, 3)
    assert labels.max() + 1 == regions_found
    assert (labels[10, 100] != labels[140, 100]) == (regions_found == 2)


def test_no_plane_is_grown_below_the_floor():
    """A wall 2 m ahead of the robot claims the whole crop (no lines): the lower image rows'
    rays meet its plane under the floor the robot drives on (z = 0), where the camera sees
    nothing. Points more than ``below_floor`` (5 cm) under it are not grown, the rest of the
    wall is; with ``below_floor=None`` the whole crop is (as before the limit: varied_9's wall
    grown 0.97 m into the floor)."""
    from dataclasses import replace

    pose = mitsonar.Pose.sensor_on_robot(0.0, 0.0, 0.0)
    h = pose.translation[2]
    plane = PlaneGroups(np.zeros(1, int), np.array([[-1.0, 0.0, 0.0]]), np.array([-2.0]),
                        np.array([[2.0, 0.0, h]]), np.array([0.01]), 1)
    surfel = np.array([[[2.0, -0.1, h - 0.1], [2.0, 0.1, h - 0.1], [2.0, 0.0, h + 0.1],
                        [2.0, 0.0, h]]])
    scan = replace(_scan_stub([]), pose=pose)
    unlimited = grow_planes(scan, np.zeros((0, 4)), plane, surfel,
                            SurfelSettings(below_floor=None))
    assert np.all(unlimited.grid_plane == 0)
    z = unlimited.grid_points[..., 2]
    assert z.min() < -0.2 and z.max() > h  # the crop reaches below the floor
    limited = grow_planes(scan, np.zeros((0, 4)), plane, surfel)
    grown = limited.grid_plane == 0
    assert np.array_equal(grown, z >= -SurfelSettings().below_floor)
    assert np.all(limited.vertices[:, 2] >= -0.05) and 0.2 < grown.mean() < 0.9


def test_a_floor_surfel_is_held_to_the_ground():
    """A lone floor surfel 2.1-2.7 m ahead whose echoes lie 4 mm above and below the floor:
    its fitted plane is tilted 1.2 deg and its normal's standard error (8 deg, from the 3.6-4.5
    cm expected errors at grazing incidence) too large to claim a region, so without ``ground``
    nothing is grown, and with a looser ``max_normal_error`` the tilted plane is, up to cm off
    the floor. With ``ground`` (the default) its plane is the floor the robot drives on, z = 0,
    known exactly: it claims the crop and every grown point lies on the floor."""
    from dataclasses import replace

    from mitsonar.recon.lines import scan_pixels
    from mitsonar.recon.surfels.growing import camera_rays
    from mitsonar.recon.surfels.map import build_map

    pose = mitsonar.Pose.sensor_on_robot(0.0, 0.0, 0.0)
    triangle = np.array([[[60.5, 105.5], [140.5, 105.5], [100.5, 135.5]]])
    scan = replace(_scan_stub([[60.5, 105.5, 140.5, 105.5], [60.5, 105.5, 100.5, 135.5]]),
                   pose=pose, triangles=triangle, segment_pairs=np.array([[0, 1]]),
                   residual=np.zeros(1), accepted=np.ones(1, bool))
    camera_pose = scan.camera.world_from_camera(pose)
    rays = camera_rays(scan.camera, camera_pose, scan_pixels(triangle)[0])
    origin = camera_pose.translation
    on_floor = origin + rays * (-origin[2] / rays[:, 2])[:, None]
    off = np.array([[0.0, 0.0, 0.004], [0.0, 0.0, -0.004], [0.0, 0.0, 0.004], [0.0, 0.0, 0.0]])
    scan = replace(scan, points_world=(on_floor + off)[None])
    settings = SurfelSettings(image_width=200, remove_shadows=False)
    alone = build_map([scan], replace(settings, ground=False))
    assert 0.5 < np.degrees(np.arccos(alone.groups.normals[0, 2])) < 2.0
    assert alone.groups.normal_errors[0] > settings.max_normal_error
    assert not np.any(alone.meshes[0].grid_plane >= 0)
    tilted = build_map([scan], replace(settings, ground=False, max_normal_error=np.radians(20)))
    grown = tilted.meshes[0].grid_plane == 0
    assert np.max(np.abs(tilted.meshes[0].grid_points[grown][:, 2])) > 0.01
    held = build_map([scan], settings)
    assert held.groups.normals[0].tolist() == [0.0, 0.0, 1.0] and held.groups.offsets[0] == 0.0
    grown = held.meshes[0].grid_plane == 0
    assert grown.mean() > 0.3
    assert np.all(np.abs(held.meshes[0].grid_points[grown][:, 2]) < 1e-9)


# ---- rendered scenes -------------------------------------------------------------------------


CREASE = np.array([2.0, 2.0, 0.0])  # where the two walls and the floor meet [m]


SUN = ('<emitter type="directional"><vector name="direction" x="0.45" y="0.45" z="-0.77"/>'
       '<rgb name="irradiance" value="1"/></emitter>')


def corner_scene(scene_file, tilt_deg=0.0, *extra):
    """Walls x = 2 (leaning back by ``tilt_deg`` about its crease with the floor) and y = 2,
    drywall, and a concrete floor z = 0, lit by a sun that reaches all three (no shadows; the
    three faces differ in brightness). Returns (path, true planes {name: (normal towards the
    room, offset)})."""
    t = np.radians(tilt_deg)
    up = np.array([np.sin(t), 0.0, np.cos(t)])  # up along the leaning wall
    n_x = np.cross(up, [0, 1, 0])
    to_sun = -np.array([0.45, 0.45, -0.77]) / np.linalg.norm([0.45, 0.45, -0.77])
    path = scene_file(  # wall_x's albedo keeps its brightness (0.225 x irradiance) at any tilt
        "corner", material_xml("wall_x", round(0.225 / (n_x @ to_sun), 3), preset="drywall"),
        material_xml("wall_y", 0.8, preset="drywall"),
        material_xml("floor", 0.15, preset="concrete"), SUN,
        *extra,
        spanned_rectangle_xml("wall_x", CREASE + [0, -3, 0] + 1.6 * up, up, [0, 1, 0], (1.6, 3)),
        spanned_rectangle_xml("wall_y", CREASE + [-3, 0, 1.5], [1, 0, 0], [0, 0, 1], (4, 1.5)),
        spanned_rectangle_xml("floor", CREASE + [-3, -3, 0], [1, 0, 0], [0, 1, 0], (3, 3)))
    planes = {"wall_x": (n_x, float(n_x @ CREASE)), "wall_y": (np.array([0, -1.0, 0]), -2.0),
              "floor": (np.array([0, 0, 1.0]), 0.0)}
    return path, planes


def corner_poses(distance=2.8, yaws_deg=(-8.0, 0.0, 8.0)):
    """Sensor poses on the robot ``distance`` [m] from the crease, looking at it (yaw 45 deg
    plus the offsets)."""
    poses = []
    for o in np.radians(yaws_deg):
        yaw = np.radians(45.0) + o
        poses.append(mitsonar.Pose.sensor_on_robot(2.0 - distance * np.cos(yaw),
                                                   2.0 - distance * np.sin(yaw), yaw))
    return poses


def plane_errors(groups, planes):
    """Per true plane: (angle [deg], offset [m]) of the group with the closest normal, and the
    (G,) group indices used."""
    out, used = {}, []
    for name, (n, d) in planes.items():
        g = int(np.argmax(groups.normals @ n))
        out[name] = (np.degrees(np.arccos(np.clip(groups.normals[g] @ n, -1, 1))),
                     groups.offsets[g] - d)
        used.append(g)
    return out, used


def _reconstruct(tmp_path_factory, tilt_deg):
    """Surfel map of the corner from three poses 2.8 m away ('paper' sonar preset: the default
    physical model's echoes are weak diffuse speckle at these 20-75 deg incidences, with range
    errors up to 25 cm, and its pings cost 5x more time than the 40 s budget of a test allows)."""
    def scene_file(name, *parts):
        return write_scene(tmp_path_factory.mktemp("surfels") / f"{name}.xml", *parts)

    path, planes = corner_scene(scene_file, tilt_deg)
    sonar = mitsonar.Sonar(path, mitsonar.SonarConfig.preset("paper"))
    return map_surfels(sonar, corner_poses(), settings=SurfelSettings()), planes


@pytest.fixture(scope="module")
def corner_map(tmp_path_factory):
    return _reconstruct(tmp_path_factory, 0.0)


@pytest.mark.slow
def test_rendered_corner_gives_three_planes(corner_map):
    """Every candidate surfel of the three poses is registered and lands on the right face: three
    groups, one per face, meeting the surfel issue's targets ('paper' preset): normals within
    1 deg, planes within 1 cm of the true planes where the faces are (at the true corner), and
    the three planes meeting within 2 cm of it. Measured (seed 0, with the check pings and the
    arrival-direction estimate, 8 spp denoised images): normals off by 0.07 deg (wall x = 2),
    0.04 deg (wall y = 2), 0.04 deg (floor); planes 2.6, 2.8, 0.2 mm from the corner, which they
    locate within 3.8 mm (without check pings: 0.09, 0.21, 0.04 deg; 2.4, 1.4, 0.3 mm; 2.8 mm).
    (Offsets d of n . x = d, i.e. referred to the world origin 2.8-3.6 m away, are off by more:
    there a 0.5 deg tilt alone moves the plane by 2-3 cm.) Sonar points alone
    (``refine=False``, no fill or check pings): 1.91, 0.66, 0.02 deg, 2.7 cm."""
    surfel_map, planes = corner_map
    assert len(surfel_map.groups) == 3 and len(surfel_map.surfel_pose) == 9
    assert np.bincount(surfel_map.groups.label).tolist() == [3, 3, 3]
    errors, used = plane_errors(surfel_map.groups, planes)
    assert sorted(used) == [0, 1, 2]
    assert all(angle < 1.0 for angle, _ in errors.values())
    g = surfel_map.groups
    assert np.all(np.abs(g.normals[used] @ CREASE - g.offsets[used]) < 0.01)
    corner = np.linalg.solve(g.normals[used], g.offsets[used])
    assert np.linalg.norm(corner - CREASE) < 0.02
    # the grown mesh lies on the fitted planes and spans the faces beyond the surfels
    g = surfel_map.groups
    on_plane = np.abs(np.einsum("fc,fc->f", surfel_map.vertices[surfel_map.triangles[:, 0]],
                                g.normals[surfel_map.plane]) - g.offsets[surfel_map.plane])
    assert np.max(on_plane) < 1e-6
    points, plane = surfel_map.sample(0.01)
    assert len(points) > 45_000  # measured 50 452: about 5 m^2 at one point per cm^2
    # the three poses' meshes overlap (sampled as one mesh at 1 cm: 138 280 points); the
    # samples keep one point per 1 cm cube, each on its own plane
    assert len(np.unique(cell_index(points, 0.01))) == len(points)
    assert np.max(np.abs(np.einsum("pc,pc->p", points, g.normals[plane]) - g.offsets[plane])) \
        < 1e-6


@pytest.mark.slow
def test_tilted_wall_is_reconstructed_tilted(tmp_path_factory):
    """The wall x = 2 leaning back 20 deg: its group's tilt from vertical is 20 deg within the
    issue's 2 deg (measured 20.03 deg with the check pings, 19.97 deg without, seed 0, 8 spp
    denoised images; sonar points alone: 19.72 deg)."""
    surfel_map, planes = _reconstruct(tmp_path_factory, 20.0)
    assert len(surfel_map.groups) == 3
    errors, _ = plane_errors(surfel_map.groups, planes)
    assert errors["wall_x"][0] < 2.0
    g = int(np.argmax(surfel_map.groups.normals @ planes["wall_x"][0]))
    tilt = np.degrees(np.arcsin(surfel_map.groups.normals[g][2]))
    assert abs(tilt - 20.0) < 2.0


SHADOW_HEIGHT = 0.6  # [m] where the board's shadow edge crosses the wall x = 2


def test_shadow_across_a_wall_is_removed(tmp_path):
    """Paper Fig. 8a: the corner, plus a lamp shining along +x (it lights only the wall x = 2;
    the floor and the wall y = 2 are parallel to it) and a board in the plane x = -2 behind the
    cameras, out of their view and the sonar's, covering z > 0.6 m: a sharp horizontal shadow
    edge across the wall. In every pose FLD finds it (within 2 px of its true image), it is
    removed as a shadow line, no registered surfel is built on it, the wall is one plane group
    and the regions on its two sides are one (no plane boundary along it). 'paper' preset,
    400 x 300, 8 spp denoised; about 30 s. (With the edge at 0.9 m, small surfels between it and the
    top of the crop got normals 7 deg off and, grouped by normals, a group of their own: the line
    was kept. Grouped by their points' fit it is removed in every pose too: three groups, normals
    0.7-1.4 deg off, the corner within 2.7 cm.)"""
    lamp = ('<emitter type="directional"><vector name="direction" x="1" y="0" z="0"/>'
            '<rgb name="irradiance" value="1.5"/></emitter>')
    top = 3.5
    board = spanned_rectangle_xml("wall_y", [-2.0, -0.75, (SHADOW_HEIGHT + top) / 2], [0, 1, 0],
                                  [0, 0, 1], (3.25, (top - SHADOW_HEIGHT) / 2))

    def scene_file(name, *parts):
        return write_scene(tmp_path / f"{name}.xml", *parts)

    path, planes = corner_scene(scene_file, 0.0, lamp, board)
    sonar = mitsonar.Sonar(path, mitsonar.SonarConfig.preset("paper"))
    settings = SurfelSettings()
    surfel_map = map_surfels(sonar, corner_poses(), settings=settings)
    assert len(surfel_map.groups) == 3
    for p, (scan, removed) in enumerate(zip(surfel_map.scans, surfel_map.shadow)):
        to_camera = scan.camera.world_from_camera(scan.pose).inverse()
        ends = scan.camera.project(to_camera.transform_points(
            [[2.0, 0.0, SHADOW_HEIGHT], [2.0, 2.0, SHADOW_HEIGHT]]))
        d = (ends[1] - ends[0]) / np.linalg.norm(ends[1] - ends[0])
        across = np.abs((scan.segments.reshape(-1, 2, 2) - ends[0]) @ [-d[1], d[0]]).max(axis=1)
        on_shadow = across < 2.0
        assert on_shadow.sum() == 1  # detected: the test can fail
        assert removed[on_shadow].all() and removed.sum() == 1
        k = np.nonzero(on_shadow)[0][0]
        registered = scan.segment_pairs[surfel_map.surfel_index[surfel_map.surfel_pose == p]]
        assert not np.any(registered == k)
        # one region, claimed by the wall's group alone, on both sides of the line
        regions = region_labels(scan.segments[~removed], scan.box,
                                (scan.camera.height, scan.camera.width))
        middle = (scan.segments[k, :2] + scan.segments[k, 2:]) / 2
        normal = np.array([-d[1], d[0]]) * settings.shadow_offset
        above, below = (np.floor(middle + s * normal).astype(int) for s in (-1, 1))
        assert regions[above[1], above[0]] == regions[below[1], below[0]] >= 0
    errors, _ = plane_errors(surfel_map.groups, planes)
    assert all(angle < 1.0 for angle, _ in errors.values())  # measured 0.25-0.46 deg


def test_regions_without_a_claiming_plane_get_a_region_surfel():
    """One line across the crop (a wall-floor crease with no corner in view) makes no junction,
    so no triangle surfel; each of its two regions gets a region surfel whose three outer scan
    pixels and centroid lie in that region at least ``fill_margin`` from the line (not from the
    crop's edges, which are no crease), spread over it: across most of its width and height.
    A region a plane claims gets none."""
    from dataclasses import replace

    from mitsonar.recon.lines import triangle_surfels
    from mitsonar.recon.surfels.growing import region_triangles

    line = [[0.5, 60.5, 199.5, 60.5]]
    assert len(triangle_surfels(line)) == 0
    scan = _scan_stub(line)
    settings = SurfelSettings(image_width=200)
    triangles = region_triangles(scan, settings)
    assert triangles.shape == (2, 3, 2)
    margin = scan.camera.focal_pixels * np.tan(settings.fill_margin)
    at = np.concatenate([triangles, triangles.mean(axis=1, keepdims=True)], axis=1)
    above = np.all(at[..., 1] < 60.5, axis=1)
    assert above.tolist() in ([True, False], [False, True])  # one on each side
    assert np.all(np.abs(at[..., 1] - 60.5) >= margin)
    assert np.all(np.ptp(at[..., 0], axis=1) > 195)
    for t, up in zip(at, above):  # rows 0-59 above the line, 61-149 below
        assert np.ptp(t[:, 1]) > (60 if up else 89) - margin - 4
    plane, surfel = _wall_ahead()  # its points project below the line: it claims that region
    mesh = grow_planes(scan, np.asarray(line), plane, surfel)
    assert np.all(mesh.grid_plane[mesh.grid_pixels[..., 1] > 65] == 0)
    claimed = region_triangles(scan, settings, mesh)
    assert len(claimed) == 1 and np.all(claimed[0, :, 1] < 60.5)
    assert len(region_triangles(replace(scan, segments=np.zeros((0, 4))), settings)) == 1


@pytest.mark.slow
def test_region_surfels_map_a_floor_seen_without_corners(tmp_path):
    """Three still poses 3.5, 3.2 and 2.9 m from the wall y = 2 of the rendered corner, facing
    it: the camera sees the wall and the floor meeting in one crease and no corner (the wall
    x = 2 is out of view), so no two segments meet and no triangle surfel is proposed: no map
    (the default: the paper's candidates). With ``region_surfels`` each pose's two regions get
    a region surfel; the wall's lose echoes at the field of view's upper corners (oblique
    incidence), the floor's three register and form one plane within 0.5 deg and 1 cm of the
    floor, grown (measured, seed 0, 'paper' preset, 400 px: 0.01 deg, 1 mm, 31 324 mesh
    triangles)."""
    def scene_file(name, *parts):
        return write_scene(tmp_path / f"{name}.xml", *parts)

    path, planes = corner_scene(scene_file)
    sonar = mitsonar.Sonar(path, mitsonar.SonarConfig.preset("paper"))
    poses = [mitsonar.Pose.sensor_on_robot(-1.5, y, np.radians(90.0)) for y in (-1.5, -1.2, -0.9)]
    paper = map_surfels(sonar, poses, settings=SurfelSettings())
    assert all(len(s.triangles) == 0 for s in paper.scans) and len(paper.triangles) == 0
    surfel_map = map_surfels(sonar, poses, settings=SurfelSettings(region_surfels=True))
    assert len(surfel_map.groups) >= 1
    floor = int(np.argmax(surfel_map.groups.normals @ planes["floor"][0]))
    angle, offset = plane_errors(surfel_map.groups, {"floor": planes["floor"]})[0]["floor"]
    assert angle < 0.5 and abs(offset) < 0.01
    assert np.sum(surfel_map.plane == floor) > 10_000
