"""Exact number formatting and output of the scene files: the same numbers give the same bytes
on every machine, so regenerating a scene gives identical files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from mitsonar.io import atomic_path


def rounded(v: float) -> float:
    """Round for output (1e-9) and drop negative zeros."""
    return float(round(float(v), 9)) + 0.0


def rounded_area(v: float) -> float:
    """Round an area for output to 12 significant digits (small objects' areas are ~1e-4 m^2)."""
    return float(f"{float(v):.12g}") + 0.0


def rounded_list(v) -> list[float]:
    """Flattened ``v`` rounded as :func:`rounded`."""
    return [rounded(x) for x in np.asarray(v, dtype=float).ravel()]


def fmt(v: float) -> str:
    """Rounded number as the XML writes it: at most 9 significant digits, no '-0'."""
    s = f"{rounded(v):.9g}"
    return "0" if s in ("-0", "0") else s


def fmt_vec(v) -> str:
    """Comma-separated numbers as :func:`fmt` writes them."""
    return ", ".join(fmt(x) for x in np.asarray(v, dtype=float).ravel())


def fmt_vec_f32(v) -> str:
    """Numbers with 9 significant digits (no rounding to 1e-9 first): a value that is exact in
    float32 (see :func:`mitsonar.scene.building.shapes.block`) reads back exactly."""
    return ", ".join("0" if x == 0 else f"{x:.9g}" for x in np.asarray(v, dtype=float).ravel())


def dump_json(obj, indent: int = 0) -> str:
    """JSON with lists of numbers (and lists of such lists) on one line."""
    pad, inner = " " * indent, " " * (indent + 2)

    def flat(o):
        return isinstance(o, list) and all(
            isinstance(x, (int, float)) or (isinstance(x, list) and all(
                isinstance(y, (int, float)) for y in x)) for x in o)

    if isinstance(obj, dict):
        if not obj:
            return "{}"
        items = [f"{inner}{json.dumps(k)}: {dump_json(v, indent + 2)}" for k, v in obj.items()]
        return "{\n" + ",\n".join(items) + "\n" + pad + "}"
    if isinstance(obj, (list, tuple)):
        obj = list(obj)
        if flat(obj):
            return json.dumps(obj)
        items = [inner + dump_json(v, indent + 2) for v in obj]
        return "[\n" + ",\n".join(items) + "\n" + pad + "]"
    return json.dumps(obj)


def write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path``; a failed write leaves the old file."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
