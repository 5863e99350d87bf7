"""Native CPU kernels, called from jitted programs through XLA's FFI.

One kernel so far: the type-1 NUFFT's spreading (``spread.cc``), the scatter-add of the
exact model's per-pulse transform (:mod:`sarjax.simulators._nufft`). XLA's CPU code forms
the tap weights as passes of their own and runs its scatter loop at about 1 ns per
update; one pulse's transform of the 404 352-scatterer seed 000 scene took 2.3 ms of CPU
(complex64; 7.2 ms complex128) against 0.8 (0.9) ms with the native loop, and the whole
scene 2.95 s against 1.97 s (``benchmarks/README.md``, "The exact model's speed"). The
JAX formulation stays the reference and the fallback:
it runs wherever the kernel is not available (no C++ compiler, another backend,
``SARJAX_NATIVE=0``) and it gives the kernel's derivatives.

**Build.** On first use in a process the source is compiled with the system's C++
compiler (``$CXX``, else ``c++``, ``g++`` or ``clang++``) against the FFI headers that
jaxlib ships (``jax.ffi.include_dir()``), for this machine's instruction set
(``-march=native``), into ``$SARJAX_NATIVE_DIR``, else ``$XDG_CACHE_HOME/sarjax/native``,
else ``~/.cache/sarjax/native`` (about 3–5 s, once). The file is named by a digest of
the source, the compiler and its version, the flags, jaxlib's version and the CPU's
model and flags, and is written to a temporary name and renamed into place, so that
processes building at once leave one whole library and a changed source or machine
never loads an old one. A failed build is logged (``logging``, this module's logger) and
the JAX formulation is used.
"""

from __future__ import annotations

import ctypes
import hashlib
import logging
import os
import platform
import shutil
import subprocess
import tempfile
import threading
from pathlib import Path

import jax
import numpy as np

logger = logging.getLogger(__name__)

ENV_SWITCH = "SARJAX_NATIVE"  # "0", "off", "false" or "no": use the JAX formulation
ENV_DIR = "SARJAX_NATIVE_DIR"
SOURCE = Path(__file__).with_name("spread.cc")
TARGETS = {np.dtype(np.complex64): "sarjax_spread_c64",
           np.dtype(np.complex128): "sarjax_spread_c128"}
_FLAGS = ("-O3", "-std=c++17", "-shared", "-fPIC",
          # lets the compiler vectorise the rounding of the fractions (no value changes:
          # no floating-point exception is ever inspected)
          "-fno-trapping-math")
_ARCH = "-march=native"
_BUILD_SECONDS = 300

_lock = threading.Lock()
_library: ctypes.CDLL | None = None
_reason = "not tried"


def enabled() -> bool:
    """False where ``$SARJAX_NATIVE`` turns the native kernels off."""
    return os.environ.get(ENV_SWITCH, "1").strip().lower() not in ("0", "off", "false", "no")


def available() -> bool:
    """True once the kernels are built, loaded and registered for the CPU in this
    process (built or loaded on the first call; thread-safe)."""
    global _library, _reason
    if not enabled():
        return False
    with _lock:
        if _library is None and _reason == "not tried":
            try:
                library = ctypes.CDLL(str(_build()))
                for name in TARGETS.values():
                    jax.ffi.register_ffi_target(
                        name, jax.ffi.pycapsule(getattr(library, name)), platform="cpu")
            except (OSError, RuntimeError, AttributeError, subprocess.SubprocessError) as e:
                _reason = f"unavailable: {e}"
                logger.info("sarjax native kernels %s; the JAX formulation runs instead",
                            _reason)
            else:
                _library, _reason = library, "loaded"
    return _library is not None


def status() -> str:
    """``"native"`` when the kernels run, else why not (for benchmark records)."""
    if not enabled():
        return f"off (${ENV_SWITCH})"
    return "native" if available() else _reason


def folder() -> Path:
    """Where built libraries are kept (module docstring)."""
    if os.environ.get(ENV_DIR):
        return Path(os.environ[ENV_DIR]).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "sarjax" / "native"


def _compiler() -> list[str]:
    if os.environ.get("CXX"):
        return os.environ["CXX"].split()
    for name in ("c++", "g++", "clang++"):
        if found := shutil.which(name):
            return [found]
    raise RuntimeError("no C++ compiler found (set $CXX)")


def _cpu() -> str:
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
    except OSError:
        return platform.processor()
    return "\n".join(sorted({line for line in lines
                             if line.startswith(("model name", "flags"))}))


def _build() -> Path:
    """The library for this source, compiler and machine: built if not there yet."""
    compiler = _compiler()
    version = subprocess.run([*compiler, "--version"], capture_output=True, text=True,
                             timeout=60).stdout
    include = jax.ffi.include_dir()
    key = hashlib.sha256("\0".join([
        SOURCE.read_text(), " ".join(compiler), version, " ".join(_FLAGS), _ARCH,
        jax.__version__, getattr(jax.lib, "__version__", ""), platform.machine(), _cpu(),
        (Path(include) / "xla" / "ffi" / "api" / "c_api.h").read_text(),
    ]).encode()).hexdigest()[:24]
    target = _writable(folder()) / f"spread-{key}.so"
    if target.exists():
        return target
    handle, partial = tempfile.mkstemp(dir=target.parent, prefix=".spread-", suffix=".so")
    os.close(handle)
    try:
        errors = ""
        for arch in ([_ARCH], []):  # a compiler without -march=native builds generic code
            run = subprocess.run([*compiler, *_FLAGS, *arch, "-I", include, str(SOURCE),
                                  "-o", partial], capture_output=True, text=True,
                                 timeout=_BUILD_SECONDS)
            if run.returncode == 0:
                os.replace(partial, target)
                return target
            errors = run.stderr.strip().splitlines()[-1:] or [f"exit {run.returncode}"]
        raise RuntimeError(f"{' '.join(compiler)} failed: {errors[0]}")
    finally:
        if os.path.exists(partial):
            os.unlink(partial)


def _writable(path: Path) -> Path:
    """``path`` (created), else a folder of this user's under the temporary directory."""
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        logger.info("cannot create %s (%s): building under the temporary directory",
                    path, e)
    if path.is_dir() and os.access(path, os.W_OK):
        return path
    user = getattr(os, "getuid", lambda: "user")()
    fallback = Path(tempfile.gettempdir()) / f"sarjax-native-{user}"
    fallback.mkdir(parents=True, exist_ok=True)
    return fallback
