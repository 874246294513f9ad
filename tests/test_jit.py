"""The Mitsuba variant setting (mitsonar.jit): default, environment, errors."""

from __future__ import annotations

import os
import gc
import subprocess
import sys

import drjit as dr
import pytest

from mitsonar import jit


def _scan(tmp_path, variant: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, MITSONAR_VARIANT=variant)
    return subprocess.run([sys.executable, "-m", "mitsonar", "scan", "room_glass", "--step", "20",
                           "--fov", "20x20", "--out", str(tmp_path / "out")],
                          env=env, capture_output=True, text=True, timeout=300)


def test_the_default_variant_runs_on_the_llvm_backend():
    assert os.environ.get(jit.VARIANT_ENV) in (None, "llvm_ad_rgb")
    assert jit.variant() == "llvm_ad_rgb"
    assert jit.backend().Float32 is dr.llvm.Float32


def test_an_unknown_variant_is_one_line_naming_the_setting(tmp_path):
    result = _scan(tmp_path, "scalar_rgb")
    assert result.returncode == 2, result.stderr
    err = result.stderr.strip().splitlines()[-1]
    assert "MITSONAR_VARIANT" in err and "'scalar_rgb'" in err and "llvm_ad_rgb" in err
    assert "Traceback" not in result.stderr
    assert not (tmp_path / "out").exists()


def test_the_cuda_variant_runs_where_cuda_exists_else_says_why(tmp_path):
    result = _scan(tmp_path, "cuda_ad_rgb")
    if dr.has_backend(dr.JitBackend.CUDA):  # a machine with an NVIDIA GPU
        assert result.returncode == 0, result.stderr
    else:
        assert result.returncode == 2, result.stderr
        err = result.stderr.strip().splitlines()[-1]
        assert "'cuda_ad_rgb' is not available" in err and "Traceback" not in result.stderr


def test_the_variant_cannot_change_once_mitsuba_runs():
    from mitsonar.scene.loading import mitsuba

    mitsuba()  # Mitsuba now runs the default variant in this process
    with pytest.raises(ValueError, match="already runs 'llvm_ad_rgb'"):
        jit.set_variant("cuda_ad_rgb")
    jit.set_variant("llvm_ad_rgb")  # the same one is fine
    with pytest.raises(ValueError, match="unknown Mitsuba variant"):
        jit.set_variant("llvm_rgb")


def test_frozen_kernels_run_with_the_garbage_collector_paused():
    """jit.freeze: the function records with Python's collector off (a collection during a
    recording aborted the process), gives the frozen result, and restores the collector."""
    seen = []

    def double(x):
        seen.append(gc.isenabled())
        return x * 2

    frozen = jit.freeze(double)
    Float = jit.backend().Float32
    assert gc.isenabled()
    result = frozen(Float([1.0, 2.0, 3.0]))
    assert seen == [False] and gc.isenabled()
    assert list(result.numpy()) == [2.0, 4.0, 6.0]
