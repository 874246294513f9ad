"""OFDM cycles and scans with shared hits (one trace and one synthesis per cycle or scan)
against the per-beam reference (each beam traced in its own cone), and the moved array's reuse
of hits against re-tracing."""

from dataclasses import replace

import numpy as np
import pytest

import mitsonar
from helpers import IDENTITY
from mitsonar.frames import direction_from_fov_angles
from mitsonar.scene.xml import material_xml, rectangle_xml, sphere_xml, write_scene
from mitsonar.sensors.ofdm_sonar import OfdmSonar, _pose_groups

#: Broadband transducers (every element pair gridded) and the default narrow-band ones.
TRANSDUCERS = {"broadband": mitsonar.Transducer(bandwidth_6db=20e3),
               "narrow-band": mitsonar.Transducer()}


def two_targets(scene_file, transducer):
    """Two metal spheres (specular: no speckle, so both traces converge to the same echoes) in
    front of 6 beams (one cycle), 20 deg apart; quiet receiver."""
    targets = direction_from_fov_angles(np.radians([0.0, 20.0]), np.radians([10.0, -10.0]))
    path = scene_file("targets", material_xml("t", preset="metal", scattering=0.0),
                      sphere_xml("t", 2.0 * targets[0], 0.1),
                      sphere_xml("t", 2.6 * targets[1], 0.15))
    hh, vv = np.meshgrid(np.radians([-20.0, 0.0, 20.0]), np.radians([-10.0, 10.0]))
    config = mitsonar.SonarConfig(transducer=transducer, noise_rms=1e-4)
    return path, config, direction_from_fov_angles(hh.ravel(), vv.ravel())


@pytest.mark.parametrize("kind, step, rays, found", [("broadband", 2.0, 96, 2),
                                                     ("narrow-band", 1.0, 160, 2)])
def test_shared_hits_frame_matches_per_beam_tracing(scene_file, kind, step, rays, found):
    """The shared path against every beam traced alone over a 60 deg cone (the union's extent,
    so both carry the same transmit side lobes; rays^2 per beam): the same decision on every
    beam, depths within 1 mm (measured 0.6 mm broadband; narrow-band 0.4 mm, its long echoes
    of the 10 cm sphere need 1 deg rays: 2.9 mm at the default 2 deg), the cycle's echo energy
    within 1 dB (measured 0.2 dB and 0.8 dB). Narrow-band, both spheres are found (within 1.5 mm
    of their surfaces) since the part balance compares each tone relative to what the code's own
    echo leaves in its filter (before, one sphere's own echo failed it: one beam was found)."""
    path, config, directions = two_targets(scene_file, TRANSDUCERS[kind])
    config = replace(config, trace=replace(config.trace, shared_ray_step=np.radians(step)))
    wide = replace(config, trace=replace(config.trace, cone_half_angle=np.radians(60.0),
                                         rays_per_axis=rays))
    shared = OfdmSonar(mitsonar.Sonar(path, config), shared_hits=True)
    reference = OfdmSonar(mitsonar.Sonar(path, wide), shared_hits=False)
    schedule = shared.schedule(directions)
    ours = shared.frame(schedule, lambda t: IDENTITY)
    theirs = reference.frame(schedule, lambda t: IDENTITY)
    assert ours.detected.sum() == found, ours.depth
    np.testing.assert_array_equal(ours.detected, theirs.detected)
    assert np.max(np.abs(ours.depth - theirs.depth)[ours.detected]) <= 1e-3

    beams = np.arange(len(directions))
    poses = [IDENTITY] * len(beams)
    codes = [schedule.codes[k] for k in schedule.code_index]
    args = (beams, poses, directions, schedule.transmit_time, codes, 0)
    energy = [np.sum(np.abs(spectrum) ** 2) for spectrum in
              (shared._shared_echoes(*args)[0], reference._beam_echoes(*args, apart=False))]
    assert abs(10 * np.log10(energy[0] / energy[1])) <= 1.0


def test_moved_array_reuses_hits_as_retracing_would(scene_file):
    """The first beam fired at rest, the others 3 cm further and turned 1 deg (two pose groups):
    reusing the hits traced from the first pose with the array moved gives the decisions and
    depths (within 1 mm; measured 0.47 mm) of tracing again from the moved pose."""
    path, config, directions = two_targets(scene_file, TRANSDUCERS["broadband"])
    moved = mitsonar.Pose.planar(0.03, 0.0, np.radians(1.0))

    def pose_at(t):
        return IDENTITY if t <= 0.0 else moved

    frames, traces = [], []
    for retrace in ((0.05, np.radians(2.0)), (0.0, 0.0)):
        ofdm = OfdmSonar(mitsonar.Sonar(path, config), shared_hits=True,
                         retrace_tolerance=retrace)
        tracer = ofdm.sonar.tracer
        traced = []
        trace_union = tracer.trace_union
        tracer.trace_union = lambda pose, *args: traced.append(pose) or trace_union(pose, *args)
        frames.append(ofdm.frame(ofdm.schedule(directions), pose_at))
        traces.append(len(traced))
    assert traces == [1, 2]  # reused once, traced again once
    reuse, retraced = frames
    assert reuse.detected.sum() == 2
    np.testing.assert_array_equal(reuse.detected, retraced.detected)
    assert np.max(np.abs(reuse.depth - retraced.depth)[reuse.detected]) <= 1e-3
    np.testing.assert_allclose(reuse.world_from_sensor, retraced.world_from_sensor)


def test_beams_fired_from_nearby_poses_form_one_group():
    """Consecutive poses within the tolerance of their group's first form one group."""
    poses = [mitsonar.Pose.planar(x, 0.0, 0.0) for x in (0.0, 0.004, 0.009, 0.012, 0.03)]
    assert _pose_groups(poses, (0.01, np.radians(0.5))) == [[0, 1, 2], [3], [4]]
    turned = [mitsonar.Pose.planar(0.0, 0.0, yaw) for yaw in np.radians([0.0, 0.4, 0.6])]
    assert _pose_groups(turned, (0.01, np.radians(0.5))) == [[0, 1], [2]]


@pytest.mark.parametrize("name", ["pose_tolerance", "retrace_tolerance"])
def test_negative_tolerances_are_refused_by_name(scene_file, name):
    """A negative distance or angle of either tolerance: one error naming it."""
    path, config, _ = two_targets(scene_file, TRANSDUCERS["narrow-band"])
    sonar = mitsonar.Sonar(path, config)
    for bad in ((-1.0, 0.0), (0.0, -0.1)):
        with pytest.raises(ValueError, match=name):
            OfdmSonar(sonar, **{name: bad})


@pytest.mark.parametrize("kind, depth_tolerance", [("broadband", 1e-3), ("narrow-band", 1.5e-3)])
def test_shared_hits_scan_matches_per_beam_tracing(scene_file, kind, depth_tolerance):
    """A scan with shared hits (one trace of the union, every element pair gridded once, each
    ping the channels driven by its steering) against every beam traced alone over a 60 deg
    cone, both on 1 deg rays (the spheres' glints need them: at 2 deg one amplitude is 3 dB
    off): the same decision on every beam, both spheres found, depths within 1 mm broadband
    (measured 0.62 mm) and 1.5 mm narrow-band (measured 0.97 mm: the per-beam path merges each
    patch's transmit elements about the carrier, the shared path grids every pair), amplitudes
    within 1 dB (measured 0.5 and 0.6 dB)."""
    path, config, directions = two_targets(scene_file, TRANSDUCERS[kind])
    config = replace(config, trace=replace(config.trace, shared_ray_step=np.radians(1.0)))
    wide = replace(config, trace=replace(config.trace, cone_half_angle=np.radians(60.0),
                                         rays_per_axis=160))
    ours = mitsonar.Sonar(path, config).scan(IDENTITY, directions, shared_hits=True)
    theirs = mitsonar.Sonar(path, wide).scan(IDENTITY, directions)
    assert ours.detected.sum() == 2, ours.depth
    np.testing.assert_array_equal(ours.detected, theirs.detected)
    assert np.max(np.abs(ours.depth - theirs.depth)[ours.detected]) <= depth_tolerance
    ratio = ours.amplitude[ours.detected] / theirs.amplitude[ours.detected]
    assert np.all(np.abs(20 * np.log10(ratio)) <= 1.0), ratio


@pytest.mark.parametrize("transducer", TRANSDUCERS.values(), ids=TRANSDUCERS.keys())
def test_shared_scan_direct_paths_and_noise_are_the_per_beam_scans(tmp_path, transducer):
    """Nothing in front (a wall behind the array): a ping's recording is its direct paths and
    noise. Noiseless, the unsteered direct paths gridded once and driven by each ping's
    steering give the steered paths' recordings within 2e-4 of their peak (measured 5e-5
    narrow-band, 8e-5 broadband; the kernel's tolerance is 3e-5 of each path). With noise,
    the same seed adds the same noise as per beam (within the recordings' single-precision
    rounding, 1e-2 of its RMS), another seed other noise."""
    path = write_scene(tmp_path / "behind.xml", material_xml("w", preset="drywall"),
                       rectangle_xml("w", (0, 0, -2.0)))
    hh, vv = np.meshgrid(np.radians([-30.0, 0.0, 25.0]), np.radians([-20.0, 0.0, 20.0]))
    directions = direction_from_fov_angles(hh.ravel(), vv.ravel())
    config = mitsonar.SonarConfig(transducer=transducer)
    noisy, quiet = (mitsonar.Sonar(path, c) for c in (config, replace(config, noise_rms=0.0)))
    shared, per_beam = (quiet.scan(IDENTITY, directions, shared_hits=s).echoes
                        for s in (True, False))
    assert np.abs(shared - per_beam).max() <= 2e-4 * np.abs(per_beam).max()
    noise = {(seed, s): noisy.scan(IDENTITY, directions, seed=seed, shared_hits=s).echoes
             - (shared if s else per_beam) for seed in (4, 5) for s in (True, False)}
    rms = np.std(noise[4, False])
    assert rms > 0
    assert np.abs(noise[4, True] - noise[4, False]).max() <= 1e-2 * rms
    assert np.std(noise[5, True] - noise[4, True]) > rms


def test_shared_scan_of_point_reflectors_traces_each_beam(scene_file):
    """The paper model's point reflectors are placed per beam (the tracer cannot share them):
    a scan asked for shared hits is the per-beam scan, bit for bit."""
    path, _, directions = two_targets(scene_file, TRANSDUCERS["narrow-band"])
    sonar = mitsonar.Sonar(path, mitsonar.SonarConfig.preset("paper"))
    assert not sonar.tracer.shares_hits()
    shared = sonar.scan(IDENTITY, directions, seed=2, shared_hits=True)
    np.testing.assert_array_equal(shared.echoes, sonar.scan(IDENTITY, directions, seed=2).echoes)


@pytest.mark.parametrize("shared_hits", [False, True], ids=["per beam", "shared hits"])
def test_a_scan_of_no_beam_is_refused(scene_file, shared_hits):
    """No direction: one error saying so, on either path."""
    path, config, _ = two_targets(scene_file, TRANSDUCERS["narrow-band"])
    with pytest.raises(ValueError, match="at least one beam direction"):
        mitsonar.Sonar(path, config).scan(IDENTITY, np.zeros((0, 3)), shared_hits=shared_hits)
