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
os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0.2")

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


# Seconds each module takes on the 2-core machine (pytest --durations, rounded). With
# ``--dist loadfile`` a module runs whole on one worker; scheduling the longest first
# (the rest keep their order) keeps a long module from running alone at the end while
# the other worker idles.
_MODULE_SECONDS = {
    "test_docs.py": 130,  # the site's build, every notebook executed
    "test_inverse.py": 108, "test_squint_fourier.py": 95, "test_validity.py": 93,
    "test_high_speed.py": 80, "test_fourier.py": 74, "test_properties.py": 65,
    "test_reproducibility.py": 61, "test_fidelity.py": 60, "test_export.py": 60,
    "test_gradients_all.py": 47, "test_focusing.py": 40, "test_nufft.py": 38,
    "test_sharding.py": 37, "test_bad_inputs.py": 37, "test_memory.py": 32,
    "test_batch.py": 30, "test_ambiguities.py": 30, "test_readme.py": 28,
    "test_gradients.py": 25, "test_fourier_gradients.py": 23, "test_cli.py": 19,
    "test_sicd.py": 6, "test_distributed.py": 55,
    "test_campaign.py": 60, "test_compilation_cache.py": 40, "test_autofocus.py": 20,
}


def pytest_configure(config):
    # pytest-xdist (≥ 3.2) reorders ``--dist loadfile`` modules by their number of tests,
    # which put the site's build (3 tests, the longest module) last; keep the order below
    if hasattr(config.option, "loadscopereorder"):
        config.option.loadscopereorder = False


def pytest_collection_modifyitems(session, config, items):
    items.sort(key=lambda item: -_MODULE_SECONDS.get(item.path.name, 0))  # stable
