"""Batch simulation, multi-device sharding and the memory limit.

Prints three tables (see benchmarks/README.md):

1. batch: one ``simulate`` call with a (B, N_x) motion against B single calls (steady
   times, ratio, max difference relative to the peak);
2. sharded: the same call on 4 forced CPU devices (subprocess with
   ``XLA_FLAGS=--xla_force_host_platform_device_count=4``) against ``devices=1``;
3. memory: the exact model under several ``memory_limit`` values, each in its own
   subprocess under ``/usr/bin/time -v`` (peak RSS), with the estimate, the chunks chosen
   and the difference to the unlimited run.

Usage: ``python benchmarks/bench_batch.py [--quick]``.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys

import jax
import numpy as np

import sarjax as sj

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _common import machine, steady, timed  # noqa: E402

BATCH = 8


def _setup(num_pulses, num_range, grid):
    radar = sj.presets.airborne_xband()
    rng = np.random.default_rng(0)
    dx, dr = float(radar.azimuth_spacing), float(radar.range_spacing)
    azimuth = (np.arange(grid) - grid // 2) * dx  # on the pulse spacing (Fourier methods)
    ranges = 5140.0 + (np.arange(grid) - grid // 2) * dr
    scene = sj.ReflectivityGrid(rng.normal(size=(grid, grid)) + 1j * rng.normal(size=(grid, grid)),
                                azimuth, ranges)
    x = (np.arange(num_pulses) - num_pulses / 2) * dx
    horizontal = np.stack([sj.smooth_deviation(x, key=b, rms=0.02, max_cycles=2, aperture=160.0)
                           for b in range(BATCH)])
    pointing = np.stack([sj.seed_pointing_jitter(radar, x, phase=0.3 * b) for b in range(BATCH)])
    kwargs = dict(num_pulses=num_pulses, num_range=num_range,
                  near_range=5140.0 - num_range / 2 * dr)
    return radar, scene, horizontal, np.asarray(pointing), kwargs


def _steady(fn, repeats):
    """The fastest of ``repeats`` calls after a compiling one [s]."""
    timed(fn)
    return steady(fn, repeats).min


def batch_table(quick):
    num_pulses, num_range, grid = (128, 256, 8) if quick else (256, 512, 16)
    radar, scene, horizontal, pointing, kwargs = _setup(num_pulses, num_range, grid)
    print(f"\n## batch: B = {BATCH}, {num_pulses} x {num_range}, {scene.num_scatterers} "
          "scatterers, cm deviations + pointing jitter")
    print("| method | first batched call [s] | batched steady [s] | B single calls [s] | "
          "ratio | max rel. diff |")
    print("|---|---|---|---|---|---|")
    for method in ("time_domain", "time_domain_nufft", "small_deviation"):
        motion = sj.Motion(horizontal=horizontal, pointing=pointing)
        first, _, batched = timed(lambda m=method, motion=motion: sj.simulate(
            radar, scene, motion, method=m, **kwargs))
        steady_b = _steady(lambda m=method, motion=motion: sj.simulate(
            radar, scene, motion, method=m, **kwargs).data, 3)
        singles = [sj.Motion(horizontal=horizontal[b], pointing=pointing[b]) for b in range(BATCH)]

        def loop(m=method, singles=singles):
            return [sj.simulate(radar, scene, s, method=m, **kwargs).data for s in singles]

        steady_s = _steady(loop, 2)
        ref = np.stack([np.asarray(d) for d in loop()])
        diff = np.max(np.abs(np.asarray(batched.data) - ref)) / np.max(np.abs(ref))
        print(f"| {method} | {first:.2f} | {steady_b:.3f} | {steady_s:.3f} | "
              f"{steady_s / steady_b:.2f} | {diff:.1e} |", flush=True)


_SHARDED = r"""
import json, sys, time
import jax, numpy as np
sys.path.insert(0, sys.argv[1])
import bench_batch as b
import sarjax as sj
quick = sys.argv[2] == "1"
num_pulses, num_range, grid = (128, 256, 8) if quick else (256, 512, 16)
radar, scene, horizontal, pointing, kwargs = b._setup(num_pulses, num_range, grid)
rows = []
for method, batched in (("time_domain", False), ("time_domain", True),
                        ("time_domain_nufft", False), ("small_deviation", True)):
    motion = (sj.Motion(horizontal=horizontal, pointing=pointing) if batched else
              sj.Motion(horizontal=horizontal[0], pointing=pointing[0]))
    plan = sj.simulation_memory(radar, scene, motion, method=method, **kwargs)
    run = lambda d: sj.simulate(radar, scene, motion, method=method, devices=d, **kwargs).data
    four, one = b._steady(lambda: run(None), 2), b._steady(lambda: run(1), 2)
    a, r = np.asarray(run(None)), np.asarray(run(1))
    rows.append(dict(method=method, shape=list(a.shape),
                     mesh=[plan.batch_shards, plan.pulse_shards],
                     four=four, one=one, diff=float(np.max(np.abs(a - r)) / np.max(np.abs(r)))))
print("RESULTS" + json.dumps(rows))
"""


def sharded_table(quick):
    env = dict(os.environ, XLA_FLAGS="--xla_force_host_platform_device_count=4",
               JAX_PLATFORMS="cpu")
    done = subprocess.run([sys.executable, "-c", _SHARDED, os.path.dirname(__file__),
                           "1" if quick else "0"], env=env, capture_output=True, text=True)
    if done.returncode:
        print(done.stderr[-3000:])
        return
    rows = json.loads(next(s for s in done.stdout.splitlines()
                           if s.startswith("RESULTS"))[len("RESULTS"):])
    print("\n## sharded: 4 forced CPU devices vs devices=1 (same 2 cores: tests the logic, "
          "not speed)")
    print("| method | output shape | mesh (batch, pulse) | 4 devices [s] | 1 device [s] | "
          "max rel. diff |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['method']} | {tuple(r['shape'])} | {tuple(r['mesh'])} | {r['four']:.3f} | "
              f"{r['one']:.3f} | {r['diff']:.1e} |")


_MEMORY = r"""
import json, sys
import numpy as np
sys.path.insert(0, sys.argv[1])
import bench_batch as b
import sarjax as sj
limit = None if sys.argv[2] == "none" else sys.argv[2]
num_pulses, num_range, grid = 512, 830, 32
radar, scene, horizontal, pointing, kwargs = b._setup(num_pulses, num_range, grid)
motion = sj.Motion(horizontal=horizontal[:4], pointing=pointing[:4])
if limit == "baseline":
    import jax.numpy as jnp
    jnp.zeros(10).block_until_ready()
    print("RESULTS" + json.dumps(dict(limit=limit)))
    sys.exit()
try:
    plan = sj.simulation_memory(radar, scene, motion, memory_limit=limit, devices=1, **kwargs)
    wall, _, data = b.timed(lambda: np.asarray(
        sj.simulate(radar, scene, motion, memory_limit=limit, devices=1, **kwargs).data))
    np.save(sys.argv[3], data)
    sim = plan.simulator
    print("RESULTS" + json.dumps(dict(limit=limit, estimate=plan.estimate.total, wall=wall,
          batch_chunk=plan.batch_chunk or 4,
          chunks=sim.chunks(num_pulses, num_range, scene.num_scatterers, np.complex128))))
except MemoryError as e:
    print("RESULTS" + json.dumps(dict(limit=limit, refused=str(e)[:160])))
"""


def memory_table(quick):
    if not os.path.exists("/usr/bin/time"):
        print("\n(/usr/bin/time not found: memory table skipped)")
        return
    limits = ["baseline", "none", "2GiB", "200MiB", "60MiB", "20MiB"]
    print("\n## memory: exact model, 4 realizations x 512 x 830, 1024 scatterers, "
          "complex128 (output 26 MiB)")
    print("| memory_limit | estimate [MiB] | chunks (batch, pulse, scatterer) | wall [s] | "
          "peak RSS [MiB] | RSS − baseline [MiB] | max rel. diff to unlimited |")
    print("|---|---|---|---|---|---|---|")
    baseline = None
    reference = None
    for limit in limits:
        out = f"/tmp/bench_batch_{os.getpid()}_{limit}.npy"
        done = subprocess.run(["/usr/bin/time", "-v", sys.executable, "-c", _MEMORY,
                               os.path.dirname(__file__), limit, out],
                              capture_output=True, text=True)
        rss = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", done.stderr)
                  .group(1)) / 1024
        line = next((s for s in done.stdout.splitlines() if s.startswith("RESULTS")), None)
        if line is None:
            print(done.stderr[-2000:])
            continue
        r = json.loads(line[len("RESULTS"):])
        if limit == "baseline":
            baseline = rss
            print(f"| (import + one op) | – | – | – | {rss:.0f} | 0 | – |")
            continue
        if "refused" in r:
            print(f"| {limit} | refused: {r['refused']} | | | {rss:.0f} | "
                  f"{rss - baseline:.0f} | – |")
            continue
        data = np.load(out)
        os.remove(out)
        if reference is None:
            reference = data
        diff = np.max(np.abs(data - reference)) / np.max(np.abs(reference))
        print(f"| {limit} | {r['estimate'] / 2**20:.0f} | ({r['batch_chunk']}, "
              f"{r['chunks'][0]}, {r['chunks'][1]}) | {r['wall']:.1f} | {rss:.0f} | "
              f"{rss - baseline:.0f} | {diff:.1e} |", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes")
    args = parser.parse_args()
    m = machine()
    print(f"jax {m['jax']}, {jax.devices()[0].device_kind}, {m['cpu']}, {m['cores']} CPUs, "
          f"load {m['load']:.2f}, commit {m['commit']}")
    batch_table(args.quick)
    sharded_table(args.quick)
    memory_table(args.quick)


if __name__ == "__main__":
    main()
