"""Repeated-scanning map: colour from the camera image, per-beam poses (12), outliers, voxels."""

import numpy as np
import pytest

import mitsonar
from mitsonar._native import import_open3d
from mitsonar.sensors.camera import CameraModel, CameraRenderer
from mitsonar.frames import Pose, direction_from_fov_angles
from mitsonar.recon.voxelmap import (VoxelMap, VoxelMapSettings, bilinear_sample, colourise,
                               linear_to_srgb, save_voxel_figure, save_voxel_ply, srgb_to_linear,
                               statistical_outliers, voxelise)
from mitsonar.scene.xml import material_xml, rectangle_xml, write_scene

# 160 x 120, f = 133.3 px; the raw render, exact at one sample per pixel (a denoiser would
# smooth the checker)
SMALL = CameraModel(spp=1, denoise=False).at_resolution(160)

# Checkerboard on a 4 m x 4 m wall at y = 2.5 m facing -y: 16 x 16 squares of 0.25 m.
WALL_Y, WALL_CENTRE_Z, WALL_HALF, SQUARES = 2.5, 0.55, 2.0, 16
SQUARE = 2 * WALL_HALF / SQUARES
RED, BLUE = np.array([200, 40, 40], np.uint8), np.array([30, 90, 220], np.uint8)  # 8-bit sRGB


def moving_beam_poses(n_beams, x0=-0.15, yaw0=np.radians(85.0)):
    """World-from-sensor (B, 4, 4) of a robot driving +x at 0.2 m/s while turning at 20 deg/s
    during one 208.5 ms frame, one pose per beam, and the reference (mid-frame) pose."""
    t = np.linspace(0.0, 0.2085, n_beams)
    x, yaw = x0 + 0.2 * t, yaw0 + np.radians(20.0) * t
    poses = np.stack([Pose.sensor_on_robot(xi, 0.0, yi).matrix() for xi, yi in zip(x, yaw)])
    reference = Pose.sensor_on_robot(x0 + 0.2 * 0.10425, 0.0, yaw0 + np.radians(20.0) * 0.10425)
    return poses, reference


def to_sensor(points_world, poses):
    """Inverse of (12) per beam: p_sensor = R^T (p_world - t)."""
    return np.einsum("bji,bj->bi", poses[:, :3, :3], points_world - poses[:, :3, 3])


def wall_hits(poses):
    """Where beams on a 41 x 29 grid over the 60 x 40 deg field of view meet the wall, (B, 3)."""
    h, v = np.meshgrid(np.radians(np.linspace(-30, 30, 41)), np.radians(np.linspace(-20, 20, 29)))
    d = np.einsum("bij,bj->bi", poses[:, :3, :3], direction_from_fov_angles(h.ravel(), v.ravel()))
    o = poses[:, :3, 3]
    return o + ((WALL_Y - o[:, 1]) / d[:, 1])[:, None] * d


@pytest.fixture(scope="module")
def checker_wall(tmp_path_factory):
    """The wall as an area emitter whose radiance is a checkerboard bitmap (no lighting noise)."""
    from PIL import Image

    folder = tmp_path_factory.mktemp("checker")
    texels = 16
    square = np.arange(SQUARES * texels) // texels
    parity = (square[:, None] + square[None, :]) % 2
    Image.fromarray(np.where(parity[..., None] == 0, RED, BLUE).astype(np.uint8)).save(
        folder / "checker.png")
    wall = (f'<shape type="rectangle"><transform name="to_world">'
            f'<scale x="{WALL_HALF}" y="{WALL_HALF}"/><rotate x="1" angle="90"/>'
            f'<translate y="{WALL_Y}" z="{WALL_CENTRE_Z}"/></transform>'
            f'<emitter type="area"><texture type="bitmap" name="radiance">'
            f'<string name="filename" value="{folder / "checker.png"}"/>'
            f'<string name="filter_type" value="nearest"/></texture></emitter>'
            f'<ref id="w"/></shape>')
    return mitsonar.load_scene(write_scene(folder / "wall.xml",
                                           material_xml("w", preset="drywall"), wall))


def texture_srgb(scene, origin, points):
    """Ground truth: the wall's radiance at ``points`` evaluated by Mitsuba, sRGB encoded."""
    mi = mitsonar.scene.loading.mitsuba()
    d = points - origin
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    n = len(points)
    ray = mi.Ray3f(mi.Point3f(*[mi.Float(np.full(n, origin[k])) for k in range(3)]),
                   mi.Vector3f(*[mi.Float(d[:, k]) for k in range(3)]))
    si = scene.scene.ray_intersect(ray)
    hit = np.asarray(si.p, dtype=float).T
    assert np.abs(hit - points).max() < 1e-4  # the points are on the wall and visible
    radiance = np.asarray(si.emitter(scene.scene).eval(si), dtype=float).T
    return linear_to_srgb(radiance)


def test_points_on_a_rendered_checker_wall_get_their_squares_colour(checker_wall):
    poses, reference = moving_beam_poses(41 * 29)
    world = wall_hits(poses)
    points_sensor = to_sensor(world, poses)
    image = CameraRenderer(checker_wall, SMALL).render(reference).rgb
    frame = colourise(points_sensor, poses, image, SMALL, reference)
    np.testing.assert_allclose(frame.points_world, world, atol=1e-9)
    # The camera (61.9 x 48.5 deg) covers the 60 x 40 deg beams, but the robot turns 4.2 deg
    # during the frame: beams at the edges of the frame fall outside the reference image.
    assert frame.n_behind_camera == 0 and 0 < frame.n_outside_image < 0.1 * len(world)
    # Away from the squares' edges (4 cm = 2.1 px at 2.5 m) a point sees only its own square.
    camera_origin = SMALL.world_from_camera(reference).translation
    expected = texture_srgb(checker_wall, camera_origin, world)
    x, z = world[:, 0] + WALL_HALF, world[:, 2] - WALL_CENTRE_Z + WALL_HALF
    edge = np.minimum(np.abs(x - SQUARE * np.round(x / SQUARE)),
                      np.abs(z - SQUARE * np.round(z / SQUARE)))
    interior = (edge > 0.04) & frame.coloured
    assert interior.sum() > 300
    srgb8 = np.array([RED, BLUE]) / 255.0
    assert np.all(np.min(np.abs(expected[:, None, :] - srgb8[None]).max(axis=2), axis=1) < 1e-5)
    error = np.abs(frame.colours[interior] - expected[interior]).max()
    assert error <= 0.5 / 255  # half an 8-bit step (measured: float32 rounding, ~1e-7)
    # Both squares' colours occur, and a camera without its 7.5 cm offset gets many wrong.
    assert len(np.unique(np.round(frame.colours[interior] * 255), axis=0)) == 2
    no_offset = CameraModel(spp=1, offset=np.zeros(3), denoise=False).at_resolution(160)
    wrong = colourise(points_sensor, poses, image, no_offset, reference)
    mismatch = np.abs(wrong.colours[interior] - expected[interior]).max(axis=1) > 0.5 / 255
    assert mismatch.mean() > 0.2


def test_every_beam_is_moved_to_the_world_by_its_own_pose():
    rng = np.random.default_rng(3)
    n = 200
    poses, reference = moving_beam_poses(n, x0=1.0, yaw0=np.radians(-40.0))
    sensor = rng.uniform([-1.0, -0.6, 0.5], [1.0, 0.6, 4.0], size=(n, 3))  # sensor frame [m]
    world = np.einsum("bij,bj->bi", poses[:, :3, :3], sensor) + poses[:, :3, 3]  # (12)
    image = np.full((SMALL.height, SMALL.width, 3), 0.2, np.float32)
    frame = colourise(sensor, poses, image, SMALL, reference)
    np.testing.assert_allclose(frame.points_world, world, atol=1e-12)
    # One pose for the whole frame would misplace points by centimetres (the test can fail).
    one_pose = colourise(sensor, reference.matrix(), image, SMALL, reference)
    assert np.linalg.norm(one_pose.points_world - world, axis=1).max() > 0.05
    # The colour is looked up through the image's pose: a constant image gives its own colour.
    np.testing.assert_allclose(frame.colours[frame.coloured], linear_to_srgb(0.2), atol=1e-7)


def test_bilinear_sampling_uses_pixel_centres_and_srgb_round_trips():
    h, w = 12, 16
    jj, ii = np.mgrid[0:h, 0:w]
    ramp = np.stack([0.01 * (ii + 0.5), 0.02 * (jj + 0.5), 0.003 * (ii + 0.5) + 0.004 * (jj + 0.5)], -1)
    uv = np.random.default_rng(0).uniform([0.5, 0.5], [w - 0.5, h - 0.5], size=(100, 2))
    want = np.stack([0.01 * uv[:, 0], 0.02 * uv[:, 1], 0.003 * uv[:, 0] + 0.004 * uv[:, 1]], -1)
    np.testing.assert_allclose(bilinear_sample(ramp, uv), want, atol=1e-12)  # exact for ramps
    np.testing.assert_allclose(bilinear_sample(ramp, [[0.0, 0.0], [w, h]]),
                               [ramp[0, 0], ramp[-1, -1]])  # clamped in the border half-pixel
    c = np.linspace(0, 1, 256)
    np.testing.assert_allclose(linear_to_srgb(srgb_to_linear(c)), c, atol=1e-12)
    assert linear_to_srgb(0.5) == pytest.approx(0.735357, abs=1e-6)  # IEC 61966-2-1
    assert linear_to_srgb(-0.1) == 0.0 and 1.0 - 1e-12 <= linear_to_srgb(2.0) <= 1.0  # saturates


def test_missing_detections_and_points_the_camera_cannot_see():
    cam = SMALL
    image = np.full((cam.height, cam.width, 3), 0.5, np.float32)
    pose = Pose.identity()
    edge_u = (cam.width - cam.principal_point[0]) / cam.focal_pixels  # x / z on the image's edge
    points = np.array([
        [0.0, 0.0, 2.0],              # 0: centre of the image
        [np.nan, np.nan, np.nan],     # 1: no detection
        [0.0, 0.5, -1.0],             # 2: behind the camera
        [3.0, 0.0, 1.0],              # 3: in front, far outside the image (u > W)
        [edge_u * 2.0 * (1 - 1e-12), -0.075, 2.0],  # 4: on the right image border (u = W): inside
        [np.nan, np.nan, np.nan],     # 5: no detection
        [0.0, -0.075, 0.0],           # 6: at the camera centre (z = 0): behind, not a division
    ])
    frame = colourise(points, np.broadcast_to(pose.matrix(), (7, 4, 4)), image, cam, pose)
    assert frame.n_beams == 7 and frame.n_detected == 5
    np.testing.assert_array_equal(frame.beam_index, [0, 2, 3, 4, 6])
    np.testing.assert_array_equal(frame.coloured, [True, False, False, True, False])
    assert frame.n_behind_camera == 2 and frame.n_outside_image == 1 and frame.n_uncoloured == 3
    assert np.all(np.isnan(frame.colours[[1, 2, 4]]))
    np.testing.assert_allclose(frame.pixels[3], [cam.width, cam.height / 2], atol=1e-9)
    np.testing.assert_allclose(frame.colours[[0, 3]], linear_to_srgb(0.5), atol=1e-7)
    # Uncoloured points still add geometry; their voxel has no colour (NaN, counted).
    vmap = VoxelMap()
    vmap.add_frame(frame)
    vox = vmap.voxelise(VoxelMapSettings(voxel_size=0.05, outlier_neighbours=0))
    assert len(vox) == 5 and vox.n_uncoloured == 3 and np.isnan(vox.colours).any(axis=1).sum() == 3
    cloud = vox.to_open3d()
    assert np.all(np.isfinite(np.asarray(cloud.colors)))  # grey stand-in, not NaN


@pytest.mark.parametrize("change, fragment", [
    (dict(points_sensor=np.array([[0.0, np.nan, 1.0]])), "points_sensor[0]"),
    (dict(points_sensor=np.array([[0.0, np.inf, 1.0]])), "points_sensor[0]"),
    (dict(points_sensor=np.zeros((1, 2))), "points_sensor must be (B, 3)"),
    (dict(world_from_sensor=np.full((1, 4, 4), np.nan)), "world_from_sensor[0] is not finite"),
    (dict(world_from_sensor=2 * np.eye(4)[None]), "world_from_sensor[0] is not a rigid"),
    (dict(world_from_sensor=np.eye(4)[None].repeat(2, 0)), "B = 1 beams"),
    (dict(image=np.zeros((10, 10, 3))), "image must be (H, W, 3) = (120, 160, 3)"),
    (dict(image_world_from_sensor=np.eye(3)), "image_world_from_sensor"),
])
def test_bad_frame_input_is_named(change, fragment):
    args = dict(points_sensor=np.array([[0.0, 0.0, 1.0]]), world_from_sensor=np.eye(4)[None],
                image=np.zeros((120, 160, 3)), camera_model=SMALL,
                image_world_from_sensor=Pose.identity())
    args.update(change)
    with pytest.raises(ValueError) as err:
        colourise(**args)
    assert fragment in str(err.value)


def test_settings_and_map_input_are_validated():
    with pytest.raises(ValueError, match="voxel_size"):
        VoxelMapSettings(voxel_size=0.0)
    with pytest.raises(ValueError, match="outlier_neighbours"):
        VoxelMapSettings(outlier_neighbours=2.5)
    with pytest.raises(ValueError, match="outlier_std"):
        VoxelMapSettings(outlier_std=-1.0)
    with pytest.raises(ValueError, match="origin"):
        VoxelMapSettings(origin=[0.0, np.nan, 0.0])
    vmap = VoxelMap()
    with pytest.raises(ValueError, match=r"points_world\[1\]"):
        vmap.add([[0, 0, 0], [np.nan, 0, 0]], [[0, 0, 0], [0, 0, 0]])
    with pytest.raises(ValueError, match=r"colours\[0\]"):
        vmap.add([[0, 0, 0]], [[1.5, 0, 0]])
    with pytest.raises(ValueError, match=r"colours\[0\]"):
        vmap.add([[0, 0, 0]], [[np.nan, 0, 0]])
    assert len(vmap) == 0  # nothing half-added


def test_voxel_colour_is_the_mean_of_its_points_colours_as_in_open3d():
    o3d = import_open3d()
    rng = np.random.default_rng(7)
    size, origin = 0.1, np.array([0.03, -0.02, 0.01])
    centre_keys = rng.integers(-5, 5, size=(30, 3))
    which = rng.integers(0, 30, size=600)
    points = origin + size * (centre_keys[which] + rng.uniform(0.01, 0.99, size=(600, 3)))
    colours = rng.uniform(0, 1, size=(600, 3))
    settings = VoxelMapSettings(voxel_size=size, outlier_neighbours=0, origin=origin)
    vox = voxelise(points, colours, settings)
    keys = np.floor((points - origin) / size).astype(int)
    assert len(vox) == len(np.unique(keys, axis=0)) == len(np.unique(centre_keys, axis=0))
    for k, key in enumerate(vox.keys):  # reference: direct means, voxel by voxel
        inside = np.all(keys == key, axis=1)
        assert vox.counts[k] == inside.sum()
        np.testing.assert_allclose(vox.colours[k], colours[inside].mean(axis=0), atol=1e-12)
        np.testing.assert_allclose(vox.positions[k], points[inside].mean(axis=0), atol=1e-12)
    # Open3D's voxel_down_sample also averages colours; its grid starts half a voxel below the
    # cloud's minimum, so a point at origin + size/2 (a voxel centre) puts both on one grid.
    anchor = origin + size * (centre_keys.min(axis=0) - 0.5)  # below every other point
    pts = np.vstack([points, anchor])
    cols = np.vstack([colours, [0.3, 0.6, 0.9]])
    ours = voxelise(pts, cols, settings)
    cloud = o3d.geometry.PointCloud()
    cloud.points = o3d.utility.Vector3dVector(pts)
    cloud.colors = o3d.utility.Vector3dVector(cols)
    down = cloud.voxel_down_sample(size)
    theirs_p, theirs_c = np.asarray(down.points), np.asarray(down.colors)
    order = np.lexsort(theirs_p.T[::-1])
    mine = np.lexsort(ours.positions.T[::-1])
    np.testing.assert_allclose(theirs_p[order], ours.positions[mine], atol=1e-12)
    np.testing.assert_allclose(theirs_c[order], ours.colours[mine], atol=1e-12)
    # Uncoloured points (NaN) do not count for the colour, only for the position.
    cols_nan = cols.copy()
    cols_nan[::3] = np.nan
    part = voxelise(pts, cols_nan, settings)
    inv = np.unique(np.floor((pts - origin) / size).astype(int), axis=0, return_inverse=True)[1]
    for k in range(len(part)):
        sel = (inv.ravel() == k) & ~np.isnan(cols_nan[:, 0])
        assert part.coloured_counts[k] == sel.sum()
        if sel.any():
            np.testing.assert_allclose(part.colours[k], cols_nan[sel].mean(axis=0), atol=1e-12)
        else:
            assert np.all(np.isnan(part.colours[k]))
    np.testing.assert_allclose(part.positions, ours.positions, atol=1e-12)


def test_the_grid_is_fixed_in_the_world_as_the_map_grows():
    vmap = VoxelMap()
    vmap.add([[0.12, 0.12, 0.12]], [[1.0, 0.0, 0.0]])
    first = vmap.voxelise(VoxelMapSettings(voxel_size=0.1, outlier_neighbours=0))
    vmap.add([[-0.93, 0.55, 0.55]], [[0.0, 1.0, 0.0]])  # extends the map's bounds
    second = vmap.voxelise(VoxelMapSettings(voxel_size=0.1, outlier_neighbours=0))
    assert first.keys.tolist() == [[1, 1, 1]]
    assert [1, 1, 1] in second.keys.tolist() and [-10, 5, 5] in second.keys.tolist()


def wall_grid(spacing=0.05, n=21):
    a = spacing * np.arange(n)
    x, z = np.meshgrid(a, a)
    return np.stack([x.ravel(), np.full(x.size, 2.0), z.ravel()], axis=1)


def test_outlier_removal_drops_an_isolated_far_point():
    wall = wall_grid() + np.random.default_rng(5).normal(0, 0.003, size=(441, 3))
    far = np.array([[0.5, 3.5, 0.5]])  # 1.5 m behind the wall
    vmap = VoxelMap()
    vmap.add(wall, np.full((441, 3), 0.4))
    vmap.add(far, [[1.0, 0.0, 0.0]])
    outliers = statistical_outliers(vmap.points()[0], neighbours=8, std_ratio=2.0)
    assert outliers[-1] and outliers[:-1].sum() <= 0.02 * 441  # measured: far point + few edges
    vox = vmap.voxelise(VoxelMapSettings(voxel_size=0.1, outlier_neighbours=8, outlier_std=2.0))
    assert vox.n_outliers == outliers.sum() and np.all(vox.positions[:, 1] < 2.1)
    assert np.all(np.abs(vox.colours - 0.4) < 1e-12)  # the red point's colour is gone
    cloud = vmap.build(voxel_size=0.1, outlier_neighbours=8, outlier_std=2.0)
    np.testing.assert_allclose(np.asarray(cloud.points), vox.positions)


def test_outlier_removal_keeps_duplicates_and_otherwise_agrees_with_open3d():
    o3d = import_open3d()
    rng = np.random.default_rng(11)
    pts = np.vstack([rng.normal(0, 0.3, size=(400, 3)), rng.uniform(-3, 3, size=(20, 3))])
    cloud = o3d.geometry.PointCloud()
    cloud.points = o3d.utility.Vector3dVector(pts)
    _, kept = cloud.remove_statistical_outlier(nb_neighbors=9, std_ratio=1.5)
    ours = statistical_outliers(pts, neighbours=8, std_ratio=1.5)  # Open3D counts the point itself
    np.testing.assert_array_equal(np.flatnonzero(~ours), np.sort(np.asarray(kept)))
    assert 5 <= ours.sum() <= 30
    # A robot standing still returns the same points every frame: Open3D drops them all.
    repeated = np.tile(wall_grid(), (10, 1))
    cloud.points = o3d.utility.Vector3dVector(repeated)
    assert len(cloud.remove_statistical_outlier(nb_neighbors=5, std_ratio=2.0)[1]) == 0
    assert not statistical_outliers(repeated, neighbours=5, std_ratio=2.0).any()


def test_saved_ply_and_png(tmp_path):
    o3d = import_open3d()
    import matplotlib.image

    rng = np.random.default_rng(2)
    vmap = VoxelMap()
    pts = wall_grid() + rng.normal(0, 0.002, size=(441, 3))
    cols = np.where((pts[:, :1] > 0.5), [[0.9, 0.1, 0.1]], [[0.1, 0.2, 0.9]])
    cols[:20] = np.nan
    vmap.add(pts, cols)
    vox = vmap.voxelise(VoxelMapSettings(voxel_size=0.1, outlier_neighbours=0))
    save_voxel_ply(tmp_path / "map.ply", vox)
    back = o3d.io.read_point_cloud(str(tmp_path / "map.ply"))
    np.testing.assert_allclose(np.asarray(back.points), vox.positions, atol=1e-6)
    np.testing.assert_allclose(np.asarray(back.colors), vox.display_colours(), atol=0.5 / 255)
    header = (tmp_path / "map.ply").read_text().split("end_header")[0]
    assert "property float count" in header and "property float coloured" in header
    save_voxel_figure(tmp_path / "map.png", vox, sensor_positions=[[0, 0, 0.5], [1, 0, 0.5]],
                      title="test wall")
    png = matplotlib.image.imread(tmp_path / "map.png")
    assert png.shape[0] > 300 and png.shape[1] > 900
    assert not list(tmp_path.glob(".*"))  # no temporary files left behind
    save_voxel_figure(tmp_path / "empty.png", VoxelMap().voxelise())  # an empty map still draws
    assert (tmp_path / "empty.png").stat().st_size > 0


@pytest.mark.slow
def test_checkerboard_wall_gives_voxels_with_the_colours_of_its_squares(scene_file):
    """Full repeated-scanning pipeline (OFDM frame, camera, colours, registration, voxels) on a
    rough wall 2.1 m ahead with a red/blue checkerboard of 1 m squares. The expected colour of each
    voxel is the texture (Mitsuba's own checkerboard) at the wall point the camera sees there;
    voxels within 6 cm of a square's edge (voxel size + footprint) are not judged."""
    from mitsonar.recon.repeated import RepeatedMapSpec, map_repeated
    from mitsonar.scene.loading import mitsuba

    red, blue = (0.8, 0.05, 0.05), (0.05, 0.05, 0.8)
    board = ('<texture type="checkerboard" name="reflectance">'
             f'<rgb name="color0" value="{",".join(map(str, red))}"/>'
             f'<rgb name="color1" value="{",".join(map(str, blue))}"/>'
             '<transform name="to_uv"><scale x="2" y="2"/></transform></texture>')
    material = ('<bsdf type="acoustic" id="w"><string name="preset" value="concrete"/>'
                '<float name="scattering" value="0.5"/>'  # rough render: diffuse echoes
                f'<bsdf type="diffuse">{board}</bsdf></bsdf>')
    wall = rectangle_xml("w", (2.1, 0.64, 1.14), (0, -90, 0), size=(4, 4))  # edges off the beams
    light = '<emitter type="constant"><rgb name="radiance" value="1"/></emitter>'
    config = mitsonar.SonarConfig(transducer=mitsonar.Transducer(bandwidth_6db=20e3))
    sonar = mitsonar.Sonar(scene_file("board", material, wall, light), config)
    trajectory = mitsonar.Trajectory(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]), speed=1e-3)
    spec = RepeatedMapSpec(frames=1, scan_step=np.radians(5.0), image_width=320, spp=16,
                           voxels=VoxelMapSettings(voxel_size=0.05, outlier_neighbours=5))
    voxels, _, _ = map_repeated(sonar, trajectory, spec)
    coloured = voxels.coloured_counts > 0
    assert coloured.sum() >= 10
    p = voxels.positions[coloured]
    # The texture where each voxel lies on the wall (rays along the wall normal).
    mi = mitsuba()
    rays = mi.Ray3f(mi.Point3f(*(p - [1.0, 0, 0]).T), mi.Vector3f(1.0, 0.0, 0.0))
    si = sonar.scene.scene.ray_intersect(rays)
    texture = mi.load_dict({"type": "checkerboard", "color0": {"type": "rgb", "value": red},
                            "color1": {"type": "rgb", "value": blue},
                            "to_uv": mi.ScalarTransform4f().scale([2, 2, 1])})
    assert np.all(np.array(si.is_valid()))
    expected = np.array(texture.eval(si)).T
    expected_red = expected[:, 0] > expected[:, 2]
    uv = np.array(si.uv).T * 4.0  # 4 squares of 1 m across
    edge = np.abs(uv - np.round(uv)).min(axis=1)  # [m] to the nearest square edge
    judged = edge > 0.06
    measured_red = voxels.colours[coloured][:, 0] > voxels.colours[coloured][:, 2]
    assert judged.sum() >= 10  # measured 15 voxels, all judged
    assert np.mean(measured_red[judged] == expected_red[judged]) >= 0.9  # measured 15 of 15


def test_repeated_frames_are_spread_by_the_interval(scene_file):
    """Frame k starts (pose, camera image) at k x interval; shorter than a frame is refused."""
    from mitsonar.recon.repeated import RepeatedMapSpec, map_repeated
    from mitsonar.sensors.ofdm_sonar import pose_along

    material = material_xml("w", preset="concrete")
    sonar = mitsonar.Sonar(scene_file("wall", material, rectangle_xml("w", (3.0, 0, 0.5),
                                                                      (0, -90, 0), size=(4, 4))))
    trajectory = mitsonar.Trajectory(np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]]), speed=0.2)
    spec = RepeatedMapSpec(frames=2, interval=4.0, scan_step=np.radians(30.0), image_width=32,
                           spp=1)
    _, positions, scanned = map_repeated(sonar, trajectory, spec)
    np.testing.assert_allclose(positions[:, 0], [0.1, 0.9], atol=1e-9)  # head 0.1 m ahead
    np.testing.assert_allclose(scanned[1].pose.translation, pose_along(trajectory)(4.0).translation)
    with pytest.raises(ValueError, match="interval"):
        map_repeated(sonar, trajectory, RepeatedMapSpec(frames=2, interval=0.1))
    with pytest.raises(ValueError, match="interval"):
        RepeatedMapSpec(interval=-1.0)


def test_repeated_imaging_frames_group_images_under_one_camera_image(scene_file):
    """The "imaging" scan: frame k holds ceil(0.2 s / cycle) single-ping images, image i fired
    i cycles after the frame's start from its own pose and seed; the frame's points are its
    images' points, each with its image's pose, so registered they are the images' world
    points; the voxel map holds them. An unknown scan is refused."""
    from mitsonar.recon.repeated import IMAGE_FRAME, RepeatedMapSpec, map_repeated
    from mitsonar.sensors.imaging_sonar import ImagingSonar, TransmitSettings
    from mitsonar.sensors.ofdm_sonar import pose_along
    from mitsonar.sensors.sonar import beam_seed

    material = material_xml("w", preset="concrete")
    wall = rectangle_xml("w", (2.0, 0, 0.5), (0, -90, 0), size=(4, 4))
    paper = mitsonar.SonarConfig.preset("paper")
    config = mitsonar.SonarConfig(medium=paper.medium, trace=paper.trace,
                                  transducer_response=False, pulse=mitsonar.Chirp())
    sonar = mitsonar.Sonar(scene_file("wall", material, wall), config)
    trajectory = mitsonar.Trajectory(np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]]), speed=0.2)
    transmit = TransmitSettings(rays_per_axis=24)
    spec = RepeatedMapSpec(frames=2, scan="imaging", transmit=transmit, image_width=32, spp=1,
                           voxels=VoxelMapSettings(voxel_size=0.05, outlier_neighbours=0))
    voxels, positions, scanned = map_repeated(sonar, trajectory, spec)
    imaging = ImagingSonar(sonar, transmit=transmit)
    per_frame = int(np.ceil(IMAGE_FRAME / imaging.cycle_time))
    pose_at = pose_along(trajectory)
    assert [len(s.images) for s in scanned] == [per_frame] * 2
    second = scanned[1]
    assert second.start_time == pytest.approx(per_frame * imaging.cycle_time)
    for i in (0, per_frame - 1):
        t = second.start_time + i * imaging.cycle_time
        np.testing.assert_allclose(second.images[i].pose.matrix(), pose_at(t).matrix())
        again = imaging.image(pose_at(t), seed=beam_seed(spec.seed + 1, i))
        np.testing.assert_array_equal(again.points_sensor, second.images[i].points_sensor)
    world = np.einsum("nij,nj->ni", second.world_from_sensor[:, :3, :3], second.points) \
        + second.world_from_sensor[:, :3, 3]
    np.testing.assert_allclose(world, np.concatenate([im.points_world for im in second.images]),
                               atol=1e-12)
    off = np.abs(world[:, 0] - 2.0)  # the wall 1.9 m ahead: within 5 mm (measured 0.4 mm)
    assert len(world) >= per_frame and len(voxels.positions) > 0 and off.max() < 5e-3, off
    with pytest.raises(ValueError, match="scan"):
        RepeatedMapSpec(scan="sweep")


def test_repeated_images_keep_points_by_the_rule_of_their_drive(scene_file):
    """``RepeatedMapSpec.imaging`` None (the default): images driven by the 20-80 kHz sweep keep
    points by the sub-band trust rule (``WIDE_SWEEP_SETTINGS``), those of a burst by the default
    rule; a rule given is used as it is."""
    from mitsonar.recon.repeated import RepeatedMapSpec, _RepeatedFrames
    from mitsonar.sensors.imaging_sonar import TransmitSettings
    from mitsonar.signal.imaging_settings import WIDE_SWEEP_SETTINGS, ImagingSettings

    path = scene_file("wall", material_xml("w", preset="concrete"),
                      rectangle_xml("w", (2.0, 0, 0.5), (0, -90, 0), size=(4, 4)))
    trajectory = mitsonar.Trajectory(np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]]), speed=0.2)
    paper = mitsonar.SonarConfig.preset("paper")
    fast = TransmitSettings(rays_per_axis=16)
    mine = ImagingSettings(min_coherence=0.3)
    for config, imaging, rule in ((paper.with_drive(chirp="20-80"), None, WIDE_SWEEP_SETTINGS),
                                  (paper, None, ImagingSettings()),
                                  (paper.with_drive(chirp="20-80"), mine, mine)):
        spec = RepeatedMapSpec(frames=1, scan="imaging", transmit=fast, imaging=imaging,
                               image_width=16, spp=1)
        frames = _RepeatedFrames(mitsonar.Sonar(path, config), trajectory, spec)
        assert frames.imaging.imager.settings == rule
