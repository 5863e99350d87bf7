"""Batch simulation: a Motion with a leading batch axis gives raw data with that axis.

The batched call vmaps the one-realization simulator over the batch axis inside the one
jitted entry point; each realization must equal its own single call. The tolerance is
1e-6 relative to the peak (issue acceptance); vmapping changes only the order of
independent operations, so the measured differences are at rounding level (≲ 1e-15).
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

import sarjax as sj
import sarjax._simulate as _simulate_module
from sarjax.validity import FASTEST_FIRST, choose_method

NUM_PULSES = 48
NUM_RANGE = 96
NEAR_RANGE = 5100.0
RELATIVE = 1e-6  # acceptance: batched = single calls to 1e-6 of the peak


def _radar():
    return sj.presets.airborne_xband()


def _scene():
    return sj.PointTargets(azimuth=[0.0, 3.0, -2.0, 1.5], range=[5140.0, 5150.0, 5135.0, 5170.0],
                           reflectivity=[1.0, 0.5j, 0.3, -0.7], height=[0.0, 10.0, 0.0, 25.0])


def _realizations(batch, seed=0):
    """cm-level deviations and mrad pointing jitter, one row per realization."""
    rng = np.random.default_rng(seed)
    x = np.linspace(-1.0, 1.0, NUM_PULSES)
    phase = rng.uniform(0, 2 * np.pi, size=(batch, 1))
    horizontal = (0.02 * np.sin(3 * x[None, :] + phase)
                  + 0.002 * rng.normal(size=(batch, NUM_PULSES)))
    vertical = 0.01 * np.cos(2 * x[None, :] + phase)
    pointing = 1e-3 * rng.normal(size=(batch, NUM_PULSES))
    return horizontal, vertical, pointing


def _simulate(motion, method="time_domain", **kwargs):
    return sj.simulate(_radar(), _scene(), motion, method=method, num_pulses=NUM_PULSES,
                       num_range=NUM_RANGE, near_range=NEAR_RANGE, **kwargs)


def _relative(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def _check_batch_equals_singles(method, batch, **options):
    horizontal, vertical, pointing = _realizations(batch)
    raw = _simulate(sj.Motion(horizontal=horizontal, vertical=vertical, pointing=pointing),
                    method, **options)
    assert raw.data.shape == (batch, NUM_PULSES, NUM_RANGE)
    assert raw.azimuth.shape == (NUM_PULSES,) and raw.range.shape == (NUM_RANGE,)
    singles = np.stack([
        np.asarray(_simulate(sj.Motion(horizontal=horizontal[b], vertical=vertical[b],
                                       pointing=pointing[b]), method, **options).data)
        for b in range(batch)
    ])
    assert np.max(np.abs(singles)) > 0.1  # the targets are in the window
    assert _relative(raw.data, singles) <= RELATIVE
    # the realizations differ: a shared result would not be a batch
    assert _relative(singles[1], singles[0]) > 1e-3


def test_batch_of_8_equals_8_single_calls_time_domain():
    _check_batch_equals_singles("time_domain", 8)


@pytest.mark.parametrize("method", ["small_deviation", "moderate_deviation"])
def test_batch_equals_single_calls_fourier(method):
    """The Fourier engine vmapped (CI: both deviation methods, 3 realizations; 8: slow).
    The cm-level realizations are outside small_deviation's ε13 (it says so); the batch
    must still equal the single calls. moderate_deviation chooses its coupling order from
    the motion's span over every realization (a batch once failed there)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sj.ValidityWarning)
        _check_batch_equals_singles(method, 3)


@pytest.mark.slow
@pytest.mark.parametrize("method", ["time_domain_nufft", "small_deviation",
                                    "moderate_deviation"])
def test_batch_of_8_equals_8_single_calls_every_method(method):
    """As the CI test: the cm-level realizations are outside small_deviation's ε13 (it
    says so); the batch must still equal the single calls."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sj.ValidityWarning)
        _check_batch_equals_singles(method, 8)


@pytest.mark.slow
def test_batch_fourier_2d_ignores_motion():
    """The ideal 2-D simulator ignores motion: every realization is the straight track."""
    horizontal, vertical, pointing = _realizations(3)
    with pytest.warns(sj.ValidityWarning, match="epsilon_motion"):  # and says so
        raw = _simulate(sj.Motion(horizontal=horizontal, pointing=pointing), "fourier_2d")
    ideal = _simulate(None, "fourier_2d")
    assert raw.data.shape == (3, NUM_PULSES, NUM_RANGE)
    for b in range(3):
        assert _relative(raw.data[b], ideal.data) <= RELATIVE


@pytest.mark.parametrize("method", ["high_speed", "chirp_scaling"])
def test_straight_track_methods_refuse_a_motion_batch(method):
    """high_speed and chirp_scaling simulate a straight track: a motion batch is refused
    (clearly), not silently ignored."""
    horizontal, _, _ = _realizations(2)
    with pytest.raises(ValueError, match="straight track"):
        _simulate(sj.Motion(horizontal=horizontal), method)


def test_shared_components_broadcast_over_the_batch():
    """Unbatched components are shared by every realization of the batch."""
    horizontal, _, pointing = _realizations(4, seed=3)
    shared = horizontal[0]
    raw = _simulate(sj.Motion(horizontal=shared, pointing=pointing))
    for b in (0, 3):
        single = _simulate(sj.Motion(horizontal=shared, pointing=pointing[b]))
        assert _relative(raw.data[b], single.data) <= RELATIVE


def test_batch_of_one():
    horizontal, vertical, pointing = _realizations(1)
    raw = _simulate(sj.Motion(horizontal=horizontal, pointing=pointing))
    single = _simulate(sj.Motion(horizontal=horizontal[0], pointing=pointing[0]))
    assert raw.data.shape == (1, NUM_PULSES, NUM_RANGE)
    assert _relative(raw.data[0], single.data) <= RELATIVE


def test_batch_in_chunks_equals_all_at_once():
    """A memory limit that forces fewer realizations at a time leaves the result unchanged."""
    horizontal, vertical, pointing = _realizations(6, seed=1)
    motion = sj.Motion(horizontal=horizontal, vertical=vertical, pointing=pointing)
    full = sj.simulation_memory(_radar(), _scene(), motion, num_pulses=NUM_PULSES,
                                num_range=NUM_RANGE, near_range=NEAR_RANGE, devices=1)
    assert full.batch_chunk is None
    limit = full.estimate.total - full.estimate.workspace // 2  # half the workspace
    chunked = sj.simulation_memory(_radar(), _scene(), motion, num_pulses=NUM_PULSES,
                                   num_range=NUM_RANGE, near_range=NEAR_RANGE, devices=1,
                                   memory_limit=limit)
    assert chunked.batch_chunk is not None and chunked.batch_chunk < 6
    assert chunked.estimate.total <= limit
    a = _simulate(motion, devices=1)
    b = _simulate(motion, devices=1, memory_limit=limit)
    assert _relative(b.data, a.data) <= RELATIVE


def test_auto_chooses_for_every_realization():
    """``method="auto"`` takes the most exact method any realization needs: here the
    small realization admits every Fourier method, the large one not the ideal one."""
    radar = _radar()
    x = np.arange(NUM_PULSES)
    small = 1e-4 * np.sin(x / 7.0)
    large = 0.5 * np.sin(x / 7.0)  # decimetres: beyond the Fourier methods' budgets
    kw = dict(num_pulses=NUM_PULSES, num_range=NUM_RANGE, near_range=NEAR_RANGE)
    chosen_small = choose_method(radar, _scene(), sj.Motion(horizontal=small), **kw)[0]
    chosen_large = choose_method(radar, _scene(), sj.Motion(horizontal=large), **kw)[0]
    fourier = ("fourier_2d", "small_deviation", "moderate_deviation")
    assert all(sj.validity(radar, _scene(), sj.Motion(horizontal=small), method=m, **kw).valid
               for m in fourier)
    assert not sj.validity(radar, _scene(), sj.Motion(horizontal=large), method="fourier_2d",
                           **kw).valid
    assert FASTEST_FIRST.index(chosen_small) <= FASTEST_FIRST.index(chosen_large)
    batched = _simulate_module._choose_batched_method(
        radar, _scene(), sj.Motion(horizontal=np.stack([small, large, small])), 3,
        azimuth_center=0.0, **kw)
    assert batched[0] == chosen_large
    assert batched[1].startswith("the most exact of the 3 realizations' choices: ")


def test_batched_values_do_not_retrace():
    traces = []

    class CountingTimeDomain(sj.TimeDomain):
        def simulate(self, plan, radar, scene, motion, acquisition, dtype):
            traces.append(motion.horizontal.shape)
            return super().simulate(plan, radar, scene, motion, acquisition, dtype)

    for seed in range(3):
        horizontal, _, pointing = _realizations(4, seed=seed)
        _simulate(sj.Motion(horizontal=horizontal, pointing=pointing),
                  CountingTimeDomain(), devices=1)
    assert len(traces) == 1, traces  # traced once, inside vmap (per-realization shapes)
    assert traces[0] == (NUM_PULSES,)


# ---- validation ----------------------------------------------------------------------


def test_batch_sizes_must_agree():
    horizontal, _, pointing = _realizations(4)
    motion = sj.Motion(horizontal=horizontal, pointing=pointing[:3])
    with pytest.raises(ValueError, match=r"motion\.pointing has shape \(3, 48\) but "
                                         r"motion\.horizontal has 4 realizations"):
        _simulate(motion)


@pytest.mark.parametrize("shape", [(4, NUM_PULSES - 1), (2, 2, NUM_PULSES), (NUM_PULSES, 4)])
def test_batched_shape_must_end_with_the_pulses(shape):
    with pytest.raises(ValueError, match=re.escape(
            f"motion.vertical has shape {shape}, expected ({NUM_PULSES},)")):
        _simulate(sj.Motion(vertical=np.zeros(shape)))


def test_empty_batch():
    with pytest.raises(ValueError, match=r"batch of 0 realizations"):
        _simulate(sj.Motion(horizontal=np.zeros((0, NUM_PULSES))))


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_value_in_a_realization(bad):
    horizontal, _, _ = _realizations(5)
    horizontal[3, 17] = bad
    with pytest.raises(ValueError, match=r"motion\.horizontal has non-finite values "
                                         r".* at \(realization, pulse\) \[\(3, 17\)\]"):
        _simulate(sj.Motion(horizontal=horizontal))
