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


def check_positive_integer(name: str, value) -> None:
    """Raise ValueError unless ``value`` is an integer >= 1."""
    if int(value) != value or value < 1:
        raise ValueError(f"{name} must be a positive integer, got {value}")


#: Narrowest camera image the pipelines take [pixels] (the camera's 4:3 frame: 8 x 6).
MIN_IMAGE_WIDTH = 8


def check_image_width(name: str, value) -> None:
    """Raise ValueError unless ``value`` is an integer camera image width of at least
    :data:`MIN_IMAGE_WIDTH` [pixels]."""
    if isinstance(value, bool) or int(value) != value or value < MIN_IMAGE_WIDTH:
        raise ValueError(f"{name} [pixels] must be an integer >= {MIN_IMAGE_WIDTH}, got {value!r}")


def check_range(name: str, value, lo: float, hi: float) -> None:
    """Raise ValueError unless lo <= value <= hi (and finite)."""
    check_finite(name, value)
    arr = np.asarray(value, dtype=float)
    if np.any(arr < lo) or np.any(arr > hi):
        raise ValueError(f"{name} must lie in [{lo}, {hi}], got {value!r}")
