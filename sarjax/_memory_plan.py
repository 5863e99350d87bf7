"""The memory plan of a :func:`sarjax.simulate` call: chunks and shards within the
memory limit (see :mod:`sarjax._memory` for the estimate and the limit)."""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import jax.numpy as jnp

from . import _memory, _sharding
from .simulators import AbstractPlan, AbstractSimulator


class MemoryPlan(NamedTuple):
    """How :func:`sarjax.simulate` runs a call within its memory limit.

    Attributes:
        estimate: the estimated peak memory (:class:`sarjax._memory.Estimate`, bytes;
            ``.total``, ``.output``, ``.inputs``, ``.workspace``).
        limit: the memory limit [bytes].
        batch_size: realizations B (None: unbatched).
        batch_chunk: realizations evaluated together on a device (None: all).
        simulator: the simulator as it runs (its chunk options set).
        plan: the simulator's plan (``simulator.prepare``: its static sizes).
        devices: the devices the call is split over (empty: one device);
            ``batch_shards`` × ``pulse_shards`` their mesh.
    """

    estimate: _memory.Estimate
    limit: int
    batch_size: int | None
    batch_chunk: int | None
    simulator: AbstractSimulator
    plan: AbstractPlan
    devices: tuple
    batch_shards: int
    pulse_shards: int


def memory_plan(simulator, plan, radar, scene, motion_bytes, acquisition, dtype, batch_size,
                devices, memory_limit, name) -> MemoryPlan:
    """Chunks and shards within the memory limit; raises
    :class:`~sarjax._memory.MemoryLimitError` when even the smallest chunks exceed it.

    The workspace of one realization is the simulator's own declaration
    (``simulator.memory(plan, ...)``), on the block of pulses one device runs (a
    pulse-local simulator) or with its columns split over the devices of one scene
    (``shards=``, a ``splits_columns`` simulator).
    """
    limit = _memory.memory_limit(memory_limit, devices)
    kind = type(simulator)
    n_batch, n_pulse = _sharding.shards(len(devices), batch_size, acquisition.num_pulses,
                                        kind.pulse_local or kind.splits_columns)
    used = n_batch * n_pulse
    block_pulses = -(-acquisition.num_pulses // n_pulse)
    block = dataclasses.replace(acquisition, num_pulses=block_pulses)
    # a column split synthesises every pulse on each device, 1/n_pulse of the columns
    by_columns = n_pulse > 1 and not kind.pulse_local
    split = dict(shards=n_pulse) if by_columns else {}
    block_batch = None if batch_size is None else -(-batch_size // n_batch)
    item = jnp.dtype(dtype).itemsize
    output = ((block_batch or 1) * n_batch * block_pulses * n_pulse
              * acquisition.num_range * item)
    inputs = used * _memory.scene_bytes(scene) + motion_bytes

    def estimate(sim, batch_chunk):
        together = 1 if block_batch is None else min(batch_chunk or block_batch, block_batch)
        workspace = (sim.memory(plan, radar, scene, acquisition, dtype, **split)
                     if by_columns else sim.memory(plan, radar, scene, block, dtype))
        return _memory.Estimate(int(output), int(inputs), int(used * together * workspace))

    def planned(sim, batch_chunk, est):
        return MemoryPlan(
            estimate=est, limit=limit, batch_size=batch_size, batch_chunk=batch_chunk,
            simulator=sim, plan=plan, devices=tuple(devices[:used]) if used > 1 else (),
            batch_shards=n_batch, pulse_shards=n_pulse,
        )

    est = estimate(simulator, None)
    if est.total <= limit:
        return planned(simulator, None, est)
    chunk = None
    if block_batch is not None:  # fewer realizations at a time
        chunk = block_batch
        while chunk > 1:
            chunk = max(1, chunk // 2)
            est = estimate(simulator, chunk)
            if est.total <= limit:
                return planned(simulator, chunk, est)
    for smaller in simulator.smaller_chunks(plan, block, scene, dtype):
        est = estimate(smaller, chunk)
        if est.total <= limit:
            return planned(smaller, chunk, est)
    _memory.refuse(f"simulate(method={name!r})", est, limit)
