"""Cramér–Rao bound of motion parameters from the Fisher information of the raw data."""

from __future__ import annotations

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.flatten_util import ravel_pytree

from ..motion import Motion
from . import _engine, _setup
from ._parametrisations import MotionModel, SinusoidalJitter
from ._result import _jitter_summary, _profile_std, _scene_centre_direction, project_profiles


@dataclasses.dataclass(frozen=True)
class CRB:
    """Cramér–Rao bound of an unbiased estimator of the model parameters.

    Attributes:
        covariance: (K, K) inverse Fisher matrix of the motion parameters (reflectivities,
            when estimated, are nuisance parameters and already marginalised).
        fisher: (K + 2T, K + 2T) Fisher matrix of motion parameters then Re/Im γ (or K × K).
        parameter_names: (K,) ``(component, index)`` pairs.
        profile_std: per-pulse CRB standard deviations on the support pulses:
            ``horizontal``, ``vertical`` [m], ``pointing`` [rad], ``line_of_sight`` [m]
            (projected on the scene-centre direction, see :attr:`FitResult.profile_std`).
        rms: root-mean-square over the support pulses of each ``profile_std`` entry.
        jitter: for :class:`SinusoidalJitter`, the bound on ``amplitude`` [rad],
            ``period`` [s] and ``phase`` [rad] (keys ``*_std``); else None.
        support: (num_pulses,) bool, the pulses the bound is computed on (those inside a
            scatterer's main lobe, as in :func:`fit_motion`).
        fixed: components held fixed (see :class:`~sarjax.inverse.Fixed`).
        params: the parameters at which the bound is evaluated.
        model: the bound :class:`MotionModel`.
    """

    covariance: np.ndarray
    fisher: np.ndarray
    parameter_names: tuple
    profile_std: dict
    rms: dict
    jitter: dict | None
    support: np.ndarray
    fixed: tuple
    params: dict
    model: MotionModel


@eqx.filter_jit
def _fisher_blocks(problem, model, params, line_of_sight, gamma):
    flat, unravel = ravel_pytree(params)
    x = problem.azimuth

    def profiles(f):
        return _setup.motion3(model, unravel(f), x, line_of_sight)

    m3 = profiles(flat)
    d = jax.jacfwd(profiles)(flat)  # (azimuth, 3, K)
    signals, dsignals = _engine.signals_and_jacobian(problem, m3)
    jac = jnp.einsum("t,tpsk->psk", gamma, dsignals)  # (azimuth, sample, 3)
    g = jnp.real(jnp.einsum("psi,psj->pij", jnp.conj(jac), jac))
    f_mm = jnp.einsum("pik,pij,pjl->kl", d, g, d)
    js = jnp.einsum("psi,tps->pit", jnp.conj(jac), signals)  # (azimuth, 3, target)
    f_ma = jnp.einsum("pik,pit->kt", d, jnp.real(js))
    f_mb = -jnp.einsum("pik,pit->kt", d, jnp.imag(js))
    ss = jnp.einsum("tps,ups->tu", jnp.conj(signals), signals)
    return f_mm, f_ma, f_mb, ss


def crb(
    radar,
    scene,
    *,
    noise_power,
    motion: Motion | None = None,
    jitter=None,
    model: MotionModel | None = None,
    params: dict | None = None,
    num_pulses=None,
    num_range=None,
    near_range=None,
    azimuth_center=0.0,
    reflectivity: str = "estimate",
) -> CRB:
    """Cramér–Rao bound for the motion parameters of ``model`` from raw data with complex
    white noise of power ``noise_power`` per sample.

    Fisher information of the exact time-domain model (physics.md §3) on the raw grid,
    ``F = (2/σ²) Re(Jᴴ J)`` with ``J = ∂h/∂(θ, Re γ, Im γ)`` over every raw sample of the
    pulses inside some scatterer's main lobe (the pulses :func:`fit_motion` uses), computed
    by forward-mode differentiation (the per-pulse Jacobian of the pulse-local simulator,
    then the chain rule through the parametrisation). Reflectivities are nuisance
    parameters unless ``reflectivity="known"``; the gauges of :func:`fit_motion` apply.

    Args:
        radar: the :class:`~sarjax.Radar`.
        scene: :class:`~sarjax.PointTargets` with their reflectivities γ.
        noise_power: σ² = E|n|² per complex raw sample.
        motion: the true :class:`~sarjax.Motion` on the acquisition's pulses (its Δy, Δz are
            projected on the model's profiles); or give ``params``.
        jitter: (δ_m [rad], T_b [s], φ₀ [rad]) when the model's pointing is
            :class:`SinusoidalJitter` and ``params`` is not given.
        model: :class:`MotionModel` (default as in :func:`fit_motion`).
        params: model parameters (bound to the support pulses), instead of ``motion``.
        num_pulses, num_range, near_range, azimuth_center: the raw grid (defaults as in
            :func:`sarjax.simulate`).
        reflectivity: ``"estimate"`` (nuisance) or ``"known"``.

    Returns:
        :class:`CRB`.
    """
    if reflectivity not in ("estimate", "known"):
        raise ValueError(f"reflectivity={reflectivity!r} must be 'estimate' or 'known'")
    if not (np.isfinite(noise_power) and noise_power > 0):
        raise ValueError(f"noise_power={noise_power!r} must be finite and > 0")
    num_pulses = radar.num_pulses if num_pulses is None else num_pulses
    num_range = radar.num_range if num_range is None else num_range
    near = float(radar.near_range if near_range is None else near_range)
    index = np.arange(num_pulses) - (num_pulses - 1) / 2
    raw_x = float(azimuth_center) + index * float(radar.azimuth_spacing)
    raw_r = near + np.arange(num_range) * float(radar.range_spacing)
    _setup.check_inputs(radar, scene, raw_x, raw_r)
    p0, p1 = _setup.pulse_span(radar, scene, raw_x)
    x = raw_x[p0:p1]
    model = _setup.default_model(radar) if model is None else model
    known = reflectivity == "known"
    bound, fixed, los = _setup.bind_model(radar, scene, model, x, reflectivity_known=known)
    los_arr = None if los is None else jnp.asarray(los)
    if params is None:
        if motion is None:
            raise ValueError("give the true motion (motion=...) or the model parameters")
        params = _params_from_motion(bound, motion, raw_x, p0, p1, los, jitter)
    params = {n: jnp.asarray(params[n], dtype=float) for n in bound.components}
    problem = _setup.make_problem(radar, scene, x, near, num_range)
    gamma = jnp.asarray(scene.reflectivity)
    f_mm, f_ma, f_mb, ss = (np.asarray(a) for a in _fisher_blocks(
        problem, bound, params, los_arr, gamma))
    scale = 2.0 / float(noise_power)
    if known:
        fisher = scale * f_mm
    else:
        f_aa = np.real(ss)
        f_ab = -np.imag(ss)
        fisher = scale * np.block([
            [f_mm, f_ma, f_mb],
            [f_ma.T, f_aa, f_ab],
            [f_mb.T, f_ab.T, f_aa],
        ])
    k = f_mm.shape[0]
    covariance = np.linalg.pinv(fisher, hermitian=True)[:k, :k]
    flat, _ = ravel_pytree(params)
    names = tuple((n, i) for n in sorted(params) for i in range(int(np.size(params[n]))))
    stds = _profile_std(bound, params, x, los, covariance, names,
                        _scene_centre_direction(radar))
    rms = {key: float(np.sqrt(np.mean(v**2))) for key, v in stds.items()}
    jit = None
    if isinstance(bound.pointing, SinusoidalJitter):
        jit = _jitter_summary(bound.pointing, np.asarray(params["pointing"]), covariance, names)
        jit = {key: v for key, v in jit.items() if key.endswith("_std")}
    support = np.zeros(raw_x.size, bool)
    support[p0:p1] = True
    return CRB(covariance=covariance, fisher=fisher, parameter_names=names,
               profile_std=stds, rms=rms, jitter=jit, support=support, fixed=tuple(fixed),
               params={n: np.asarray(v) for n, v in params.items()}, model=bound)


def _params_from_motion(model, motion, raw_x, p0, p1, los, jitter):
    dy, dz, pointing = (np.asarray(v)[p0:p1] for v in motion.resolve(raw_x.size))
    return project_profiles(model, dy, dz, pointing, raw_x[p0:p1], los, jitter)
