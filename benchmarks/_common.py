"""What every benchmark shares: one timer, the machine description and the writer of
``benchmarks/RESULTS.md``.

Timing (see README.md, "How timing works"):

* :func:`timed` — wall time (``time.perf_counter``) and process CPU time
  (``time.process_time``, every thread of the process) of one call, its result blocked on
  (``jax.block_until_ready``).
* :func:`steady` — ``repeats`` calls after the compiling one: the minimum, median and
  maximum wall time, and the CPU time of the fastest repeat.
* :func:`aot_compile_time` — lowering and compiling the jitted program behind a
  ``sarjax.simulate`` call ahead of time (``.lower(...).compile()``), where the first call
  would mix compiling with running.

:func:`replace_section` rewrites one script's ``<!-- name:start -->`` …
``<!-- name:end -->`` section of RESULTS.md and keeps every other section as it is.
"""

from __future__ import annotations

import datetime
import os
import platform
import statistics
import subprocess
import time
from pathlib import Path
from typing import NamedTuple

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
RESULTS = HERE / "RESULTS.md"
HEADER = """# Benchmark results

Each section below is written by one script in this folder (see [README.md](README.md))
and replaced only by that script; do not edit inside the marked sections.
"""


# ---- timing -----------------------------------------------------------------------------


def timed(fn):
    """(wall s, process CPU s, result) of ``fn()``, the result blocked on when it holds
    JAX arrays."""
    import jax

    c0, t0 = time.process_time(), time.perf_counter()
    out = jax.block_until_ready(fn())
    return time.perf_counter() - t0, time.process_time() - c0, out


class Steady(NamedTuple):
    """Steady-state timing over repeated calls [s]: ``min``/``median``/``max`` wall time,
    ``cpu`` the process CPU time of the fastest call, ``walls`` every call's wall time."""

    min: float
    median: float
    max: float
    cpu: float
    walls: tuple


def steady(fn, repeats):
    """:class:`Steady` over ``repeats`` (≥ 1) calls of ``fn`` (compile it before)."""
    runs = [timed(fn)[:2] for _ in range(max(int(repeats), 1))]
    walls = tuple(w for w, _ in runs)
    best, cpu = min(runs)
    return Steady(best, statistics.median(walls), max(walls), cpu, walls)


def captured_entry(call):
    """(``_run``, args, kwargs): the jitted entry point behind ``call()`` and the
    arguments ``simulate`` passes it, captured without running it (``_run`` swapped for a
    spy for one call); args None when ``call`` did not reach it."""
    from sarjax import _simulate

    real = _simulate._run
    captured = {}

    class _Captured(Exception):
        pass

    def spy(*args, **kwargs):
        captured["args"], captured["kwargs"] = args, kwargs
        raise _Captured

    _simulate._run = spy
    try:
        call()
    except _Captured:
        pass
    finally:
        _simulate._run = real
    return real, captured.get("args"), captured.get("kwargs")


def aot_compile_time(call):
    """(lower s, compile s) of the jitted entry point behind ``call()``, or None.

    ``simulate`` validates its inputs and then calls ``sarjax._simulate._run``
    (an ``eqx.filter_jit``); the arguments are captured (:func:`captured_entry`), then
    ``_run.lower(*args).compile()`` is timed. This reaches a private name, so any
    failure falls back to "first call − steady".
    """
    try:
        real, args, kwargs = captured_entry(call)
        if args is None:
            return None
        t0 = time.perf_counter()
        lowered = real.lower(*args, **kwargs)
        t1 = time.perf_counter()
        lowered.compile()
        t2 = time.perf_counter()
        return t1 - t0, t2 - t1
    except Exception as err:  # noqa: BLE001 - fall back, but say why
        print(f"  (AOT compile timing unavailable: {type(err).__name__}: {err})")
        return None


# ---- the machine --------------------------------------------------------------------------


def cpu_model():
    """The CPU model name (``/proc/cpuinfo``, else the platform's processor)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def _git(*args):
    try:
        return subprocess.run(["git", "-C", str(REPO), *args], capture_output=True,
                              text=True, timeout=10, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""


def commit():
    """The short commit, marked when ``sarjax/`` has uncommitted changes."""
    head = _git("rev-parse", "--short", "HEAD") or "unknown"
    dirty = bool(_git("status", "--porcelain", "--", "sarjax"))
    return head + (" (sarjax/ has uncommitted changes)" if dirty else "")


def load_average():
    """The 1-minute load average (nan where the system has none)."""
    try:
        return os.getloadavg()[0]
    except (AttributeError, OSError):
        return float("nan")


def machine():
    """The machine and software a result was measured on: CPU model, cores (all and
    usable by this process), load average, commit, versions, devices and date."""
    import jax
    import jaxlib
    import numpy as np

    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:
        usable = os.cpu_count()
    return dict(
        cpu=cpu_model(), cores=os.cpu_count(), usable_cores=usable, load=load_average(),
        commit=commit(), jax=jax.__version__, jaxlib=jaxlib.__version__,
        numpy=np.__version__, python=platform.python_version(),
        backend=jax.default_backend(),
        devices=", ".join(str(d) for d in jax.devices()),
        date=datetime.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M %Z"),
    )


# ---- RESULTS.md ---------------------------------------------------------------------------


def markers(name):
    """The (start, end) comment lines around section ``name``."""
    return f"<!-- {name}:start -->", f"<!-- {name}:end -->"


def replace_section(name, text, path=RESULTS):
    """Write ``text`` as section ``name`` of ``path``: replaces the text between its
    markers (inclusive), or appends it; every other section is kept as it is. ``text``
    may hold its markers already."""
    start, end = markers(name)
    body = text.strip()
    if body.startswith(start):
        body = body[len(start):]
    if body.endswith(end):
        body = body[: -len(end)]
    block = f"{start}\n{body.strip()}\n{end}"
    path = Path(path)
    old = path.read_text() if path.exists() else HEADER
    if start in old and end in old.split(start, 1)[1]:
        before, rest = old.split(start, 1)
        new = before + block + rest.split(end, 1)[1]
    else:
        new = old.rstrip("\n") + "\n\n" + block + "\n"
    tmp = path.with_suffix(path.suffix + f".{name}.tmp")
    tmp.write_text(new)
    os.replace(tmp, path)
    print(f"wrote {path} (section {start} … {end})")
