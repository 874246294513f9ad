"""A new Sonar on the same settings reuses what the first one computed: the OFDM codes' system
responses (kept per value for the process, not per synthesizer)."""

import numpy as np

import mitsonar
from mitsonar.scene.xml import material_xml, sphere_xml
from mitsonar.sensors.ofdm_sonar import OfdmSonar
from mitsonar.signal.band import Band, code_response


def target_scene(scene_file, name, distance):
    """A metal sphere of 0.15 m radius ``distance`` [m] ahead."""
    return scene_file(name, material_xml("t", preset="metal", scattering=0.0),
                      sphere_xml("t", [0.0, 0.0, distance], 0.15))


def test_code_response_is_computed_once_for_equal_bands(scene_file, monkeypatch):
    """Two Sonars' bands on the same settings share a code's response: computed once, the same
    values as the band's own."""
    path = target_scene(scene_file, "near", 1.5)
    bands = [OfdmSonar(mitsonar.Sonar(path)).band for _ in range(2)]
    code = OfdmSonar(mitsonar.Sonar(path)).schedule(np.array([[0.0, 0.0, 1.0]])).codes[0]
    frequencies = np.linspace(39e3, 41e3, 37) + np.pi  # a grid no other test asks for
    expected = bands[0].system_response(code, frequencies)
    calls = []
    original = Band.system_response
    monkeypatch.setattr(Band, "system_response",
                        lambda band, *args: calls.append(band) or original(band, *args))
    responses = [code_response(band, code, frequencies) for band in bands]
    assert len(calls) == 1
    assert responses[1] is responses[0]
    np.testing.assert_array_equal(responses[0], expected)
