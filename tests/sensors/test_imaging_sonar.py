"""Single-ping imaging (ImagingSonar) on traced scenes, and the tracer's transmit hook."""

from dataclasses import replace

import numpy as np
import pytest

import mitsonar
from helpers import BROADSIDE, IDENTITY
from mitsonar.evaluation.metrics import point_to_mesh
from mitsonar.evaluation.reference import image_paths, plane_images
from mitsonar.frames import direction_from_fov_angles
from mitsonar.scene.mesh import scene_mesh
from mitsonar.scene.xml import material_xml, rectangle_xml, sphere_xml, write_scene
from mitsonar.sensors.imaging_sonar import DEFOCUSED, ImagingSonar, TransmitSettings
from mitsonar.signal.imaging_settings import WIDE_SWEEP_SETTINGS, ImagingSettings
from mitsonar.trace.paths import Paths
from mitsonar.trace.tracer import AcousticTracer

#: Few rays for speed: 64 per axis over the 60 deg cone (1.9 deg apart, refined at edges).
FAST = TransmitSettings(rays_per_axis=64)
RADIUS = 0.1  # [m] of the spheres
RIGID = {"impedance": 1e12, "scattering": 0.0}


@pytest.fixture(scope="module")
def spheres(tmp_path_factory):
    """Five metal spheres at 1.2-2.9 m towards directions across the field of view, before a
    drywall at 3.8 m. Returns (imaging sonar, sphere centres (5, 3), ground-truth mesh)."""
    towards = direction_from_fov_angles(np.radians([-18, 12, 0, 22, -6]),
                                        np.radians([6, -10, 12, 8, -14]))
    centres = np.array([1.5, 2.0, 2.6, 1.2, 2.9])[:, None] * towards
    path = write_scene(tmp_path_factory.mktemp("spheres") / "spheres.xml",
                       material_xml("t", preset="metal", scattering=0.0),
                       material_xml("w", preset="drywall"),
                       *[sphere_xml("t", c, RADIUS) for c in centres],
                       rectangle_xml("w", (0, 0, 3.8), size=(8.0, 8.0)))
    sonar = mitsonar.Sonar(path)
    return ImagingSonar(sonar, transmit=FAST), centres, scene_mesh(sonar.scene)


def test_a_single_ping_finds_every_sphere_and_no_ghost(spheres):
    """Every sphere has a point within 5 mm of its surface and 1 deg of its direction (measured
    <= 2.2 mm); a ghost (a point more than 2 cm from every surface) is at most 10 % of the
    points (measured: none, over two seeds)."""
    imaging, centres, mesh = spheres
    for seed in (0, 1):
        image = imaging.image(IDENTITY, seed=seed)
        off_surface = np.linalg.norm(image.points_sensor[:, None] - centres[None], axis=-1) - RADIUS
        assert np.all(np.abs(off_surface).min(axis=0) <= 5e-3), np.abs(off_surface).min(axis=0)
        nearest = np.abs(off_surface).argmin(axis=0)
        towards = centres / np.linalg.norm(centres, axis=1, keepdims=True)
        cos = np.sum(image.direction[nearest] * towards, axis=1)
        assert np.all(cos >= np.cos(np.radians(1.0)))
        ghosts = point_to_mesh(image.points_world, mesh)[0] > 0.02
        assert ghosts.mean() <= 0.10, (ghosts.sum(), len(image))
        assert np.all(image.snr >= imaging.imager.settings.detection_snr)


def test_sector_pings_fire_as_from_their_virtual_sources(spheres):
    """'sectors': six pings a frame, each element of ping s fired when a spherical wave from its
    virtual source v_s would reach it; each ping's imager reports its own sector, placing from
    v_s (the placement itself: tests/signal/test_imaging.py)."""
    imaging = spheres[0]
    sectors = ImagingSonar(imaging.sonar, transmit=replace(FAST, transmit="sectors"))
    assert sectors.pings_per_frame == 6 and len(sectors.imagers) == 6
    geometry = imaging.sonar.config.geometry
    c = imaging.sonar.config.medium.speed_of_sound
    for emission, imager in zip(sectors.emissions, sectors.imagers):
        distance = np.linalg.norm(geometry.tx_positions - emission.source, axis=1)
        np.testing.assert_allclose(emission.firing * c + emission.lead, distance, atol=1e-12)
        assert emission.firing.min() == 0 and imager.region == emission.region
    regions = np.array([e.region for e in sectors.emissions])  # 3 x 2 sectors of 20 x 20 deg
    np.testing.assert_allclose(np.degrees(regions[:, 1] - regions[:, 0]), 20.0)
    np.testing.assert_allclose(np.degrees(regions[:, 3] - regions[:, 2]), 20.0)
    with pytest.raises(ValueError, match="ping"):
        sectors.image(IDENTITY, ping=6)


def test_same_seed_same_image(spheres):
    imaging = spheres[0]
    first, again = imaging.image(IDENTITY, seed=5), imaging.image(IDENTITY, seed=5)
    for name in ("points_sensor", "direction", "amplitude", "snr"):
        np.testing.assert_array_equal(getattr(first, name), getattr(again, name))
    other = imaging.image(IDENTITY, seed=6)
    assert not np.array_equal(first.amplitude, other.amplitude)
    assert imaging.cycle_time == imaging.sonar.config.record_duration  # one cycle: ~34 ms
    assert first.envelopes is None
    kept = imaging.image(IDENTITY, seed=5, keep_envelopes=True)
    assert kept.envelopes.shape == (len(kept.directions), len(kept.times))


def test_an_empty_scene_gives_no_point(tmp_path):
    """Nothing in front (a wall behind the sensor): only the blanked cross-talk and noise."""
    path = write_scene(tmp_path / "behind.xml", material_xml("w", preset="drywall"),
                       rectangle_xml("w", (0, 0, -2.0)))
    for transmit in ("element", "array", "sectors"):
        imaging = ImagingSonar(mitsonar.Sonar(path), transmit=replace(FAST, transmit=transmit))
        for seed in range(3):
            assert len(imaging.image(IDENTITY, seed=seed, ping=seed % imaging.pings_per_frame)) == 0


@pytest.mark.parametrize("rule,transmit", [(ImagingSettings(), FAST),
                                           (WIDE_SWEEP_SETTINGS, DEFOCUSED)],
                         ids=["default rule, one element", "sub-band rule, defocused"])
def test_free_space_gives_no_point_behind_a_wide_sweep(tmp_path, rule, transmit):
    """The 20-80 kHz sweep (paper preset, ``SonarConfig.with_wide_sweep``): the
    direct path's matched-filter envelope, traced at five frequency nodes, keeps a tail 1-4
    times the noise envelope 2-10 ms after the transmission. Noise on that tail crossed twice
    the tail (the blanking margin) 0.25 times an image (5 points in 20 images, where the
    design allows 4e-4 an image); it must now cross the tail plus the noise threshold: no
    point in 20 images, with the default points rule and one element, and with the sweep's own
    rule (sub-band coherence 0.2, clutter 2 x the RMS) behind the defocused array (the chart's
    best strategy)."""
    path = write_scene(tmp_path / "behind.xml", material_xml("w", preset="drywall"),
                       rectangle_xml("w", (0, 0, -2.0)))
    config = mitsonar.SonarConfig.preset("paper").with_wide_sweep()
    imaging = ImagingSonar(mitsonar.Sonar(path, config), rule, transmit)
    assert sum(len(imaging.image(IDENTITY, seed=seed)) for seed in range(20)) == 0


def test_one_element_reproduces_the_image_source_echo_of_a_wall(tmp_path):
    """A rigid wall at 1.5 m, lit by one element over the wide cone (uniform ray cells): the
    broadside image equals that of the element's mirror image within 1 dB (measured -0.15 dB),
    and the wall's point lies within 5 mm of its plane (measured 0.4 mm)."""
    distance = 1.5
    path = write_scene(tmp_path / "wall.xml", material_xml("wall", **RIGID),
                       rectangle_xml("wall", (0, 0, distance), size=(30, 30)))
    config = mitsonar.SonarConfig(noise_rms=0.0)
    sonar = mitsonar.Sonar(path, config)
    imaging = ImagingSonar(sonar, ImagingSettings(detection_floor=1e-4), FAST)
    imager = imaging.imager
    trace = imaging.tracer.trace(IDENTITY, BROADSIDE)
    n_rx = config.geometry.rx.count
    traced = imager.envelopes(sonar.synthesizer.groups_spectrum(
        sonar.echo_groups(trace.paths, config.pulse), n_rx))
    element = np.flatnonzero(imaging.tracer.settings.transmit_weights)
    mirror = image_paths(config, BROADSIDE, plane_images(config.geometry.tx_positions, distance))
    alone = np.repeat(np.isin(np.arange(config.geometry.tx.count), element), n_rx)
    reference = imager.envelopes(sonar.synthesizer.group_spectrum(
        Paths(mirror.gain[alone], mirror.delay[alone], mirror.channel[alone]), None, n_rx))
    broadside = np.argmax(imager.directions[:, 2])
    ratio_db = 20 * np.log10(traced[broadside].max() / reference[broadside].max())
    assert abs(ratio_db) <= 1.0, ratio_db
    image = imaging.image(IDENTITY)
    on_axis = np.argmax(image.direction[:, 2])
    assert abs(image.points_sensor[on_axis, 2] - distance) <= 5e-3


def test_transmit_weights_fire_exactly_the_weighted_elements(tmp_path):
    """The tracer's hook: weights of 1 change no bit of a steered beam's paths; one element alone
    gives the paths of an array that has only that element."""
    path = write_scene(tmp_path / "scene.xml", material_xml("w", preset="drywall"),
                       rectangle_xml("w", (0.3, 0, 2.0), (0, 20, 0), size=(3, 3)),
                       sphere_xml("w", (-0.2, 0.1, 1.2), 0.1))
    config = mitsonar.SonarConfig()
    sonar = mitsonar.Sonar(path, config)
    g, trace = config.geometry, config.resolved_trace()
    direction = direction_from_fov_angles(np.radians(8.0), np.radians(-5.0))

    def tracer(geometry, **changes):
        return AcousticTracer(sonar.scene, geometry, config.transducer, config.medium,
                              config.pulse, replace(trace, **changes))

    ones = tracer(g, transmit_weights=(1.0,) * g.tx.count)
    for a, b in ((ones.trace(IDENTITY, direction, 3).paths, sonar.tracer.trace(IDENTITY, direction,
                                                                              3).paths),
                 (ones.direct_paths(direction), sonar.tracer.direct_paths(direction))):
        for name in ("gain", "delay", "channel"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    weights = np.zeros(g.tx.count)
    weights[7] = 0.5
    single = replace(g, tx=mitsonar.ArrayLayout(g.tx.positions[[7]]),
                     tx_phase_offsets=g.tx_phase_offsets[[7]])
    one = tracer(g, transmit_weights=tuple(weights)).trace(IDENTITY, direction, 3).paths
    alone = tracer(single).trace(IDENTITY, direction, 3).paths
    np.testing.assert_array_equal(one.delay, alone.delay)
    np.testing.assert_allclose(one.gain, 0.5 * alone.gain, rtol=1e-12, atol=0)
    with pytest.raises(ValueError, match="transmit_weights"):
        tracer(g, transmit_weights=(1.0, 0.0))
    with pytest.raises(ValueError, match="no element transmits"):
        mitsonar.TraceSettings(transmit_weights=(0.0, 0.0))
    with pytest.raises(ValueError, match="ray_density"):
        mitsonar.TraceSettings(ray_density="dense")
