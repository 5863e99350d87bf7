"""Soak run (not CI): random valid configurations across every simulation method, checked
for crashes, non-finite output and memory growth.

Each configuration draws, on the fixed grid of 64 pulses × 128 range samples with six
point scatterers:

* a method (every simulator class in the ``sarjax.simulate`` registry) and a dtype
  (complex64 or complex128);
* radar values: carrier 9–10 GHz, speed 80–120 m/s, antenna 0.9–1.2 m, PRF 1.6–2.4 × 2v/L,
  height 2.5–4 km (bandwidth 45 MHz, f_s 50 MHz, τ = 1 µs fixed: they set static FFT
  sizes), kept where the Fourier methods' azimuth padding stays one size;
* the scene: positions inside the range window and the aperture, complex reflectivities,
  heights up to 50 m; moving scatterers (±2 m/s) and squint (±5°) for the exact models;
* the motion (the methods that model it; else a straight track): smooth deviations up to
  5 cm rms and pointing jitter up to 0.1 λ/L, or none.

Values vary but structures repeat, so each compiled program is reused. A warm-up compiles
every structure once (method × motion given or not × dtype × squinted or not), then draws
configurations until ``--quiet`` draws in a row compile nothing (some static sizes, such
as the chirp-scaling range FFT length, follow the values); compilations during the
measured run are counted (``jax.monitoring``): a new program raises the resident memory
by its code and the compiler's arenas, a step that is not a leak. Per
configuration the peak resident memory is read from ``VmHWM`` of ``/proc/self/status``
after resetting it (``/proc/self/clear_refs``; else the process's ``ru_maxrss``): memory is
flat when the largest peak of the last 50 configurations is within 10 % of the largest of
the first 50.

Usage::

    python benchmarks/soak.py                      # 200 configurations, ≤ 600 s
    python benchmarks/soak.py --configs 50 --budget 120 --no-write

Writes its section of ``benchmarks/RESULTS.md`` (between ``<!-- soak:start -->`` and
``<!-- soak:end -->``) unless ``--no-write``; exit status 1 when a check fails.
"""

from __future__ import annotations

import argparse
import collections
import re
import resource
import sys
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

import sarjax as sj

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import load_average, machine, replace_section  # noqa: E402

NUM_PULSES, NUM_RANGE, NUM_SCATTERERS = 64, 128, 6
MOTION = ("time_domain", "time_domain_nufft", "fourier_2d", "small_deviation",
          "moderate_deviation")
GENERAL = ("time_domain", "time_domain_nufft")  # squint and moving scatterers
PAD_BAND = (640.0, 768.0)  # footprint / pulse spacing: one azimuth padding (768 pulses)
RESULTS = Path(__file__).resolve().parent / "RESULTS.md"


def methods():
    """One registered name per simulator class."""
    return sorted(sj.simulators.method_names(aliases=False))


# ---- memory and compilations ---------------------------------------------------------


def reset_peak():
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def peak_rss_mib(resettable):
    if resettable:
        status = Path("/proc/self/status").read_text()
        return int(re.search(r"VmHWM:\s+(\d+) kB", status).group(1)) / 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


COMPILES = collections.Counter()


def _count(event, *args, **kwargs):
    if "backend_compile" in event:
        COMPILES["n"] += 1


jax.monitoring.register_event_duration_secs_listener(_count)


# ---- random configurations -----------------------------------------------------------


def draw(rng, method=None, *, motion=None, dtype=None, squinted=None):
    """One random valid configuration (the structure may be fixed by the arguments)."""
    method = method or str(rng.choice(methods()))
    dtype = dtype or str(rng.choice(["complex64", "complex128"]))
    general = method in GENERAL
    squinted = (general and rng.random() < 0.5) if squinted is None else squinted
    while True:  # radar values keeping the Fourier azimuth padding one size
        f = rng.uniform(9e9, 10e9)
        v = rng.uniform(80.0, 120.0)
        length = rng.uniform(0.9, 1.2)
        prf = rng.uniform(1.6, 2.4) * 2 * v / length
        r_mid = rng.uniform(5200.0, 5260.0)
        ratio = 299792458.0 / f * prf / (length * v)  # footprint / spacing per metre
        if PAD_BAND[0] < ratio * (r_mid - 60) and ratio * (r_mid + 60) < PAD_BAND[1]:
            break
    radar = sj.presets.airborne_xband(
        carrier_frequency=f, velocity=v, antenna_length=length, prf=prf,
        height=rng.uniform(2500.0, 4000.0), chirp_duration=1e-6, num_pulses=NUM_PULSES,
        num_range=NUM_RANGE, squint=np.deg2rad(rng.uniform(-5, 5)) if squinted else 0.0)
    near = r_mid - 150.0
    dx = v / prf
    half_aperture = 0.45 * NUM_PULSES * dx
    moving = general and rng.random() < 0.3
    n = NUM_SCATTERERS
    scene = sj.PointTargets(
        azimuth=rng.uniform(-half_aperture, half_aperture, n),
        range=np.clip(r_mid + rng.uniform(-60.0, 60.0, n), near + 80.0, None),
        reflectivity=rng.uniform(0.2, 1.5, n) * np.exp(2j * np.pi * rng.random(n)),
        height=rng.uniform(0.0, 50.0, n),
        velocity_range=rng.uniform(-2, 2, n) if moving else None,
        velocity_azimuth=rng.uniform(-2, 2, n) if moving else None)
    if motion is None:
        motion = method in MOTION and rng.random() < 0.75
    track = None
    if motion:
        x = (np.arange(NUM_PULSES) - (NUM_PULSES - 1) / 2) * dx
        aperture = float(radar.footprint(r_mid))
        rms = rng.uniform(0.0, 0.05)
        track = sj.Motion(
            horizontal=sj.smooth_deviation(x, key=rng, rms=rms, max_cycles=2.0,
                                           aperture=aperture),
            vertical=sj.smooth_deviation(x, key=rng, rms=rms, max_cycles=2.0,
                                         aperture=aperture),
            pointing=np.asarray(sj.seed_pointing_jitter(
                radar, x, amplitude_fraction=rng.uniform(0.0, 0.1), phase=rng.uniform(0, 6))))
    return dict(method=method, radar=radar, scene=scene, motion=track, dtype=dtype,
                near_range=near)


def run_one(config):
    raw = sj.simulate(config["radar"], config["scene"], config["motion"],
                      method=config["method"], dtype=jnp.dtype(config["dtype"]),
                      near_range=config["near_range"])
    data = np.asarray(raw.data)
    problems = []
    if data.shape != (NUM_PULSES, NUM_RANGE):
        problems.append(f"shape {data.shape}")
    if not np.all(np.isfinite(data)):
        problems.append(f"{int(np.sum(~np.isfinite(data)))} non-finite samples")
    elif not np.abs(data).max() > 0:
        problems.append("all zero")
    return problems


def structures():
    """Every (method, motion given, dtype, squinted) the run draws from."""
    for method in methods():
        for motion in ((False, True) if method in MOTION else (False,)):
            for dtype in ("complex64", "complex128"):
                for squinted in ((False, True) if method in GENERAL else (False,)):
                    yield method, motion, dtype, squinted


# ---- report --------------------------------------------------------------------------


def machine_lines():
    """:func:`_common.machine` as the section's bullet lines."""
    m = machine()
    return (f"- CPU: {m['cpu']}; {m['cores']} logical cores\n"
            f"- JAX {m['jax']}, backend `{m['backend']}`; NumPy {m['numpy']}; Python "
            f"{m['python']}\n"
            f"- sarjax commit {m['commit']}\n"
            f"- Date: {m['date']}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--configs", type=int, default=200)
    parser.add_argument("--budget", type=float, default=600.0,
                        help="seconds for the whole run, warm-up included")
    parser.add_argument("--seed", type=int, default=2024)
    parser.add_argument("--quiet", type=int, default=100,
                        help="warm-up ends after this many draws in a row compile nothing")
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    t0 = time.perf_counter()
    load_start = load_average()
    resettable = reset_peak()

    warm = list(structures())
    for method, motion, dtype, squinted in warm:
        run_one(draw(rng, method, motion=motion, dtype=dtype, squinted=squinted))
    draws = quiet = 0
    while quiet < args.quiet and time.perf_counter() - t0 < 0.5 * args.budget:
        before = COMPILES["n"]
        run_one(draw(rng))
        draws += 1
        quiet = quiet + 1 if COMPILES["n"] == before else 0
    warm_compiles, warm_time = COMPILES["n"], time.perf_counter() - t0
    print(f"warm-up: {len(warm)} structures and {draws} draws, {warm_compiles} "
          f"compilations, {warm_time:.0f} s")

    rows, failures = [], []
    for i in range(args.configs):
        if time.perf_counter() - t0 > args.budget:
            break
        config = draw(rng)
        reset_peak()
        before = COMPILES["n"]
        t = time.perf_counter()
        try:
            problems = run_one(config)
        except Exception as err:  # a crash is a finding: record it and go on
            problems = [f"{type(err).__name__}: {' '.join(str(err).split())[:200]}"]
        rows.append(dict(method=config["method"], dtype=config["dtype"],
                         motion=config["motion"] is not None, seconds=time.perf_counter() - t,
                         peak=peak_rss_mib(resettable), compiled=COMPILES["n"] - before))
        if rows[-1]["compiled"]:
            print(f"[{i}] {config['method']} {config['dtype']}: compiled "
                  f"{rows[-1]['compiled']} program(s), peak {rows[-1]['peak']:.0f} MiB")
        if problems:
            failures.append((i, config["method"], problems))
            print(f"[{i}] {config['method']}: {'; '.join(problems)}")
        if (i + 1) % 25 == 0:
            print(f"{i + 1} configurations, {time.perf_counter() - t0:.0f} s, peak "
                  f"{rows[-1]['peak']:.0f} MiB")

    done = len(rows)
    peaks = np.array([r["peak"] for r in rows])
    window = min(50, done // 2) or 1
    first, last = peaks[:window].max(), peaks[-window:].max()
    growth = last / first - 1
    flat = abs(growth) <= 0.10
    counts = collections.Counter(r["method"] for r in rows)
    run_compiles = sum(r["compiled"] for r in rows)
    wall = time.perf_counter() - t0
    ok = not failures and flat and done >= args.configs
    verdict = "PASS" if ok else "FAIL"

    lines = [
        "## Soak run (`soak.py`)",
        "",
        "Generated by `python benchmarks/soak.py "
        + " ".join(argv if argv is not None else sys.argv[1:]) + "`"
        + " (see its docstring); re-running it replaces only this section.",
        "",
        "### Machine",
        "",
        machine_lines(),
        f"- Load average (1 min) at start / end: {load_start:.2f} / {load_average():.2f}"
        " (the machine is shared with other work: times are indicative only)",
        "",
        f"### Result: **{verdict}**",
        "",
        f"- configurations: {done} of {args.configs} (seed {args.seed}, budget "
        f"{args.budget:.0f} s), wall {wall:.0f} s (warm-up {warm_time:.0f} s: "
        f"{len(warm)} structures and {draws} random draws, {warm_compiles} compilations)",
        f"- crashes or non-finite / empty output: {len(failures)}",
        "- per method: " + ", ".join(f"{m} {counts[m]}" for m in methods()),
        f"- compilations during the measured run: {run_compiles}",
        f"- peak resident memory per configuration "
        f"({'VmHWM, reset before each' if resettable else 'ru_maxrss'}): first {window}: "
        f"max {first:.0f} MiB; last {window}: max {last:.0f} MiB; "
        f"change {100 * growth:+.1f} % (limit ±10 %): {'flat' if flat else 'NOT flat'}",
        f"- time per configuration: median {np.median([r['seconds'] for r in rows]):.3f} s, "
        f"max {max(r['seconds'] for r in rows):.2f} s",
    ]
    if failures:
        lines += ["", "Failures:", ""] + [f"- [{i}] {m}: {'; '.join(p)}"
                                          for i, m, p in failures[:20]]
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        replace_section("soak", text, RESULTS)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
