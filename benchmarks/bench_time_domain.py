"""Benchmark of the exact time-domain simulator (``sj.simulate(method="time_domain")``).

Cases (raw grid 1941 pulses × 830 range samples of ``sj.presets.airborne_xband()``):

* ``points``: 3 point targets at r = 4840, 5140, 5440 m with cm-level trajectory
  deviations (Δy, Δz: 2 cm rms) and the seed 000 pointing jitter;
* ``grid``: a 64 × 64 ``ReflectivityGrid`` (4096 scatterers, raw pixel spacing
  0.25 m × ~3 m, centred at x = 0, r = 5140 m, pyramid heights), same motion;

each in complex128 and complex64. For every case the script reports

* compile time: ahead-of-time ``lower`` + ``compile`` of the jitted entry point
  (``sarjax._simulate._run``, captured from a real ``simulate`` call), and also
  "first call − steady" for comparison;
* steady time: min over repeats of ``simulate(...).data.block_until_ready()``
  (wall clock), with the process CPU time of that repeat (CPU/wall ≈ cores in use);
* throughput: scatterer·pulse evaluations / s and scatterer·pulse·sample / s;
* the ratio steady / (one complex64 2-D FFT of the 2048 × 1024 padded grid,
  ``jax.jit(jnp.fft.fft2)``), the FFT timed in the same run as a machine-speed yardstick.

Then a (pulse_chunk, scatterer_chunk) sweep on the complex64 grid case.
Results go to a table on stdout and to ``benchmarks/RESULTS.md`` (``--no-write`` skips
writing; ``--quick`` runs a reduced size and does not write unless ``--write``).

Usage::

    python benchmarks/bench_time_domain.py            # full run, writes RESULTS.md
    python benchmarks/bench_time_domain.py --quick    # smoke test (256 pulses)
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
from _common import aot_compile_time, load_average, machine, replace_section, steady, timed

import sarjax as sj

HERE = Path(__file__).resolve().parent
FULL_PULSES = 1941
NUM_RANGE = 830
GRID_N = 64
FFT_SHAPE = (2048, 1024)
SWEEP = [  # (pulse_chunk, scatterer_chunk)
    (64, 64),
    (32, 128),
    (16, 256),
    (8, 512),
    (1, 1024),
    (1, 4096),
    (128, 32),
]
DTYPES = {"complex128": jnp.complex128, "complex64": jnp.complex64}
MARKER = "bench_time_domain"


# ---- inputs -----------------------------------------------------------------------


def pulse_positions(num_pulses):
    """x' of the raw pulses [m] (0.25 m spacing, centred at 0)."""
    return (np.arange(num_pulses) - (num_pulses - 1) // 2) * 0.25


def make_motion(radar, num_pulses):
    x = pulse_positions(num_pulses)
    return sj.Motion(
        horizontal=sj.smooth_deviation(x, key=1, rms=0.02, max_cycles=2, aperture=160.0),
        vertical=sj.smooth_deviation(x, key=2, rms=0.02, max_cycles=2, aperture=160.0),
        pointing=sj.seed_pointing_jitter(radar, x),
    )


def make_points():
    return sj.PointTargets(
        azimuth=[0.0, 0.0, 0.0], range=[4840.0, 5140.0, 5440.0], reflectivity=[1, 1, 1]
    )


def make_grid(radar, n=GRID_N):
    """n × n reflectivity grid on the raw pixel spacing, centred at (0, r₀)."""
    dx = float(radar.azimuth_spacing)
    dr = float(radar.range_spacing)
    az = (np.arange(n) - (n - 1) / 2) * dx
    rg = float(radar.reference_range) + (np.arange(n) - (n - 1) / 2) * dr
    rng = np.random.default_rng(0)
    gamma = (rng.normal(size=(n, n)) + 1j * rng.normal(size=(n, n))) / np.sqrt(2)
    height = sj.pyramid_height(az, rg, peak=20.0)
    return sj.ReflectivityGrid(gamma, az, rg, height=height)


# ---- timing helpers -----------------------------------------------------------------


def fft_baseline(repeats=20):
    rng = np.random.default_rng(1)
    a = (rng.normal(size=FFT_SHAPE) + 1j * rng.normal(size=FFT_SHAPE)).astype(np.complex64)
    a = jnp.asarray(a)
    fft2 = jax.jit(jnp.fft.fft2)
    jax.block_until_ready(fft2(a))
    s = steady(lambda: fft2(a), repeats)
    wall, cpu = s.min, s.cpu
    return wall, cpu


# ---- benchmark ----------------------------------------------------------------------


def run_case(name, radar, scene, motion, num_pulses, dtype_name, repeats, **chunks):
    dtype = DTYPES[dtype_name]
    n_scat = scene.num_scatterers

    def call():
        return sj.simulate(
            radar, scene, motion, method="time_domain", num_pulses=num_pulses,
            dtype=dtype, **chunks,
        ).data

    aot = aot_compile_time(call)
    # The AOT compile fills JAX's executable cache; clear it so that the first call
    # below traces and compiles again ("first − steady" is an independent estimate).
    jax.clear_caches()
    first, _, data = timed(call)
    s = steady(call, repeats)
    wall, cpu, walls = s.min, s.cpu, list(s.walls)
    assert data.shape == (num_pulses, NUM_RANGE) and data.dtype == dtype
    assert bool(jnp.all(jnp.isfinite(data)))
    evals = n_scat * num_pulses
    row = dict(
        case=name, dtype=dtype_name, scatterers=n_scat, pulses=num_pulses, range=NUM_RANGE,
        aot_lower=aot[0] if aot else None, aot_compile=aot[1] if aot else None,
        first=first, first_minus_steady=first - wall, steady=wall, cpu=cpu,
        walls=walls, repeats=repeats,
        sp_per_s=evals / wall, sps_per_s=evals * NUM_RANGE / wall, sp_per_cpu_s=evals / cpu,
        spread=max(walls) / min(walls), data=np.asarray(data),
    )
    compile_s = row["aot_lower"] + row["aot_compile"] if aot else row["first_minus_steady"]
    print(
        f"  {name:7s} {dtype_name:10s} compile {compile_s:7.2f} s  steady {wall:8.4f} s "
        f"(cpu {cpu:7.3f} s, walls {', '.join(f'{w:.3f}' for w in walls)})  "
        f"{row['sp_per_s']:.3e} sc·pulse/s  {row['sps_per_s']:.3e} sc·pulse·sample/s",
        flush=True,
    )
    return row


def run_sweep(radar, scene, motion, num_pulses, repeats):
    """Grid case, complex64, each SWEEP setting: (TimeDomain.chunks() default, rows)."""
    default = sj.TimeDomain().chunks(num_pulses, NUM_RANGE, scene.num_scatterers,
                                     jnp.complex64)
    rows = []
    for pc, sc in SWEEP:
        label = f"({pc}, {sc})" + (" = default" if (pc, sc) == default else "")

        def call(pc=pc, sc=sc):
            return sj.simulate(
                radar, scene, motion, num_pulses=num_pulses, dtype=jnp.complex64,
                pulse_chunk=pc, scatterer_chunk=sc,
            ).data

        first, _, _ = timed(call)
        s = steady(call, repeats)
        wall, cpu, walls = s.min, s.cpu, list(s.walls)
        evals = scene.num_scatterers * num_pulses
        rows.append(dict(label=label, pc=pc, sc=sc, first=first, steady=wall, cpu=cpu,
                         walls=walls, sp_per_s=evals / wall, sp_per_cpu_s=evals / cpu))
        print(
            f"  chunks {label:22s} steady {wall:7.3f} s  cpu {cpu:7.3f} s  "
            f"{evals / wall:.3e} sc·pulse/s  {evals / cpu:.3e} sc·pulse/cpu-s",
            flush=True,
        )
    return default, rows


# ---- report -------------------------------------------------------------------------


def fmt(v, spec):
    return "–" if v is None else format(v, spec)


def table(rows):
    head = (
        "| case | dtype | scatterers × pulses × samples | compile (AOT lower+compile) [s] "
        "| first − steady [s] | steady [s] | max/min wall | CPU/wall | repeats "
        "| scatterer·pulse / s | scatterer·pulse·sample / s | scatterer·pulse / CPU-s "
        "| steady / FFT | complex64 vs complex128: NMSE [dB], max \\|e\\| / max \\|ref\\| |"
    )
    lines = [head, "|" + "---|" * 14]
    for r in rows:
        aot = None if r["aot_lower"] is None else r["aot_lower"] + r["aot_compile"]
        lines.append(
            f"| {r['case']} | {r['dtype']} | {r['scatterers']} × {r['pulses']} × {r['range']} "
            f"| {fmt(aot, '.2f')} | {r['first_minus_steady']:.2f} | {r['steady']:.4f} "
            f"| {r['spread']:.2f} | {r['cpu'] / r['steady']:.2f} | {r['repeats']} "
            f"| {r['sp_per_s']:.3e} | {r['sps_per_s']:.3e} | {r['sp_per_cpu_s']:.3e} "
            f"| {r['ratio_fft']:.3g} | {r.get('error', '(reference)')} |"
        )
    return "\n".join(lines)


def sweep_table(sweep_rows):
    lines = [
        "| (pulse_chunk, scatterer_chunk) | steady [s] | CPU [s] "
        "| scatterer·pulse / s | scatterer·pulse / CPU-s |",
        "|---|---|---|---|---|",
    ]
    for r in sweep_rows:
        lines.append(
            f"| {r['label']} | {r['steady']:.3f} | {r['cpu']:.3f} "
            f"| {r['sp_per_s']:.3e} | {r['sp_per_cpu_s']:.3e} |"
        )
    return "\n".join(lines)


def write_results(path, info, fft, fft_end, rows, sweep, load, argv):
    default, sweep_rows, sweep_pulses, sweep_repeats = sweep
    best_wall = min(sweep_rows, key=lambda r: r["steady"])
    best_cpu = min(sweep_rows, key=lambda r: r["cpu"])
    text = f"""## Time-domain simulator (`{Path(__file__).name}`)

Generated by `python benchmarks/{Path(__file__).name}{(' ' + ' '.join(argv)) if argv else ''}`
(see [README.md](README.md) for what is measured); re-running it replaces only this section.

### Machine

- CPU: {info['cpu']}; {info['cores']} logical cores ({info['usable_cores']} usable by this process)
- JAX {info['jax']} (jaxlib {info['jaxlib']}), backend `{info['backend']}` ({info['devices']});
  NumPy {info['numpy']}; Python {info['python']}
- sarjax commit {info['commit']}
- Date: {info['date']}
- Load average (1 min) at start / end of the run: {load[0]:.2f} / {load[1]:.2f}. The
  machine is shared: a CPU/wall ratio below the core count and a large spread between
  repeats mean other processes held cores; steady times are the minimum over repeats.

### Time-domain simulation, raw grid {rows[0]['pulses']} × {NUM_RANGE}

Baseline: one complex64 2-D FFT of the {FFT_SHAPE[0]} × {FFT_SHAPE[1]} padded grid
(`jax.jit(jnp.fft.fft2)`, min of 20, timed before and after the four cases:
{fft[0] * 1e3:.2f} ms and {fft_end[0] * 1e3:.2f} ms): **{min(fft[0], fft_end[0]) * 1e3:.2f} ms**,
the smaller of the two, is the "steady / FFT" denominator.

{table(rows)}

- compile: ahead-of-time `lower()` + `compile()` of the jitted `sarjax._simulate._run`
  with the arguments of the real call; "first − steady" is the first `simulate` call
  minus the steady time (it also includes tracing, input validation and dispatch).
- steady: min wall time over the stated repeats of `simulate(...).data.block_until_ready()`.
  CPU/wall is the process CPU time of that repeat over its wall time (≈ cores in use);
  max/min wall is the spread over the repeats. scatterer·pulse / CPU-s uses the CPU time
  of that repeat: it is less sensitive to other processes taking cores than the wall rate.
- scatterer·pulse·sample / s counts every (scatterer, pulse, range sample) evaluation of
  the kernel: it evaluates the chirp at all {NUM_RANGE} samples, inside the pulse extent or not.

### (pulse_chunk, scatterer_chunk) sweep — grid case, complex64, {sweep_pulses} pulses

{sweep_repeats} repeats after a compile call; `TimeDomain.chunks()` default for this case:
{default}.

{sweep_table(sweep_rows)}

Fastest by wall time: **{best_wall['label']}** ({best_wall['steady']:.3f} s); by CPU time:
**{best_cpu['label']}** ({best_cpu['cpu']:.3f} CPU-s).
"""
    replace_section(MARKER, text, path)


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true", help="reduced size (256 pulses) smoke test")
    p.add_argument("--no-write", action="store_true", help="do not write RESULTS.md")
    p.add_argument("--write", action="store_true", help="write RESULTS.md even with --quick")
    p.add_argument("--pulses", type=int, default=None, help="pulses (default 1941; quick 256)")
    p.add_argument("--repeats", type=int, default=10, help="steady repeats, point case")
    p.add_argument("--grid-repeats", type=int, default=3, help="steady repeats, grid case")
    p.add_argument("--sweep-pulses", type=int, default=None,
                   help="pulses in the chunk sweep (default 512; quick 64)")
    p.add_argument("--sweep-repeats", type=int, default=2)
    p.add_argument("--no-sweep", action="store_true")
    p.add_argument("--output", type=Path, default=HERE / "RESULTS.md")
    args = p.parse_args(argv)

    num_pulses = args.pulses or (256 if args.quick else FULL_PULSES)
    sweep_pulses = args.sweep_pulses or (64 if args.quick else 512)
    write = not args.no_write and (not args.quick or args.write)
    load_start = load_average()

    info = machine()
    print(f"{info['cpu']}, {info['cores']} cores, JAX {info['jax']} ({info['backend']}), "
          f"load {load_start:.2f}")
    radar = sj.presets.airborne_xband()
    motion = make_motion(radar, num_pulses)
    points, grid = make_points(), make_grid(radar)

    fft = fft_baseline()
    print(f"FFT2 complex64 {FFT_SHAPE}: {fft[0] * 1e3:.2f} ms (cpu {fft[1] * 1e3:.2f} ms)")

    rows = []
    for name, scene, repeats in (("points", points, args.repeats),
                                 ("grid", grid, args.grid_repeats)):
        for dtype_name in DTYPES:
            rows.append(run_case(name, radar, scene, motion, num_pulses, dtype_name,
                                 repeats))
    for ref, low in zip(rows[0::2], rows[1::2], strict=True):  # complex128, complex64 of each case
        err = low["data"].astype(np.complex128) - ref["data"]
        nmse = 10 * np.log10(np.sum(np.abs(err) ** 2) / np.sum(np.abs(ref["data"]) ** 2))
        low["error"] = f"{nmse:.1f}, {np.max(np.abs(err)) / np.max(np.abs(ref['data'])):.1e}"
        print(f"  {low['case']}: complex64 vs complex128 {low['error']}")
    fft_end = fft_baseline()
    print(f"FFT2 again at the end: {fft_end[0] * 1e3:.2f} ms (cpu {fft_end[1] * 1e3:.2f} ms)")
    fft_time = min(fft[0], fft_end[0])
    for r in rows:
        r["ratio_fft"] = r["steady"] / fft_time

    sweep = None
    if not args.no_sweep:
        print(f"chunk sweep, grid, complex64, {sweep_pulses} pulses:")
        sweep_motion = make_motion(radar, sweep_pulses)
        default, sweep_rows = run_sweep(radar, grid, sweep_motion, sweep_pulses,
                                        args.sweep_repeats)
        sweep = (default, sweep_rows, sweep_pulses, args.sweep_repeats)
        print(sweep_table(sweep_rows))

    print()
    print(table(rows))
    load = (load_start, load_average())
    if write:
        if sweep is None:
            print("(--no-sweep: RESULTS.md not written, it needs the sweep)")
        else:
            write_results(args.output, info, fft, fft_end, rows, sweep, load, argv)


if __name__ == "__main__":
    main()
