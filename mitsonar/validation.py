"""Small input checks shared by the configuration dataclasses: every error names the parameter."""

from __future__ import annotations

import numpy as np


def check_finite(name: str, value) -> None:
    """Raise ValueError if ``value`` (scalar or array) has a NaN or infinity."""
    arr = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {value!r}")


def check_positive(name: str, value) -> None:
    """Raise ValueError unless ``value`` is finite and > 0."""
    check_finite(name, value)
    if not np.all(np.asarray(value, dtype=float) > 0):
        raise ValueError(f"{name} must be > 0, got {value!r}")


def check_range(name: str, value, lo: float, hi: float) -> None:
    """Raise ValueError unless lo <= value <= hi (and finite)."""
    check_finite(name, value)
    arr = np.asarray(value, dtype=float)
    if np.any(arr < lo) or np.any(arr > hi):
        raise ValueError(f"{name} must lie in [{lo}, {hi}], got {value!r}")
