import ctypes
import gc
import os
import pathlib

# One compilation cache for the whole suite: the test processes (pytest-xdist workers), the
# notebook kernels and the subprocess tests inherit it, so a program compiled once is
# loaded from disk afterwards — also after a module has released its programs (below).
# XLA keys each entry on the program, the compile options and the jax/jaxlib versions.
# Tests that must compile afresh turn it off (test_reproducibility.py).
_COMPILATION_CACHE = pathlib.Path(__file__).resolve().parent.parent / ".pytest_cache" / "jax"
os.environ.setdefault("JAX_COMPILATION_CACHE_DIR", str(_COMPILATION_CACHE))
os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0.5")

import jax  # noqa: E402
import pytest  # noqa: E402

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_rank_promotion", "raise")

import sarjax  # noqa: E402,F401  (enables x64 as the library does)


@pytest.fixture(autouse=True, scope="module")
def _release_compiled_programs():
    """Each test module compiles its own shapes; the compiled programs of a finished
    module are released (jax keeps every one otherwise: one process of the suite grew to
    6.9 GB)."""
    yield
    jax.clear_caches()
    gc.collect()
    _trim()


def _trim():
    """Hand the freed heap back to the system (glibc keeps it otherwise)."""
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except OSError:  # not glibc
        pass
