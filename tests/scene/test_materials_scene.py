"""Acoustic materials, the acoustic BSDF plugin and scene loading, including bad input."""

import warnings

import numpy as np
import pytest

import mitsonar
from mitsonar.scene.loading import DefaultMaterialWarning, SceneError
from mitsonar.scene.xml import material_xml, rectangle_xml

Z_AIR = mitsonar.Medium().impedance


def test_normal_incidence_reflection_is_impedance_ratio():
    for name in ("concrete", "glass", "drywall", "wood", "metal"):
        m = mitsonar.preset(name)
        r = m.reflection_coefficient(1.0, Z_AIR)
        assert r == pytest.approx((m.impedance - Z_AIR) / (m.impedance + Z_AIR), rel=1e-12)
        assert 0.999 < r < 1.0
    custom = mitsonar.AcousticMaterial("light", impedance=3 * Z_AIR)
    assert custom.reflection_coefficient(1.0, Z_AIR) == pytest.approx(0.5)


def test_absorption_defined_materials_keep_their_energy_balance():
    for name in ("foam", "fabric"):
        m = mitsonar.preset(name)
        r = m.reflection_coefficient(1.0, Z_AIR)
        assert r**2 == pytest.approx(1 - m.absorption, rel=1e-12)
    assert mitsonar.preset("foam").reflection_coefficient(1.0, Z_AIR) < 0.3
    assert mitsonar.preset("fabric").reflection_coefficient(1.0, Z_AIR) < 0.65


@pytest.mark.parametrize("kwargs,field", [
    ({"impedance": -5.0}, "impedance"), ({"impedance": np.nan}, "impedance"),
    ({"absorption": 1.5}, "absorption"), ({"impedance": 1e6, "scattering": -0.1}, "scattering"),
    ({}, "exactly one"), ({"impedance": 1e6, "absorption": 0.5}, "exactly one")])
def test_material_validation_names_material_and_field(kwargs, field):
    with pytest.raises(ValueError, match=f"'slab'.*{field}"):
        mitsonar.AcousticMaterial("slab", **kwargs)


def test_unknown_preset_lists_known_ones():
    with pytest.raises(ValueError, match="unknown acoustic preset 'marble'.*concrete"):
        mitsonar.preset("marble")


def test_scene_materials_are_read_from_the_plugin(scene_file):
    path = scene_file("two", material_xml("pane", preset="glass", scattering=0.0),
                      material_xml("panel", impedance=2e6, scattering=0.3),
                      rectangle_xml("pane", (0, 0, 2), shape_id="window"),
                      rectangle_xml("panel", (0, 0, 3), shape_id="wall"))
    scene = mitsonar.load_scene(path)
    by_shape = {sid: scene.materials[i] for sid, i in zip(scene.shape_ids, scene.shape_material)}
    assert by_shape["window"].impedance == mitsonar.preset("glass").impedance
    assert by_shape["window"].scattering == 0.0  # explicit value overrides the preset
    assert by_shape["wall"].impedance == 2e6 and by_shape["wall"].scattering == 0.3


def test_plain_mitsuba_scene_gets_default_material_with_one_warning(scene_file):
    path = scene_file("plain", '<bsdf type="diffuse" id="grey"/>',
                      rectangle_xml("grey", (0, 0, 2), shape_id="left"),
                      rectangle_xml("grey", (0, 0, 3), shape_id="right"))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = mitsonar.load_scene(path)
    ours = [w for w in caught if issubclass(w.category, DefaultMaterialWarning)]
    assert len(ours) == 1
    assert "left" in str(ours[0].message) and "right" in str(ours[0].message)
    assert {m.name for m in scene.materials} == {"drywall"}


@pytest.mark.parametrize("props,message", [
    ({"impedance": -1.0}, "impedance"), ({"preset": "marble"}, "marble"),
    ({"impedance": "nan"}, "impedance"), ({"colour": 3.0}, "unknown properties"),
    ({"scattering": 0.2}, "preset")])
def test_invalid_material_in_file_names_file_and_material(scene_file, props, message):
    path = scene_file("bad", material_xml("broken_wall", **props), rectangle_xml("broken_wall", (0, 0, 2)))
    with pytest.raises(SceneError) as err:
        mitsonar.load_scene(path)
    text = str(err.value)
    assert "bad.xml" in text and "broken_wall" in text and message in text
    assert "Traceback" not in text and "\n" not in text  # Mitsuba's wrapping removed


def test_malformed_xml_names_the_file(tmp_path):
    path = tmp_path / "broken.xml"
    path.write_text('<scene version="3.0.0"><shape type="rectangle">\n</scene>')
    with pytest.raises(SceneError, match="broken.xml"):
        mitsonar.load_scene(path)
    with pytest.raises(SceneError, match="not found"):
        mitsonar.load_scene(tmp_path / "missing.xml")
