"""The ``sarjax`` command: demo, simulate, focus, autofocus, metrics, fit, check, export, plot,
campaign, launch.

Every command takes ``--help``. Files are NetCDF-4 (:mod:`sarjax.io`): ``simulate`` writes
raw data with every parameter of the run, ``focus`` an image carrying them on, so each
file reproduces its run. Outputs are written atomically and never replace an existing
file without ``--force``. Exit status 0 on success; on bad input one line
``sarjax: error: …`` on stderr and status 2 (1 for an unexpected internal error, also
one line; ``SARJAX_TRACEBACK=1`` shows its traceback).

Compiled programs are kept between runs in ``~/.cache/sarjax/jax``
(``$XDG_CACHE_HOME`` respected; ``SARJAX_CACHE_DIR`` names another folder, ``off`` none):
XLA's entries and, under ``programs/``, each simulation call traced and compiled, so a
second run of a configuration skips both (:mod:`sarjax._compilation_cache`; the key and
its safety under concurrent runs: the architecture page, "The compilation cache"). The
command also keeps the memory a call frees for the next one (:mod:`sarjax._allocator`;
not when :func:`main` is called from Python with its arguments).

The configuration files (TOML) of ``simulate`` and their keys: :mod:`sarjax.cli.config`.
The verbs: :mod:`sarjax.cli.commands`.
"""

from __future__ import annotations

import os
import sys
import warnings

import click

from .commands import cli as cli
from .config import Fail
from .config import build_run as build_run
from .config import load_config as load_config
from .config import simulate_config as simulate_config


def _one_line_warning(message, category, filename, lineno, file=None, line=None):
    text = " ".join(str(message).split())
    print(f"sarjax: warning: {text} ({category.__name__})", file=sys.stderr)


def main(argv=None) -> int:
    """Entry point of the ``sarjax`` command; returns the exit status."""
    from .. import _allocator, _exported
    from .._compilation_cache import enable_compilation_cache

    if argv is None:  # run as the command (not called from Python with its arguments)
        # a call reuses the memory the last one freed (set before JAX's backend starts)
        _allocator.retain_freed_memory()
    if os.environ.get("SARJAX_COORDINATOR"):  # one of the processes of a launched run
        from .. import distributed

        distributed.initialize()

    kept = _exported.folder()  # restored on return (main called from Python)
    try:
        # a later run of the same call loads its programs ($SARJAX_CACHE_DIR=off: none)
        enable_compilation_cache()
    except ValueError as err:
        print(f"sarjax: warning: {err}", file=sys.stderr)
    try:
        return _main(argv)
    finally:
        _exported.set_folder(kept)


def _main(argv):
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _one_line_warning  # one line each, as errors are
            result = cli.main(args=argv, prog_name="sarjax", standalone_mode=False)
    except click.exceptions.Exit as exit_:
        return int(exit_.exit_code)
    except click.exceptions.Abort:
        print("sarjax: error: aborted", file=sys.stderr)
        return 1
    except click.exceptions.ClickException as err:
        print(f"sarjax: error: {err.format_message()}", file=sys.stderr)
        return 2
    except (Fail, ValueError, OSError, ImportError, Warning) as err:  # Warning: -W error
        message = " ".join(str(err).split())
        print(f"sarjax: error: {message}", file=sys.stderr)
        return 2
    except Exception as err:  # a bug: still one line (the traceback on request)
        if os.environ.get("SARJAX_TRACEBACK"):
            raise
        message = " ".join(str(err).split())
        print(f"sarjax: error: internal error ({type(err).__name__}: {message}); "
              "SARJAX_TRACEBACK=1 shows where", file=sys.stderr)
        return 1
    return result if isinstance(result, int) else 0
