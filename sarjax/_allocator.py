"""Freed memory kept for the next call: glibc's allocator settings for repeated simulations.

XLA's CPU runtime allocates a call's temporaries afresh on every execution. glibc serves
an allocation above its mmap threshold (32 MB at most), or one that a thread's arena
(64 MB heaps) cannot hold, straight from the kernel and unmaps it on free, so the next
call touches new pages again: a minor page fault per 4 KiB page, about 2 µs each on the
reference machine (a virtual machine). Measured on the seed 000 scene of
``benchmarks/bench_fourier.py`` (complex64, one core): 14 k faults (55 MB) per ideal
2-D call, 9 k (37 MB) for Algorithm A, 34 k (131 MB) for Algorithm B, 10–20 % of each
call; with :func:`retain_freed_memory`, a few hundred.

The settings, ``mallopt(3)``: ``M_MMAP_MAX = 0`` (no allocation is served by its own
mapping), ``M_TRIM_THRESHOLD`` at its largest (the heap's free top is not handed back)
and ``M_ARENA_MAX = 1`` (every thread allocates from the main heap, which can grow past
64 MB). They are process-wide and the process keeps its peak memory until it exits:
the ``sarjax`` command sets them for its run; in Python they are an opt-in.

They must be set **before JAX's backend starts** (its first computation): XLA's threads,
which allocate each call's temporaries, take their own arenas when they start, and a
thread keeps its arena, so a later ``M_ARENA_MAX = 1`` does not reach them and their
large blocks are still mapped and unmapped on every call (Algorithm B, seed 000,
complex64, two cores: set at the start 2.0 k faults and 122–127 ms a call; set after
one computation 29 k faults and 146 ms, as without). Called later,
:func:`retain_freed_memory` changes nothing and warns (:class:`FreedMemoryWarning`).
The same settings in the environment before the process starts reach every thread
(2.0 k faults, 122 ms): ``GLIBC_TUNABLES`` set to
``glibc.malloc.arena_max=1:glibc.malloc.mmap_max=0:glibc.malloc.trim_threshold=2147483647``
(:data:`TUNABLES`).

An alternative that does not keep the peak, set in the environment before the process
starts (glibc reads it then): ``GLIBC_TUNABLES=glibc.malloc.hugetlb=1`` makes glibc ask
for transparent huge pages on its mappings, where the kernel allows them
(``/sys/kernel/mm/transparent_hugepage/enabled`` not ``never``), so that a fault maps
2 MiB: on the same scene 9.5 k → 169 faults per ideal 2-D call (75.8 → 63.0 ms) and
37.6 k → 403 for Algorithm B (245 → 197 ms), its resident memory after the calls as
without (``benchmarks/README.md``).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import warnings

# mallopt(3) parameters (glibc <malloc.h>)
M_TRIM_THRESHOLD = -1
M_MMAP_MAX = -4
M_ARENA_MAX = -8
SETTINGS = ((M_MMAP_MAX, 0), (M_TRIM_THRESHOLD, 2**31 - 1), (M_ARENA_MAX, 1))


def _libc():
    """glibc's ``mallopt``, or None on another C library."""
    name = ctypes.util.find_library("c") or "libc.so.6"
    try:
        mallopt = ctypes.CDLL(name).mallopt
    except (OSError, AttributeError):
        return None
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    return mallopt


class FreedMemoryWarning(UserWarning):
    """:func:`retain_freed_memory` was called after JAX's backend started: it changed
    nothing (the message says what to do instead)."""


# the environment that gives a process the same settings from its start (glibc's names)
_TUNABLE_NAMES = {M_ARENA_MAX: "arena_max", M_MMAP_MAX: "mmap_max",
                  M_TRIM_THRESHOLD: "trim_threshold"}
TUNABLES = "GLIBC_TUNABLES=" + ":".join(
    f"glibc.malloc.{name}={dict(SETTINGS)[param]}" for param, name in _TUNABLE_NAMES.items())


def _backend_started() -> bool:
    """Whether JAX's backends, and with them XLA's threads, have started (False where
    this JAX does not say)."""
    try:
        from jax._src import xla_bridge
    except ImportError:
        return False
    started = getattr(xla_bridge, "backends_are_initialized", None)
    return bool(started()) if started is not None else False


def retain_freed_memory() -> bool:
    """Keep the memory a call frees for the next call instead of returning it to the
    system (module docstring: fewer page faults, 10–20 % faster repeated calls of the
    Fourier-domain methods here). Process-wide, for the rest of the process: its
    resident memory stays at its peak. Call it once, **before the first JAX
    computation** (right after ``import sarjax``): XLA's threads keep the allocator
    arenas they take when the backend starts, which the settings do not reach.

    Returns:
        True when the C library is glibc and took every setting; False otherwise: on
        another C library, or after JAX's backend started (then nothing is changed and
        a :class:`FreedMemoryWarning` says how to get the settings instead).
    """
    mallopt = _libc()
    if mallopt is None:
        return False
    if _backend_started():
        warnings.warn(FreedMemoryWarning(
            "sarjax.retain_freed_memory() changed nothing: JAX's backend has started, and "
            "its threads, which allocate each call's temporaries, keep the allocator "
            "arenas they have, whose large blocks are returned to the system after every "
            "call all the same. Call it before the first JAX computation (right after "
            f"`import sarjax`), or start the process with {TUNABLES} in its "
            "environment."), stacklevel=2)
        return False
    return all(mallopt(param, value) == 1 for param, value in SETTINGS)
