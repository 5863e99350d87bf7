"""The one jitted simulation entry point: resolve the method in the registry, check the
inputs and the method's budgets, plan the call (the simulator's plan, memory, devices),
run the kernel under one ``jit`` and wrap the result in :class:`~sarjax.RawData`."""

from __future__ import annotations

import concurrent.futures
import dataclasses
import math
import os
import threading

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import _exported, _sharding, _validate
from ._data import Acquisition, RawData
from ._memory_plan import MemoryPlan, memory_plan
from .motion import Motion
from .scene import PointTargets, ReflectivityGrid
from .simulators import _registry
from .validity import explain_choice


@dataclasses.dataclass(frozen=True)
class CallPlan:
    """How one call runs (static: part of the jit cache key).

    Attributes:
        batch_size: realizations B of a batched motion (None: unbatched).
        batch_chunk: realizations evaluated together on a device (None: all).
        devices: devices of the mesh, batch-major (empty: no sharding).
        batch_shards, pulse_shards: mesh shape (batch, pulse).
    """

    batch_size: int | None = None
    batch_chunk: int | None = None
    devices: tuple = ()
    batch_shards: int = 1
    pulse_shards: int = 1


_SINGLE = CallPlan()
_Plan = CallPlan  # the earlier private name


def _broadcast_batch(motion, batch_size, num_pulses):
    """Every given motion component as (batch, pulses) (unbatched ones are shared)."""
    return jax.tree_util.tree_map(
        lambda v: jnp.broadcast_to(v, (batch_size, num_pulses)), motion)


@eqx.filter_jit
def _run(simulator, plan, radar, scene, motion, acquisition, dtype, name, call=_SINGLE):
    if call.batch_size is not None:
        motion = _broadcast_batch(motion, call.batch_size, acquisition.num_pulses)
    if len(call.devices) > 1:
        data = _sharding.sharded(simulator, plan, radar, scene, motion, acquisition, dtype,
                                 call)
    else:
        data = _sharding.realizations(simulator, plan, radar, scene, motion, acquisition,
                                      dtype, call.batch_size, call.batch_chunk)
    return RawData(
        data=data,
        azimuth=acquisition.pulse_azimuths(radar),
        range=acquisition.range_axis(radar),
        method=name,
    )


def _realization(motion, b):
    """Realization b of a batched motion."""
    return Motion(**{
        name: (None if v is None else (v[b] if v.ndim == 2 else v))
        for name, v in (("horizontal", motion.horizontal), ("vertical", motion.vertical),
                        ("pointing", motion.pointing))
    })


def _choose_batched_method(radar, scene, motion, batch_size, **kwargs):
    """``method="auto"`` for a batch: the most exact of the methods chosen for each
    realization (the one chosen for the realization that needs the most). (name, reason)."""
    if batch_size is None:
        return explain_choice(radar, scene, motion, **kwargs)
    chosen, rank, reason = None, -1, ""
    order = _registry.method_names(aliases=False)
    for b in range(batch_size):
        method, why = explain_choice(radar, scene, _realization(motion, b), **kwargs)
        cls = _registry.simulator_class(method)
        # the exact models after the approximate ones, each in registry order
        this = (cls.exact, order.index(method))
        if chosen is None or this > rank:
            chosen, rank, reason = method, this, f"realization {b} needs it ({why})"
    return chosen, (f"the most exact of the {batch_size} realizations' choices: {reason}")


def _prepare(radar, scene, motion, *, method, num_pulses, num_range, near_range,
             azimuth_center, dtype, devices, memory_limit, options, concurrent_checks=False):
    """Validate, resolve the method and plan the call (everything but running it).

    ``concurrent_checks``: the model's checks (:func:`sarjax._validate.model_findings`: the
    budgets, the swath) are returned as a :class:`concurrent.futures.Future` of their
    findings, started in a worker thread, where the call is not strict and nothing is
    traced (else None, and they ran here): :func:`simulate` runs the simulation meanwhile.
    """
    strict = _validate.check_arguments(radar, options)
    dtype = _validate.check_dtype(dtype)
    motion = Motion() if motion is None else motion
    if not isinstance(motion, Motion):
        raise ValueError(f"motion={type(motion).__name__} is not a Motion")
    if not isinstance(scene, (PointTargets, ReflectivityGrid)):
        raise ValueError(f"scene={type(scene).__name__} is not PointTargets or ReflectivityGrid")
    num_pulses = radar.num_pulses if num_pulses is None else num_pulses
    num_range = radar.num_range if num_range is None else num_range
    _validate.check_grid(num_pulses, num_range)
    _validate.check_radar(radar)
    _validate.check_scene(scene, radar)
    batch_size = _validate.check_motion(motion, num_pulses)
    acquisition = Acquisition(
        num_pulses=int(num_pulses),
        num_range=int(num_range),
        near_range=radar.near_range if near_range is None else near_range,
        azimuth_center=azimuth_center,
    )
    _validate.require_positive(acquisition, ["near_range"], "acquisition")
    _validate.check_finite_scalar(azimuth_center, "azimuth_center")
    devices = _sharding.resolve_devices(devices)
    if isinstance(method, np.str_):
        method = str(method)
    reason = ""
    if isinstance(method, str) and method == _registry.AUTO:
        method, reason = _choose_batched_method(
            radar, scene, motion, batch_size, num_pulses=acquisition.num_pulses,
            num_range=acquisition.num_range, near_range=acquisition.near_range,
            azimuth_center=float(azimuth_center), dtype=dtype, **options,
        )
    simulator = _registry.build(method, options)
    name = method if isinstance(method, str) else type(simulator).__name__
    _validate.check_supported(simulator, radar, scene, motion)
    plan = simulator.prepare(radar, scene, acquisition, motion)
    checks = None
    if concurrent_checks and not strict and not _validate.is_traced(radar, scene, motion):
        checks = _checks_pool().submit(_validate.model_findings, simulator, radar, scene,
                                       motion, acquisition, strict, dtype)
    else:
        _validate.check_model(simulator, radar, scene, motion, acquisition, strict, dtype)
    motion_bytes = sum(math.prod(np.shape(v)) * 8 for v in jax.tree_util.tree_leaves(motion))
    memory = memory_plan(simulator, plan, radar, scene, motion_bytes, acquisition, dtype,
                         batch_size, devices, memory_limit, name)
    call = CallPlan(batch_size=batch_size, batch_chunk=memory.batch_chunk,
                    devices=memory.devices, batch_shards=memory.batch_shards,
                    pulse_shards=memory.pulse_shards)
    return (memory.simulator, plan, motion, acquisition, dtype, name, call, reason, memory,
            checks)


_POOL = None
_POOL_LOCK = threading.Lock()


def _checks_pool():
    """The threads the model's checks run in beside the simulations (created once)."""
    global _POOL
    with _POOL_LOCK:
        if _POOL is None:
            _POOL = concurrent.futures.ThreadPoolExecutor(
                max_workers=2, thread_name_prefix="sarjax-checks")
        return _POOL


def _forget_checks_pool():
    """In a forked child: the parent's threads are not there (work given to its pool
    would never run), so a new pool is made on the next call."""
    global _POOL, _POOL_LOCK
    _POOL, _POOL_LOCK = None, threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_checks_pool)


# An exact model's call on one CPU device runs as this many blocks of pulses, each from
# a host thread of its own, where it is estimated to take at least HOST_SPLIT_SECONDS:
# XLA runs the NUFFT model's scatter-add and much of the time-domain kernel on one core,
# and two programs called from two threads run at once (benchmarks/README.md).
HOST_BLOCKS = 2
HOST_SPLIT_SECONDS = 0.25


def _usable_cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def _host_blocks(simulator, plan, radar, scene, motion, acquisition, dtype, call,
                 device, memory=None) -> int:
    """The blocks of pulses a call runs as, one per host thread (1: the whole call at
    once): :data:`HOST_BLOCKS` for a pulse-local (exact) model's unbatched call on one
    CPU device of a machine with as many cores, whose cost model estimates at least
    :data:`HOST_SPLIT_SECONDS`, with traced inputs nowhere and, under ``memory`` (the
    call's :class:`MemoryPlan`), room for each further block's workspace at once."""
    kind = type(simulator)
    if (not kind.pulse_local or call.batch_size is not None or device.platform != "cpu"
            or acquisition.num_pulses < 2 * HOST_BLOCKS
            or _usable_cores() < HOST_BLOCKS
            or _validate.is_traced(radar, scene, motion, acquisition)):
        return 1
    if memory is not None and (memory.estimate.total
                               + (HOST_BLOCKS - 1) * memory.estimate.workspace
                               > memory.limit):
        return 1
    steady = simulator.cost(plan, radar, scene, acquisition, dtype).steady
    return HOST_BLOCKS if steady >= HOST_SPLIT_SECONDS else 1


def _run_in_blocks(run, blocks, device, simulator, plan, radar, scene, motion, acquisition,
                   dtype, name, call):
    """``run`` on ``blocks`` equal blocks of the pulses at once, one host thread each,
    joined into one :class:`~sarjax.RawData`: each block an acquisition of its own
    (its pulses, shifted by ``pulse_offset`` to where the whole acquisition puts them, and
    the motion's slice), all of one shape (the last block starts early where the pulses
    do not divide, its repeated pulses dropped), so one compiled program serves them.
    Pulse-local models only: the whole call's pulses, to the bit, and its data to rounding
    (≤ 4e-16 of the peak in drawn cases: XLA may compile a block's shape differently)."""
    n = acquisition.num_pulses
    size = -(-n // blocks)
    starts = [min(b * size, n - size) for b in range(blocks)]
    parts = []
    for start in starts:
        moved = jax.tree_util.tree_map(lambda v, s=start: v[s:s + size], motion)
        parts.append((acquisition.pulse_block(start, size), moved))

    def one(args):
        part, moved = args
        with jax.default_device(device):
            return run(simulator, plan, radar, scene, moved, part, dtype, name, call)

    pool = concurrent.futures.ThreadPoolExecutor(max_workers=blocks,
                                                 thread_name_prefix="sarjax-pulses")
    with pool:
        raws = list(pool.map(one, parts))
    keep = [slice(max(0, (starts[b - 1] + size) - start) if b else 0, size)
            for b, start in enumerate(starts)]
    return dataclasses.replace(
        raws[0],
        data=jnp.concatenate([r.data[k] for r, k in zip(raws, keep, strict=True)]),
        azimuth=jnp.concatenate([r.azimuth[k] for r, k in zip(raws, keep, strict=True)]))


def simulate(
    radar,
    scene,
    motion=None,
    *,
    method="time_domain",
    num_pulses=None,
    num_range=None,
    near_range=None,
    azimuth_center=0.0,
    dtype=jnp.complex128,
    devices=None,
    memory_limit=None,
    **options,
) -> RawData:
    """Simulate stripmap raw data h(x', r'), for one platform motion or a batch of them.

    Args:
        radar: :class:`~sarjax.Radar` (e.g. ``sj.presets.airborne_xband()``).
        scene: :class:`~sarjax.PointTargets` or :class:`~sarjax.ReflectivityGrid`.
        motion: :class:`~sarjax.Motion` (per-pulse Δy, Δz [m], δ_az [rad]); None = ideal.
            **Batch** (Monte-Carlo studies): components of shape (batch, azimuth) are B
            motion realizations, simulated in one jitted call (the simulator vmapped over
            the leading axis); components of shape (azimuth,) are shared by all of them.
        method: ``"time_domain"`` (exact model, physics.md §3), ``"time_domain_nufft"``
            (the exact model by one non-uniform FFT per pulse), ``"fourier_2d"`` (ideal
            straight track, §4), ``"small_deviation"`` / ``"algorithm_a"``,
            ``"moderate_deviation"`` / ``"algorithm_b"`` (§5–6), ``"high_speed"`` (§10),
            ``"chirp_scaling"`` (§9), ``"auto"`` (the cheapest method whose validity
            budgets hold by each simulator's cost model, see :func:`sarjax.validity`,
            for every realization of a batch; the choice is in ``RawData.method``, why in
            ``RawData.method_reason``) or a
            simulator instance. ``sarjax.simulators.method_names()`` lists them.
        num_pulses: pulses N_x (default ``radar.num_pulses``).
        num_range: range samples N_r (default ``radar.num_range``).
        near_range: r' of the first range sample [m] (default ``radar.near_range``).
        azimuth_center: x' of the middle pulse [m].
        dtype: complex dtype of the kernel and output. Geometry and phases are always
            formed in float64; complex64 keeps the phase error ≲ 1e-3 rad rms.
        devices: the JAX devices to run on: None (default: all devices of the default
            backend), a count n (the first n) or a sequence of ``jax.Device``; 1 runs on
            one device. With several, the call is split with ``shard_map`` over a
            (batch, pulse) mesh: realizations of a batch across devices, then one scene
            across the devices left over: for the exact models (``time_domain``,
            ``time_domain_nufft``) blocks of pulses; for the Fourier-domain methods
            (``fourier_2d``, ``small_deviation``, ``moderate_deviation``,
            ``high_speed``) the range-wavenumber columns between the azimuth and range
            transforms, each device then left with a block of the pulses by one
            all-to-all (so a scene larger than one device's memory runs on several;
            ``chirp_scaling`` is not split). The output is sharded over the devices by
            pulse. Results equal the one-device results to rounding. On one CPU device
            an exact model's call estimated at 0.25 s or more runs as two blocks of
            pulses, one host thread each, joined (the same pulse positions, the data
            equal to rounding; the NUFFT model's scatter-add runs on one core).
        memory_limit: bound on the call's estimated peak memory, bytes or a string such as
            ``"2GiB"`` (default: ``$SARJAX_MEMORY_LIMIT``, else half the memory available
            now; see :mod:`sarjax._memory`). Over it the call runs fewer realizations at
            a time and (exact model) fewer pulses and scatterers per chunk; results do not
            depend on the chunking. :func:`simulation_memory` shows the plan.
        strict: refuse, rather than warn about or run, input outside the model's
            validity: the approximate methods' budgets (:func:`sarjax.validity`), a PRF
            below the echoes' Doppler band (Fourier-domain methods) and scatterers whose
            echoes miss the range window (see :func:`sarjax._validate.check_model`).
        **options: simulator options (e.g. ``pulse_chunk=``, ``scatterer_chunk=``).

    Returns:
        :class:`~sarjax.RawData` with ``.data`` (azimuth, range) — (batch, azimuth, range)
        for a batched motion —, ``.azimuth`` x' [m], ``.range`` r' [m].

    Raises:
        ValueError: on non-physical or inconsistent input, naming the value.
        MemoryError: (:class:`sarjax._memory.MemoryLimitError`, also a ValueError) when
            the estimated peak memory exceeds ``memory_limit`` even at the smallest chunks;
            the message states the estimate and the limit.
    """
    # the model's checks (the validity budgets) run in a worker thread while the
    # simulation runs (strict: before it, which then does not run); their warnings are
    # given here once both are done
    simulator, plan, motion, acquisition, dtype, name, call, reason, memory, checks = _prepare(
        radar, scene, motion, method=method, num_pulses=num_pulses, num_range=num_range,
        near_range=near_range, azimuth_center=azimuth_center, dtype=dtype, devices=devices,
        memory_limit=memory_limit, options=options, concurrent_checks=True,
    )
    run = _exported.persistent(_run)  # loaded from disk when the cache is on
    try:
        if call.devices:
            raw = run(simulator, plan, radar, scene, motion, acquisition, dtype, name, call)
        else:
            device = _sharding.resolve_devices(devices)[0]  # the first named
            blocks = _host_blocks(simulator, plan, radar, scene, motion, acquisition,
                                  dtype, call, device, memory)
            if blocks > 1:
                raw = _run_in_blocks(run, blocks, device, simulator, plan, radar, scene,
                                     motion, acquisition, dtype, name, call)
            else:
                with jax.default_device(device):
                    raw = run(simulator, plan, radar, scene, motion, acquisition, dtype,
                              name, call)
    except BaseException:
        if checks is not None:  # the run's error is the call's; the checks end first
            concurrent.futures.wait([checks])
        raise
    if checks is not None:
        _validate.emit(checks.result(), stacklevel=2)
    # outside the jit: the reason (costs, budgets) and the period would otherwise key
    # its cache
    period = simulator.azimuth_period(radar, scene, motion, acquisition)
    if reason or period:
        raw = dataclasses.replace(raw, method_reason=reason, azimuth_period=period)
    return raw


def simulation_memory(
    radar,
    scene,
    motion=None,
    *,
    method="time_domain",
    num_pulses=None,
    num_range=None,
    near_range=None,
    azimuth_center=0.0,
    dtype=jnp.complex128,
    devices=None,
    memory_limit=None,
    **options,
) -> MemoryPlan:
    """The :class:`MemoryPlan` of the same :func:`simulate` call, without running it:
    estimated peak memory [bytes], the limit, the chunks and the devices. Same arguments
    and errors as :func:`simulate`."""
    return _prepare(
        radar, scene, motion, method=method, num_pulses=num_pulses, num_range=num_range,
        near_range=near_range, azimuth_center=azimuth_center, dtype=dtype, devices=devices,
        memory_limit=memory_limit, options=options,
    )[-2]
