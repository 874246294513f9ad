"""OFDM codes and schedule: orthogonality (9), code correlations, the paper's frame timing."""

import numpy as np
import pytest

import mitsonar
from mitsonar.ofdm import PAPER_TONES, Schedule, check_orthogonal, code_correlation, code_set


def test_paper_tones_are_orthogonal_and_give_25_codes():
    check_orthogonal(PAPER_TONES, 0.5e-3)
    codes = code_set()
    assert len(codes) == 25 and len({(c.first, c.second) for c in codes}) == 25
    for c in codes:  # whole periods in each half: the waveform is continuous at the joint
        assert (c.first * c.slot / 2) % 1 == 0 and (c.second * c.slot / 2) % 1 == 0


@pytest.mark.parametrize("tones,slot", [((32e3, 34.5e3, 40e3), 0.5e-3), ((32e3, 36e3), 0.3e-3)])
def test_non_orthogonal_code_sets_are_rejected(tones, slot):
    with pytest.raises(ValueError, match="not orthogonal"):
        code_set(tones, slot)


def test_code_correlations_follow_the_shared_halves():
    codes = code_set()
    corr = code_correlation(codes)
    shared = np.array([[(a.first == b.first) + (a.second == b.second) for b in codes] for a in codes])
    np.testing.assert_allclose(corr, shared / 2.0, atol=2e-3)  # 1, 1/2 or 0 (orthogonal halves)


def test_paper_frame_is_208_5_ms_with_117_points():
    directions = mitsonar.ArrayGeometry().fov_grid(np.radians(5.0))
    schedule = Schedule.build(directions, code_set())
    assert len(schedule.directions) == 117
    assert schedule.frame_duration == pytest.approx(0.2085, abs=1e-12)
    assert len(schedule.cycle_start) == 5 and np.bincount(schedule.cycle).tolist() == [25, 25, 25, 25, 17]
    np.testing.assert_allclose(np.diff(schedule.cycle_start), 0.0425)
    assert np.all(np.diff(schedule.transmit_time[:25]) == pytest.approx(0.5e-3))
