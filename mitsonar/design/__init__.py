"""Sparse-array design: the genetic algorithm behind the shipped 5x5 layouts, and its figures."""
