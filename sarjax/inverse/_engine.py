"""Forward model and structured Jacobian shared by :func:`fit_motion` and :func:`crb`.

The exact time-domain model (physics.md §3) is *pulse-local*: pulse p's echo depends on the
motion only through (Δy_p, Δz_p, δ_az,p). So one forward-mode Jacobian with respect to a
per-pulse *common* shift s ∈ R³ of the three motion arrays,
``∂h_p/∂s = ∂h_p/∂(Δy_p, Δz_p, δ_az,p)`` (azimuth, range, 3), is the whole per-pulse
Jacobian; any parametrisation follows by the chain rule through ``∂motion_p/∂θ``. The cost is
one simulation and three tangents, whatever the number of parameters.

Each scatterer is simulated with unit reflectivity, so that the complex reflectivities enter
linearly: ``h = Σ_t γ_t s_t(motion)``.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._data import Acquisition
from ..motion import Motion
from ..processing._range_compression import matched_filter
from ..radar import Radar
from ..scene import PointTargets
from ..simulators import TimeDomain


class Problem(eqx.Module):
    """A calibration scene on an acquisition grid, with the fixed linear transform of the
    data used by the fit.

    Attributes:
        radar: the :class:`~sarjax.Radar`.
        scene: (target,) point scatterers (their reflectivities are not used: unit each).
        acquisition: the (pulse, range) grid simulated.
        simulator: the pulse-local exact simulator.
        phase_filter: (range,) unimodular range filter ``conj(C)/|C|`` (C: DFT of the chirp
            replica), or None for the raw samples. Range compression by this filter is
            unitary, so white noise stays white with the same variance.
        window_index: (azimuth, window) range-sample indices kept after compression, or None.
    """

    radar: Radar
    scene: PointTargets
    acquisition: Acquisition
    simulator: TimeDomain
    phase_filter: jnp.ndarray | None = None
    window_index: jnp.ndarray | None = None

    @property
    def azimuth(self):
        """(azimuth,) pulse positions x' [m]."""
        return self.acquisition.pulse_azimuths(self.radar)

    @property
    def num_targets(self) -> int:
        return self.scene.num_scatterers


@eqx.filter_jit
def unitary_range_filter(radar, num_range: int):
    """(range,) phase-only matched filter on a circular grid of ``num_range`` samples."""
    mf = matched_filter(radar, num_range)
    mag = jnp.abs(mf)
    return jnp.where(mag > 0, mf / jnp.where(mag > 0, mag, 1.0), 1.0)


def transform(problem: Problem, raw):
    """Range-compress (unitary) and keep the windows: (..., azimuth, range) → (..., azimuth,
    window); identity when the problem has no filter."""
    if problem.phase_filter is None:
        return raw
    spectrum = jnp.fft.fft(raw, axis=-1) * problem.phase_filter.reshape(
        (1,) * (raw.ndim - 1) + (-1,))
    compressed = jnp.fft.ifft(spectrum, axis=-1)
    if problem.window_index is None:
        return compressed
    index = jnp.broadcast_to(problem.window_index, compressed.shape[:-1]
                             + problem.window_index.shape[-1:])
    return jnp.take_along_axis(compressed, index, axis=-1)


def _single_targets(scene: PointTargets):
    """The scene's leaves as (target, 1) arrays with unit reflectivity."""
    leaves = {name: getattr(scene, name)[:, None] for name in
              ("azimuth", "range", "height", "velocity_range", "velocity_azimuth")}
    leaves["reflectivity"] = jnp.ones_like(scene.reflectivity)[:, None]
    return leaves


def target_signals(problem: Problem, motion3):
    """(target, azimuth, sample) transformed echo of each scatterer with γ = 1.

    Args:
        problem: the :class:`Problem`.
        motion3: (azimuth, 3) per-pulse (Δy [m], Δz [m], δ_az [rad]).
    """
    motion = Motion(horizontal=motion3[:, 0], vertical=motion3[:, 1], pointing=motion3[:, 2])
    template = problem.scene

    def one(leaves):
        scene = eqx.tree_at(
            lambda s: (s.azimuth, s.range, s.height, s.velocity_range, s.velocity_azimuth,
                       s.reflectivity),
            template,
            (leaves["azimuth"], leaves["range"], leaves["height"], leaves["velocity_range"],
             leaves["velocity_azimuth"], leaves["reflectivity"]),
        )
        raw = problem.simulator(problem.radar, scene, motion, problem.acquisition,
                                jnp.complex128)
        return transform(problem, raw)

    return jax.vmap(one)(_single_targets(problem.scene))


def signals_and_jacobian(problem: Problem, motion3):
    """``(S, dS)``: the (target, azimuth, sample) signals and their per-pulse derivatives
    (target, azimuth, sample, 3) with respect to (Δy_p, Δz_p, δ_az,p) of the same pulse."""

    def shifted(shift):
        return target_signals(problem, motion3 + shift[None, :])

    zero = jnp.zeros(3)
    jac = jax.jacfwd(shifted)(zero)
    return shifted(zero), jac


def check_pulse_local(problem: Problem, motion3, *, key=0):
    """Maximum relative difference between a directional derivative of the simulator along a
    random per-pulse tangent and its prediction from the per-pulse Jacobian (a check that the
    simulator is pulse-local)."""
    rng = np.random.default_rng(key)
    tangent = jnp.asarray(rng.normal(size=motion3.shape) * np.array([[1e-3, 1e-3, 1e-4]]))
    _, direct = jax.jvp(lambda m: target_signals(problem, m), (motion3,), (tangent,))
    _, jac = signals_and_jacobian(problem, motion3)
    predicted = jnp.einsum("tpsk,pk->tps", jac, tangent)
    return float(jnp.max(jnp.abs(direct - predicted)) / jnp.max(jnp.abs(direct)))


def model_jacobian_blocks(problem, motion3, gamma):
    """Per-pulse blocks of the data Jacobian for reflectivities ``gamma`` (target,):

    Returns:
        ``(model, jac_motion, signals)``: (azimuth, sample) model ``Σ γ_t s_t``;
        (azimuth, sample, 3) its per-pulse motion Jacobian; (target, azimuth, sample) s_t.
    """
    signals, dsignals = signals_and_jacobian(problem, motion3)
    model = jnp.einsum("t,tps->ps", gamma, signals)
    jac = jnp.einsum("t,tpsk->psk", gamma, dsignals)
    return model, jac, signals
