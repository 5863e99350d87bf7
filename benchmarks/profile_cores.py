"""Which of a Fourier-domain call's operations use the second core.

The FFT2-equivalents of issue 19 divide a call by one lone 2-D FFT, which XLA runs on
both cores. This script measures, for ``fourier_2d``, ``small_deviation`` and
``moderate_deviation`` on the seed 000 scene (``profile_fourier.seed000_case``,
complex64, freed memory kept), how much of each call's work does the same: each method
runs in two child processes, one pinned to one core (``os.sched_setaffinity`` before JAX
starts, so XLA's thread pool has one thread) and one with both. In each child:

* the call's wall time: min of 10 untraced steady calls;
* its compiled operations (the thunks XLA's CPU runtime executes, named after HLO
  instructions; loops left out, their bodies counted) under ``jax.profiler.trace``, each
  operation's time summed over the call, the least of 3 traced calls. An operation whose
  time halves on two cores is split across them (XLA partitions large fusions along their
  outer dimension); one whose time does not ran on one thread;
* on two cores, the time during which a single operation runs and nothing else does,
  for the FFTs: what their one thread costs the call's wall time;
* the call's two parts apart (min of 10 each): its compiled program alone
  (``sarjax._simulate._run``, the simulation without the checks) and its validity checks
  alone (``sarjax._validate.model_findings``). A call runs the checks in a worker thread
  beside the program, so on two cores it takes about the program's time plus what the
  checks take from it.

Beside them, one and two cores: one lone jitted FFT of the yardstick (complex128,
2560 × 675) and of one 416 × 2000 complex64 line set along its rows, and the same
transform at the end of a program of six large elementwise fusions (which XLA splits
across the cores; the transform's traced time);
and the memory bandwidth of one streaming pass (``numpy.multiply`` over 128 MiB, which
releases the interpreter lock) from one thread and from two threads at once.

Usage::

    python benchmarks/profile_cores.py [--write] [--methods ...]   # ~1.5 min on 2 cores

``--write`` replaces the ``<!-- profile_cores:start -->`` … ``<!-- profile_cores:end -->``
section of ``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
import warnings
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

METHODS = ("fourier_2d", "small_deviation", "moderate_deviation")
YARDSTICK = "yardstick FFT2, complex128 2560 × 675"  # issue 19's fixed FFT2
AFTER_FUSIONS = ("the same line set transform at the end of a program of six partitioned "
                 "fusions (its traced time)")


# ---- child: one method on a given number of cores ---------------------------------------


def _operations(events):
    """{operation: summed duration [s]} of one traced call's thunks (loops left out)."""
    ops = collections.Counter()
    for e in events:
        name = e["name"]
        if (name.startswith(("$", "Pjit", "np.", "H2D", "DevicePut", "D2H", "while",
                             "end:")) or "::" in name):
            continue
        ops[name] += e["dur"] * 1e-6
    return ops


def _alone(events):
    """{operation: seconds during which it ran and no other operation did}."""
    edges = []
    for e in events:
        name = e["name"]
        if (name.startswith(("$", "Pjit", "np.", "H2D", "DevicePut", "D2H", "while",
                             "end:")) or "::" in name):
            continue
        edges += [(e["ts"], 1, name), (e["ts"] + e["dur"], -1, name)]
    edges.sort()
    running, alone, last = collections.Counter(), collections.Counter(), None
    for t, step, name in edges:
        live = [k for k, v in running.items() if v > 0]
        if last is not None and len(live) == 1:
            alone[live[0]] += (t - last) * 1e-6
        last = t
        running[name] += step
    return alone


def _lone_transforms(repeats=30):
    """Wall time [s] of the yardstick FFT2 and of one line set's row transform."""
    import jax
    import jax.numpy as jnp
    import numpy as np

    from _common import steady

    rng = np.random.default_rng(1)
    out = {}
    for label, shape, dtype, fn in (
            (YARDSTICK, (2560, 675), jnp.complex128,
             jnp.fft.fft2),
            ("line set transform, complex64 416 × 2000 along its rows", (416, 2000),
             jnp.complex64, lambda a: jnp.fft.fft(a, axis=1))):
        a = jnp.asarray(rng.normal(size=shape) + 1j * rng.normal(size=shape), dtype)
        f = jax.jit(fn)
        jax.block_until_ready(f(a))
        out[label] = steady(lambda: f(a), repeats).min
    out[AFTER_FUSIONS] = _transform_after_fusions()
    return out


def _transform_after_fusions(traces=3):
    """The traced time [s] of the line set's transform when it ends a program after six
    elementwise fusions large enough for XLA to split across the cores (least of
    ``traces`` calls)."""
    import jax
    import jax.numpy as jnp
    import numpy as np

    import profile_fourier as pf

    rng = np.random.default_rng(2)
    a = jnp.asarray(rng.normal(size=(416, 2000)) + 1j * rng.normal(size=(416, 2000)),
                    jnp.complex64)
    w = jnp.asarray(rng.random(2000), jnp.float32)

    def program(y):
        for _ in range(6):
            y = y * jnp.exp(1j * jnp.sin(y.real * w))
        return jnp.fft.fft(y, axis=1)

    f = jax.jit(program)
    jax.block_until_ready(f(a))
    best = float("inf")
    for _ in range(traces):
        with tempfile.TemporaryDirectory() as folder:
            with jax.profiler.trace(folder, create_perfetto_trace=True):
                jax.block_until_ready(f(a))
            events = pf._events(folder)
        best = min(best, sum(e["dur"] for e in events if e["name"].startswith("fft")) * 1e-6)
    return best


def _bandwidth(threads, passes=10):
    """GB/s of ``passes`` streaming passes (128 MiB read, 128 MiB written) per thread,
    ``threads`` threads at once."""
    import numpy as np

    arrays = [(np.random.default_rng(i).random(1 << 24), np.empty(1 << 24))
              for i in range(threads)]
    for a, b in arrays:
        np.multiply(a, 1.0001, out=b)

    def work(a, b):
        for _ in range(passes):
            np.multiply(a, 1.0001, out=b)

    best = float("inf")
    for _ in range(3):
        pool = [threading.Thread(target=work, args=ab) for ab in arrays]
        t0 = time.perf_counter()
        for t in pool:
            t.start()
        for t in pool:
            t.join()
        best = min(best, time.perf_counter() - t0)
    return threads * passes * 2 * arrays[0][0].nbytes / best / 1e9


def _parts(radar, scene, motion, kwargs, repeats=10):
    """Steady wall time [s] of the call's compiled program alone and of its checks alone."""
    import jax
    import jax.numpy as jnp

    from _common import steady
    from sarjax import _exported, _simulate, _validate

    kwargs = dict(kwargs)
    plan = _simulate._prepare(
        radar, scene, motion, method=kwargs.pop("method"),
        num_pulses=kwargs.pop("num_pulses", None), num_range=kwargs.pop("num_range", None),
        near_range=kwargs.pop("near_range", None),
        azimuth_center=kwargs.pop("azimuth_center", 0.0), dtype=jnp.complex64,
        devices=None, memory_limit=None, options=kwargs)
    simulator, sim_plan, motion, acquisition, dtype, name, call, _, _, _ = plan
    run = _exported.persistent(_simulate._run)

    def program():
        return run(simulator, sim_plan, radar, scene, motion, acquisition, dtype, name,
                   call).data

    def checks():
        return _validate.model_findings(simulator, radar, scene, motion, acquisition, False,
                                        dtype)

    jax.block_until_ready(program())
    checks()
    return dict(program=steady(program, repeats).min, checks=steady(checks, repeats).min)


def child(method, cores, out):
    if cores == 1:
        os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
    import jax
    import jax.numpy as jnp

    jax.config.update("jax_enable_x64", True)
    import profile_fourier as pf
    from _common import steady

    import sarjax as sj

    sj.retain_freed_memory()
    # the seed 000 scene is outside the budgets of fourier_2d and small_deviation: timed all
    # the same, as in bench_fourier.py
    warnings.simplefilter("ignore", sj.ValidityWarning)
    radar, scene, motion, kwargs = pf.seed000_case(method)

    def call():
        return sj.simulate(radar, scene, motion, dtype=jnp.complex64, **kwargs).data

    jax.block_until_ready(call())
    wall = steady(call, 10).min
    runs = []
    for _ in range(3):
        with tempfile.TemporaryDirectory() as folder:
            with jax.profiler.trace(folder, create_perfetto_trace=True):
                jax.block_until_ready(call())
            runs.append(pf._events(folder))
    sums = [_operations(ev) for ev in runs]
    ops = {k: min(s.get(k, 0.0) for s in sums) for k in set().union(*sums)}
    alone = _alone(runs[-1])
    result = dict(method=method, cores=len(os.sched_getaffinity(0)), wall=wall, ops=ops,
                  alone=dict(alone), parts=_parts(radar, scene, motion, kwargs))
    result["lone"] = _lone_transforms()
    if cores != 1:
        result["bandwidth"] = {n: _bandwidth(n) for n in (1, 2)}
    Path(out).write_text(json.dumps(result))


# ---- parent --------------------------------------------------------------------------------


def run_child(method, cores):
    with tempfile.NamedTemporaryFile(suffix=".json", delete=False) as f:
        path = f.name
    subprocess.run([sys.executable, __file__, "--child", method, str(cores), path],
                   check=True, stdout=subprocess.DEVNULL)
    result = json.loads(Path(path).read_text())
    os.unlink(path)
    return result


def _fft(name):
    return name.startswith("fft")


def rows(results, yardstick):
    lines = ["| method | call, one core → two [ms] | speed-up | FFT2-eq., one core → two "
             "| FFT operations, one core "
             "→ two [ms] | other operations, one core → two [ms] | FFTs running alone on "
             "two cores [ms] (share of the call) |", "|---|---|---|---|---|---|---|"]
    for method in results:
        one, two = results[method][1], results[method][2]
        fft1 = sum(v for k, v in one["ops"].items() if _fft(k))
        fft2 = sum(v for k, v in two["ops"].items() if _fft(k))
        rest1 = sum(v for k, v in one["ops"].items() if not _fft(k))
        rest2 = sum(v for k, v in two["ops"].items() if not _fft(k))
        alone = sum(v for k, v in two["alone"].items() if _fft(k))
        lines.append(
            f"| {method} | {one['wall'] * 1e3:.1f} → {two['wall'] * 1e3:.1f} | "
            f"{one['wall'] / two['wall']:.2f} | {one['wall'] / yardstick[1]:.1f} → "
            f"{two['wall'] / yardstick[2]:.1f} | {fft1 * 1e3:.1f} → {fft2 * 1e3:.1f} "
            f"({fft1 / fft2:.2f}×) | {rest1 * 1e3:.1f} → {rest2 * 1e3:.1f} "
            f"({rest1 / rest2:.2f}×) | {alone * 1e3:.1f} ({alone / two['wall']:.0%}) |")
    return "\n".join(lines)


def parts_rows(results, yardstick):
    lines = ["| method | program alone, one core → two [ms] | FFT2-eq., one core → two | "
             "checks alone, one core → two [ms] | call on two cores [ms] (FFT2-eq.) | "
             "call less program, two cores [ms] |", "|---|---|---|---|---|---|"]
    for method in results:
        one, two = results[method][1], results[method][2]
        p1, p2 = one["parts"]["program"], two["parts"]["program"]
        c1, c2 = one["parts"]["checks"], two["parts"]["checks"]
        lines.append(
            f"| {method} | {p1 * 1e3:.1f} → {p2 * 1e3:.1f} | {p1 / yardstick[1]:.1f} → "
            f"{p2 / yardstick[2]:.1f} | {c1 * 1e3:.1f} → {c2 * 1e3:.1f} | "
            f"{two['wall'] * 1e3:.1f} ({two['wall'] / yardstick[2]:.1f}) | "
            f"{(two['wall'] - p2) * 1e3:.1f} |")
    return "\n".join(lines)


def largest(results, method, count=8):
    one, two = results[method][1], results[method][2]
    names = sorted(one["ops"], key=lambda k: -one["ops"][k])[:count]
    return ", ".join(f"`{k}` {one['ops'][k] * 1e3:.1f} → {two['ops'].get(k, 0) * 1e3:.1f}"
                     for k in names)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--methods", default=",".join(METHODS))
    parser.add_argument("--write", action="store_true")
    parser.add_argument("--child", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        method, cores, out = args.child
        return child(method, int(cores), out)
    from _common import load_average, machine, replace_section

    load0 = load_average()
    results = {}
    for method in args.methods.split(","):
        results[method] = {cores: run_child(method, cores) for cores in (1, 2)}
        r = results[method]
        print(f"{method:20s} one core {r[1]['wall'] * 1e3:.1f} ms, two {r[2]['wall'] * 1e3:.1f} ms",
              flush=True)
    first = results[next(iter(results))]
    lone1, lone2 = first[1]["lone"], first[2]["lone"]
    lone = "\n".join(f"| {k} | {lone1[k] * 1e3:.2f} | {lone2[k] * 1e3:.2f} | "
                     f"{lone1[k] / lone2[k]:.2f} |" for k in lone1)
    bw = first[2]["bandwidth"]
    bw1, bw2 = bw["1"], bw["2"]
    yardstick = {1: lone1[YARDSTICK], 2: lone2[YARDSTICK]}
    table = rows(results, yardstick)
    parts = parts_rows(results, yardstick)
    m = machine()
    details = "\n".join(f"- {method}: {largest(results, method)}" for method in results)
    text = f"""<!-- profile_cores:start -->
## Which operations use the second core (`profile_cores.py`)

Generated by `python benchmarks/profile_cores.py --write` (see the script's docstring and
README.md). {m['cpu']}, {m['usable_cores']} usable cores; JAX {m['jax']}; commit
{m['commit']}; {m['date']}; load average {load0:.2f} / {load_average():.2f} (start / end).
Seed 000 scene, complex64, freed memory kept; each method in a process pinned to one core
and in one with both. Operation times: summed over one traced call, the least of three.

{table}

The call's two parts apart (min of 10 each): the compiled program alone and the
validity checks alone (which a call runs in a worker thread beside the program):

{parts}

The largest operations, one core → two [ms]:
{details}

Lone programs (min of 30 calls) and memory:

| | one core [ms] | two cores [ms] | speed-up |
|---|---|---|---|
{lone}

Streaming memory bandwidth (`numpy.multiply`, 128 MiB in, 128 MiB out, per thread):
one thread {bw1:.1f} GB/s, two threads at once {bw2:.1f} GB/s in all ({bw2 / bw1:.2f}×).
<!-- profile_cores:end -->"""
    print(text)
    if args.write:
        replace_section("profile_cores", text)
    return None


if __name__ == "__main__":
    main()
