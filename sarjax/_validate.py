"""Input checks at the API boundary: bad input raises ValueError naming the value.

Checks run eagerly on concrete values; inside a user's own ``jit`` (traced values)
they are skipped, and the structural checks (shapes) still apply.
"""

from __future__ import annotations

import math
import warnings

import jax
import numpy as np


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


def check_supported(simulator, radar, scene):
    """Refuse model features a simulator does not implement (never ignore them silently).

    A simulator declares what it implements with the class attributes
    ``supports_squint`` and ``supports_moving_targets`` (default False).
    """
    name = type(simulator).__name__
    squint = _concrete(radar.squint)
    if squint is not None and squint != 0 and not getattr(simulator, "supports_squint", False):
        raise ValueError(
            f"radar.squint={float(squint):g} rad: squinted acquisition is not implemented by "
            f"{name} (use method='time_domain', 'fourier_2d', 'small_deviation', "
            "'moderate_deviation' or 'high_speed')"
        )
    if getattr(simulator, "supports_moving_targets", False):
        return
    for field in ("velocity_range", "velocity_azimuth"):
        v = _concrete(getattr(scene, field, None)) if hasattr(scene, field) else None
        if v is not None and np.any(v != 0):
            raise ValueError(
                f"scene.{field} is non-zero: moving scatterers are not implemented by "
                f"{name} (use method='time_domain' or 'high_speed')"
            )


# ---- checks that need the whole call (strict mode) ------------------------------------


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


def _scene_positions(scene):
    """(x, r) NumPy arrays broadcastable to the scene's scatterers, or None if traced."""
    from .scene import ReflectivityGrid

    x, r = _concrete(scene.azimuth), _concrete(scene.range)
    if x is None or r is None:
        return None
    if isinstance(scene, ReflectivityGrid):
        return x[:, None], r[None, :]
    return x, r


def doppler_band(radar, scene, acquisition) -> float:
    """The largest Doppler extent [Hz] of one scatterer's echo over the pulses of the
    window that see it within the beam's half-width, ``|u| ≤ 1/2``.

    ``u = (a + r T)/(X (1 − a T/r))`` (``a = x' − x``, ``T = tan φ_d``, ``X = λr/L``),
    so the beam covers ``a ∈ [a(−½), a(½)]``, ``a(u) = (uX − rT)/(1 + uXT/r)``; over the
    part of it inside the window the Doppler ``f = −(2v/λ) a/√(r² + a²)`` spans
    ``(2v/λ) |a/R|`` between the ends. For a window longer than the footprint at
    broadside this is ``2v/L``; for a shorter one, ``≈ 2v A/(λ r)`` (A its length).
    Static scatterers, nominal pointing. Returns 0 for traced inputs.
    """
    positions = _scene_positions(scene)
    values = [_concrete(v) for v in (radar.wavelength, radar.antenna_length, radar.velocity,
                                     radar.squint, radar.azimuth_spacing,
                                     acquisition.azimuth_center)]
    if positions is None or any(v is None for v in values):
        return 0.0
    lam, length, v, squint, dx, centre = (float(v) for v in values)
    x, r = positions
    t = math.tan(squint)
    footprint = lam * r / length

    def edge(u):
        denominator = 1 + u * footprint * t / r
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(denominator > 0, (u * footprint - r * t) / denominator,
                            np.sign(u) * np.inf)

    half = (acquisition.num_pulses - 1) / 2 * dx
    lo = np.maximum(edge(-0.5), centre - half - x)
    hi = np.minimum(edge(0.5), centre + half - x)
    sine = lambda a: a / np.sqrt(r**2 + a**2)
    span = np.where(hi > lo, sine(np.where(hi > lo, hi, 0.0)) - sine(np.where(hi > lo, lo, 0.0)),
                    0.0)
    return float(2 * v / lam * np.max(span, initial=0.0))


def echoes_outside_window(radar, scene, motion, acquisition):
    """Which scatterers' echoes cannot reach the range window (bool, broadcast to the
    scene: (scatterer,) or (azimuth, range) for a grid), or None for traced inputs.

    The echo of a scatterer at (x, r) covers ``r' ∈ [R_min − cτ/4, R_max + cτ/4]``, R its
    range from the window's pulses (nearest and farthest), widened by the largest
    line-of-sight deviation ``max|Δy| + max|Δz|``, the range walk ``|v_r|`` × the
    window's duration and two range samples.
    """
    positions = _scene_positions(scene)
    values = [_concrete(v) for v in (radar.azimuth_spacing, radar.range_spacing,
                                     radar.pulse_half_length, radar.prf,
                                     acquisition.near_range, acquisition.azimuth_center)]
    if positions is None or any(v is None for v in values):
        return None
    dx, dr, half_pulse, prf, near, centre = (float(v) for v in values)
    x, r = positions
    margin = 2 * dr
    for name in ("horizontal", "vertical"):
        v = getattr(motion, name)
        c = None if v is None else _concrete(v)
        if v is not None and c is None:
            return None
        if c is not None and c.size:
            margin += float(np.max(np.abs(c)))
    duration = acquisition.num_pulses / prf
    speed = _concrete(getattr(scene, "velocity_range", None)) if hasattr(
        scene, "velocity_range") else None
    walk = 0.0 if speed is None else np.abs(speed) * duration
    half = (acquisition.num_pulses - 1) / 2 * dx
    first, last = centre - half, centre + half
    nearest = np.clip(x, first, last) - x
    farthest = np.maximum(np.abs(first - x), np.abs(last - x))
    far = near + (acquisition.num_range - 1) * dr
    reach = half_pulse + margin + walk
    # start = √(r² + nearest²) − reach > far and end = √(r² + farthest²) + reach < near,
    # compared in squares (no square root per scatterer)
    r2 = r**2
    beyond = r2 + nearest**2 > (far + reach) ** 2
    low = near - reach
    before = (r2 + farthest**2 < low**2) & (low > 0)
    return np.broadcast_to(beyond | before, np.broadcast_shapes(np.shape(x), np.shape(r)))


def _validity_method(simulator):
    """The :func:`sarjax.validity` method name of an approximate simulator (or None)."""
    from .simulators import Fourier2D, ModerateDeviation, SmallDeviation

    for cls, name in ((Fourier2D, "fourier_2d"), (SmallDeviation, "small_deviation"),
                      (ModerateDeviation, "moderate_deviation")):
        if isinstance(simulator, cls):
            return name
    return None


def _is_exact(simulator) -> bool:
    from .simulators import TimeDomain, TimeDomainNUFFT

    return isinstance(simulator, (TimeDomain, TimeDomainNUFFT))


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


def check_model(simulator, radar, scene, motion, acquisition, strict=False):
    """Checks of a whole :func:`sarjax.simulate` call (after the method is resolved).

    * **Swath**: when no scatterer's echo can reach the range window
      (:func:`echoes_outside_window`) the data would be identically zero: a
      :class:`SwathWarning`; strict: a ValueError, also when only some scatterers miss it.
    * **Azimuth aliasing** (strict only): a PRF below the echoes' Doppler band
      (:func:`doppler_band`; ``2v/L`` for a window longer than the footprint). The exact
      models (``time_domain``, ``time_domain_nufft``) sample the echo at the pulses, so
      their record is right, aliasing included: never refused. The Fourier-domain
      simulators synthesise the principal Doppler band only and lose the folded part
      (against the exact model, airborne set, 128 pulses, two targets: NMSE −41 dB at
      PRF = 2 × 2v/L, −29.5 dB at 0.75 × 2v/L, −2.4 dB at 0.3 × 2v/L), so for them it is
      an approximation outside its validity: a ValueError in strict mode. It is not a
      warning by default: undersampled small configurations (PRF ≪ 2v/L) are a
      deliberate, cheap setting for tests of gradients and shapes, where only
      self-consistency matters.
    * **Validity budgets** (strict only): the approximate methods (``fourier_2d``,
      ``small_deviation``, ``moderate_deviation``) must hold every budget of
      :func:`sarjax.validity` for every realization, with the simulator's own
      ``pointing_order``, ``coupling_order`` and ``envelope_correction``.

    Checks of traced values are skipped.
    """
    name = type(simulator).__name__
    outside = echoes_outside_window(radar, scene, motion, acquisition)
    if outside is not None and outside.size and outside.any():
        r = np.broadcast_to(_scene_positions(scene)[1], outside.shape)[outside]
        dr = float(radar.range_spacing)
        window = (f"range window r' = {float(acquisition.near_range):.6g} … "
                  f"{float(acquisition.near_range) + (acquisition.num_range - 1) * dr:.6g} m")
        if outside.all():
            message = (f"no scatterer's echo reaches the {window} (scene.range = "
                       f"{np.unique(r)[:5]} m …): the raw data is identically zero")
            if strict:
                raise ValueError(message)
            warnings.warn(message, SwathWarning, stacklevel=4)
        elif strict:
            raise ValueError(
                f"strict=True: {int(outside.sum())} of {outside.size} scatterers' echoes "
                f"miss the {window} (scene.range = {np.unique(r)[:5]} m …)"
            )
    if strict and not _is_exact(simulator):
        band = doppler_band(radar, scene, acquisition)
        prf = _concrete(radar.prf)
        if prf is not None and band > float(prf):
            message = (
                f"radar.prf={float(prf):g} Hz is below the Doppler band {band:.4g} Hz of the "
                f"echoes (2v/L = {2 * float(radar.velocity) / float(radar.antenna_length):.4g}"
                f" Hz): the azimuth samples alias, and {name} synthesises only the principal "
                "band (use method='time_domain' or 'time_domain_nufft', or raise the PRF)"
            )
            raise ValueError(f"strict=True: {message}")
    if not strict:
        return
    method = _validity_method(simulator)
    if method is None:
        return
    from .validity import validity

    options = dict(pointing_order=getattr(simulator, "pointing_order", 2),
                   coupling_order=getattr(simulator, "coupling_order", 3),
                   envelope_correction=getattr(simulator, "envelope_correction", True))
    realizations = _realizations(motion)
    for index, realization in enumerate(realizations):
        report = validity(radar, scene, realization, method=method,
                          num_pulses=acquisition.num_pulses,
                          azimuth_center=float(acquisition.azimuth_center), **options)
        if not report.valid:
            broken = "; ".join(f"{b.name}={b.value:.3g} > {b.threshold:g} ({b.meaning})"
                               for b in report.budgets if not b.ok)
            which = f" (realization {index})" if len(realizations) > 1 else ""
            raise ValueError(
                f"strict=True: method={method!r} is outside its validity{which}: {broken}; "
                "use method='auto' or 'time_domain', or strict=False"
            )


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
