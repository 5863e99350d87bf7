"""The result of :func:`~sarjax.inverse.fit_motion` and the profile helpers shared with
:func:`~sarjax.inverse.crb`: parameters ↔ per-pulse profiles, their standard deviations,
the jitter summary, and the comparison of an estimate with a reference."""

from __future__ import annotations

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.flatten_util import ravel_pytree

from .._data import RawData
from ..motion import Motion
from . import _setup
from ._parametrisations import MotionModel, SinusoidalJitter


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


class StageLog:
    """The :class:`Stage` records and timings of a fit, in the order its stages ran.

    ``objective`` (a :class:`~sarjax.inverse._residual.Objective`) prices the closed-form
    stages' estimates.
    """

    def __init__(self, objective):
        self.objective = objective
        self.stages = []
        self.timings = {}

    def add(self, name, seconds, cost, steps, params):
        """Record a stage that ended at ``params`` (motion parameters) with ``cost``."""
        self.stages.append(Stage(name, seconds, cost, int(steps),
                                 {n: np.asarray(v) for n, v in params.items()}))
        self.timings[name] = seconds

    def record(self, name, seconds, params):
        """Record a closed-form stage: its cost with the least-squares reflectivities."""
        components = self.objective.model.components
        self.add(name, seconds, self.objective.stage_cost(params), 0,
                 {n: params[n] for n in components})


def _profile_std(model, params, x, line_of_sight, covariance, names, los_direction):
    motion_params = {n: jnp.asarray(params[n]) for n in model.components}
    keep = [i for i, (name, _) in enumerate(names) if name != "reflectivity"]
    los = None if line_of_sight is None else jnp.asarray(line_of_sight)
    d = np.asarray(_profile_jacobian(model, motion_params, jnp.asarray(x), los))
    cov = covariance[np.ix_(keep, keep)]
    out = {}
    for i, name in enumerate(("horizontal", "vertical", "pointing")):
        out[name] = np.sqrt(np.maximum(np.einsum("pk,kl,pl->p", d[:, i], cov, d[:, i]), 0))
    if los_direction is not None:
        s, c = los_direction
        dl = -s * d[:, 0] + c * d[:, 1]
        out["line_of_sight"] = np.sqrt(np.maximum(np.einsum("pk,kl,pl->p", dl, cov, dl), 0))
    return out


@eqx.filter_jit
def _profile_jacobian(model, motion_params, x, los):
    """(azimuth, 3, K_motion) ∂(Δy, Δz, δ_az)/∂θ, θ the motion parameters raveled."""
    flat, unravel = ravel_pytree(motion_params)
    return jax.jacfwd(lambda f: _setup.motion3(model, unravel(f), x, los))(flat)


@eqx.filter_jit
def _physical_jacobian(jitter, theta):
    """(3, 3) ∂(δ_m, T_b, φ₀)/∂θ of a :class:`SinusoidalJitter`."""
    return jax.jacfwd(lambda t: jnp.stack(jitter.physical(t)))(theta)


def _scene_centre_direction(radar):
    """(sin ϑ₀, cos ϑ₀) of the reference range r₀ on the ground (h = 0)."""
    c = float(radar.height) / float(radar.reference_range)
    return (float(np.sqrt(1 - c * c)), c)


def _jitter_summary(jitter, params, covariance, names):
    idx = [i for i, (k, _) in enumerate(names) if k == "pointing"]
    cov = covariance[np.ix_(idx, idx)]
    theta = jnp.asarray(params)
    values = jitter.physical(theta)
    jac = np.asarray(_physical_jacobian(jitter, theta))
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
