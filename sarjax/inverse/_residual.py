"""The least-squares problem of :func:`~sarjax.inverse.fit_motion`: the whitened residual
of the range-compressed data (with a structured forward-mode derivative), its cost, and
the Levenberg–Marquardt solvers."""

from __future__ import annotations

import warnings

import equinox as eqx
import jax
import jax.numpy as jnp
import lineax as lx
import numpy as np
import optimistix as optx
from jax.flatten_util import ravel_pytree

from . import _engine, _setup
from ._parametrisations import MotionModel

SOLVERS = ("optimistix", "jaxopt")


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


class Args(eqx.Module):
    problem: _engine.Problem
    data: jnp.ndarray
    model: MotionModel
    line_of_sight: jnp.ndarray | None
    scales: dict
    inv_sigma: jnp.ndarray
    reflectivity: jnp.ndarray | None  # (target, 2) when known


def residuals(y, args: Args):
    params = {n: y[n] * args.scales[n] for n in args.model.components}
    m3 = _setup.motion3(args.model, params, args.problem.azimuth, args.line_of_sight)
    if args.reflectivity is None:
        gamma_ri = y["reflectivity"] * args.scales["reflectivity"]
    else:
        gamma_ri = args.reflectivity
    return _core(args.problem, args.data, args.inv_sigma, m3, gamma_ri), \
        args.model.penalty(params)


# ---- solvers -------------------------------------------------------------------------


@eqx.filter_jit
def solve_optimistix(y0, args, rtol, atol, max_steps):
    # normal equations by Cholesky: K × K instead of a QR of the (M + K) × K system
    solver = optx.LevenbergMarquardt(rtol=rtol, atol=atol,
                                     linear_solver=lx.Normal(lx.Cholesky()))
    sol = optx.least_squares(residuals, solver, y0, args, max_steps=max_steps, throw=False)
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
def solve_jaxopt(y0, args, rtol, atol, max_steps):
    jaxopt = _import_jaxopt()
    flat0, unravel = ravel_pytree(y0)

    def flat_residuals(flat):
        return ravel_pytree(residuals(unravel(flat), args))[0]

    solver = jaxopt.LevenbergMarquardt(
        flat_residuals, maxiter=max_steps, tol=atol, xtol=rtol, gtol=atol,
        materialize_jac=True, jit=True,
    )
    out = solver.run(flat0)
    return unravel(out.params), out.state.iter_num, out.state.iter_num < max_steps


def solver_function(solver):
    """The jitted solve(y0, args, rtol, atol, max_steps) of a solver name."""
    return solve_optimistix if solver == "optimistix" else solve_jaxopt


# ---- jitted pieces -------------------------------------------------------------------


@eqx.filter_jit
def jacobian(y, args):
    flat, unravel = ravel_pytree(y)
    return jax.jacfwd(lambda f: ravel_pytree(residuals(unravel(f), args))[0])(flat)


@eqx.filter_jit
def signals(problem, m3):
    return _engine.target_signals(problem, m3)


@eqx.filter_jit
def compress(problem, raw):
    return _engine.transform(problem, raw)


def ls_reflectivity(signals, data):
    """Least-squares complex reflectivities (target,) of data ≈ Σ γ_t s_t."""
    a = np.asarray(signals).reshape(signals.shape[0], -1).T
    gamma, *_ = np.linalg.lstsq(a, np.asarray(data).reshape(-1), rcond=None)
    return gamma


@eqx.filter_jit
def _terms(args, y):
    """((azimuth,) χ² of each pulse's whitened residual (2 × samples real residuals), the
    penalty's ‖p‖²): one program for the cost, χ² and the per-pulse χ², which a fit's
    stages and its slip check all read (on the notebook's 400 × 360 fit three programs of
    the same residual compiled in 2.1 s, this one in 0.6 s)."""
    res, penalty = residuals(y, args)
    return jnp.sum(res**2, axis=(1, 2)), jnp.sum(penalty**2)


def cost(args, y):
    """½‖r‖² (the residual and the penalty) at ``y``."""
    per_pulse, penalty = _terms(args, y)
    return 0.5 * (float(np.sum(np.asarray(per_pulse))) + float(penalty))


def chi2(args, y):
    """χ² of the whitened residual (the penalty excluded) at ``y``."""
    return float(np.sum(np.asarray(_terms(args, y)[0])))


def pulse_chi2(args, y):
    """(azimuth,) χ² of each pulse's whitened residual (2 × samples real residuals)."""
    return _terms(args, y)[0]


# ---- one fit's objective -------------------------------------------------------------


class Objective(Args):
    """The residual's arguments for one fit's windowed compressed data (``scales``: of the
    motion parameters only), with the known (target,) complex reflectivities ``known``
    (None when estimated; ``reflectivity`` holds them as (target, 2) Re/Im).
    """

    known: np.ndarray | None

    @property
    def num_residuals(self):
        """M, real residuals."""
        return int(np.prod(self.data.shape)) * 2

    def num_params(self, params):
        """K: motion parameters, and Re/Im of the reflectivities when estimated."""
        num_targets = int(np.size(self.problem.scene.range))
        return sum(int(np.size(params[n])) for n in self.model.components) + \
            (0 if self.known is not None else 2 * num_targets)

    def args(self, scales):
        """The residual's arguments with the parameter scales ``scales``."""
        return Args(self.problem, self.data, self.model, self.line_of_sight, scales,
                    self.inv_sigma, self.reflectivity)

    def start_reflectivity(self, params):
        """(target,) complex: the known reflectivities, or the least-squares ones at
        ``params``."""
        m3 = _setup.motion3(self.model, params, self.problem.azimuth, self.line_of_sight)
        if self.known is not None:
            return self.known
        return ls_reflectivity(signals(self.problem, m3), self.data)

    def stage_cost(self, params):
        """½‖r‖² at ``params`` with the least-squares reflectivities."""
        gamma = self.start_reflectivity(params)
        y = {n: params[n] / self.scales[n] for n in self.model.components}
        args = self.args(self.scales)
        if self.known is None:
            scales_g = jnp.asarray(float(np.max(np.abs(gamma))) or 1.0)
            args = eqx.tree_at(lambda a: a.scales, args,
                               {**self.scales, "reflectivity": scales_g})
            y["reflectivity"] = jnp.asarray(np.stack([gamma.real, gamma.imag], -1) / scales_g)
        return cost(args, y)

    def start(self, params):
        """(y0, args) of a solver started at ``params``, the reflectivities at their
        least-squares values; ``args.scales`` include the reflectivity scale."""
        gamma = self.start_reflectivity(params)
        y0 = {n: jnp.asarray(params[n]) / self.scales[n] for n in self.model.components}
        all_scales = dict(self.scales)
        if self.known is None:
            scale_g = float(np.max(np.abs(gamma))) or 1.0
            all_scales["reflectivity"] = jnp.asarray(scale_g)
            y0["reflectivity"] = jnp.asarray(np.stack([gamma.real, gamma.imag], -1) / scale_g)
        return y0, self.args(all_scales)

    def fitted_reflectivity(self, fit):
        """(target,) complex reflectivities of a joint fit (the known ones when known)."""
        if self.known is not None:
            return self.known
        g = np.asarray(fit.y["reflectivity"] * fit.args.scales["reflectivity"])
        return g[:, 0] + 1j * g[:, 1]


def make_objective(problem, data_crop, model, los, scales, reflectivity, noise_power):
    """The :class:`Objective` of the cropped raw data ``data_crop`` and the compressed
    lines (azimuth, range) the cold start reads; ``reflectivity``: the known (target,)
    reflectivities or None; ``noise_power``: σ² or None (estimated from the median
    power of the compressed lines, biased high by the echoes).

    Returns ``(objective, compressed, σ²)``.
    """
    data_win = compress(problem, data_crop)
    los_arr = None if los is None else jnp.asarray(los)
    known_ri = None
    if reflectivity is not None:
        g = np.asarray(reflectivity)
        known_ri = jnp.asarray(np.stack([g.real, g.imag], axis=-1))
    compressed_only = eqx.tree_at(lambda p: p.window_index, problem, None,
                                  is_leaf=lambda v: v is None)
    compressed = compress(compressed_only, data_crop)
    sigma0_sq = float(np.median(np.abs(np.asarray(compressed)) ** 2) / np.log(2))
    if noise_power is not None:
        sigma0_sq = float(noise_power)
    inv_sigma = jnp.asarray(np.sqrt(2.0 / sigma0_sq))
    known = None if reflectivity is None else np.asarray(reflectivity)
    objective = Objective(problem, data_win, model, los_arr, scales, inv_sigma, known_ri,
                          known)
    return objective, compressed, sigma0_sq
