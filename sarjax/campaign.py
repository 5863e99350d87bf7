"""Campaigns: many scenarios, one resumable Zarr store.

A campaign is a grid of scenarios, each measured once; two kinds:

* :class:`ValidityMap`: each method against the exact model over deviation rms × squint
  × motion realization — the raw NMSE and whether ``simulate`` warned;
* :class:`FitMonteCarlo`: cold-start motion fits (:func:`sarjax.fit_motion`) of noisy
  exact-model data over deviation rms × SNR × realization — the fit's error in its own
  gauge beside the Cramér–Rao bound.

The scenarios are cut into *units* of ``unit`` scenarios; a unit is the unit of work and
of writing:

* the store is created whole before any unit runs (every array pre-sized, filled with
  NaN or −1; created in a temporary folder and renamed into place);
* a finished unit writes its slice of every result array (one Zarr chunk each, each file
  written atomically by Zarr's local store), *then* its flag in ``unit_done``;
* a rerun of the same campaign on the same store reads ``unit_done`` and runs only the
  units not flagged, so nothing finished is recomputed and a unit cut off anywhere
  (``kill -9`` between two files) is recomputed whole. Each scenario's result depends
  on nothing but its own parameters, so a resumed store equals an uninterrupted one bit
  for bit (``tests/test_campaign.py``).

A store made by another campaign, or not by sarjax, is refused with the reason, never
overwritten. Units are shared out over the processes of a multi-process run
(:mod:`sarjax.distributed`): unit ``u`` runs in process ``u mod P``.

Read a store with ``xarray.open_zarr(path, consolidated=False)`` (or :func:`load`);
:func:`summary` gives the table printed at the end, :func:`sarjax.plot.validity_map` the
figure of a validity map.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import os
import shutil
import time
import uuid
import warnings
from pathlib import Path
from typing import ClassVar

import numpy as np

from ._data import Acquisition
from ._simulate import simulate
from ._validate import SwathWarning, ValidityWarning
from .metrics import nmse_db
from .motion import Motion, seed_pointing_jitter, smooth_deviation
from .radar import Radar, radar_attributes
from .scene import PointTargets


class Campaign:
    """What every campaign declares (a frozen dataclass with ``radar``, ``scene``,
    ``realizations`` and ``unit`` fields): its ``kind``, its ``results`` (name →
    (dtype, units, meaning)), its scenario axis and a runner that measures one scenario.
    :class:`ValidityMap` and :class:`FitMonteCarlo` are the two kinds."""

    kind: ClassVar[str]
    results: ClassVar[dict[str, tuple[str, str, str]]]
    axes: ClassVar[tuple[str, ...]]  # the grid's tuple fields, slowest first

    def _check(self):
        for name in self.axes:
            values = tuple(getattr(self, name))
            object.__setattr__(self, name, values)
            if not values:
                raise ValueError(f"{type(self).__name__}.{name} is empty")
        if not (isinstance(self.realizations, int) and self.realizations >= 1):
            raise ValueError(f"{type(self).__name__}.realizations={self.realizations!r} "
                             "must be ≥ 1")
        if not (isinstance(self.unit, int) and self.unit >= 1):
            raise ValueError(f"{type(self).__name__}.unit={self.unit!r} must be an integer "
                             "≥ 1")
        bad = [v for v in self.deviation_rms if not (np.isfinite(v) and v >= 0)]
        if bad:
            raise ValueError(f"{type(self).__name__}.deviation_rms holds {bad}: each must "
                             "be ≥ 0 m")

    def scenarios(self) -> dict[str, np.ndarray]:
        """The scenario axis: a (scenario,) array per grid axis (the last varies
        fastest, the realization just before it)."""
        grids = [getattr(self, name) for name in self.axes]
        rows = list(itertools.product(*grids[:-1], range(self.realizations), grids[-1]))
        names = (*self.axes[:-1], "realization", self.axes[-1])
        out = {}
        for i, name in enumerate(names):
            column = [row[i] for row in rows]
            out[_COLUMN.get(name, name)] = (
                np.array(column, np.int64) if name == "realization" else
                np.array(column, dtype=object) if isinstance(column[0], str) else
                np.array(column, float))
        return out

    @property
    def num_scenarios(self) -> int:
        return self.realizations * int(np.prod([len(getattr(self, n)) for n in self.axes]))

    @property
    def num_units(self) -> int:
        return -(-self.num_scenarios // self.unit)

    def identity(self) -> str:
        """The campaign as canonical JSON: a store answers to this exactly."""
        scene = {name: np.asarray(getattr(self.scene, name)).tolist()
                 for name in ("azimuth", "range")}
        gamma = np.asarray(self.scene.reflectivity)
        scene["reflectivity"] = [gamma.real.tolist(), gamma.imag.tolist()]
        spec = {"kind": self.kind, "radar": radar_attributes(self.radar), "scene": scene}
        for field in dataclasses.fields(self):
            if field.name not in ("radar", "scene"):
                spec[field.name] = getattr(self, field.name)
        return json.dumps(spec, sort_keys=True, default=list)

    def runner(self):  # pragma: no cover - each kind defines it
        """A callable measuring one scenario (a dict of its axis values), returning one
        value per entry of ``results``."""
        raise NotImplementedError


_COLUMN = {"methods": "method"}  # the scenario column of a grid axis, where it differs


@dataclasses.dataclass(frozen=True)
class ValidityMap(Campaign):
    """Each method against the exact model (``time_domain``): raw NMSE and whether
    ``simulate`` warned, over deviation rms × squint × realization × method.

    Attributes:
        radar: the :class:`~sarjax.Radar` (its grid: ``num_pulses`` × ``num_range``).
        scene: the :class:`~sarjax.PointTargets`.
        methods: the simulators to measure.
        deviation_rms: rms of the smooth horizontal and vertical deviations [m].
        squint_deg: squint angles φ_d [deg].
        realizations: motion realizations per grid point.
        max_cycles: highest deviation cycles per footprint (``smooth_deviation``).
        unit: scenarios per unit of work (and per Zarr chunk).
    """

    radar: Radar
    scene: PointTargets
    methods: tuple[str, ...] = ("fourier_2d", "small_deviation", "moderate_deviation")
    deviation_rms: tuple[float, ...] = (0.0, 0.005, 0.02, 0.1)
    squint_deg: tuple[float, ...] = (0.0,)
    realizations: int = 1
    max_cycles: float = 1.0
    unit: int = 8

    kind: ClassVar[str] = "sarjax.campaign/validity-map/1"
    results: ClassVar[dict] = {  # name: (dtype, units, meaning)
        "nmse_db": ("f8", "dB", "raw NMSE of the method against the exact model"),
        "warned": ("i1", "1", "1: simulate warned (ValidityWarning or SwathWarning)"),
        "refused": ("i1", "1", "1: the method refused the scenario (ValueError)"),
    }
    axes: ClassVar[tuple[str, ...]] = ("deviation_rms", "squint_deg", "methods")

    def __post_init__(self):
        self._check()
        bad = [v for v in self.squint_deg if not (np.isfinite(v) and abs(v) < 80)]
        if bad:
            raise ValueError(f"ValidityMap.squint_deg holds {bad}: each must lie in "
                             "(−80, 80)")

    def runner(self):
        return _ValidityRunner(self)


@dataclasses.dataclass(frozen=True)
class FitMonteCarlo(Campaign):
    """The inverse module's Monte Carlo: :func:`sarjax.fit_motion` from a cold start on
    noisy exact-model data of a known point-target scene, its error against the truth in
    its own gauge (:func:`sarjax.inverse.align`) beside the Cramér–Rao bound
    (:func:`sarjax.crb`), over deviation rms × SNR × realization.

    Each realization draws smooth Δy, Δz of the given rms and the seed's pointing jitter
    (amplitude λ/(20L), period T_s/10, a random phase), and complex white noise of power
    mean|h|²/SNR (the raw SNR of ``tests/test_inverse.py``).

    Attributes:
        radar, scene: as :class:`ValidityMap` (the scene: the calibration targets).
        deviation_rms: rms of Δy and Δz [m].
        snr_db: raw signal-to-noise ratios [dB].
        realizations: draws per grid point.
        max_cycles: highest deviation cycles per footprint.
        unit: scenarios per unit of work (a fit takes seconds: 1 by default).
    """

    radar: Radar
    scene: PointTargets
    deviation_rms: tuple[float, ...] = (0.02,)
    snr_db: tuple[float, ...] = (0.0, 10.0)
    realizations: int = 10
    max_cycles: float = 1.0
    unit: int = 1

    kind: ClassVar[str] = "sarjax.campaign/fit-monte-carlo/1"
    results: ClassVar[dict] = {
        "error_los": ("f8", "m", "rms line-of-sight error of the fit in its gauge"),
        "error_horizontal": ("f8", "m", "rms Δy error in the fit's gauge"),
        "error_vertical": ("f8", "m", "rms Δz error in the fit's gauge"),
        "crb_los": ("f8", "m", "rms Cramér–Rao bound of the line-of-sight profile"),
        "std_los": ("f8", "m", "rms standard deviation the fit reports (its covariance)"),
        "converged": ("i1", "1", "1: the fit converged"),
    }
    axes: ClassVar[tuple[str, ...]] = ("deviation_rms", "snr_db")

    def __post_init__(self):
        self._check()
        bad = [v for v in self.snr_db if not np.isfinite(v)]
        if bad:
            raise ValueError(f"FitMonteCarlo.snr_db holds {bad}: each must be finite")

    def runner(self):
        return _FitRunner(self)


# ---------------------------------------------------------------------------- the store


def _zarr():
    try:
        import zarr
    except ImportError as err:  # pragma: no cover - a core dependency
        raise ImportError("campaigns need zarr (pip install 'zarr>=3')") from err
    return zarr


def _open_existing(path: Path, campaign: Campaign):
    """The store at ``path`` if it holds this campaign; otherwise a ValueError naming why
    (nothing is changed)."""
    zarr = _zarr()
    try:
        group = zarr.open_group(str(path), mode="r+", zarr_format=3)
        identity = group.attrs.get("sarjax_campaign")
    except Exception as err:  # unreadable metadata: not ours to touch
        raise ValueError(f"{path} exists and is not a readable Zarr store "
                         f"({type(err).__name__}: {err}); it is left as it is: choose "
                         "another path") from None
    if identity is None:
        raise ValueError(f"{path} exists and is not a sarjax campaign store; it is left "
                         "as it is: choose another path")
    if identity != campaign.identity():
        raise ValueError(f"{path} holds another campaign (its parameters differ from this "
                         "one's); it is left as it is: choose another path, or rerun "
                         "that campaign's configuration to resume it")
    for name in (*campaign.results, "unit_done"):
        if name not in group:
            raise ValueError(f"{path}: the campaign store lacks {name!r} (damaged); it is "
                             "left as it is")
    return group


def _create(path: Path, campaign: Campaign):
    """Create the store whole in a temporary folder beside ``path``, then rename it into
    place (a store that exists is complete in its layout)."""
    zarr = _zarr()
    scenarios = campaign.scenarios()
    n, unit = campaign.num_scenarios, campaign.unit
    tmp = path.parent / f".{path.name}.{uuid.uuid4().hex}.partial"
    try:
        group = zarr.open_group(str(tmp), mode="w-", zarr_format=3)
        group.attrs.update({
            "sarjax_campaign": campaign.identity(),
            "title": f"sarjax {type(campaign).__name__} campaign",
            "num_scenarios": n, "unit": unit})
        for name, values in scenarios.items():
            dtype = np.dtypes.StringDType() if name == "method" else values.dtype
            array = group.create_array(name, shape=(n,), chunks=(n,), dtype=dtype,
                                       dimension_names=["scenario"])
            array[:] = values.astype(str) if name == "method" else values
        for name, (dtype, units, meaning) in campaign.results.items():
            fill = np.nan if dtype == "f8" else -1
            array = group.create_array(name, shape=(n,), chunks=(unit,), dtype=dtype,
                                       fill_value=fill, dimension_names=["scenario"])
            array.attrs.update({"units": units, "long_name": meaning})
        done = group.create_array("unit_done", shape=(campaign.num_units,), chunks=(1,),
                                  dtype="i1", fill_value=0, dimension_names=["unit"])
        done.attrs["long_name"] = f"1: unit finished (scenarios u·{unit} … (u+1)·{unit} − 1)"
        os.rename(tmp, path)
    except OSError as err:  # another process may have created it meanwhile: then reopen
        if not path.exists():
            raise ValueError(f"cannot create the campaign store {path}: {err}") from None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)  # gone after the rename, or a failed try
    return _open_existing(path, campaign)


def open_store(path, campaign: Campaign):
    """The campaign's store at ``path``: created when absent, reopened when it holds the
    same campaign, refused (ValueError) otherwise."""
    path = Path(path)
    if not path.parent.is_dir():
        raise ValueError(f"folder {path.parent} of the store does not exist")
    if path.exists():
        return _open_existing(path, campaign)
    return _create(path, campaign)


def _remove_partial_files(path: Path):
    """Zarr's temporary files of writes cut off by a killed process."""
    for leftover in path.rglob("*.partial"):
        leftover.unlink(missing_ok=True)


# ---------------------------------------------------------------------------- running


def _pulse_azimuths(radar):
    """(azimuth,) x' of the radar's pulses, centred on 0 [m]."""
    acquisition = Acquisition(num_pulses=radar.num_pulses, num_range=radar.num_range,
                              near_range=radar.near_range, azimuth_center=0.0)
    return np.asarray(acquisition.pulse_azimuths(radar))


def _deviations(campaign, x, rms, keys):
    """(Δy, Δz): smooth deviations of ``rms`` [m], one random key (or generator) each."""
    aperture = float(campaign.radar.footprint(campaign.radar.reference_range))
    return tuple(smooth_deviation(x, key=key, rms=rms, max_cycles=campaign.max_cycles,
                                  aperture=aperture) for key in keys)


def _motion(campaign: ValidityMap, rms: float, realization: int):
    if rms == 0.0:
        return None
    keys = np.random.SeedSequence([2017, realization]).generate_state(2)
    dy, dz = _deviations(campaign, _pulse_azimuths(campaign.radar), rms,
                         [int(k) for k in keys])
    return Motion(horizontal=dy, vertical=dz)


def _local_devices():
    """Each process runs its own units on its own devices (simulate's default would span
    every process's devices in a multi-process run)."""
    import jax

    return dict(devices=jax.local_devices())


class _ValidityRunner:
    """Scenario results, the exact model's data kept for the methods of the same grid
    point (the method varies fastest)."""

    def __init__(self, campaign: ValidityMap):
        self.campaign = campaign
        self._exact_key = None
        self._exact = None

    def __call__(self, row):
        method, rms = str(row["method"]), float(row["deviation_rms"])
        squint_deg, realization = float(row["squint_deg"]), int(row["realization"])
        local = _local_devices()
        campaign = self.campaign
        radar = campaign.radar.replace(squint=np.deg2rad(squint_deg))
        motion = _motion(campaign, rms, realization)
        key = (rms, squint_deg, realization)
        if key != self._exact_key:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", SwathWarning)
                self._exact = np.asarray(simulate(radar, campaign.scene, motion,
                                                  method="time_domain", **local).data)
            self._exact_key = key
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                fast = np.asarray(simulate(radar, campaign.scene, motion, method=method,
                                           **local).data)
            except ValueError:  # a motion or squint the method does not model
                return np.nan, 0, 1
        warned = any(issubclass(w.category, (ValidityWarning, SwathWarning))
                     for w in caught)
        if not np.any(self._exact):
            return np.nan, int(warned), 0
        return nmse_db(fast, self._exact), int(warned), 0


class _FitRunner:
    """One cold-start fit of noisy data and its bound (see :class:`FitMonteCarlo`)."""

    def __init__(self, campaign: FitMonteCarlo):
        self.campaign = campaign

    def __call__(self, row):
        from .inverse import align, crb, fit_motion

        campaign, radar = self.campaign, self.campaign.radar
        rms, snr_db = float(row["deviation_rms"]), float(row["snr_db"])
        # the draw depends on the scenario's values only (not on its unit or process)
        rng = np.random.default_rng(np.random.SeedSequence(
            [2017, int(row["realization"]), int(round(rms * 1e9)), int(round(snr_db * 1e6))]))
        x = _pulse_azimuths(radar)
        phase = float(rng.uniform(-np.pi, np.pi))
        # (amplitude, period, phase) of seed_pointing_jitter, as crb takes them
        jitter = (float(radar.wavelength / radar.antenna_length) / 20,
                  float(radar.integration_time()) / 10, phase)
        dy, dz = _deviations(campaign, x, rms, [rng, rng])
        truth = Motion(horizontal=dy, vertical=dz,
                       pointing=np.asarray(seed_pointing_jitter(radar, x, phase=phase)))
        clean = simulate(radar, campaign.scene, truth, method="time_domain",
                         **_local_devices())
        data = np.asarray(clean.data)
        noise_power = float(np.mean(np.abs(data) ** 2) / 10 ** (snr_db / 10))
        noise = np.sqrt(noise_power / 2) * (rng.normal(size=data.shape)
                                            + 1j * rng.normal(size=data.shape))
        raw = dataclasses.replace(clean, data=data + noise)
        result = fit_motion(radar, campaign.scene, raw)
        ey, ez, _ = align(result.motion, truth, result)
        s0, c0 = result.reference_direction
        rms_of = lambda v: float(np.sqrt(np.mean(np.square(v))))
        bound = crb(radar, campaign.scene, noise_power=noise_power, motion=truth,
                    jitter=jitter)
        std = result.profile_std().get("line_of_sight")
        return (rms_of(-s0 * ey + c0 * ez), rms_of(ey), rms_of(ez),
                float(bound.rms["line_of_sight"]),
                np.nan if std is None else rms_of(std), int(bool(result.converged)))


def run(campaign: Campaign, path, *, progress=None, process_index: int | None = None,
        process_count: int | None = None) -> int:
    """Run (or resume) ``campaign`` into the Zarr store ``path``.

    Args:
        campaign: the :class:`Campaign`.
        path: the store (a folder); created when absent, resumed when it holds this
            campaign, refused when it holds anything else.
        progress: None, or a callable ``progress(units_done, units_total)`` called after
            each unit this process finishes (and once at the start).
        process_index, process_count: this process among several (default: JAX's, so a
            run under :mod:`sarjax.distributed` shares the units out).

    Returns:
        The number of units this call ran.
    """
    import jax

    path = Path(path)
    together = process_index is None or process_count is None
    if together:
        process_index, process_count = jax.process_index(), jax.process_count()
    if together and process_count > 1 and process_index != 0:
        _wait_for_store(path)  # process 0 creates it
    group = open_store(path, campaign)
    _remove_partial_files(path)
    done = np.asarray(group["unit_done"][:])
    mine = [u for u in range(campaign.num_units)
            if u % process_count == process_index and not done[u]]
    total = campaign.num_units
    finished = int(np.sum(done == 1))
    if progress is not None:
        progress(finished, total)
    scenarios = campaign.scenarios()
    runner = campaign.runner()
    arrays = {name: group[name] for name in campaign.results}
    for u in mine:
        lo, hi = u * campaign.unit, min((u + 1) * campaign.unit, campaign.num_scenarios)
        results = {name: [] for name in campaign.results}
        for s in range(lo, hi):
            values = runner({name: column[s] for name, column in scenarios.items()})
            for name, value in zip(campaign.results, values, strict=True):
                results[name].append(value)
        for name, (dtype, _, _) in campaign.results.items():
            arrays[name][lo:hi] = np.asarray(results[name], dtype=dtype)
        group["unit_done"][u] = 1  # after the data: a flagged unit is complete
        finished += 1
        if progress is not None:
            progress(finished, total)
    if together and process_count > 1:  # every unit is written when any process returns
        from jax.experimental import multihost_utils

        multihost_utils.sync_global_devices(f"sarjax.campaign {path}")
    return len(mine)


def _wait_for_store(path: Path, timeout: float = 300.0):
    deadline = time.monotonic() + timeout
    while not (path / "zarr.json").exists():
        if time.monotonic() > deadline:
            raise ValueError(f"process 0 did not create the campaign store {path} within "
                             f"{timeout:.0f} s")
        time.sleep(0.1)


def load(path):
    """The store as an ``xarray.Dataset`` (scenario axis; ``unit_done`` on ``unit``)."""
    import xarray as xr

    return xr.open_zarr(str(path), consolidated=False)


def summary(dataset) -> str:
    """The table printed at the end of a run: for a :class:`ValidityMap`, per method and
    deviation rms, the median raw NMSE [dB] over squints and realizations and the share
    of runs that warned or were refused; for a :class:`FitMonteCarlo`, per deviation rms
    and SNR, the median line-of-sight error, the median bound and their ratio, and the
    share of fits that converged; both with how many scenarios are done."""
    if "nmse_db" in dataset:
        return _validity_summary(dataset)
    return _fit_summary(dataset)


def _validity_summary(dataset) -> str:
    method = np.array([str(m) for m in np.asarray(dataset["method"].values)])
    rms = np.asarray(dataset["deviation_rms"].values)
    nmse = np.asarray(dataset["nmse_db"].values)
    warned = np.asarray(dataset["warned"].values)
    refused = np.asarray(dataset["refused"].values)
    lines = [f"{'method':<20} {'rms [m]':>8} {'median NMSE [dB]':>17} {'warned':>7} "
             f"{'refused':>8} {'done':>9}"]
    for m in dict.fromkeys(method):
        for r in sorted(set(rms[method == m])):
            sel = (method == m) & (rms == r)
            ran = sel & (warned >= 0)  # done (the fill value is −1)
            measured = ran & np.isfinite(nmse)
            median = np.median(nmse[measured]) if np.any(measured) else np.nan
            shares = [f"{np.mean(flags[ran] == 1):.0%}" if np.any(ran) else "—"
                      for flags in (warned, refused)]
            lines.append(f"{m:<20} {r:8.4g} {median:17.1f} {shares[0]:>7} {shares[1]:>8} "
                         f"{int(np.sum(ran)):>4}/{int(np.sum(sel)):<4}")
    return "\n".join(lines)


def _fit_summary(dataset) -> str:
    rms = np.asarray(dataset["deviation_rms"].values)
    snr = np.asarray(dataset["snr_db"].values)
    error = np.asarray(dataset["error_los"].values)
    bound = np.asarray(dataset["crb_los"].values)
    converged = np.asarray(dataset["converged"].values)
    lines = [f"{'rms [m]':>8} {'SNR [dB]':>9} {'median LOS error [m]':>21} "
             f"{'median CRB [m]':>15} {'error/CRB':>10} {'converged':>10} {'done':>9}"]
    for r in sorted(set(rms)):
        for q in sorted(set(snr[rms == r])):
            sel = (rms == r) & (snr == q)
            ran = sel & (converged >= 0)
            if np.any(ran):
                e, b = np.median(error[ran]), np.median(bound[ran])
                share = f"{np.mean(converged[ran] == 1):.0%}"
            else:
                e = b = np.nan
                share = "—"
            lines.append(f"{r:8.4g} {q:9.3g} {e:21.3g} {b:15.3g} {e / b:10.2f} {share:>10} "
                         f"{int(np.sum(ran)):>4}/{int(np.sum(sel)):<4}")
    return "\n".join(lines)


__all__ = ["Campaign", "FitMonteCarlo", "ValidityMap", "load", "open_store", "run",
           "summary"]
