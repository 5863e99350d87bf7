"""Scenes: point scatterers and reflectivity grids (physics.md §1–2).

Scatterer coordinates are cylindrical about the nominal track: azimuth ``x`` [m] along
track and closest-approach slant range ``r`` [m] from the nominal track at height ``H``;
an optional terrain height ``h`` [m] sets the look angle ``cos ϑ = (H − h)/r``.
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np


def _real(v):
    return jnp.asarray(v, dtype=float)


def _complex(v):
    return jnp.asarray(v, dtype=complex)


def _array(owner, name, value, dtype):
    """``value`` as an array of ``dtype``, or a ValueError naming ``owner.name`` (complex
    values for a real field are refused, not truncated)."""
    if dtype is float and np.iscomplexobj(value):
        raise ValueError(f"{owner}.{name} must be real, got complex values")
    try:
        return jnp.asarray(value, dtype=dtype)
    except (TypeError, ValueError) as err:
        kind = "real" if dtype is float else "complex"
        raise ValueError(f"{owner}.{name} must be {kind} numbers ({err})") from None


class PointTargets(eqx.Module):
    """A set of point scatterers.

    Attributes:
        azimuth: (scatterer,) along-track position x [m].
        range: (scatterer,) closest-approach slant range r from the nominal track [m].
        reflectivity: (scatterer,) complex reflectivity γ [–].
        height: (scatterer,) terrain height h above the reference plane [m] (default 0).
        velocity_range: (scatterer,) slant-range velocity v_r [m/s] (default 0).
        velocity_azimuth: (scatterer,) along-track velocity v_a [m/s] (default 0).
    """

    azimuth: jnp.ndarray = eqx.field(converter=_real)
    range: jnp.ndarray = eqx.field(converter=_real)
    reflectivity: jnp.ndarray = eqx.field(converter=_complex)
    height: jnp.ndarray = eqx.field(converter=_real)
    velocity_range: jnp.ndarray = eqx.field(converter=_real)
    velocity_azimuth: jnp.ndarray = eqx.field(converter=_real)

    def __init__(
        self,
        azimuth,
        range,
        reflectivity=None,
        height=None,
        *,
        velocity_range=None,
        velocity_azimuth=None,
    ):
        azimuth = jnp.atleast_1d(_array("PointTargets", "azimuth", azimuth, float))
        n = azimuth.shape[0]

        def fill(name, v, dtype):
            if v is None:
                return jnp.zeros(n, dtype) if dtype is float else jnp.ones(n, dtype)
            return jnp.atleast_1d(_array("PointTargets", name, v, dtype))

        self.azimuth = azimuth
        self.range = jnp.atleast_1d(_array("PointTargets", "range", range, float))
        self.reflectivity = fill("reflectivity", reflectivity, complex)
        self.height = fill("height", height, float)
        self.velocity_range = fill("velocity_range", velocity_range, float)
        self.velocity_azimuth = fill("velocity_azimuth", velocity_azimuth, float)

    def __check_init__(self):
        n = self.azimuth.shape
        for name in ("range", "reflectivity", "height", "velocity_range", "velocity_azimuth"):
            shape = getattr(self, name).shape
            if shape != n:
                raise ValueError(
                    f"PointTargets.{name} has shape {shape}, azimuth has shape {n}: "
                    "every per-scatterer array must have one value per scatterer"
                )
        if len(n) != 1:
            raise ValueError(f"PointTargets arrays must be 1-D, got shape {n}")

    @property
    def num_scatterers(self) -> int:
        """Number of scatterers (static)."""
        return self.azimuth.shape[0]


class ReflectivityGrid(eqx.Module):
    """A reflectivity map γ(x, r) sampled on a regular grid, with optional heights.

    Attributes:
        reflectivity: (azimuth, range) complex reflectivity γ [–].
        azimuth: (azimuth,) along-track coordinates x of the grid rows [m].
        range: (range,) closest-approach slant ranges r of the grid columns [m].
        height: (azimuth, range) terrain height h [m] (default 0).
    """

    reflectivity: jnp.ndarray = eqx.field(converter=_complex)
    azimuth: jnp.ndarray = eqx.field(converter=_real)
    range: jnp.ndarray = eqx.field(converter=_real)
    height: jnp.ndarray = eqx.field(converter=_real)

    def __init__(self, reflectivity, azimuth, range, height=None):
        self.reflectivity = _array("ReflectivityGrid", "reflectivity", reflectivity, complex)
        self.azimuth = _array("ReflectivityGrid", "azimuth", azimuth, float)
        self.range = _array("ReflectivityGrid", "range", range, float)
        self.height = (jnp.zeros(self.reflectivity.shape) if height is None
                       else _array("ReflectivityGrid", "height", height, float))

    def __check_init__(self):
        shape = self.reflectivity.shape
        if len(shape) != 2:
            raise ValueError(f"ReflectivityGrid.reflectivity must be 2-D, got shape {shape}")
        if self.azimuth.shape != (shape[0],) or self.range.shape != (shape[1],):
            raise ValueError(
                f"ReflectivityGrid axes {self.azimuth.shape}, {self.range.shape} do not match "
                f"reflectivity shape {shape}"
            )
        if self.height.shape != shape:
            raise ValueError(
                f"ReflectivityGrid.height has shape {self.height.shape}, expected {shape}"
            )

    def to_points(self) -> PointTargets:
        """The grid as point scatterers, one per cell (row-major)."""
        xx, rr = jnp.meshgrid(self.azimuth, self.range, indexing="ij")
        return PointTargets(
            azimuth=xx.ravel(),
            range=rr.ravel(),
            reflectivity=self.reflectivity.ravel(),
            height=self.height.ravel(),
        )

    @property
    def num_scatterers(self) -> int:
        """Number of grid cells (static)."""
        return int(np.prod(self.reflectivity.shape))


def pyramid_height(azimuth, range, *, peak, azimuth_center=None, range_center=None,
                   half_width_azimuth=None, half_width_range=None):
    """Pyramid terrain h(x, r) [m] on a grid (seed 000 §4 extended scene).

    Args:
        azimuth: (azimuth,) grid azimuths [m].
        range: (range,) grid slant ranges [m].
        peak: apex height [m].

    Returns:
        (azimuth, range) heights, ``peak`` at the centre falling linearly to 0 at the edges.
    """
    azimuth = np.asarray(azimuth, float)
    range_ = np.asarray(range, float)
    xc = azimuth.mean() if azimuth_center is None else azimuth_center
    rc = range_.mean() if range_center is None else range_center
    wx = (np.ptp(azimuth) / 2 or 1.0) if half_width_azimuth is None else half_width_azimuth
    wr = (np.ptp(range_) / 2 or 1.0) if half_width_range is None else half_width_range
    dx = np.abs(azimuth[:, None] - xc) / wx
    dr = np.abs(range_[None, :] - rc) / wr
    return peak * np.clip(1.0 - np.maximum(dx, dr), 0.0, None)
