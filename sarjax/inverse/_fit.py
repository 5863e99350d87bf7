"""Fit trajectory deviations and pointing jitter to raw data of a known scene."""

from __future__ import annotations

import dataclasses
import time
import warnings

import equinox as eqx
import jax
import jax.numpy as jnp
import lineax as lx
import numpy as np
import optimistix as optx
from jax.flatten_util import ravel_pytree

from .._data import RawData
from ..motion import Motion
from . import _engine, _setup, _staging
from ._parametrisations import MotionModel, SinusoidalJitter

_SOLVERS = ("optimistix", "jaxopt")


@dataclasses.dataclass(frozen=True)
class Stage:
    """One stage of a fit.

    Attributes:
        name: ``"envelope"``, ``"phase"``, ``"jitter"``, ``"initial"``, ``"joint"`` or
            ``"recovery k"`` (a joint fit re-started after a detected unwrapping slip; the
            result is the lowest-χ² joint fit).
        seconds: wall time of the stage [s].
        cost: ½‖r‖² of the whitened residual at the stage's estimate, reflectivities at
            their least-squares values (≈ half the number of real residuals at the optimum).
        steps: solver steps (0 for closed-form stages).
        params: the motion parameters after the stage (dict of NumPy arrays).
    """

    name: str
    seconds: float
    cost: float
    steps: int
    params: dict


@dataclasses.dataclass(frozen=True)
class FitResult:
    """Result of :func:`fit_motion`.

    Attributes:
        motion: :class:`~sarjax.Motion` on every raw pulse (Δy, Δz [m], δ_az [rad]);
            outside ``support`` the profiles hold their end values.
        params: fitted parameters per component (dict of (n,) arrays, the model's own
            parametrisation), plus ``"reflectivity"`` (target,) complex.
        jitter: for :class:`SinusoidalJitter`, ``{"amplitude": δ_m [rad], "period": T_b [s],
            "phase": φ₀ [rad]}`` with ``"*_std"`` standard deviations; else None.
        covariance: (K, K) covariance of the parameters in ``parameter_names`` order
            (motion parameters, then Re/Im of the reflectivities), from the Gauss–Newton
            Fisher matrix at the solution and the noise power.
        parameter_names: (K,) ``(component, index)`` pairs.
        residual: :class:`~sarjax.RawData`: raw data minus the fitted model on the raw grid.
        noise_power: E|n|² per complex raw sample used for the covariance (given, or
            estimated from the residual as χ²/(M − K)).
        chi2: ‖r‖² of the whitened residual (with the noise power above ≈ M − K).
        num_residuals: M, real residuals in the fit.
        history: per-stage :class:`Stage` records.
        timings: seconds per stage and ``"total"``.
        fixed: :class:`Fixed` components the fit did not estimate, with the reason.
        support: (azimuth,) bool, the raw pulses whose data were fitted.
        model: the bound :class:`MotionModel`.
        line_of_sight: None, or (sin ϑ̄, cos ϑ̄) when only a line-of-sight profile was fitted.
        solver: ``"optimistix"`` or ``"jaxopt"``; ``converged``: the solver's verdict.
    """

    motion: Motion
    params: dict
    jitter: dict | None
    covariance: np.ndarray
    parameter_names: tuple
    residual: RawData
    noise_power: float
    chi2: float
    num_residuals: int
    history: tuple
    timings: dict
    fixed: tuple
    support: np.ndarray
    model: MotionModel
    line_of_sight: tuple | None
    solver: str
    converged: bool
    reference_direction: tuple

    def profile_std(self):
        """Per-pulse standard deviations on the support pulses (dict of (support,) arrays):
        ``horizontal``, ``vertical`` [m], ``pointing`` [rad] and ``line_of_sight`` [m], the
        deviation projected on the scene centre (r₀, h = 0) direction
        ``reference_direction`` = (sin ϑ₀, cos ϑ₀): δr = −Δy sin ϑ₀ + Δz cos ϑ₀."""
        x = np.asarray(self.residual.azimuth)[self.support]
        return _profile_std(self.model, self.params, x, self.line_of_sight, self.covariance,
                            self.parameter_names, self.reference_direction)


def _profile_std(model, params, x, line_of_sight, covariance, names, los_direction):
    motion_params = {n: jnp.asarray(params[n]) for n in model.components}
    flat, unravel = ravel_pytree(motion_params)
    x = jnp.asarray(x)
    keep = [i for i, (name, _) in enumerate(names) if name != "reflectivity"]
    los = None if line_of_sight is None else jnp.asarray(line_of_sight)

    def profiles(f):
        return _setup.motion3(model, unravel(f), x, los)

    d = np.asarray(jax.jacfwd(profiles)(flat))  # (azimuth, 3, K_motion)
    cov = covariance[np.ix_(keep, keep)]
    out = {}
    for i, name in enumerate(("horizontal", "vertical", "pointing")):
        out[name] = np.sqrt(np.maximum(np.einsum("pk,kl,pl->p", d[:, i], cov, d[:, i]), 0))
    if los_direction is not None:
        s, c = los_direction
        dl = -s * d[:, 0] + c * d[:, 1]
        out["line_of_sight"] = np.sqrt(np.maximum(np.einsum("pk,kl,pl->p", dl, cov, dl), 0))
    return out


# ---- the residual with a structured forward-mode derivative --------------------------


@jax.custom_jvp
def _core(problem, data, inv_sigma, m3, gamma_ri):
    """Whitened residual (azimuth, sample, 2) of the transformed data; its JVP (with respect
    to ``m3`` and ``gamma_ri`` only) uses the per-pulse Jacobian: one simulation and three
    tangents, whatever the number of parameters."""
    signals = _engine.target_signals(problem, m3)
    gamma = gamma_ri[:, 0] + 1j * gamma_ri[:, 1]
    r = data - jnp.einsum("t,tps->ps", gamma, signals)
    return jnp.stack([r.real, r.imag], axis=-1) * inv_sigma


@_core.defjvp
def _core_jvp(primals, tangents):
    problem, data, inv_sigma, m3, gamma_ri = primals
    *_, dm, dg = tangents
    signals, dsignals = _engine.signals_and_jacobian(problem, m3)
    gamma = gamma_ri[:, 0] + 1j * gamma_ri[:, 1]
    jac = jnp.einsum("t,tpsk->psk", gamma, dsignals)  # primal-only
    r = data - jnp.einsum("t,tps->ps", gamma, signals)
    dgamma = dg[:, 0] + 1j * dg[:, 1]
    dr = -(jnp.einsum("psk,pk->ps", jac, dm) + jnp.einsum("t,tps->ps", dgamma, signals))
    out = jnp.stack([r.real, r.imag], axis=-1) * inv_sigma
    dout = jnp.stack([dr.real, dr.imag], axis=-1) * inv_sigma
    return out, dout


class _Args(eqx.Module):
    problem: _engine.Problem
    data: jnp.ndarray
    model: MotionModel
    line_of_sight: jnp.ndarray | None
    scales: dict
    inv_sigma: jnp.ndarray
    reflectivity: jnp.ndarray | None  # (target, 2) when known


def _residuals(y, args: _Args):
    params = {n: y[n] * args.scales[n] for n in args.model.components}
    m3 = _setup.motion3(args.model, params, args.problem.azimuth, args.line_of_sight)
    if args.reflectivity is None:
        gamma_ri = y["reflectivity"] * args.scales["reflectivity"]
    else:
        gamma_ri = args.reflectivity
    return _core(args.problem, args.data, args.inv_sigma, m3, gamma_ri), \
        args.model.penalty(params)


@eqx.filter_jit
def _solve_optimistix(y0, args, rtol, atol, max_steps):
    # normal equations by Cholesky: K × K instead of a QR of the (M + K) × K system
    solver = optx.LevenbergMarquardt(rtol=rtol, atol=atol,
                                     linear_solver=lx.Normal(lx.Cholesky()))
    sol = optx.least_squares(_residuals, solver, y0, args, max_steps=max_steps, throw=False)
    return sol.value, sol.stats["num_steps"], sol.result == optx.RESULTS.successful


def _import_jaxopt():
    try:
        with warnings.catch_warnings():
            # jaxopt announces on import that it is no longer maintained
            warnings.simplefilter("ignore", DeprecationWarning)
            import jaxopt
    except ImportError:
        raise ValueError(
            "solver='jaxopt' needs the optional dependency: pip install 'sarjax[jaxopt]'"
        ) from None
    return jaxopt


@eqx.filter_jit
def _solve_jaxopt(y0, args, rtol, atol, max_steps):
    jaxopt = _import_jaxopt()
    flat0, unravel = ravel_pytree(y0)

    def flat_residuals(flat):
        return ravel_pytree(_residuals(unravel(flat), args))[0]

    solver = jaxopt.LevenbergMarquardt(
        flat_residuals, maxiter=max_steps, tol=atol, xtol=rtol, gtol=atol,
        materialize_jac=True, jit=True,
    )
    out = solver.run(flat0)
    return unravel(out.params), out.state.iter_num, out.state.iter_num < max_steps


@eqx.filter_jit
def _jacobian(y, args):
    flat, unravel = ravel_pytree(y)
    return jax.jacfwd(lambda f: ravel_pytree(_residuals(unravel(f), args))[0])(flat)


@eqx.filter_jit
def _signals(problem, m3):
    return _engine.target_signals(problem, m3)


@eqx.filter_jit
def _compress(problem, raw):
    return _engine.transform(problem, raw)


def _ls_reflectivity(signals, data):
    """Least-squares complex reflectivities (target,) of data ≈ Σ γ_t s_t."""
    a = np.asarray(signals).reshape(signals.shape[0], -1).T
    gamma, *_ = np.linalg.lstsq(a, np.asarray(data).reshape(-1), rcond=None)
    return gamma


@eqx.filter_jit
def _cost_jit(args, y):
    res = _residuals(y, args)
    return 0.5 * sum(jnp.sum(r**2) for r in res)


def _cost(args, y):
    return float(_cost_jit(args, y))


@eqx.filter_jit
def _chi2_jit(args, y):
    return jnp.sum(_residuals(y, args)[0] ** 2)


# A slipped cold start is flagged after the joint fit by: the solver stopping short; χ²
# above this multiple of its floor M − K (a good fit sits below it: the noise power from
# the median of the compressed data is biased high by the echoes, χ² ≈ 0.87 (M − K) on the
# acceptance scene); or a stretch of pulses whose mean χ² exceeds the median pulse's by
# _SLIP_PULSE_CHI2. The recovery retries with these phase-gradient smoothing half-lengths
# [pulses], rebuilding the pulses with excess residual or not.
_SLIP_CHI2 = 1.03
_SLIP_PULSE_CHI2 = 1.2
_RECOVERY = ((8, True), (4, True), (16, False))


@eqx.filter_jit
def _pulse_chi2(args, y):
    """(azimuth,) χ² of each pulse's whitened residual (2 × samples real residuals)."""
    return jnp.sum(_residuals(y, args)[0] ** 2, axis=(1, 2))


# ---- the public entry point --------------------------------------------------------------


def fit_motion(
    radar,
    scene,
    raw: RawData,
    *,
    model: MotionModel | None = None,
    initial: Motion | dict | None = None,
    noise_power=None,
    reflectivity: str = "estimate",
    solver: str = "optimistix",
    window: int = 8,
    max_deviation: float = 5.0,
    jitter_period_bounds=None,
    rtol: float = 1e-8,
    atol: float = 1e-8,
    max_steps: int = 60,
    min_snr: float = 10.0,
) -> FitResult:
    """Estimate per-pulse trajectory deviations and pointing error from raw data of a known
    calibration scene, by Levenberg–Marquardt through the exact time-domain model.

    The data model is physics.md §3 (seed 000 eq. 19–20):
    ``h(x', r') = Σ_t γ_t · exp[−j4πR_t/λ − jb(r' − R_t)²] · rect · W²((x' − x_t − δx)/X_t)``
    with ``R_t`` the exact range from the displaced antenna ``(x', Δy, H + Δz)`` and
    ``δx = (r_t + δr_xr) δ_az``. The residual is formed on the range-compressed data: a
    unitary phase-only matched filter (white noise stays white with the same variance),
    keeping ``2·window + 1`` samples about each scatterer's nominal range in every pulse
    (≈ 99 % of the echo energy for ``window = 8``) of the pulses inside some scatterer's
    main lobe. Real and imaginary parts are separate real residuals, whitened by the noise.

    Stages (each in ``history``): ``envelope`` and ``phase`` (see
    :mod:`sarjax.inverse._staging`) and ``jitter`` (weighted periodogram of the pattern
    modulation) when ``initial`` is None; ``joint``: Levenberg–Marquardt on all motion
    parameters and the complex reflectivities (optimistix by default, float64; the
    Jacobian is forward-mode, one simulation plus three tangents per linearisation because
    the model is pulse-local). After a cold start, a slipped phase unwrapping is detected
    (the solver stops short, χ² ends above 1.03 (M − K), or some ±8-pulse stretch has a
    mean χ² per pulse 1.2 times the median pulse's) and recovered: the profile is refitted
    on the pulses at the noise level, every scatterer's phase is re-unwrapped about it and
    the joint fit re-started (``recovery k`` stages, at most three); the result is the
    lowest-χ² joint fit.

    Unobservable components are fixed and listed in ``result.fixed``: with unknown
    reflectivities the mean Δy and Δz over the illuminated pulses (a constant deviation
    only changes each scatterer's phase, absorbed by γ, and shifts it by a fraction of a
    range cell: it trades with the scene position); with a single look angle the cross
    line-of-sight component (only ℓ = −Δy sin ϑ + Δz cos ϑ is fitted). Compare an estimate
    with a reference after removing the same components (:func:`align`).

    Args:
        radar: the :class:`~sarjax.Radar` (broadside).
        scene: :class:`~sarjax.PointTargets`, the calibration scatterers (positions known;
            reflectivities estimated unless ``reflectivity="known"``).
        raw: :class:`~sarjax.RawData` (azimuth, range) with uniform axes of the radar's
            spacings; every echo must lie inside its range window.
        model: :class:`MotionModel` (default: 36 cubic B-splines for Δy and Δz,
            :class:`SinusoidalJitter` for δ_az); None components are held at zero.
        initial: None (cold start, staged), a :class:`~sarjax.Motion` (its profiles are
            projected on the model; a SinusoidalJitter then needs ``initial`` as a dict),
            or a dict of model parameters (warm start: only the joint stage runs).
        noise_power: E|n|² per complex raw sample; None = estimate it.
        reflectivity: ``"estimate"`` (default) or ``"known"`` (use ``scene.reflectivity``).
        solver: ``"optimistix"`` (default) or ``"jaxopt"`` (optional dependency).
        window: half-width of the kept compressed samples per scatterer (≥ 2).
        max_deviation: bound on |R − R_n| searched by the envelope stage [m].
        jitter_period_bounds: (T_min, T_max) [s] searched by the periodogram (default
            4/PRF … span/(2v)).
        rtol, atol: Levenberg–Marquardt tolerances on the normalised parameters.
        max_steps: Levenberg–Marquardt step limit.
        min_snr: per-pulse compressed SNR (power ratio) below which a pulse is not used by
            the envelope and phase stages.

    Returns:
        :class:`FitResult`.

    Raises:
        ValueError: on a bad value, naming it.
    """
    t_start = time.perf_counter()
    timings = {}
    history = []
    if reflectivity not in ("estimate", "known"):
        raise ValueError(f"reflectivity={reflectivity!r} must be 'estimate' or 'known'")
    if solver not in _SOLVERS:
        raise ValueError(f"solver={solver!r} must be one of {_SOLVERS}")
    if not isinstance(window, int) or window < 2:
        raise ValueError(f"window={window!r} must be an integer >= 2")
    if not isinstance(raw, RawData):
        raise ValueError(f"raw={type(raw).__name__} must be sarjax.RawData")
    if raw.data.ndim != 2 or raw.data.shape != (raw.azimuth.shape[0], raw.range.shape[0]):
        raise ValueError(f"raw.data has shape {raw.data.shape}, inconsistent with its axes")
    if not np.all(np.isfinite(np.asarray(raw.data))):
        raise ValueError("raw.data has non-finite samples")
    if noise_power is not None and not (np.isfinite(noise_power) and noise_power > 0):
        raise ValueError(f"noise_power={noise_power!r} must be finite and > 0")
    if jitter_period_bounds is not None and not (
        len(jitter_period_bounds) == 2 and 0 < jitter_period_bounds[0] < jitter_period_bounds[1]
    ):
        raise ValueError(f"jitter_period_bounds={jitter_period_bounds!r} must be "
                         "(T_min, T_max) with 0 < T_min < T_max [s]")
    _setup.check_inputs(radar, scene, raw.azimuth, raw.range)
    model = _setup.default_model(radar) if model is None else model
    if not isinstance(model, MotionModel) or not model.components:
        raise ValueError("model must be a MotionModel with at least one fitted component")

    # ---- grid, transform and gauge ----------------------------------------------------
    t0 = time.perf_counter()
    raw_x = np.asarray(raw.azimuth, float)
    p0, p1 = _setup.pulse_span(radar, scene, raw_x)
    x = raw_x[p0:p1]
    r0, r1 = _setup.range_span(radar, scene, raw.range, x, max_deviation)
    near = float(raw.range[r0])
    num_range = r1 - r0
    problem = _setup.make_problem(radar, scene, x, near, num_range, half_width=window)
    data_crop = jnp.asarray(raw.data[p0:p1, r0:r1], dtype=jnp.complex128)
    data_win = _compress(problem, data_crop)
    known = reflectivity == "known"
    bound, fixed, los = _setup.bind_model(radar, scene, model, x, reflectivity_known=known)
    los_arr = None if los is None else jnp.asarray(los)
    scales = bound.scale(radar)
    gamma_known = None
    if known:
        g = np.asarray(scene.reflectivity)
        gamma_known = jnp.asarray(np.stack([g.real, g.imag], axis=-1))
    compressed_only = eqx.tree_at(lambda p: p.window_index, problem, None,
                                  is_leaf=lambda v: v is None)
    compressed = _compress(compressed_only, data_crop)
    sigma0_sq = float(np.median(np.abs(np.asarray(compressed)) ** 2) / np.log(2))
    if noise_power is not None:
        sigma0_sq = float(noise_power)
    inv_sigma = jnp.asarray(np.sqrt(2.0 / sigma0_sq))
    timings["setup"] = time.perf_counter() - t0

    def make_args(reflectivity_ri):
        return _Args(problem, data_win, bound, los_arr, scales, inv_sigma, reflectivity_ri)

    def ls_gamma(params):
        m3 = _setup.motion3(bound, params, problem.azimuth, los_arr)
        if known:
            return np.asarray(scene.reflectivity)
        return _ls_reflectivity(_signals(problem, m3), data_win)

    def record(name, seconds, params, steps=0):
        gamma = ls_gamma(params)
        y = {n: params[n] / scales[n] for n in bound.components}
        args = make_args(gamma_known)
        if not known:
            scales_g = jnp.asarray(float(np.max(np.abs(gamma))) or 1.0)
            args = eqx.tree_at(lambda a: a.scales, args, {**scales, "reflectivity": scales_g})
            y["reflectivity"] = jnp.asarray(np.stack([gamma.real, gamma.imag], -1) / scales_g)
        history.append(Stage(name, seconds, _cost(args, y), int(steps),
                             {n: np.asarray(params[n]) for n in bound.components}))
        timings[name] = seconds
        return gamma

    # ---- initial estimate -------------------------------------------------------------
    if initial is None:
        params, rephase = _cold_start(radar, scene, bound, los, problem, compressed, x,
                                      near, sigma0_sq, max_deviation, jitter_period_bounds,
                                      min_snr, record)
    else:
        params = _initial_params(bound, initial, x, los)
        rephase = None
        t0 = time.perf_counter()
        record("initial", time.perf_counter() - t0, params)

    # ---- joint Levenberg–Marquardt --------------------------------------------------------
    solve = _solve_optimistix if solver == "optimistix" else _solve_jaxopt
    n_data = int(np.prod(data_win.shape)) * 2
    num_params = sum(int(np.size(params[n])) for n in bound.components) + \
        (0 if known else 2 * int(np.size(scene.range)))
    floor = max(n_data - num_params, 1)

    def joint(start):
        gamma = ls_gamma(start)
        y0 = {n: jnp.asarray(start[n]) / scales[n] for n in bound.components}
        all_scales = dict(scales)
        if not known:
            scale_g = float(np.max(np.abs(gamma))) or 1.0
            all_scales["reflectivity"] = jnp.asarray(scale_g)
            y0["reflectivity"] = jnp.asarray(np.stack([gamma.real, gamma.imag], -1) / scale_g)
        args = _Args(problem, data_win, bound, los_arr, all_scales, inv_sigma, gamma_known)
        y, steps, converged = solve(y0, args, rtol, atol, max_steps)
        y = jax.block_until_ready(y)
        return dict(y=y, args=args, all_scales=all_scales, steps=int(steps),
                    converged=bool(converged), chi2=float(_chi2_jit(args, y)))

    t0 = time.perf_counter()
    best = joint(params)
    t_joint = time.perf_counter() - t0
    history.append(Stage("joint", t_joint, 0.5 * best["chi2"], best["steps"],
                         {n: np.asarray(best["y"][n] * best["all_scales"][n])
                          for n in bound.components}))
    timings["joint"] = t_joint
    attempts = 0
    # a phase-unwrapping slip (typically at an aperture edge, where the echoes are weak and
    # the coarse estimate's slope error can exceed π per pulse) leaves the joint fit in a
    # local minimum, whole multiples of λ/2 of line of sight away on part of the aperture:
    # χ² stays well above the noise floor (≈ M − K real residuals) or the solver stops
    # short. Recovery: locate the pulses with excess residual, refit the profile on the
    # others (the smooth model carries it over the slipped stretch), re-unwrap every
    # scatterer's phase about that line of sight (the residual phase is then small and slow
    # where it was slipped), refit jointly from there; keep the lowest χ².
    def excess(fit, half_window):
        """(azimuth,) bool: pulses whose χ², averaged over ±half_window pulses, exceeds
        the typical pulse's (the median: a slip covers a minority of the pulses) by 20 %
        (≈ 6 standard deviations of that average for 2 × 3 × 17 real residuals a pulse)."""
        per_pulse = np.asarray(_pulse_chi2(fit["args"], fit["y"]))
        kernel = np.ones(2 * half_window + 1) / (2 * half_window + 1)
        smooth = np.convolve(per_pulse, kernel, mode="same")
        norm = np.convolve(np.ones_like(per_pulse), kernel, mode="same")
        return smooth / norm > _SLIP_PULSE_CHI2 * np.median(per_pulse)

    def slipped(fit):
        return (not fit["converged"] or fit["chi2"] > _SLIP_CHI2 * floor
                or bool(excess(fit, 8).any()))

    for half_window, reset in _RECOVERY:
        if rephase is None or not slipped(best):
            break
        t0 = time.perf_counter()
        fitted = {n: best["y"][n] * best["all_scales"][n] for n in bound.components}
        keep = None
        if reset:
            # refit the profile on the pulses at the noise level, less a margin of
            # half_window pulses about the others: the slipped stretch is rebuilt
            bad = excess(best, half_window)
            bad = np.convolve(bad.astype(float), np.ones(2 * half_window + 1), "same") > 0
            keep = ~bad
            if keep.all() or not keep.any():
                keep = None
        start = dict(params)
        start.update(rephase(_setup.motion3(bound, fitted, problem.azimuth, los_arr),
                             half_window, keep))
        trial = joint(start)
        seconds = time.perf_counter() - t0
        attempts += 1
        history.append(Stage(f"recovery {attempts}", seconds, 0.5 * trial["chi2"],
                             trial["steps"], {n: np.asarray(trial["y"][n]
                                                            * trial["all_scales"][n])
                                              for n in bound.components}))
        timings[f"recovery {attempts}"] = seconds
        if trial["chi2"] < best["chi2"]:
            best = trial
    y, args, all_scales = best["y"], best["args"], best["all_scales"]
    converged = best["converged"]
    params = {n: y[n] * all_scales[n] for n in bound.components}

    # ---- covariance, noise, residual ------------------------------------------------------
    t0 = time.perf_counter()
    jac = np.asarray(_jacobian(y, args))
    chi2 = best["chi2"]
    num_params = jac.shape[1]
    normal = jac.T @ jac
    cov_scaled = np.linalg.pinv(normal, hermitian=True)
    if noise_power is None:
        factor = chi2 / max(n_data - num_params, 1)
        noise = sigma0_sq * factor
    else:
        factor = 1.0
        noise = float(noise_power)
    flat_scale = np.asarray(ravel_pytree(
        {k: jnp.broadcast_to(all_scales[k], jnp.shape(y[k])) for k in y})[0])
    covariance = cov_scaled * factor * np.outer(flat_scale, flat_scale)
    names = tuple((k, i) for k in sorted(y) for i in range(int(np.size(y[k]))))
    if known:
        gamma_fit = np.asarray(scene.reflectivity)
    else:
        g = np.asarray(y["reflectivity"] * all_scales["reflectivity"])
        gamma_fit = g[:, 0] + 1j * g[:, 1]
    m3_raw = np.asarray(_setup.motion3(bound, params, jnp.asarray(raw_x), los_arr))
    motion = Motion(horizontal=m3_raw[:, 0], vertical=m3_raw[:, 1], pointing=m3_raw[:, 2])
    model_raw = _full_model(radar, scene, gamma_fit, motion, raw)
    residual = RawData(data=raw.data - model_raw, azimuth=raw.azimuth, range=raw.range,
                       method="residual")
    jitter = None
    if isinstance(bound.pointing, SinusoidalJitter):
        jitter = _jitter_summary(bound.pointing, params["pointing"], covariance, names)
    support = np.zeros(raw_x.size, bool)
    support[p0:p1] = True
    timings["covariance"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - t_start
    out_params = {n: np.asarray(params[n]) for n in bound.components}
    out_params["reflectivity"] = gamma_fit
    result = FitResult(
        motion=motion, params=out_params, jitter=jitter, covariance=covariance,
        parameter_names=names, residual=residual, noise_power=float(noise), chi2=chi2,
        num_residuals=n_data, history=tuple(history), timings=timings, fixed=tuple(fixed),
        support=support, model=bound, line_of_sight=los, solver=solver,
        converged=bool(converged), reference_direction=_scene_centre_direction(radar),
    )
    return result


def _scene_centre_direction(radar):
    """(sin ϑ₀, cos ϑ₀) of the reference range r₀ on the ground (h = 0)."""
    c = float(radar.height) / float(radar.reference_range)
    return (float(np.sqrt(1 - c * c)), c)


@eqx.filter_jit
def _full_model_jit(simulator, radar, scene, motion, acquisition):
    return simulator(radar, scene, motion, acquisition, jnp.complex128)


def _full_model(radar, scene, gamma, motion, raw):
    from .._data import Acquisition

    x = np.asarray(raw.azimuth, float)
    acquisition = Acquisition(
        num_pulses=int(x.size), num_range=int(raw.range.shape[0]),
        near_range=float(raw.range[0]), azimuth_center=float(0.5 * (x[0] + x[-1])),
    )
    scene = eqx.tree_at(lambda s: s.reflectivity, scene, jnp.asarray(gamma, complex))
    from ..simulators import TimeDomain

    return np.asarray(_full_model_jit(TimeDomain(), radar, scene, motion, acquisition))


def _jitter_summary(jitter, params, covariance, names):
    idx = [i for i, (k, _) in enumerate(names) if k == "pointing"]
    cov = covariance[np.ix_(idx, idx)]
    theta = jnp.asarray(params)
    values = jitter.physical(theta)
    jac = np.asarray(jax.jacfwd(lambda t: jnp.stack(jitter.physical(t)))(theta))
    var = np.einsum("ik,kl,il->i", jac, cov, jac)
    std = np.sqrt(np.maximum(var, 0))
    keys = ("amplitude", "period", "phase")
    out = {k: float(v) for k, v in zip(keys, values, strict=True)}
    out.update({f"{k}_std": float(s) for k, s in zip(keys, std, strict=True)})
    return out


def _initial_params(model, initial, x, los):
    if isinstance(initial, dict):
        missing = [n for n in model.components if n not in initial]
        if missing:
            raise ValueError(f"initial parameters miss {missing}")
        return {n: jnp.asarray(initial[n], dtype=float) for n in model.components}
    if not isinstance(initial, Motion):
        raise ValueError(f"initial={type(initial).__name__} must be None, a Motion or a dict")
    n = x.size
    dy, dz, pointing = (np.asarray(v) for v in initial.resolve(n)) if all(
        v is None or np.shape(v)[-1] == n for v in (initial.horizontal, initial.vertical,
                                                    initial.pointing)
    ) else (None, None, None)
    if dy is None:
        raise ValueError(f"initial Motion must have one value per fitted pulse ({n})")
    return project_profiles(model, dy, dz, pointing, x, los)


def project_profiles(model, dy, dz, pointing, x, los, jitter=None):
    """Model parameters of given (support,) profiles: least-squares projections of the
    linear components; a :class:`SinusoidalJitter` from ``jitter = (δ_m, T_b, φ₀)``."""
    params = {}
    if model.horizontal is not None:
        if los is not None:
            s, c = los
            params["horizontal"] = model.horizontal.project(-s * dy + c * dz, x)
        else:
            params["horizontal"] = model.horizontal.project(dy, x)
    if model.vertical is not None:
        params["vertical"] = model.vertical.project(dz, x)
    if model.pointing is not None:
        if isinstance(model.pointing, SinusoidalJitter):
            if jitter is None:
                raise ValueError("SinusoidalJitter needs jitter=(amplitude, period, phase) or "
                                 "initial parameters as a dict")
            params["pointing"] = model.pointing.from_physical(*jitter)
        else:
            params["pointing"] = model.pointing.project(pointing, x)
    return params


def align(estimate: Motion, reference: Motion, result: FitResult):
    """Error of ``estimate`` against ``reference`` on the support pulses, with the components
    ``result`` fixed removed (the means of Δy and Δz over the support when the
    reflectivities were estimated).

    Returns:
        (Δy, Δz, δ_az) errors, each (support,) [m, m, rad].
    """
    n = result.support.size
    est = [np.asarray(v)[result.support] for v in estimate.resolve(n)]
    ref = [np.asarray(v)[result.support] for v in reference.resolve(n)]
    err = [e - r for e, r in zip(est, ref, strict=True)]
    if any(f.component.endswith("mean") for f in result.fixed):
        err[0] = err[0] - err[0].mean()
        err[1] = err[1] - err[1].mean()
    return tuple(err)


# ---- cold start ---------------------------------------------------------------------------


def _cold_start(radar, scene, model, los, problem, compressed, x, near, sigma_sq,
                max_deviation, period_bounds, min_snr, record):
    dr = float(radar.range_spacing)
    k0 = float(radar.wavenumber)
    up = _staging.UPSAMPLE
    xs = np.asarray(scene.azimuth)[None, :]
    rs = np.asarray(scene.range)[None, :]
    along = x[:, None] - xs
    nominal = np.sqrt(rs**2 + along**2)  # R_n (azimuth, target)
    angles = _setup.look_angles(radar, scene)
    los_rows = np.stack([-np.sin(angles), np.cos(angles)], axis=-1)  # (target, 2)
    params = {}

    # ---- envelope -------------------------------------------------------------------
    t0 = time.perf_counter()
    lines = _staging.upsample_lines(compressed)
    gain_noise = sigma_sq  # the unitary filter keeps the noise power per sample
    search = int(np.ceil(max_deviation / dr * up)) + up // 2
    pos, amp = _staging.envelope_peaks(lines, (nominal - near) / dr * up, search)
    valid = amp**2 > min_snr * gain_noise
    if valid.sum() < 8:
        raise ValueError(
            f"fewer than 8 pulses have a compressed SNR above min_snr={min_snr}: the data "
            "are too noisy for a cold start"
        )
    peak_range = near + pos / up * dr
    los_env = np.sqrt(np.maximum(peak_range**2 - along**2, 0)) - rs
    has_dev = model.horizontal is not None
    if has_dev:
        design, kh = _staging.linear_design(model, x, los)
        coef, const = _staging.fit_los(design, los_rows, los_env, amp**2 * valid,
                                       per_target_constant=True)
        params.update(_split(model, coef, kh, los))
        pred = np.einsum("tk,pkj,j->pt", los_rows, design, coef) + const[None, :]
    else:
        pred = np.zeros_like(los_env)
    params.update(_zero_rest(model, params, radar, x))
    record("envelope", time.perf_counter() - t0, params)

    # ---- phase ------------------------------------------------------------------------
    t0 = time.perf_counter()
    wavelength = float(radar.wavelength)

    def phase_stage(pred, half_window=8):
        """Unwrapped-phase line-of-sight fit from the prediction ``pred`` (azimuth, target)
        [m]: returns (deviation parameters, prediction, compressed amplitudes, valid)."""
        out = {}
        weights = np.zeros(pred.shape)
        phase_based = False
        for _ in range(8 if has_dev else 1):
            r_pred = np.sqrt((rs + pred) ** 2 + along**2)
            z = _staging.sample_lines(lines, (r_pred - near) / dr * up)
            amp = np.abs(z)
            valid = amp**2 > min_snr * gain_noise
            if not has_dev:
                break
            residual = z * np.exp(1j * k0 * r_pred)
            fine = np.zeros(residual.shape)
            for t in range(residual.shape[1]):
                unwrapped, mask = _staging.unwrap_from_peak(residual[:, t], amp[:, t],
                                                            valid[:, t], half_window)
                fine[:, t] = unwrapped
                weights[:, t] = amp[:, t] ** 2 * mask
            r_fine = r_pred - fine / k0
            los_fine = np.sqrt(np.maximum(r_fine**2 - along**2, 0)) - rs
            if phase_based:
                # robust: pulses a slip put ≥ λ/8 off the previous (phase-based) prediction
                # do not pull the fit, unless that would drop most of a scatterer's pulses
                misfit = los_fine - pred
                misfit -= np.median(misfit, axis=0)[None, :]
                keep = np.abs(misfit) < wavelength / 8
                enough = keep.sum(axis=0) >= 0.5 * np.maximum((weights > 0).sum(axis=0), 1)
                weights = weights * np.where(enough[None, :], keep, True)
            phase_based = True
            coef, const = _staging.fit_los(design, los_rows, los_fine, weights,
                                           per_target_constant=True)
            out.update(_split(model, coef, kh, los))
            new_pred = np.einsum("tk,pkj,j->pt", los_rows, design, coef) + const[None, :]
            change = np.max(np.abs(new_pred - pred - np.median(new_pred - pred, axis=0)))
            pred = new_pred
            if change < wavelength / 1000:
                break
        return out, pred, amp, valid

    dev_params, pred, amp, valid = phase_stage(pred)
    params.update(dev_params)
    record("phase", time.perf_counter() - t0, params)

    # ---- jitter -----------------------------------------------------------------------
    if model.pointing is not None:
        t0 = time.perf_counter()
        footprint = np.asarray(radar.footprint(scene.range))[None, :]
        u = along / footprint
        pattern = np.asarray(jax.vmap(radar.pattern)(jnp.asarray(u.ravel()))).reshape(u.shape)
        slope = np.asarray(jax.vmap(jax.grad(radar.pattern))(jnp.asarray(u.ravel())))
        slope = slope.reshape(u.shape)
        w = valid.astype(float)
        gain = (amp * pattern * w).sum(0) / np.maximum((pattern**2 * w).sum(0), 1e-300)
        observed = amp / gain[None, :] - pattern
        sensitivity = -slope * rs / footprint  # ∂W²/∂δ_az
        info_t = gain[None, :] ** 2 * sensitivity**2 * w
        info = info_t.sum(1)
        delta = np.where(info > 0, (gain[None, :] ** 2 * sensitivity * observed * w).sum(1)
                         / np.where(info > 0, info, 1.0), 0.0)
        if isinstance(model.pointing, SinusoidalJitter):
            v = float(radar.velocity)
            span = np.ptp(x)
            t_min, t_max = (4.0 / float(radar.prf), span / (2 * v)) if period_bounds is None \
                else period_bounds
            if not (0 < t_min < t_max):
                raise ValueError(f"jitter_period_bounds={period_bounds!r} must be 0 < T_min < "
                                 "T_max [s]")
            theta, _ = _staging.sinusoid_initial(model.pointing, x, delta, info,
                                                 (1 / (v * t_max), 1 / (v * t_min)))
            params["pointing"] = jnp.asarray(theta)
        else:
            design_p = np.asarray(model.pointing.design(jnp.asarray(x)))
            if model.pointing.gauge is not None:
                design_p = design_p @ np.asarray(model.pointing.gauge)
            sw = np.sqrt(info)[:, None]
            a = design_p * sw
            normal = a.T @ a
            normal += 1e-9 * np.trace(normal) / normal.shape[0] * np.eye(normal.shape[0])
            params["pointing"] = jnp.asarray(np.linalg.solve(normal, a.T @ (delta * sw[:, 0])))
        record("jitter", time.perf_counter() - t0, params)
    if not has_dev:
        return params, None

    def rephase(m3, half_window, keep=None):
        """Deviation parameters re-unwrapped about the line of sight of ``m3`` (azimuth,
        3) (Δy, Δz, δ_az): ℓ_t = −Δy sin ϑ_t + Δz cos ϑ_t per scatterer. With ``keep``
        (azimuth,) bool, the profile is first refitted on the kept pulses only, the
        others (where the fit is off by a slip) following the smooth model with its
        data-free coefficients held near zero."""
        prediction = np.asarray(m3)[:, :2] @ los_rows.T
        if keep is not None:
            w = np.broadcast_to(keep[:, None].astype(float), prediction.shape)
            coef, const = _staging.fit_los(design, los_rows, prediction, w,
                                           per_target_constant=False, ridge=1e-3)
            prediction = np.einsum("tk,pkj,j->pt", los_rows, design, coef) + const[None, :]
        return phase_stage(prediction, half_window)[0]

    return params, rephase


def _split(model, coef, kh, los):
    out = {"horizontal": jnp.asarray(coef[:kh])}
    if model.vertical is not None and los is None:
        out["vertical"] = jnp.asarray(coef[kh:])
    return out


def _zero_rest(model, params, radar, x):
    out = {}
    for n in model.components:
        if n in params:
            continue
        p = getattr(model, n)
        if isinstance(p, SinusoidalJitter):
            # zero amplitude at a mid-band frequency: a neutral start for the amplitude
            out[n] = jnp.asarray([0.0, 0.0, 4.0 / np.ptp(x)])
        else:
            out[n] = jnp.zeros(p.num_params())
    return out
