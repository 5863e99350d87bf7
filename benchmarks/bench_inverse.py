"""Acceptance runs of the inverse module (``sj.fit_motion``, ``sj.crb``).

Setup (issue 6): ``sj.presets.airborne_xband()`` on its point-target raw grid 1941 × 830;
three unit point targets at x = 0, r = 4840, 5140, 5440 m; raw data from the exact model
(``method="time_domain"``) plus complex white noise at raw-data SNR 0 dB (noise power =
mean |h|² over the 1941 × 830 grid). Truth per seed: Δy, Δz =
``smooth_deviation(rms, max_cycles=5, aperture=X)`` (X = λr₀/L = 161 m), the seed jitter
δ_m = λ/(20L), T_b = T_s/10 with φ₀ uniform in (−π, π]. Case A: rms 2 cm; case B: 0.5 m.
Fits start from zero deviation and no jitter guess (``fit_motion`` defaults: 36 cubic
B-splines per deviation component over the pulses within X_t/2 of a target, sinusoidal
jitter, optimistix Levenberg–Marquardt).

Errors are measured on the fitted pulses after removing the components the fit reports
as fixed (the means of Δy and Δz: ``sj.inverse.align``); LOS is the deviation projected
on the scene-centre direction, −Δy sin ϑ₀ + Δz cos ϑ₀. Criteria per seed: LOS rmse ≤ λ/20;
Δy and Δz rmse ≤ max(λ/10, 1.5 × their CRB rms); jitter amplitude within 5 %, period
within 1 %, phase within 0.1 rad.

Also: a Monte-Carlo run (fixed case-A truth, independent noise draws): rmse / CRB per
parameter group; back-projection (``sj.focus(method="backprojection")``, of the pulses
the fit used) with the fitted and with the true track: PSLR and peak differences; fit times
(the first call includes compilation).

Writes its section of ``benchmarks/RESULTS.md`` (between ``<!-- bench_inverse:start -->``
and ``<!-- bench_inverse:end -->``). Usage::

    python benchmarks/bench_inverse.py            # 50 MC draws, 20 seeds per case
    python benchmarks/bench_inverse.py --quick    # 4 draws, 2 seeds, writes nothing

The section is rewritten after each part (Monte-Carlo draws first, then the cases, then
back-projection), so an interrupted run leaves what it finished, marked incomplete.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import sarjax as sj
from sarjax import inverse as inv

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _common import load_average, machine, replace_section, timed  # noqa: E402

START = "<!-- bench_inverse:start -->"
END = "<!-- bench_inverse:end -->"
TARGET_RANGES = (4840.0, 5140.0, 5440.0)


def setup():
    radar = sj.presets.airborne_xband()
    scene = sj.PointTargets(azimuth=[0.0, 0.0, 0.0], range=list(TARGET_RANGES))
    return radar, scene


def truth(radar, rms, seed):
    rng = np.random.default_rng(seed)
    n = radar.num_pulses
    x = (np.arange(n) - (n - 1) / 2) * float(radar.azimuth_spacing)
    footprint = float(radar.footprint(radar.reference_range))
    dy = sj.smooth_deviation(x, key=rng, rms=rms, max_cycles=5, aperture=footprint)
    dz = sj.smooth_deviation(x, key=rng, rms=rms, max_cycles=5, aperture=footprint)
    jitter = (float(radar.wavelength / radar.antenna_length) / 20,
              float(radar.integration_time()) / 10, float(rng.uniform(-np.pi, np.pi)))
    pointing = np.asarray(sj.sinusoidal_pointing(
        x, amplitude=jitter[0], period=jitter[1], velocity=float(radar.velocity),
        phase=jitter[2]))
    return sj.Motion(horizontal=dy, vertical=dz, pointing=pointing), jitter


def noisy(clean, rng):
    data = np.asarray(clean.data)
    power = float(np.mean(np.abs(data) ** 2))  # SNR 0 dB over the raw grid
    noise = np.sqrt(power / 2) * (rng.normal(size=data.shape) + 1j * rng.normal(size=data.shape))
    return sj.RawData(data=data + noise, azimuth=clean.azimuth, range=clean.range), power


def errors(result, motion, jitter):
    ey, ez, _ = inv.align(result.motion, motion, result)
    s0, c0 = result.reference_direction
    rms = lambda v: float(np.sqrt(np.mean(np.asarray(v) ** 2)))
    amplitude, period, phase = jitter
    return dict(
        horizontal=rms(ey), vertical=rms(ez), los=rms(-s0 * ey + c0 * ez),
        amplitude=result.jitter["amplitude"] / amplitude - 1,
        period=result.jitter["period"] / period - 1,
        phase=float(np.angle(np.exp(1j * (result.jitter["phase"] - phase)))),
    )


def passes(err, bound, lam):
    return (err["los"] <= lam / 20
            and err["horizontal"] <= max(lam / 10, 1.5 * bound.rms["horizontal"])
            and err["vertical"] <= max(lam / 10, 1.5 * bound.rms["vertical"])
            and abs(err["amplitude"]) <= 0.05 and abs(err["period"]) <= 0.01
            and abs(err["phase"]) <= 0.1)


def run_case(radar, scene, rms, seeds, log):
    lam = float(radar.wavelength)
    rows = []
    for seed in seeds:
        motion, jitter = truth(radar, rms, seed)
        clean = sj.simulate(radar, scene, motion)
        raw, power = noisy(clean, np.random.default_rng(10_000 + seed))
        seconds, _, result = timed(lambda raw=raw: sj.fit_motion(radar, scene, raw))
        bound = sj.crb(radar, scene, noise_power=power, motion=motion, jitter=jitter)
        err = errors(result, motion, jitter)
        ok = passes(err, bound, lam)
        rows.append(dict(seed=seed, seconds=seconds, ok=ok, err=err, crb=bound.rms,
                         converged=result.converged, steps=result.history[-1].steps,
                         timings=result.timings, chi2=result.chi2 / result.num_residuals))
        log(f"  rms={rms} seed={seed}: {'ok ' if ok else 'FAIL'} {seconds:6.1f} s  "
            f"LOS {err['los'] * 1e3:.4f} mm  H {err['horizontal'] * 1e3:.3f} mm  "
            f"V {err['vertical'] * 1e3:.3f} mm  δ_m {err['amplitude'] * 100:+.2f} %  "
            f"T_b {err['period'] * 100:+.3f} %  φ₀ {err['phase']:+.4f} rad  "
            f"steps {rows[-1]['steps']}  converged {result.converged}")
    return rows


def monte_carlo(radar, scene, draws, log, progress=None):
    motion, jitter = truth(radar, 0.02, 0)
    clean = sj.simulate(radar, scene, motion)
    power = float(np.mean(np.abs(np.asarray(clean.data)) ** 2))
    bound = sj.crb(radar, scene, noise_power=power, motion=motion, jitter=jitter)
    amplitude, period, _ = jitter
    crb = {
        "horizontal": bound.rms["horizontal"], "vertical": bound.rms["vertical"],
        "los": bound.rms["line_of_sight"],
        "amplitude": bound.jitter["amplitude_std"] / amplitude,
        "period": bound.jitter["period_std"] / period, "phase": bound.jitter["phase_std"],
    }
    sq = {k: [] for k in ("horizontal", "vertical", "los", "amplitude", "period", "phase")}
    times = []
    recovered = 0

    def summary():
        # a cold-start failure (LOS rmse > λ/20) is counted, and the rmse is given both over
        # all draws and over the others (the estimator's efficiency where it converged)
        ok = np.asarray(sq["los"]) <= (float(radar.wavelength) / 20) ** 2
        rmse = {k: (float(np.sqrt(np.mean(v))),
                    float(np.sqrt(np.mean(np.asarray(v)[ok]))) if ok.any() else np.nan)
                for k, v in sq.items()}
        return rmse, crb, list(times), int((~ok).sum()), recovered

    for d in range(draws):
        raw, _ = noisy(clean, np.random.default_rng(50_000 + d))
        seconds, _, result = timed(lambda raw=raw: sj.fit_motion(radar, scene, raw))
        times.append(seconds)
        err = errors(result, motion, jitter)
        for k in sq:
            sq[k].append(err[k] ** 2)
        retries = sum(s.name.startswith("recovery") for s in result.history)
        recovered += retries > 0
        log(f"  draw {d} (noise seed {50_000 + d}): {times[-1]:.1f} s, LOS "
            f"{err['los'] * 1e6:.2f} µm, H {err['horizontal'] * 1e6:.1f} µm, V "
            f"{err['vertical'] * 1e6:.1f} µm, δ_m {err['amplitude'] * 100:+.2f} %, T_b "
            f"{err['period'] * 100:+.3f} %, φ₀ {err['phase']:+.4f} rad, χ²/M "
            f"{result.chi2 / result.num_residuals:.4f}, converged {result.converged}, "
            f"re-starts {retries}")
        if progress is not None:
            progress(summary())
    return summary()


def backprojection_check(radar, scene, rms, seed):
    motion, jitter = truth(radar, rms, seed)
    clean = sj.simulate(radar, scene, motion)
    raw, _ = noisy(clean, np.random.default_rng(10_000 + seed))
    result = sj.fit_motion(radar, scene, raw)
    dx, dr = float(radar.azimuth_spacing), float(radar.range_spacing)
    # both images from the pulses the fit used (the fit says nothing about the others)
    keep = result.support
    raw = sj.RawData(data=np.asarray(raw.data)[keep], azimuth=np.asarray(raw.azimuth)[keep],
                     range=raw.range)
    tracks = []
    for m in (motion, result.motion):
        dy, dz, pointing = (np.asarray(v)[keep] for v in m.resolve(keep.size))
        tracks.append(sj.Motion(horizontal=dy, vertical=dz, pointing=pointing))
    out = []
    for r in TARGET_RANGES:
        az = (np.arange(128) - 64) * dx
        rg = r + (np.arange(64) - 32) * dr / 2
        metrics = []
        for track in tracks:
            image = sj.focus(radar, raw, method="backprojection", motion=track, azimuth=az,
                             range=rg)
            metrics.append(sj.point_target_metrics(image, azimuth=0.0, range=r))
        true, fit = metrics
        out.append(dict(
            range=r,
            pslr_azimuth=fit.pslr_azimuth - true.pslr_azimuth,
            pslr_range=fit.pslr_range - true.pslr_range,
            peak=fit.peak_db - true.peak_db,
        ))
    return out


def host_line():
    """:func:`_common.machine` on one line."""
    m = machine()
    return (f"{m['cpu']}; {m['cores']} logical cores; JAX {m['jax']}, backend "
            f"{m['backend']}; NumPy {m['numpy']}; Python {m['python']}; sarjax commit "
            f"{m['commit']}; {m['date']}")


def render(cases, mc, bp, lines, n_seeds, n_draws, load0, load1, pending, host):
    """The RESULTS.md section from the parts done so far (``pending``: parts still running);
    ``host``: :func:`host_line` at the start (the commit whose code runs)."""
    md = [START, "## Inverse module (`bench_inverse.py`)", "",
          "Generated by `python benchmarks/bench_inverse.py` (see the script's docstring for "
          "the setup); re-running it replaces only this section.", "",
          f"- Machine: {host}",
          f"- Load average (1 min) at start / end: {load0:.2f} / {load1:.2f}. The machine is "
          "shared with other work: times are wall-clock and disturbed by it.", ""]
    if pending:
        md += [f"**Incomplete: still running or not reached: {', '.join(pending)}.**", ""]
    if mc:
        rmse, crb, mc_times, failed, recovered = mc
        done = len(mc_times)
        md += [f"### Monte-Carlo: {done} noise draws at the seed-0 case-A truth", "",
               f"Cold-start failures (LOS rmse > λ/20): {failed} of {done}. Draws where a "
               f"slipped unwrapping was detected and the fit re-started: {recovered}.", "",
               "| parameter group | rmse, all draws | rmse, without failures | CRB | "
               "rmse / CRB (all draws) | rmse / CRB (without failures) |",
               "|---|---|---|---|---|---|"]
        units = dict(horizontal=("mm", 1e3), vertical=("mm", 1e3), los=("µm", 1e6),
                     amplitude=("%", 100), period=("%", 100), phase=("rad", 1))
        for k in rmse:
            u, f = units[k]
            md.append(f"| {k} [{u}] | {rmse[k][0] * f:.4g} | {rmse[k][1] * f:.4g} | "
                      f"{crb[k] * f:.4g} | {rmse[k][0] / crb[k]:.3f} | "
                      f"{rmse[k][1] / crb[k]:.3f} |")
        md += ["", f"Median fit time over the draws: {np.median(mc_times):.1f} s. Per-draw "
               "lines:", "", "```"]
        md += [s for s in lines if s.startswith("  draw ")]
        md += ["```", ""]
    if cases:
        md += [f"### Acceptance: {n_seeds} random seeds per case, from zero initial motion", "",
               "| case | seeds passing | LOS rmse max [mm] (λ/20 = 1.57) | Δy rmse max [mm] | "
               "Δz rmse max [mm] | CRB Δy / Δz / LOS rms [mm] | |δ_m err| max [%] | "
               "|T_b err| max [%] | |φ₀ err| max [rad] | fit time median / max [s] | "
               "first fit of the case [s] (compilation: the first Monte-Carlo draw) |",
               "|---|---|---|---|---|---|---|---|---|---|---|"]
        for label, rows in cases.items():
            e = lambda k, rows=rows: max(abs(r["err"][k]) for r in rows)
            c = rows[0]["crb"]
            t = [r["seconds"] for r in rows]
            md.append(
                f"| {label} | {sum(r['ok'] for r in rows)} / {len(rows)} | "
                f"{e('los') * 1e3:.4f} | "
                f"{e('horizontal') * 1e3:.3f} | {e('vertical') * 1e3:.3f} | "
                f"{c['horizontal'] * 1e3:.3f} / {c['vertical'] * 1e3:.3f} / "
                f"{c['line_of_sight'] * 1e3:.4f} | {e('amplitude') * 100:.2f} | "
                f"{e('period') * 100:.3f} | {e('phase'):.4f} | {np.median(t[1:] or t):.1f} / "
                f"{max(t):.1f} | {t[0]:.1f} |")
        md += ["", "λ/10 = 3.14 mm: every Δy, Δz criterion is met by the λ/10 clause (the CRB "
               "is far below). Per-seed lines:", "", "```"]
        md += [s for s in lines if s.startswith("  rms=")]
        md += ["```", ""]
    if bp:
        md += ["### Back-projection with the fitted vs the true track (seed 0)", "",
               "| case | target range [m] | ΔPSLR azimuth [dB] | ΔPSLR range [dB] | "
               "Δpeak [dB] |", "|---|---|---|---|---|"]
        for label, rows in bp.items():
            for r in rows:
                md.append(f"| {label} | {r['range']:.0f} | {r['pslr_azimuth']:+.4f} | "
                          f"{r['pslr_range']:+.4f} | {r['peak']:+.5f} |")
        md += [""]
    md += [END]
    return "\n".join(md)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--write", action="store_true", help="write RESULTS.md with --quick")
    parser.add_argument("--seeds", type=int, default=None)
    parser.add_argument("--draws", type=int, default=None)
    args = parser.parse_args()
    n_seeds = args.seeds if args.seeds is not None else (2 if args.quick else 20)
    n_draws = args.draws if args.draws is not None else (4 if args.quick else 50)
    lines = []
    log = lambda s: (print(s, flush=True), lines.append(s))
    radar, scene = setup()
    load0 = load_average()
    host = host_line()
    save = not args.quick or args.write
    cases, mc, bp = {}, None, {}
    parts = ["Monte-Carlo", "case A", "case B", "back-projection"]

    def checkpoint(done):
        # the section is rewritten after every part (and every Monte-Carlo draw), so a slow
        # run still leaves what it finished
        if done in parts:
            parts.remove(done)
        text = render(cases, mc, bp, lines, n_seeds, n_draws, load0, load_average(),
                      parts, host)
        if save:
            replace_section("bench_inverse", text)
        return text

    # the Monte-Carlo first: the longest part, and the one the CRB comparison needs
    if n_draws:
        log("Monte-Carlo (case A, seed-0 truth)")

        def progress(partial):
            nonlocal mc
            mc = partial
            checkpoint(None)

        mc = monte_carlo(radar, scene, n_draws, log, progress)
    checkpoint("Monte-Carlo")
    for label, rms in (("A", 0.02), ("B", 0.5)):
        if n_seeds:
            log(f"case {label} (rms {rms} m)")
            cases[label] = run_case(radar, scene, rms, range(n_seeds), log)
        checkpoint(f"case {label}")
    log("back-projection")
    bp = {label: backprojection_check(radar, scene, rms, 0)
          for label, rms in (("A", 0.02), ("B", 0.5))}
    print(checkpoint("back-projection"))


if __name__ == "__main__":
    main()
