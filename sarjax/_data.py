"""Acquisition grids, the raw-data / image containers and their ``xarray`` form.

:func:`to_xarray` / :func:`from_xarray` convert a product (and the run's parameters) to
and from an ``xarray.Dataset``; :mod:`sarjax.io` writes that dataset to a file.
"""

from __future__ import annotations

import dataclasses
import json

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .radar import radar_attributes
from .scene import PointTargets, ReflectivityGrid


class Acquisition(eqx.Module):
    """Sampling grid of one acquisition: pulses along track and range samples.

    Pulse ``p`` is at ``x'_p = azimuth_center + (p − (N_x − 1)/2 + s) · v/PRF`` and range
    sample ``k`` at ``r'_k = near_range + k · c/(2 f_s)`` (physics.md §1).

    Attributes:
        num_pulses: N_x (static).
        num_range: N_r (static).
        near_range: r' of the first range sample [m].
        azimuth_center: x' of the middle pulse [m] (with ``pulse_offset`` 0).
        pulse_offset: s, the pulses' index shift (default 0). A block of pulses of a
            longer acquisition (``sarjax.simulate``'s splits between host threads and
            devices) keeps that acquisition's centre and shifts its indices by a multiple
            of ½: the index sum is then exact in float64, and each pulse lies where the
            whole acquisition puts it, to the bit.
    """

    num_pulses: int = eqx.field(static=True)
    num_range: int = eqx.field(static=True)
    near_range: jnp.ndarray = eqx.field(converter=lambda v: jnp.asarray(v, dtype=float))
    azimuth_center: jnp.ndarray = eqx.field(converter=lambda v: jnp.asarray(v, dtype=float))
    pulse_offset: jnp.ndarray = eqx.field(default=0.0,
                                          converter=lambda v: jnp.asarray(v, dtype=float))

    def pulse_azimuths(self, radar):
        """(azimuth,) x' of every pulse [m]."""
        index = jnp.arange(self.num_pulses) - (self.num_pulses - 1) / 2 + self.pulse_offset
        return self.azimuth_center + index * radar.azimuth_spacing

    def pulse_block(self, start, size):
        """The acquisition of pulses ``start … start + size − 1`` of this one (``start``
        may be traced): its centre kept, its indices shifted by a multiple of ½, so that
        each pulse lies where this acquisition puts it, to the bit."""
        shift = self.pulse_offset + (start - (self.num_pulses - size) / 2)
        return dataclasses.replace(self, num_pulses=size, pulse_offset=shift)

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
        with dims ``("azimuth", "range")`` in metres (see :func:`to_xarray`)."""
        return to_xarray(self, radar=radar, scene=scene, motion=motion, attrs=attrs)

    @classmethod
    def from_xarray(cls, dataset):
        """Inverse of :meth:`to_xarray` (see :func:`from_xarray`)."""
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
        method_reason: why ``method="auto"`` chose it (each candidate's estimated cost, or
            the budget that rules it out; :func:`sarjax.explain_choice`); empty
            for a method named by the caller.
        azimuth_period: pulses over which the data repeat along track, 0 where they do
            not (recorded data, or a simulation that held every echo). A Fourier-domain
            simulation with a fixed ``azimuth_padding`` too small for the scene (0: the
            seeds' circular setup) synthesises on a circular grid of that many pulses
            and its echoes wrap (the ``azimuth_window`` budget); :func:`sarjax.focus`
            then correlates circularly over that period (the consistent inverse where
            the data hold the whole period, as with ``azimuth_padding=0``).
    """

    method_reason: str = eqx.field(static=True, default="")
    azimuth_period: int = eqx.field(static=True, default=0)


class Image(_Gridded):
    """A focused (or range-compressed) complex image.

    Attributes:
        data: (azimuth, range) complex image.
        azimuth: (azimuth,) along-track coordinate x [m].
        range: (range,) closest-approach slant range r [m].
    """


# ---- products <-> xarray ----------------------------------------------------------------

_PRODUCTS = {"RawData": RawData, "Image": Image}
_VARIABLE = {"RawData": "raw", "Image": "image"}


def _xr():
    try:
        import xarray
    except ImportError:
        raise ImportError("xarray is needed for sarjax.io and the xarray form of products: "
                          "pip install xarray h5netcdf") from None
    return xarray


def to_xarray(product, *, radar=None, scene=None, motion=None, attrs=None):
    """A :class:`~sarjax.RawData` or :class:`~sarjax.Image` as an ``xarray.Dataset``.

    Args:
        product: the raw data or image.
        radar, scene, motion: the run's parameters (stored when given).
        attrs: further attributes (str, numbers, or anything JSON-serialisable).

    Returns:
        Dataset with the complex variable ``raw`` / ``image`` on
        ``("azimuth", "range")`` and the parameters (see :mod:`sarjax.io`).
    """
    xr = _xr()
    variables, coords, all_attrs = dataset_parts(product, radar=radar, scene=scene,
                                                 motion=motion, attrs=attrs)
    return xr.Dataset(variables, coords=coords, attrs=all_attrs)


def dataset_parts(product, *, radar=None, scene=None, motion=None, attrs=None):
    """The parts of :func:`to_xarray`'s dataset as plain NumPy: ``(variables, coords,
    attrs)``, each variable and coordinate ``name: (dims, array, attrs)`` (what
    ``xarray.Dataset(variables, coords=coords, attrs=attrs)`` takes)."""
    kind = type(product).__name__
    if kind not in _PRODUCTS:
        raise ValueError(f"product of type {kind} is neither RawData nor Image")
    data = np.asarray(product.data)
    azimuth = np.asarray(product.azimuth, float)
    range_ = np.asarray(product.range, float)
    name = _VARIABLE[kind]
    coords = {
        "azimuth": ("azimuth", azimuth, {"units": "m", "long_name": (
            "pulse position x' along track" if kind == "RawData" else "along-track x")}),
        "range": ("range", range_, {"units": "m", "long_name": (
            "range-sample coordinate r' = c t / 2" if kind == "RawData"
            else "closest-approach slant range r")}),
    }
    variables = {name: (("azimuth", "range"), data, {
        "long_name": "complex baseband echoes h(x', r')" if kind == "RawData"
        else "complex focused image"})}
    if motion is not None:
        n = data.shape[0]
        for comp, unit in (("horizontal", "m"), ("vertical", "m"), ("pointing", "rad")):
            value = getattr(motion, comp)
            if value is not None:
                variables[comp] = ("azimuth", np.broadcast_to(np.asarray(value, float), (n,)),
                                   {"units": unit})
    if scene is not None:
        variables.update(_scene_variables(scene))
    all_attrs = {"sarjax_product": kind, "method": getattr(product, "method", "") or "",
                 "method_reason": getattr(product, "method_reason", "") or "",
                 "conventions": "arrays (azimuth, range); metres, seconds, radians, hertz"}
    if kind == "RawData":
        all_attrs["azimuth_period"] = int(product.azimuth_period)
    if radar is not None:
        all_attrs.update({f"radar_{k}": v for k, v in radar_attributes(radar).items()})
    for key, value in (attrs or {}).items():
        all_attrs[key] = _attr(value)
    return variables, coords, all_attrs


def _attr(value):
    if isinstance(value, (str, int, float, np.integer, np.floating)) and not isinstance(
            value, bool):
        return value
    return json.dumps(value)


def _scene_variables(scene):
    if isinstance(scene, PointTargets):
        out = {}
        for field, unit in (("azimuth", "m"), ("range", "m"), ("reflectivity", "1"),
                            ("height", "m"), ("velocity_range", "m/s"),
                            ("velocity_azimuth", "m/s")):
            out[f"scatterer_{field}"] = ("scatterer", np.asarray(getattr(scene, field)),
                                         {"units": unit})
        return out
    if isinstance(scene, ReflectivityGrid):
        return {
            "scene_reflectivity": (("scene_azimuth", "scene_range"),
                                   np.asarray(scene.reflectivity), {"units": "1"}),
            "scene_height": (("scene_azimuth", "scene_range"), np.asarray(scene.height),
                             {"units": "m"}),
            "scene_azimuth": ("scene_azimuth", np.asarray(scene.azimuth), {"units": "m"}),
            "scene_range": ("scene_range", np.asarray(scene.range), {"units": "m"}),
        }
    raise ValueError(f"scene of type {type(scene).__name__} is not PointTargets or "
                     "ReflectivityGrid")


def from_xarray(dataset):
    """The :class:`~sarjax.RawData` or :class:`~sarjax.Image` held by a dataset made by
    :func:`to_xarray` (or read by :func:`sarjax.io.load`); also accepts a bare complex
    DataArray on ``("azimuth", "range")`` (taken as raw data)."""
    xr = _xr()
    if isinstance(dataset, xr.DataArray):
        array, kind, method, reason, period = dataset, "RawData", "", "", 0
    else:
        kind = dataset.attrs.get("sarjax_product")
        if kind not in _PRODUCTS:
            raise ValueError(f"dataset attribute sarjax_product={kind!r} is neither RawData "
                             "nor Image")
        if _VARIABLE[kind] not in dataset:
            raise ValueError(f"the {kind} file holds no {_VARIABLE[kind]!r} variable")
        array, method = dataset[_VARIABLE[kind]], str(dataset.attrs.get("method", ""))
        reason = str(dataset.attrs.get("method_reason", ""))
        period = _period(dataset.attrs.get("azimuth_period", 0))
    if array.dims != ("azimuth", "range"):
        raise ValueError(f"dims {array.dims} must be ('azimuth', 'range')")
    cls = _PRODUCTS[kind]
    fields = dict(data=np.asarray(array.values), azimuth=np.asarray(array["azimuth"].values),
                  range=np.asarray(array["range"].values))
    if kind == "RawData":
        return cls(**fields, method=method, method_reason=reason, azimuth_period=period)
    return cls(**fields)


def _period(value):
    """The ``azimuth_period`` attribute of a file as a whole number of pulses ≥ 0."""
    period = np.asarray(value)
    if period.ndim or not np.isfinite(period) or period < 0 or period != np.round(period):
        raise ValueError(f"the file's azimuth_period={value!r} is not a whole number of "
                         "pulses ≥ 0")
    return int(period)
