"""Input checks at the API boundary: bad input raises ValueError naming the value.

Checks run eagerly on concrete values; inside a user's own ``jit`` (traced values)
they are skipped, and the structural checks (shapes) still apply.
"""

from __future__ import annotations

import warnings

import jax
import numpy as np

from .simulators._base import is_traced as is_traced

# the window and sampling measures live with the budgets; re-exported here
from .simulators._budgets import doppler_band as doppler_band
from .simulators._budgets import echoes_outside_window as echoes_outside_window
from .simulators._budgets import scene_positions as scene_positions


def _concrete(value):
    if isinstance(value, jax.core.Tracer):
        return None
    return np.asarray(value)


def require_positive(obj, names, where):
    for name in names:
        v = _concrete(getattr(obj, name))
        if v is None:
            continue
        if not np.all(np.isfinite(v)):
            raise ValueError(f"{where}.{name}={v} is not finite")
        if not np.all(v > 0):
            raise ValueError(f"{where}.{name}={v} must be > 0")


_RADAR_SCALARS = (
    "carrier_frequency", "bandwidth", "chirp_duration", "sampling_rate", "prf", "velocity",
    "height", "antenna_length", "reference_range", "near_range", "squint",
)


def check_radar(radar):
    for name in _RADAR_SCALARS:
        shape = np.shape(getattr(radar, name))
        if shape != ():
            raise ValueError(f"radar.{name} must be a scalar, got shape {shape}")
    require_positive(
        radar,
        ["carrier_frequency", "bandwidth", "chirp_duration", "sampling_rate", "prf",
         "velocity", "height", "antenna_length", "reference_range", "near_range"],
        "radar",
    )
    fs, bw = _concrete(radar.sampling_rate), _concrete(radar.bandwidth)
    if fs is not None and bw is not None and fs < bw:
        raise ValueError(
            f"radar.sampling_rate={float(fs):g} Hz is below radar.bandwidth={float(bw):g} Hz: "
            "complex baseband sampling needs f_s >= Δf"
        )
    sq = _concrete(radar.squint)
    if sq is not None and not np.isfinite(sq):
        raise ValueError(f"radar.squint={sq} is not finite")


def _finite_sum(values) -> bool:
    """Whether the sum of ``values`` is finite (False also for an overflowing sum)."""
    with np.errstate(over="ignore", invalid="ignore"):
        return bool(np.isfinite(np.sum(values)))


def check_scene(scene, radar):
    if scene.num_scatterers == 0:
        raise ValueError("the scene is empty (0 scatterers): nothing to simulate")
    for name in ("azimuth", "range", "reflectivity", "height", "velocity_range",
                 "velocity_azimuth"):
        if not hasattr(scene, name):
            continue
        v = _concrete(getattr(scene, name))
        # a sum is finite when every value is (one pass; the slow search only on failure)
        if v is not None and not _finite_sum(v) and not np.all(np.isfinite(v)):
            bad = np.flatnonzero(~np.isfinite(v))[:5]
            raise ValueError(f"scene.{name} has non-finite values {v[bad]} at indices {bad}")
    r, h, H = _concrete(scene.range), _concrete(scene.height), _concrete(radar.height)
    if r is not None and h is not None and r.ndim == 1 and h.ndim == 2:  # grid
        if H is not None and np.all(r > H - np.min(h, axis=0)):
            return  # the lowest cell of every range line is below the platform's range
        r = np.broadcast_to(r[None, :], h.shape).ravel()
        h = h.ravel()
    if r is not None and h is not None and H is not None:
        bad = np.flatnonzero(r <= H - h)
        if bad.size:
            raise ValueError(
                f"scene.range={r[bad[:5]]} m is not beyond the platform height above the "
                f"scatterer (H − h = {(H - h)[bad[:5]]} m): no real ground position"
            )


def check_motion(motion, num_pulses):
    """Each given component is (num_pulses,) or, for a batch of B realizations,
    (B, num_pulses) with one B for every batched component. Returns B (None: unbatched)."""
    batch, first = None, None
    for name in ("horizontal", "vertical", "pointing"):
        v = getattr(motion, name)
        if v is None:
            continue
        if v.ndim not in (1, 2) or v.shape[-1] != num_pulses:
            raise ValueError(
                f"motion.{name} has shape {v.shape}, expected ({num_pulses},): one value per "
                f"pulse (or (batch, {num_pulses}) for a batch of realizations)"
            )
        if v.ndim == 2:
            if v.shape[0] == 0:
                raise ValueError(f"motion.{name} has shape {v.shape}: a batch of 0 realizations")
            if batch is not None and v.shape[0] != batch:
                raise ValueError(
                    f"motion.{name} has shape {v.shape} but motion.{first} has {batch} "
                    "realizations: batched components need the same leading (batch) axis"
                )
            batch, first = v.shape[0], name
        c = _concrete(v)
        if c is not None and not np.all(np.isfinite(c)):
            if c.ndim == 1:
                bad = np.flatnonzero(~np.isfinite(c))[:5]
                raise ValueError(f"motion.{name} has non-finite values {c[bad]} at pulses {bad}")
            rows, cols = np.nonzero(~np.isfinite(c))
            rows, cols = rows[:5], cols[:5]
            raise ValueError(
                f"motion.{name} has non-finite values {c[rows, cols]} at (realization, pulse) "
                f"{list(zip(rows.tolist(), cols.tolist(), strict=True))}"
            )
    return batch


def check_dtype(dtype):
    """``dtype`` as a complex64 or complex128 ``numpy.dtype``; anything else: a
    ValueError naming it."""
    try:
        resolved = np.dtype(dtype)
    except TypeError:
        raise ValueError(f"dtype={dtype!r} must be complex64 or complex128") from None
    if resolved not in (np.complex64, np.complex128):
        raise ValueError(f"dtype={resolved} must be complex64 or complex128")
    return resolved


def check_grid(num_pulses, num_range):
    for name, n in (("num_pulses", num_pulses), ("num_range", num_range)):
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise ValueError(f"{name}={n!r} must be a positive integer")


def check_finite_scalar(value, name):
    v = _concrete(value)
    if v is None:
        return
    if np.shape(v) != ():
        raise ValueError(f"{name} must be a scalar, got shape {np.shape(v)}")
    if not np.isfinite(v):
        raise ValueError(f"{name}={v} is not finite")


def _motion_is_ideal(motion) -> bool:
    return motion is None or motion.is_ideal


def check_supported(simulator, radar, scene, motion=None):
    """Refuse model features a simulator does not implement (never ignore them silently).

    A simulator declares what it implements with the class attributes
    ``supports_squint``, ``supports_moving_targets`` (default False) and
    ``accepts_motion`` (False: a straight-track model that refuses any motion).
    """
    from .simulators import _registry

    name = type(simulator).__name__

    def those(feature):
        names = [cls.names[0] for cls in _registry.SIMULATORS if getattr(cls, feature)]
        return ", ".join(f"'{n}'" for n in names)

    squint = _concrete(radar.squint)
    if squint is not None and squint != 0 and not simulator.supports_squint:
        raise ValueError(
            f"radar.squint={float(squint):g} rad: squinted acquisition is not implemented by "
            f"{name} (use method={those('supports_squint')})"
        )
    if not simulator.accepts_motion and not _motion_is_ideal(motion):
        raise ValueError(
            f"method={type(simulator).names[0]!r} simulates a straight track: motion errors "
            f"are not implemented (use method={those('accepts_motion')})"
        )
    if simulator.supports_moving_targets:
        return
    for field in ("velocity_range", "velocity_azimuth"):
        v = _concrete(getattr(scene, field, None)) if hasattr(scene, field) else None
        if v is not None and np.any(v != 0):
            raise ValueError(
                f"scene.{field} is non-zero: moving scatterers are not implemented by "
                f"{name} (use method={those('supports_moving_targets')})"
            )


# ---- checks that need the whole call (strict mode) ------------------------------------


class ValidityWarning(UserWarning):
    """A simulation outside one of its method's validity budgets (:func:`sarjax.validity`):
    the data may be inaccurate; the message names each budget broken, its value and
    threshold, and the methods to use instead. ``strict=True`` raises instead."""


class FocusWarning(UserWarning):
    """A focusing outside its method's measured budget (:func:`sarjax.focus`): the image
    may be inaccurate; the message names the budget, its value and threshold, and the
    method to use instead. ``strict=True`` raises instead."""


class SwathWarning(UserWarning):
    """No scatterer's echo reaches the range window: the raw data is identically zero."""


def check_arguments(radar, options) -> bool:
    """The radar's type, and ``strict=`` taken out of the simulator ``options``.

    Returns:
        The strict flag (default False).
    """
    from .radar import Radar

    if not isinstance(radar, Radar):
        raise ValueError(f"radar={type(radar).__name__} is not a sarjax.Radar")
    strict = options.pop("strict", False)
    if not isinstance(strict, (bool, np.bool_)):
        raise ValueError(f"strict={strict!r} must be True or False")
    return bool(strict)


def _realizations(motion):
    """The motion of each realization of a batch (one for an unbatched motion)."""
    from .motion import Motion

    parts = {n: getattr(motion, n) for n in ("horizontal", "vertical", "pointing")}
    batch = max((v.shape[0] for v in parts.values() if v is not None and v.ndim == 2),
                default=None)
    if batch is None:
        return [motion]
    return [Motion(**{n: None if v is None else (v[b] if v.ndim == 2 else v)
                      for n, v in parts.items()}) for b in range(batch)]


def check_model(simulator, radar, scene, motion, acquisition, strict=False,
                dtype=jax.numpy.complex128):
    """Checks of a whole :func:`sarjax.simulate` call (after the method is resolved):
    :func:`model_findings`, each warned about (strict: the first raised as a ValueError).
    """
    emit(model_findings(simulator, radar, scene, motion, acquisition, strict, dtype),
         stacklevel=4)


def emit(findings, stacklevel=2):
    """Warn about each (message, warning class) of :func:`model_findings`, ``stacklevel``
    counted from the caller of this function."""
    for message, category in findings:
        warnings.warn(message, category, stacklevel=stacklevel + 1)


def model_findings(simulator, radar, scene, motion, acquisition, strict=False,
                   dtype=jax.numpy.complex128):
    """What is wrong with a whole :func:`sarjax.simulate` call (after the method is
    resolved), as a list of (message, warning class), warned about by :func:`emit`.

    * **Swath**: when no scatterer's echo can reach the range window
      (:func:`echoes_outside_window`) the data would be identically zero: a
      :class:`SwathWarning`; strict: a ValueError, also when only some scatterers miss it.
    * **Budgets**: every budget the simulator declares (``simulator.budgets``,
      :func:`sarjax.validity`) must hold for every realization: for the Fourier-domain
      methods their azimuth grid (aliases, wrap, extent), the approximation budgets,
      with the simulator's own options, and in complex64 the track methods' rounding.
      Outside them a :class:`ValidityWarning` names each budget, its value and
      threshold, and the methods to use instead; strict: a ValueError. The exact models
      sample the echo at the pulses, aliasing included: only their range window counts.

    Checks of traced values are skipped. Only NumPy and jax programs of its own: it may
    run in another thread while the simulation runs (:func:`sarjax.simulate`).
    """
    findings = []
    outside = echoes_outside_window(radar, scene, motion, acquisition)
    if outside is not None and outside.size and outside.any():
        r = np.broadcast_to(scene_positions(scene)[1], outside.shape)[outside]
        dr = float(radar.range_spacing)
        window = (f"range window r' = {float(acquisition.near_range):.6g} … "
                  f"{float(acquisition.near_range) + (acquisition.num_range - 1) * dr:.6g} m")
        if outside.all():
            message = (f"no scatterer's echo reaches the {window} (scene.range = "
                       f"{np.unique(r)[:5]} m …): the raw data is identically zero")
            if strict:
                raise ValueError(message)
            findings.append((message, SwathWarning))
        elif strict:
            raise ValueError(
                f"strict=True: {int(outside.sum())} of {outside.size} scatterers' echoes "
                f"miss the {window} (scene.range = {np.unique(r)[:5]} m …)"
            )
    if is_traced(radar, scene, motion):  # inside a user's transformation (a gradient):
        return findings  # judged on concrete calls
    realizations = _realizations(motion)
    for index, realization in enumerate(realizations):
        # one realization: the swath check's scatterers are this budget's too
        report = simulator.budgets(radar, scene, realization, acquisition, dtype,
                                   outside=outside if len(realizations) == 1 else None)
        broken = [b for b in report.violated if b.name != "range_window"]
        if broken:
            which = f" (realization {index})" if len(realizations) > 1 else ""
            message = _outside_validity(simulator, broken, which)
            if strict:
                raise ValueError(f"strict=True: {message}, or strict=False")
            findings.append((message, ValidityWarning))
            break
    return findings


def _outside_validity(simulator, broken, which) -> str:
    """The message of a run outside its budgets: each budget broken (value, threshold,
    meaning) and the methods to use instead: for an approximation, the registered
    methods that model more of the motion (without checking their own budgets:
    ``method='auto'`` does that), and the exact models; for the grid, the exact models."""
    from .simulators import MOTION_KINDS, _registry

    cls = type(simulator)
    name = cls.names[0] if cls.names else cls.__name__
    text = "; ".join(f"{b.name}={b.value:.3g} > {b.threshold:g} ({b.meaning})"
                     for b in broken)
    instead = []
    if any(b.name.startswith("epsilon") for b in broken) and cls.motion in MOTION_KINDS:
        rank = MOTION_KINDS.index(cls.motion)
        instead = [c.names[0] for c in _registry.auto_candidates()
                   if not c.exact and MOTION_KINDS.index(c.motion) > rank
                   and (c.supports_squint or not simulator.supports_squint)]
    instead += [c.names[0] for c in _registry.SIMULATORS if c.exact]
    rounding = " or dtype=jnp.complex128" if any(
        b.name == "complex64_rounding" for b in broken) else ""
    wrapped = (", or the default azimuth_padding=None (as it is, the data repeat along "
               "track, RawData.azimuth_period, and sj.focus correlates circularly over that "
               "period)") if any(b.name == "azimuth_window" for b in broken) else ""
    return (f"method={name!r} is outside its validity{which}: {text}; use method="
            + " or ".join(f"{m!r}" for m in ["auto"] + instead) + rounding + wrapped)


def check_focus(radar, raw, motion):
    """Inputs of :func:`sarjax.focus`: a valid radar (:func:`check_radar`), finite raw
    samples on axes of matching length, and motion components of one finite value per
    pulse. Traced values skip the value checks."""
    from .radar import Radar

    if not isinstance(radar, Radar):
        raise ValueError(f"radar={type(radar).__name__} is not a sarjax.Radar")
    check_radar(radar)
    data = raw.data
    shape = np.shape(data)
    if not isinstance(data, jax.core.Tracer) and not bool(jax.numpy.all(jax.numpy.isfinite(
            data))):
        bad = np.argwhere(~np.isfinite(np.asarray(data)))[:5]
        raise ValueError(f"raw.data has non-finite samples at (pulse, sample) "
                         f"{[tuple(b) for b in bad.tolist()]}")
    if len(shape) != 2:
        return
    for name, size in (("azimuth", shape[0]), ("range", shape[1])):
        axis = getattr(raw, name)
        if np.shape(axis) != (size,):
            raise ValueError(f"raw.{name} has shape {np.shape(axis)}, raw.data has shape "
                             f"{shape}: one value per {'pulse' if name == 'azimuth' else 'sample'}")
        c = _concrete(axis)
        if c is not None and not np.all(np.isfinite(c)):
            raise ValueError(f"raw.{name} has non-finite values {c[~np.isfinite(c)][:5]}")
    for name in ("horizontal", "vertical", "pointing"):
        v = getattr(motion, name)
        if v is None:
            continue
        if np.shape(v) != (shape[0],):
            raise ValueError(f"motion.{name} has shape {np.shape(v)}, expected ({shape[0]},): "
                             "one value per pulse of the raw data")
        c = _concrete(v)
        if c is not None and not np.all(np.isfinite(c)):
            bad = np.flatnonzero(~np.isfinite(c))[:5]
            raise ValueError(f"motion.{name} has non-finite values {c[bad]} at pulses {bad}")
