"""Atomic file output: nothing is left half-written if a run is interrupted or fails."""

from __future__ import annotations

import json
import os
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np


@contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; it replaces ``path`` only if the block succeeds."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=path.suffix)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    try:
        yield Path(tmp)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp's 0600 -> what open() would have given
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def write_json(path, data) -> None:
    """Write ``data`` as indented JSON, atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(data, indent=2, default=_json_default) + "\n")


def write_table(path, rows: list[dict], markdown: list[str] | None = None) -> None:
    """Write rows (dicts with the same keys) as ``path`` .csv, atomically; with ``markdown``
    lines also the .md beside it (experiments' tables)."""
    path = Path(path)
    header = list(rows[0])

    def cell(v) -> str:  # integers in full (counts), floats to 6 significant digits
        if isinstance(v, str):
            return v
        return f"{v:d}" if isinstance(v, (int, np.integer)) else f"{v:.6g}"

    with atomic_path(path.with_suffix(".csv")) as tmp:
        tmp.write_text(",".join(header) + "\n"
                       + "\n".join(",".join(cell(r[k]) for k in header) for r in rows) + "\n")
    if markdown is not None:
        with atomic_path(path.with_suffix(".md")) as tmp:
            tmp.write_text("\n".join(markdown) + "\n")


def write_npz(path, **arrays) -> None:
    """Write arrays to a compressed .npz, atomically."""
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            np.savez_compressed(f, **arrays)


def write_ply(path, points, colors=None, scalars: dict | None = None, faces=None) -> None:
    """Write an ASCII PLY point cloud (or triangle mesh), atomically.

    Args:
        points: (N, 3) positions [m].
        colors: optional (N, 3) uint8 RGB.
        scalars: optional name -> (N,) float32 per-point values (e.g. amplitude).
        faces: optional (F, 3) vertex indices of triangles.
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    cols = [pts]
    header = ["ply", "format ascii 1.0", f"element vertex {len(pts)}",
              "property float x", "property float y", "property float z"]
    fmt = ["%.6f", "%.6f", "%.6f"]
    if colors is not None:
        cols.append(np.asarray(colors).reshape(-1, 3))
        header += ["property uchar red", "property uchar green", "property uchar blue"]
        fmt += ["%d", "%d", "%d"]
    for name, values in (scalars or {}).items():
        cols.append(np.asarray(values, dtype=float).reshape(-1, 1))
        header.append(f"property float {name}")
        fmt.append("%.6g")
    tri = np.zeros((0, 3), dtype=np.int64) if faces is None \
        else np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if faces is not None:
        header += [f"element face {len(tri)}", "property list uchar int vertex_indices"]
    header.append("end_header")
    with atomic_path(path) as tmp:
        with open(tmp, "w") as f:
            f.write("\n".join(header) + "\n")
            if len(pts):
                np.savetxt(f, np.hstack(cols), fmt=fmt)
            if len(tri):
                np.savetxt(f, np.hstack([np.full((len(tri), 1), 3), tri]), fmt="%d")


def _json_default(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value)}")
