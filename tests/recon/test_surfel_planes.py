"""Surfel plane geometry (section III-D, (14)(15)): plane fits, grouping of surfels by their
points and expected errors, the floor the robot drives on, and the joint refinement with the image
creases; point arrays alone, no image and no sonar."""

import numpy as np
import pytest

from mitsonar.sensors.camera import CameraModel
from mitsonar.recon.surfels import PlaneGroups, SurfelSettings, fit_plane, group_surfels


def test_plane_fit_recovers_a_noisy_plane():
    """500 points on a 2 m x 2 m patch of the plane n . x = 1.5 with 5 mm noise along n: the
    SVD fit (14)(15) is within 0.2 deg and 1 mm, oriented towards the given viewpoint."""
    rng = np.random.default_rng(0)
    n = np.array([0.3, -0.2, 0.9])
    n /= np.linalg.norm(n)
    e1 = np.cross(n, [1.0, 0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    uv = rng.uniform(-1, 1, (500, 2))
    pts = 1.5 * n + uv[:, :1] * e1 + uv[:, 1:] * e2 + rng.normal(0, 0.005, (500, 1)) * n
    normal, offset = fit_plane(pts, towards=np.zeros(3))  # the origin is on the -n side
    assert np.degrees(np.arccos(normal @ -n)) < 0.2
    assert abs(offset + 1.5) < 1e-3


def _surfel(centre, e1, e2, size=0.3):
    """Four points (4, 3) of a surfel: three around ``centre`` in the plane (e1, e2), then it."""
    c, e1, e2 = (np.asarray(x, float) for x in (centre, e1, e2))
    return np.array([c + size * e1, c - size * (e1 + e2) / 2, c + size * e2, c])


def test_grouping_merges_coplanar_surfels_and_keeps_others_apart():
    """Five surfels on the wall x = 2 (chained over 3 m, 1 cm noise), two on the floor and one
    on a parallel wall 0.3 m behind: three groups, the wall's fit within 0.5 deg and 5 mm."""
    rng = np.random.default_rng(1)
    wall = [_surfel([2.0, y, z], [0, 1, 0], [0, 0, 1]) for y, z in
            [(-1.5, 0.5), (-0.8, 1.2), (0.0, 0.4), (0.7, 1.5), (1.5, 0.8)]]
    floor = [_surfel([x, y, 0.0], [1, 0, 0], [0, 1, 0]) for x, y in [(1.0, 0.0), (0.5, 1.0)]]
    behind = [_surfel([2.3, 3.0, 1.0], [0, 1, 0], [0, 0, 1])]
    points = np.array(wall + floor + behind)
    points[:, :, 0] += rng.normal(0, 0.003, points.shape[:2]) * (np.arange(len(points)) < 5)[:, None]
    groups = group_surfels(points, np.zeros((len(points), 3)))
    assert groups.label.tolist() == [0, 0, 0, 0, 0, 1, 1, 2]
    assert np.degrees(np.arccos(abs(groups.normals[0] @ [1, 0, 0]))) < 0.5
    np.testing.assert_allclose(groups.normals[0], [-1, 0, 0], atol=0.01)  # towards the sensor
    assert abs(groups.offsets[0] + 2.0) < 0.005
    np.testing.assert_allclose(groups.normals[1], [0, 0, 1], atol=1e-9)


def test_grouping_leaves_surfels_marked_alone_in_groups_of_their_own():
    """Four surfels on the wall x = 2 form one group; marked ``alone``, the second and third
    form a group each (neither joins the wall's nor is joined), the other two stay together."""
    wall = np.array([_surfel([2.0, y, z], [0, 1, 0], [0, 0, 1]) for y, z in
                     [(-1.5, 0.5), (-0.5, 1.2), (0.5, 0.4), (1.5, 0.8)]])
    view = np.zeros((len(wall), 3))
    assert group_surfels(wall, view).label.tolist() == [0, 0, 0, 0]
    alone = np.array([False, True, True, False])
    assert group_surfels(wall, view, alone=alone).label.tolist() == [0, 1, 2, 0]


def test_grouping_judges_a_small_noisy_surfel_by_its_points():
    """Four surfels with eight fill points each (5 mm noise) on the wall x = 2, seen from 2 m
    away; a small surfel (8 cm) on it whose 1.5 cm point errors tilt its normal 11 deg (beyond
    ``merge_angle``, but its normal's standard error is 19 deg): all its points lie within
    ``merge_sigmas`` expected errors of the wall's plane, so it joins the wall's group; alone, its
    group would not be grown. A 15 cm surfel on the perpendicular wall y = 2, 15-45 cm from the
    crease, stays in a group of its own."""
    rng = np.random.default_rng(2)
    fill = np.array([[u, v] for u in (-0.15, 0.0, 0.15) for v in (-0.15, 0.0, 0.15)][:8])
    wall_at = [(-0.6, 0.6), (-0.5, 1.4), (0.6, 0.7), (0.7, 1.5)]
    wall = np.array([_surfel([2.0, y, z], [0, 1, 0], [0, 0, 1]) for y, z in wall_at])
    extra = np.array([[[2.0, y + u, z + v] for u, v in fill] for y, z in wall_at])
    wall[:, :, 0] += rng.normal(0, 0.005, wall.shape[:2])
    extra[:, :, 0] += rng.normal(0, 0.005, extra.shape[:2])
    small = _surfel([2.0, 0.0, 1.0], [0, 1, 0], [0, 0, 1], size=0.08)
    small[:, 0] += [0.01, -0.01, -0.01, 0.0]
    side = _surfel([1.7, 2.0, 1.0], [1, 0, 0], [0, 0, 1], size=0.15)
    points = np.concatenate([wall, [small, side]])
    extra = np.concatenate([extra, np.full((2, 8, 3), np.nan)])
    view = np.tile([0.0, -1.0, 1.2], (len(points), 1))
    tilt = np.degrees(np.arccos(abs(fit_plane(small)[0] @ [1, 0, 0])))
    assert SurfelSettings().merge_angle < np.radians(tilt) < np.radians(13.0)
    groups = group_surfels(points, view, extra=extra)
    assert groups.label.tolist() == [0, 0, 0, 0, 0, 1]
    assert groups.normal_errors[0] < SurfelSettings().max_normal_error
    alone = group_surfels(small[None], view[:1])
    assert alone.normal_errors[0] > SurfelSettings().max_normal_error  # not grown


def _on_x(x, yz):
    """Points (n, 3) on the plane at ``x`` [m] at (y, z) ``yz`` (n, 2) [m]."""
    yz = np.asarray(yz, float)
    return np.column_stack([np.full(len(yz), x), yz])


def _window_and_wall(case):
    """Surfel points (k, 4, 3), fill points (k, 8, 3) and viewpoints (k, 3) [m] of a window
    pane at x = 3.1 and, last, one surfel on the wall's face x = 3.0 beside it (5 mm noise).
    'drive': room_glass's east window from eight poses of its drive (two surfels each between
    the frame's lines) and a wall surfel's four points seen 2.7 m away at 45 deg; 'wide': a
    2.6 x 1 m pane seen square-on from three poses and a wall surfel with eight fill points
    seen 3.8 m away at 58 deg."""
    rng = np.random.default_rng(5)
    if case == "drive":
        pane = [[(0.23, 0.9), (-0.45, 0.9), (0.23, 1.29), (0.04, 1.13)],
                [(-0.72, 0.91), (-0.69, 1.17), (-0.16, 0.89), (-0.51, 1.04)]]
        views = np.repeat([[x, 0.0, 0.5] for x in np.linspace(0.1, 1.1, 8)], 2, axis=0)
        wall = [(1.86, 0.29), (0.92, 0.09), (1.87, 0.71), (1.53, 0.27)]
        wall_view, fill = [1.09, 0.05, 0.5], []
    else:
        pane = [[(y + 0.3, z), (y - 0.15, z - 0.15), (y, z + 0.3), (y, z)]
                for y in (-1.0, 0.0, 1.0) for z in (0.6, 1.3)]
        views = np.repeat([[1.0, y, 0.5] for y in (-1.0, 0.0, 1.0)], 2, axis=0)
        wall = [(2.7, 0.8), (2.25, 0.65), (2.4, 1.1), (2.4, 0.8)]
        wall_view = [1.0, -1.0, 0.5]
        fill = [(2.4 + u, 0.8 + v) for u in (-0.2, 0.0, 0.2) for v in (-0.2, 0.0, 0.2)][:8]
    points = np.array([_on_x(3.1, s) for s in pane * (len(views) // len(pane))] + [_on_x(3.0, wall)])
    extra = np.full((len(points), 8, 3), np.nan)
    extra[-1, :len(fill)] = _on_x(3.0, fill).reshape(-1, 3)
    points[:, :, 0] += rng.normal(0, 0.005, points.shape[:2])
    extra[:, :, 0] += rng.normal(0, 0.005, extra.shape[:2])
    return points, extra, np.concatenate([views, [wall_view]])


@pytest.mark.parametrize("case", ["drive", "wide"])
def test_grouping_keeps_a_wall_apart_from_a_window_pane_10_cm_behind(case):
    """A wall surfel 10 cm in front of a window's pane (room_glass's recessed windows; the
    wall's points expected 2-6 cm off their plane at 2.7-3.8 m and oblique incidence): the
    pairwise links chained it to the pane (a plane tilted between it and each small patch of
    the pane fits both within ``merge_sigmas`` expected errors), but the pane's own plane and
    the wall's fit their points far better than one plane for both, beyond chance (chi^2 with
    3 degrees of freedom at 3 sigma): two groups, centred at x = 3.1 and 3.0 within 5 mm."""
    points, extra, view = _window_and_wall(case)
    groups = group_surfels(points, view, SurfelSettings(), extra)
    assert groups.label.tolist() == [0] * (len(points) - 1) + [1]
    np.testing.assert_allclose(groups.centroids[:, 0], [3.1, 3.0], atol=0.005)


def test_groups_that_fit_the_floor_the_robot_drives_on():
    """Echoes seen from a sensor 0.575 m up, 1.5-3 m away (grazing, 2-5 cm expected errors):
    a floor patch scattered 3 mm about z = 0 fits the ground plane as well as its own; a board
    5 cm above the floor (each echo within 1-1.9 expected errors of the floor, but the twelve
    together not: chi^2 21 against 14.2) and a wall do not; a group of two points is not
    judged."""
    from mitsonar.recon.surfels.planes import on_ground

    rng = np.random.default_rng(0)
    xy = np.column_stack([rng.uniform(1.5, 3.0, 12), rng.uniform(-0.5, 0.5, 12)])
    floor = np.column_stack([xy, rng.normal(0.0, 0.003, 12)])
    board = np.column_stack([xy, np.full(12, 0.05)])
    wall = np.column_stack([np.full(12, 2.0), xy[:, 1], np.linspace(0.2, 1.0, 12)])
    points = np.concatenate([floor, board, wall, floor[:2]])
    label = np.repeat([0, 1, 2, 3], [12, 12, 12, 2])
    view = np.tile([0.0, 0.0, 0.575], (len(points), 1))
    assert on_ground(4, points, label, view).tolist() == [True, False, False, False]


def test_floor_surfels_are_grouped_apart():
    """Six 40 cm surfels on a plane tilted 10 deg up from the floor (a slope meeting the floor
    at y = 0.33 m) and two 20 cm floor surfels across that line, seen from 0.5 m up: a floor
    surfel's normal is poorly determined at grazing incidence (tens of degrees), and its
    echoes lie within 2 cm (under one expected error) of the tilted plane too, so both join
    the slope's group; grouped apart (``floor``: the surfels that fit the ground alone,
    :func:`~mitsonar.recon.surfels.map._grounded`), the slope's group keeps its six and the
    two floor surfels form a group of their own, on the floor."""
    from mitsonar.recon.surfels.map import _grounded

    tilt = np.radians(10.0)
    up = np.array([0.0, -np.sin(tilt), np.cos(tilt)])
    along = np.array([0.0, np.cos(tilt), np.sin(tilt)])  # up the slope
    corner = np.array([[0.0, 0.0], [0.4, 0.0], [0.0, 0.4], [0.13, 0.13]])
    slope = np.array([[0.33 * np.array([0, 1, 0]) + (x0 + a) * np.array([1.0, 0, 0])
                       + (s0 + b) * along for a, b in corner]
                      for x0 in (-0.6, 0.1) for s0 in (1.2, 2.2, 3.2)])
    floor = np.array([[[x0 + a / 2, 0.23 + b / 2, 0.0] for a, b in corner] for x0 in (0.3, 0.6)])
    floor[..., 2] += np.array([0.002, -0.001, 0.0, 0.001])  # echoes a few mm about the floor
    points = np.concatenate([slope, floor])
    view = np.tile([0.0, -1.5, 0.5], (len(points), 1))
    settings = SurfelSettings()
    assert np.abs(slope @ up - 0.33 * up[1]).max() < 1e-12
    grouped = group_surfels(points, view, settings)
    assert grouped.label.tolist() == [0] * 8  # the floor surfels join the slope
    extra = np.full((len(points), 0, 3), np.nan)
    floored = _grounded(points, view, extra, settings)
    assert floored.tolist() == [False] * 6 + [True] * 2
    apart = group_surfels(points, view, settings, floor=floored)
    assert apart.label.tolist() == [0] * 6 + [1] * 2
    assert np.degrees(np.arccos(apart.normals[0] @ up)) < 0.1
    assert np.degrees(np.arccos(apart.normals[1][2])) < 0.5


def _wall_crease_camera():
    """A camera at the origin looking along world +x (camera x right = world -y, y down =
    world -z) and the walls x = 2 and y = 1, whose vertical crease at (2, 1) it sees at
    u = uc - f / 2 (x_cam = -1 at z_cam = 2)."""
    from mitsonar.frames import Pose

    camera = CameraModel().at_resolution(320)
    rotation = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    pose = Pose(rotation, np.zeros(3))
    normals = np.array([[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])  # towards the camera
    offsets = np.array([-2.0, -1.0])
    return camera, pose, normals, offsets


def test_crease_residuals_are_the_pixel_distance_from_the_projected_crease():
    """A segment on the crease's image has residuals 0 (1e-9 px), one 5 px to the right +-5 px
    at both ends, one tilted ends apart in proportion; parallel planes give 1e3."""
    from mitsonar.recon.surfels.planes import Creases, _crease_residuals

    camera, pose, normals, offsets = _wall_crease_camera()
    uc, vc = camera.principal_point
    u = uc - camera.focal_pixels / 2
    segments = [(u, vc - 40, u, vc + 40), (u + 5, vc - 40, u + 5, vc + 40),
                (u, vc - 40, u + 8, vc + 40)]
    creases = Creases.of([(camera, pose, seg, 0, 1) for seg in segments] +
                         [(camera, pose, segments[0], 0, 0)])
    r = _crease_residuals(normals, offsets, creases)
    assert r.shape == (4, 2)
    np.testing.assert_allclose(r[0], 0.0, atol=1e-9)
    np.testing.assert_allclose(np.abs(r[1]), 5.0, rtol=1e-9)
    assert r[1, 0] == pytest.approx(r[1, 1])
    np.testing.assert_allclose(np.abs(r[2]), [0.0, 8.0], atol=1e-9)
    np.testing.assert_array_equal(r[3], 1e3)


def test_refine_planes_recovers_two_walls_from_noisy_points_and_their_crease():
    """Two walls (x = 2, y = 1) started 3 deg and 5 cm off, 200 points each with 5 mm noise
    and the crease seen in the image: the refined planes are within 0.5 deg and 3 mm."""
    from mitsonar.recon.surfels.planes import refine_planes

    camera, pose, normals, offsets = _wall_crease_camera()
    rng = np.random.default_rng(3)
    wall_x = np.column_stack([np.full(200, 2.0), rng.uniform(-1, 0.9, 200),
                              rng.uniform(-0.5, 1.5, 200)])
    wall_y = np.column_stack([rng.uniform(0.5, 1.9, 200), np.full(200, 1.0),
                              rng.uniform(-0.5, 1.5, 200)])
    points = np.concatenate([wall_x, wall_y]) + rng.normal(0, 0.005, (400, 3))
    label = np.repeat([0, 1], 200)
    tilt = np.radians(3.0)
    start = np.array([[-np.cos(tilt), np.sin(tilt), 0.0], [np.sin(tilt), -np.cos(tilt), 0.0]])
    groups = PlaneGroups(np.array([0, 1]), start, offsets + 0.05, np.zeros((2, 3)),
                         np.zeros(2), 1)
    uc, vc = camera.principal_point
    u = uc - camera.focal_pixels / 2
    refined = refine_planes(groups, points, label, np.zeros((400, 3)),
                            [(camera, pose, (u, vc - 40, u, vc + 40), 0, 1)])
    angle = np.degrees(np.arccos(np.clip(np.einsum("gc,gc->g", refined.normals, normals), -1, 1)))
    assert np.all(angle < 0.5), angle
    np.testing.assert_allclose(refined.offsets, offsets, atol=3e-3)
