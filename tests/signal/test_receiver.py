"""The batched receiver (EchoProcessor.process_beams) against beam-by-beam processing."""

import numpy as np
import pytest

import mitsonar
from helpers import IDENTITY
from mitsonar.frames import direction_from_fov_angles
from mitsonar.scene.xml import material_xml, rectangle_xml, sphere_xml, write_scene
from mitsonar.sensors.ofdm_sonar import OfdmSonar
from mitsonar.sensors.sonar import beam_seed

#: Batched and beam-by-beam results may differ by floating-point summation order only
#: (measured: equal).
DEPTH_TOLERANCE = 1e-9  # [m]


@pytest.fixture(scope="module")
def targets(tmp_path_factory):
    """Nine spheres on a 3 x 3 grid of directions at 1.6-2.8 m before a drywall at 3.5 m, and a
    smooth plate turned by 40 deg (specular side-lobe returns, which the receiver rejects);
    broadband transducers (20 kHz at -6 dB, so that every OFDM code gets through). Returns the
    sonar and the directions (12, 3): the spheres' and three open ones (the wall's speckle)."""
    hh, vv = np.meshgrid(np.radians([-16.0, 0.0, 16.0]), np.radians([-10.0, 0.0, 10.0]))
    towards = direction_from_fov_angles(hh.ravel(), vv.ravel())
    ranges = np.random.default_rng(1).permutation(np.linspace(1.6, 2.8, 9))
    spheres = [sphere_xml("t", r * u, 0.08 * (r / 2) ** 2) for r, u in zip(ranges, towards)]
    path = write_scene(tmp_path_factory.mktemp("targets") / "targets.xml",
                       material_xml("t", preset="metal", scattering=0.0),
                       material_xml("w", preset="drywall"), *spheres,
                       rectangle_xml("w", (0, 0, 3.5), size=(8.0, 8.0)),
                       rectangle_xml("t", (1.0, 0, 2.5), (0, -40, 0), size=(1.5, 3.0)))
    config = mitsonar.SonarConfig(transducer=mitsonar.Transducer(bandwidth_6db=20e3))
    open_directions = direction_from_fov_angles(np.radians([24.0, -24.0, 8.0]),
                                                np.radians([15.0, -15.0, -17.0]))
    return mitsonar.Sonar(path, config), np.concatenate([towards, open_directions])


FIELDS = ("detected", "depth", "point", "amplitude")


def _assert_same(batched: dict, alone: list):
    """Same decisions as the beams' :class:`Detection` s ``alone``; depths and points within
    DEPTH_TOLERANCE, amplitudes within 1e-12 (relative)."""
    expected = {name: np.array([getattr(d, name) for d in alone]) for name in FIELDS}
    np.testing.assert_array_equal(batched["detected"], expected["detected"])
    for name in ("depth", "point"):
        np.testing.assert_allclose(batched[name], expected[name], rtol=0, atol=DEPTH_TOLERANCE)
    np.testing.assert_allclose(batched["amplitude"], expected["amplitude"], rtol=1e-12)


def test_a_scan_gives_each_beam_what_a_ping_gives_it(targets):
    """A scan (beams processed TRACE_BATCH at a time, each from its own recording) against one
    ping per beam."""
    sonar, directions = targets
    scan = sonar.scan(IDENTITY, directions, seed=2)
    pings = [sonar.ping(IDENTITY, u, seed=beam_seed(2, b)).detection
             for b, u in enumerate(directions)]
    _assert_same(dict(detected=scan.detected, depth=scan.depth, point=scan.points_sensor,
                      amplitude=scan.amplitude), pings)
    assert scan.detected[:9].all() and not scan.detected.all()  # measured: 11 of 12


def test_an_ofdm_cycle_decoded_together_equals_its_beams_decoded_one_by_one(targets, monkeypatch):
    """The beams of an OFDM cycle, decoded together from their shared recording (each with its
    own code, firing time and blanking), against each beam decoded alone from it."""
    sonar, directions = targets
    ofdm = OfdmSonar(sonar)
    processor = ofdm.processor
    calls = []
    batched = processor.process_beams

    def spy(*args, **kwargs):
        calls.append((args, kwargs, batched(*args, **kwargs)))
        return calls[-1][2]

    monkeypatch.setattr(processor, "process_beams", spy)
    frame = ofdm.frame(ofdm.schedule(directions), lambda t: IDENTITY, seed=4)
    monkeypatch.undo()
    assert len(calls) == 1 and frame.detected.sum() >= 7  # measured: the nine spheres
    (recording, beams, blank, codes), kwargs, (envelopes, together) = calls[0]
    alone = [processor.process(recording, u, blank[b], codes[b], kwargs["transmit_times"][b],
                               kwargs["max_path_length"]) for b, u in enumerate(beams)]
    np.testing.assert_allclose(envelopes, [env for env, _ in alone], rtol=0,
                               atol=1e-12 * envelopes.max())
    _assert_same({name: getattr(together, name) for name in FIELDS}, [det for _, det in alone])


def test_a_cycle_synthesised_at_once_equals_its_beams_synthesised_apart(targets):
    """By default a cycle's echoes are synthesised at once (one grid and FFT per waveform); asked
    for the codes' cross-talk, every beam's echoes are synthesised apart and summed. The two
    recordings differ by rounding only: the same decisions, depths within 1e-9 m, and the
    cross-talk figure only where asked for. Per-beam traces (the cross-talk figure's), not
    shared hits."""
    sonar, directions = targets
    ofdm = OfdmSonar(sonar, shared_hits=False)
    schedule = ofdm.schedule(directions)
    apart = ofdm.frame(schedule, lambda t: IDENTITY, seed=4, crosstalk=True)
    at_once = ofdm.frame(schedule, lambda t: IDENTITY, seed=4)
    np.testing.assert_array_equal(at_once.detected, apart.detected)
    np.testing.assert_allclose(at_once.depth, apart.depth, rtol=0, atol=1e-9)
    assert np.isfinite(apart.crosstalk_db[apart.detected]).all() and apart.detected.any()
    assert np.isnan(at_once.crosstalk_db).all()
