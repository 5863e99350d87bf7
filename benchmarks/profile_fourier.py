"""Where a Fourier-domain simulation's time goes: one steady ``sarjax.simulate`` call under
JAX's profiler, its compiled program's operations summed by stage.

Case: the seed 000 scene of ``bench_fourier.py`` (972 × 416 speckle grid with heights,
cm-level Δy, Δz, seed pointing jitter, airborne preset) for ``fourier_2d``,
``small_deviation`` and ``moderate_deviation``; ``high_speed`` on the reduced seed 004
scene of ``bench_high_speed.py --quick``. For each method and dtype, after a compiling
call and two steady ones, one call is traced (``jax.profiler.trace``, Perfetto events) and
its time split into:

* **checks and dispatch**: the argument checks, the validity budgets and the plan
  (``sarjax._simulate._prepare``, timed on its own; Python and small eager programs);
* **column loop, transforms**: FFTs inside the program's loops (the per-column azimuth
  inverse transforms);
* **column loop, synthesis**: everything else inside the loops (the range synthesis:
  κ(ξ, η), the kernel reads of the scene's DTFT table, phasors, weights);
* **scene tables, transforms**: FFTs outside the loops (the scene's 2-D transform / line
  DTFTs, the track's per-line transforms, the final range transform);
* **scene tables, elementwise**: every other operation outside the loops (scene factors,
  padding, the track's per-line phases, zero-filled buffers, transposes).

The call's wall time is the fastest of 5 untraced calls; the program's share (wall −
checks) is split in the proportions the traced call's operations take (tracing slows a
call by 10–50 %). FFT2-equivalents: the call's wall time over one complex128
``jax.jit(jnp.fft.fft2)`` of the fixed 2560 × 675 grid, timed in the same run). The
breakdown is written between ``<!-- profile_fourier:start -->`` and
``<!-- profile_fourier:end -->`` in ``benchmarks/RESULTS.md`` (``--write``).

Usage::

    taskset -c 0 python benchmarks/profile_fourier.py [--write] [--methods ...]

On one core (``taskset``) the attribution to the loops is exact; on two, XLA runs some
operations concurrently and the traced call is 1.5× slower than an untraced one, so the
proportions are less certain.
"""

from __future__ import annotations

import argparse
import collections
import glob
import gzip
import json
import sys
import tempfile
from pathlib import Path

import jax
import jax.numpy as jnp

import sarjax as sj

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_fourier as bf  # noqa: E402
from _common import load_average, machine, replace_section, steady  # noqa: E402

START = "<!-- profile_fourier:start -->"
END = "<!-- profile_fourier:end -->"
STAGES = ("checks and dispatch", "column loop, synthesis", "column loop, transforms",
          "scene tables, transforms", "scene tables, elementwise")


def seed000_case(method):
    """(radar, scene, motion, keyword arguments of ``simulate``) of the seed 000 scene."""
    radar = sj.presets.airborne_xband()
    gamma, az, rg, height = bf.make_scene(radar, 972, 416)
    scene = sj.ReflectivityGrid(gamma, az, rg, height=height)
    dy, dz, pointing = bf.make_motion_arrays(radar, 972)
    motion = sj.Motion(horizontal=dy, vertical=dz, pointing=pointing)
    return radar, scene, motion, dict(method=method, num_pulses=972, num_range=416,
                                      near_range=float(rg[0]))


def high_speed_case():
    """The same for ``high_speed`` on ``bench_high_speed.py --quick``'s mixed scene."""
    import bench_high_speed as bh

    cfg = bh.QUICK
    radar = bh._radar(cfg)
    return radar, bh._scene("mixed"), None, dict(
        method="high_speed", azimuth_padding=cfg["padding"], num_pulses=cfg["pulses"],
        num_range=cfg["range"], near_range=float(radar.near_range))


def checks_time(case, dtype):
    """Steady time [s] of the call's checks and plan (``bench_fourier.checks_time``)."""
    radar, scene, motion, kwargs = case
    kwargs = dict(kwargs)
    grid = (kwargs.pop("num_pulses"), kwargs.pop("num_range"), kwargs.pop("near_range"))
    return bf.checks_time(radar, scene, motion, grid, kwargs.pop("method"), kwargs, dtype)


def _events(trace_dir):
    path = glob.glob(f"{trace_dir}/**/*.trace.json.gz", recursive=True)[0]
    with gzip.open(path) as f:
        return [e for e in json.load(f)["traceEvents"] if e.get("ph") == "X"]


def breakdown(case, dtype, repeats=5):
    """{stage: seconds} of a steady call, and its wall time [s].

    The wall time is the fastest of ``repeats`` untraced calls and the checks' time that
    of :func:`checks_time`; the rest, the program, is split in the proportions of one
    traced call's operations (tracing slows the call itself).
    """
    radar, scene, motion, kwargs = case

    def call():
        return sj.simulate(radar, scene, motion, dtype=dtype, **kwargs).data

    jax.block_until_ready(call())
    wall = steady(call, repeats).min
    checks = checks_time(case, dtype)
    with tempfile.TemporaryDirectory() as folder:
        with jax.profiler.trace(folder, create_perfetto_trace=True):
            jax.block_until_ready(call())
        events = _events(folder)
    # the program's operations: the thunks XLA's CPU runtime executes (named after HLO
    # instructions); loops are ``while.N`` thunks that contain their body's thunks
    ops = [e for e in events if not e["name"].startswith("$") and "::" not in e["name"]
           and not e["name"].startswith(("Pjit", "np.", "H2D", "DevicePut", "D2H"))]
    loops = [(e["ts"], e["ts"] + e["dur"], e["tid"]) for e in ops
             if e["name"].startswith("while")]

    def inside(e):  # on any thread: a loop's body may run on another core's thread
        return any(lo <= e["ts"] and e["ts"] + e["dur"] <= hi
                   for lo, hi, _ in loops if (lo, hi) != (e["ts"], e["ts"] + e["dur"]))

    traced = collections.Counter()
    for e in ops:
        if e["name"].startswith("while"):
            continue
        in_loop = inside(e)
        fft = e["name"].startswith("fft")
        key = (("column loop, transforms" if fft else "column loop, synthesis") if in_loop
               else ("scene tables, transforms" if fft else "scene tables, elementwise"))
        traced[key] += e["dur"] * 1e-6
    total = sum(traced.values())
    program = max(wall - checks, 0.0)
    out = collections.Counter({k: program * v / total for k, v in traced.items()})
    out["checks and dispatch"] = checks
    return out, wall


def fft_yardstick():
    """Wall time [s] of the fixed complex128 FFT2 (``bench_fourier.fft_baseline``)."""
    return bf.fft_baseline(bf.YARDSTICK)["complex128"][0]


def table(rows, fft):
    head = ("| method | dtype | call [ms] | FFT2-eq. | "
            + " | ".join(f"{s} [ms]" for s in STAGES) + " |")
    lines = [head, "|" + "---|" * (4 + len(STAGES))]
    for method, dtype, parts, wall in rows:
        lines.append(f"| {method} | {dtype} | {wall * 1e3:.1f} | {wall / fft:.1f} | "
                     + " | ".join(f"{parts[s] * 1e3:.1f}" for s in STAGES) + " |")
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--methods", default="fourier_2d,small_deviation,moderate_deviation")
    parser.add_argument("--dtypes", default="complex128,complex64")
    parser.add_argument("--write", action="store_true")
    args = parser.parse_args(argv)
    jax.config.update("jax_enable_x64", True)
    load0 = load_average()
    fft = fft_yardstick()
    rows = []
    for method in args.methods.split(","):
        for dname in args.dtypes.split(","):
            dtype = jnp.dtype(dname)
            case = high_speed_case() if method == "high_speed" else seed000_case(method)
            parts, wall = breakdown(case, dtype)
            rows.append((method, dname, parts, wall))
            print(f"{method:20s} {dname:10s} {wall * 1e3:7.1f} ms "
                  + " ".join(f"{s.split(',')[-1].strip()[:10]}={parts[s] * 1e3:.1f}"
                             for s in STAGES), flush=True)
    fft_end = fft_yardstick()
    fft = min(fft, fft_end)
    text = table(rows, fft)
    print(f"\nFFT2 2560 x 675 complex128: {fft * 1e3:.2f} ms\n{text}")
    if args.write:
        m = machine()
        replace_section("profile_fourier", f"""{START}
## Where a Fourier-domain call's time goes (`profile_fourier.py`)

Generated by `python benchmarks/profile_fourier.py --write`; one steady call per row under
`jax.profiler.trace`, its compiled operations summed by stage (see the script's
docstring and README.md). {m['cpu']}, {m['usable_cores']} usable core(s); JAX {m['jax']};
commit {m['commit']};
{m['date']}; load average {load0:.2f} / {load_average():.2f} (start / end). Yardstick:
one complex128 2-D FFT of 2560 × 675, **{fft * 1e3:.2f} ms** (min of 20, before and after).

{text}
{END}""")


if __name__ == "__main__":
    main()
