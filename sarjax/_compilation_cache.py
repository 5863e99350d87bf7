"""The persistent compilation cache: compiled programs kept on disk between processes.

A Fourier-domain method's first call compiles for seconds (the engine's block body, the
budget checks); with the cache, a later process running the same shapes loads the
programs instead. The ``sarjax`` command turns it on for every run; in Python it is an
opt-in, :func:`enable_compilation_cache`. JAX writes each entry under a key of the
program, its compile options and the jax/jaxlib versions, to a temporary name renamed
into place, so processes running at once share one folder safely, and an upgrade of jax
never loads a stale program.
"""

from __future__ import annotations

import os
from pathlib import Path

import jax

ENV_DIR = "SARJAX_CACHE_DIR"  # where; "off" turns the command's cache off
# programs that compile faster than this are not worth a disk entry (most budget checks
# compile in 0.1-0.3 s, the engine's block bodies in 1-3 s)
MIN_COMPILE_SECONDS = 0.1


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

    Returns:
        The cache folder in use, or None when ``$SARJAX_CACHE_DIR`` is ``off``.
    """
    current = jax.config.jax_compilation_cache_dir
    if current:
        return Path(current)
    if path is None and os.environ.get(ENV_DIR, "").lower() == "off":
        return None
    folder = Path(path).expanduser() if path is not None else default_cache_dir()
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise ValueError(f"compilation cache folder {folder} cannot be created: {err}; "
                         f"set {ENV_DIR} to another folder, or to 'off'") from None
    jax.config.update("jax_compilation_cache_dir", str(folder))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", MIN_COMPILE_SECONDS)
    return folder
