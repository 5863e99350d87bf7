"""sarjax side by side with FastSAR (PyPI ``fastsar``) on raw-echo workloads both can do.

FastSAR's raw-echo simulators (read from its source, version 0.1.8):

* ``fastsar.stripmap.simulate(p, targets, amp)``: exact stripmap point-target echoes on a
  straight, constant-velocity track, float64 NumPy, one target at a time over the pulses
  inside its simulated beam (``|u| ≤ p.extent``)::

      s(η_p, τ_k) = Σ_n a_n G(u) exp(+jπ K_r (τ_k − 2R/c)²) exp(−j4πR/λ),  |τ_k − 2R/c| ≤ T_p/2
      R = √(r_n² + (x_n − vη_p)²),  u = L_a (sin θ − sin θ_s)/λ,  sin θ = (x_n − vη_p)/R,
      G = sinc²(u) (or a Gaussian), τ_k = t₀ + k/f_s, η_p = η₀ + p/PRF.

* ``fastsar.sim.raw_echoes(col, pos, amp, fs, chirp, r_near, n, lat, lon, ...)``: raw echoes
  of 3-D scatterers for any per-pulse antenna position (``col.ant``, so any track), no
  antenna pattern, stop-and-go (unless ``vel`` is given): a sampled replica ``chirp`` of
  L samples delayed by the two-way time with a band-limited fractional shift (its 4L-point
  DFT times a linear phase), times ``exp(−j2π f_c τ)``, summed by a Python loop over
  (pulse, scatterer); complex64 output. Positions go through ``to_ecf`` (a rigid motion;
  at lat = lon = heading = 0 it is an axis permutation plus the Earth radius).

* ``fastsar.sim.simulate(col, pos, amp, eps)``: not raw echoes but the motion-compensated
  frequency-domain phase history ``S[p, k] = Σ σ exp(−j4π f_k ΔR/c)`` (no chirp, no range
  gate), one finufft type-1 NUFFT per pulse (needs ``finufft``; run with one thread, see
  :func:`fastsar_fx`). Timed as FastSAR's fastest
  many-scatterer path, with its accuracy against its own float64 direct sum
  (``sim.simulate_brute``); a different product, so never counted as like-for-like.

sarjax model (``method="time_domain"``)::

    h(x'_p, r'_k) = Σ γ W²(u) exp(−j4πρ/λ − j b (r'_k − ρ)²) rect[(r'_k − ρ)/(cτ/2)],
    b = 4πΔf/(c²τ),  ρ = exact 3-D range (stop-and-go),  u = (x' − x − δx)/(λr/L).

Alignment (every convention difference and how it is matched):

* chirp sign: b (r' − ρ)² = πK_r(τ − 2ρ/c)² with τ = 2r'/c, but FastSAR's chirp is an
  up-chirp ``+jπK_r`` and sarjax's ``−j b``; the carrier term ``exp(−j4πR/λ)`` has the same
  sign in both. ``stripmap``: ``B = −Δf`` (K_r < 0; only K_r enters the simulation).
  ``raw_echoes``: the replica is ``exp(−jπ(Δf/τ)u²)``.
* chirp position: ``raw_echoes`` starts the replica (L = round(τ f_s) samples, centred
  ``u = (i − (L−1)/2)/f_s``) at the echo delay; its window start is moved by
  ``c (L−1)/(4 f_s)`` so that the chirp centre falls at ρ as in sarjax.
* sampling: ``t₀ = 2 r'₀/c``, ``f_s`` the same; pulses ``η₀ = −(N_x − 1)/(2 PRF)`` so that
  ``vη_p`` = sarjax's ``x'_p``; ``raw_echoes``: ``f_c = f_min + (K//2) df`` set to sarjax's.
* geometry: sarjax's antenna (x'_p, Δy_p, H + Δz_p) and scatterer (x, √(r² − (H − h)²), h)
  are given to ``raw_echoes`` as (Δy, x', H + Δz) and (y_P, x, h) (its frame: x across
  track, y along track, z up); distances are unchanged.
* pattern: ``raw_echoes`` has none, so the like-for-like workloads use an isotropic
  pattern in sarjax (``W² = 1``, a pattern module defined here) and in ``stripmap``
  (``L_a = 10⁻⁹`` m: u < 10⁻⁸, sinc²(u) = 1.0 in float64, every pulse inside the beam);
  the NumPy oracle gets ``antenna_length = 10⁻¹²`` m (sinc²(u) = 1.0 likewise).
  A "native pattern" workload runs both with their sinc² patterns; these are different
  models (FastSAR: u from sin θ = Δx/R and zero beyond the first null; sarjax: u from
  tan φ = Δx/r, all side lobes), so it is timing context, not like-for-like.
* range gate: FastSAR ``|Δτ| ≤ T_p/2``, sarjax ``|Δr| < cτ/4``: they differ only where a
  sample lies exactly on a pulse edge; the targets are placed off the sample grid.
* echo edges: ``raw_echoes``' band-limited fractional delay of the sampled replica is
  not the sampled analytic (hard-edged) chirp: it rings at the pulse ends (Gibbs), so its
  error against the exact model sits at the pulse edges; the point workloads also report
  the error on samples > 8 samples from every pulse edge.

Workloads (same inputs to both, same process, same run):

* ``points``: 3 targets, airborne preset raw grid 1941 × 830, straight track, isotropic;
* ``points-large``: 9 targets, 4096 × 2048, straight track, isotropic;
* ``points-sinc2``: as ``points`` with each simulator's own sinc² pattern (not like-for-like);
* ``scatterers-1k`` / ``scatterers-8k``: 1024 / 8192 random scatterers (complex Gaussian
  γ, heights 0–30 m) on a deviated track (smooth Δy, Δz of 0.5 m rms), isotropic;
  512 / 128 pulses × 830 samples (FastSAR's ``raw_echoes`` costs ~60 µs per scatterer and
  pulse, so the pulse count is reduced; the cost per pulse does not depend on it).

Accuracy: against the float64 NumPy oracle ``tests/reference_numpy.py`` on a few pulses
(a single-pulse call per pulse), and against sarjax ``time_domain`` in complex128 (itself
checked against the oracle here) on the whole grid: NMSE (dB), max |error| / max |ref|,
rms and max phase error where |ref| ≥ 0.1 × its rms. Timing: sarjax compile = ahead-of-time
lower + compile of the jitted entry point (and "first − steady"); steady = min wall over
repeats, with the process CPU time of that repeat; FastSAR is NumPy (no compilation).
Speed ratio = FastSAR steady / sarjax steady, by wall and by CPU time, against the
like-for-like FastSAR simulator of the workload.

Usage::

    python benchmarks/bench_peer.py            # full run (~15-25 min on 2 cores), writes RESULTS.md
    python benchmarks/bench_peer.py --quick    # smoke test (reduced sizes), writes nothing
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

import sarjax as sj
from sarjax.antenna import AbstractPattern

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(REPO / "tests"))
sys.path.insert(0, str(HERE))

import reference_numpy  # noqa: E402  (the float64 oracle of the test suite)
from _common import (  # noqa: E402
    aot_compile_time,
    load_average,
    machine,
    replace_section,
    steady,
    timed,
)

C = 299792458.0
MARKER = "bench_peer"
ISOTROPIC_LA = 1e-9  # FastSAR antenna length giving sinc²(u) = 1.0 (u < 1e-8)
ORACLE_LA = 1e-12  # oracle antenna length giving sinc²(u) = 1.0
ORACLE_BUDGET = 6e6  # (scatterer × sample) evaluations of the NumPy oracle per workload
EDGE_GUARD = 8  # samples from a pulse edge left out of the "interior" error
ROW_BUDGET_S = 40.0  # steady repeats per row: as many as fit (at least 1, at most max)
FLOAT64_TIE_DB = -150.0  # both below this: equal accuracy (float64 rounding)


class IsotropicPattern(AbstractPattern):
    """W²(u) = 1: no azimuth pattern (FastSAR's ``raw_echoes`` has none)."""

    def __call__(self, u):
        return jnp.ones_like(u)


# ---- workloads ----------------------------------------------------------------------


@dataclass
class Workload:
    name: str
    description: str
    pattern: str  # "isotropic" or "sinc2"
    num_pulses: int
    num_range: int
    azimuth: np.ndarray
    slant_range: np.ndarray
    height: np.ndarray
    reflectivity: np.ndarray
    horizontal: np.ndarray | None = None  # Δy per pulse [m]; None: straight track
    vertical: np.ndarray | None = None
    like_for_like: bool = True
    fastsar: tuple = ()  # FastSAR simulators: "stripmap", "raw_echoes", "fx_nufft"
    max_repeats: int = 5
    radar: object = field(default=None)

    @property
    def num_scatterers(self):
        return self.azimuth.size

    @property
    def straight(self):
        return self.horizontal is None


def pulse_positions(num_pulses, radar):
    """x'_p [m] as sarjax's Acquisition (centre 0)."""
    return (np.arange(num_pulses) - (num_pulses - 1) / 2) * float(radar.velocity / radar.prf)


def make_workloads(quick):
    iso = sj.presets.airborne_xband(pattern=IsotropicPattern())
    sinc = sj.presets.airborne_xband()
    # off the sample grid (no sample exactly on a pulse edge, see module doc)
    pts = dict(azimuth=np.array([0.11, -0.07, 0.19]),
               slant_range=np.array([4840.37, 5140.71, 5439.83]),
               height=np.zeros(3), reflectivity=np.ones(3, complex))
    n_x, n_r = (256, 830) if quick else (1941, 830)
    out = [
        Workload("points", f"3 point targets, {n_x} × {n_r}, straight track, isotropic",
                 "isotropic", n_x, n_r, **pts, fastsar=("stripmap", "raw_echoes"), radar=iso),
    ]
    n_x2, n_r2 = (512, 1024) if quick else (4096, 2048)
    ax = np.array([-60.13, 0.11, 59.87])
    rg = np.array([4600.31, 6400.63, 9100.94]) if not quick else np.array(
        [4600.31, 5200.63, 5800.94])
    grid_x, grid_r = np.meshgrid(ax, rg, indexing="ij")
    out.append(Workload(
        "points-large", f"9 point targets, {n_x2} × {n_r2}, straight track, isotropic",
        "isotropic", n_x2, n_r2, grid_x.ravel(), grid_r.ravel(), np.zeros(9),
        np.exp(1j * np.linspace(0, 2, 9)), fastsar=("stripmap", "raw_echoes"), radar=iso))
    out.append(Workload(
        "points-sinc2", f"3 point targets, {n_x} × {n_r}, straight track, each its own sinc² "
        "pattern", "sinc2", n_x, n_r, **pts, like_for_like=False, fastsar=("stripmap",),
        radar=sinc))
    for n_scat, n_pulses in ((1024, 512), (8192, 128)):
        if quick:
            n_scat, n_pulses = n_scat // 8, 32
        out.append(scatterer_workload(iso, n_scat, n_pulses, 830))
    return out


def scatterer_workload(radar, n_scat, num_pulses, num_range):
    """Random scatterers in the range window on a track with 0.5 m rms deviations."""
    rng = np.random.default_rng(n_scat)
    near = float(radar.near_range)
    far = near + (num_range - 1) * float(radar.range_spacing)
    x = rng.uniform(-100.0, 100.0, n_scat)
    r = rng.uniform(near + 150.0, far - 150.0, n_scat)  # partly cut echoes at both ends
    h = rng.uniform(0.0, 30.0, n_scat)
    gamma = (rng.normal(size=n_scat) + 1j * rng.normal(size=n_scat)) / np.sqrt(2)
    xp = pulse_positions(num_pulses, radar)
    dev = dict(rms=0.5, max_cycles=3, aperture=160.0)
    name = f"scatterers-{n_scat // 1024}k" if n_scat % 1024 == 0 else f"scatterers-{n_scat}"
    return Workload(
        name, f"{n_scat} scatterers, {num_pulses} × {num_range}, deviated track "
        "(Δy, Δz 0.5 m rms), isotropic", "isotropic", num_pulses, num_range, x, r, h, gamma,
        horizontal=np.asarray(sj.smooth_deviation(xp, key=1, **dev)),
        vertical=np.asarray(sj.smooth_deviation(xp, key=2, **dev)),
        fastsar=("raw_echoes", "fx_nufft"), max_repeats=3, radar=radar)


# ---- the two simulators ---------------------------------------------------------------


def sarjax_call(w, method, dtype, options):
    scene = sj.PointTargets(azimuth=w.azimuth, range=w.slant_range,
                            reflectivity=w.reflectivity, height=w.height)
    motion = None if w.straight else sj.Motion(horizontal=w.horizontal, vertical=w.vertical)

    def call():
        return sj.simulate(w.radar, scene, motion, method=method, num_pulses=w.num_pulses,
                           num_range=w.num_range, dtype=dtype, **options).data

    return call


def radar_numbers(radar):
    return {k: float(getattr(radar, k)) for k in (
        "carrier_frequency", "bandwidth", "chirp_duration", "sampling_rate", "prf", "velocity",
        "height", "antenna_length", "near_range", "wavelength")}


def fastsar_stripmap(w):
    from fastsar import stripmap

    q = radar_numbers(w.radar)
    params = stripmap.StripParams(
        fc=q["carrier_frequency"], B=-q["bandwidth"], Tp=q["chirp_duration"],
        fs=q["sampling_rate"], prf=q["prf"], v=q["velocity"], r0=float(w.radar.reference_range),
        La=ISOTROPIC_LA if w.pattern == "isotropic" else q["antenna_length"], squint=0.0,
        na=w.num_pulses, nr=w.num_range, t0=2 * q["near_range"] / C,
        eta0=-(w.num_pulses - 1) / 2 / q["prf"], pattern="sinc2", extent=1.0)
    targets = np.stack([w.azimuth, w.slant_range], axis=1)
    amp = np.asarray(w.reflectivity, complex)
    return lambda: stripmap.simulate(params, targets, amp)


def fastsar_geometry(w):
    """(antenna [N_x, 3], scatterers [N, 3]) in FastSAR's frame (x across, y along, z up)."""
    q = radar_numbers(w.radar)
    xp = pulse_positions(w.num_pulses, w.radar)
    dy = np.zeros_like(xp) if w.straight else w.horizontal
    dz = np.zeros_like(xp) if w.straight else w.vertical
    ant = np.stack([dy, xp, q["height"] + dz], axis=1)
    ground = np.sqrt(w.slant_range**2 - (q["height"] - w.height) ** 2)
    pos = np.stack([ground, w.azimuth, w.height], axis=1)
    return ant, pos


def fastsar_raw_echoes(w):
    from fastsar import sim

    q = radar_numbers(w.radar)
    fs, tau, bw = q["sampling_rate"], q["chirp_duration"], q["bandwidth"]
    n_chirp = int(round(tau * fs))
    u = (np.arange(n_chirp) - 0.5 * (n_chirp - 1)) / fs
    replica = np.exp(-1j * np.pi * (bw / tau) * u**2)
    ant, pos = fastsar_geometry(w)
    # f_c = f_min + (K // 2) df: K = 2, df = 1 Hz
    col = sim.Collect(fmin=q["carrier_frequency"] - 1.0, df=1.0, K=2, ant=ant, res=1.0)
    r_near = q["near_range"] + C * (n_chirp - 1) / (4 * fs)  # chirp centre at the delay
    amp = np.asarray(w.reflectivity, complex)
    return lambda: sim.raw_echoes(col, pos, amp, fs, replica, r_near, w.num_range, 0.0, 0.0)


def fastsar_fx(w, eps=1e-6, nthreads=1):
    """FastSAR's NUFFT phase history: K = N_r frequencies over the sampled band, origin at
    the scene centre. Returns (call, brute(pulses)).

    ``nthreads=1``: with finufft's default (all cores, OpenMP) each small per-pulse
    transform took ~100× longer on the shared 2-core machine (85 ms vs 0.8 ms for 1024
    points, 830 modes), so one thread is FastSAR's fastest setting here."""
    from fastsar import sim

    q = radar_numbers(w.radar)
    ant, pos = fastsar_geometry(w)
    centre = np.array([np.sqrt(float(w.radar.reference_range) ** 2 - q["height"] ** 2), 0, 0])
    k = w.num_range
    df = q["sampling_rate"] / k
    fmin = q["carrier_frequency"] - (k // 2) * df
    col = sim.Collect(fmin=fmin, df=df, K=k, ant=ant - centre, res=1.0)
    amp = np.asarray(w.reflectivity, complex)

    def brute(pulses):
        sub = sim.Collect(fmin=fmin, df=df, K=k, ant=col.ant[pulses], res=1.0)
        return sim.simulate_brute(sub, pos - centre, amp)

    return (lambda: sim.simulate(col, pos - centre, amp, eps=eps, nthreads=nthreads)), brute


# ---- reference and accuracy -----------------------------------------------------------


def oracle_pulses(w):
    n = int(max(1, min(5, ORACLE_BUDGET // (w.num_scatterers * w.num_range))))
    return np.unique(np.linspace(0, w.num_pulses - 1, n + 2)[1:-1].round().astype(int))


def oracle(w, pulses):
    """The float64 NumPy oracle at the given pulses (one single-pulse call each)."""
    q = radar_numbers(w.radar)
    xp = pulse_positions(w.num_pulses, w.radar)
    rows = []
    for p in pulses:
        data, _, _ = reference_numpy.simulate_reference(
            carrier_frequency=q["carrier_frequency"], bandwidth=q["bandwidth"],
            chirp_duration=q["chirp_duration"], sampling_rate=q["sampling_rate"],
            prf=q["prf"], velocity=q["velocity"], height=q["height"],
            antenna_length=ORACLE_LA if w.pattern == "isotropic" else q["antenna_length"],
            target_azimuth=w.azimuth, target_range=w.slant_range,
            target_reflectivity=w.reflectivity, target_height=w.height,
            horizontal=None if w.straight else w.horizontal[p:p + 1],
            vertical=None if w.straight else w.vertical[p:p + 1],
            num_pulses=1, num_range=w.num_range, near_range=q["near_range"],
            azimuth_center=xp[p])
        rows.append(data[0])
    return np.stack(rows)


def accuracy(out, ref, mask=None):
    """NMSE [dB], max |e| / max |ref|, rms and max phase error [rad] (|ref| ≥ 0.1 rms)."""
    out = np.asarray(out, np.complex128)
    ref = np.asarray(ref, np.complex128)
    if mask is not None:
        out, ref = out[mask], ref[mask]
    err = out - ref
    power = np.sum(np.abs(ref) ** 2)
    nmse = 10 * np.log10(max(np.sum(np.abs(err) ** 2) / power, 1e-300))
    nonzero = np.abs(ref) > 0
    level = 0.1 * np.sqrt(np.mean(np.abs(ref[nonzero]) ** 2))
    bright = np.abs(ref) >= level
    phase = np.angle(out[bright] * np.conj(ref[bright]))
    return dict(nmse=nmse, max_rel=float(np.max(np.abs(err)) / np.max(np.abs(ref))),
                phase_rms=float(np.sqrt(np.mean(phase**2))),
                phase_max=float(np.max(np.abs(phase))))


def interior_mask(w):
    """Samples farther than EDGE_GUARD samples from every pulse edge (straight track)."""
    q = radar_numbers(w.radar)
    xp = pulse_positions(w.num_pulses, w.radar)
    dr = C / (2 * q["sampling_rate"])
    half = C * q["chirp_duration"] / 4
    k = np.arange(w.num_range)
    mask = np.ones((w.num_pulses, w.num_range), bool)
    for x, r in zip(w.azimuth, w.slant_range, strict=True):
        rng = np.sqrt(r * r + (xp - x) ** 2)
        for edge in (rng - half, rng + half):
            pos = (edge - q["near_range"]) / dr
            mask &= np.abs(k[None, :] - pos[:, None]) > EDGE_GUARD
    return mask


# ---- timing ---------------------------------------------------------------------------


def measure(fn, max_repeats, sarjax_call_for_aot=None):
    """First call, then steady repeats (as many as fit ROW_BUDGET_S, ≥ 1, ≤ max_repeats)."""
    aot = None
    if sarjax_call_for_aot is not None:
        aot = aot_compile_time(sarjax_call_for_aot)
        jax.clear_caches()
    first, _, out = timed(fn)
    repeats = int(max(1, min(max_repeats, ROW_BUDGET_S // max(first, 1e-3))))
    s = steady(fn, repeats)
    return dict(first=first, steady=s.min, cpu=s.cpu, repeats=repeats,
                spread=s.max / s.min,
                compile=None if aot is None else aot[0] + aot[1]), np.asarray(out)


def sarjax_methods():
    methods = [("time_domain", "complex128", {}), ("time_domain", "complex64", {})]
    if "time_domain_nufft" in sj.simulators.method_names():
        methods += [
            ("time_domain_nufft", "complex128", {}),
            ("time_domain_nufft", "complex64", {}),
            ("time_domain_nufft", "complex128", {"range_bands": 8, "tolerance": 1e-6}),
        ]
    return methods


DTYPES = {"complex128": jnp.complex128, "complex64": jnp.complex64}


def run_workload(w):
    print(f"\n== {w.name}: {w.description}", flush=True)
    rows = []
    pulses = oracle_pulses(w)
    t0 = time.perf_counter()
    oracle_rows = oracle(w, pulses)
    print(f"  oracle at pulses {[int(p) for p in pulses]}: {time.perf_counter() - t0:.1f} s",
          flush=True)
    interior = interior_mask(w) if w.straight else None
    reference = None
    for method, dtype_name, options in sarjax_methods():
        call = sarjax_call(w, method, DTYPES[dtype_name], options)
        timing, out = measure(call, w.max_repeats, sarjax_call_for_aot=call)
        label = "sarjax " + method + "".join(f", {k}={v}" for k, v in options.items())
        row = dict(tool="sarjax", label=label, dtype=dtype_name, **timing,
                   acc_oracle=accuracy(out[pulses], oracle_rows))
        if reference is None:  # the first row: time_domain complex128, the reference
            reference = out
            row["reference"] = True
        else:
            row["acc_ref"] = accuracy(out, reference)
            if interior is not None:
                row["acc_interior"] = accuracy(out, reference, interior)
        rows.append(row)
        report(row)
    for name in w.fastsar:
        brute = None
        if name == "stripmap":
            if not w.straight:
                continue
            fn, label, dtype_name = fastsar_stripmap(w), "FastSAR stripmap.simulate", "complex128"
        elif name == "raw_echoes":
            if w.pattern != "isotropic":
                continue
            fn, label, dtype_name = fastsar_raw_echoes(w), "FastSAR sim.raw_echoes", "complex64"
        else:
            try:
                import finufft  # noqa: F401
            except ImportError:
                print("  (finufft not installed: FastSAR sim.simulate skipped)")
                continue
            fn, brute = fastsar_fx(w)
            label = "FastSAR sim.simulate (finufft, eps=1e-6, 1 thread): FX phase history"
            dtype_name = "complex128"
        timing, out = measure(fn, w.max_repeats)
        row = dict(tool="FastSAR", label=label, dtype=dtype_name, **timing, product=name)
        if brute is None:
            row["acc_oracle"] = accuracy(out[pulses], oracle_rows)
            row["acc_ref"] = accuracy(out, reference)
            if interior is not None:
                row["acc_interior"] = accuracy(out, reference, interior)
        else:
            row["acc_own"] = accuracy(out[pulses], brute(pulses))
        rows.append(row)
        report(row)
    compare(w, rows)
    return dict(workload=w, rows=rows, oracle_pulses=[int(p) for p in pulses])


def goal_nmse(row):
    """The accuracy used for the goal: the worse of vs-oracle and vs-reference."""
    values = [row["acc_oracle"]["nmse"]] if "acc_oracle" in row else []
    if "acc_ref" in row:
        values.append(row["acc_ref"]["nmse"])
    return max(values) if values else None


def compare(w, rows):
    """Speed ratio and goal verdict of every sarjax row against the like-for-like FastSAR
    row (the first FastSAR raw-echo simulator of the workload)."""
    base = next((r for r in rows if r["tool"] == "FastSAR" and "acc_ref" in r), None)
    for r in rows:
        if r["tool"] != "sarjax" or base is None:
            continue
        r["speedup"] = base["steady"] / r["steady"]
        r["speedup_cpu"] = base["cpu"] / r["cpu"]
        mine, theirs = goal_nmse(r), goal_nmse(base)
        tie = mine <= FLOAT64_TIE_DB and theirs <= FLOAT64_TIE_DB
        r["as_accurate"] = tie or mine <= theirs + 0.5
        r["goal"] = r["as_accurate"] and r["speedup"] >= 2.0
    if base is not None:
        base["baseline"] = True


def report(r):
    acc = r.get("acc_ref") or r.get("acc_oracle") or r.get("acc_own")
    comp = "" if r.get("compile") is None else f"compile {r['compile']:6.2f} s  "
    print(f"  {r['label'][:58]:58s} {r['dtype']:10s} {comp}first {r['first']:8.3f} s  "
          f"steady {r['steady']:8.4f} s (cpu {r['cpu']:8.3f} s, ×{r['repeats']})  "
          f"NMSE {acc['nmse']:7.1f} dB", flush=True)


# ---- report -------------------------------------------------------------------------


def fmt(v, spec, none="–"):
    return none if v is None else format(v, spec)


def fmt_nmse(acc):
    if acc is None:
        return "–"
    return "≤ −300" if acc["nmse"] <= -300 else f"{acc['nmse']:.1f}"


def fmt_phase(acc):
    if acc is None:
        return "–"
    return f"{acc['phase_rms']:.1e} / {acc['phase_max']:.1e}"


def table(result):
    w = result["workload"]
    head = ("| simulator | dtype | compile [s] | first − steady [s] | steady [s] | CPU [s] "
            "| repeats | FastSAR / sarjax (wall, CPU) | NMSE vs oracle [dB] "
            "| NMSE vs time_domain c128 [dB] | max \\|e\\| / max \\|ref\\| "
            "| phase err rms / max [rad] |")
    straight = w.straight
    if straight:
        head += " NMSE > 8 samples from pulse edges [dB] |"
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in result["rows"]:
        if "speedup" in r:
            ratio = f"{r['speedup']:.2f}×, {r['speedup_cpu']:.2f}×"
        elif r.get("baseline"):
            ratio = "baseline (1×)"
        else:
            ratio = "–"
        ref_acc = r.get("acc_ref")
        own = r.get("acc_own")
        nmse_ref = "(reference)" if r.get("reference") else fmt_nmse(ref_acc)
        nmse_oracle = fmt_nmse(r.get("acc_oracle"))
        if own is not None:
            nmse_oracle = f"{fmt_nmse(own)} (vs its own float64 direct sum)"
            nmse_ref = "n/a (other product)"
        acc = ref_acc or r.get("acc_oracle") or own
        label = r["label"] + (" ✱" if r.get("goal") else "")
        line = (f"| {label} | {r['dtype']} | {fmt(r.get('compile'), '.2f')} "
                f"| {r['first'] - r['steady']:.2f} | {r['steady']:.4f} | {r['cpu']:.3f} "
                f"| {r['repeats']} | {ratio} | {nmse_oracle} | {nmse_ref} "
                f"| {acc['max_rel']:.1e} | {fmt_phase(acc)} |")
        if straight:
            line += f" {fmt_nmse(r.get('acc_interior'))} |"
        lines.append(line)
    return "\n".join(lines)


def verdict(result):
    w = result["workload"]
    sar = [r for r in result["rows"] if "speedup" in r]
    base = next((r for r in result["rows"] if r.get("baseline")), None)
    if base is None or not sar:
        return "no like-for-like FastSAR row"
    met = [r for r in sar if r["goal"]]
    kind = "like-for-like" if w.like_for_like else "NOT like-for-like (different pattern models)"
    text = f"{kind}; FastSAR baseline {base['label']} ({base['steady']:.3f} s, NMSE " \
           f"{fmt_nmse(base.get('acc_ref'))} dB vs time_domain c128). "
    if met:
        best = max(met, key=lambda r: r["speedup"])
        text += ("Goal (≥ 2× faster at equal or better accuracy) **met** by: "
                 + ", ".join(f"{r['label']} {r['dtype']} ({r['speedup']:.1f}×)" for r in met)
                 + f"; best {best['speedup']:.1f}× wall, {best['speedup_cpu']:.1f}× CPU.")
    else:
        text += "Goal **not met** by any sarjax configuration."
    fx = next((r for r in result["rows"] if r.get("product") == "fx_nufft"), None)
    nufft = [r for r in sar if "nufft" in r["label"]]
    if fx is not None and nufft:
        fastest = min(nufft, key=lambda r: r["steady"])
        text += (f" FastSAR's finufft phase history (a different, smaller product: no chirp, "
                 f"no gate) takes {fx['steady']:.3f} s; {fastest['label']} "
                 f"{fastest['dtype']} computes the raw echoes in {fastest['steady']:.3f} s "
                 f"({fx['steady'] / fastest['steady']:.1f}× less).")
    slower = [r for r in sar if not r["as_accurate"]]
    if slower:
        text += (" Less accurate than the FastSAR baseline: "
                 + ", ".join(f"{r['label']} {r['dtype']}" for r in slower) + ".")
    return text


NOTES = """\
Conventions and alignment (details in the script's docstring):

- Chirp: FastSAR's `stripmap` is an up-chirp `exp(+jπK_r Δτ²)`, sarjax's is
  `exp(−j b Δr²)` (the same magnitude, b Δr² = π|K_r| Δτ²); the carrier `exp(−j4πR/λ)`
  has the same sign in both. Matched by `B = −Δf` in `stripmap` (only K_r enters) and by
  the replica `exp(−jπ(Δf/τ)u²)` given to `raw_echoes`. No conjugation or constant phase
  is needed after that (max phase error of `stripmap` ≈ 1e-9 rad).
- Chirp position: `raw_echoes` starts its L = round(τ f_s) = 250-sample replica at the echo
  delay; its window start is moved by c(L − 1)/(4 f_s) so the chirp is centred on the delay
  as in sarjax. Sampling: t₀ = 2r'₀/c, same f_s; pulses η₀ = −(N_x − 1)/(2 PRF).
- Track: sarjax's antenna (x', Δy, H + Δz) and scatterer (x, y_P, h) are FastSAR's
  (Δy, x', H + Δz) and (y_P, x, h); `raw_echoes` maps them to ECF at lat = lon = 0
  (an axis permutation plus 6378137 m; distances kept to ~1e-9 m).
- Pattern: `raw_echoes` has none, so the like-for-like workloads are isotropic in all
  (sarjax: W² = 1 pattern module; `stripmap`: L_a = 1e-9 m, sinc²(u) = 1.0; oracle:
  L = 1e-12 m). `points-sinc2` runs each with its own sinc²: FastSAR's
  u = L_a sin θ/λ (sin θ = Δx/R) cut at the first null (|u| ≤ 1, pulses beyond skipped),
  sarjax's u = L Δx/(λ r) with all side lobes; its NMSE column measures that model
  difference, not an error. Only timing is comparable there.
- Gate: FastSAR `|Δτ| ≤ T_p/2`, sarjax `|Δr| < cτ/4`; they differ on samples lying exactly
  on a pulse edge (the preset's broadside target at r₀ = 5140 m does: pulse 970,
  sample 290), so the targets here are off the sample grid.
- `raw_echoes` shifts the sampled replica by a band-limited fractional delay (4L-point
  DFT): the result rings at the pulse ends instead of being the sampled hard-edged chirp,
  so its error against the exact model is concentrated at the pulse edges (see the
  "> 8 samples from pulse edges" column); it also returns complex64 and loops over
  (pulse, scatterer) in Python.
- `sim.simulate` (FastSAR's finufft path) computes a different product — the dechirped,
  motion-compensated phase history on N_r frequencies (no chirp, no range gate) — so it
  is timed but not counted for the goal; its accuracy is against `sim.simulate_brute`.
  It runs finufft with one thread: with finufft's default (OpenMP on all cores) each small
  per-pulse transform took ~100× longer on this shared 2-core machine.
- Reference: sarjax `time_domain` complex128 on the whole grid (its own row reports its
  agreement with the NumPy oracle); NMSE vs oracle on the listed pulses. Phase errors are
  over samples with |ref| ≥ 0.1 × rms |ref|.
- sarjax `time_domain` complex64 on many scatterers: its NMSE against complex128 (about
  −70 dB) is set by pulse-edge gate decisions taken in float32 range coordinates: a
  sample within ~1e-4 m of a pulse edge (float32 spacing at a few km) falls inside the
  pulse in one precision and outside in the other, a full-amplitude error on that one
  sample (e.g. scatterers-1k, pulse 162, sample 319: edge margin 1.2e-5 m). Away from such
  samples it agrees to about −92 dB (the oracle pulses happen to hold none).
- ✱: sarjax configuration meeting the goal (≥ 2× FastSAR's wall time, NMSE ≤ FastSAR's
  + 0.5 dB, or both ≤ −150 dB: float64 rounding). NMSE for the goal is the worse of the
  oracle and time_domain-c128 figures.
"""


def section(info, results, load, argv):
    parts = [f"""## sarjax side by side with FastSAR (`{Path(__file__).name}`)

Generated by `python benchmarks/{Path(__file__).name}{(' ' + ' '.join(argv)) if argv else ''}`
(see [README.md](README.md)); re-running it replaces only this section.

### Machine

- CPU: {info['cpu']}; {info['cores']} logical cores ({info['usable_cores']} usable by this process)
- JAX {info['jax']} (jaxlib {info['jaxlib']}), backend `{info['backend']}` \
({info['devices']}); NumPy {info['numpy']}; Python {info['python']}
- FastSAR {info['fastsar']} (its simulators are NumPy; its JAX/C++/CUDA code is image \
formation only); finufft {info['finufft']}
- sarjax commit {info['commit']}
- Date: {info['date']}
- Load average (1 min) at start / end of the run: {load[0]:.2f} / {load[1]:.2f}. The machine is
  shared with other work: steady = min wall time over repeats, and the CPU-time ratio is the
  less load-sensitive figure (sarjax/XLA uses both cores, FastSAR's NumPy loops mostly one).
"""]
    for res in results:
        w = res["workload"]
        parts.append(f"""### `{w.name}`: {w.description}

Oracle pulses: {res['oracle_pulses']}.

{table(res)}

{verdict(res)}
""")
    parts.append("### Notes\n\n" + NOTES)
    return "\n".join(parts)


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true", help="reduced sizes (smoke test)")
    p.add_argument("--no-write", action="store_true", help="do not write RESULTS.md")
    p.add_argument("--write", action="store_true", help="write RESULTS.md even with --quick")
    p.add_argument("--only", nargs="*", default=None, help="workload names to run")
    p.add_argument("--output", type=Path, default=HERE / "RESULTS.md")
    args = p.parse_args(argv)
    write = not args.no_write and (not args.quick or args.write) and not args.only

    import fastsar

    try:
        import finufft
        finufft_version = finufft.__version__
    except ImportError:
        finufft_version = "not installed"
    load_start = load_average()
    info = machine() | dict(fastsar=fastsar.__version__, finufft=finufft_version)
    print(f"{info['cpu']}, {info['cores']} cores, JAX {info['jax']} ({info['backend']}), "
          f"FastSAR {info['fastsar']}, load {load_start:.2f}; sarjax methods: "
          + ", ".join(sorted({m for m, _, _ in sarjax_methods()})))
    results = []
    for w in make_workloads(args.quick):
        if args.only and w.name not in args.only:
            continue
        results.append(run_workload(w))
    load = (load_start, load_average())
    text = section(info, results, load, argv)
    print()
    for res in results:
        print(f"### {res['workload'].name}\n{table(res)}\n{verdict(res)}\n")
    if write:
        replace_section(MARKER, text, args.output)


if __name__ == "__main__":
    main()
