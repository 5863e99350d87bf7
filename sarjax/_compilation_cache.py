"""The persistent compilation cache: compiled programs kept on disk between processes.

A Fourier-domain method's first call traces and compiles for seconds (the engine's block
body, the budget checks); with the cache, a later process running the same call loads
the programs instead. The ``sarjax`` command turns it on for every run; in Python it is
an opt-in, :func:`enable_compilation_cache`. Two kinds of entry share the folder:

* XLA's entries (``jit_<name>-<hash>-cache``), every program jax compiles: JAX keys each
  on the program, its compile options and the jax/jaxlib versions. jax 0.10 writes an
  entry in place (no temporary name, and no lock unless the cache has a size limit): a
  process reading an entry another was still writing found it truncated, warned
  (``Error reading persistent compilation cache entry``) and compiled the program
  itself. Importing sarjax makes jax's file cache write each entry to a temporary name
  and rename it into place (:class:`_WholeEntries`), so a reader finds an entry whole
  or not at all; a cache jax had already opened before sarjax was imported keeps
  jax's writer.
* ``programs/``: the simulation call itself, traced, compiled and serialised
  (:mod:`sarjax._exported`), so a later process skips its tracing too; keyed on
  everything static (method, options, plan, shapes, dtypes, devices, versions, the
  sarjax source), written to a temporary name renamed into place.

Processes running at once therefore share one folder safely, and an upgrade never loads
a stale program.
"""

from __future__ import annotations

import os
import threading
from pathlib import Path

import jax

from . import _exported

ENV_DIR = "SARJAX_CACHE_DIR"  # where; "off" turns the command's cache off
PROGRAMS = "programs"  # the sub-folder of the serialised simulation programs
# every program gets an entry: the 30-40 small eager ones (input conversion, budget
# checks) compile in 5-80 ms each and together cost 0.3-0.6 s a run, more than loading
MIN_COMPILE_SECONDS = 0.0


def default_cache_dir() -> Path:
    """``$SARJAX_CACHE_DIR``, else ``$XDG_CACHE_HOME/sarjax/jax``, else
    ``~/.cache/sarjax/jax``."""
    if os.environ.get(ENV_DIR):
        return Path(os.environ[ENV_DIR]).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "sarjax" / "jax"


def enable_compilation_cache(path=None) -> Path | None:
    """Keep compiled programs in ``path`` (default :func:`default_cache_dir`) for later
    processes; call before the first simulation. A folder already chosen for JAX (the
    ``JAX_COMPILATION_CACHE_DIR`` environment variable, or ``jax.config``) is kept.

    Covers every program jax compiles (XLA's cache) and, in the sub-folder ``programs``,
    the traced and compiled program of each :func:`sarjax.simulate` call, so that a later
    process with the same call skips tracing as well (:mod:`sarjax._exported`: the key,
    the files). The input checks and validity warnings still run on every call.

    Returns:
        The cache folder in use, or None when ``$SARJAX_CACHE_DIR`` is ``off``.
    """
    off = path is None and os.environ.get(ENV_DIR, "").lower() == "off"
    current = jax.config.jax_compilation_cache_dir
    if current:
        _exported.set_folder(None if off else Path(current) / PROGRAMS)
        return Path(current)
    if off:
        _exported.set_folder(None)
        return None
    folder = Path(path).expanduser() if path is not None else default_cache_dir()
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise ValueError(f"compilation cache folder {folder} cannot be created: {err}; "
                         f"set {ENV_DIR} to another folder, or to 'off'") from None
    jax.config.update("jax_compilation_cache_dir", str(folder))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", MIN_COMPILE_SECONDS)
    _exported.set_folder(folder / PROGRAMS)
    return folder



try:  # jax's private cache modules (jax 0.10): where they differ, jax's own writer stays
    from jax._src import compilation_cache as _jax_cache
    from jax._src import lru_cache as _jax_lru
except ImportError:
    _jax_cache = _jax_lru = None

if _jax_lru is not None and isinstance(getattr(_jax_lru, "LRUCache", None), type):

    class _WholeEntries(_jax_lru.LRUCache):
        """jax's file cache, an entry written to a temporary name in the same folder
        and renamed into place (``os.replace``, atomic on a local file system): a
        process reading the cache finds each entry whole or absent. With a size limit
        (jax's file lock) or on a remote file system, jax's own writer."""

        writes_whole_entries = True

        def put(self, key: str, value: bytes) -> None:
            if self.eviction_enabled or "://" in str(self.path):
                return super().put(key, value)
            if not key:
                raise ValueError("key cannot be empty")
            folder = Path(str(self.path))
            entry = folder / f"{key}{_jax_lru._CACHE_SUFFIX}"
            if entry.exists():
                return
            temporary = folder / f".{entry.name}.{os.getpid()}.{threading.get_ident()}.tmp"
            try:
                temporary.write_bytes(value)
                os.replace(temporary, entry)
            finally:
                temporary.unlink(missing_ok=True)

    _jax_cache.LRUCache = _WholeEntries  # what jax opens its file cache with
