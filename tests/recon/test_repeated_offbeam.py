"""Repeated maps re-place off-beam echoes where they arrive from (RepeatedMapSpec.off_beam), and
not the other codes' cross-talk of an OFDM cycle."""

from dataclasses import replace

import numpy as np
import pytest

import mitsonar
from mitsonar.recon.repeated import RepeatedMapSpec, scan_repeated
from mitsonar.scene.xml import material_xml, rectangle_xml, write_scene

#: Where the drywall wall stands ahead of the robot (x [m]), and the height it turns about [m].
WALL_X, WALL_Z = 2.4, 0.5


def _wall_frame(tmp_path, tilt_deg: float, echoes: str, broadband: bool, off_beam=None):
    """One OFDM frame (10 deg beam grid, 35 beams) of the physical default sonar (TCT40, or
    20 kHz broadband transducers) at the start of a path towards a 8 m drywall wall WALL_X
    ahead, turned ``tilt_deg`` about the lateral axis, each beam traced in its own cone (with
    shared hits, the mirror echo heard through every beam's side lobes hides all but the beam
    facing the wall: one detection, nothing to re-place). Returns the frame and the distances
    [m] of its echoes' world points to the wall."""
    path = write_scene(tmp_path / f"wall{tilt_deg}.xml", material_xml("w", preset="drywall"),
                       rectangle_xml("w", (WALL_X, 0.0, WALL_Z), (0, -90 + tilt_deg, 0),
                                     size=(8.0, 8.0)),
                       '<emitter type="constant"><rgb name="radiance" value="1"/></emitter>')
    config = mitsonar.SonarConfig()
    if broadband:
        config = replace(config, transducer=mitsonar.Transducer(bandwidth_6db=20e3))
    trajectory = mitsonar.Trajectory(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]), speed=0.05)
    spec = RepeatedMapSpec(frames=1, scan_step=np.radians(10.0), image_width=32, spp=1,
                           echoes=echoes, off_beam=off_beam, shared_hits=False)
    frame = scan_repeated(mitsonar.Sonar(path, config), trajectory, spec)[0][0].frame
    tilt = np.radians(tilt_deg)
    normal = np.array([np.cos(tilt), 0.0, -np.sin(tilt)])
    off_wall = np.abs((frame.echo_points_world - [WALL_X, 0.0, WALL_Z]) @ normal)
    return frame, off_wall


def test_cross_talk_of_a_wall_facing_one_beam_is_not_re_placed(tmp_path):
    """A wall facing the broadside beam (TCT40): its mirror echo leaks into every code of the
    cycle (|X| up to 1/2) from broadside and fails their side-lobe checks. Re-placed along the
    broadside direction with each code's own firing time, it gave 20 points 0.4 cm to 1.9 m
    off the wall (measured before the cross-talk test); now no off-beam point is off the wall
    by more than 2 cm, and the beams' own points are those without off_beam. Nor is any of
    the beams' own points more than 5 cm off (measured: 3 cm at most, seeds 0-3): one was
    1.58 m off, another code's echo lit through its beam's side lobe from inside this beam's
    main lobe (:mod:`mitsonar.signal.crosstalk`)."""
    frame, off_wall = _wall_frame(tmp_path, 0.0, "first", broadband=False)
    moved = frame.echo_table.off_beam
    assert np.all(off_wall[moved] <= 0.02), off_wall[moved]
    assert np.all(off_wall <= 0.05), off_wall
    plain, plain_off_wall = _wall_frame(tmp_path, 0.0, "first", broadband=False, off_beam=False)
    np.testing.assert_allclose(np.sort(off_wall[~moved]), np.sort(plain_off_wall))


@pytest.mark.parametrize("echoes", ["first", "all"])
def test_a_wall_5_deg_off_the_beams_normal_gains_off_beam_points_on_it(tmp_path, echoes):
    """The wall turned 5 deg (broadband transducers, as experiments/comparison.py's repeated
    mode): its mirror echo reaches the beams near broadside through their transmit side lobes.
    The map gains at least one flagged point (measured: 1, at the foot of the perpendicular),
    within 2 cm of the wall (measured: 0.3 cm), and keeps every point it had without."""
    frame, off_wall = _wall_frame(tmp_path, 5.0, echoes, broadband=True)
    moved = frame.echo_table.off_beam
    assert np.count_nonzero(moved) >= 1
    assert np.all(off_wall[moved] <= 0.02), off_wall[moved]
    plain, plain_off_wall = _wall_frame(tmp_path, 5.0, echoes, broadband=True, off_beam=False)
    np.testing.assert_allclose(np.sort(off_wall[~moved]), np.sort(plain_off_wall))


def test_the_map_chooses_off_beam_where_the_echo_mode_allows_it():
    detection = mitsonar.DetectionSettings()
    for echoes, expected in (("first", True), ("all", True), ("cells", False), ("image", False)):
        assert RepeatedMapSpec(echoes=echoes).detection(detection).off_beam == expected
    assert not RepeatedMapSpec(off_beam=False).detection(detection).off_beam
    no_check = mitsonar.DetectionSettings(ghost_margin=0.0)
    assert not RepeatedMapSpec().detection(no_check).off_beam
    with pytest.raises(ValueError, match="RepeatedMapSpec.off_beam"):
        RepeatedMapSpec(echoes="cells", off_beam=True)
