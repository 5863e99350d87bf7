"""Model-based autofocus: trajectory deviations and pointing error from data of an unknown
scene.

:func:`autofocus` estimates Δy(x'), Δz(x') (cubic B-splines) by

0. where the start's image is blurred beyond the phase gradients' reach (``map_drift``,
   ``map_drift_blur``), multi-look map drift (:mod:`sarjax.inverse._map_drift`): the
   relative displacements of looks across the Doppler band, measured on the backscatter's
   structure and solved for the deviation (coarse: it brings errors of tens of radians to
   about one);
1. a range-dependent phase-gradient stage (:mod:`sarjax.inverse._pga`): the pulse-to-pulse
   phase products of the dominant scatterers, fitted by the line-of-sight model
   ``k₀ δr_xr ≈ k₀ (−Δy sin ϑ(r) + Δz cos ϑ(r))`` with a shrinking window (coarse to fine);
2. a sharpness stage: L-BFGS on the image entropy (or contrast) of the whole swath focused
   through the differentiable focuser of :mod:`sarjax.inverse._sharpness`, with the exact
   line-of-sight deviation ``δr_xr(Δy, Δz, r)`` (physics.md §2) at every range bin;
3. the pointing error δ_az(x') from the Doppler centroid of the motion-compensated data,
   referred to the centroid the focused scene predicts with no pointing error.

Stages 0–2 run again from a randomly perturbed start (``restarts``); the estimate most
starts agree with is kept (of those the sharpest) and its largest difference from another,
:attr:`AutofocusResult.agreement`, is reported (a warning above ``agreement_tolerance``:
the estimate is not unique).

Unobservable components, held at zero and listed in :attr:`AutofocusResult.fixed`: the
constant and the linear trend of Δy and Δz over the pulses (a constant deviation changes
each scatterer's phase by a constant, a linear one moves the image; neither changes the
sharpness); the components of δ_az slower than about X/2 (a constant Doppler offset trades
with a linear trend of the line-of-sight deviation, slow ones with the backscatter's
variation across the beam).
"""

from __future__ import annotations

import dataclasses
import functools
import time
import warnings

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import scipy.optimize

from .. import geometry
from .._data import Image, RawData
from ..motion import Motion, smooth_deviation
from ..processing import focus
from . import _map_drift, _pga
from ._parametrisations import BSpline, MotionModel
from ._sharpness import (
    MIN_LOOK_ANGLE,
    OBJECTIVES,
    AzimuthFocuser,
    image_entropy,
    make_focuser,
    sharpness_loss,
    value_and_grad,
)

SCENE_MIN_LOOK_ANGLE = np.deg2rad(8.0)  # nearest clutter of random_scene [rad]


MAP_DRIFT_ITERATIONS = 8  # the map-drift stage's iterations where map_drift=None runs it


class AutofocusWarning(UserWarning):
    """An autofocus estimate outside what was measured to be reliable (too few dominant
    scatterers, an optimiser that did not converge, a pulse span no scatterer covers,
    estimates from different starts that disagree); the message says which."""


@dataclasses.dataclass(frozen=True)
class AutofocusResult:
    """Result of :func:`autofocus` (and of the baselines).

    Attributes:
        motion: :class:`~sarjax.Motion` on every raw pulse: Δy, Δz [m] (None for a
            single-phase-history method) and δ_az [rad] (None when not estimated).
        phase_history: (pulse,) one phase history φ(x') [rad] removed at every range
            (single-phase-history methods), else None.
        image: the refocused :class:`~sarjax.Image`.
        method: ``"model"``, ``"pga"`` or ``"sharpness_phase"``.
        objective: the sharpness objective used (or None).
        history: (stage, seconds, value) per stage.
        timings: seconds per stage and ``"total"``.
        fixed: components held at zero (unobservable).
        coverage: (pulse,) relative weight of the dominant scatterers per pulse.
        agreement: (block,) for :func:`autofocus` with restarts: the largest difference
            [rad] between the estimate kept and the estimate of any other start, as
            :func:`residual_phase_rms` (aperture-detrended line-of-sight phase) per range
            block of :func:`range_blocks`; None without restarts.
        agreeing: for :func:`autofocus` with restarts: how many starts, the kept one
            included, ended within ``agreement_tolerance`` of the estimate kept in every
            range block (all of them: no warning); None without restarts. Agreement is
            not accuracy: several starts can share a wrong optimum.
    """

    motion: Motion
    phase_history: np.ndarray | None
    image: Image
    method: str
    objective: str | None
    history: tuple
    timings: dict
    fixed: tuple
    coverage: np.ndarray
    agreement: np.ndarray | None = None
    agreeing: int | None = None

    def attributes(self) -> dict:
        """Plain attributes of the estimate for a file: method, objective, stages, times."""
        return {
            "autofocus_method": self.method,
            "autofocus_objective": self.objective or "",
            "autofocus_fixed": ", ".join(self.fixed),
            "autofocus_stages": "; ".join(f"{name} {value:.6g}"
                                          for name, _, value in self.history),
            "autofocus_seconds": float(self.timings.get("total", float("nan"))),
            **({} if self.agreement is None else
               {"autofocus_agreement_rad": [float(v) for v in self.agreement]}),
            **({} if self.agreeing is None else
               {"autofocus_agreeing_starts": int(self.agreeing)}),
        }

    def line_of_sight_phase(self, radar, ranges):
        """(range, pulse) two-way phase k₀ δr_xr(x', r) [rad] that the estimate removes at
        slant ranges ``ranges`` [m] (h = 0)."""
        ranges = np.atleast_1d(np.asarray(ranges, float))
        if self.phase_history is not None:
            return np.broadcast_to(self.phase_history, (ranges.size, self.phase_history.size))
        return true_line_of_sight_phase(radar, self.motion, ranges)


def true_line_of_sight_phase(radar, motion: Motion, ranges):
    """(range, pulse) two-way phase k₀ δr_xr(x', r) [rad] of ``motion`` at slant ranges
    ``ranges`` [m] (h = 0; exact form of :func:`sarjax.geometry.line_of_sight_deviation`)."""
    ranges = np.atleast_1d(np.asarray(ranges, float))
    n = _num_pulses(motion)
    dy, dz, _ = (np.asarray(v) for v in motion.resolve(n))
    los = geometry.line_of_sight_deviation(dy[None, :], dz[None, :], ranges[:, None], 0.0,
                                           float(radar.height))
    return float(radar.wavenumber) * np.asarray(los)


def _num_pulses(motion):
    for v in (motion.horizontal, motion.vertical, motion.pointing):
        if v is not None:
            return int(np.shape(v)[-1])
    raise ValueError("motion has no component")


# ---- metrics ----------------------------------------------------------------------------


def range_blocks(radar, raw_range, num_blocks: int = 3, *, min_look_angle=MIN_LOOK_ANGLE):
    """(block, 2) slant-range limits [m] of ``num_blocks`` equal blocks (near … far) of the
    range bins that have ground (look angle ≥ ``min_look_angle``)."""
    r = np.asarray(raw_range, float)
    r = r[r * np.cos(min_look_angle) >= float(radar.height)]
    edges = np.linspace(r[0], r[-1], num_blocks + 1)
    return np.stack([edges[:-1], edges[1:]], axis=1)


def residual_phase_rms(radar, estimate: AutofocusResult, truth: Motion, blocks, *,
                       detrend: str = "aperture", pulses=None, samples: int = 16):
    """Residual line-of-sight phase error rms [rad] per range block.

    At ``samples`` slant ranges r of each block the error
    ``e(x', r) = k₀ δr_xr,true(x', r) − φ_est(x', r)`` is formed and detrended:

    * ``detrend="aperture"`` (default): in every window of one synthetic aperture
      X(r) = λr/L (the pulses that focus one scatterer) the constant and linear trend of e
      are removed, and the rms is taken over all full windows (stride X/16). A scatterer's
      focus depends only on this part: the constant changes its phase, the linear trend
      moves it by ``r ∂e/∂x' / k₀``; neither is observable without a reference in the
      scene.
    * ``detrend="global"``: the constant and linear trend over ``pulses`` (a boolean
      mask, default all) are removed (the components that no estimator can see). What is
      left includes the slow components (periods beyond X) that only displace the image.

    Returns:
        (block,) rms [rad].
    """
    n = int(np.size(estimate.coverage))
    return _block_phase_rms(
        radar, lambda ranges: (true_line_of_sight_phase(radar, truth, ranges)
                               - estimate.line_of_sight_phase(radar, ranges)),
        n, blocks, detrend=detrend, pulses=pulses, samples=samples)


def _block_phase_rms(radar, error_at, n, blocks, *, detrend="aperture", pulses=None,
                     samples=16):
    """:func:`residual_phase_rms` of the (range, pulse) phase error ``error_at(ranges)``
    on ``n`` pulses."""
    if detrend not in ("aperture", "global"):
        raise ValueError(f"detrend={detrend!r}; choose 'aperture' or 'global'")
    out = []
    mask = np.ones(n, bool) if pulses is None else np.asarray(pulses, bool)
    spacing = float(radar.azimuth_spacing)
    for lo, hi in np.asarray(blocks, float):
        ranges = np.linspace(lo, hi, samples)
        err = error_at(ranges)
        if detrend == "global":
            out.append(_detrended_rms(err[:, mask]))
            continue
        squares = []
        for r, e in zip(ranges, err, strict=True):
            width = int(round(float(radar.footprint(r)) / spacing))
            starts = np.arange(0, n - width + 1, max(width // 16, 1))
            if starts.size == 0:
                raise ValueError(f"{n} pulses are fewer than one aperture ({width}) at r={r:.0f} m")
            windows = e[starts[:, None] + np.arange(width)[None, :]]
            squares.append(_detrended_rms(windows) ** 2)
        out.append(float(np.sqrt(np.mean(squares))))
    return np.asarray(out)


def _detrended_rms(rows):
    """rms of each row of (k, n) ``rows`` after removing its own constant and linear
    trend, pooled over the rows."""
    rows = np.asarray(rows, float)
    t = np.arange(rows.shape[-1], dtype=float)
    t -= t.mean()
    centred = rows - rows.mean(axis=-1, keepdims=True)
    slope = centred @ t / (t @ t)
    resid = centred - slope[:, None] * t[None, :]
    return float(np.sqrt(np.mean(resid**2)))


# ---- the estimator -------------------------------------------------------------------------


def _default_model(radar, x):
    span = float(np.ptp(x))
    footprint = float(radar.footprint(radar.reference_range))
    # knots every X/8: represents smooth_deviation(max_cycles=2) profiles of 7 rad rms of
    # line-of-sight phase to 0.016–0.043 rad (aperture-detrended, airborne set; X/12:
    # 0.002–0.006 rad); more functions fit the clutter as well: X/12 left a larger
    # residual than X/8 on 8 of 10 benchmark draws, X/40 ≈ 1 rad
    n = int(np.clip(round(span / (footprint / 8)) + 3, 6, 200))
    return MotionModel(horizontal=BSpline(n), vertical=BSpline(n),
                       pointing=BSpline(max(int(round(span / (footprint / 30))) + 3, 8)))


def _check(radar, raw, objective, windows, max_steps):
    if not isinstance(raw, RawData):
        raise ValueError(f"raw={type(raw).__name__} must be sarjax.RawData")
    data = np.asarray(raw.data)
    axes = (int(raw.azimuth.shape[0]), int(raw.range.shape[0]))
    if data.shape != axes:
        raise ValueError(f"raw.data has shape {data.shape}; its axes give {axes}")
    if not np.isfinite(data).all():
        raise ValueError("raw.data has non-finite samples")
    if objective not in OBJECTIVES:
        raise ValueError(f"objective={objective!r}; choose one of {OBJECTIVES}")
    if len(windows) < 1 or any(w < 1 for w in windows):
        raise ValueError(f"windows={windows!r} must be a non-empty list of positive widths [m]")
    if not isinstance(max_steps, int) or max_steps < 0:
        raise ValueError(f"max_steps={max_steps!r} must be an integer >= 0")
    if float(radar.squint) != 0.0:
        raise ValueError(f"radar.squint={float(radar.squint)!r}: autofocus is broadside only")


def autofocus(radar, raw: RawData, *, model: MotionModel | None = None,
              objective: str = "entropy", windows=(48.0, 24.0, 12.0, 8.0, 6.0, 4.0, 4.0, 4.0),
              max_targets: int = 24, min_ratio: float = 30.0, max_steps: int = 200,
              estimate_pointing: bool = True, sharpness_region: str = "targets",
              target_window: float = 16.0, step_check: str = "windows",
              sharpness_passes: int = 3, min_window: float = 8.0,
              initial: Motion | None = None,
              gradient_targets: int = 12, restarts: int = 2,
              restart_rms: float | None = None,
              agreement_tolerance: float = 0.1, map_drift: int | None = None,
              map_drift_blur: float = 30.0, looks: int = 16,
              strict: bool = False) -> AutofocusResult:
    """Estimate Δy(x'), Δz(x') and δ_az(x') from raw data of an unknown scene, and refocus.

    Stages (module docstring): map drift of the looks (``map_drift`` iterations, none by
    default), then range-dependent phase gradients of the dominant scatterers (one
    iteration per entry of ``windows``), then L-BFGS on the sharpness of the windows about
    them through the exact line-of-sight deviation, then the pointing error from the
    Doppler centroid. The image is focused by :func:`sarjax.focus` (ω-k with second-order
    motion compensation of the estimate).

    Args:
        radar: the :class:`~sarjax.Radar` (broadside).
        raw: :class:`~sarjax.RawData` (azimuth, range) with the radar's spacings.
        model: :class:`MotionModel` with :class:`BSpline` horizontal and vertical
            components (default: knots every X/8 of the pulse span, X the footprint at
            r₀: periods down to X/2) and optionally a :class:`BSpline` pointing component.
        objective: ``"entropy"`` (default) or ``"contrast"``.
        windows: half-widths [m] of the azimuth window about each dominant scatterer, one
            phase-gradient iteration each (the first must hold the blur of the initial
            error: ``r max|∂φ/∂x'|/k₀``). Within each entry the half-width is taken from
            the data: 1.5 × the −10 dB width of the median of the scatterers' centred,
            normalised intensity lines, no less than ``min_window``.
        min_window: the smallest half-width [m] the data may choose while the entry
            allows it. Measured on the 10 benchmark draws (2 cm rms Δy, Δz, blur ≈ ±8 m):
            with a floor of 1 m and the mean the windows shrank to ±1 m after one or two
            iterations while 1–3 rad of error remained; with 8 m and the median (and the
            slopes solved jointly) the median over the draws of the worst block's residual
            went from 0.72 to 0.17 rad.
        max_targets: dominant scatterers about which the sharpness stage's windows lie
            (and the step check's).
        gradient_targets: the strongest dominant scatterers used per phase-gradient
            iteration. In the first, blurred images bright clutter passes the peak test
            and its products pull the fit; fewer, stronger scatterers avoid it. Measured
            on draws 100–119 of the benchmark's setup (12 points each): with 12 instead
            of 24 the failing draws improved (worst block 4.1 → 0.16, 2.0 → 1.5,
            1.8 → 0.6, 6.2 → 2.8 rad), one worsened (1.14 → 1.25 rad), the others
            moved by ≤ 0.015 rad; 16 was mixed (6.2 → 4.3 but 1.14 → 2.2 rad); 8 too
            few (two converged draws failed).
        min_ratio: a dominant scatterer's peak over its range bin's median power.
        max_steps: L-BFGS iterations of the sharpness stage (0 = skip it).
        sharpness_region: ``"targets"`` (default): the objective of the image windows
            (±``target_window`` m in azimuth, ±1 range bin) about the dominant scatterers;
            ``"image"``: of the whole swath (measured to over-fit the speckle of clutter:
            its entropy falls below the true track's while the error grows).
        target_window: half-width of those windows [m].
        step_check: how a phase-gradient step is judged: ``"windows"`` (default) by the
            objective of the windows about the current dominant scatterers, ``"image"`` by
            that of the whole swath (speckle-dominated: it admitted steps that made the
            error grow).
        sharpness_passes: L-BFGS runs of the sharpness stage, each on the windows about the
            dominant scatterers of the image the previous one left (measured against one
            pass on 16 drawn clutter scenes of the benchmark's setup: the worst block's
            median 1.1 → 0.8 rad on draws 100–109 and 1.7 → 0.5 rad on 110–115; clearly
            better on four draws, e.g. 2.9 → 0.29 rad, worse on two, 0.10 → 0.20 and
            0.19 → 0.77 rad).
        estimate_pointing: estimate δ_az (else ``motion.pointing`` is None).
        initial: optional :class:`~sarjax.Motion` (Δy, Δz per raw pulse [m], e.g. from
            navigation data or an earlier estimate) to start from; its least-squares
            B-spline fit is the starting point (default: the straight track).
        restarts: further estimates, each from the start plus a smooth random deviation
            (``restart_rms`` rms in Δy and in Δz, up to one cycle per footprint X, drawn
            with keys 0, 1, …): the estimate kept is the one most other starts agree with
            (within ``agreement_tolerance`` in every range block), of those the one whose
            image windows about the dominant scatterers of every run's image are sharpest,
            and :attr:`AutofocusResult.agreement` is its largest difference from another.
            An estimate stuck in a wrong optimum of the objective depends on where it
            started; a converged one does not. Measured on the benchmark's draws 100–119
            (sharpness alone choosing): with two restarts (default) all 5 draws whose
            first estimate failed (0.6–2.8 rad from the truth) were flagged (0.15–3.9 rad
            apart), and 2 of the 15 whose first estimate converged (≤ 0.35 rad), where one
            restart went elsewhere (the kept estimates 0.09 and 0.10 rad from the truth);
            the other 13 agreed within 0.003–0.070 rad. With one restart 4 of the 5
            failures were flagged (both starts of draw 116 ended 0.8 rad off, 0.07 rad
            apart) and none of the 15. It tests uniqueness, not accuracy: an error every
            start shares passes. The sharpest windows alone (the rule before agreement
            came first) kept a wrong estimate where others converged: on draw 109 with
            seven restarts four starts agreed within 0.015–0.044 rad at 0.07 / 0.10 /
            0.15 rad from the truth, and the sharpest windows were a stray's (0.57 / 0.97 /
            1.50 rad; in another process the worst of eight, 2.2 / 4.1 / 5.3 rad).
        restart_rms: rms [m] of the restarts' deviation; None (default): that of the
            first estimate (Δy, Δz without their trend), at least 1 rad of line-of-sight
            phase (1/k₀). A fixed 2 cm flagged all five failures above but also a
            converged estimate of a smaller error (2.5 rad rms, the notebook's case),
            whose restart stopped 0.22 rad away.
        agreement_tolerance: the largest agreement [rad] (any range block) accepted;
            above it an :class:`AutofocusWarning` (``strict``: a ValueError) says the
            estimate is not unique.
        map_drift: iterations of the map-drift stage that runs first from every start
            (0: none; None, the default: 8 where the start's image is blurred by
            ``map_drift_blur`` or more, else none): the
            displacements of ``looks`` looks of the backscatter's structure
            (:mod:`sarjax.inverse._map_drift`), solved for an increment of Δy and Δz; a
            step is kept only when it sharpens the windows about the dominant scatterers,
            and the stage stops at the first that does not. It widens the errors the
            later stages converge from, and costs what they do at the issue's size.
            Measured with 8 (``benchmarks/RESULTS.md``, both variants on the same data):
            at 5 cm rms (≈ 18 rad of line-of-sight phase, draws 200–205) 3 of 6 converged
            (worst block ≤ 0.35 rad) against 1 without it, the others ending 0.45–1.45 rad
            from the truth against 0.46–19 rad; at 2 cm (draws 100–109) 7 of 10 against 8
            and 9 in two runs (on draws 100–119 in another session 15 of 20 against 16),
            so it is not the default; its starts agreed on every converged draw (no false
            warning) where without it 3 of 8 warned. ≈ 0.5 s per iteration and start on
            the airborne preset.
        map_drift_blur: the half-width [m] of the start image's blur (measured as the
            phase-gradient stage measures it, 1.5 × the −10 dB width of the median
            dominant scatterer's line, within the first of ``windows``) from which
            ``map_drift=None`` runs the map-drift stage. Measured on the benchmark's
            draws (starting from the straight track): 4–22 m on the twenty 2 cm draws
            100–119 (where map drift lost a draw), 38–48 m on the six 5 cm draws 200–205
            (where it won two); the true largest blur r max|∂φ/∂x'|/k₀ was 5–15 m and
            23–38 m.
        looks: looks across the Doppler band for the map-drift stage (≥ 3).
        strict: raise instead of warning when the starts disagree.

    Returns:
        :class:`AutofocusResult` (``method="model"``).

    Raises:
        ValueError: on a bad value, naming it; with ``strict``, when the starts disagree
            by more than ``agreement_tolerance``.
    """
    t_start = time.perf_counter()
    _check(radar, raw, objective, windows, max_steps)
    if sharpness_region not in ("targets", "image"):
        raise ValueError(f"sharpness_region={sharpness_region!r}; choose 'targets' or 'image'")
    if step_check not in ("windows", "image"):
        raise ValueError(f"step_check={step_check!r}; choose 'windows' or 'image'")
    if not target_window > 0:
        raise ValueError(f"target_window={target_window!r} must be > 0 [m]")
    if not isinstance(gradient_targets, int) or gradient_targets < 3:
        raise ValueError(f"gradient_targets={gradient_targets!r} must be an integer >= 3")
    if not min_window > 0:
        raise ValueError(f"min_window={min_window!r} must be > 0 [m]")
    if not isinstance(sharpness_passes, int) or sharpness_passes < 1:
        raise ValueError(f"sharpness_passes={sharpness_passes!r} must be an integer >= 1")
    if not isinstance(restarts, int) or restarts < 0:
        raise ValueError(f"restarts={restarts!r} must be an integer >= 0")
    if restart_rms is not None and not restart_rms > 0:
        raise ValueError(f"restart_rms={restart_rms!r} must be > 0 [m]")
    if not agreement_tolerance > 0:
        raise ValueError(f"agreement_tolerance={agreement_tolerance!r} must be > 0 [rad]")
    if map_drift is not None and (not isinstance(map_drift, int) or map_drift < 0):
        raise ValueError(f"map_drift={map_drift!r} must be None or an integer >= 0")
    if not map_drift_blur > 0:
        raise ValueError(f"map_drift_blur={map_drift_blur!r} must be > 0 [m]")
    if not isinstance(looks, int) or looks < 3:
        raise ValueError(f"looks={looks!r} must be an integer >= 3")
    x = np.asarray(raw.azimuth, float)
    model = _default_model(radar, x) if model is None else model
    if not (isinstance(model, MotionModel) and isinstance(model.horizontal, BSpline)
            and isinstance(model.vertical, BSpline)):
        raise ValueError("model must be a MotionModel with BSpline horizontal and vertical "
                         "components")
    timings = {}
    t0 = time.perf_counter()
    focuser = make_focuser(radar, raw)
    design_y = np.asarray(model.horizontal.bind(x).design(jnp.asarray(x)))
    design_z = np.asarray(model.vertical.bind(x).design(jnp.asarray(x)))
    start_y = start_z = np.zeros(x.size)
    if initial is not None:
        if not isinstance(initial, Motion):
            raise ValueError(f"initial={type(initial).__name__} must be a sarjax.Motion")
        start_y, start_z, _ = (np.asarray(v, float) for v in initial.resolve(x.size))
        if not (np.isfinite(start_y).all() and np.isfinite(start_z).all()):
            raise ValueError("initial motion has non-finite values")
    timings["setup"] = time.perf_counter() - t0

    spacing = float(radar.azimuth_spacing)
    footprint = float(radar.footprint(radar.reference_range))
    segment = max(int(footprint / 2 / spacing), 8)
    blur = None
    if map_drift is None:  # the map-drift stage where the start is blurred beyond the
        # reach of the phase gradients' windows
        start = (np.linalg.lstsq(design_y, start_y, rcond=None)[0],
                 np.linalg.lstsq(design_z, start_z, rcond=None)[0])
        blur = _start_blur(focuser, design_y, design_z, start, half_m=windows[0],
                           segment=segment, gradient_targets=gradient_targets,
                           min_ratio=min_ratio, min_window=min_window)
        map_drift = MAP_DRIFT_ITERATIONS if blur is not None and blur >= map_drift_blur else 0
    settings = dict(objective=objective, windows=windows, max_targets=max_targets,
                    min_ratio=min_ratio, max_steps=max_steps, segment=segment,
                    sharpness_region=sharpness_region, target_half=int(round(
                        target_window / spacing)), step_check=step_check,
                    sharpness_passes=sharpness_passes, min_window=min_window,
                    gradient_targets=gradient_targets, map_drift=map_drift, looks=looks)
    runs, notes, profiles = [], [], []  # profiles: each run's (Δy, Δz) without the trend
    for k in range(restarts + 1):
        dy0, dz0 = start_y, start_z
        if k > 0:  # the k-th restart: a smooth random deviation added to the start
            scale = restart_rms
            if scale is None:  # the first estimate's size, at least 1 rad of phase
                scale = max(float(np.sqrt(np.mean(np.concatenate(profiles[0]) ** 2))),
                            1.0 / float(radar.wavenumber))
            rng = np.random.default_rng(k - 1)
            dy0 = dy0 + smooth_deviation(x, key=rng, rms=scale, max_cycles=1,
                                         aperture=footprint)
            dz0 = dz0 + smooth_deviation(x, key=rng, rms=scale, max_cycles=1,
                                         aperture=footprint)
        start = (np.linalg.lstsq(design_y, dy0, rcond=None)[0],
                 np.linalg.lstsq(design_z, dz0, rcond=None)[0])
        with warnings.catch_warnings(record=True) as caught:  # re-issued for the one kept
            warnings.simplefilter("always")
            runs.append(_estimate(focuser, design_y, design_z, start, **settings))
        notes.append(caught)
        profiles.append((_remove_trend(design_y @ runs[-1].c_y),
                         _remove_trend(design_z @ runs[-1].c_z)))
        for stage in ("map drift", "gradients", "sharpness"):
            timings[stage] = timings.get(stage, 0.0) + runs[-1].timings[stage]

    t0 = time.perf_counter()
    kept, agreement, support = 0, None, None
    if len(runs) > 1:
        kept, agreement, support = _choose(radar, raw, focuser, profiles, settings,
                                           agreement_tolerance)
        if float(np.max(agreement)) > agreement_tolerance:
            message = (
                f"autofocus: the estimates from {len(runs)} starts differ by up to "
                f"{float(np.max(agreement)):.3g} rad of line-of-sight phase ({support - 1} of the "
                f"other {len(runs) - 1} agree with the estimate kept; range blocks: "
                f"{', '.join(f'{v:.3g}' for v in agreement)} rad; agreement_tolerance="
                f"{agreement_tolerance:g}): the sharpness has more than one optimum here and "
                "the estimate kept may be one of the wrong ones; start from navigation data "
                "(initial=), or fit calibration targets with sarjax.inverse.fit_motion")
            if strict:
                raise ValueError(f"strict=True: {message}")
            warnings.warn(message, AutofocusWarning, stacklevel=2)
    timings["restarts"] = time.perf_counter() - t0
    for note in notes[kept]:
        warnings.warn_explicit(note.message, note.category, note.filename, note.lineno)
    dy, dz = profiles[kept]
    run = runs[kept]

    # ---- 3. pointing ------------------------------------------------------------------------
    t0 = time.perf_counter()
    pointing = None
    if estimate_pointing:
        pointing_model = model.pointing if isinstance(model.pointing, BSpline) else BSpline(
            _default_model(radar, x).pointing.num_basis())
        pointing = _pointing(radar, focuser, dy, dz, pointing_model.bind(x), x)
    timings["pointing"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    motion = Motion(horizontal=dy, vertical=dz, pointing=pointing)
    image = focus(radar, raw, motion=Motion(horizontal=dy, vertical=dz))
    timings["image"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - t_start
    fixed = ("mean horizontal", "linear horizontal", "mean vertical", "linear vertical")
    if estimate_pointing:
        fixed = fixed + ("pointing slower than X/2",)
    history = run.log if len(runs) == 1 else run.log + (
        (f"start {kept} of {len(runs)} kept", timings["restarts"], float(np.max(agreement))),)
    if blur is not None:
        history = ((f"start blur ±{blur:.1f} m: {map_drift} map-drift iterations "
                    f"(map_drift_blur={map_drift_blur:g} m)", 0.0, blur),) + history
    return AutofocusResult(
        motion=motion, phase_history=None, image=image, method="model", objective=objective,
        history=history, timings=timings, fixed=fixed,
        coverage=run.coverage / max(run.coverage.max(), 1e-300), agreement=agreement,
        agreeing=support,
    )


@dataclasses.dataclass(frozen=True)
class _Run:
    """One start's estimate: B-spline coefficients, stage log, seconds per stage and the
    dominant scatterers' weight per pulse."""

    c_y: np.ndarray
    c_z: np.ndarray
    log: tuple
    timings: dict
    coverage: np.ndarray


def _estimate(focuser, design_y, design_z, start, *, objective, windows, max_targets,
              min_ratio, max_steps, segment, sharpness_region, target_half, step_check,
              sharpness_passes, min_window, gradient_targets, map_drift, looks) -> _Run:
    """Stages 1 and 2 of :func:`autofocus` from the coefficients ``start``."""
    spacing = float(focuser.radar.azimuth_spacing)
    num_pulses = design_y.shape[0]
    log, timings = [], {}

    # ---- 1. range-dependent phase gradients -------------------------------------------------
    t0 = time.perf_counter()
    c_y, c_z = (np.asarray(c, float) for c in start)
    coverage = np.zeros(num_pulses)
    phase = _los_phase(focuser, jnp.asarray(design_y @ c_y), jnp.asarray(design_z @ c_z))
    image = _pga.jax_image(focuser, phase)
    value = float(_sharpness_value(image, focuser.energy, objective))
    log.append(("start", time.perf_counter() - t0, value))

    # ---- 0. map drift of the looks ------------------------------------------------------
    derivatives = ((np.gradient(design_y, spacing, axis=0),
                    np.gradient(design_z, spacing, axis=0)) if map_drift else None)
    for i in range(map_drift):
        step, used = _map_drift.map_drift_increment(focuser, phase, derivatives,
                                                    num_looks=looks)
        if step is None:
            break
        trial_phase = _los_phase(focuser, jnp.asarray(design_y @ (c_y + step[0])),
                                 jnp.asarray(design_z @ (c_z + step[1])))
        region = _target_region(focuser, image, segment, max_targets, min_ratio, target_half)
        if (float(_window_value(focuser, trial_phase, region, objective))
                >= float(_window_value(focuser, phase, region, objective))):
            log.append((f"map drift {i} (rejected)", time.perf_counter() - t0, value))
            break  # the looks' displacements are at their noise: the finer stages follow
        c_y, c_z, phase = c_y + step[0], c_z + step[1], trial_phase
        image = _pga.jax_image(focuser, phase)
        value = float(_sharpness_value(image, focuser.energy, objective))
        log.append((f"map drift {i} ({used} equations)", time.perf_counter() - t0, value))
    timings["map drift"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    previous_half = num_pulses
    for i, half_m in enumerate(windows):
        rows, cols, half = _dominant_blur(
            np.abs(np.asarray(image)) ** 2, num_pulses,
            min(max(int(round(half_m / spacing)), 2), previous_half),
            segment=segment, gradient_targets=gradient_targets, min_ratio=min_ratio,
            min_window=min_window, spacing=spacing)
        if half is None:
            warnings.warn(f"autofocus: {rows.size} dominant scatterers (peak ≥ {min_ratio:g}× "
                          f"the range bin's median) in iteration {i}: the phase-gradient "
                          "stage stops; the estimate may be poor", AutofocusWarning,
                          stacklevel=3)
            break
        previous_half = half
        z = np.asarray(_pga.target_products(focuser, phase, jnp.asarray(rows),
                                            jnp.asarray(cols), jnp.asarray(half)))
        dy_c, dz_c = _pga.motion_increment(z, rows, focuser, design_y, current=(c_y, c_z))
        trial_phase = _los_phase(focuser, jnp.asarray(design_y @ (c_y + dy_c)),
                                 jnp.asarray(design_z @ (c_z + dz_c)))
        trial = _pga.jax_image(focuser, trial_phase)
        trial_value = float(_sharpness_value(trial, focuser.energy, objective))
        if step_check == "windows":  # judged on the windows about the dominant scatterers
            region = _target_region(focuser, image, segment, max_targets, min_ratio,
                                    target_half)
            worse = (float(_window_value(focuser, trial_phase, region, objective))
                     >= float(_window_value(focuser, phase, region, objective)))
        else:
            worse = trial_value >= value
        if worse:  # a step that does not sharpen the image is not taken
            log.append((f"gradients {i} (rejected)", time.perf_counter() - t0, trial_value))
            continue
        c_y, c_z, phase, image, value = c_y + dy_c, c_z + dz_c, trial_phase, trial, trial_value
        cov = np.sum(np.abs(z), axis=0)
        coverage = np.concatenate([[cov[0]], 0.5 * (cov[1:] + cov[:-1]), [cov[-1]]])
        log.append((f"gradients {i} (±{half} columns)", time.perf_counter() - t0, value))
    timings["gradients"] = time.perf_counter() - t0

    # ---- 2. sharpness ---------------------------------------------------------------------
    t0 = time.perf_counter()
    for i in range(sharpness_passes if max_steps > 0 else 0):
        region = None
        if sharpness_region == "targets":
            if i > 0:  # the windows about the scatterers of the image just sharpened
                image = _pga.jax_image(focuser, _los_phase(
                    focuser, jnp.asarray(design_y @ c_y), jnp.asarray(design_z @ c_z)))
            region = _target_region(focuser, image, segment, max_targets, min_ratio,
                                    target_half)
        c, value = _sharpen(focuser, _LineOfSight(jnp.asarray(design_y), jnp.asarray(design_z)),
                            np.concatenate([c_y, c_z]), 1.0 / float(focuser.radar.wavenumber),
                            objective, max_steps, region)
        c_y, c_z = c[: c_y.size], c[c_y.size:]
        log.append((f"sharpness {i}", time.perf_counter() - t0, value))
    timings["sharpness"] = time.perf_counter() - t0
    return _Run(c_y=c_y, c_z=c_z, log=tuple(log), timings=timings, coverage=coverage)


def _start_blur(focuser, design_y, design_z, start, *, half_m, segment, gradient_targets,
                min_ratio, min_window):
    """Half-width [m] of the blur of the image the coefficients ``start`` focus, as the
    phase-gradient stage's first iteration measures it (``_pga.blur_half_width`` of the
    dominant scatterers' lines within ``half_m``); None with fewer than 3 of them."""
    spacing = float(focuser.radar.azimuth_spacing)
    phase = _los_phase(focuser, jnp.asarray(design_y @ start[0]),
                       jnp.asarray(design_z @ start[1]))
    _, _, half = _dominant_blur(
        np.abs(np.asarray(_pga.jax_image(focuser, phase))) ** 2, design_y.shape[0],
        max(int(round(half_m / spacing)), 2), segment=segment,
        gradient_targets=gradient_targets, min_ratio=min_ratio, min_window=min_window,
        spacing=spacing)
    return None if half is None else spacing * half


def _dominant_blur(power, num_pulses, cap, *, segment, gradient_targets, min_ratio,
                   min_window, spacing):
    """(rows, cols, half-width [columns]) of the dominant scatterers of an image's
    ``power`` (range, n_fft; ``num_pulses`` columns hold pulses) and their blur
    (``_pga.blur_half_width``, the median line, at most ``cap`` columns, at least
    ``min_window`` [m]); half-width None with fewer than 3 of them. What each
    phase-gradient iteration measures first."""
    rows, cols = _pga.select_targets(power, num_pulses, segment=segment,
                                     max_targets=gradient_targets, min_ratio=min_ratio,
                                     exclusion=cap)
    if rows.size < 3:
        return rows, cols, None
    return rows, cols, _pga.blur_half_width(power, rows, cols, cap, average="median",
                                            floor=max(int(round(min_window / spacing)), 2))


def _choose(radar, raw, focuser, profiles, settings, tolerance):
    """(index of the estimate kept, (block,) agreement [rad], number of starts that agree
    with it) of the starts' (Δy, Δz) ``profiles``, by :func:`_consensus`: the estimate most
    other starts agree with (aperture-detrended line-of-sight phase difference ≤
    ``tolerance`` in every range block), of those the one whose windows about the dominant
    scatterers of every start's image have the lowest summed objective (a window set of one
    image alone favours the estimate that made it; the whole swath is dominated by speckle).
    The agreement is its largest difference from another start per range block."""
    objective = settings["objective"]
    phases = [_los_phase(focuser, jnp.asarray(dy), jnp.asarray(dz)) for dy, dz in profiles]
    regions = [_target_region(focuser, _pga.jax_image(focuser, phase), settings["segment"],
                              settings["max_targets"], settings["min_ratio"],
                              settings["target_half"]) for phase in phases]
    values = [sum(float(_window_value(focuser, phase, region, objective))
                  for region in regions) for phase in phases]
    blocks = range_blocks(radar, raw.range)
    motions = [Motion(horizontal=dy, vertical=dz) for dy, dz in profiles]
    n = int(raw.azimuth.shape[0])
    count = len(profiles)
    differences = np.zeros((count, count, len(blocks)))
    for i in range(count):
        for j in range(i + 1, count):
            differences[i, j] = differences[j, i] = _block_phase_rms(
                radar, lambda ranges, a=motions[i], b=motions[j]: (
                    true_line_of_sight_phase(radar, a, ranges)
                    - true_line_of_sight_phase(radar, b, ranges)), n, blocks)
    kept, support = _consensus(differences, values, tolerance)
    return kept, np.max(np.delete(differences[kept], kept, axis=0), axis=0), support


def _consensus(differences, values, tolerance):
    """(index kept, starts within ``tolerance`` of it, itself included) of estimates with
    (start, start, block) pairwise ``differences`` [rad] and sharpness ``values`` (lower is
    sharper): the estimate with the most starts within ``tolerance`` in every block, ties
    broken by the lowest value.

    An estimate stuck in a wrong optimum depends on where it started; converged ones agree.
    The sharpness of the starts' windows alone kept a wrong one: on the benchmark's draw
    109 with seven restarts four starts ended within 0.015–0.044 rad of each other, at
    0.07 / 0.10 / 0.15 rad from the truth, four elsewhere, and the sharpest windows were
    those of a stray (0.57 / 0.97 / 1.50 rad). Several starts can share a wrong optimum
    (draw 103: three of eight within 0.08 rad of each other, all ≥ 0.70 / 1.29 / 1.94 rad
    from the truth), so agreement is not accuracy and any disagreement is still
    reported."""
    close = np.max(np.asarray(differences), axis=-1) <= tolerance
    support = np.sum(close | np.eye(close.shape[0], dtype=bool), axis=1)
    order = sorted(range(len(values)), key=lambda i: (-support[i], values[i]))
    return order[0], int(support[order[0]])


@jax.jit
def _los_phase_jit(radar, azimuth, rng, dy, dz):
    los = geometry.line_of_sight_deviation(dy[None, :], dz[None, :], rng[:, None], 0.0,
                                           radar.height)
    return radar.wavenumber * los


@functools.partial(jax.jit, static_argnames="objective")
def _sharpness_value(image, energy, objective="entropy"):
    return sharpness_loss(image, energy, objective)


def _los_phase(focuser: AzimuthFocuser, dy, dz):
    return _los_phase_jit(focuser.radar, focuser.azimuth, focuser.range, dy, dz)


def _remove_trend(profile):
    t = np.arange(profile.size, dtype=float)
    t -= t.mean()
    p = profile - profile.mean()
    return p - t * (t @ p) / (t @ t)


class _LineOfSight(eqx.Module):
    """Phase model of the sharpness stage: Δy = B_y c[:n], Δz = B_z c[n:] (c in metres)
    through the exact line-of-sight deviation at each range bin."""

    design_y: jnp.ndarray
    design_z: jnp.ndarray

    def __call__(self, foc, c, band):
        n = self.design_y.shape[1]
        return foc.line_of_sight_phase(self.design_y @ c[:n], self.design_z @ c[n:],
                                       range_index=band)


class _History(eqx.Module):
    """Phase model of one history shared by all ranges: φ = B c (c in radians)."""

    design: jnp.ndarray

    def __call__(self, foc, c, band):
        rows = foc.range.shape[0] if band is None else band.shape[0]
        return jnp.broadcast_to((self.design @ c)[None, :], (rows, self.design.shape[0]))


def _target_region(focuser, image, segment, max_targets, min_ratio, half):
    """(range index (3k,), columns (3k, 2·half + 1)) of the windows about the dominant
    scatterers of ``image`` (their range bins ±1)."""
    power = np.abs(np.asarray(image)) ** 2
    rows, cols = _pga.select_targets(power, focuser.num_pulses, segment=segment,
                                     max_targets=max_targets, min_ratio=min_ratio,
                                     exclusion=8)
    n_rows = int(focuser.range.shape[0])
    band = np.clip(rows[:, None] + np.arange(-1, 2)[None, :], 0, n_rows - 1)
    n_fft = int(focuser.compressed.shape[-1])
    columns = (np.repeat(cols, 3)[:, None] + np.arange(-half, half + 1)[None, :]) % n_fft
    return jnp.asarray(band.ravel()), jnp.asarray(columns)


@functools.partial(eqx.filter_jit)
def _window_value(focuser, phase, region, objective):
    """Objective of the windows ``region`` (:func:`_target_region`) of the image after
    compensating the (range, pulse) ``phase``, normalised by their own energy."""
    band, columns = region
    image = focuser.image(phase[band], range_index=band)
    windows = jnp.take_along_axis(image, columns, axis=-1)
    energy = jnp.sum(jnp.real(windows) ** 2 + jnp.imag(windows) ** 2)
    return sharpness_loss(windows, energy, objective)


def _sharpness_of(theta, focuser, phase_model, c0, step, region, objective):
    """The loss :func:`_sharpen` minimises at ``θ`` (its arguments)."""
    c = c0 + theta * step
    if region is None:
        return sharpness_loss(focuser.image(phase_model(focuser, c, None)), focuser.energy,
                              objective)
    band, columns = region
    image = focuser.image(phase_model(focuser, c, band), range_index=band)
    windows = jnp.take_along_axis(image, columns, axis=-1)
    energy = jnp.sum(jnp.real(windows) ** 2 + jnp.imag(windows) ** 2)
    return sharpness_loss(windows, energy, objective)


# one program per shape for every start, pass and call (a loss defined inside _sharpen
# was a new function each time: nine compilations per autofocus call, 2.1 s of a 6.0 s
# call on the notebook's 512 × 160 scene)
_sharpness_loss_and_gradient = value_and_grad(_sharpness_of)


def _sharpen(focuser, phase_model, c0, step, objective, max_steps, region=None):
    """L-BFGS on the sharpness w.r.t. the coefficients ``c = c0 + step · θ`` of
    ``phase_model`` (``step``: one unit of θ ≈ 1 rad of phase).

    ``region``: None (the whole swath) or (range index, columns) from
    :func:`_target_region`: the objective of the image windows about the dominant
    scatterers, normalised by their own energy, so that the speckle between them does not
    drive the fit.

    Returns:
        (c, final objective value).
    """
    c0 = jnp.asarray(c0)
    step_array = jnp.asarray(step, float)  # an argument of the program, not a constant

    def fun(theta):
        value, grad = _sharpness_loss_and_gradient(jnp.asarray(theta), focuser, phase_model,
                                                   c0, step_array, region, objective)
        return float(value), np.asarray(grad, float)

    res = scipy.optimize.minimize(fun, np.zeros(c0.shape[0]), jac=True, method="L-BFGS-B",
                                  options=dict(maxiter=max_steps, maxcor=20, ftol=1e-15,
                                               gtol=1e-12))
    return np.asarray(c0) + res.x * step, float(res.fun)


def _pointing(radar, focuser, dy, dz, spline, x):
    """δ_az(x') [rad] from the Doppler centroid of the motion-compensated data.

    A pointing error δ_az moves the beam centre to x' − r δ_az (physics.md §6), i.e. the
    Doppler centroid to ``f_dc = −2v δ_az/λ``. Per pulse, the average cross-correlation
    of adjacent compensated pulses over all kept range bins,
    ``c(p) = Σ_r s̃(x'_{p+1}, r) s̃*(x'_p, r)``, has the phase ``2π f_dc/PRF`` (Madsen
    1989); it is fitted by the B-spline ``spline`` (weighted by |c|). The backscatter's
    variation across the beam (fields, edges, bright points) shifts the centroid too, slowly:
    it is a convolution of the scene with the footprint. So the components slower than
    about X/2 (a smooth B-spline with knots every X/4, X the footprint at r₀) are removed
    from the estimate, with them any slow pointing error (measured on a drawn clutter scene
    with the seed jitter, T_b = T_s/10: 17 % rms error, 1.3e-3 rad rms without this step,
    i.e. worse than no estimate).
    """
    correlation = np.asarray(_adjacent_correlation(focuser, jnp.asarray(dy), jnp.asarray(dz)))
    f_dc = np.angle(correlation) * float(radar.prf) / (2 * np.pi)  # (pulse − 1,)
    pointing = -f_dc * float(radar.wavelength) / (2 * float(radar.velocity))
    mid = 0.5 * (x[1:] + x[:-1])
    design = np.asarray(spline.design(jnp.asarray(mid)))
    w = np.sqrt(np.abs(correlation))
    coef = np.linalg.lstsq(design * w[:, None], pointing * w, rcond=None)[0]
    profile = np.asarray(spline.design(jnp.asarray(x))) @ coef
    footprint = float(radar.footprint(radar.reference_range))
    slow = BSpline(max(int(round(np.ptp(x) / (footprint / 4))) + 3, 4)).bind(x)
    slow_design = np.asarray(slow.design(jnp.asarray(x)))
    profile = profile - slow_design @ np.linalg.lstsq(slow_design, profile, rcond=None)[0]
    return profile - profile.mean()


@eqx.filter_jit
def _adjacent_correlation(focuser, dy, dz):
    phase = focuser.line_of_sight_phase(dy, dz)
    n = focuser.num_pulses
    data = focuser.compressed[:, :n] * jnp.exp(1j * phase).astype(focuser.compressed.dtype)
    return jnp.sum(data[:, 1:] * jnp.conj(data[:, :-1]), axis=0)


def image_metrics(image) -> dict:
    """Entropy of an image (NumPy)."""
    return dict(entropy=image_entropy(np.asarray(image.data)))


# ---- baselines -------------------------------------------------------------------------------


def no_estimate(raw: RawData) -> AutofocusResult:
    """The zero estimate (the nominal straight track), for comparisons."""
    n = int(raw.azimuth.shape[0])
    return AutofocusResult(
        motion=Motion(horizontal=np.zeros(n), vertical=np.zeros(n)), phase_history=None,
        image=None, method="none", objective=None, history=(), timings={}, fixed=(),
        coverage=np.ones(n),
    )


def _phase_image(radar, raw, phase):
    """ω-k image after removing one phase history φ(x') [rad] at every range (first-order
    motion compensation of the vertical deviation that has φ as its line-of-sight phase
    at r₀)."""
    cos_look = float(radar.height) / float(radar.reference_range)
    vertical = np.asarray(phase) / (float(radar.wavenumber) * cos_look)
    return focus(radar, raw, motion=Motion(vertical=vertical),
                 motion_compensation="first_order")


def pga(radar, raw: RawData, *, windows=(48.0, 24.0, 12.0, 6.0, 3.0), max_targets: int = 24,
        min_ratio: float = 30.0) -> AutofocusResult:
    """Phase gradient autofocus (:mod:`sarjax.inverse._pga`): one phase history φ(x') [rad]
    for every range, the baseline of :func:`autofocus`. Each iteration (one per entry of
    ``windows``, half-widths [m]) is kept only when it sharpens the image (entropy).

    Returns:
        :class:`AutofocusResult` with ``phase_history`` and ``method="pga"``.
    """
    _check(radar, raw, "entropy", windows, 0)
    t0 = time.perf_counter()
    focuser = make_focuser(radar, raw)
    spacing = float(radar.azimuth_spacing)
    segment = max(int(float(radar.footprint(radar.reference_range)) / 2 / spacing), 8)
    log = []
    phase, coverage = _pga.phase_gradient_autofocus(
        focuser, windows=[max(int(round(w / spacing)), 2) for w in windows], segment=segment,
        max_targets=max_targets, min_ratio=min_ratio, log=log)
    image = _phase_image(radar, raw, phase)
    return AutofocusResult(
        motion=Motion(), phase_history=phase, image=image, method="pga", objective=None,
        history=tuple(log), timings={"total": time.perf_counter() - t0},
        fixed=("mean phase", "linear phase"), coverage=coverage / max(coverage.max(), 1e-300),
    )


def sharpness_phase(radar, raw: RawData, *, num_basis: int | None = None,
                    objective: str = "entropy", max_steps: int = 200,
                    initial: AutofocusResult | None = None,
                    sharpness_region: str = "targets",
                    target_window: float = 16.0) -> AutofocusResult:
    """Sharpness-only autofocus of one phase history φ(x') = B(x') c [rad] shared by all
    ranges (the second baseline): L-BFGS on the objective from ``initial``'s history (or
    from PGA's, computed here when None), on the same windows about the dominant
    scatterers as :func:`autofocus` (``sharpness_region``, ``target_window`` as there).

    Returns:
        :class:`AutofocusResult` with ``phase_history`` and ``method="sharpness_phase"``.
    """
    _check(radar, raw, objective, (1.0,), max_steps)
    if sharpness_region not in ("targets", "image"):
        raise ValueError(f"sharpness_region={sharpness_region!r}; choose 'targets' or 'image'")
    t0 = time.perf_counter()
    start = pga(radar, raw) if initial is None else initial
    if start.phase_history is None:
        raise ValueError("initial must be a single-phase-history result (pga, sharpness_phase)")
    focuser = make_focuser(radar, raw)
    x = np.asarray(raw.azimuth, float)
    n_basis = _default_model(radar, x).horizontal.num_basis() if num_basis is None else num_basis
    design = np.asarray(BSpline(n_basis).bind(x).design(jnp.asarray(x)))
    c0 = np.linalg.lstsq(design, start.phase_history, rcond=None)[0]
    region = None
    if sharpness_region == "targets":
        spacing = float(radar.azimuth_spacing)
        segment = max(int(float(radar.footprint(radar.reference_range)) / 2 / spacing), 8)
        image = _pga.jax_image(focuser, jnp.asarray(design @ c0)[None, :])
        region = _target_region(focuser, image, segment, 24, 30.0,
                                int(round(target_window / spacing)))
    c, value = _sharpen(focuser, _History(jnp.asarray(design)), c0, 1.0, objective,
                        max_steps, region)
    phase = design @ c
    image = _phase_image(radar, raw, phase)
    return AutofocusResult(
        motion=Motion(), phase_history=phase, image=image, method="sharpness_phase",
        objective=objective, history=start.history + (("sharpness", 0.0, value),),
        timings={"total": time.perf_counter() - t0}, fixed=("mean phase", "linear phase"),
        coverage=start.coverage,
    )


# ---- scenes nobody described ----------------------------------------------------------------


def random_scene(radar, azimuth, *, key, num_points: int = 12, point_amplitude=(15.0, 40.0),
                 num_fields: int = 12, field_db=(-10.0, 5.0), spacing=(0.5, None),
                 min_look_angle=SCENE_MIN_LOOK_ANGLE, far_margin: float = 30.0):
    """A random clutter scene: speckle over fields of different backscatter (edges), a
    dark straight road, and a few bright points (NumPy draws, float64).

    The clutter is a :class:`~sarjax.ReflectivityGrid` of complex Gaussian reflectivities
    (E|γ|² = the field's level, 0 dB = 1 per cell) on ``spacing`` = (azimuth, range) [m]
    (range default: the range sample) over the pulses' span extended by half a far-range
    footprint at each end (every pulse sees a full footprint), from the range of look angle
    ``min_look_angle`` to ``far_margin`` before the far edge of the range window. The
    fields are a Voronoi partition of ``num_fields`` random sites with levels uniform in
    ``field_db``; the road is 6 m wide at −20 dB. The points have |γ| uniform in
    ``point_amplitude`` and random phase, at positions uniform within the pulses' span.

    Args:
        radar: the :class:`~sarjax.Radar` (its range window: ``near_range``, ``num_range``).
        azimuth: (pulse,) pulse positions x' [m].
        key: integer seed or ``numpy.random.Generator``.

    Returns:
        (clutter :class:`~sarjax.ReflectivityGrid`, points :class:`~sarjax.PointTargets`).
    """
    from ..scene import PointTargets, ReflectivityGrid

    rng = key if isinstance(key, np.random.Generator) else np.random.default_rng(key)
    x = np.asarray(azimuth, float)
    r_far = float(radar.near_range) + (radar.num_range - 1) * float(radar.range_spacing)
    r_near = float(radar.height) / np.cos(min_look_angle)
    r_far -= far_margin + float(radar.pulse_half_length)
    if r_far <= r_near:
        raise ValueError(f"the range window ends at {r_far:.0f} m, before the ground at "
                         f"{r_near:.0f} m")
    half = float(radar.footprint(r_far)) / 2
    dx = float(spacing[0])
    dr = float(radar.range_spacing) if spacing[1] is None else float(spacing[1])
    ax = np.arange(x.min() - half, x.max() + half, dx)
    rg = np.arange(r_near, r_far, dr)
    sites = np.stack([rng.uniform(ax[0], ax[-1], num_fields),
                      rng.uniform(rg[0], rg[-1], num_fields)], axis=1)
    xx, rr = np.meshgrid(ax, rg, indexing="ij")
    scale_r = np.ptp(ax) / max(np.ptp(rg), 1.0)  # fields of similar extent in x and r
    d = ((xx[..., None] - sites[:, 0]) ** 2 + ((rr[..., None] - sites[:, 1]) * scale_r) ** 2)
    level_db = rng.uniform(*field_db, num_fields)[d.argmin(axis=-1)]
    angle = rng.uniform(0, np.pi)
    centre = (rng.uniform(ax[0], ax[-1]), rng.uniform(rg[0], rg[-1]))
    road = np.abs((xx - centre[0]) * np.sin(angle) - (rr - centre[1]) * np.cos(angle)
                  * scale_r) < 3.0
    level_db = np.where(road, -20.0, level_db)
    amplitude = np.sqrt(10 ** (level_db / 10) / 2)
    gamma = amplitude * (rng.normal(size=xx.shape) + 1j * rng.normal(size=xx.shape))
    clutter = ReflectivityGrid(gamma, ax, rg)
    px = rng.uniform(x.min(), x.max(), num_points)
    pr = rng.uniform(rg[0], rg[-1], num_points)
    pa = rng.uniform(*point_amplitude, num_points) * np.exp(
        1j * rng.uniform(-np.pi, np.pi, num_points))
    return clutter, PointTargets(azimuth=px, range=pr, reflectivity=pa)
