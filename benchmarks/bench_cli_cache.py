"""The persistent compilation cache of the ``sarjax`` command: a first and a second run
of the same configuration, each a fresh process, with an empty cache folder before the
first; and the same two runs with the cache turned off (``SARJAX_CACHE_DIR=off``) as the
baseline measured in the same run.

Configuration: the README's three-target airborne run at 1025 pulses × 830 samples with
cm-level motion and jitter, ``sarjax simulate`` with each method named (wall time of the
whole command: start-up, compilation, the run and the file).

The script replaces its section of ``benchmarks/RESULTS.md``.

Usage::

    python benchmarks/bench_cli_cache.py [--methods small_deviation,...]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
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


def _run(folder, method, cache, index):
    env = {k: v for k, v in os.environ.items()
           if k not in ("JAX_COMPILATION_CACHE_DIR", "JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS")}
    env["SARJAX_CACHE_DIR"] = cache
    out = folder / f"{method}-{Path(cache).name}-{index}.nc"
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "sarjax.cli", "simulate", str(folder / "run.toml"),
                    "-o", str(out), "--set", f"simulate.method={method}"], env=env,
                   check=True, capture_output=True)
    return time.perf_counter() - start


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--methods", default=",".join(METHODS))
    p.add_argument("--no-write", action="store_true", help="do not touch RESULTS.md")
    args = p.parse_args(argv)
    info = machine()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "run.toml").write_text(CONFIG)
        for method in args.methods.split(","):
            cache = folder / f"cache-{method}"
            times = [_run(folder, method, str(cache), i) for i in range(2)]
            off = [_run(folder, method, "off", i) for i in range(2)]
            entries = len(list(cache.iterdir()))
            rows.append((method, *times, *off, entries))
            print(f"{method:20s} cached {times[0]:6.2f} -> {times[1]:6.2f} s "
                  f"({times[0] / times[1]:.1f}x), off {off[0]:6.2f} / {off[1]:6.2f} s, "
                  f"{entries} entries", flush=True)
    lines = [
        "## The command's compilation cache (`bench_cli_cache.py`)",
        "",
        f"Machine: {info['cpu']}, {info['usable_cores']} cores, load {info['load']:.2f}; "
        f"commit {info['commit']}, jax {info['jax']}, {info['date']}.",
        "",
        "`sarjax simulate` of the README's three-target run (1025 × 830, cm-level motion "
        "and jitter), wall time of the whole command in a fresh process; the second run "
        "finds the first run's programs in the cache folder. Baseline: the same two runs "
        "with `SARJAX_CACHE_DIR=off`.",
        "",
        "| method | first run [s] | second run [s] | speed-up | cache off, 1st / 2nd [s] | "
        "entries |",
        "|---|---|---|---|---|---|",
    ]
    for method, first, second, off1, off2, entries in rows:
        lines.append(f"| `{method}` | {first:.2f} | {second:.2f} | {first / second:.1f}× | "
                     f"{off1:.2f} / {off2:.2f} | {entries} |")
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        replace_section("bench_cli_cache", text)


if __name__ == "__main__":
    main()
