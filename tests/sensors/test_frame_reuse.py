"""A second Sonar (same or another scene) and later frames reuse what the first frame of the
process built: Dr.Jit's kernels (no kernel the process has not launched, so none to compile),
the frozen functions' recordings (module level) and the OFDM codes' system responses (kept per
value for the process, not per synthesizer)."""

from dataclasses import replace

import drjit as dr
import numpy as np
import pytest

import mitsonar
from helpers import IDENTITY
from mitsonar.frames import direction_from_fov_angles
from mitsonar.scene.xml import material_xml, sphere_xml
from mitsonar.sensors.ofdm_sonar import OfdmSonar
from mitsonar.signal import band as band_module
from mitsonar.signal.band import Band, code_response
from mitsonar.signal.gridding import pair_kernel, spread_kernel
from mitsonar.trace.element_factors import _kernel as _factors_kernel
from mitsonar.trace.hitpaths import _merge_kernel

#: The frozen kernels of a frame.
FROZEN = (_factors_kernel, _merge_kernel, spread_kernel, pair_kernel)


def target_scene(scene_file, name, distance):
    """A metal sphere of 0.15 m radius ``distance`` [m] ahead."""
    return scene_file(name, material_xml("t", preset="metal", scattering=0.0),
                      sphere_xml("t", [0.0, 0.0, distance], 0.15))


def frame_and_kernels(ofdm, schedule):
    """The frame of ``ofdm`` and the hashes of the Dr.Jit kernels it launched (a kernel whose
    hash was not launched before is compiled, or loaded from Dr.Jit's disk cache)."""
    with dr.scoped_set_flag(dr.JitFlag.KernelHistory, True):
        dr.kernel_history()  # empties the history
        frame = ofdm.frame(schedule, lambda t: IDENTITY)
        history = dr.kernel_history()
    return frame, {k["hash"] for k in history if k["type"] == dr.KernelType.JIT}


@pytest.mark.parametrize("shared, bandwidth", [(False, None), (True, 20e3)])
def test_new_sonars_launch_no_new_kernel_and_record_no_function(scene_file, shared, bandwidth):
    """After a Sonar's first two frames (the first records the frozen functions, the second
    replays them), a new Sonar on the same scene records no frozen function again and gives the
    same decisions and depths bit for bit; a Sonar on another scene (the sphere farther: other
    ray and patch counts, firing offsets, fixed-point scales and windows, which as kernel
    literals made new kernels) launches no kernel the others did not (none to compile); and
    neither computes a code's system response again. The per-beam path with the default
    transducers (merged paths), the shared one with broadband ones (every element pair)."""
    config = mitsonar.SonarConfig(noise_rms=1e-4)
    if bandwidth is not None:
        config = replace(config, transducer=mitsonar.Transducer(bandwidth_6db=bandwidth))
    near, far = target_scene(scene_file, "near", 1.5), target_scene(scene_file, "far", 2.5)
    directions = direction_from_fov_angles(np.radians([-10.0, 0.0, 10.0]), np.zeros(3))
    first = OfdmSonar(mitsonar.Sonar(near, config), shared_hits=shared)
    schedule = first.schedule(directions)
    # The same flags in every frame: Dr.Jit's flags are part of a frozen function's key.
    reference, kernels = frame_and_kernels(first, schedule)
    assert reference.detected.sum() >= 1
    kernels |= frame_and_kernels(first, schedule)[1]
    recordings = [kernel().frozen.n_recordings for kernel in FROZEN]
    responses = len(band_module._responses)

    frame, launched = frame_and_kernels(
        OfdmSonar(mitsonar.Sonar(near, config), shared_hits=shared), schedule)
    kernels |= launched
    np.testing.assert_array_equal(frame.detected, reference.detected)
    np.testing.assert_array_equal(frame.depth, reference.depth)
    assert [kernel().frozen.n_recordings for kernel in FROZEN] == recordings

    frame, launched = frame_and_kernels(
        OfdmSonar(mitsonar.Sonar(far, config), shared_hits=shared), schedule)
    assert frame.detected.sum() == reference.detected.sum()
    assert launched - kernels == set()
    assert [kernel().frozen.n_recordings for kernel in FROZEN] == recordings
    assert len(band_module._responses) == responses


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
