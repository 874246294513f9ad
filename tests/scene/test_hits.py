"""First hits from Mitsuba's preliminary intersection (mitsonar.scene.hits) against Mitsuba's own
surface interaction, on every kind of shape the scenes use, turned and stretched."""

from __future__ import annotations

import numpy as np
import pytest

from mitsonar.scene.hits import SceneHits
from mitsonar.scene.loading import load_scene, mitsuba
from mitsonar.scene.rays import rays
from mitsonar.scene.xml import material_xml, rectangle_xml, sphere_xml

#: Every kind of shape: meshes (rectangle, cube) and the analytic disk, sphere and cylinder,
#: turned about unit axes, moved and (but the sphere) stretched unevenly.
SHAPES = (
    rectangle_xml("m", (0.0, 0.0, 3.0), (20, 35, 10), (1.5, 0.8)),
    '<shape type="cube"><transform name="to_world"><scale x="0.3" y="0.5" z="0.2"/>'
    '<rotate x="0.6" y="0.8" z="0" angle="30"/><translate x="-1.2" y="0.4" z="2.5"/></transform>'
    '<ref id="m"/></shape>',
    '<shape type="disk"><transform name="to_world"><scale x="0.6" y="0.3"/>'
    '<rotate x="0" y="0.6" z="0.8" angle="50"/><translate x="1.3" y="-0.5" z="2.2"/></transform>'
    '<ref id="m"/></shape>',
    sphere_xml("m", (0.9, 0.9, 2.0), 0.35),
    '<shape type="cylinder"><point name="p0" x="-0.8" y="-1.0" z="1.6"/>'
    '<point name="p1" x="-0.2" y="-0.6" z="2.4"/><float name="radius" value="0.25"/>'
    '<ref id="m"/></shape>',
)


def _mitsubas(scene, origins, directions):
    """t (inf: miss), point, geometric normal and shape index by ``ray_intersect``."""
    import drjit as dr

    mi = mitsuba()
    si = scene.scene.ray_intersect(rays(origins, directions), ray_flags=mi.RayFlags.Minimal,
                                 coherent=False)
    valid = np.asarray(si.is_valid(), bool)
    dr.eval(si.t, si.p, si.n, si.shape)
    reg = np.asarray(dr.reinterpret_array(mi.UInt32, si.shape), dtype=np.int64)
    index = {int(r): k for k, r in enumerate(scene.registry_ids)}
    shape = np.array([index.get(int(r), -1) if v else -1 for r, v in zip(reg, valid)])
    return (np.where(valid, np.asarray(si.t, float), np.inf), np.asarray(si.p, float).T,
            np.asarray(si.n, float).T, shape)


@pytest.fixture(scope="module")
def shapes_scene(tmp_path_factory):
    path = tmp_path_factory.mktemp("hits") / "shapes.xml"
    path.write_text('<scene version="3.0.0">' + material_xml("m", 0.5, preset="concrete")
                    + "".join(SHAPES) + "</scene>")
    scene = load_scene(path)
    rng = np.random.default_rng(7)
    origins = rng.uniform((-2.5, -2.0, -0.5), (2.5, 2.0, 0.5), (40_000, 3))
    targets = rng.uniform((-1.6, -1.4, 1.4), (1.8, 1.4, 3.4), (40_000, 3))
    directions = targets - origins
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    return scene, origins, directions


@pytest.mark.parametrize("tabulated", [True, False])
def test_first_hits_are_mitsubas(shapes_scene, tabulated):
    """The same distance and shape for every ray, points within 1e-5 m and normals within 1e-6
    (single-precision rounding: Mitsuba's are float32) with Mitsuba's sign, on every kind of
    shape; ``tabulated=False`` is the path of scenes holding other shapes (``ray_intersect``)."""
    scene, origins, directions = shapes_scene
    hits = SceneHits(scene)
    assert hits.tabulated
    hits.tabulated = tabulated
    t, point, normal, shape = hits.first(origins, directions)
    t_ref, point_ref, normal_ref, shape_ref = _mitsubas(scene, origins, directions)
    on = np.isfinite(t_ref)
    kinds = np.array([s.class_name() for s in scene.scene.shapes()])
    counts = {k: int(np.sum(kinds[shape_ref[on]] == k)) for k in kinds}
    assert min(counts.values()) >= 100, counts  # every kind of shape is tested
    np.testing.assert_array_equal(shape, shape_ref)
    np.testing.assert_array_equal(t, t_ref)
    assert np.abs(point[on] - point_ref[on]).max() < 1e-5
    agreement = np.einsum("ij,ij->i", normal[on], normal_ref[on])
    assert agreement.min() > 1 - 1e-6
    assert np.allclose(np.linalg.norm(normal[on], axis=1), 1.0)


def test_a_sheared_disk_gets_the_normal_of_the_plane_its_hits_span(tmp_path):
    """A disk turned about an unnormalised axis (Mitsuba's ``rotate`` does not normalise it, so
    its to_world M shears the disk): its hit points lie in the plane normal to M (0, 0, 1), and
    so does the normal (M^-T (0, 0, 1), a plane normal's usual transform, is 3 deg off it)."""
    path = tmp_path / "disk.xml"
    path.write_text('<scene version="3.0.0">' + material_xml("m", 0.5, preset="concrete")
                    + SHAPES[2].replace('y="0.6" z="0.8"', 'y="1" z="1"') + "</scene>")
    scene = load_scene(path)
    rng = np.random.default_rng(3)
    targets = rng.uniform((0.9, -0.9, 1.8), (1.7, -0.1, 2.6), (2_000, 3))
    directions = targets / np.linalg.norm(targets, axis=1, keepdims=True)
    t, point, normal, shape = SceneHits(scene).first(np.zeros((2_000, 3)), directions)
    on = shape == 0
    assert on.sum() > 100
    spread = point[on] - point[on].mean(axis=0)
    assert np.abs(spread @ normal[on][0]).max() < 1e-5 * np.abs(spread).max()
    assert np.ptp(normal[on], axis=0).max() < 1e-12  # one plane, one normal
