"""Scene XML pieces written in code: they load, carry their ids and sit where they say."""

import numpy as np

from mitsonar.scene.loading import load_scene
from mitsonar.scene.mesh import scene_mesh
from mitsonar.scene.xml import (material_xml, rectangle_xml, spanned_rectangle_xml, sphere_xml,
                                write_scene)


def test_every_piece_loads_where_it_says(tmp_path):
    path = write_scene(tmp_path / "pieces.xml",
                       material_xml("wall", 0.5, preset="drywall"),
                       material_xml("panel", "0.2, 0.4, 0.6", impedance=2e6, scattering=0.1),
                       rectangle_xml("wall", (1.0, 2.0, 3.0), (0, 90, 0), size=(2.0, 4.0),
                                     shape_id="tilted"),
                       spanned_rectangle_xml("panel", (0, 0, -1.0), [2, 0, 0], [0, 0, 1],
                                             (0.5, 0.25), shape_id="spanned"),
                       sphere_xml("wall", (0, 5.0, 0), 0.5, shape_id="ball"))
    assert path == str(tmp_path / "pieces.xml")
    scene = load_scene(path)
    mesh = scene_mesh(scene)
    assert scene.shape_ids == ["tilted", "spanned", "ball"]
    names = [scene.materials[i].name for i in scene.shape_material]
    assert names == ["wall", "panel", "wall"]
    assert scene.materials[scene.shape_material[1]].impedance == 2e6

    def box(k):
        v = mesh.vertices[np.unique(mesh.triangles[mesh.triangle_shape == k])]
        return v.min(axis=0), v.max(axis=0)

    # 2 m x 4 m, turned 90 deg about y: its x extent becomes z; normal +z -> +x
    np.testing.assert_allclose(box(0), [[1.0, 0.0, 2.0], [1.0, 4.0, 4.0]], atol=1e-6)
    np.testing.assert_allclose(mesh.triangle_normals()[mesh.triangle_shape == 0], [[1, 0, 0]] * 2,
                               atol=1e-6)
    # +-0.5 m along x, +-0.25 m along z, lit side towards x cross z = -y
    np.testing.assert_allclose(box(1), [[-0.5, 0, -1.25], [0.5, 0, -0.75]], atol=1e-6)
    np.testing.assert_allclose(mesh.triangle_normals()[mesh.triangle_shape == 1], [[0, -1, 0]] * 2,
                               atol=1e-6)
    np.testing.assert_allclose(box(2), [[-0.5, 4.5, -0.5], [0.5, 5.5, 0.5]], atol=1e-3)


def test_shapes_without_an_id_have_no_id_attribute():
    for xml in (rectangle_xml("m", (0, 0, 0)), spanned_rectangle_xml("m", (0, 0, 0), [1, 0, 0],
                                                                   [0, 1, 0], (1, 1)),
                sphere_xml("m", (0, 0, 0), 1.0)):
        assert xml.startswith("<shape type=") and " id=" not in xml.split(">")[0]
