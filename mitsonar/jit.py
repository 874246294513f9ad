"""Moving arrays from NumPy to Dr.Jit's LLVM backend without recompiling kernels.

Dr.Jit's LLVM backend specialises a kernel on the memory alignment of its input buffers. NumPy
arrays come at whatever alignment the allocator gave them, so a kernel fed straight from NumPy
is compiled anew for many combinations of its inputs' alignments (up to 2^inputs variants, up to
seconds each for a large kernel). :func:`to_jit` copies through an aligned buffer, so each kernel
compiles once and is then reused (and loaded from Dr.Jit's disk cache in later runs).
"""

from __future__ import annotations

import numpy as np

#: Alignment of the buffers handed to Dr.Jit [bytes] (a cache line; covers AVX-512 loads).
ALIGNMENT = 64


def to_jit(array_type, values):
    """A flat Dr.Jit LLVM array of ``array_type`` (e.g. ``drjit.llvm.Float``) holding ``values``
    (any shape, flattened, converted to the type's precision), from an ``ALIGNMENT``-byte
    aligned copy."""
    import drjit as dr

    v = dr.VarType
    dtype = np.dtype({v.Float32: np.float32, v.Float64: np.float64, v.Int32: np.int32,
                      v.UInt32: np.uint32, v.Int64: np.int64, v.UInt64: np.uint64,
                      v.Bool: np.bool_}[dr.type_v(array_type)])
    values = np.asarray(values)
    raw = np.empty(values.size * dtype.itemsize + ALIGNMENT, np.uint8)
    start = -raw.ctypes.data % ALIGNMENT
    aligned = raw[start: start + values.size * dtype.itemsize].view(dtype)
    aligned.reshape(values.shape)[...] = values  # one pass: gathers strided views, converts
    return array_type(aligned)
