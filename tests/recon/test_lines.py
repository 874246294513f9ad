"""Image side of surfel scanning: field-of-view crop, FLD segments, merging, triangle surfels,
scan points and their beam directions (section III-D, equations (10)(11))."""

import cv2
import numpy as np
import pytest

import mitsonar
from mitsonar.physics.array import ArrayGeometry
from mitsonar.sensors.camera import CameraModel, CameraRenderer
from mitsonar.frames import direction_from_angles, fov_angles
from mitsonar.recon.lines import (_angle_neighbours, clip_segments, close_junctions, detect_segments,
                            fov_crop_box, merge_collinear, scan_directions, scan_pixels, triangle_surfels)
from helpers import IDENTITY
from mitsonar.scene.xml import material_xml, spanned_rectangle_xml

CAMERA = CameraModel()
GEOMETRY = ArrayGeometry()

# A room corner drawn in OpenCV coordinates (integer pixel centres): the vertical crease, the
# left and right wall-floor creases meet at CORNER.
W, H = 1600, 1200
CORNER = (820, 700)
POLYGONS = {  # name: (vertices, grey level)
    "left wall": (np.array([[0, 0], [CORNER[0], 0], CORNER, [0, 1000]]), 90),
    "right wall": (np.array([[CORNER[0], 0], [W - 1, 0], [W - 1, 1050], CORNER]), 170),
    "floor": (np.array([[0, 1000], CORNER, [W - 1, 1050], [W - 1, H - 1], [0, H - 1]]), 130),
}


def corner_image() -> np.ndarray:
    img = np.zeros((H, W), np.uint8)
    for vertices, grey in POLYGONS.values():
        cv2.fillPoly(img, [vertices.astype(np.int32)], grey)
    return img


def clip_to_box(a, b, box):
    """Segment a-b (mitsonar coordinates) clipped to the box u0 <= u <= u1, v0 <= v <= v1."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    t = np.linspace(0.0, 1.0, 100001)[:, None]
    p = a + t * (b - a)
    u0, v0, u1, v1 = box
    inside = (p[:, 0] >= u0) & (p[:, 0] <= u1) & (p[:, 1] >= v0) & (p[:, 1] <= v1)
    return np.concatenate([p[inside][0], p[inside][-1]])


def endpoint_error(found, expected) -> float:
    """Largest endpoint distance [pixels] between two segments (4,), either orientation."""
    f, e = found.reshape(2, 2), expected.reshape(2, 2)
    return min(np.max(np.hypot(*(f - e).T)), np.max(np.hypot(*(f[::-1] - e).T)))


def offset_and_cover(found, expected):
    """Largest distance [pixels] of the found segment's ends from the expected segment's line,
    and the fraction of the expected segment that the found one covers."""
    a, b = expected[:2], expected[2:]
    d = (b - a) / np.hypot(*(b - a))
    ends = found.reshape(2, 2) - a
    along = np.clip(ends @ d, 0.0, np.hypot(*(b - a)))
    return np.max(np.abs(ends @ [-d[1], d[0]])), np.ptp(along) / np.hypot(*(b - a))


def match(found, expected):
    """For each expected segment, the error of the closest found one [pixels]."""
    return np.array([min(endpoint_error(f, e) for f in found) for e in expected])


def test_fov_crop_box_edges_lie_on_the_field_of_view():
    u0, v0, u1, v1 = box = fov_crop_box(CAMERA, GEOMETRY)
    assert box == (30, 115, 1570, 1085)  # f = 1333.3 px: 800 -/+ 769.8, 600 -/+ 485.3
    h, v = fov_angles(scan_directions(CAMERA, np.array([[u0, v0], [u1, v1]], float)))
    f = CAMERA.focal_pixels
    uc, vc = CAMERA.principal_point
    # half a pixel's angle at the box edge: d atan(x / f) / dx = f / (f^2 + x^2)
    half_u = 0.5 * f / (f**2 + (u1 - uc) ** 2)
    half_v = 0.5 * f / (f**2 + (v1 - vc) ** 2)
    np.testing.assert_allclose(h, [-np.radians(30), np.radians(30)], atol=half_u)
    np.testing.assert_allclose(v, [-np.radians(20), np.radians(20)], atol=half_v)
    # a reduced camera keeps the same field of view
    small = CAMERA.at_resolution(400)
    assert fov_crop_box(small, GEOMETRY) == (8, 29, 392, 271)


def test_fov_crop_box_at_a_finite_depth_follows_the_camera_offset():
    """Points on the field of view's corners 2 m ahead project within half a pixel of the box
    corners; the box lies f * 0.075 / 2 = 50 px lower than at infinity (camera above array)."""
    depth = 2.0
    box = fov_crop_box(CAMERA, GEOMETRY, depth=depth)
    th, tv = np.tan(np.radians(30)), np.tan(np.radians(20))
    corners = np.array([[-th, -tv, 1.0], [th, tv, 1.0]]) * depth
    pixels = CAMERA.project(CAMERA.camera_from_sensor().transform_points(corners))
    np.testing.assert_allclose(pixels.ravel(), box, atol=0.5)
    assert box[1] - fov_crop_box(CAMERA, GEOMETRY)[1] == 50
    with pytest.raises(ValueError, match="outside"):
        fov_crop_box(CAMERA, GEOMETRY, depth=0.05)  # so close the footprint is below the image
    with pytest.raises(ValueError, match="depth"):
        fov_crop_box(CAMERA, GEOMETRY, depth=-1.0)


def test_corner_image_gives_three_edges_and_three_surfels():
    box = fov_crop_box(CAMERA, GEOMETRY)
    segments = detect_segments(corner_image(), box)
    corner = np.add(CORNER, 0.5)  # mitsonar coordinates: pixel centres at half-integers
    expected = np.array([clip_to_box(corner, p, box) for p in
                         (corner + [0, -700], corner + [-820, 300], corner + [779, 350])])
    assert len(segments) == 3  # the three creases, nothing else (no piece shorter than 50 px)
    assert np.all(match(segments, expected) <= 4.0)  # measured 1.4, 2.9, 1.1 px

    surfels = triangle_surfels(segments)
    assert len(surfels) == 3  # one per pair of creases
    np.testing.assert_allclose(surfels.vertices[:, 0], np.tile(corner, (3, 1)), atol=2.0)
    assert sorted(map(tuple, surfels.segment_pairs)) == [(0, 1), (0, 2), (1, 2)]
    # counterclockwise as displayed (v down): (b - a) x (c - a) < 0 in (u, v)
    (du1, dv1), (du2, dv2) = (surfels.vertices[:, 1:] - surfels.vertices[:, :1]).transpose(1, 2, 0)
    assert np.all(du1 * dv2 - dv1 * du2 < 0)
    # each surfel's four scan points fall inside one polygon, more than 5 px from its border,
    # and the three surfels cover the three polygons
    points = scan_pixels(surfels.vertices) - 0.5  # back to OpenCV coordinates
    owners = []
    for quad in points:
        inside = [name for name, (vertices, _) in POLYGONS.items()
                  if all(cv2.pointPolygonTest(vertices.astype(np.float32), tuple(map(float, p)),
                                              True) > 5.0 for p in quad)]
        assert len(inside) == 1
        owners += inside
    assert sorted(owners) == sorted(POLYGONS)


def test_both_edges_of_a_thin_line_merge_into_its_centre_line():
    img = np.full((400, 600), 200, np.uint8)
    cv2.line(img, (50, 100), (550, 300), 60, 3)  # 3 px thick: FLD sees two edges ~5 px apart
    segments = detect_segments(img)
    assert len(segments) == 1
    assert endpoint_error(segments[0], np.array([50.5, 100.5, 550.5, 300.5])) <= 3.0


def test_merge_collinear_joins_pieces_of_a_line_and_keeps_a_parallel_one():
    d = np.array([np.cos(0.3), np.sin(0.3)])
    n = np.array([-d[1], d[0]])
    p0 = np.array([100.0, 200.0])

    def piece(t0, t1, offset=0.0):
        return np.concatenate([p0 + t0 * d + offset * n, p0 + t1 * d + offset * n])

    segments = np.array([
        piece(0, 80), piece(90, 200),      # broken by a 10 px gap
        piece(150, 260, 1.5)[[2, 3, 0, 1]],  # overlapping duplicate, 1.5 px off, reversed
        piece(0, 260, 20.0),               # parallel line 20 px away
        piece(400, 500),                   # same line, 140 px further on: a separate segment
    ])
    merged = merge_collinear(segments, np.radians(2.0), distance_tolerance=4.0, gap_tolerance=15.0)
    assert len(merged) == 3
    # the joined line spans t = 0..260 (extreme projections) within the 1.5 px offset
    assert endpoint_error(merged[0], piece(0, 260)) <= 1.5
    np.testing.assert_allclose(merged[1], piece(0, 260, 20.0), atol=1e-9)
    np.testing.assert_allclose(merged[2], piece(400, 500), atol=1e-9)
    # a tighter gap tolerance keeps the broken pieces apart; tilting a piece by 5 deg too
    assert len(merge_collinear(segments[:2], gap_tolerance=5.0)) == 2
    c, s = np.cos(np.radians(5)), np.sin(np.radians(5))
    tilted = np.concatenate([p0 + 90 * d, p0 + 90 * d + 110 * (np.array([[c, -s], [s, c]]) @ d)])
    assert len(merge_collinear(np.array([segments[0], tilted]))) == 2
    assert merge_collinear(np.zeros((0, 4))).shape == (0, 4)


def test_merge_candidates_by_sorted_direction_match_all_pairs():
    """The sorted-direction neighbour search (in chunks) lists exactly the pairs within the
    angle tolerance, across pi = 0 too; pieces of a line tilted -0.5 and +0.5 deg merge."""
    theta = np.random.default_rng(2).uniform(0, np.pi, 300)
    tol = np.radians(3.0)
    pairs = np.concatenate([np.stack(p, 1) for p in _angle_neighbours(theta, tol, chunk=50)])
    diff = np.abs(theta[:, None] - theta[None, :])
    brute = {(i, j) for i, j in zip(*np.nonzero(np.minimum(diff, np.pi - diff) <= tol)) if i < j}
    assert len(pairs) == len(brute) and {tuple(sorted(p)) for p in pairs} == brute
    e = np.radians(0.5)
    pieces = np.array([[0, 0, 100 * np.cos(e), -100 * np.sin(e)],
                       [105, 0, 105 + 100 * np.cos(e), 100 * np.sin(e)]])
    assert len(merge_collinear(pieces)) == 1


def test_triangle_surfels_need_a_junction_at_ends_of_both_segments():
    corner = triangle_surfels(np.array([[100, 100, 300, 100], [100, 100, 100, 300]], float))
    assert len(corner) == 1
    # junction, then the far ends counterclockwise as displayed: down first, then right
    np.testing.assert_allclose(corner.vertices[0], [[100, 100], [100, 300], [300, 100]])
    # a gap of 6 px at the junction is within the 10 px tolerance; the vertex is the crossing
    gapped = triangle_surfels(np.array([[106, 100, 300, 100], [100, 104, 100, 300]], float))
    np.testing.assert_allclose(gapped.vertices[0, 0], [100, 100])
    cases = {
        "crossing": [[0, 100, 200, 100], [100, 0, 100, 200]],
        "T junction": [[0, 100, 200, 100], [100, 100, 100, 300]],
        "far apart": [[130, 100, 300, 100], [100, 130, 100, 300]],
        "nearly collinear (5 deg)": [[0, 0, 100, 0], [100, 0, 200, 100 * np.tan(np.radians(5))]],
        "parallel": [[0, 0, 100, 0], [0, 5, 100, 5]],
    }
    for name, segments in cases.items():
        assert len(triangle_surfels(np.array(segments, float))) == 0, name


def test_close_junctions_extends_ends_to_nearby_junctions_only():
    """L junction with both ends short (6 and 20 px) -> both reach the corner; a T junction
    20 px short -> reaches the stem's line; a junction 40 px away (gap 25 px), parallel
    segments, and ends already past the crossing are left alone."""
    gap = 25.0
    closed = close_junctions(np.array([[106, 100, 300, 100], [100, 120, 100, 300]], float), gap)
    np.testing.assert_allclose(closed, [[100, 100, 300, 100], [100, 100, 100, 300]])
    tee = close_junctions(np.array([[0, 100, 200, 100], [100, 120, 100, 300]], float), gap)
    np.testing.assert_allclose(tee, [[0, 100, 200, 100], [100, 100, 100, 300]])
    for segments in ([[140, 100, 300, 100], [100, 100, 100, 300]],  # 40 px short
                     [[0, 0, 100, 0], [0, 5, 100, 5]],  # parallel
                     [[0, 100, 200, 100], [100, 0, 100, 200]]):  # a crossing: nothing to close
        s = np.array(segments, float)
        np.testing.assert_array_equal(close_junctions(s, gap), s)
    # of two junctions within reach, an end takes the nearer one
    two = close_junctions(np.array([[0, 100, 190, 100], [200, 0, 200, 200],
                                    [210, 0, 210, 200]], float), gap)
    np.testing.assert_allclose(two[0], [0, 100, 200, 100])


def test_scan_pixels_one_third_towards_each_vertex_then_the_centroid():
    vertices = np.array([[[0.0, 0.0], [0.0, 3.0], [3.0, 0.0]],
                         [[10.0, 10.0], [16.0, 10.0], [10.0, 4.0]]])
    expected = np.array([[[2 / 3, 2 / 3], [2 / 3, 5 / 3], [5 / 3, 2 / 3], [1.0, 1.0]],
                         [[12 - 2 / 3, 8 + 2 / 3], [12 + 4 / 3, 8 + 2 / 3], [12 - 2 / 3, 8 - 4 / 3],
                          [12.0, 8.0]]])
    np.testing.assert_allclose(scan_pixels(vertices), expected, atol=1e-12)


def test_scan_directions_follow_equations_10_11_and_the_offset():
    rng = np.random.default_rng(0)
    pixels = rng.uniform([31, 116], [1569, 1084], size=(5, 4, 2))  # inside the FOV box
    directions = scan_directions(CAMERA, pixels)
    theta, phi = CAMERA.pixel_angles(pixels[..., 0], pixels[..., 1])
    np.testing.assert_allclose(directions, direction_from_angles(theta, phi), atol=1e-12)
    np.testing.assert_allclose(scan_directions(CAMERA, np.array([800.0, 600.0])), [0, 0, 1],
                               atol=1e-12)
    # with a depth, the beam from the array origin meets the camera ray at that z
    depth = 2.0
    aimed = scan_directions(CAMERA, pixels, depth=depth)
    points = aimed * (depth / aimed[..., 2])[..., None]
    back = CAMERA.project(CAMERA.camera_from_sensor().transform_points(points))
    np.testing.assert_allclose(back, pixels, atol=1e-9)
    GEOMETRY.check_in_fov(directions)


def test_bad_inputs_name_the_parameter():
    img = corner_image()
    with pytest.raises(ValueError, match="2-D"):
        detect_segments(np.zeros((10, 10, 3)))
    with pytest.raises(ValueError, match="min_length"):
        detect_segments(img, min_length=0.0)
    with pytest.raises(ValueError, match="box"):
        detect_segments(img, box=(0, 0, 1700, 1200))
    with pytest.raises(ValueError, match="gray image must be finite"):
        detect_segments(np.full((10, 10), np.nan))
    with pytest.raises(ValueError, match="segments"):
        merge_collinear(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="join_tolerance"):
        triangle_surfels(np.zeros((2, 4)), join_tolerance=0.0)
    with pytest.raises(ValueError, match="vertices"):
        scan_pixels(np.zeros((2, 4, 2)))
    with pytest.raises(ValueError, match="pixels"):
        scan_directions(CAMERA, np.zeros((3, 3)))


def test_rendered_room_corner_gives_its_three_creases(scene_file):
    """Two walls at 45 deg and a floor, seen from 3 m (world = sensor frame: y down), lit by a
    sun that reaches all three faces (so nothing casts a shadow), path traced at 400 x 300,
    32 spp, denoised: FLD finds the three creases and the surfels' scan points each land on one
    face."""
    corner = np.array([0.0, 0.5, 3.0])  # where the creases meet, 0.575 m below the camera
    s = np.sqrt(0.5)
    material = material_xml("m", 0.7, preset="drywall")
    sun = ('<emitter type="directional"><vector name="direction" x="0.537" y="0.447" z="0.716"/>'
           '<rgb name="irradiance" value="1"/></emitter>')
    scene = mitsonar.load_scene(scene_file(
        "corner", material, sun,
        # left wall, right wall, floor
        spanned_rectangle_xml("m", corner + [-3 * s, 0, -3 * s], [0, 1, 0], [1, 0, 1], (6, 4.3)),
        spanned_rectangle_xml("m", corner + [3 * s, 0, -3 * s], [-1, 0, 1], [0, 1, 0], (4.3, 6)),
        spanned_rectangle_xml("m", corner, [1, 0, 0], [0, 0, 1], (10, 10))))
    camera = CameraModel(spp=32).at_resolution(400)
    images = CameraRenderer(scene, camera).render(IDENTITY, seed=0)
    gray = (images.gray / images.gray.max()) ** (1 / 2.2)  # display-like tone map
    box = fov_crop_box(camera, GEOMETRY)
    segments = detect_segments(gray, box, min_length=50.0 * 400 / 1600)

    junction = camera.project(corner - camera.offset)  # (200, 213.9)
    far = camera.project(corner + np.array([[0.0, -5.0, 0.0], [-2.5, 0.0, -2.5], [2.5, 0.0, -2.5]])
                         - camera.offset)  # far along each crease (up, towards the camera)
    expected = np.array([clip_to_box(junction, p, box) for p in far])
    assert len(segments) == 3
    for e in expected:  # raw 32 spp images, seeds 0-4: noise shortened ends by up to 9 px
        across, covered = np.array([offset_and_cover(f, e) for f in segments]).T
        k = np.argmin(across)
        assert across[k] <= 1.5 and covered[k] >= 0.9  # seed 0: <= 0.25 px, >= 0.98

    surfels = triangle_surfels(segments)
    assert len(surfels) == 3  # the vertex is where the lines cross: seed 0 <= 0.3 px off
    np.testing.assert_allclose(surfels.vertices[:, 0], np.tile(junction, (3, 1)), atol=1.5)
    quads = np.floor(scan_pixels(surfels.vertices)).astype(int)
    faces = images.shape_index[quads[..., 1], quads[..., 0]]  # (3 surfels, 4 points)
    assert np.all(faces == faces[:, :1]) and sorted(faces[:, 0]) == [0, 1, 2]


def test_segments_are_clipped_to_the_box_and_reach_its_edges():
    """Clipping keeps the inside part (crossing, inside, along a side), drops the outside ones;
    an edge running off the crop is detected up to the crop's border (FLD sees 8 px beyond it),
    not a few pixels short of it."""
    clipped = clip_segments([[0, 5, 20, 5], [5, -5, 5, 25], [30, 30, 40, 40], [2, 2, 8, 8],
                             [15, 0, 15, 20]], (1, 0, 10, 10))
    np.testing.assert_allclose(clipped, [[1, 5, 10, 5], [5, 0, 5, 10], [2, 2, 8, 8]])
    img = np.full((200, 300), 60, np.uint8)
    img[100:] = 200  # a horizontal step across the whole image
    segments = detect_segments(img, (20, 20, 280, 180))
    assert len(segments) == 1
    np.testing.assert_allclose(segments[0, [0, 2]], [20, 280], atol=0.01)


def faint_corner(slope: float, noise: float, seed: int = 0) -> np.ndarray:
    """A 320 x 240 float image in [0, 1] of two walls meeting at a vertical crease u = 160 (a
    pixel edge) with no step in brightness: the shading falls by ``slope`` grey levels (of
    255) per pixel towards the crease from both sides (mid-grey there), as two walls of one
    paint under ceiling lights; Gaussian ``noise`` [grey levels], as a denoised render's."""
    u = np.arange(320) + 0.5
    row = 0.45 + slope / 255.0 * np.abs(u - 160.0)
    rng = np.random.default_rng(seed)
    return np.tile(row, (240, 1)) + rng.normal(0.0, noise / 255.0, (240, 320))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_crease_with_no_step_is_found_by_its_shading_slope(seed):
    """The slope changes by 1 grey level per pixel across the crease (0.5 each side: the
    wall-wall creases of room_glass under its ceiling panels change by 0.6-1), under 0.4 grey
    levels of noise: the step detector alone finds nothing; with the shading-slope creases
    (SLOPE_SIGMA 2 px, threshold 6 times the median strength) exactly the crease, its ends
    within 1 px of it over 90 % of its length or more (seeds 0-2: within 0.6 px, 99.6 %; the
    detection ends near 0.35 grey levels per pixel each side: at 0.25 only broken pieces)."""
    image = faint_corner(0.5, 0.4, seed)
    assert len(detect_segments(image, min_length=20, slope_sigma=None)) == 0
    found = detect_segments(image, min_length=20)
    assert len(found) == 1
    across, covered = offset_and_cover(found[0], np.array([160.0, 0.0, 160.0, 240.0]))
    assert across <= 1.0 and covered >= 0.9


def test_shading_slope_ignores_noise_and_plain_steps():
    """Noise alone (0.4 grey levels, no crease) gives no segment; a plain 20-level step gives
    one segment on the step, not three (its flanks, +-sigma off it, are left to the step
    detector): within 1 px (0.51 px here, as the step detector alone)."""
    rng = np.random.default_rng(5)
    assert len(detect_segments(0.5 + rng.normal(0, 0.4 / 255, (240, 320)), min_length=20)) == 0
    step = np.where(np.arange(320) < 160, 0.4, 0.4 + 20 / 255)[None, :].repeat(240, axis=0)
    found = detect_segments(step + rng.normal(0, 0.4 / 255, step.shape), min_length=20)
    assert len(found) == 1
    across, covered = offset_and_cover(found[0], np.array([160.0, 0.0, 160.0, 240.0]))
    assert across <= 1.0 and covered >= 0.9
