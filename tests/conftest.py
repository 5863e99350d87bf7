import ctypes
import gc

import jax
import pytest

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
