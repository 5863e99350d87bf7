"""One scene split across devices: seed 004's Table 1 scene (``method="high_speed"``) on
1, 2 and 4 devices.

Case: the full-size scene of ``bench_high_speed.py`` (``sj.presets.highspeed_xband()``,
2048 pulses × 32 768 range samples, 40 µs chirp, one footprint of azimuth padding each
side: working grid 7500 × 62 208; five static point targets, or ``--scene mixed``: with
three moving ones), complex64. With D devices the range-wavenumber columns are split
over them (``sarjax._fourier_engine.split_columns``): each device synthesises 1/D of the
columns on every pulse, one all-to-all leaves it 1/D of the pulses, and it transforms
those in range.

Each device count runs in its own process with ``XLA_FLAGS=
--xla_force_host_platform_device_count=D`` (CPU devices: the split's logic and memory,
not a speed-up — the D devices share this machine's cores; on a machine with D
accelerators the split is what lets a scene larger than one of them run).

Measured per device count:

* **memory per device**: XLA's compiled memory analysis of the jitted entry point
  (``argument + output + temp`` bytes of the per-device program, ahead of time: what one
  device must hold at its peak), and its ratio to the one-device program;
* compile (ahead-of-time lower + compile), steady wall and CPU time of one call, and the
  process's peak resident memory (all D devices together, ``/usr/bin/time -v``);
* the largest difference from the one-device output, relative to its peak (the D-device
  process saves its output; the one-device run's is compared).

``--memory-only`` skips the calls (compile and memory only: a minute); ``--quick`` runs
the reduced grid of ``bench_high_speed.py --quick`` and writes nothing.

Usage::

    python benchmarks/bench_split.py                 # full size, writes RESULTS.md
    python benchmarks/bench_split.py --memory-only   # full size, no calls
    python benchmarks/bench_split.py --quick
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(HERE))
from _common import (  # noqa: E402
    captured_entry,
    load_average,
    machine,
    replace_section,
    steady,
)

NAME = "bench_split"
DEVICES = (1, 2, 4)


def child(args):
    """One device count in this process: compile, memory analysis, optionally a call."""
    import jax
    import jax.numpy as jnp
    from bench_high_speed import FULL, QUICK, _radar, _scene

    import sarjax as sj

    cfg = QUICK if args["quick"] else FULL
    radar, scene = _radar(cfg), _scene(args["scene"])

    def call():
        return sj.simulate(radar, scene, method="high_speed", azimuth_padding=cfg["padding"],
                           dtype=jnp.complex64)

    plan = sj.simulation_memory(radar, scene, method="high_speed",
                                azimuth_padding=cfg["padding"], dtype=jnp.complex64)
    run, a, k = captured_entry(call)
    t0 = time.perf_counter()
    compiled = run.lower(*a, **k).compile()
    compile_s = time.perf_counter() - t0
    stats = compiled.compiled.memory_analysis()
    out = dict(devices=jax.device_count(), mesh=[plan.batch_shards, plan.pulse_shards],
               compile=compile_s, argument=stats.argument_size_in_bytes,
               output=stats.output_size_in_bytes, temp=stats.temp_size_in_bytes,
               estimate=plan.estimate.total)
    if args["run"]:
        data = call().data  # the first call (loads the compiled program)
        timing = steady(lambda: call().data, 1)
        out.update(wall=timing.min, cpu=timing.cpu)
        np.save(args["save"], np.asarray(data))
    print("RESULT " + json.dumps(out), flush=True)


def _run_child(devices, args):
    env = dict(os.environ, JAX_PLATFORMS="cpu",
               XLA_FLAGS=(os.environ.get("XLA_FLAGS", "")
                          + f" --xla_force_host_platform_device_count={devices}").strip())
    cmd = [sys.executable, __file__, "--child", json.dumps(args)]
    if Path("/usr/bin/time").exists():
        cmd = ["/usr/bin/time", "-v", *cmd]
    done = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=REPO)
    lines = [ln for ln in done.stdout.splitlines() if ln.startswith("RESULT ")]
    if done.returncode != 0 or not lines:
        raise RuntimeError(f"{devices} devices failed ({done.returncode}):\n"
                           f"{done.stderr[-3000:]}")
    match = re.search(r"Maximum resident set size \(kbytes\): (\d+)", done.stderr)
    result = json.loads(lines[-1][len("RESULT "):])
    result["rss"] = int(match.group(1)) / 1024**2 if match else float("nan")
    return result


def section(info, cfg, scene, rows, load, load_end, total):
    from bench_high_speed import working_grid

    n_x, n_r, _ = working_grid(cfg, scene)
    one = rows[0]
    per_one = one["argument"] + one["output"] + one["temp"]
    timed = "wall" in one
    lines = [
        "## One scene split across devices, seed 004 Table 1 (`bench_split.py`)",
        "",
        f"Machine: {info['cpu']}, {info['cores']} cores ({info['usable_cores']} usable), "
        f"JAX {info['jax']} (forced CPU devices), commit {info['commit']}, {info['date']}; "
        f"load average {load:.2f} at start, {load_end:.2f} at the end; whole run "
        f"{total / 60:.0f} min.",
        "",
        f"`high_speed`, {scene} scene, raw grid {cfg['pulses']} × {cfg['range']} "
        f"(complex64), working grid {n_x} × {n_r}; the range-wavenumber columns split over "
        "D devices, an all-to-all to pulse blocks. Memory per device: XLA's compiled "
        "memory analysis of the per-device program (arguments + output + temporaries), "
        "ahead of time. The D CPU devices share the machine's cores: times show the "
        "split's overhead, not a speed-up (efficiency = one-device time / (D × time) "
        "would need D real devices).",
        "",
        "| devices | mesh (batch, pulse) | per device [GB] | vs 1 device | output + temp "
        "[GB] | compile [s] |" + (" steady [s] | CPU [s] | process peak RSS [GB] | "
                                  "max diff / peak |" if timed else ""),
        "| ---: | --- | ---: | ---: | ---: | ---: |"
        + (" ---: | ---: | ---: | ---: |" if timed else ""),
    ]
    for r in rows:
        per = r["argument"] + r["output"] + r["temp"]
        row = (f"| {r['devices']} | {tuple(r['mesh'])} | {per / 1e9:.2f} | "
               f"{100 * per / per_one:.0f} % | {r['output'] / 1e9:.2f} + "
               f"{r['temp'] / 1e9:.2f} | {r['compile']:.1f} |")
        if timed:
            diff = "–" if r.get("difference") is None else f"{r['difference']:.1e}"
            row += f" {r['wall']:.1f} | {r['cpu']:.1f} | {r['rss']:.2f} | {diff} |"
        lines.append(row)
    return "\n".join(lines)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--child", help=argparse.SUPPRESS)
    p.add_argument("--quick", action="store_true", help="reduced grid, writes nothing")
    p.add_argument("--memory-only", action="store_true", help="compile and memory only")
    p.add_argument("--scene", choices=("static", "mixed"), default="static")
    p.add_argument("--no-write", action="store_true")
    args = p.parse_args(argv)
    if args.child:
        child(json.loads(args.child))
        return
    from bench_high_speed import FULL, QUICK

    cfg = QUICK if args.quick else FULL
    info, load, t0 = machine(), load_average(), time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for devices in DEVICES:
            save = str(Path(folder) / f"{devices}.npy")
            r = _run_child(devices, dict(quick=args.quick, scene=args.scene, save=save,
                                         run=not args.memory_only))
            if not args.memory_only:
                ref = np.load(str(Path(folder) / "1.npy"), mmap_mode="r")
                got = np.load(save, mmap_mode="r")
                r["difference"] = float(np.max(np.abs(got - ref)) / np.max(np.abs(ref)))
            rows.append(r)
            print(json.dumps(r), flush=True)
    text = section(info, cfg, args.scene, rows, load, load_average(),
                   time.perf_counter() - t0)
    print(text)
    if not (args.quick or args.no_write):
        replace_section(NAME, text)


if __name__ == "__main__":
    main()
