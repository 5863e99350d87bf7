"""Inverse module: motion fits through the exact model, and the Cramér–Rao bound.

The CI problem is the airborne set with a 2 m antenna (footprint X = λr/L ≈ 80 m: half the
pulses) and a 2.5 µs chirp (125 range samples), on a 400 × 400 raw grid, so that one fit
takes seconds; the three calibration scatterers are those of the acceptance scene (x = 0;
r = 4840, 5140, 5440 m) and the jitter the seed one (δ_m = λ/(20L), T_b = T_s/10).
The full-size acceptance runs are in ``benchmarks/bench_inverse.py`` and the slow tests.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import sarjax as sj
from sarjax import inverse as inv
from sarjax.inverse import _engine, _setup

NUM_PULSES = 400
NUM_RANGE = 360
NEAR_RANGE = 4620.0


def _radar(**overrides):
    return sj.presets.airborne_xband(antenna_length=2.0, chirp_duration=2.5e-6,
                                     num_pulses=NUM_PULSES, num_range=NUM_RANGE,
                                     near_range=NEAR_RANGE, **overrides)


SCENE = dict(azimuth=[0.0, 0.0, 0.0], range=[4840.0, 5140.0, 5440.0])


def _truth(radar, rms, key):
    rng = np.random.default_rng(key)
    n = radar.num_pulses
    x = (np.arange(n) - (n - 1) / 2) * float(radar.azimuth_spacing)
    footprint = float(radar.footprint(radar.reference_range))
    dy = sj.smooth_deviation(x, key=rng, rms=rms, max_cycles=5, aperture=footprint)
    dz = sj.smooth_deviation(x, key=rng, rms=rms, max_cycles=5, aperture=footprint)
    jitter = (float(radar.wavelength / radar.antenna_length) / 20,
              float(radar.integration_time()) / 10, float(rng.uniform(-np.pi, np.pi)))
    pointing = np.asarray(sj.sinusoidal_pointing(x, amplitude=jitter[0], period=jitter[1],
                                                 velocity=float(radar.velocity),
                                                 phase=jitter[2]))
    return sj.Motion(horizontal=dy, vertical=dz, pointing=pointing), jitter, rng


def _noisy(radar, scene, motion, rng, snr_db=0.0):
    clean = sj.simulate(radar, scene, motion)
    data = np.asarray(clean.data)
    noise_power = np.mean(np.abs(data) ** 2) / 10 ** (snr_db / 10)
    noise = np.sqrt(noise_power / 2) * (rng.normal(size=data.shape)
                                        + 1j * rng.normal(size=data.shape))
    return sj.RawData(data=data + noise, azimuth=clean.azimuth, range=clean.range), noise_power


def _rms(v):
    return float(np.sqrt(np.mean(np.asarray(v) ** 2)))


def test_cold_start_recovers_motion_at_0db():
    """Acceptance case A (raw SNR 0 dB), one seed, from zero initial motion and no jitter
    guess, on 1025 of the preset's 1941 pulses (× 830; the full grid is the slow
    acceptance run): the acceptance bounds (LOS ≤ λ/20; Δy, Δz ≤ max(λ/10, 1.5 CRB);
    jitter 5 %, 1 %, 0.1 rad) and consistency with the CRB."""
    radar = sj.presets.airborne_xband(num_pulses=1025)
    scene = sj.PointTargets(**SCENE)
    truth, jitter, rng = _truth(radar, 0.02, key=3)
    raw, noise_power = _noisy(radar, scene, truth, rng)
    result = sj.fit_motion(radar, scene, raw)
    assert result.converged
    names = [s.name for s in result.history]
    assert names == ["envelope", "phase", "jitter", "joint"]
    # the cost falls stage by stage; the noise power estimated from the final residual is
    # the true one (its relative std is ≈ 1/√(M/2) ≈ 0.5 %)
    costs = [s.cost for s in result.history]
    assert costs[0] > costs[1] > costs[3]
    assert np.isclose(result.noise_power, noise_power, rtol=0.03)
    lam = float(radar.wavelength)
    ey, ez, ep = inv.align(result.motion, truth, result)
    s0, c0 = result.reference_direction
    bound = sj.crb(radar, scene, noise_power=noise_power, motion=truth, jitter=jitter)
    los = _rms(-s0 * ey + c0 * ez)
    assert los <= lam / 20, los
    assert _rms(ey) <= max(lam / 10, 1.5 * bound.rms["horizontal"])
    assert _rms(ez) <= max(lam / 10, 1.5 * bound.rms["vertical"])
    # well inside: the estimator reaches its bound (3× leaves room for one noise draw)
    assert los <= 3 * bound.rms["line_of_sight"], (los, bound.rms)
    amplitude, period, phase = jitter
    assert abs(result.jitter["amplitude"] / amplitude - 1) < 0.05
    assert abs(result.jitter["period"] / period - 1) < 0.01
    assert abs(np.angle(np.exp(1j * (result.jitter["phase"] - phase)))) < 0.1
    # the fit's own error bars agree with the bound (same Fisher information up to the
    # compression window's 1 % energy loss and the estimated noise)
    std = result.profile_std()
    assert np.isclose(_rms(std["line_of_sight"]), bound.rms["line_of_sight"], rtol=0.2)
    assert np.isclose(result.jitter["period_std"], bound.jitter["period_std"], rtol=0.2)
    fixed = {f.component for f in result.fixed}
    assert fixed == {"horizontal mean", "vertical mean"}
    # the residual is the raw data minus the fitted model: noise only on the fitted pulses
    fitted = np.asarray(result.residual.data)[result.support]
    assert np.isclose(np.mean(np.abs(fitted) ** 2), noise_power, rtol=0.03)


@pytest.fixture(scope="module")
def exact_problem():
    """Noise-free data from a motion the default model represents exactly."""
    radar = _radar()
    scene = sj.PointTargets(**SCENE, reflectivity=[1.0, 0.8 - 0.3j, -0.5 + 0.7j])
    x = (np.arange(NUM_PULSES) - (NUM_PULSES - 1) / 2) * float(radar.azimuth_spacing)
    p0, p1 = _setup.pulse_span(radar, scene, x)
    model, _, _ = _setup.bind_model(radar, scene, _setup.default_model(radar), x[p0:p1],
                                    reflectivity_known=False)
    rng = np.random.default_rng(11)
    params = {
        "horizontal": jnp.asarray(rng.normal(size=model.horizontal.num_params()) * 0.02),
        "vertical": jnp.asarray(rng.normal(size=model.vertical.num_params()) * 0.02),
        "pointing": model.pointing.from_physical(1.5e-3, 0.16, 0.7),
    }
    m3 = np.asarray(_setup.motion3(model, params, jnp.asarray(x), None))
    motion = sj.Motion(horizontal=m3[:, 0], vertical=m3[:, 1], pointing=m3[:, 2])
    raw = sj.simulate(radar, scene, motion)
    return radar, scene, raw, params


@pytest.mark.parametrize("solver", ["optimistix", "jaxopt"])
def test_noise_free_warm_start_recovers_parameters(exact_problem, solver):
    """Start 1 mm / 1 % off the truth: the parameters come back to 1e-6 relative, and the
    residual vanishes (both solver backends)."""
    radar, scene, raw, params = exact_problem
    rng = np.random.default_rng(5)
    start = {
        "horizontal": params["horizontal"] + 1e-3 * rng.normal(size=params["horizontal"].shape),
        "vertical": params["vertical"] + 1e-3 * rng.normal(size=params["vertical"].shape),
        "pointing": params["pointing"] * jnp.asarray([1.01, 0.99, 1.002]),
    }
    result = sj.fit_motion(radar, scene, raw, initial=start, solver=solver, rtol=1e-12,
                           atol=1e-12, max_steps=40)
    assert result.solver == solver
    assert [s.name for s in result.history] == ["initial", "joint"]
    for name in ("horizontal", "vertical", "pointing"):
        got, want = np.asarray(result.params[name]), np.asarray(params[name])
        rel = np.linalg.norm(got - want) / np.linalg.norm(want)
        assert rel < 1e-6, (name, rel)
    gamma = np.asarray(scene.reflectivity)
    assert np.allclose(result.params["reflectivity"], gamma, rtol=0, atol=1e-6)
    peak = np.max(np.abs(np.asarray(raw.data)))
    assert np.max(np.abs(np.asarray(result.residual.data))) < 1e-5 * peak


def test_crb_fisher_matches_dense_jacobian():
    """The structured Fisher matrix (per-pulse Jacobian × parametrisation chain rule) equals
    (2/σ²) Re(JᴴJ) with J from a dense forward-mode Jacobian through ``sj.simulate``."""
    radar = _radar()
    scene = sj.PointTargets(**SCENE, reflectivity=[1.0, 0.5j, -0.7])
    model = sj.MotionModel(horizontal=sj.BSpline(5), vertical=sj.Fourier(4),
                           pointing=sj.SinusoidalJitter(velocity=radar.velocity))
    truth, jitter, _ = _truth(radar, 0.01, key=2)
    noise_power = 0.3
    bound = sj.crb(radar, scene, noise_power=noise_power, motion=truth, jitter=jitter,
                   model=model, reflectivity="known")
    x = (np.arange(NUM_PULSES) - (NUM_PULSES - 1) / 2) * float(radar.azimuth_spacing)
    support = bound.support
    flat, unravel = jax.flatten_util.ravel_pytree(
        {k: jnp.asarray(v) for k, v in bound.params.items()})

    def data(f):
        m3 = _setup.motion3(bound.model, unravel(f), jnp.asarray(x[support]), None)
        motion = sj.Motion(horizontal=m3[:, 0], vertical=m3[:, 1], pointing=m3[:, 2])
        out = sj.simulate(radar, scene, motion, num_pulses=int(support.sum()),
                          azimuth_center=float(x[support].mean())).data
        return jnp.concatenate([out.real.ravel(), out.imag.ravel()])

    jac = np.asarray(jax.jacfwd(data)(flat))
    dense = 2 / noise_power * jac.T @ jac
    assert np.allclose(bound.fisher, dense, rtol=1e-8, atol=1e-8 * np.abs(dense).max())


def test_simulator_is_pulse_local():
    """The structured Jacobian rests on pulse locality: a random per-pulse tangent's JVP
    equals the per-pulse Jacobian contracted with it (to rounding)."""
    radar = _radar()
    scene = sj.PointTargets(**SCENE)
    x = (np.arange(64) - 31.5) * float(radar.azimuth_spacing)
    problem = _setup.make_problem(radar, scene, x, NEAR_RANGE, NUM_RANGE, half_width=4)
    motion3 = jnp.asarray(np.random.default_rng(0).normal(size=(64, 3)) * [0.01, 0.01, 1e-3])
    assert _engine.check_pulse_local(problem, motion3) < 1e-12


def _check_single_look_angle(radar, truth, raw, model=None):
    scene = sj.PointTargets(azimuth=[0.0], range=[5140.0])
    result = sj.fit_motion(radar, scene, raw, model=model, max_steps=30)
    components = [f.component for f in result.fixed]
    assert "cross-line-of-sight deviation" in components
    assert "line-of-sight mean" in components
    assert result.line_of_sight is not None
    ey, ez, _ = inv.align(result.motion, truth, result)
    s, c = result.line_of_sight
    assert _rms(-s * ey + c * ez) < float(radar.wavelength) / 20


def test_single_look_angle_fits_line_of_sight_only():
    """One scatterer (one look angle): Δy and Δz cannot be separated; the fit says so,
    fits the line-of-sight profile, and recovers it (CI size: 2 m antenna, 2.5 µs chirp,
    400 × 360 grid, 20 B-splines for the halved footprint, raw SNR 10 dB as in the
    notebook; the preset grid at 0 dB is the slow test below)."""
    radar = _radar()
    scene = sj.PointTargets(azimuth=[0.0], range=[5140.0])
    truth, _, rng = _truth(radar, 0.01, key=8)
    raw, _ = _noisy(radar, scene, truth, rng, snr_db=10.0)
    lam = float(radar.wavelength)
    model = sj.MotionModel(horizontal=sj.BSpline(20), vertical=sj.BSpline(20),
                           pointing=sj.SinusoidalJitter(velocity=radar.velocity,
                                                        amplitude_scale=lam / 40))
    _check_single_look_angle(radar, truth, raw, model)


@pytest.mark.slow
def test_single_look_angle_full_size():
    """As above on the preset grid at raw SNR 0 dB."""
    radar = sj.presets.airborne_xband()
    scene = sj.PointTargets(azimuth=[0.0], range=[5140.0])
    truth, _, rng = _truth(radar, 0.01, key=8)
    raw, _ = _noisy(radar, scene, truth, rng)
    _check_single_look_angle(radar, truth, raw)


def test_parametrisations():
    """B-spline partition of unity and gauge; Fourier and sinusoid round trips."""
    x = np.linspace(-50.0, 70.0, 121)
    spline = sj.BSpline(8).bind(x)
    design = np.asarray(spline.design(jnp.asarray(x)))
    assert np.allclose(design.sum(axis=1), 1.0)  # partition of unity on the span
    gauged = sj.BSpline(8).bind(x, zero_mean=True)
    assert gauged.num_params() == 7
    profile = gauged(jnp.asarray(np.random.default_rng(0).normal(size=7)), jnp.asarray(x))
    assert abs(float(jnp.mean(profile))) < 1e-12
    smooth = np.cos(np.pi * (x - x[0]) / np.ptp(x) * 3)  # three basis terms exactly
    fourier = sj.Fourier(8).bind(x)
    fitted = fourier(fourier.project(smooth, x), jnp.asarray(x))
    assert np.max(np.abs(np.asarray(fitted) - smooth)) < 1e-12
    jitter = sj.SinusoidalJitter(velocity=100.0).bind(x)
    theta = jitter.from_physical(1.5e-3, 0.16, -2.0)
    amplitude, period, phase = (float(v) for v in jitter.physical(theta))
    assert np.allclose([amplitude, period, phase], [1.5e-3, 0.16, -2.0], rtol=1e-12)
    reference = sj.sinusoidal_pointing(x, amplitude=1.5e-3, period=0.16, velocity=100.0,
                                       phase=-2.0)
    assert np.allclose(jitter(theta, jnp.asarray(x)), reference, atol=1e-15)
    per_pulse = sj.PerPulse(smoothness=2.0).bind(x)
    assert per_pulse.num_params() == x.size
    line = jnp.asarray(0.3 * x + 1.0)
    assert np.allclose(per_pulse.penalty(line), 0.0, atol=1e-12)  # no curvature


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(solver="scipy"), "solver="),
        (dict(window=1), "window="),
        (dict(reflectivity="maybe"), "reflectivity="),
        (dict(noise_power=-1.0), "noise_power="),
        (dict(jitter_period_bounds=(0.5, 0.1)), "jitter_period_bounds="),
    ],
)
def test_bad_arguments(kwargs, match):
    radar = _radar()
    scene = sj.PointTargets(**SCENE)
    raw = sj.simulate(radar, scene)
    with pytest.raises(ValueError, match=match):
        sj.fit_motion(radar, scene, raw, **kwargs)


def test_bad_data_and_scene():
    radar = _radar()
    scene = sj.PointTargets(**SCENE)
    raw = sj.simulate(radar, scene)
    short = sj.RawData(data=raw.data[:, :120], azimuth=raw.azimuth, range=raw.range[:120])
    with pytest.raises(ValueError, match="range window"):
        sj.fit_motion(radar, scene, short)
    far = sj.PointTargets(azimuth=[5000.0], range=[5140.0])
    with pytest.raises(ValueError, match="main lobe|do not cover"):
        sj.fit_motion(radar, far, raw)
    with pytest.raises(ValueError, match="PointTargets"):
        sj.fit_motion(radar, "scene", raw)
    with pytest.raises(ValueError, match="non-finite"):
        bad = np.asarray(raw.data).copy()
        bad[3, 4] = np.nan
        sj.fit_motion(radar, scene, sj.RawData(data=bad, azimuth=raw.azimuth,
                                               range=raw.range))


@pytest.mark.slow
@pytest.mark.parametrize("rms, seed", [(0.02, 21), (0.5, 21), (0.5, 22)])
def test_acceptance_cases_full_size(rms, seed):
    """Acceptance cases A (2 cm) and B (0.5 m) on the preset grid at 0 dB, extra seeds (the
    20-seed runs are in benchmarks/bench_inverse.py)."""
    radar = sj.presets.airborne_xband()
    scene = sj.PointTargets(**SCENE)
    truth, jitter, rng = _truth(radar, rms, key=seed)
    raw, noise_power = _noisy(radar, scene, truth, rng)
    result = sj.fit_motion(radar, scene, raw)
    lam = float(radar.wavelength)
    ey, ez, _ = inv.align(result.motion, truth, result)
    s0, c0 = result.reference_direction
    bound = sj.crb(radar, scene, noise_power=noise_power, motion=truth, jitter=jitter)
    assert _rms(-s0 * ey + c0 * ez) <= lam / 20
    assert _rms(ey) <= max(lam / 10, 1.5 * bound.rms["horizontal"])
    assert _rms(ez) <= max(lam / 10, 1.5 * bound.rms["vertical"])
    amplitude, period, phase = jitter
    assert abs(result.jitter["amplitude"] / amplitude - 1) < 0.05
    assert abs(result.jitter["period"] / period - 1) < 0.01
    assert abs(np.angle(np.exp(1j * (result.jitter["phase"] - phase)))) < 0.1


@pytest.mark.slow
def test_cold_start_recovers_from_unwrapping_slip():
    """Case A truth of seed 0, noise draw 50022 (a Monte-Carlo draw of the benchmark): the
    envelope estimate wiggles at the aperture's start, where the echoes are weak, faster
    than the phase unwrapping can follow (> π per pulse); the phase stage then puts the
    first pulses whole wavelengths off and the joint fit stalls at its 60-step limit with χ²
    ≈ 36 % above the noise level. The fit must flag it, re-start from the rebuilt profile
    and meet the acceptance bounds at the CRB level. (Which draws slip depends on the
    cold start's rounding: of draws 50000–50053, 50019, 50022 and 50036 slip today; the
    earlier draw 50013 no longer does since the stages' helpers run as compiled programs.)"""
    radar = sj.presets.airborne_xband()
    scene = sj.PointTargets(**SCENE)
    truth, jitter, _ = _truth(radar, 0.02, key=0)
    raw, noise_power = _noisy(radar, scene, truth, np.random.default_rng(50_022))
    result = sj.fit_motion(radar, scene, raw)
    names = [s.name for s in result.history]
    assert names[:4] == ["envelope", "phase", "jitter", "joint"]
    assert any(n.startswith("recovery") for n in names), names
    assert result.converged
    # the kept fit is the lowest-χ² joint fit, at the noise level (the noise power from
    # its residual is the true one, whose relative std is ≈ 0.5 %)
    assert result.chi2 == min(2 * s.cost for s in result.history[3:])
    assert np.isclose(result.noise_power, noise_power, rtol=0.03)
    lam = float(radar.wavelength)
    ey, ez, _ = inv.align(result.motion, truth, result)
    s0, c0 = result.reference_direction
    bound = sj.crb(radar, scene, noise_power=noise_power, motion=truth, jitter=jitter)
    los = _rms(-s0 * ey + c0 * ez)
    assert los <= lam / 20
    assert los <= 3 * bound.rms["line_of_sight"], (los, bound.rms)
    assert _rms(ey) <= 3 * bound.rms["horizontal"]
    assert _rms(ez) <= 3 * bound.rms["vertical"]
    amplitude, period, phase = jitter
    assert abs(result.jitter["amplitude"] / amplitude - 1) < 0.05
    assert abs(result.jitter["period"] / period - 1) < 0.01
    assert abs(np.angle(np.exp(1j * (result.jitter["phase"] - phase)))) < 0.1


@pytest.mark.parametrize("level, flagged", [(1.0, True), (1e-9, False)])
def test_slip_stretch_flagged_only_above_the_noise(monkeypatch, level, flagged):
    """A ±8-pulse stretch with 5× the median pulse's χ² is a slip when the pulses sit at
    the noise level (χ² per pulse ≈ (M − K) / pulses); on noise-free data (the median pulse
    1e-9 of that) the same relative bump is the model's rounding and no recovery runs."""
    from sarjax.inverse import _recovery

    pulses, per_pulse_noise = 400, 102.0
    chi2 = np.full(pulses, level * per_pulse_noise)
    chi2[200:217] *= 5.0
    monkeypatch.setattr(_recovery._residual, "pulse_chi2", lambda args, y: chi2)
    fit = _recovery.JointFit(y={}, args=None, steps=3, converged=True,
                             chi2=float(chi2.sum()))
    floor = pulses * per_pulse_noise
    assert bool(_recovery.excess(fit, 8, floor).any()) is flagged
    assert _recovery.slipped(fit, floor) is flagged
