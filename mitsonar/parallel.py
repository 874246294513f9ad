"""Frames of a trajectory simulated by several processes at once, in order.

A sonar frame, a single-ping image or a camera image along a trajectory depends on its pose, its
seed and the scene alone, so the frames of a drive can be simulated in any order by any number
of processes and give the same results. Much of a frame is single-threaded NumPy (the receive
chain), so one process leaves cores idle: two worker processes on this project's 2-core
machine simulate ``paper``-preset OFDM frames about twice as fast as one process does
(docs/performance.md).

:func:`ordered_map` runs ``task(state, item)`` for every item, ``state = make()`` built once
per process (the loaded scene, the sensors and their kept tables), in ``workers`` spawned
processes (1: in this one), and yields the results in the items' order. Each worker runs
Dr.Jit on its share of the cores (``os.cpu_count() // workers`` threads, at least one); every
kernel of the simulation gives the same values whatever its thread count (fixed-point grids,
element-wise factors), so the results do not depend on ``workers``
(tests/test_parallel.py).
"""

from __future__ import annotations

import os
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context

_state = None  # a worker process's state, built once by :func:`_start`


def _start(make, threads: int) -> None:
    """Worker initialiser: Dr.Jit on ``threads`` threads, then ``make()`` once."""
    global _state
    import drjit as dr  # after mitsonar's own import (this module's package) set up libLLVM

    dr.set_thread_count(threads)
    _state = make()


def _run(task, item):
    return task(_state, item)


def ordered_map(make, task, items, workers: int = 1):
    """Yields ``task(state, item)`` for each of ``items`` in order, ``state = make()`` built
    once per process; ``workers`` processes (1: this one). ``make`` and ``task`` must be
    picklable with ``workers`` > 1 (module-level functions, or ``functools.partial`` of them).
    """
    items = list(items)
    if workers <= 1 or len(items) <= 1:
        state = make()
        for item in items:
            yield task(state, item)
        return
    workers = min(workers, len(items))
    threads = max(1, (os.cpu_count() or 1) // workers)
    with ProcessPoolExecutor(workers, mp_context=get_context("spawn"), initializer=_start,
                             initargs=(make, threads)) as pool:
        yield from pool.map(_run, [task] * len(items), items)
