"""What ``sj.simulate`` runs in host threads: the model's checks (the validity budgets,
the swath) in a worker thread while the simulation runs, their warnings given once both
are done (the same warnings as the checks run first, pointing at the caller;
``strict=True`` still refuses before anything runs; an error of the run is the call's
error); and an exact model's large call on a CPU as blocks of pulses, one thread each,
equal to the whole call."""

from __future__ import annotations

import contextlib
import dataclasses
import threading
import warnings
from types import SimpleNamespace

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import sarjax as sj
from sarjax import _simulate, _validate
from sarjax._data import Acquisition
from sarjax._memory import Estimate
from sarjax.simulators import _registry

RADAR = sj.presets.airborne_xband()
N, M = 256, 192
NEAR = 5140.0 - M // 2 * float(RADAR.range_spacing)
SCENE = sj.PointTargets(azimuth=[0.0, 6.0], range=[5140.0, 5150.0])
KW = dict(num_pulses=N, num_range=M, near_range=NEAR, method="fourier_2d")


def _motion(rms):
    x = (np.arange(N) - N // 2) * float(RADAR.azimuth_spacing)
    return sj.Motion(horizontal=rms * np.sin(2 * np.pi * x / 40.0),
                     vertical=0.5 * rms * np.cos(2 * np.pi * x / 55.0))


def test_warnings_are_those_of_the_checks_and_point_at_the_caller():
    """A deviated track given to the straight-track method: its ValidityWarning, with
    the message the checks give when run alone, at this file's line; the data equal
    those of a call that warns nothing (the ideal track: fourier_2d ignores motion)."""
    motion = _motion(0.05)
    acquisition = Acquisition(num_pulses=N, num_range=M, near_range=NEAR, azimuth_center=0.0)
    expected = _validate.model_findings(sj.Fourier2D(), RADAR, SCENE, motion,
                                        acquisition, False, jnp.complex128)
    assert [c for _, c in expected] == [sj.ValidityWarning]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        raw = sj.simulate(RADAR, SCENE, motion, **KW)
    validity = [w for w in caught if issubclass(w.category, sj.ValidityWarning)]
    assert [str(w.message) for w in validity] == [expected[0][0]]
    assert validity[0].filename == __file__, validity[0].filename
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the ideal track: nothing to warn about
        ideal = sj.simulate(RADAR, SCENE, **KW)
    np.testing.assert_array_equal(np.asarray(raw.data), np.asarray(ideal.data))


def test_strict_refuses_before_the_simulation_runs(monkeypatch):
    """strict=True: the checks run first and raise; the simulation program never runs."""
    def refuse(*args, **kwargs):
        raise AssertionError("the simulation ran")

    monkeypatch.setattr(_simulate, "_run", refuse)
    with pytest.raises(ValueError, match="strict=True.*epsilon_motion"):
        sj.simulate(RADAR, SCENE, _motion(0.05), strict=True, **KW)


def test_an_error_of_the_run_is_the_calls_error(monkeypatch):
    """The run raises while the checks are under way: the run's error reaches the caller,
    not a warning or an error of the checks."""
    def broken(*args, **kwargs):
        raise RuntimeError("the run failed")

    monkeypatch.setattr(_simulate, "_run", broken)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(RuntimeError, match="the run failed"):
            sj.simulate(RADAR, SCENE, _motion(0.05), **KW)
    assert not [w for w in caught if issubclass(w.category, sj.ValidityWarning)]


def test_simulations_from_several_threads_equal_one_at_a_time():
    """Four calls from four threads at once (each with its checks in the workers) give
    the data of the same calls made one after the other, bit for bit up to XLA's
    threaded kernels (1e-12 of the peak)."""
    rms = [0.0, 0.001, 0.02, 0.05]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sj.ValidityWarning)
        alone = [np.asarray(sj.simulate(RADAR, SCENE, _motion(r), **dict(
            KW, method="small_deviation")).data) for r in rms]
        results, errors = [None] * len(rms), []

        def one(i):
            try:
                results[i] = np.asarray(sj.simulate(RADAR, SCENE, _motion(rms[i]), **dict(
                    KW, method="small_deviation")).data)
            except Exception as err:  # reported below, in the test's thread
                errors.append(err)

        threads = [threading.Thread(target=one, args=(i,)) for i in range(len(rms))]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    assert not errors, errors
    for a, b in zip(alone, results, strict=True):
        np.testing.assert_allclose(b, a, rtol=0, atol=1e-12 * np.abs(a).max())


def test_a_forked_child_makes_its_own_pool():
    """After a fork the parent's worker threads are not in the child: the child forgets
    the pool (``os.register_at_fork``) and makes a new one that runs its checks."""
    kept, fresh = _simulate._checks_pool(), None
    try:
        _simulate._forget_checks_pool()  # what the child runs after a fork
        fresh = _simulate._checks_pool()
        assert fresh is not kept
        assert fresh.submit(lambda: 42).result(timeout=10) == 42
    finally:
        if fresh is not None:
            fresh.shutdown(wait=True)
        with _simulate._POOL_LOCK:
            _simulate._POOL = kept


@contextlib.contextmanager
def _pulse_blocks(blocks):
    """Calls run as ``blocks`` host-thread blocks of pulses whatever their cost (1: whole),
    on a machine said to have the cores for them; yields the pulse counts ``_run`` got."""
    saved = (_simulate.HOST_BLOCKS, _simulate.HOST_SPLIT_SECONDS, _simulate._usable_cores,
             _simulate._run)
    calls = []

    def counted(*args, **kwargs):
        calls.append(args[5].num_pulses)
        return saved[3](*args, **kwargs)

    _simulate.HOST_BLOCKS, _simulate.HOST_SPLIT_SECONDS = blocks, 0.0
    _simulate._usable_cores, _simulate._run = (lambda: blocks), counted
    try:
        yield calls
    finally:
        (_simulate.HOST_BLOCKS, _simulate.HOST_SPLIT_SECONDS, _simulate._usable_cores,
         _simulate._run) = saved


@settings(max_examples=8)
@given(method=st.sampled_from(["time_domain", "time_domain_nufft"]),
       num_pulses=st.integers(4, 90), num_range=st.integers(16, 80),
       squint=st.sampled_from([0.0, 0.12, -0.25]), moving=st.booleans(),
       stop_and_go=st.booleans(), pointing=st.booleans(), single=st.booleans(),
       centre=st.floats(-60.0, 60.0), azimuth=st.floats(-1.5, 1.5),
       slant=st.floats(-0.5, 1.5))
def test_pulse_blocks_from_host_threads_equal_the_whole_call(
        method, num_pulses, num_range, squint, moving, stop_and_go, pointing, single, centre,
        azimuth, slant):
    """An exact model's call split into two blocks of pulses, one host thread each
    (forced: the cost model puts these calls under the split's threshold), against the
    whole call, drawn over both exact models, pulse counts the blocks divide and do not
    (the last block then starts early, its repeated pulse dropped), squint, moving
    scatterers, non-stop-and-go, pointing errors, either dtype, any track centre (not a
    multiple of anything) and a target inside, at the edge of or outside the window: the
    pulse positions equal to the bit (each block keeps the acquisition's centre and
    shifts its pulse indices by a multiple of ½, exact in float64), the data to rounding
    (XLA may compile the block's shape differently: ≤ 4e-16 of the peak measured;
    bound 1e-14 in complex128, 1e-6 in complex64, the dtype's rounding over a few
    hundred terms)."""
    radar = dataclasses.replace(RADAR, squint=squint) if squint else RADAR
    dr, dx = float(RADAR.range_spacing), float(RADAR.azimuth_spacing)
    near = 5140.0 - num_range // 2 * dr
    x = (np.arange(num_pulses) - num_pulses // 2) * dx
    motion = sj.Motion(horizontal=0.03 * np.sin(x / 3.0), vertical=0.02 * np.cos(x / 5.0),
                       pointing=1e-3 * np.sin(x / 2.0) if pointing else None)
    scene = sj.PointTargets(
        azimuth=[centre + azimuth * num_pulses * dx, centre],
        range=[near + slant * num_range * dr, 5140.0],
        velocity_range=[3.0, 0.0] if moving else None,
        velocity_azimuth=[-2.0, 0.0] if moving else None)
    dtype = jnp.complex64 if single else jnp.complex128
    kw = dict(num_pulses=num_pulses, num_range=num_range, near_range=near,
              azimuth_center=centre, method=method, dtype=dtype)
    if not stop_and_go:
        kw["stop_and_go"] = False
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a target outside the window: the swath warning
        with _pulse_blocks(1) as calls:
            whole = sj.simulate(radar, scene, motion, **kw)
        assert calls == [num_pulses]
        with _pulse_blocks(2) as calls:
            split = sj.simulate(radar, scene, motion, **kw)
    assert calls == [-(-num_pulses // 2)] * 2
    np.testing.assert_array_equal(np.asarray(split.azimuth), np.asarray(whole.azimuth))
    a, b = np.asarray(whole.data), np.asarray(split.data)
    assert a.shape == b.shape == (num_pulses, num_range)
    assert np.abs(b - a).max() <= (1e-6 if single else 1e-14) * max(np.abs(a).max(), 1e-30)
    assert split.method == whole.method


def test_which_calls_run_as_pulse_blocks(monkeypatch):
    """Only a pulse-local (exact) model's unbatched call on a CPU device of a machine with
    the cores for it, estimated at or above the threshold, with nothing traced."""
    device = jax.devices("cpu")[0]
    acquisition = Acquisition(num_pulses=N, num_range=M, near_range=NEAR, azimuth_center=0.0)
    call = _simulate.CallPlan()

    still = sj.Motion()

    def blocks(method, threshold, motion=still, call=call, cores=2, memory=None):
        monkeypatch.setattr(_simulate, "HOST_SPLIT_SECONDS", threshold)
        monkeypatch.setattr(_simulate, "_usable_cores", lambda: cores)
        simulator = _registry.build(method, {})
        plan = simulator.prepare(RADAR, SCENE, acquisition, motion)
        return _simulate._host_blocks(simulator, plan, RADAR, SCENE, motion, acquisition,
                                      jnp.complex128, call, device, memory)

    def memory(limit):  # a plan of 100 MB, 60 MB of it one block's workspace
        return SimpleNamespace(estimate=Estimate(output=30e6, inputs=10e6, workspace=60e6),
                               limit=limit)

    assert blocks("time_domain_nufft", 0.0) == 2
    assert blocks("time_domain", 0.0) == 2
    assert blocks("time_domain_nufft", 1e9) == 1  # too small a call to split
    assert blocks("fourier_2d", 0.0) == 1  # not pulse-local
    assert blocks("time_domain", 0.0, cores=1) == 1
    assert blocks("time_domain", 0.0, call=_simulate.CallPlan(batch_size=3)) == 1
    # a second block's workspace at once must fit the memory limit
    assert blocks("time_domain_nufft", 0.0, memory=memory(160e6)) == 2
    assert blocks("time_domain_nufft", 0.0, memory=memory(159e6)) == 1
