"""Eager (NumPy) set-up shared by :func:`fit_motion` and :func:`crb`: the illuminated
pulses, the range window holding every echo, the gauge and the observability checks."""

from __future__ import annotations

import dataclasses

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .. import _validate
from .._data import Acquisition
from ..scene import PointTargets
from ..simulators import TimeDomain
from . import _engine
from ._parametrisations import BSpline, MotionModel, SinusoidalJitter

# Horizontal/vertical separation needs look-angle diversity: below this spread of the
# scatterers' look angles [rad] only the line-of-sight component is fitted (the
# separation would amplify the line-of-sight error by ≈ 1/spread).
MIN_LOOK_ANGLE_SPREAD = 0.01


@dataclasses.dataclass(frozen=True)
class Fixed:
    """A component the fit does not estimate, and why.

    Attributes:
        component: what is held fixed (e.g. ``"horizontal mean"``).
        value: the value it is held at.
        reason: the physical trade-off that makes it unobservable.
    """

    component: str
    value: str
    reason: str


def look_angles(radar, scene):
    """(target,) look angles ϑ with cos ϑ = (H − h)/r [rad]."""
    r = np.asarray(scene.range, float)
    h = np.asarray(scene.height, float)
    return np.arccos((float(radar.height) - h) / r)


def illuminated(radar, scene, azimuth, *, lobe=1.0):
    """(azimuth,) True where some scatterer is inside its two-way main lobe,
    |x' − x_t| < lobe · X_t with X_t = λ r_t / L."""
    x = np.asarray(azimuth, float)[:, None]
    footprint = np.asarray(radar.footprint(scene.range))[None, :]
    return np.any(np.abs(x - np.asarray(scene.azimuth)[None, :]) < lobe * footprint, axis=1)


def check_inputs(radar, scene, raw_azimuth, raw_range):
    _validate.check_radar(radar)
    if not isinstance(scene, PointTargets):
        raise ValueError(
            f"scene={type(scene).__name__}: the calibration scene must be PointTargets"
        )
    _validate.check_scene(scene, radar)
    if np.any(np.asarray(scene.velocity_range) != 0) or np.any(
        np.asarray(scene.velocity_azimuth) != 0
    ):
        raise ValueError("scene has moving scatterers: the calibration scene must be static")
    if float(radar.squint) != 0:
        raise ValueError(f"radar.squint={float(radar.squint):g}: only broadside is implemented")
    x = np.asarray(raw_azimuth, float)
    r = np.asarray(raw_range, float)
    dx, dr = float(radar.azimuth_spacing), float(radar.range_spacing)
    if x.ndim != 1 or x.size < 8 or not np.allclose(np.diff(x), dx, rtol=1e-6, atol=1e-9):
        raise ValueError(
            f"raw.azimuth must hold >= 8 pulses spaced v/PRF = {dx:g} m (got {x.size} pulses)"
        )
    if r.ndim != 1 or r.size < 8 or not np.allclose(np.diff(r), dr, rtol=1e-6, atol=1e-9):
        raise ValueError(f"raw.range must be uniform with spacing c/(2 f_s) = {dr:g} m")


# Pulses used: those within half a footprint of some scatterer, |x' − x_t| < X_t/2 (each
# scatterer's synthetic aperture, integration time T_s = X/v): 95 % of the echo energy of
# the two-way sinc² pattern (99.7 % is inside the main lobe |x' − x_t| < X_t), and no
# pulse whose only echo is at the edge of a main lobe, where the data say little about it.
APERTURE_FRACTION = 0.5


def pulse_span(radar, scene, raw_azimuth):
    """(first, stop) indices of the contiguous pulses within X_t/2 of some scatterer."""
    mask = illuminated(radar, scene, raw_azimuth, lobe=APERTURE_FRACTION)
    if mask.sum() < 16:
        raise ValueError(
            f"only {int(mask.sum())} pulses see a scatterer inside its main lobe: the raw "
            "data do not cover the calibration scene"
        )
    idx = np.flatnonzero(mask)
    return int(idx[0]), int(idx[-1]) + 1


def range_span(radar, scene, raw_range, azimuth, max_deviation):
    """(first, stop) raw range indices holding every echo of the support pulses."""
    r = np.asarray(raw_range, float)
    dr = float(radar.range_spacing)
    x = np.asarray(azimuth, float)[:, None]
    slant = np.sqrt(np.asarray(scene.range)[None, :] ** 2
                    + (x - np.asarray(scene.azimuth)[None, :]) ** 2)
    half = float(radar.pulse_half_length)
    margin = max_deviation + 2 * dr
    low, high = slant.min() - half - margin, slant.max() + half + margin
    if low < r[0] or high > r[-1]:
        raise ValueError(
            f"the echoes span r' = {low:.1f} … {high:.1f} m (with the {max_deviation:g} m "
            f"deviation margin) but raw.range covers {r[0]:.1f} … {r[-1]:.1f} m: every echo "
            "must lie inside the range window"
        )
    first = int(np.floor((low - r[0]) / dr))
    stop = int(np.ceil((high - r[0]) / dr)) + 1
    return first, min(stop, r.size)


def window_index(radar, scene, azimuth, near_range, num_range, half_width):
    """(azimuth, target·window) range indices ±half_width about each nominal range R_n."""
    x = np.asarray(azimuth, float)[:, None]
    slant = np.sqrt(np.asarray(scene.range)[None, :] ** 2
                    + (x - np.asarray(scene.azimuth)[None, :]) ** 2)
    centre = np.rint((slant - near_range) / float(radar.range_spacing)).astype(int)
    index = centre[:, :, None] + np.arange(-half_width, half_width + 1)[None, None, :]
    if index.min() < 0 or index.max() >= num_range:
        raise ValueError("a compression window leaves the range window (internal error)")
    return index.reshape(index.shape[0], -1)


def make_problem(radar, scene, azimuth, near_range, num_range, *, half_width=None):
    """The engine problem on a pulse grid (uniform ``azimuth``) and range window."""
    x = np.asarray(azimuth, float)
    acquisition = Acquisition(
        num_pulses=int(x.size), num_range=int(num_range), near_range=float(near_range),
        azimuth_center=float(0.5 * (x[0] + x[-1])),
    )
    simulator = TimeDomain()
    if half_width is None:
        return _engine.Problem(radar, scene, acquisition, simulator)
    index = window_index(radar, scene, x, float(near_range), int(num_range), half_width)
    return _engine.Problem(
        radar, scene, acquisition, simulator,
        _engine.unitary_range_filter(radar, int(num_range)), jnp.asarray(index),
    )


def default_model(radar):
    """B-splines (36 functions) for Δy and Δz, sinusoidal jitter for δ_az."""
    return MotionModel(
        horizontal=BSpline(36), vertical=BSpline(36),
        pointing=SinusoidalJitter(
            velocity=radar.velocity,
            amplitude_scale=radar.wavelength / radar.antenna_length / 20,
        ),
    )


def bind_model(radar, scene, model, azimuth, *, reflectivity_known):
    """Bind every parametrisation to the support pulses and apply the gauges.

    Returns ``(bound_model, fixed, line_of_sight)`` where ``line_of_sight`` is None or the
    (sin ϑ̄, cos ϑ̄) direction along which a single deviation profile is fitted.
    """
    fixed = []
    zero_mean = not reflectivity_known
    angles = look_angles(radar, scene)
    spread = float(np.ptp(angles))
    line_of_sight = None
    if model.horizontal is not None and model.vertical is not None \
            and spread < MIN_LOOK_ANGLE_SPREAD:
        theta = float(np.mean(angles))
        line_of_sight = (np.sin(theta), np.cos(theta))
        fixed.append(Fixed(
            "cross-line-of-sight deviation",
            "0",
            f"the scatterers' look angles span {spread:.2e} rad < {MIN_LOOK_ANGLE_SPREAD} rad: "
            "Δy and Δz are separable only through look-angle diversity, so one profile "
            f"ℓ(x') is fitted along the mean line of sight ϑ̄ = {theta:.4f} rad "
            "(Δy = −ℓ sin ϑ̄, Δz = ℓ cos ϑ̄)",
        ))
        model = eqx.tree_at(lambda m: m.vertical, model, None, is_leaf=lambda v: v is None)
    bound = {}
    for name in ("horizontal", "vertical", "pointing"):
        p = getattr(model, name)
        if p is None:
            bound[name] = None
            continue
        gauge = zero_mean and name != "pointing"
        bound[name] = p.bind(azimuth, zero_mean=gauge)
        if gauge:
            label = "line-of-sight" if line_of_sight is not None else name
            fixed.append(Fixed(
                f"{label} mean",
                "0 (mean over the illuminated pulses)",
                "a constant deviation changes every scatterer's two-way phase by a constant, "
                "which the unknown reflectivity phases absorb, and its range delay by a "
                "fraction of a resolution cell (it trades with the scene position)",
            ))
    return MotionModel(**bound), fixed, line_of_sight


def motion3(model, params, azimuth, line_of_sight):
    """(azimuth, 3) (Δy, Δz, δ_az) from the model parameters."""
    dy, dz, pointing = model.profiles(params, azimuth)
    if line_of_sight is not None:
        s, c = line_of_sight
        dy, dz = -s * dy, c * dy
    return jnp.stack([dy, dz, pointing], axis=-1)
