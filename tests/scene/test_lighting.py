"""The scenes' two looks (mitsonar.scene.building.lights): the key look's lights against the
irradiance they must give, its shadows, and the camera images it gives (deterministic, walls
facing different ways differ in brightness)."""

import numpy as np
import pytest

import mitsonar
from mitsonar.scene.building.lights import (AMBIENT_IRRADIANCE, FILL_DIRECTION, FILL_IRRADIANCE,
                                            KEY_DIRECTION, KEY_IRRADIANCE, PANEL_RADIANCE,
                                            ceiling_lights)
from mitsonar.scene.building.materials import Material
from mitsonar.scene.building.shapes import block, rectangle
from mitsonar.scene.building.shell import enclosure
from mitsonar.scene.building.spec import SceneSpec
from mitsonar.scene.loading import SceneError
from mitsonar.sensors.camera import CameraModel, CameraRenderer
from mitsonar.frames import Pose

WALL, FLOOR = 0.7, 0.4
#: The raw estimate at many samples (its mean is the expectation), and the default pipeline.
RAW = CameraModel(spp=128, denoise=False).at_resolution(96)
CAMERA = CameraModel(spp=8).at_resolution(96)
#: Robot at (-0.5, -0.5) facing the north-east corner (2, 2) of the room below.
CORNER_VIEW = Pose.sensor_on_robot(-0.5, -0.5, np.radians(45.0))


def _room(tmp_path, lighting: str, panel: bool = False, cube: bool = False, pane: bool = False):
    """A 4 m x 4 m x 2.5 m room (x and y -2..2), grey walls and floor, in ``lighting``;
    optionally a ceiling panel at its centre, a 0.5 m cube on the floor at (0.5, -1) and a
    glass pane 1 m x 1 m at x = 1.5, its centre 1 m up."""
    spec = SceneSpec(f"room_{lighting}", "test room", height=2.5, lighting=lighting)
    spec.rooms = [{"id": "room", "x": (-2.0, 2.0), "y": (-2.0, 2.0)}]
    wall = spec.material(Material("paint", "drywall", rgb=(WALL,) * 3))
    floor = spec.material(Material("screed", "concrete", rgb=(FLOOR,) * 3))
    lights = [((-0.3, 0.3, -0.3, 0.3), PANEL_RADIANCE)] if panel else []
    enclosure(spec, (-2.0, 2.0, -2.0, 2.0), wall, floor, wall, lights=lights)
    spec.add(*ceiling_lights(lights, spec.height, wall))
    if cube:
        spec.add(block("cube", (0.25, 0.75), (-1.25, -0.75), (0.0, 0.5), wall, "furniture", "cube"))
    if pane:
        glass = spec.material(Material("pane_glass", "glass", optical="thindielectric", ior=1.5))
        spec.add(rectangle("pane", (1.5, 0.0, 1.0), (0, 0.5, 0), (0, 0, 0.5), glass, "furniture",
                           "pane"))
    return mitsonar.load_scene(spec.write(tmp_path))


def _irradiance(normal) -> float:
    """Irradiance [W/m^2] of the key look on a surface facing ``normal``, nothing shadowing."""
    toward = [-np.asarray(d) / np.linalg.norm(d) for d in (KEY_DIRECTION, FILL_DIRECTION)]
    return AMBIENT_IRRADIANCE + sum(e * max(0.0, float(np.dot(normal, t)))
                                    for e, t in zip((KEY_IRRADIANCE, FILL_IRRADIANCE), toward))


def _inner(mask) -> np.ndarray:
    """``mask`` (H, W) without its border pixels (antialiased across an edge)."""
    inner = mask.copy()
    inner[1:-1, 1:-1] &= mask[:-2, 1:-1] & mask[2:, 1:-1] & mask[1:-1, :-2] & mask[1:-1, 2:]
    return inner & np.pad(np.ones((mask.shape[0] - 2, mask.shape[1] - 2), bool), 1)


def _by_shape(scene, images, statistic=np.median) -> dict:
    """``statistic`` of the luminance of each shape's inner pixels, by shape id."""
    seen = np.unique(images.shape_index[images.shape_index >= 0])
    return {scene.shape_ids[k]: float(statistic(images.gray[_inner(images.shape_index == k)]))
            for k in seen}


def test_key_look_matches_the_irradiance_of_its_lights(tmp_path):
    """Direct light only, no panel: a diffuse surface of albedo rho shows rho E / pi with E the
    ambient term plus each light's irradiance times its cosine. The mean of the raw estimate
    over a surface's inner pixels (128 samples each; each sample lights a point by one light
    drawn at random) within 1.5 %: three standard errors."""
    scene = _room(tmp_path, "key")
    lum = _by_shape(scene, CameraRenderer(scene, RAW).render(CORNER_VIEW), np.mean)
    expected = {"wall_east": WALL * _irradiance([-1, 0, 0]) / np.pi,
                "wall_north": WALL * _irradiance([0, -1, 0]) / np.pi,
                "floor": FLOOR * _irradiance([0, 0, 1]) / np.pi}
    for shape, value in expected.items():
        assert lum[shape] == pytest.approx(value, rel=1.5e-2), shape
    # the two walls and the floor differ by 30 % and more at the corner
    assert lum["wall_north"] / lum["wall_east"] > 1.3
    assert lum["floor"] / lum["wall_north"] > 1.3


def test_key_light_is_shadowed_by_what_stands_in_the_room_only(tmp_path):
    """The east wall (on the key light's side) casts no shadow on the floor beside it, the cube
    does: floor points whose ray to the key light crosses the wall are lit as the open floor,
    those behind the cube get only the fill and the ambient term (means of the raw estimate,
    1.5 % and 3 %: three standard errors)."""
    scene = _room(tmp_path, "key", cube=True)
    renderer = CameraRenderer(scene, RAW)
    pose = Pose.sensor_on_robot(-1.5, -1.2, np.radians(10.0))
    images = renderer.render(pose)
    camera_pose = CAMERA.world_from_camera(pose)
    rays = CAMERA.pixel_rays()
    points = camera_pose.transform_points(rays * (images.depth / rays[..., 2])[..., None])
    floor = images.shape_index == scene.shape_ids.index("floor")
    toward = -np.asarray(KEY_DIRECTION) / np.linalg.norm(KEY_DIRECTION)
    # where the ray to the key light leaves the room through the east wall below 2.5 m
    through_wall = _inner(floor) & (points[..., 0] > 2.0 - 2.4 * toward[0] / toward[2]) \
        & (points[..., 1] > 0.0)  # clear of the cube's shadows (the fill's falls north-east)
    # the cube's shadow: rays to the key light that cross the cube
    step = points[..., :2] + (0.25 / toward[2]) * toward[:2]  # the ray at half the cube's height
    shadow = _inner(floor) & (np.abs(step[..., 0] - 0.5) < 0.2) & (np.abs(step[..., 1] + 1) < 0.2)
    assert through_wall.sum() > 50 and shadow.sum() > 10
    lit = FLOOR * _irradiance([0, 0, 1]) / np.pi
    assert np.mean(images.gray[through_wall]) == pytest.approx(lit, rel=1.5e-2)
    unlit = FLOOR * (_irradiance([0, 0, 1]) - KEY_IRRADIANCE * toward[2]) / np.pi
    assert np.mean(images.gray[shadow]) == pytest.approx(unlit, rel=3e-2)


def test_key_look_sees_through_glass(tmp_path):
    """Direct light only, yet the east wall seen through a glass pane is lit: 0.92 times the
    wall beside it (the pane's two surfaces pass 92 % at normal incidence: (1 - R)^2 / (1 - R^2)
    with R = 0.04 for n = 1.5; within 3 %: the rays cross it up to 15 deg off normal)."""
    scene = _room(tmp_path, "key", pane=True)
    images = CameraRenderer(scene, RAW).render(Pose.sensor_on_robot(-0.5, 0.0, 0.0))
    # what the camera sees first: the pane (the east wall behind it), the wall beside it
    seen_through = np.mean(images.gray[_inner(images.shape_index
                                              == scene.shape_ids.index("pane"))])
    beside = np.mean(images.gray[_inner(images.shape_index
                                        == scene.shape_ids.index("wall_east"))])
    r = 0.04
    assert seen_through / beside == pytest.approx((1 - r) ** 2 / (1 - r ** 2), rel=3e-2)


def test_key_look_images_are_deterministic_and_show_the_crease(tmp_path):
    """Same seed, same image, bit for bit. At the corner the denoised images of the key look
    show walls differing by more than 20 % (28 %: 38 % without the panel, whose light is the
    same on both); in the ceiling look, lit by the panel at the centre of the square room, the
    two walls are mirror images and meet with no step (under 3 %)."""
    key = _room(tmp_path, "key", panel=True)
    renderer = CameraRenderer(key, CAMERA)
    first, again = renderer.render(CORNER_VIEW, seed=3), renderer.render(CORNER_VIEW, seed=3)
    assert np.array_equal(first.rgb, again.rgb)
    assert not np.array_equal(first.rgb, renderer.render(CORNER_VIEW, seed=4).rgb)
    ceiling = _room(tmp_path, "ceiling", panel=True)
    steps = {}
    for name, scene in (("key", key), ("ceiling", ceiling)):
        lum = _by_shape(scene, CameraRenderer(scene, CAMERA).render(CORNER_VIEW, seed=3))
        steps[name] = abs(np.log(lum["wall_north"] / lum["wall_east"]))
    assert steps["key"] > np.log(1.2) and steps["ceiling"] < np.log(1.03)


def test_key_light_errors_name_the_emitter(tmp_path):
    scene = (tmp_path / "bad.xml")
    for body, message in (('<string name="rooms" value="0 1 0 1 0"/>', "rooms must be"),
                          ('<string name="rooms" value="1 0 0 1 0 1"/>', "rooms must be")):
        scene.write_text(
            '<scene version="3.0.0"><emitter type="key_light" id="sun_1">'
            '<vector name="direction" value="0, 0, -1"/><rgb name="irradiance" value="1, 1, 1"/>'
            f'{body}</emitter></scene>')
        with pytest.raises(SceneError, match=f"sun_1.*{message}"):
            mitsonar.load_scene(scene)


def test_scene_spec_rejects_an_unknown_lighting():
    with pytest.raises(ValueError, match="lighting must be one of"):
        SceneSpec("x", "x", height=2.5, lighting="sunset")


def test_a_varied_room_is_the_same_room_in_either_look():
    """The look changes the lights only: shapes, materials and ground truth are the same."""
    from mitsonar.scene.varied.room import varied_room

    key, ceiling = varied_room(3), varied_room(3, "ceiling")
    assert (key.lighting, ceiling.lighting) == ("key", "ceiling")
    assert key.ground_truth() == ceiling.ground_truth()
    assert key.xml("t") != ceiling.xml("t") and '<emitter type="key_light"' in key.xml("t")
