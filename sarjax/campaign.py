"""Campaigns: many scenarios, one resumable Zarr store.

A campaign is a grid (or a random draw) of scenarios — method × deviation rms × squint ×
motion realization — each simulated and measured against the exact model: the raw NMSE
of the method and whether ``simulate`` warned (a *validity map*). The scenarios are cut
into *units* of ``unit`` scenarios; a unit is the unit of work and of writing:

* the store is created whole before any unit runs (every array pre-sized, filled with
  NaN; created in a temporary folder and renamed into place);
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

Read a store with ``xarray.open_zarr(path, consolidated=False)``; :func:`summary` gives the
table printed at the end, :func:`sarjax.plot.validity_map` the figure.
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

import numpy as np

from ._simulate import simulate
from ._validate import SwathWarning, ValidityWarning
from .metrics import nmse_db
from .motion import Motion, smooth_deviation
from .radar import Radar, radar_attributes
from .scene import PointTargets

STORE_KIND = "sarjax.campaign/validity-map/1"
RESULTS = {  # name: (dtype, units, meaning)
    "nmse_db": ("f8", "dB", "raw NMSE of the method against the exact model"),
    "warned": ("i1", "1", "1: simulate warned (ValidityWarning or SwathWarning)"),
    "refused": ("i1", "1", "1: the method refused the scenario (ValueError)"),
}


@dataclasses.dataclass(frozen=True)
class Campaign:
    """A validity-map campaign: every combination of the axes below, in this order
    (the method varies fastest), each against the exact model (``time_domain``).

    Attributes:
        radar: the :class:`~sarjax.Radar` (its grid: ``num_pulses`` × ``num_range``).
        scene: the :class:`~sarjax.PointTargets`.
        methods: the simulators to measure.
        deviation_rms: rms of the smooth horizontal and vertical deviations [m].
        squint_deg: squint angles φ_d [deg].
        realizations: motion realizations per grid point (random keys 0 … n − 1).
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

    def __post_init__(self):
        for name in ("methods", "deviation_rms", "squint_deg"):
            values = tuple(getattr(self, name))
            object.__setattr__(self, name, values)
            if not values:
                raise ValueError(f"Campaign.{name} is empty")
        if not (isinstance(self.realizations, int) and self.realizations >= 1):
            raise ValueError(f"Campaign.realizations={self.realizations!r} must be ≥ 1")
        if not (isinstance(self.unit, int) and self.unit >= 1):
            raise ValueError(f"Campaign.unit={self.unit!r} must be an integer ≥ 1")
        bad = [v for v in self.deviation_rms if not (np.isfinite(v) and v >= 0)]
        if bad:
            raise ValueError(f"Campaign.deviation_rms holds {bad}: each must be ≥ 0 m")
        bad = [v for v in self.squint_deg if not (np.isfinite(v) and abs(v) < 80)]
        if bad:
            raise ValueError(f"Campaign.squint_deg holds {bad}: each must lie in (−80, 80)")

    def scenarios(self) -> dict[str, np.ndarray]:
        """The scenario axis: (scenario,) arrays of method, deviation_rms [m],
        squint_deg [deg] and realization."""
        rows = list(itertools.product(self.deviation_rms, self.squint_deg,
                                      range(self.realizations), self.methods))
        return {"deviation_rms": np.array([r[0] for r in rows], float),
                "squint_deg": np.array([r[1] for r in rows], float),
                "realization": np.array([r[2] for r in rows], np.int64),
                "method": np.array([r[3] for r in rows], dtype=object)}

    @property
    def num_scenarios(self) -> int:
        return (len(self.methods) * len(self.deviation_rms) * len(self.squint_deg)
                * self.realizations)

    @property
    def num_units(self) -> int:
        return -(-self.num_scenarios // self.unit)

    def identity(self) -> str:
        """The campaign as canonical JSON: a store answers to this exactly."""
        scene = {name: np.asarray(getattr(self.scene, name)).tolist()
                 for name in ("azimuth", "range")}
        gamma = np.asarray(self.scene.reflectivity)
        scene["reflectivity"] = [gamma.real.tolist(), gamma.imag.tolist()]
        spec = {"kind": STORE_KIND, "radar": radar_attributes(self.radar), "scene": scene,
                **{name: getattr(self, name) for name in (
                    "methods", "deviation_rms", "squint_deg", "realizations", "max_cycles",
                    "unit")}}
        return json.dumps(spec, sort_keys=True, default=list)


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
    for name in (*RESULTS, "unit_done"):
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
            "title": "sarjax validity map: raw NMSE of each method against time_domain",
            "num_scenarios": n, "unit": unit})
        for name, values in scenarios.items():
            dtype = np.dtypes.StringDType() if name == "method" else values.dtype
            array = group.create_array(name, shape=(n,), chunks=(n,), dtype=dtype,
                                       dimension_names=["scenario"])
            array[:] = values.astype(str) if name == "method" else values
        for name, (dtype, units, meaning) in RESULTS.items():
            fill = np.nan if dtype == "f8" else -1
            array = group.create_array(name, shape=(n,), chunks=(unit,), dtype=dtype,
                                       fill_value=fill, dimension_names=["scenario"])
            array.attrs.update({"units": units, "long_name": meaning})
        done = group.create_array("unit_done", shape=(campaign.num_units,), chunks=(1,),
                                  dtype="i1", fill_value=0, dimension_names=["unit"])
        done.attrs["long_name"] = f"1: unit finished (scenarios u·{unit} … (u+1)·{unit} − 1)"
        os.rename(tmp, path)
    except FileExistsError:  # another process created it meanwhile: fine if it matches
        shutil.rmtree(tmp, ignore_errors=True)
    except OSError as err:
        shutil.rmtree(tmp, ignore_errors=True)
        if not path.exists():
            raise ValueError(f"cannot create the campaign store {path}: {err}") from None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
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


def _motion(campaign: Campaign, rms: float, realization: int):
    if rms == 0.0:
        return None
    radar = campaign.radar
    n = radar.num_pulses
    x = (np.arange(n) - (n - 1) / 2) * float(radar.azimuth_spacing)
    aperture = float(radar.footprint(radar.reference_range))
    keys = np.random.SeedSequence([2017, realization]).generate_state(2)
    return Motion(
        horizontal=smooth_deviation(x, key=int(keys[0]), rms=rms,
                                    max_cycles=campaign.max_cycles, aperture=aperture),
        vertical=smooth_deviation(x, key=int(keys[1]), rms=rms,
                                  max_cycles=campaign.max_cycles, aperture=aperture))


class _Runner:
    """Scenario results, the exact model's data kept for the methods of the same grid
    point (the method varies fastest)."""

    def __init__(self, campaign: Campaign):
        self.campaign = campaign
        self._exact_key = None
        self._exact = None

    def run(self, method: str, rms: float, squint_deg: float, realization: int):
        import jax

        # each process runs its own units on its own devices (simulate's default would
        # span every process's devices in a multi-process run)
        local = dict(devices=jax.local_devices())
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
    runner = _Runner(campaign)
    arrays = {name: group[name] for name in RESULTS}
    for u in mine:
        lo, hi = u * campaign.unit, min((u + 1) * campaign.unit, campaign.num_scenarios)
        results = {name: [] for name in RESULTS}
        for s in range(lo, hi):
            values = runner.run(str(scenarios["method"][s]),
                                float(scenarios["deviation_rms"][s]),
                                float(scenarios["squint_deg"][s]),
                                int(scenarios["realization"][s]))
            for name, value in zip(RESULTS, values, strict=True):
                results[name].append(value)
        for name, (dtype, _, _) in RESULTS.items():
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
    """A table: per method and deviation rms, the median raw NMSE [dB] over squints and
    realizations, the share of runs that warned or were refused, and how many are done."""
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


__all__ = ["Campaign", "load", "open_store", "run", "summary"]
