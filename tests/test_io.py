"""Native NetCDF files: xarray round trips, every parameter stored, one file reproduces
its run."""

import numpy as np
import pytest

import sarjax as sj
from sarjax import io


@pytest.fixture(scope="module")
def run():
    radar = sj.presets.airborne_xband(num_pulses=65, num_range=96, near_range=5000.0,
                                      pattern=sj.GaussianPattern(width=0.4))
    scene = sj.PointTargets(azimuth=[0.0, 2.0], range=[5100.0, 5120.0],
                            reflectivity=[1.0, 0.3 - 0.2j], height=[0.0, 12.0])
    x = (np.arange(65) - 32) * float(radar.azimuth_spacing)
    motion = sj.Motion(horizontal=0.01 * np.sin(x / 3), pointing=1e-3 * np.cos(x))
    raw = sj.simulate(radar, scene, motion, near_range=5000.0)
    return radar, scene, motion, raw


def test_to_xarray_dims_coordinates_and_attributes(run):
    radar, scene, motion, raw = run
    ds = raw.to_xarray(radar=radar, scene=scene, motion=motion, attrs={"note": {"a": 1}})
    assert ds["raw"].dims == ("azimuth", "range")
    assert ds["azimuth"].attrs["units"] == ds["range"].attrs["units"] == "m"
    np.testing.assert_array_equal(ds["range"].values, np.asarray(raw.range))
    assert ds.attrs["radar_carrier_frequency"] == float(radar.carrier_frequency)
    assert ds.attrs["radar_pattern"] == "GaussianPattern"
    assert ds.attrs["note"] == '{"a": 1}'
    assert "vertical" not in ds  # absent motion components stay absent
    back = sj.RawData.from_xarray(ds)
    np.testing.assert_array_equal(np.asarray(back.data), np.asarray(raw.data))
    assert back.method == "time_domain"
    with pytest.raises(ValueError, match="RawData, not Image"):
        sj.Image.from_xarray(ds)


def test_file_round_trip_is_exact_and_reproduces_the_run(run, tmp_path):
    radar, scene, motion, raw = run
    attrs = io.simulate_attributes(method="time_domain", num_pulses=65, num_range=96,
                                   near_range=5000.0)
    path = io.save(tmp_path / "raw.nc", raw, radar=radar, scene=scene, motion=motion,
                   attrs=attrs)
    loaded = io.load(path)
    np.testing.assert_array_equal(np.asarray(loaded.product.data), np.asarray(raw.data))
    np.testing.assert_array_equal(np.asarray(loaded.product.azimuth), np.asarray(raw.azimuth))
    assert io.radar_attributes(loaded.radar) == io.radar_attributes(radar)
    for field in ("azimuth", "range", "reflectivity", "height"):
        np.testing.assert_array_equal(np.asarray(getattr(loaded.scene, field)),
                                      np.asarray(getattr(scene, field)))
    np.testing.assert_array_equal(np.asarray(loaded.motion.horizontal),
                                  np.asarray(motion.horizontal))
    assert loaded.motion.vertical is None
    again = loaded.simulate()
    np.testing.assert_array_equal(np.asarray(again.data), np.asarray(raw.data))
    with pytest.raises(FileExistsError):
        io.save(path, raw)


def test_image_and_grid_scene_round_trip(run, tmp_path):
    radar, _, _, raw = run
    grid = sj.ReflectivityGrid(np.arange(6.0).reshape(2, 3) * (1 + 1j), [0.0, 1.0],
                               [5100.0, 5101.0, 5102.0])
    image = sj.focus(radar, raw)
    loaded = io.load(io.save(tmp_path / "image.nc", image, radar=radar, scene=grid))
    assert isinstance(loaded.product, sj.Image)
    np.testing.assert_array_equal(np.asarray(loaded.product.data), np.asarray(image.data))
    np.testing.assert_array_equal(np.asarray(loaded.scene.reflectivity),
                                  np.asarray(grid.reflectivity))
    assert loaded.motion is None
    with pytest.raises(ValueError, match="cannot be re-simulated|simulate_method"):
        loaded.simulate()


def test_bad_files(tmp_path):
    with pytest.raises(FileNotFoundError):
        io.load(tmp_path / "missing.nc")
    import xarray as xr

    xr.Dataset({"raw": (("range", "azimuth"), np.zeros((2, 2)))}, attrs={
        "sarjax_product": "RawData"}).to_netcdf(tmp_path / "swapped.nc", engine="h5netcdf")
    with pytest.raises(ValueError, match="dims"):
        io.load(tmp_path / "swapped.nc")


def _hdf5_layout(path):
    """Every object of an HDF5 file: its kind, dtype, shape and attributes (the dimension
    scales' object references left out), and the file's attributes."""
    h5py = pytest.importorskip("h5py")
    layout = {}
    with h5py.File(path) as f:
        def visit(name, obj):
            attrs = {k: np.asarray(v).tolist() for k, v in obj.attrs.items()
                     if k not in ("DIMENSION_LIST", "REFERENCE_LIST")}
            layout[name] = (type(obj).__name__, str(getattr(obj, "dtype", "")),
                            getattr(obj, "shape", None), repr(attrs))
        f.visititems(visit)
        layout["/"] = repr({k: np.asarray(v).tolist() for k, v in f.attrs.items()})
    return layout


@pytest.mark.parametrize("product", ["raw", "image"])
def test_the_direct_writer_writes_what_xarray_writes(run, tmp_path, product):
    """``save`` writes NetCDF-4 through h5netcdf without importing xarray (0.25 s of a
    command's run): the file is the one ``xarray.Dataset.to_netcdf(engine="h5netcdf")``
    writes from ``to_xarray`` — the same dimensions and ids, variables, dtypes, values
    and attributes, and xarray reads both as identical datasets."""
    pytest.importorskip("h5netcdf")
    xr = pytest.importorskip("xarray")
    radar, scene, motion, raw = run
    if product == "image":
        raw = sj.Image(data=np.asarray(raw.data)[:8, :6], azimuth=np.arange(8.0),
                       range=5000.0 + np.arange(6.0))
        scene = sj.ReflectivityGrid(azimuth=np.arange(3.0), range=5100.0 + np.arange(2.0),
                                    reflectivity=np.ones((3, 2)) * (1 + 1j))
        motion = None  # an image's rows are not the pulses
    written = io.save(tmp_path / "direct.nc", raw, radar=radar, scene=scene, motion=motion,
                      attrs={"note": {"a": 1}, "count": 3})
    ds = raw.to_xarray(radar=radar, scene=scene, motion=motion,
                       attrs={"note": {"a": 1}, "count": 3})
    for name in [n for n in ds.data_vars if np.iscomplexobj(ds[n].values)]:
        var = ds[name]
        ds[f"{name}_real"] = var.real.assign_attrs(var.attrs, complex_part="real")
        ds[f"{name}_imag"] = var.imag.assign_attrs(var.attrs, complex_part="imag")
        ds = ds.drop_vars(name)
    ds.to_netcdf(tmp_path / "xarray.nc", engine="h5netcdf", format="NETCDF4")
    assert _hdf5_layout(written) == _hdf5_layout(tmp_path / "xarray.nc")
    with xr.open_dataset(written, engine="h5netcdf") as a, \
            xr.open_dataset(tmp_path / "xarray.nc", engine="h5netcdf") as b:
        assert a.load().identical(b.load())
