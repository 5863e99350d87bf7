"""Autofocus on unknown scenes: ``sj.inverse.autofocus`` beside PGA and a single-history
sharpness autofocus, on the same data, with the same metrics.

Setup per draw (issue 18): ``sj.presets.airborne_xband()`` on its grid 1941 × 830; the
scene ``sj.inverse.random_scene`` (speckled clutter on 0.5 m × 3 m cells over Voronoi fields
of −10…+5 dB with a −20 dB road, and 12 bright points of |γ| 15–40, i.e. ≈ 25–33 dB over a
0 dB field per resolution cell); Δy, Δz = ``smooth_deviation(rms=2 cm, max_cycles=2,
aperture=X)`` (X = λr₀/L = 161 m; ≈ 8 rad rms of line-of-sight phase), the seed pointing
jitter (δ_m = λ/(20L), T_b = T_s/10, random φ₀); raw data by the exact model
(``time_domain_nufft``, clutter and points simulated apart and added) plus complex white
noise at SNR 10 dB (mean |h|² over the grid / noise power).

Metrics (``docs/autofocus.md``): residual line-of-sight phase error rms per range block
(near/mid/far thirds of the ground swath), aperture-detrended (what the focus depends on)
and globally detrended; entropy and contrast of the ω-k image relative to the true-track
image; azimuth PSLR of the three brightest points with a clean true-track response
(PSLR ≤ −10 dB) against the true-track image, the unobservable trend aligned; run time
(wall, the first draw includes compilation). "Started from the true motion": the same
estimator with ``initial=`` the truth and no restarts, where its objective's own optimum
lies (what is left is not the search's doing). The "single-history floor" is the residual
of the best phase history shared by all ranges (the true line-of-sight phase averaged over
the swath): no single-history method (PGA, sharpness of one history) can go below it.

Success of a draw: every block ≤ 0.02 rad (aperture-detrended), entropy within 1 %, every
PSLR within 0.5 dB of the true-track image.

Usage::

    python benchmarks/bench_autofocus.py            # 10 draws, writes RESULTS.md
    python benchmarks/bench_autofocus.py --quick    # 1 draw, writes nothing
    python benchmarks/bench_autofocus.py --rms 0.05 --first 200 --draws 6
                                    # larger errors, a section of their own
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

import sarjax as sj
from sarjax.inverse import _autofocus as af
from sarjax.inverse import _autofocus_bound as bound
from sarjax.inverse import _sharpness

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _common import load_average, machine, replace_section, timed  # noqa: E402

NAME = "bench_autofocus"


def draw(seed, *, rms=0.02, max_cycles=2.0, snr_db=10.0):
    radar = sj.presets.airborne_xband()
    rng = np.random.default_rng(seed)
    n = radar.num_pulses
    x = (np.arange(n) - (n - 1) / 2) * float(radar.azimuth_spacing)
    footprint = float(radar.footprint(radar.reference_range))
    clutter, points = sj.inverse.random_scene(radar, x, key=rng)
    dy = sj.smooth_deviation(x, key=rng, rms=rms, max_cycles=max_cycles, aperture=footprint)
    dz = sj.smooth_deviation(x, key=rng, rms=rms, max_cycles=max_cycles, aperture=footprint)
    pointing = np.asarray(sj.seed_pointing_jitter(radar, x, phase=rng.uniform(-np.pi, np.pi)))
    truth = sj.Motion(horizontal=dy, vertical=dz, pointing=pointing)
    parts = [sj.simulate(radar, s, truth, method="time_domain_nufft") for s in (clutter, points)]
    data = np.asarray(parts[0].data) + np.asarray(parts[1].data)
    noise_power = np.mean(np.abs(data) ** 2) / 10 ** (snr_db / 10)
    data = data + np.sqrt(noise_power / 2) * (rng.normal(size=data.shape)
                                              + 1j * rng.normal(size=data.shape))
    raw = sj.RawData(data=data, azimuth=parts[0].azimuth, range=parts[0].range)
    return radar, raw, truth, points, (np.asarray(parts[0].data), np.asarray(parts[1].data),
                                       noise_power)


def genie_bounds(radar, raw, parts, truth, targets):
    """Cramér–Rao references per range block [rad] for the model-based estimator's B-spline
    size: ``scene`` (clutter and points known, only the noise), ``points`` (the points
    known, the clutter counted as interference), ``clutter`` (the points known, the
    clutter's reflectivity unknown: a Gaussian process of known spectrum and local power,
    ``_autofocus_bound.clutter_information``) and ``positions`` (as ``clutter``, with each
    point's phase and azimuth position unknown as well: ``phase_bound(points=...)``, each
    point's echo simulated alone by the exact model)."""
    clutter, pts, noise_power = parts
    x = np.asarray(raw.azimuth)
    num_basis = af._default_model(radar, x).horizontal.num_basis()
    blocks = af.range_blocks(radar, raw.range)
    scene, ranges = bound.phase_information(radar, clutter + pts, noise_power, raw.azimuth,
                                            raw.range)
    points, _ = bound.phase_information(radar, pts, noise_power, raw.azimuth, raw.range,
                                        interference=clutter)
    band, _ = bound.clutter_information(
        radar, clutter, noise_power, raw.azimuth, raw.range,
        phase=lambda r: af.true_line_of_sight_phase(radar, truth, r))
    each = []
    for k in range(int(np.size(targets.azimuth))):
        one = sj.PointTargets(azimuth=np.asarray(targets.azimuth)[k:k + 1],
                              range=np.asarray(targets.range)[k:k + 1],
                              reflectivity=np.asarray(targets.reflectivity)[k:k + 1])
        echo = np.asarray(sj.simulate(radar, one, truth, method="time_domain").data)
        each.append(bound.phase_information(radar, echo, noise_power, raw.azimuth, raw.range,
                                            interference=clutter)[0])
    return {"scene": bound.phase_bound(radar, scene, ranges, num_basis, blocks),
            "positions": bound.phase_bound(radar, None, ranges, num_basis, blocks,
                                           clutter=band, points=each),
            "points": bound.phase_bound(radar, points, ranges, num_basis, blocks),
            "clutter": bound.phase_bound(radar, points, ranges, num_basis, blocks,
                                         clutter=band)}


def clean_points(points, raw, radar, reference, count=3, *, max_pslr_db=-10.0):
    """The ``count`` brightest points at least one footprint/2 inside the pulses' span
    whose azimuth PSLR in the true-track ``reference`` image is ≤ ``max_pslr_db``: where
    clutter or another point lies in a point's sidelobes, its PSLR measures them, not the
    focus (on draw 108 the three brightest points have −12.7, −5.0 and −0.9 dB)."""
    x = np.asarray(raw.azimuth)
    half = float(radar.footprint(radar.reference_range)) / 2
    inside = ((np.asarray(points.azimuth) > x.min() + half)
              & (np.asarray(points.azimuth) < x.max() - half))
    chosen = []
    for i in np.argsort(-np.abs(np.asarray(points.reflectivity))):
        if not inside[i]:
            continue
        where = (float(points.azimuth[i]), float(points.range[i]))
        if pslr(reference, [where])[0] <= max_pslr_db:
            chosen.append(where)
        if len(chosen) == count:
            break
    return chosen


def trend(v):
    """The constant and linear trend of ``v`` over the pulses (what no autofocus sees)."""
    v = np.asarray(v, float)
    return v - af._remove_trend(v)


def aligned_image(radar, raw, truth, result):
    """The image of ``result`` with its own constant and linear trend replaced by the
    truth's: a linear trend moves the image (by r ∂δr/∂x', 0.1–0.3 m here), which changes
    where a PSLR is sampled; it is unobservable, so the comparison is made without it."""
    dy, dz, _ = (np.asarray(v) for v in truth.resolve(int(raw.azimuth.shape[0])))
    if result.phase_history is None:
        motion = sj.Motion(horizontal=af._remove_trend(result.motion.horizontal) + trend(dy),
                           vertical=af._remove_trend(result.motion.vertical) + trend(dz))
        return sj.focus(radar, raw, motion=motion)
    los = af.true_line_of_sight_phase(radar, truth, [float(radar.reference_range)])[0]
    return af._phase_image(radar, raw, af._remove_trend(result.phase_history) + trend(los))


def pslr(image, where):
    out = []
    for xa, ra in where:
        try:
            m = sj.metrics.point_target_metrics(image, azimuth=xa, range=ra)
        except ValueError:  # a response too wide for the neighbourhood: not focused
            out.append(np.nan)
            continue
        out.append(m.pslr_azimuth)
    return np.asarray(out)


def evaluate(radar, raw, truth, points, result, reference, where):
    blocks = af.range_blocks(radar, raw.range)
    aperture = af.residual_phase_rms(radar, result, truth, blocks)
    global_ = af.residual_phase_rms(radar, result, truth, blocks, detrend="global")
    entropy = af.image_entropy(result.image.data) / af.image_entropy(reference.data) - 1
    contrast = (_sharpness.image_contrast(result.image.data)
                / _sharpness.image_contrast(reference.data) - 1)
    d_pslr = pslr(aligned_image(radar, raw, truth, result), where) - pslr(reference, where)
    return dict(aperture=aperture, global_=global_, entropy=entropy, contrast=contrast,
                d_pslr=d_pslr)


def single_history_floor(radar, raw, truth):
    focus_ranges = np.asarray(_sharpness.make_focuser(radar, raw).range)
    common = af.true_line_of_sight_phase(radar, truth, focus_ranges).mean(axis=0)
    floor = af.no_estimate(raw)
    floor = af.AutofocusResult(**{**floor.__dict__, "phase_history": common,
                                  "motion": sj.Motion()})
    blocks = af.range_blocks(radar, raw.range)
    return af.residual_phase_rms(radar, floor, truth, blocks)


def fmt(v, digits=3):
    return " / ".join(f"{x:.{digits}f}" for x in np.atleast_1d(v))


def table(rows, info, complete, draws, rms=0.02):
    name = section_name(rms)
    lines = [
        f"<!-- {name}:start -->",
        "## Autofocus on unknown scenes (`bench_autofocus.py`, issue 18)"
        + ("" if rms == 0.02 else f", {rms * 100:g} cm rms"),
        "",
        f"Machine: {info['cpu']}, {info['usable_cores']} usable cores (shared; load "
        f"{info['load']:.1f} at the start), jax {info['jax']}, commit {info['commit']}, "
        f"{info['date']}." + ("" if complete else f" **Incomplete: {len(rows)} of {draws} "
                                                   "draws.**"),
        "",
        "Airborne preset 1941 × 830, random clutter scene (fields, road, 12 bright points), "
        f"Δy, Δz smooth {rms * 100:g} cm rms (2 cycles per footprint), seed pointing jitter, "
        f"SNR 10 dB (draws {rows[0]['seed'] if rows else 100}–"
        f"{rows[-1]['seed'] if rows else 100}). "
        "Residual LOS phase rms [rad] per range block near / mid / far, aperture-detrended "
        "(global detrend in brackets); ΔH = entropy relative to the true-track image; "
        "ΔPSLR = worst azimuth PSLR difference [dB] of the 3 brightest points whose true-track "
        "PSLR is ≤ −10 dB (others have clutter in their sidelobes), each image with the "
        "truth's constant and linear trend in place of its own (unobservable: it moves the "
        "image and so where the PSLR is sampled), with the number of such points; nan: no "
        "response narrow enough to measure; time = wall "
        "seconds of the call (first draw includes compilation). CRB rows: genie-aided "
        "Cramér–Rao references of the same metric for the default model "
        "(docs/autofocus.md): scene known (the genie bound), points known with the clutter "
        "as interference (what the points alone support), points known with the clutter's "
        "reflectivity unknown (a Gaussian process of known spectrum and local power: a lower "
        "bound for any unbiased estimator not told the clutter), and the same with each "
        "point's phase and azimuth position unknown too (as for an estimator that finds the "
        "points in the data; ratio = the model-based residual over it).",
        "",
        "| draw | method | residual [rad] | (global) | ΔH | ΔPSLR [dB] | time [s] | ok |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        for name in ("model", "pga", "sharpness_phase"):
            m = row[name]
            worst = float(np.max(np.abs(m["d_pslr"]))) if m["d_pslr"].size else float("nan")
            shown = (f"{worst:.2f} ({m['d_pslr'].size} pt)" if m["d_pslr"].size
                     else "– (no clean point)")
            ok = (np.all(m["aperture"] <= 0.02) and abs(m["entropy"]) <= 0.01
                  and (not m["d_pslr"].size or worst <= 0.5))
            lines.append(f"| {row['seed']} | {name} | {fmt(m['aperture'])} | "
                         f"({fmt(m['global_'], 2)}) | {100 * m['entropy']:+.3f} % | "
                         f"{shown} | {m['time']:.1f} | {'yes' if ok else 'no'} |")
        lines.append(f"| {row['seed']} | model-based, agreement of 3 starts | "
                     f"{fmt(row['agreement'])} | | | | | "
                     f"{'warned' if row['warned'] else 'no warning'} |")
        drift = row["map_drift"]
        lines.append(f"| {row['seed']} | model-based, the other stage-0 choice "
                     f"(`map_drift={drift['iterations']}`) | "
                     f"{fmt(drift['aperture'])} | | | | {drift['time']:.1f} | "
                     f"{'warned' if drift['warned'] else 'no warning'} |")
        lines.append(f"| {row['seed']} | model-based, started from the true motion | "
                     f"{fmt(row['from_truth'])} | | | | | |")
        lines.append(f"| {row['seed']} | single-history floor | {fmt(row['floor'])} | | | | "
                     "| |")
        lines.append(f"| {row['seed']} | no correction | {fmt(row['none'])} | | | | | |")
        lines.append(f"| {row['seed']} | CRB, scene known | {fmt(row['bounds']['scene'], 5)} | "
                     "| | | | |")
        lines.append(f"| {row['seed']} | CRB, points known | {fmt(row['bounds']['points'], 4)}"
                     " | | | | | |")
        lines.append(f"| {row['seed']} | CRB, points known, clutter unknown | "
                     f"{fmt(row['bounds']['clutter'], 4)} | | | | | |")
        ratio = row["model"]["aperture"] / row["bounds"]["positions"]
        lines.append(f"| {row['seed']} | CRB, points at unknown positions, clutter unknown | "
                     f"{fmt(row['bounds']['positions'], 4)} | (ratio {fmt(ratio, 1)}) | | | "
                     "| |")
    if rows:
        ok = sum(bool(np.all(r["model"]["aperture"] <= 0.02)) for r in rows)
        med = np.median([r["model"]["aperture"] for r in rows], axis=0)
        med_pga = np.median([r["pga"]["aperture"] for r in rows], axis=0)
        med_t = np.median([r["model"]["time"] for r in rows[1:]] or [rows[0]["model"]["time"]])
        above = sum(bool(np.any(r["bounds"]["clutter"] > 0.02)) for r in rows)
        crb = np.array([r["bounds"]["clutter"] for r in rows])
        pos = np.array([r["bounds"]["positions"] for r in rows])
        ratios = [float(np.max(r["model"]["aperture"] / r["bounds"]["positions"])) for r in rows]
        within3 = sum(q <= 3 for q in ratios)
        failed = [bool(np.max(r["model"]["aperture"]) > 0.35) for r in rows]
        warned = [r["warned"] for r in rows]
        caught = sum(f and w for f, w in zip(failed, warned, strict=True))
        med_truth = np.median([r["from_truth"] for r in rows], axis=0)
        truth_failed = [float(np.max(r["from_truth"])) for r, f in zip(rows, failed,
                                                                         strict=True) if f]
        false_alarms = sum(w and not f for f, w in zip(failed, warned, strict=True))
        drift_failed = [bool(np.max(r["map_drift"]["aperture"]) > 0.35) for r in rows]
        drift_warned = [r["map_drift"]["warned"] for r in rows]
        drift_false = sum(w and not f for f, w in zip(drift_failed, drift_warned, strict=True))
        drift_t = np.median([r["map_drift"]["time"] for r in rows])
        lines += ["", f"Model-based: median residual {fmt(med)} rad (PGA {fmt(med_pga)}); "
                      f"{ok} of {len(rows)} draws ≤ 0.02 rad in every block; median run time "
                      f"{med_t:.1f} s (draws after the first). Cramér–Rao bound with the "
                      f"clutter unknown: {crb.min():.3f}–{crb.max():.3f} rad, above 0.02 rad "
                      f"in at least one block on {above} of {len(rows)} draws. With the points' "
                      f"positions unknown too: {pos.min():.3f}–{pos.max():.3f} rad; model-based "
                      f"residual within 3× of it in every block on {within3} of {len(rows)} "
                      f"draws (median worst-block ratio {np.median(ratios):.1f}). "
                      f"Starts that disagree (> 0.1 rad, an AutofocusWarning): "
                      f"{caught} of the {sum(failed)} draws whose worst block is > 0.35 rad "
                      f"warned; {false_alarms} of the other {len(rows) - sum(failed)} did. "
                      f"The default ran the map-drift stage (its start's blur ≥ "
                      f"`map_drift_blur`) on {sum(r['map_drift']['iterations'] == 0 for r in rows)}"
                      f" of {len(rows)} draws. With the other choice of that stage on each "
                      f"draw (same data): "
                      f"{len(rows) - sum(drift_failed)} of {len(rows)} draws converge (worst "
                      f"block ≤ 0.35 rad) against {len(rows) - sum(failed)} with the default; "
                      f"{sum(f and w for f, w in zip(drift_failed, drift_warned, strict=True))}"
                      f" of its {sum(drift_failed)} failures warned, {drift_false} of its "
                      f"{len(rows) - sum(drift_failed)} converged draws did; median run time "
                      f"{drift_t:.1f} s. "
                      f"Started from the true motion (`initial=`, no restarts) the estimator "
                      f"ends at a median {fmt(med_truth)} rad from it: its objective's "
                      f"optimum lies that far from the truth, whatever the search"
                      + (f"; on the draws whose estimate failed it ends "
                         f"{', '.join(f'{v:.3f}' for v in truth_failed)} rad (worst block) "
                         "from it, so those failures are the search's." if truth_failed
                         else ".")]
    lines.append(f"<!-- {name}:end -->")
    return "\n".join(lines)


def section_name(rms):
    """The RESULTS.md section of a run: the issue's 2 cm setup, or another size apart."""
    return NAME if rms == 0.02 else f"{NAME}_{rms * 100:g}cm"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--draws", type=int, default=10)
    parser.add_argument("--first", type=int, default=100, help="seed of the first draw")
    parser.add_argument("--rms", type=float, default=0.02,
                        help="rms of Δy and Δz [m]; other than 0.02 writes its own section")
    args = parser.parse_args()
    draws = 1 if args.quick else args.draws
    info = machine()
    rows = []
    for seed in range(args.first, args.first + draws):
        t0 = time.perf_counter()
        radar, raw, truth, points, parts = draw(seed, rms=args.rms)
        print(f"draw {seed}: simulated in {time.perf_counter() - t0:.0f} s "
              f"(load {load_average():.1f})", flush=True)
        reference = sj.focus(radar, raw, motion=truth)
        where = clean_points(points, raw, radar, reference)
        row = dict(seed=seed, floor=single_history_floor(radar, raw, truth),
                   bounds=genie_bounds(radar, raw, parts, truth, points),
                   none=af.residual_phase_rms(radar, af.no_estimate(raw), truth,
                                              af.range_blocks(radar, raw.range)))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", af.AutofocusWarning)
            wall, _, model = timed(lambda raw=raw, radar=radar: sj.inverse.autofocus(radar, raw))
        row["warned"] = any("starts differ" in str(w.message) for w in caught)
        # the same estimator started from the true motion: how far its objective's optimum
        # lies from the truth, apart from the search
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", af.AutofocusWarning)
            from_truth = sj.inverse.autofocus(radar, raw, initial=truth, restarts=0)
        row["from_truth"] = af.residual_phase_rms(radar, from_truth, truth,
                                                  af.range_blocks(radar, raw.range))
        with warnings.catch_warnings():
            warnings.simplefilter("always", af.AutofocusWarning)
            wall_pga, _, pga = timed(lambda raw=raw, radar=radar: sj.inverse.pga(radar, raw))
            wall_sp, _, sharp = timed(lambda raw=raw, radar=radar, pga=pga:
                                      sj.inverse.sharpness_phase(radar, raw, initial=pga))
        for name, result, seconds in (("model", model, wall), ("pga", pga, wall_pga),
                                      ("sharpness_phase", sharp, wall_sp + wall_pga)):
            row[name] = evaluate(radar, raw, truth, points, result, reference, where)
            row[name]["time"] = seconds
        row["agreement"] = model.agreement
        # the same estimator with the other choice of its first stage (map drift: off where
        # the default ran it, 8 iterations where it did not), same data
        other = 0 if any(": 8 map-drift" in step[0] for step in model.history) else 8
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", af.AutofocusWarning)
            wall_drift, _, drift = timed(lambda raw=raw, radar=radar, other=other:
                                         sj.inverse.autofocus(radar, raw, map_drift=other))
        row["map_drift"] = dict(
            aperture=af.residual_phase_rms(radar, drift, truth, af.range_blocks(radar, raw.range)),
            warned=any("starts differ" in str(w.message) for w in caught), time=wall_drift,
            iterations=other)
        pointing_error = (np.asarray(model.motion.pointing)
                          - (truth.pointing - np.mean(truth.pointing)))
        print(f"  model {fmt(row['model']['aperture'])} pga {fmt(row['pga']['aperture'])} "
              f"sharp {fmt(row['sharpness_phase']['aperture'])} floor {fmt(row['floor'])} "
              f"time {wall:.1f} s; pointing error rms "
              f"{np.sqrt(np.mean(pointing_error**2)):.2e} rad of "
              f"{np.std(truth.pointing):.2e}", flush=True)
        rows.append(row)
        if not args.quick:
            replace_section(section_name(args.rms),
                            table(rows, info, len(rows) == draws, draws, args.rms))
    if args.quick:
        print(table(rows, info, True, draws, args.rms))


if __name__ == "__main__":
    main()
