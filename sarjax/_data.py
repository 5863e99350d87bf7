"""Acquisition grids and the raw-data / image containers."""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp


class Acquisition(eqx.Module):
    """Sampling grid of one acquisition: pulses along track and range samples.

    Pulse ``p`` is at ``x'_p = azimuth_center + (p − (N_x − 1)/2) · v/PRF`` and range
    sample ``k`` at ``r'_k = near_range + k · c/(2 f_s)`` (physics.md §1).

    Attributes:
        num_pulses: N_x (static).
        num_range: N_r (static).
        near_range: r' of the first range sample [m].
        azimuth_center: x' of the middle pulse [m].
    """

    num_pulses: int = eqx.field(static=True)
    num_range: int = eqx.field(static=True)
    near_range: jnp.ndarray = eqx.field(converter=lambda v: jnp.asarray(v, dtype=float))
    azimuth_center: jnp.ndarray = eqx.field(converter=lambda v: jnp.asarray(v, dtype=float))

    def pulse_azimuths(self, radar):
        """(azimuth,) x' of every pulse [m]."""
        index = jnp.arange(self.num_pulses) - (self.num_pulses - 1) / 2
        return self.azimuth_center + index * radar.azimuth_spacing

    def range_axis(self, radar):
        """(range,) r' of every range sample [m]."""
        return self.near_range + jnp.arange(self.num_range) * radar.range_spacing


class _Gridded(eqx.Module):
    data: jnp.ndarray
    azimuth: jnp.ndarray
    range: jnp.ndarray
    method: str = eqx.field(static=True, default="")

    @property
    def shape(self):
        """(n_azimuth, n_range)."""
        return self.data.shape

    def to_xarray(self, *, radar=None, scene=None, motion=None, attrs=None):
        """This product (and the run's parameters, when given) as an ``xarray.Dataset``
        with dims ``("azimuth", "range")`` in metres (see :mod:`sarjax.io`)."""
        from .io import to_xarray

        return to_xarray(self, radar=radar, scene=scene, motion=motion, attrs=attrs)

    @classmethod
    def from_xarray(cls, dataset):
        """Inverse of :meth:`to_xarray` (see :func:`sarjax.io.from_xarray`)."""
        from .io import from_xarray

        product = from_xarray(dataset)
        if not isinstance(product, cls):
            raise ValueError(f"the dataset holds {type(product).__name__}, not {cls.__name__}")
        return product


class RawData(_Gridded):
    """Complex baseband raw data.

    Attributes:
        data: (azimuth, range) complex echoes h(x', r').
        azimuth: (azimuth,) pulse positions x' [m].
        range: (range,) range-sample coordinates r' = c t/2 [m].
        method: the simulator that produced it (what ``method="auto"`` chose).
    """


class Image(_Gridded):
    """A focused (or range-compressed) complex image.

    Attributes:
        data: (azimuth, range) complex image.
        azimuth: (azimuth,) along-track coordinate x [m].
        range: (range,) closest-approach slant range r [m].
    """
