"""Native files: raw data, images and every parameter of a run in one NetCDF-4/HDF5 file.

Layout (xarray's, read through xarray and written through h5netcdf directly, as
xarray's h5netcdf engine writes it; dims ``("azimuth", "range")``, coordinates in
metres):

* ``raw`` or ``image``: the complex samples. NetCDF has no complex type, so on disk they
  are two float variables ``raw_real`` / ``raw_imag`` (recombined on loading).
* ``horizontal``, ``vertical`` [m], ``pointing`` [rad] on ``azimuth``: the motion.
* the scene: ``scatterer_*`` on dim ``scatterer`` (point targets) or
  ``scene_reflectivity`` / ``scene_height`` on ``(scene_azimuth, scene_range)`` (grid).
* attributes: ``sarjax_product`` (``RawData`` / ``Image``), ``method``, raw data's
  ``azimuth_period`` (pulses; 0: not periodic, :class:`~sarjax.RawData`), every radar
  field as ``radar_<name>`` (SI units), the pattern, the simulation settings as
  ``simulate_<name>`` (``num_pulses``, ``near_range``, ``azimuth_center``, ``dtype`` and
  the simulator options), anything else given as ``attrs`` (e.g. the TOML configuration).

``load(path).simulate()`` re-runs the simulation that made a raw-data file.

The conversions this module writes and reads live beside the objects they convert and
are available here too: :func:`to_xarray` / :func:`from_xarray` (products,
:mod:`sarjax._data`) and :func:`radar_attributes` / :func:`radar_from_attributes`
(:mod:`sarjax.radar`).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from . import _validate
from ._data import Image, RawData, _xr, dataset_parts, from_xarray, to_xarray
from ._files import atomic_write
from .motion import Motion
from .radar import Radar, radar_attributes, radar_from_attributes
from .scene import PointTargets, ReflectivityGrid

__all__ = ["Run", "from_xarray", "load", "radar_attributes", "radar_from_attributes",
           "save", "to_xarray"]


# ---- scene and motion from a dataset ----------------------------------------------------


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

    def simulate_arguments(self) -> dict:
        """The keyword arguments of :func:`sarjax.simulate` that repeat the simulation
        which produced this raw-data file (read from its ``simulate_*`` attributes)."""
        if self.radar is None or self.scene is None:
            raise ValueError("the file holds no radar or scene: it cannot be re-simulated")
        settings = {k.removeprefix("simulate_"): v for k, v in self.attrs.items()
                    if k.startswith("simulate_")}
        if "method" not in settings:
            raise ValueError("the file holds no simulate_method attribute")
        options = json.loads(settings.pop("options", "{}"))
        return dict(radar=self.radar, scene=self.scene, motion=self.motion,
                    method=settings["method"], num_pulses=int(settings["num_pulses"]),
                    num_range=int(settings["num_range"]),
                    near_range=float(settings["near_range"]),
                    azimuth_center=float(settings["azimuth_center"]),
                    dtype=np.dtype(settings["dtype"]), **options)

    def simulate(self):
        """Re-run the simulation that produced this raw-data file:
        ``sarjax.simulate(**self.simulate_arguments())``."""
        from ._simulate import simulate

        return simulate(**self.simulate_arguments())


def simulate_attributes(*, method, num_pulses, num_range, near_range, azimuth_center=0.0,
                        dtype="complex128", **options) -> dict:
    """The ``simulate_*`` attributes that let :meth:`Run.simulate` repeat a simulation
    (:meth:`Run.simulate_arguments` reads them back)."""
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
    variables, coords, attributes = dataset_parts(product, radar=radar, scene=scene,
                                                  motion=motion, attrs=attrs)
    # NetCDF-4 has no complex type: two real variables each, after the real ones
    stored = {name: v for name, v in variables.items() if not np.iscomplexobj(v[1])}
    for name, (dims, values, var_attrs) in variables.items():
        if np.iscomplexobj(values):
            stored[f"{name}_real"] = (dims, np.real(values), dict(var_attrs, complex_part="real"))
            stored[f"{name}_imag"] = (dims, np.imag(values), dict(var_attrs, complex_part="imag"))

    if _engine() == "h5netcdf":
        # written directly: the file xarray writes with this engine, without importing
        # xarray and pandas (0.25 s of a command's run; tests/test_io.py compares them)
        def write(tmp):
            _write_h5netcdf(tmp, stored, coords, attributes)
    else:
        def write(tmp):
            _xr().Dataset(stored, coords=coords, attrs=attributes).to_netcdf(
                tmp, engine="netcdf4", format="NETCDF4")

    return atomic_write(path, write, overwrite=overwrite)


def _write_h5netcdf(path, variables, coords, attributes):
    """A NetCDF-4 file of ``coords`` and ``variables`` (``name: (dims, array, attrs)``)
    as xarray's ``to_netcdf(engine="h5netcdf")`` writes it: the dimensions, each
    coordinate a dimension's variable, floating variables with ``_FillValue`` NaN."""
    import h5netcdf

    # xarray's order (its dimensions' ids follow it), each dims a tuple
    items = {name: ((dims,) if isinstance(dims, str) else tuple(dims), np.asarray(values), a)
             for name, (dims, values, a) in {**variables, **coords}.items()}
    with h5netcdf.File(path, "w") as f:
        sizes = {}
        for dims, values, _ in items.values():
            sizes.update(zip(dims, values.shape, strict=True))
        f.dimensions = sizes
        for name, (dims, values, var_attrs) in items.items():
            fill = {"fillvalue": np.nan} if np.issubdtype(values.dtype, np.floating) else {}
            variable = f.create_variable(name, dims, values.dtype, data=values, **fill)
            if fill:
                variable.attrs["_FillValue"] = values.dtype.type(np.nan)
            for key, value in var_attrs.items():
                variable.attrs[key] = value
        for key, value in attributes.items():
            f.attrs[key] = value


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
