"""Dr.Jit's backend: the Mitsuba variant mitsonar runs on, and moving arrays from NumPy to it
without recompiling kernels.

Variant. Every scene, ray cast and kernel runs on one Mitsuba variant per process, the setting
``MITSONAR_VARIANT`` (environment; default ``llvm_ad_rgb``: Dr.Jit's LLVM backend on the CPU,
RGB for the camera) or :func:`set_variant` before the first scene is loaded. ``cuda_ad_rgb``
selects Dr.Jit's CUDA backend where the Mitsuba build and an NVIDIA GPU provide it; mitsonar's
kernels take their array types from :func:`backend`. (The CUDA variant ran once on an NVIDIA
H200: the same depths and decisions as on the CPU, but no faster, a frame being mostly host
work in NumPy; docs/performance.md. The CI machines have no GPU.)

Alignment.
Dr.Jit's LLVM backend specialises a kernel on the memory alignment of its input buffers. NumPy
arrays come at whatever alignment the allocator gave them, so a kernel fed straight from NumPy
is compiled anew for many combinations of its inputs' alignments (up to 2^inputs variants, up to
seconds each for a large kernel). :func:`to_jit` copies through an aligned buffer, so each kernel
compiles once and is then reused (and loaded from Dr.Jit's disk cache in later runs).

Frozen kernels. :func:`freeze` wraps ``drjit.freeze`` so that Python's garbage collector does
not run while a frozen function records or replays: a collection there frees Dr.Jit variables
of unrelated objects in the middle of the recording, and the process aborted inside the frozen
pair kernel with the collector running (an intermittent crash of the test suite). A recording
that reaches Mitsuba objects through Dr.Jit's registry (the camera's render pass) is valid only
while no registered object (a scene's shapes, BSDFs and emitters, a camera) is added or removed:
Dr.Jit 1.5 then raises ``assign_with_registry()`` or, undetected, crashes. :func:`registry_changes`
counts the scenes and cameras mitsonar made and freed, so such a recording is dropped and made
anew when the count moved (tests ran two freshly cloned suites into both failures).
"""

from __future__ import annotations

import functools
import gc
import os
import weakref

import numpy as np

#: Variants mitsonar runs on: RGB (the camera) on Dr.Jit's LLVM (CPU) or CUDA (GPU) backend.
VARIANTS = ("llvm_ad_rgb", "cuda_ad_rgb")
#: Environment variable that chooses the variant.
VARIANT_ENV = "MITSONAR_VARIANT"

_variant: str | None = None


def _checked(name: str, source: str) -> str:
    if name not in VARIANTS:
        raise ValueError(f"{source}: unknown Mitsuba variant {name!r}; mitsonar runs on "
                         f"{', '.join(VARIANTS)}")
    return name


def variant() -> str:
    """The Mitsuba variant of this process: :func:`set_variant`'s, else ``MITSONAR_VARIANT``'s,
    else ``llvm_ad_rgb``."""
    global _variant
    if _variant is None:
        _variant = _checked(os.environ.get(VARIANT_ENV, VARIANTS[0]), VARIANT_ENV)
    return _variant


def set_variant(name: str) -> None:
    """Run on Mitsuba variant ``name`` (one of :data:`VARIANTS`); call before the first scene is
    loaded (Mitsuba's plugins and mitsonar's kernels are built for one variant per process)."""
    global _variant
    import sys

    name = _checked(name, "set_variant")
    mi = sys.modules.get("mitsuba")
    active = mi.variant() if mi is not None else None
    if active is not None and active != name:
        raise ValueError(f"set_variant({name!r}): Mitsuba already runs {active!r} in this "
                         "process; choose the variant before loading a scene")
    _variant = name


def backend():
    """The Dr.Jit array namespace of the variant's backend (``drjit.llvm`` or ``drjit.cuda``),
    from which kernels take their array types (``backend().Float32``)."""
    if variant().startswith("cuda"):
        import drjit.cuda as namespace
    else:
        import drjit.llvm as namespace
    return namespace

#: Alignment of the buffers handed to Dr.Jit [bytes] (a cache line; covers AVX-512 loads).
ALIGNMENT = 64


def to_jit(array_type, values):
    """A flat Dr.Jit array of ``array_type`` (e.g. ``backend().Float``) holding ``values``
    (any shape, flattened, converted to the type's precision), from an ``ALIGNMENT``-byte
    aligned copy."""
    dtype = _dtype(array_type)
    values = np.asarray(values)
    raw = np.empty(values.size * dtype.itemsize + ALIGNMENT, np.uint8)
    start = -raw.ctypes.data % ALIGNMENT
    aligned = raw[start: start + values.size * dtype.itemsize].view(dtype)
    aligned.reshape(values.shape)[...] = values  # one pass: gathers strided views, converts
    return array_type(aligned)


@functools.cache
def _dtype(array_type) -> np.dtype:
    """The NumPy dtype of a Dr.Jit array type's elements (looked up once per type: the lookup
    costs more than converting the few hundred values of a small array)."""
    import drjit as dr

    v = dr.VarType
    return np.dtype({v.Float32: np.float32, v.Float64: np.float64, v.Int32: np.int32,
                     v.UInt32: np.uint32, v.Int64: np.int64, v.UInt64: np.uint64,
                     v.Bool: np.bool_}[dr.type_v(array_type)])


def freeze(function, **options):
    """``drjit.freeze(function, **options)``, called with Python's garbage collector paused
    (module docstring: Frozen kernels); the frozen function itself is ``.frozen`` (its
    ``n_recordings`` counts the recordings made)."""
    import drjit as dr
    frozen = dr.freeze(function, **options)

    @functools.wraps(function)
    def call(*args, **kwargs):
        collecting = gc.isenabled()
        gc.disable()
        try:
            return frozen(*args, **kwargs)
        finally:
            if collecting:
                gc.enable()

    call.frozen = frozen
    return call


_registry_changes = 0


def registry_changes() -> int:
    """How many times a scene or camera that registers Mitsuba objects was made or freed in this
    process (:func:`count_registry_changes`): a recording reaching the registry replays only
    while this stays the same."""
    return _registry_changes


def count_registry_changes(owner) -> None:
    """Count ``owner`` (an object holding registered Mitsuba objects) as made now and as freed
    when it is collected."""
    _registry_changed()
    weakref.finalize(owner, _registry_changed)


def _registry_changed() -> None:
    global _registry_changes
    _registry_changes += 1


def concat(parts) -> tuple:
    """Columns of flat Dr.Jit arrays joined end to end: ``parts`` holds each part's columns (a
    tuple of arrays of one width); returns the joined columns, each as ``drjit.concat`` joins
    it, evaluated. By kernels that do not depend on the parts' widths: ``drjit.concat`` writes
    each part at its offset as a literal, and Dr.Jit fuses the writes of parts of equal width
    into one kernel, so every new width, or coincidence of widths, of a beam's paths made a
    new kernel, compiled anew. Here the offsets are variables (``drjit.opaque``) and each part
    is written by a kernel of its own (all in one where every part has the same width)."""
    import drjit as dr

    parts = [tuple(p) for p in parts]
    if len(parts) == 1:
        return parts[0]
    widths = [dr.width(p[0]) for p in parts]
    index = dr.uint32_array_t(type(parts[0][0]))
    columns = tuple(dr.empty(type(a), sum(widths)) for a in parts[0])
    apart = len(set(widths)) > 1
    start = 0
    for part, width in zip(parts, widths):
        at = dr.arange(index, width) + dr.opaque(index, start)
        for column, values in zip(columns, part):
            dr.scatter(column, values, at, mode=dr.ReduceMode.Permute)
        if apart:
            dr.eval(columns)
        start += width
    dr.eval(columns)
    return columns
