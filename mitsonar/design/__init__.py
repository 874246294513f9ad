"""Sparse-array design: the genetic algorithm behind the shipped 5x5 layouts, and its figures.

Modules (each imports only those above it):

* :mod:`mitsonar.design.evaluation`: what a good layout is (``BeamCriteria``), the exact
  PSLL and 3 dB widths of a transmit/receive pair over the field of view, the uniform 5x5 pair.
* :mod:`mitsonar.design.genetic`: the seeded genetic algorithm, its settings, spacing repair and
  fast lattice objective (``design_arrays``).
* :mod:`mitsonar.design.record`: the layout JSON file (record, reading back, shipped path) and
  the printed summary.
* :mod:`mitsonar.design.figures`: figures and tables of ``mitsonar array plot``.

The command line is :mod:`mitsonar.cli.array`.
"""
