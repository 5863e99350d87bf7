"""Input checks at the API boundary: bad input raises ValueError naming the value.

Checks run eagerly on concrete values; inside a user's own ``jit`` (traced values)
they are skipped, and the structural checks (shapes) still apply.
"""

from __future__ import annotations

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


def check_scene(scene, radar):
    if scene.num_scatterers == 0:
        raise ValueError("the scene is empty (0 scatterers): nothing to simulate")
    for name in ("azimuth", "range", "reflectivity", "height", "velocity_range",
                 "velocity_azimuth"):
        if not hasattr(scene, name):
            continue
        v = _concrete(getattr(scene, name))
        if v is not None and not np.all(np.isfinite(v)):
            bad = np.flatnonzero(~np.isfinite(v))[:5]
            raise ValueError(f"scene.{name} has non-finite values {v[bad]} at indices {bad}")
    r, h, H = _concrete(scene.range), _concrete(scene.height), _concrete(radar.height)
    if r is not None and h is not None and r.ndim == 1 and h.ndim == 2:  # grid
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
                f"{list(zip(rows.tolist(), cols.tolist()))}"
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
            f"{name} (use method='time_domain', 'small_deviation', 'moderate_deviation', "
            "'high_speed' or 'chirp_scaling')"
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
