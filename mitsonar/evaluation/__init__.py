"""Evaluation: scores against the ground-truth mesh, analytic and direct-summation references,
and the fidelity presets with their automatic choice."""
