"""Frames simulated by several processes (mitsonar.parallel): in order, each process's state built
once, Dr.Jit on its share of the cores, and the same frames as one process gives."""

from __future__ import annotations

import os

import numpy as np

import mitsonar
from mitsonar.parallel import ordered_map
from mitsonar.recon.repeated import RepeatedMapSpec, scan_repeated
from mitsonar.scene.xml import material_xml, rectangle_xml

from helpers import IDENTITY  # noqa: F401  (tests/ on the path of spawned workers too)


def _state():
    return {"pid": os.getpid(), "built": 0}


def _task(state, item):
    import drjit as dr

    state["built"] += 1  # the state persists between a process's items
    return item * item, state["pid"], state["built"], dr.thread_count()


def test_items_come_back_in_order_from_each_process():
    results = list(ordered_map(_state, _task, range(7), workers=2))
    assert [r[0] for r in results] == [k * k for k in range(7)]
    pids = {r[1] for r in results}  # which worker takes which item is up to the pool
    assert 1 <= len(pids) <= 2 and os.getpid() not in pids
    for pid in pids:  # one state per process, kept across its items
        assert sorted(r[2] for r in results if r[1] == pid) == \
            list(range(1, sum(r[1] == pid for r in results) + 1))
    assert {r[3] for r in results} == {max(1, (os.cpu_count() or 1) // 2)}
    assert [r[:1] for r in ordered_map(_state, _task, range(7))] == [(k * k,) for k in range(7)]


def test_repeated_frames_are_the_same_from_two_processes(tmp_path, scene_file):
    """Three OFDM frames (paper preset, every range cell) along a short drive past a wall and a
    slanted board, with their camera images: bit for bit the same points, poses and images
    whether one process or two simulate them."""
    path = scene_file("room", material_xml("c", 0.6, preset="concrete"),
                      rectangle_xml("c", (0.0, 3.0, 1.0), (90, 0, 0), (8.0, 3.0)),
                      rectangle_xml("c", (1.0, 2.0, 0.6), (70, 30, 0), (1.0, 1.0)))
    trajectory = mitsonar.Trajectory(np.array([[0.0, 0.0, np.pi / 2], [0.0, 1.0, np.pi / 2]]))
    sonar = mitsonar.Sonar(path, mitsonar.SonarConfig.preset("paper"))
    spec = RepeatedMapSpec(frames=3, echoes="cells", image_width=64, spp=1)
    one, _ = scan_repeated(sonar, trajectory, spec)
    two, _ = scan_repeated(sonar, trajectory, spec, workers=2)
    assert sum(len(s.points) for s in one) > 10
    for a, b in zip(one, two, strict=True):
        np.testing.assert_array_equal(a.points, b.points)
        np.testing.assert_array_equal(a.world_from_sensor, b.world_from_sensor)
        np.testing.assert_array_equal(a.image, b.image)
        np.testing.assert_array_equal(a.frame.depth, b.frame.depth)
