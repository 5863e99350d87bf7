"""Native files: raw data, images and every parameter of a run in one NetCDF-4/HDF5 file.

Layout (through xarray; dims ``("azimuth", "range")``, coordinates in metres):

* ``raw`` or ``image``: the complex samples. NetCDF has no complex type, so on disk they
  are two float variables ``raw_real`` / ``raw_imag`` (recombined on loading).
* ``horizontal``, ``vertical`` [m], ``pointing`` [rad] on ``azimuth``: the motion.
* the scene: ``scatterer_*`` on dim ``scatterer`` (point targets) or
  ``scene_reflectivity`` / ``scene_height`` on ``(scene_azimuth, scene_range)`` (grid).
* attributes: ``sarjax_product`` (``RawData`` / ``Image``), ``method``, every radar
  field as ``radar_<name>`` (SI units), the pattern, the simulation settings as
  ``simulate_<name>`` (``num_pulses``, ``near_range``, ``azimuth_center``, ``dtype`` and
  the simulator options), anything else given as ``attrs`` (e.g. the TOML configuration).

``load(path).simulate()`` re-runs the simulation that made a raw-data file.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from ._data import Image, RawData
from .motion import Motion
from .radar import Radar
from .scene import PointTargets, ReflectivityGrid

__all__ = ["Run", "from_xarray", "load", "radar_attributes", "radar_from_attributes",
           "save", "to_xarray"]

_RADAR_SCALARS = ("carrier_frequency", "bandwidth", "chirp_duration", "sampling_rate", "prf",
                  "velocity", "height", "antenna_length", "reference_range", "near_range",
                  "squint")
_UNITS = {"carrier_frequency": "Hz", "bandwidth": "Hz", "chirp_duration": "s",
          "sampling_rate": "Hz", "prf": "Hz", "velocity": "m/s", "height": "m",
          "antenna_length": "m", "reference_range": "m", "near_range": "m", "squint": "rad"}
_PRODUCTS = {"RawData": RawData, "Image": Image}
_VARIABLE = {"RawData": "raw", "Image": "image"}


def _xr():
    try:
        import xarray
    except ImportError:
        raise ImportError("xarray is needed for sarjax.io: pip install xarray h5netcdf") from None
    return xarray


# ---- radar <-> attributes -------------------------------------------------------------


def radar_attributes(radar: Radar) -> dict:
    """Every field of ``radar`` as plain numbers / strings (SI units)."""
    from . import antenna

    out = {name: float(np.asarray(getattr(radar, name))) for name in _RADAR_SCALARS}
    out["num_pulses"] = int(radar.num_pulses)
    out["num_range"] = int(radar.num_range)
    pattern = radar.pattern
    out["pattern"] = type(pattern).__name__
    if isinstance(pattern, antenna.GaussianPattern):
        out["pattern_width"] = float(np.asarray(pattern.width))
    elif not isinstance(pattern, antenna.Sinc2Pattern):
        raise ValueError(f"pattern {type(pattern).__name__} cannot be written to a file: "
                         "only Sinc2Pattern and GaussianPattern are known")
    return out


def radar_from_attributes(attrs: dict, prefix: str = "") -> Radar:
    """Inverse of :func:`radar_attributes` (keys optionally prefixed)."""
    from . import antenna

    get = lambda k: attrs[prefix + k]

    def number(name, kind):
        try:
            value = get(name)
        except KeyError:
            raise ValueError(f"radar parameter {name!r} missing from the file") from None
        try:
            return kind(value)
        except (TypeError, ValueError):
            raise ValueError(f"radar parameter {name}={value!r} in the file is not a "
                             f"{kind.__name__}") from None

    kwargs = {name: number(name, float) for name in _RADAR_SCALARS}
    kwargs["num_pulses"] = number("num_pulses", int)
    kwargs["num_range"] = number("num_range", int)
    try:
        pattern = str(get("pattern"))
    except KeyError:
        raise ValueError("radar parameter 'pattern' missing from the file") from None
    if pattern == "GaussianPattern":
        kwargs["pattern"] = antenna.GaussianPattern(width=number("pattern_width", float))
    elif pattern != "Sinc2Pattern":
        raise ValueError(f"unknown antenna pattern {pattern!r} in the file")
    return Radar(**kwargs)


# ---- products <-> xarray ----------------------------------------------------------------


def to_xarray(product, *, radar=None, scene=None, motion=None, attrs=None):
    """A :class:`~sarjax.RawData` or :class:`~sarjax.Image` as an ``xarray.Dataset``.

    Args:
        product: the raw data or image.
        radar, scene, motion: the run's parameters (stored when given).
        attrs: further attributes (str, numbers, or anything JSON-serialisable).

    Returns:
        Dataset with the complex variable ``raw`` / ``image`` on
        ``("azimuth", "range")`` and the parameters (see the module docstring).
    """
    xr = _xr()
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
                 "conventions": "arrays (azimuth, range); metres, seconds, radians, hertz"}
    if radar is not None:
        all_attrs.update({f"radar_{k}": v for k, v in radar_attributes(radar).items()})
    for key, value in (attrs or {}).items():
        all_attrs[key] = _attr(value)
    return xr.Dataset(variables, coords=coords, attrs=all_attrs)


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
    :func:`to_xarray` (or read by :func:`load`); also accepts a bare complex DataArray on
    ``("azimuth", "range")`` (taken as raw data)."""
    xr = _xr()
    if isinstance(dataset, xr.DataArray):
        array, kind, method = dataset, "RawData", ""
    else:
        kind = dataset.attrs.get("sarjax_product")
        if kind not in _PRODUCTS:
            raise ValueError(f"dataset attribute sarjax_product={kind!r} is neither RawData "
                             "nor Image")
        if _VARIABLE[kind] not in dataset:
            raise ValueError(f"the {kind} file holds no {_VARIABLE[kind]!r} variable")
        array, method = dataset[_VARIABLE[kind]], str(dataset.attrs.get("method", ""))
    if array.dims != ("azimuth", "range"):
        raise ValueError(f"dims {array.dims} must be ('azimuth', 'range')")
    cls = _PRODUCTS[kind]
    fields = dict(data=np.asarray(array.values), azimuth=np.asarray(array["azimuth"].values),
                  range=np.asarray(array["range"].values))
    return cls(**fields, method=method) if kind == "RawData" else cls(**fields)


def _scene_from(ds):
    if "scatterer_azimuth" in ds:
        get = lambda f: np.asarray(ds[f"scatterer_{f}"].values)
        return PointTargets(get("azimuth"), get("range"), get("reflectivity"), get("height"),
                            velocity_range=get("velocity_range"),
                            velocity_azimuth=get("velocity_azimuth"))
    if "scene_reflectivity" in ds:
        return ReflectivityGrid(np.asarray(ds["scene_reflectivity"].values),
                                np.asarray(ds["scene_azimuth"].values),
                                np.asarray(ds["scene_range"].values),
                                np.asarray(ds["scene_height"].values))
    return None


def _motion_from(ds):
    parts = {c: np.asarray(ds[c].values) for c in ("horizontal", "vertical", "pointing")
             if c in ds}
    return Motion(**parts) if parts else None


# ---- files ------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Run:
    """Everything read back from a sarjax file.

    Attributes:
        product: :class:`~sarjax.RawData` or :class:`~sarjax.Image`.
        radar, scene, motion: the stored parameters (None where absent).
        attrs: all file attributes.
    """

    product: RawData | Image
    radar: Radar | None
    scene: PointTargets | ReflectivityGrid | None
    motion: Motion | None
    attrs: dict

    def simulate(self):
        """Re-run the simulation that produced this raw-data file."""
        from ._simulate import simulate

        if self.radar is None or self.scene is None:
            raise ValueError("the file holds no radar or scene: it cannot be re-simulated")
        settings = {k.removeprefix("simulate_"): v for k, v in self.attrs.items()
                    if k.startswith("simulate_")}
        if "method" not in settings:
            raise ValueError("the file holds no simulate_method attribute")
        options = json.loads(settings.pop("options", "{}"))
        return simulate(self.radar, self.scene, self.motion, method=settings["method"],
                        num_pulses=int(settings["num_pulses"]),
                        num_range=int(settings["num_range"]),
                        near_range=float(settings["near_range"]),
                        azimuth_center=float(settings["azimuth_center"]),
                        dtype=np.dtype(settings["dtype"]), **options)


def simulate_attributes(*, method, num_pulses, num_range, near_range, azimuth_center=0.0,
                        dtype="complex128", **options) -> dict:
    """The ``simulate_*`` attributes that let :meth:`Run.simulate` repeat a simulation."""
    return {"simulate_method": str(method), "simulate_num_pulses": int(num_pulses),
            "simulate_num_range": int(num_range), "simulate_near_range": float(near_range),
            "simulate_azimuth_center": float(azimuth_center),
            "simulate_dtype": np.dtype(dtype).name, "simulate_options": json.dumps(options)}


def save(path, product, *, radar=None, scene=None, motion=None, attrs=None,
         overwrite: bool = False):
    """Write ``product`` and the run's parameters to a NetCDF-4 file (atomically).

    Args:
        path: destination (``.nc``).
        product: :class:`~sarjax.RawData` or :class:`~sarjax.Image`.
        radar, scene, motion, attrs: see :func:`to_xarray`.
        overwrite: replace an existing file (otherwise FileExistsError).

    Returns:
        The path.
    """
    from .export._common import atomic_write

    ds = to_xarray(product, radar=radar, scene=scene, motion=motion, attrs=attrs)
    for name in list(ds.data_vars):
        if np.iscomplexobj(ds[name].values):
            var = ds[name]
            ds[f"{name}_real"] = var.real.assign_attrs(var.attrs, complex_part="real")
            ds[f"{name}_imag"] = var.imag.assign_attrs(var.attrs, complex_part="imag")
            ds = ds.drop_vars(name)

    def write(tmp):
        ds.to_netcdf(tmp, engine=_engine(), format="NETCDF4")

    return atomic_write(path, write, overwrite=overwrite)


def _engine():
    try:
        import h5netcdf  # noqa: F401

        return "h5netcdf"
    except ImportError:
        return "netcdf4"


def open_dataset(path):
    """The file as an ``xarray.Dataset`` (complex variables recombined, loaded in memory)."""
    xr = _xr()
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path} does not exist")
    try:
        with xr.open_dataset(path, engine=_engine()) as ds:
            ds = ds.load()
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise ValueError(f"cannot read {path}: not a NetCDF-4/HDF5 file sarjax can open "
                         f"({type(err).__name__}: {err})") from err
    for name in [n for n in ds.data_vars if n.endswith("_real")]:
        base = name.removesuffix("_real")
        if f"{base}_imag" in ds:
            attrs = {k: v for k, v in ds[name].attrs.items() if k != "complex_part"}
            ds[base] = (ds[name] + 1j * ds[f"{base}_imag"]).assign_attrs(attrs)
            ds = ds.drop_vars([name, f"{base}_imag"])
    return ds


def load(path) -> Run:
    """Read a file written by :func:`save`."""
    from . import _validate

    ds = open_dataset(path)
    attrs = dict(ds.attrs)
    try:
        radar = (radar_from_attributes(attrs, "radar_")
                 if "radar_carrier_frequency" in attrs else None)
        if radar is not None:
            _validate.check_radar(radar)
        return Run(from_xarray(ds), radar, _scene_from(ds), _motion_from(ds), attrs)
    except (KeyError, TypeError, ValueError) as err:
        message = err.args[0] if isinstance(err, KeyError) and err.args else err
        raise ValueError(f"{path} is not a valid sarjax file: {message}") from None
