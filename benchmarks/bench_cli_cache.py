"""The persistent compilation cache of the ``sarjax`` command: a first and a second run
of the same configuration, each a fresh process, with an empty cache folder before the
first; and the same two runs with the cache turned off (``SARJAX_CACHE_DIR=off``) as the
baseline measured in the same run, back to back per method.

Configuration: the README's three-target airborne run at 1025 pulses × 830 samples with
cm-level motion and jitter, ``sarjax simulate`` with each method named (wall time of the
whole command: start-up, compilation, the run and the file).

Each run also reports where its time goes (timers around the command's stages and jax's
own trace / lowering / compile events, ``jax.monitoring``):

* ``start-up``: the interpreter and the imports of ``sarjax.cli`` (jax, sarjax);
* ``config``: reading the TOML file and building the radar, scene and motion;
* ``checks``: ``_simulate._prepare``: input checks, the simulator's plan, its budget
  checks and the memory plan, each with the eager programs they trace and compile;
* ``program``: the simulation call: ``trace``, ``lower``, ``compile`` (XLA; a load when
  its persistent cache holds it), ``load`` (the serialised program of ``programs/``) and
  ``run`` (the rest: executing it);
* ``write``: the NetCDF file (with the import of xarray).

The script replaces its section of ``benchmarks/RESULTS.md``.

Usage::

    python benchmarks/bench_cli_cache.py [--methods small_deviation,...] [--repeat 3]
        [--no-write]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(HERE))

from _common import machine, replace_section  # noqa: E402

CONFIG = """\
preset = "airborne"
[radar]
num_pulses = 1025
[scene]
azimuth = [0.0, 0.0, 0.0]
range = [4840.0, 5140.0, 5440.0]
[motion]
deviation_rms = 0.02
jitter = 0.05
"""
METHODS = ("fourier_2d", "small_deviation", "moderate_deviation", "time_domain")

# The command, run with timers around its stages; prints one JSON line on stdout last.
CHILD = r"""
import json, os, sys, time
start = time.perf_counter()
import sarjax.cli as cli
imported = time.perf_counter()
from jax._src import monitoring
from sarjax import _exported, _simulate, io
from sarjax.cli import config
stage, spans, current = {}, [], ["other"]
events = {"jaxpr_trace_duration": "trace", "jaxpr_to_mlir_module_duration": "lower",
          "backend_compile_duration": "compile"}
def listen(event, begin, end, **_):
    kind = events.get(event.rsplit("/", 1)[-1])
    if kind:
        spans.append((current[0], kind, begin, end))
monitoring.register_event_time_span_listener(listen)
def timed(module, name, label, only=None):
    fn = getattr(module, name)
    def wrapper(*args, **kwargs):
        if only is not None and getattr(args[0], "__name__", "") != only:
            return fn(*args, **kwargs)  # the checks' eager programs: part of the checks
        outer, current[0] = current[0], label
        t = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            stage[label] = stage.get(label, 0.0) + time.perf_counter() - t
            current[0] = outer
    setattr(module, name, wrapper)
if os.environ.get("BENCH_XLA_ONLY"):  # the cache as it was: XLA's entries, no programs/
    keep = _exported.set_folder
    _exported.set_folder = lambda folder: keep(None)
timed(config, "build_run", "config")
timed(_simulate, "_prepare", "checks")
if os.environ["SARJAX_CACHE_DIR"] == "off" or os.environ.get("BENCH_XLA_ONLY"):
    timed(_simulate, "_run", "program")
else:
    timed(_exported, "_call", "program", only="_run")
    timed(_exported, "_load", "load", only="_run")
timed(io, "save", "write")
status = cli.main(sys.argv[1:])
jax_time = {}
for label, kind, begin, end in spans:  # nested events (a jit inside a jit) count once
    if not any(b <= begin and end <= e and (b, e) != (begin, end)
               for l, k, b, e in spans if k == kind):
        jax_time[f"{label}.{kind}"] = jax_time.get(f"{label}.{kind}", 0.0) + end - begin
print(json.dumps({"imports": imported - start, "main": time.perf_counter() - imported,
                  "stage": stage, "jax": jax_time, "status": status}))
sys.exit(status)
"""


def _run(folder, method, cache, index, xla_only=False):
    """Wall time [s] of one command in a fresh process, and its breakdown."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("JAX_COMPILATION_CACHE_DIR", "JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS")}
    env["SARJAX_CACHE_DIR"] = cache
    env["PYTHONPATH"] = str(folder / "source")  # the snapshot: one source for every run
    if xla_only:
        env["BENCH_XLA_ONLY"] = "1"
    out = folder / f"{method}-{Path(cache).name}-{index}.nc"
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", CHILD, "simulate", str(folder / "run.toml"),
                           "-o", str(out), "--force", "--set", f"simulate.method={method}"],
                          env=env, cwd=folder, capture_output=True, text=True)
    if done.returncode:
        raise RuntimeError(f"sarjax simulate ({method}, cache {cache}) failed: "
                           f"{done.stderr[-2000:]}")
    wall = time.perf_counter() - start
    return wall, _breakdown(wall, json.loads(done.stdout.strip().splitlines()[-1]))


def _breakdown(wall, child):
    """Seconds per stage; ``program`` split into trace, lower, compile, load and run."""
    stage, jax_time = child["stage"], child["jax"]
    program = stage.get("program", 0.0)
    parts = {k: jax_time.get(f"program.{k}", 0.0) for k in ("trace", "lower", "compile")}
    parts["load"] = stage.get("load", 0.0)
    parts["run"] = max(program - sum(parts.values()), 0.0)
    checks = stage.get("checks", 0.0)
    jax_checks = sum(jax_time.get(f"checks.{k}", 0.0) for k in ("trace", "lower", "compile"))
    return {
        "start-up": wall - child["main"],
        "config": stage.get("config", 0.0),
        "checks": checks,
        "checks jax": jax_checks,
        **{f"program {k}": v for k, v in parts.items()},
        "write": stage.get("write", 0.0),
        "other": child["main"] - program - checks - stage.get("config", 0.0)
                 - stage.get("write", 0.0),
    }


def _cell(b):
    return (f"{b['start-up']:.2f} | {b['config']:.2f} | {b['checks']:.2f} "
            f"({b['checks jax']:.2f}) | {b['program trace']:.2f} / {b['program lower']:.2f} / "
            f"{b['program compile']:.2f} / {b['program load']:.2f} / {b['program run']:.2f} | "
            f"{b['write']:.2f}")


def _pair(folder, method, cache, xla_only=False):
    """A first and a second run with one (empty) cache folder."""
    return [_run(folder, method, cache, i, xla_only) for i in range(2)]


def _median(runs):
    """Per index (first, second): the median wall time and the median of each stage."""
    return [(statistics.median(r[i][0] for r in runs),
             {k: statistics.median(r[i][1][k] for r in runs) for k in runs[0][i][1]})
            for i in range(2)]


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--methods", default=",".join(METHODS))
    p.add_argument("--repeat", type=int, default=3,
                   help="repetitions of each method's runs (medians reported)")
    p.add_argument("--no-write", action="store_true", help="do not touch RESULTS.md")
    args = p.parse_args(argv)
    info = machine()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "run.toml").write_text(CONFIG)
        # a copy of the package taken now: the programs' key holds a digest of its source,
        # which an edit of the working tree during the benchmark would change
        shutil.copytree(REPO / "sarjax", folder / "source" / "sarjax",
                        ignore=shutil.ignore_patterns("__pycache__"))
        for method in args.methods.split(","):
            cached, xla, off = [], [], []
            for r in range(args.repeat):
                cache = folder / f"cache-{method}-{r}"
                cached.append(_pair(folder, method, str(cache)))
                xla.append(_pair(folder, method, str(folder / f"xla-{method}-{r}"), True))
                off.append(_pair(folder, method, "off"))
                print(f"{method:20s} #{r}: cached {cached[-1][0][0]:6.2f} -> "
                      f"{cached[-1][1][0]:6.2f} s, XLA's cache only {xla[-1][0][0]:6.2f} -> "
                      f"{xla[-1][1][0]:6.2f} s, off {off[-1][0][0]:6.2f} / "
                      f"{off[-1][1][0]:6.2f} s", flush=True)
            ratios = [statistics.median(c[0][0] / c[1][0] for c in runs)
                      for runs in (cached, xla)]
            entries = len([p for p in cache.iterdir() if p.is_file()])
            programs = len(list((cache / "programs").glob("*.bin")))
            rows.append((method, _median(cached), _median(xla), _median(off), ratios,
                         entries, programs))
            for name, b in (("first", rows[-1][1][0][1]), ("second", rows[-1][1][1][1]),
                            ("XLA 2nd", rows[-1][2][1][1]), ("off", rows[-1][3][1][1])):
                print(f"    {name:7s} " + "  ".join(f"{k} {v:.2f}" for k, v in b.items()),
                      flush=True)
    lines = [
        "## The command's compilation cache (`bench_cli_cache.py`)",
        "",
        f"Machine: {info['cpu']}, {info['usable_cores']} cores, load {info['load']:.2f}; "
        f"commit {info['commit']}, jax {info['jax']}, {info['date']}.",
        "",
        "`sarjax simulate` of the README's three-target run (1025 × 830, cm-level motion "
        "and jitter), wall time of the whole command in a fresh process; the second run "
        "finds the first run's programs in the cache folder (XLA's entries and the "
        "serialised simulation program). Compared in the same run: XLA's cache alone (no "
        "`programs/`, the cache before the programs were kept) and `SARJAX_CACHE_DIR=off`. "
        f"Each pair of runs back to back, {args.repeat} times per method (fresh folders): "
        "medians, and the median of the pairs' speed-ups.",
        "",
        "| method | first run [s] | second run [s] | speed-up | XLA's cache only: 1st → 2nd "
        "[s] (speed-up) | cache off, 1st / 2nd [s] | XLA entries / programs |",
        "|---|---|---|---|---|---|---|",
    ]
    for method, cached, xla, off, ratios, entries, programs in rows:
        lines.append(f"| `{method}` | {cached[0][0]:.2f} | {cached[1][0]:.2f} | "
                     f"{ratios[0]:.1f}× | {xla[0][0]:.2f} → {xla[1][0]:.2f} "
                     f"({ratios[1]:.1f}×) | {off[0][0]:.2f} / {off[1][0]:.2f} | "
                     f"{entries} / {programs} |")
    lines += [
        "",
        "Where the time goes [s] (medians): start-up (interpreter, imports) | config | "
        "checks (of which jax tracing, lowering, compiling their eager programs) | the "
        "simulation program: trace / lower / compile / load / run (dispatch; a loaded "
        "program's first run is waited for) | write (waits for the data, imports xarray).",
        "",
        "| method | run | start-up | config | checks (jax) | program: trace / lower / "
        "compile / load / run | write |",
        "|---|---|---|---|---|---|---|",
    ]
    for method, cached, xla, off, _, _, _ in rows:
        for name, b in (("first", cached[0][1]), ("second", cached[1][1]),
                        ("second, XLA's cache only", xla[1][1]), ("cache off", off[1][1])):
            lines.append(f"| `{method}` | {name} | {_cell(b)} |")
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        replace_section("bench_cli_cache", text)


if __name__ == "__main__":
    main()
