"""Fit trajectory deviations and pointing jitter to raw data of a known scene."""

from __future__ import annotations

import time

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jax.flatten_util import ravel_pytree

from .._data import Acquisition, RawData
from ..motion import Motion
from ..simulators import TimeDomain
from . import _residual, _setup, _staging
from ._parametrisations import MotionModel, SinusoidalJitter
from ._recovery import Solver, fit_jointly
from ._result import FitResult as FitResult
from ._result import Stage as Stage
from ._result import StageLog, _initial_params, _jitter_summary, _scene_centre_direction
from ._result import align as align
from ._result import project_profiles as project_profiles

_SOLVERS = _residual.SOLVERS


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
    mean χ² per pulse 1.2 times the median pulse's and above half what noise alone gives
    a pulse, (M − K) / pulses: below the noise nothing is left to recover, as on noise-free
    data) and recovered: the profile is refitted
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
    _check_arguments(raw, reflectivity, solver, window, noise_power, jitter_period_bounds)
    _setup.check_inputs(radar, scene, raw.azimuth, raw.range)
    model = _setup.default_model(radar) if model is None else model
    if not isinstance(model, MotionModel) or not model.components:
        raise ValueError("model must be a MotionModel with at least one fitted component")
    known = reflectivity == "known"

    # ---- grid, transform and gauge ----------------------------------------------------
    t0 = time.perf_counter()
    raw_x = np.asarray(raw.azimuth, float)
    p0, p1 = _setup.pulse_span(radar, scene, raw_x)
    x = raw_x[p0:p1]
    r0, r1 = _setup.range_span(radar, scene, raw.range, x, max_deviation)
    near = float(raw.range[r0])
    problem = _setup.make_problem(radar, scene, x, near, r1 - r0, half_width=window)
    data_crop = jnp.asarray(raw.data[p0:p1, r0:r1], dtype=jnp.complex128)
    bound, fixed, los = _setup.bind_model(radar, scene, model, x, reflectivity_known=known)
    objective, compressed, sigma0_sq = _residual.make_objective(
        problem, data_crop, bound, los, bound.scale(radar),
        np.asarray(scene.reflectivity) if known else None, noise_power)
    log = StageLog(objective)
    log.timings["setup"] = time.perf_counter() - t0

    # ---- initial estimate, joint fit and slip recovery --------------------------------
    if initial is None:
        params, phase = _staging.cold_start(radar, scene, bound, los, compressed, x, near,
                                            sigma0_sq, max_deviation, jitter_period_bounds,
                                            min_snr, log.record)
    else:
        params = _initial_params(bound, initial, x, los)
        phase = None
        t0 = time.perf_counter()
        log.record("initial", time.perf_counter() - t0, params)
    best = fit_jointly(objective, params, phase,
                       Solver(_residual.solver_function(solver), rtol, atol, max_steps), log)

    # ---- covariance, noise, residual ------------------------------------------------------
    t0 = time.perf_counter()
    params = best.params(bound.components)
    names, covariance, noise = _covariance(best, objective.num_residuals, noise_power,
                                           sigma0_sq)
    gamma_fit = objective.fitted_reflectivity(best)
    motion = _raw_motion(bound, params, raw_x, objective.line_of_sight)
    residual = RawData(data=raw.data - _full_model(radar, scene, gamma_fit, motion, raw),
                       azimuth=raw.azimuth, range=raw.range, method="residual")
    jitter = None
    if isinstance(bound.pointing, SinusoidalJitter):
        jitter = _jitter_summary(bound.pointing, params["pointing"], covariance, names)
    support = np.zeros(raw_x.size, bool)
    support[p0:p1] = True
    log.timings["covariance"] = time.perf_counter() - t0
    log.timings["total"] = time.perf_counter() - t_start
    out_params = {n: np.asarray(params[n]) for n in bound.components}
    out_params["reflectivity"] = gamma_fit
    return FitResult(
        motion=motion, params=out_params, jitter=jitter, covariance=covariance,
        parameter_names=names, residual=residual, noise_power=float(noise), chi2=best.chi2,
        num_residuals=objective.num_residuals, history=tuple(log.stages),
        timings=log.timings, fixed=tuple(fixed), support=support, model=bound,
        line_of_sight=los, solver=solver, converged=bool(best.converged),
        reference_direction=_scene_centre_direction(radar),
    )


def _check_arguments(raw, reflectivity, solver, window, noise_power, jitter_period_bounds):
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


def _covariance(fit, num_residuals, noise_power, sigma0_sq):
    """``(parameter_names, covariance, noise_power)`` of a joint fit: the Gauss–Newton
    Fisher matrix at the solution, with the given noise power or the one estimated from
    χ²/(M − K) × σ₀²."""
    y, scales = fit.y, fit.args.scales
    # the dense (M, K) Jacobian: JᵀJ assembled from per-pulse blocks instead (as crb's
    # Fisher matrix is) agreed to 2e-10 but its program compiled in 2.4 s against 1.9 s
    # (notebook 02's 400 × 360 fit; the first call's covariance stage 5.2–6.8 s either way)
    jac = np.asarray(_residual.jacobian(y, fit.args))
    num_params = jac.shape[1]
    normal = jac.T @ jac
    cov_scaled = np.linalg.pinv(normal, hermitian=True)
    if noise_power is None:
        factor = fit.chi2 / max(num_residuals - num_params, 1)
        noise = sigma0_sq * factor
    else:
        factor = 1.0
        noise = float(noise_power)
    flat_scale = np.asarray(ravel_pytree(
        {k: jnp.broadcast_to(scales[k], jnp.shape(y[k])) for k in y})[0])
    covariance = cov_scaled * factor * np.outer(flat_scale, flat_scale)
    names = tuple((k, i) for k in sorted(y) for i in range(int(np.size(y[k]))))
    return names, covariance, noise


def _raw_motion(model, params, raw_x, line_of_sight):
    """The fitted :class:`~sarjax.Motion` on every raw pulse."""
    m3_raw = np.asarray(_setup.motion3(model, params, jnp.asarray(raw_x), line_of_sight))
    return Motion(horizontal=m3_raw[:, 0], vertical=m3_raw[:, 1], pointing=m3_raw[:, 2])


@eqx.filter_jit
def _full_model_jit(simulator, radar, scene, motion, acquisition):
    return simulator(radar, scene, motion, acquisition, jnp.complex128)


def _full_model(radar, scene, gamma, motion, raw):
    x = np.asarray(raw.azimuth, float)
    acquisition = Acquisition(
        num_pulses=int(x.size), num_range=int(raw.range.shape[0]),
        near_range=float(raw.range[0]), azimuth_center=float(0.5 * (x[0] + x[-1])),
    )
    scene = eqx.tree_at(lambda s: s.reflectivity, scene, jnp.asarray(gamma, complex))
    return np.asarray(_full_model_jit(TimeDomain(), radar, scene, motion, acquisition))
