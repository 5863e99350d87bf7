"""Campaigns: a resumable Zarr store, killed and resumed, equals an uninterrupted one.

The campaign runs in a child process that kills itself (SIGKILL: no clean-up at all) at
a drawn point — inside a drawn unit, before one of its scenarios or between two of its
result files, its flag unwritten — three times, then it is rerun to the end. Its
data variables must equal those of an uninterrupted run bit for bit, and the units
finished before each kill must not be run again. A store of another campaign, a folder
that is not a sarjax store, or a damaged one is refused and left as it was.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import sarjax as sj
from sarjax import campaign as cp

TESTS = str(Path(__file__).resolve().parent)


def small_campaign(size="ci"):
    """24 scenarios in 8 units (CI); 200 in 25 (slow tier)."""
    radar = sj.presets.airborne_xband(num_pulses=64, num_range=64,
                                      near_range=5140.0 - 32 * 2.99792458)
    scene = sj.PointTargets(azimuth=[0.0, 2.0], range=[5140.0, 5146.0])
    if size == "ci":
        return cp.ValidityMap(radar, scene, methods=("fourier_2d", "small_deviation"),
                           deviation_rms=(0.0, 0.005, 0.05), realizations=4, unit=3)
    return cp.ValidityMap(radar, scene, methods=("fourier_2d", "small_deviation"),
                       deviation_rms=(0.0, 0.002, 0.01, 0.05, 0.2),
                       squint_deg=(0.0, 5.0, 10.0, 20.0), realizations=5, unit=8)


CHILD = textwrap.dedent("""
    import os, signal, sys
    sys.path.insert(0, sys.argv[3])
    import zarr
    from test_campaign import small_campaign
    from sarjax import campaign

    # SIGKILL this process inside unit ``cut`` (0-based) at ``point``: before its
    # scenario ``point`` (point < unit), or after its ``point − unit + 1``-th result file
    # (between two files; its flag unwritten)
    path, size, cut, point = sys.argv[1], sys.argv[2], int(sys.argv[4]), int(sys.argv[5])
    spec = small_campaign(size)
    done = int(zarr.open_array(path + "/unit_done", mode="r")[:].sum())
    count = dict(scenarios=done * spec.unit, writes=0)
    die = lambda: os.kill(os.getpid(), signal.SIGKILL)

    runner = spec.runner()

    def counting_runner(row):
        if count["scenarios"] == cut * spec.unit + point:
            die()
        count["scenarios"] += 1
        return runner(row)

    object.__setattr__(spec, "runner", lambda: counting_runner)
    setitem = zarr.Array.__setitem__

    def counting_setitem(array, key, value):
        setitem(array, key, value)
        in_cut = count["scenarios"] == min((cut + 1) * spec.unit, spec.num_scenarios)
        if in_cut and array.basename in spec.results:
            count["writes"] += 1
            if point >= spec.unit and count["writes"] == point - spec.unit + 1:
                die()

    zarr.Array.__setitem__ = counting_setitem
    campaign.run(spec, path)
""")


def _units_done(path):
    import zarr

    try:
        return int(np.sum(zarr.open_array(str(path / "unit_done"), mode="r")[:]))
    except Exception:  # not created yet
        return 0


def _data(path):
    with cp.load(path) as ds:
        names = [name for name in ds.data_vars if name in (*cp.ValidityMap.results,
                                                             *cp.FitMonteCarlo.results,
                                                             "unit_done")]
        return {name: np.asarray(ds[name].values) for name in names}


def _killed_and_resumed(path, size, rng, kills=3):
    """Run the campaign in children killed ``kills`` times (each by itself at a drawn
    point, see CHILD: mid-unit or between two result files), then to the end; the units
    flagged done after each kill (which the next run must not repeat)."""
    campaign = small_campaign(size)
    cp.open_store(path, campaign)
    flagged = []
    for _ in range(kills):
        before = _units_done(path)
        cut = min(before + int(rng.integers(0, 2)), campaign.num_units - 1)
        point = int(rng.integers(0, campaign.unit + len(campaign.results)))
        child = subprocess.run([sys.executable, "-c", CHILD, str(path), size, TESTS,
                                str(cut), str(point)], timeout=300)
        assert child.returncode == -signal.SIGKILL, child.returncode
        flagged.append(_units_done(path))
        assert flagged[-1] == cut  # the units before the cut, not the cut one
    ran = cp.run(small_campaign(size), path)
    return flagged, ran


@pytest.mark.parametrize("size", ["ci", pytest.param("full", marks=pytest.mark.slow)])
def test_killed_three_times_and_resumed_equals_uninterrupted(tmp_path, size):
    campaign = small_campaign(size)
    whole = tmp_path / "whole.zarr"
    assert cp.run(campaign, whole) == campaign.num_units
    resumed = tmp_path / "resumed.zarr"
    flagged, ran = _killed_and_resumed(resumed, size, np.random.default_rng(5))
    assert ran == campaign.num_units - flagged[-1]  # nothing finished is run again
    assert flagged == sorted(flagged) and flagged[-1] < campaign.num_units
    a, b = _data(whole), _data(resumed)
    for name in a:
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)
    assert np.all(a["unit_done"] == 1) and np.all(a["warned"] >= 0)
    assert not list(resumed.rglob("*.partial"))
    # a second rerun has nothing left to do
    assert cp.run(campaign, resumed) == 0


def test_results_are_the_measurements(tmp_path):
    """Spot check: a stored scenario's NMSE and warning are simulate's own."""
    import warnings

    campaign = small_campaign()
    path = tmp_path / "s.zarr"
    cp.run(campaign, path)
    data, scenarios = _data(path), campaign.scenarios()
    s = int(np.flatnonzero((scenarios["method"] == "small_deviation")
                           & (scenarios["deviation_rms"] == 0.005))[1])
    radar, motion = campaign.radar, cp._motion(campaign, 0.005, int(scenarios["realization"][s]))
    exact = sj.simulate(radar, campaign.scene, motion, method="time_domain")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fast = sj.simulate(radar, campaign.scene, motion, method="small_deviation")
    assert data["nmse_db"][s] == sj.metrics.nmse_db(fast, exact)
    assert data["warned"][s] == int(any(issubclass(w.category, sj.ValidityWarning)
                                        for w in caught))
    # the summary has one row per method and rms, all done
    table = cp.summary(cp.load(path))
    assert table.count("4/4") == 6, table


def test_foreign_damaged_or_other_stores_are_refused(tmp_path):
    campaign = small_campaign()
    folder = tmp_path / "photos"
    folder.mkdir()
    (folder / "holiday.jpg").write_bytes(b"not zarr")
    with pytest.raises(ValueError, match="not a readable Zarr store|not a sarjax"):
        cp.run(campaign, folder)
    assert [p.name for p in folder.iterdir()] == ["holiday.jpg"]
    other = tmp_path / "other.zarr"
    cp.open_store(other, small_campaign())
    changed = cp.ValidityMap(campaign.radar, campaign.scene, methods=("fourier_2d",),
                          deviation_rms=(0.0,), unit=3)
    with pytest.raises(ValueError, match="another campaign"):
        cp.run(changed, other)
    (other / "zarr.json").write_text("{ truncated")
    with pytest.raises(ValueError, match="not a readable Zarr store"):
        cp.run(campaign, other)
    assert (other / "zarr.json").read_text() == "{ truncated"
    with pytest.raises(ValueError, match="does not exist"):
        cp.run(campaign, tmp_path / "missing" / "s.zarr")
    with pytest.raises(ValueError, match="unit=0"):
        cp.ValidityMap(campaign.radar, campaign.scene, unit=0)
    with pytest.raises(ValueError, match="deviation_rms"):
        cp.ValidityMap(campaign.radar, campaign.scene, deviation_rms=(-1.0,))


def _study_toml(folder, unit):
    """A two-method, two-amplitude study of one target on a 64 × 64 grid."""
    toml = folder / "study.toml"
    toml.write_text(textwrap.dedent(f"""
        preset = "airborne"
        [radar]
        num_pulses = 64
        num_range = 64
        near_range = 5044.07
        [scene]
        azimuth = [0.0]
        range = [5140.0]
        [campaign]
        methods = ["fourier_2d", "small_deviation"]
        deviation_rms = [0.0, 0.01]
        unit = {unit}
    """))
    return toml


def test_command_line_runs_resumes_and_plots(tmp_path, capsys):
    import sarjax.cli
    from sarjax.cli import config

    toml = _study_toml(tmp_path, unit=2)
    out, png = tmp_path / "study.zarr", tmp_path / "map.png"
    assert sarjax.cli.main(["campaign", str(toml), "-o", str(out), "--png", str(png)]) == 0
    first = capsys.readouterr().out
    assert "4 scenarios in 2 units (2 run by this call)" in first
    assert "median NMSE [dB]" in first and png.stat().st_size > 0
    assert sarjax.cli.main(["campaign", str(toml), "-o", str(out)]) == 0
    assert "(0 run by this call)" in capsys.readouterr().out
    # another configuration on the same store: refused, one line
    assert sarjax.cli.main(["campaign", str(toml), "-o", str(out),
                            "--set", "campaign.unit=1"]) == 2
    assert "another campaign" in capsys.readouterr().err
    assert sarjax.cli.main(["campaign", str(toml), "-o", str(out),
                            "--set", "campaign.uint=1"]) == 2
    assert "did you mean 'unit'?" in capsys.readouterr().err
    for key in config.CAMPAIGN_KEYS:
        assert f"# {key} =" in config.EXAMPLE, key


@pytest.mark.slow  # 14 s in CI; the launcher itself is tested in test_distributed.py
def test_two_processes_share_the_units(tmp_path):
    """Under the launcher, ``sarjax campaign`` shares the units out over two processes
    (unit u in process u mod 2; process 0 prints the summary): the store equals a
    one-process run's."""
    from sarjax import distributed

    toml = _study_toml(tmp_path, unit=1)
    two, one = tmp_path / "two.zarr", tmp_path / "one.zarr"
    status = distributed.launch(["-m", "sarjax.cli", "campaign", str(toml), "-o", str(two)],
                                2, timeout=300)
    assert status == 0
    import sarjax.cli

    assert sarjax.cli.main(["campaign", str(toml), "-o", str(one)]) == 0
    a, b = _data(one), _data(two)
    for name in a:
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)


def _fit_campaign(realizations=2):
    """Two cold-start fits on the reduced grid of tests/test_inverse.py (400 × 360,
    L = 2 m, 2.5 µs chirp), 1 cm rms one-cycle deviations and the seed's jitter, 10 dB."""
    radar = sj.presets.airborne_xband(antenna_length=2.0, chirp_duration=2.5e-6,
                                      num_pulses=400, num_range=360, near_range=4620.0)
    scene = sj.PointTargets(azimuth=[0.0, 0.0, 0.0], range=[4840.0, 5140.0, 5440.0])
    return cp.FitMonteCarlo(radar, scene, deviation_rms=(0.01,), snr_db=(10.0,),
                            realizations=realizations)


def test_fit_campaign_declares_its_grid_and_config():
    """(No fit runs here: the fits are in the slow tier.) The scenario axis, the store's
    identity distinct from a validity map's, and the configuration's ``kind``."""
    from sarjax.cli import config

    fit = cp.FitMonteCarlo(small_campaign().radar, small_campaign().scene,
                           deviation_rms=(0.01, 0.02), snr_db=(0.0, 10.0), realizations=3)
    axis = fit.scenarios()
    assert fit.num_scenarios == 12 == axis["snr_db"].size and fit.num_units == 12
    np.testing.assert_array_equal(axis["snr_db"][:4], [0.0, 10.0, 0.0, 10.0])
    np.testing.assert_array_equal(axis["realization"][:4], [0, 0, 1, 1])
    assert '"fit-monte-carlo' in fit.identity().replace("sarjax.campaign/", '"')
    assert fit.identity() != small_campaign().identity()
    base = {"preset": "airborne", "scene": {"azimuth": [0.0], "range": [5140.0]}}
    made = config.campaign_config({**base, "campaign": {"kind": "fit", "snr_db": [5.0]}})
    assert isinstance(made, cp.FitMonteCarlo) and made.snr_db == (5.0,)
    with pytest.raises(ValueError, match="apply to kind"):
        config.campaign_config({**base, "campaign": {"kind": "fit", "squint_deg": [5.0]}})
    with pytest.raises(ValueError, match="campaign.kind='fits'"):
        config.campaign_config({**base, "campaign": {"kind": "fits"}})
    with pytest.raises(ValueError, match="snr_db"):
        cp.FitMonteCarlo(fit.radar, fit.scene, snr_db=(float("nan"),))


@pytest.mark.slow
def test_fit_campaign_measures_error_against_the_bound(tmp_path):
    """Two fits, resumed after a kill in between: the stored errors are those of the
    fits, and a converged fit's line-of-sight error is within 3 CRB (one noise draw)."""
    campaign = _fit_campaign()
    path = tmp_path / "fit.zarr"
    assert cp.run(campaign, path, process_index=0, process_count=2) == 1  # unit 0 only
    assert cp.run(campaign, path) == 1  # the rest
    data = _data(path)
    assert np.all(data["unit_done"] == 1)
    for s in range(2):
        if data["converged"][s]:
            assert data["error_los"][s] <= 3 * data["crb_los"][s], data
            assert 0.5 < data["std_los"][s] / data["crb_los"][s] < 2.0, data
    table = cp.summary(cp.load(path))
    assert "error/CRB" in table and "2/2" in table, table
    png = tmp_path / "fits.png"
    assert sj.plot.fit_monte_carlo(cp.load(path), path=png) == png and png.stat().st_size


def test_fit_plot_draws_every_grid_point():
    """(A made-up store: no fit runs.) One panel per deviation rms, one curve per SNR over
    the fits done; the unfinished scenarios (converged = −1) and a failed fit's NaN
    bound are left out of the curves."""
    import xarray as xr

    rng = np.random.default_rng(3)
    n = 24
    rms = np.repeat([0.005, 0.02], n // 2)
    snr = np.tile(np.repeat([0.0, 10.0], n // 4), 2)
    converged = rng.choice([1, 1, 1, 0, -1], size=n)
    bound = np.where(rng.random(n) < 0.1, np.nan, 1e-4)
    dataset = xr.Dataset(dict(
        deviation_rms=("scenario", rms), snr_db=("scenario", snr),
        error_los=("scenario", bound * rng.uniform(0.5, 3, n)), crb_los=("scenario", bound),
        converged=("scenario", converged)))
    fig = sj.plot.fit_monte_carlo(dataset)
    panels = fig.axes
    assert [ax.get_title() for ax in panels] == ["deviation rms 0.5 cm", "deviation rms 2 cm"]
    for ax, r in zip(panels, (0.005, 0.02), strict=True):
        curves = [line for line in ax.get_lines() if line.get_label().endswith("fits)")]
        assert len(curves) == 2
        for q, line in zip((0.0, 10.0), curves, strict=True):
            sel = (rms == r) & (snr == q) & (converged >= 0) & np.isfinite(bound)
            assert line.get_label() == f"{q:g} dB ({int(sel.sum())} fits)"
    import matplotlib.pyplot as plt

    plt.close(fig)
