"""The joint Levenberg–Marquardt stage of :func:`~sarjax.inverse.fit_motion`, and the
detection of and recovery from a phase-unwrapping slip of the cold start.

A phase-unwrapping slip (typically at an aperture edge, where the echoes are weak and the
coarse estimate's slope error can exceed π per pulse) leaves the joint fit in a local
minimum, whole multiples of λ/2 of line of sight away on part of the aperture: χ² stays
well above the noise floor (≈ M − K real residuals) or the solver stops short. Recovery:
locate the pulses with excess residual, refit the profile on the others (the smooth model
carries it over the slipped stretch), re-unwrap every scatterer's phase about that line of
sight (the residual phase is then small and slow where it was slipped), refit jointly from
there; keep the lowest χ².
"""

from __future__ import annotations

import dataclasses
import time

import jax
import numpy as np

from . import _residual, _setup

# A slipped cold start is flagged after the joint fit by: the solver stopping short; χ²
# above this multiple of its floor M − K (a good fit sits below it: the noise power from
# the median of the compressed data is biased high by the echoes, χ² ≈ 0.87 (M − K) on the
# acceptance scene); or a stretch of pulses whose mean χ² exceeds the median pulse's by
# _SLIP_PULSE_CHI2. The recovery retries with these phase-gradient smoothing half-lengths
# [pulses], rebuilding the pulses with excess residual or not. A stretch is not flagged
# below _SLIP_NOISE_SHARE of the χ² that noise alone gives a pulse ((M − K) / pulses): a
# slip leaves the echo itself in the residual, above the noise at any SNR the cold start
# works at, while on noise-free or high-SNR data the median pulse sits far below the noise
# and the ratio test alone flagged the model's rounding-level structure (three recoveries,
# 4.7 s, on the README's noise-free 1025-pulse file, none of them changing the fit).
_SLIP_CHI2 = 1.03
_SLIP_PULSE_CHI2 = 1.2
_SLIP_NOISE_SHARE = 0.5
_RECOVERY = ((8, True), (4, True), (16, False))


@dataclasses.dataclass(frozen=True)
class JointFit:
    """One joint Levenberg–Marquardt fit: the solver's normalised variables ``y`` and the
    residual's ``args`` (their scales in ``args.scales``), and its outcome."""

    y: dict
    args: _residual.Args
    steps: int
    converged: bool
    chi2: float

    def params(self, components):
        """The motion parameters (dict) of ``components``."""
        return {n: self.y[n] * self.args.scales[n] for n in components}


@dataclasses.dataclass(frozen=True)
class Solver:
    """A Levenberg–Marquardt solve function and its tolerances."""

    solve: object
    rtol: float
    atol: float
    max_steps: int


def joint(objective, start, solver: Solver) -> JointFit:
    """Levenberg–Marquardt on all parameters from the motion parameters ``start``."""
    y0, args = objective.start(start)
    y, steps, converged = solver.solve(y0, args, solver.rtol, solver.atol, solver.max_steps)
    y = jax.block_until_ready(y)
    return JointFit(y=y, args=args, steps=int(steps), converged=bool(converged),
                    chi2=float(_residual.chi2(args, y)))


def excess(fit: JointFit, half_window, floor):
    """(azimuth,) bool: pulses whose χ², averaged over ±half_window pulses, exceeds the
    typical pulse's (the median: a slip covers a minority of the pulses) by 20 % (≈ 6
    standard deviations of that average for 2 × 3 × 17 real residuals a pulse), and half
    the χ² of noise alone (``floor`` = M − K over the pulses)."""
    per_pulse = np.asarray(_residual.pulse_chi2(fit.args, fit.y))
    kernel = np.ones(2 * half_window + 1) / (2 * half_window + 1)
    smooth = np.convolve(per_pulse, kernel, mode="same")
    norm = np.convolve(np.ones_like(per_pulse), kernel, mode="same")
    noise = _SLIP_NOISE_SHARE * floor / per_pulse.size
    return smooth / norm > _SLIP_PULSE_CHI2 * max(float(np.median(per_pulse)), noise)


def slipped(fit: JointFit, floor):
    """Whether ``fit`` looks stuck behind a slip (``floor``: M − K)."""
    return (not fit.converged or fit.chi2 > _SLIP_CHI2 * floor
            or bool(excess(fit, 8, floor).any()))


def kept_pulses(fit: JointFit, half_window, floor):
    """(azimuth,) bool: the pulses at the noise level, less a margin of half_window pulses
    about the others (the slipped stretch is rebuilt); None when that keeps all or none."""
    bad = excess(fit, half_window, floor)
    bad = np.convolve(bad.astype(float), np.ones(2 * half_window + 1), "same") > 0
    keep = ~bad
    if keep.all() or not keep.any():
        return None
    return keep


def fit_jointly(objective, params, phase, solver: Solver, log) -> JointFit:
    """The joint fit from ``params``, then (when ``phase``, the cold start's
    :class:`~sarjax.inverse._staging.PhaseFit`, is given) up to three recoveries from a
    slip; each fit is recorded in ``log``. Returns the lowest-χ² fit."""
    components = objective.model.components
    floor = max(objective.num_residuals - objective.num_params(params), 1)
    t0 = time.perf_counter()
    best = joint(objective, params, solver)
    log.add("joint", time.perf_counter() - t0, 0.5 * best.chi2, best.steps,
            best.params(components))
    attempts = 0
    for half_window, reset in _RECOVERY:
        if phase is None or not slipped(best, floor):
            break
        t0 = time.perf_counter()
        fitted = best.params(components)
        keep = kept_pulses(best, half_window, floor) if reset else None
        m3 = _setup.motion3(objective.model, fitted, objective.problem.azimuth,
                            objective.line_of_sight)
        start = dict(params)
        start.update(phase.rephase(m3, half_window, keep))
        trial = joint(objective, start, solver)
        attempts += 1
        log.add(f"recovery {attempts}", time.perf_counter() - t0, 0.5 * trial.chi2,
                trial.steps, trial.params(components))
        if trial.chi2 < best.chi2:
            best = trial
    return best
