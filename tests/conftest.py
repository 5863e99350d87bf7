import ctypes
import gc
import os
import pathlib
import sys

# One compilation cache for the whole suite: the test processes (pytest-xdist workers), the
# notebook kernels and the subprocess tests inherit it, so a program compiled once is
# loaded from disk afterwards — also after a module has released its programs (below).
# XLA keys each entry on the program, the compile options and the jax/jaxlib versions.
# Tests that must compile afresh turn it off (test_reproducibility.py). Every program is
# kept, however quick to compile: the suite's processes compile the same small programs
# many times over (a clean-clone CI run, same commit: 699 s with programs under 0.2 s of
# compilation left out, 655 s with none left out).
_COMPILATION_CACHE = pathlib.Path(__file__).resolve().parent.parent / ".pytest_cache" / "jax"
os.environ.setdefault("JAX_COMPILATION_CACHE_DIR", str(_COMPILATION_CACHE))
os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0")


# The suite starts many Python processes (workers, notebook kernels, the README's
# commands, the CLI, campaign and forced-device tests); with PYTHONDONTWRITEBYTECODE set
# (as on the build machine) each compiled sarjax's modules from source again (`import
# sarjax.cli` 1.14-1.33 s against 0.99-1.05 s with their bytecode): the first process
# writes it.
os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
sys.dont_write_bytecode = False


def _default_xla_flag(name, value):
    """Add ``--name=value`` to XLA_FLAGS unless XLA_FLAGS already names the option."""
    if name not in os.environ.get("XLA_FLAGS", ""):
        os.environ["XLA_FLAGS"] = (os.environ.get("XLA_FLAGS", "") + f" --{name}={value}").strip()


# XLA's CPU backend compiles the suite's programs with its elemental emitters instead of
# its fusion emitters (the default). Compiling is most of the suite's time: a clean run of
# test_fidelity compiled 87 simulator programs in 149 s of its 258 s, one per drawn case.
# On a test's grid (512 x 256) the elemental emitters compile fourier_2d in 1.7 s instead
# of 3.1 s, moderate_deviation in 2.0 s instead of 2.9 s, at the same run time
# (benchmarks/bench_emitters.py); the whole suite, cold cache, two workers: 966 s instead
# of 1207 s, the same 747 tests passing. Results agree to rounding (<= 6e-15 of the peak,
# every Fourier method, the NUFFT model, omega-k). Users keep XLA's default: at full size
# it compiles as fast and runs the NUFFT model 1.5x faster (1.53 against 2.23 s). The
# subprocesses (notebooks, README commands, forced devices) inherit the setting; an
# XLA_FLAGS that names the option keeps its own choice.
_default_xla_flag("xla_cpu_use_fusion_emitters", "false")
# Each test process runs XLA's programs on one thread (Eigen's pool off). The suite runs
# two processes on two cores, each mostly compiling (one thread); a program run on a pool
# of two threads beside the other process's compilation oversubscribed the cores. Two
# workers, cold cache, back to back: test_fidelity, test_focusing, test_validity and
# test_fourier 267 s instead of 295 s (CPU 476 s instead of 525 s); test_inverse,
# test_gradients_all, test_export, test_nufft, test_high_speed and test_squint_fourier
# 142 s instead of 158 s (CPU 261 s instead of 292 s); the same tests passing. Users keep
# XLA's default.
_default_xla_flag("xla_cpu_multi_thread_eigen", "false")

import jax  # noqa: E402
import pytest  # noqa: E402
from hypothesis import settings  # noqa: E402

# The property tests' cases: by default each test draws the same cases on every run (a
# seed derived from the test), so CI is reproducible, and no example database is written.
# ``--hypothesis-profile=fresh`` draws new cases on every run instead: the way to test the
# claims (no warning means accurate, ...) on scenes nobody has run yet, e.g.
# ``python -m pytest -m slow --hypothesis-profile=fresh tests/test_fidelity.py``; a
# failure prints the drawn case and the ``@reproduce_failure`` line that replays it.
settings.register_profile("sarjax", deadline=None, derandomize=True, database=None)
settings.register_profile("fresh", parent=settings.get_profile("sarjax"), derandomize=False,
                          print_blob=True)
settings.load_profile("sarjax")  # before --hypothesis-profile, which overrides it

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_rank_promotion", "raise")

import sarjax  # noqa: E402,F401  (enables x64 as the library does)


@pytest.fixture(autouse=True, scope="module")
def _release_compiled_programs():
    """Each test module compiles its own shapes; the compiled programs are released after
    a module that leaves the process above ``_RESIDENT_LIMIT`` (jax keeps every one
    otherwise: one process of the suite grew to 6.9 GB). Below it they are kept for the
    next modules, which compile many of the same programs (the budgets' programs, the
    small eager ones, the simulations of the common test grids)."""
    yield
    if _resident() > _RESIDENT_LIMIT:
        _release()


_RESIDENT_LIMIT = 3 << 30  # bytes: a worker's share of the 24 GB machine, with room


def _resident() -> int:
    """The process's resident memory [bytes] (0 where /proc is not there)."""
    try:
        with open("/proc/self/statm") as statm:
            return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


@pytest.fixture(autouse=True)
def _release_programs_before_the_mapping_limit():
    """Every compiled XLA program holds memory mappings of its own (code and data), and
    a module that compiles thousands (test_fidelity's drawn scenes: ~50 more mappings a
    second) reached the kernel's limit per process (``vm.max_map_count``, 65 530 here):
    XLA then crashed wherever it next mapped memory (compiling, or writing or reading
    the persistent cache). After any test that leaves the process above half the limit,
    its compiled programs are released."""
    yield
    if _MAPPING_LIMIT and _mappings() > _MAPPING_LIMIT // 2:
        _release()


def _release():
    """Release every compiled program and hand the freed memory back."""
    jax.clear_caches()
    gc.collect()
    _trim()


def _mapping_limit():
    try:
        return int(pathlib.Path("/proc/sys/vm/max_map_count").read_text())
    except (OSError, ValueError):  # not Linux
        return 0


def _mappings():
    """The process's memory mappings (0 where /proc is not there)."""
    try:
        with open("/proc/self/maps", "rb") as maps:
            return sum(1 for _ in maps)
    except OSError:
        return 0


_MAPPING_LIMIT = _mapping_limit()


def _trim():
    """Hand the freed heap back to the system (glibc keeps it otherwise)."""
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except OSError:  # not glibc
        pass


# Seconds each module takes on the 2-core machine with a cold compilation cache (CI's
# case; pytest --durations of a clean-clone run, summed per module and rounded). With
# ``--dist loadfile`` a module runs whole on one worker; scheduling the longest first
# (the rest keep their order) keeps a long module from running alone at the end while
# the other worker idles.
_MODULE_SECONDS = {
    "test_fidelity.py": 204,
    "test_docs.py": 165,  # the site's build, every notebook executed
    "test_focusing.py": 107, "test_validity.py": 104, "test_inverse.py": 74,
    "test_readme.py": 57, "test_fourier.py": 57, "test_gradients_all.py": 50,
    "test_memory.py": 46, "test_export.py": 45, "test_nufft.py": 41,
    "test_high_speed.py": 41, "test_squint_fourier.py": 38, "test_sharding.py": 35,
    "test_autofocus.py": 33, "test_distributed.py": 27, "test_campaign.py": 27,
    "test_cli.py": 27, "test_compilation_cache.py": 23, "test_properties.py": 22,
    "test_ambiguities.py": 21, "test_gradients.py": 20, "test_concurrent_checks.py": 19,
    "test_batch.py": 18, "test_reproducibility.py": 17, "test_bad_inputs.py": 14,
    "test_fourier_gradients.py": 14, "test_map_drift.py": 13, "test_models.py": 13,
    "test_chirp_scaling.py": 12, "test_interpolation.py": 12, "test_retrace.py": 9,
    "test_precision.py": 7, "test_layers.py": 5, "test_sicd.py": 5,
}


def pytest_configure(config):
    # pytest-xdist (≥ 3.2) reorders ``--dist loadfile`` modules by their number of tests,
    # which put the site's build (3 tests, one build of ~230 s) last; keep the order below
    if hasattr(config.option, "loadscopereorder"):
        config.option.loadscopereorder = False


def pytest_collection_modifyitems(session, config, items):
    items.sort(key=lambda item: -_MODULE_SECONDS.get(item.path.name, 0))  # stable
