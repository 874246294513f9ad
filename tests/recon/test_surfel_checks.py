"""Surfel check pings: the echoes over the grown planes that confirm a poorly determined plane,
refute a group or split it, judge a misfit surfel alone, and stop a plane where the sonar says
otherwise."""

import numpy as np
import pytest

from mitsonar.recon.surfels import CheckPings, PlaneGroups, SurfelSettings, grow_planes
from test_surfel_planes import _surfel
from test_surfels import _along_pixels, _scan_stub, _wall_ahead


def test_a_refuted_group_of_several_surfels_is_split_before_any_is_dropped(monkeypatch):
    """Three surfels on a wall 2 m ahead form one group. When the check pings refute every group
    that holds the second or the third (as a recessed window's pane surfel is refuted with the
    two surfels straddling its reveal that joined it, varied_7), the group is split first and
    only those two are dropped when refuted alone: the first keeps its plane."""
    from dataclasses import replace

    from mitsonar.recon.lines import scan_pixels
    from mitsonar.recon.surfels import map as surfel_map_module

    triangles = np.array([[[20.5, 20.5], [80.5, 20.5], [20.5, 80.5]],
                          [[120.5, 20.5], [180.5, 20.5], [120.5, 80.5]],
                          [[120.5, 130.5], [180.5, 130.5], [180.5, 70.5]]])
    scan = _scan_stub([])
    points = np.stack([_along_pixels(scan.camera, p, 2.0) for p in scan_pixels(triangles)])
    scan = replace(scan, triangles=triangles, segment_pairs=np.full((3, 2), -1),
                   residual=np.zeros(3), accepted=np.ones(3, bool), points_world=points)

    def refuted(scans, meshes, groups, settings):
        return np.isin(np.arange(len(groups)), groups.label[np.isin(found.surfel_index, [1, 2])])

    found = surfel_map_module.build_map([scan], SurfelSettings(image_width=200))
    assert found.groups.label.tolist() == [0, 0, 0]
    original = surfel_map_module._build

    def build(*args):
        nonlocal found
        found = original(*args)
        return found

    monkeypatch.setattr(surfel_map_module, "refuted_groups", refuted)
    monkeypatch.setattr(surfel_map_module, "_build", build)
    kept = surfel_map_module.build_map([scan], SurfelSettings(image_width=200))
    assert kept.surfel_index.tolist() == [0] and len(kept.groups) == 1
    assert kept.rejected["refuted"] == 2
    assert abs(kept.groups.offsets[0] + 2.0) < 1e-6


def test_a_surfel_off_its_groups_final_plane_is_judged_alone():
    """Four surfels share the plane z = 2 m, seen from the origin (expected errors 0.5-1.3 cm).
    The third lies 10 cm behind it (a window pane behind a wall's face, varied_1) and the
    fourth 3 cm: both misfit the plane (chi^2 p-values 2e-218 and 3e-5 over 4 points), and
    only the worse, the third, is judged alone this round. A lone surfel 10 cm off its
    group's plane is not (the group is its own)."""
    from mitsonar.recon.surfels.map import SurfelMap, misfit_members

    offsets = [0.0, 0.0, 0.1, 0.03, 0.1]
    points = np.array([_surfel([x, 0.0, 2.0 + dz], [1, 0, 0], [0, 1, 0], size=0.1)
                       for x, dz in zip([-0.6, -0.2, 0.2, 0.6, 1.0], offsets)])
    groups = PlaneGroups(np.array([0, 0, 0, 0, 1]), np.array([[0.0, 0.0, -1.0]] * 2),
                         np.array([-2.0, -2.0]), np.zeros((2, 3)), np.full(2, 0.01), 1)
    scan = _scan_stub([])
    found = SurfelMap([scan], groups, np.zeros(5, int), np.arange(5), points,
                      np.zeros((5, 3, 3)), np.zeros((0, 3)), np.zeros((0, 3), int),
                      np.zeros(0, int), [np.zeros(0, bool)])
    assert misfit_members(found, SurfelSettings()).tolist() == [False, False, True, False, False]


def test_check_echoes_of_another_pose_refute_a_plane_in_every_image():
    """The check echoes of a pose 0.3 m to the side (on the wall z = 2 m left of the image's
    centre, 0.5 m behind it to the right) stop the wall's growth in an image that fired no
    check pings of its own; without them the whole crop is grown."""
    from mitsonar.recon.surfels.growing import HeardChecks

    plane, surfel = _wall_ahead()
    scan = _scan_stub([])
    assert np.all(grow_planes(scan, np.zeros((0, 4)), plane, surfel).grid_plane == 0)
    pixels = np.stack(np.meshgrid(np.arange(10.0, 200.0, 20.0), np.arange(5.0, 150.0, 20.0)),
                      axis=-1).reshape(-1, 2)
    points = _along_pixels(scan.camera, pixels, np.where(pixels[:, 0] < 100, 2.0, 2.5))
    elsewhere = np.broadcast_to([0.3, 0.0, 0.0], points.shape)
    mesh = grow_planes(scan, np.zeros((0, 4)), plane, surfel, checks=HeardChecks(points,
                                                                                 elsewhere))
    cols = mesh.grid_pixels[0, :, 0]
    grown = mesh.grid_plane >= 0
    assert np.all(grown[:, cols < 99]) and not np.any(grown[:, cols > 101])


def test_check_echoes_off_every_claiming_plane_refute_a_group():
    """A plane group claiming the whole crop is refuted when at least ``min_refutations`` of
    its pose's check echoes lie on no plane there and they outnumber those on it (a grid of 10
    columns of 8 pings; echoes 0.5 m behind the plane in the right columns, on it in the
    others; pings without an echo say nothing)."""
    from dataclasses import replace

    from mitsonar.recon.surfels.map import refuted_groups

    plane, surfel = _wall_ahead()
    scan = _scan_stub([])
    mesh = grow_planes(scan, np.zeros((0, 4)), plane, surfel)
    pixels = np.stack(np.meshgrid(np.arange(10.0, 200.0, 20.0), np.arange(5.0, 150.0, 20.0)),
                      axis=-1).reshape(-1, 2)
    u = pixels[:, 0]

    def refuted(behind, heard=True, settings=SurfelSettings()):
        points = _along_pixels(scan.camera, pixels, np.where(behind, 2.5, 2.0))
        points[~np.broadcast_to(heard, len(points))] = np.nan
        checked = replace(scan, checks=CheckPings(pixels, points))
        return refuted_groups([checked], [mesh], plane, settings).tolist()

    assert refuted(u > 80) == [True]     # 48 echoes against, 32 on it
    assert refuted(u > 100) == [False]   # 40 and 40
    two = np.arange(len(u)) < 2          # two echoes heard, both behind the plane
    assert refuted(True, two) == [False]
    assert refuted(True, two, SurfelSettings(min_refutations=2)) == [True]


def test_check_echoes_scattered_beyond_their_errors_refute_a_plane():
    """Every check echo within ``merge_sigmas`` (3) expected errors of the group's plane (none
    against it), alternately 2 errors in front and behind it, as about a plane tilted through a
    crease: chi^2 per echo 4 over 80 echoes (p ~ 1e-27) refutes it at ``fit_significance``;
    echoes 0.5 errors off (chi^2 per echo 0.25, as on the true planes of the generated rooms)
    do not, nor does the scattered set with the test off (``fit_significance`` 0)."""
    from dataclasses import replace

    from mitsonar.recon.surfels.map import refuted_groups
    from mitsonar.recon.surfels.planes import _plane_offsets

    plane, surfel = _wall_ahead()
    scan = _scan_stub([])
    mesh = grow_planes(scan, np.zeros((0, 4)), plane, surfel)
    pixels = np.stack(np.meshgrid(np.arange(10.0, 200.0, 20.0), np.arange(5.0, 150.0, 20.0)),
                      axis=-1).reshape(-1, 2)
    on_wall = _along_pixels(scan.camera, pixels, 2.0)
    # one expected error along the normal (the sensor is at the origin): 0.5-0.6 cm here
    sigma = 1.0 / np.abs(_plane_offsets(on_wall + [0.0, 0.0, 1.0], np.zeros(3), plane,
                                        SurfelSettings())[:, 0])
    sign = np.where(np.arange(len(pixels)) % 2, 1.0, -1.0)

    def refuted(errors, settings=SurfelSettings()):
        points = _along_pixels(scan.camera, pixels, 2.0 + sign * errors * sigma)
        offsets = _plane_offsets(points, np.zeros(3), plane, settings)[:, 0]
        assert np.allclose(np.abs(offsets), errors, rtol=0.05)
        checked = replace(scan, checks=CheckPings(pixels, points))
        return refuted_groups([checked], [mesh], plane, settings).tolist()

    assert refuted(2.0) == [True]
    assert refuted(0.5) == [False]
    assert refuted(2.0, SurfelSettings(fit_significance=0.0)) == [False]


LONE = ([[[40.5, 40.5], [52.5, 40.5], [40.5, 52.5]]],
        [[40.5, 40.5, 52.5, 40.5], [40.5, 40.5, 40.5, 52.5]], [[0, 1]],
        [0.005, -0.005, -0.005, 0.005])
PAIR = ([[[40.5, 40.5], [52.5, 40.5], [40.5, 52.5]], [[54.5, 40.5], [66.5, 40.5], [54.5, 52.5]]],
        [[40.5, 40.5, 66.5, 40.5], [40.5, 40.5, 40.5, 52.5], [54.5, 40.5, 54.5, 52.5]],
        [[0, 1], [0, 2]], [0.0, 0.0, -0.005, 0.0])


@pytest.mark.parametrize("case", [LONE, PAIR], ids=["lone", "pair"])
def test_check_echoes_confirm_a_poorly_determined_plane(case):
    """A lone surfel 14 cm across on a wall 2 m ahead (points 5 mm off the wall), or two such
    surfels 17 cm apart seen from one pose whose fourth points lie 5 mm behind it (one group,
    its plane tilted 6 deg): the group's normal is too poorly determined (standard errors 36 and
    16 deg) to claim its region, however many surfels hold it, so nothing is grown (varied_4
    with region surfels: two surfels of one pose, 6.5 deg, grew a plane 21 deg off the wall
    behind a floor lamp, 9 % within 2 cm). Check echoes on the wall over the crop join its
    plane, which is then well determined and grown over the crop, within 1 cm of the wall."""
    from dataclasses import replace

    from mitsonar.recon.lines import scan_pixels
    from mitsonar.recon.surfels.map import build_map

    triangles, segments, pairs, off = (np.array(x) for x in case)  # off: along the sight [m]
    scan = replace(_scan_stub(segments), triangles=triangles, segment_pairs=pairs,
                   residual=np.zeros(len(pairs)), accepted=np.ones(len(pairs), bool))
    scan = replace(scan, points_world=np.stack([_along_pixels(scan.camera, p, 2.0 + off)
                                                for p in scan_pixels(triangles)]))
    settings = SurfelSettings(image_width=200, remove_shadows=False)
    alone = build_map([scan], settings)
    assert alone.groups.label.tolist() == [0] * len(pairs)
    assert alone.groups.normal_errors[0] > settings.max_normal_error
    assert not np.any(alone.meshes[0].grid_plane >= 0)
    pixels = np.stack(np.meshgrid(np.arange(10.0, 200.0, 20.0), np.arange(5.0, 150.0, 20.0)),
                      axis=-1).reshape(-1, 2)
    checked = replace(scan, checks=CheckPings(pixels, _along_pixels(scan.camera, pixels, 2.0)))
    confirmed = build_map([checked], settings)
    assert confirmed.groups.normal_errors[0] < settings.max_normal_error
    grown = confirmed.meshes[0].grid_plane >= 0
    assert np.mean(grown) > 0.9
    assert np.all(np.abs(confirmed.meshes[0].grid_points[grown][:, 2] - 2.0) < 0.01)


def test_check_pings_stop_a_plane_where_the_sonar_refutes_it():
    """One plane 2 m ahead claims the whole crop (no lines) from a surfel on its left. Check
    pings on a 20 px grid: on the plane left of u = 100, 0.5 m behind it to the right.
    The plane then grows only where the nearest evidence confirms it (left of u = 100); pings
    without an echo say nothing; without checks the whole crop is grown."""
    from dataclasses import replace

    plane, surfel = _wall_ahead()
    scan = _scan_stub([])
    unchecked = grow_planes(scan, np.zeros((0, 4)), plane, surfel)
    assert np.all(unchecked.grid_plane == 0)
    pixels = np.stack(np.meshgrid(np.arange(10.0, 200.0, 20.0), np.arange(5.0, 150.0, 20.0)),
                      axis=-1).reshape(-1, 2)
    u = pixels[:, 0]
    points = _along_pixels(scan.camera, pixels, np.where(u < 100, 2.0, 2.5))
    checked = grow_planes(replace(scan, checks=CheckPings(pixels, points)), np.zeros((0, 4)),
                          plane, surfel)
    cols = checked.grid_pixels[0, :, 0]
    grown = checked.grid_plane >= 0
    assert np.all(grown[:, cols < 99]) and not np.any(grown[:, cols > 101])
    points[u > 100] = np.nan  # no echo on the right: nothing refutes the plane there
    silent = grow_planes(replace(scan, checks=CheckPings(pixels, points)), np.zeros((0, 4)),
                         plane, surfel)
    assert np.all(silent.grid_plane == 0)
