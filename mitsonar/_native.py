"""Native libraries that mitsonar's dependencies load at run time.

* Dr.Jit's LLVM backend ``dlopen``s whatever ``libLLVM`` it finds. LLVM 15 (Debian 12's default)
  aborts the whole process on the first kernel that uses ``fminimum``. Before ``drjit`` is
  imported we pick a library that works: the user's ``DRJIT_LIBLLVM_PATH`` if set, else the
  ``libLLVM`` shipped by the ``karellen-llvm-core`` wheel, else a system one. Each candidate is
  probed once in a subprocess (an abort there cannot kill the caller) and the verdict is cached.
* ``import open3d`` needs ``libusb-1.0.so.0``; the ``libusb-package`` wheel ships it, and loading
  it globally first satisfies open3d's dynamic link.
"""

from __future__ import annotations

import ctypes
import glob
import hashlib
import json
import os
import subprocess
import sys
import warnings
from pathlib import Path

_PROBE = (
    "import drjit as dr\n"
    "from drjit.llvm import Float\n"
    "x = dr.arange(Float, 8)\n"
    "print(dr.minimum(x, 3.5) + dr.maximum(x, 1.5))\n"
)


class NativeLibraryError(RuntimeError):
    """No working native library could be found."""


def _cache_file() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "mitsonar" / "llvm-probe.json"


def _candidate_key(path: str) -> str:
    st = os.stat(path)
    import importlib.metadata as md

    drjit_version = md.version("drjit")
    raw = f"{os.path.realpath(path)}|{st.st_size}|{st.st_mtime_ns}|{drjit_version}"
    return hashlib.sha1(raw.encode()).hexdigest()


def _llvm_candidates() -> list[str]:
    """Libraries to try, best first: the PyPI wheel's LLVM, then system LLVMs, newest first."""
    found: list[str] = []
    try:
        import importlib.metadata as md

        for f in md.files("karellen-llvm-core") or []:
            name = Path(str(f)).name
            if name.startswith("libLLVM") and ".so" in name:
                found.append(str(f.locate()))
    except Exception:  # package absent: fall back to the system
        pass
    patterns = ["/usr/lib/llvm-*/lib/libLLVM*.so*", "/usr/lib/*-linux-gnu/libLLVM*.so*",
                "/usr/lib64/libLLVM*.so*", "/usr/local/lib/libLLVM*.so*"]
    system = sorted({p for pat in patterns for p in glob.glob(pat)}, reverse=True)
    seen: set[str] = set()
    ordered = []
    for p in found + system:
        real = os.path.realpath(p)
        if os.path.isfile(real) and real not in seen:
            seen.add(real)
            ordered.append(real)
    return ordered


def _probe(path: str, cache: dict) -> bool:
    key = _candidate_key(path)
    if key in cache:
        return bool(cache[key])
    env = dict(os.environ, DRJIT_LIBLLVM_PATH=path)
    try:
        ok = subprocess.run([sys.executable, "-c", _PROBE], env=env, capture_output=True,
                            timeout=120).returncode == 0
    except subprocess.TimeoutExpired:
        ok = False
    cache[key] = ok
    return ok


def configure_llvm() -> str:
    """Set ``DRJIT_LIBLLVM_PATH`` to a working libLLVM (before drjit loads) and return it.

    A path the user already set is respected as is. Raises :class:`NativeLibraryError` naming
    every library tried when none works.
    """
    user = os.environ.get("DRJIT_LIBLLVM_PATH")
    if user:
        return user
    cache_path = _cache_file()
    try:
        cache = json.loads(cache_path.read_text())
    except (OSError, ValueError):
        cache = {}
    tried = []
    chosen = None
    for cand in _llvm_candidates():
        tried.append(cand)
        if _probe(cand, cache):
            chosen = cand
            break
    try:
        cache_path.parent.mkdir(parents=True, exist_ok=True)
        tmp = cache_path.with_suffix(".tmp")
        tmp.write_text(json.dumps(cache))
        os.replace(tmp, cache_path)
    except OSError:
        pass  # caching is an optimisation only
    if chosen is None:
        raise NativeLibraryError(
            "mitsonar needs an LLVM >= 16 shared library for Dr.Jit's LLVM backend; tried: "
            + (", ".join(tried) or "none found")
            + ". Install the 'karellen-llvm-core' wheel (pip install karellen-llvm-core) or set "
              "DRJIT_LIBLLVM_PATH to a working libLLVM.so.")
    if "drjit" in sys.modules:  # too late to switch libraries in this process
        warnings.warn(f"drjit was imported before mitsonar, so Dr.Jit may have loaded a libLLVM "
                      f"that aborts the process on its first 'fminimum' kernel; import mitsonar "
                      f"first, or set DRJIT_LIBLLVM_PATH={chosen}", RuntimeWarning, stacklevel=2)
        return chosen
    os.environ["DRJIT_LIBLLVM_PATH"] = chosen
    return chosen


def import_open3d():
    """Import open3d after loading the libusb it links against (shipped by ``libusb-package``)."""
    try:
        import libusb_package

        lib = libusb_package.get_library_path()
        if lib is not None:
            ctypes.CDLL(str(lib), mode=ctypes.RTLD_GLOBAL)
    except (ImportError, OSError):
        pass  # a system libusb may still satisfy open3d; the import below reports otherwise
    import open3d

    return open3d
