"""Devices and the sharded run: realizations of a batch across devices, and blocks of
pulses across the devices left over for the pulse-local (exact) simulators."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, PartitionSpec

from ._data import Acquisition


def realizations(simulator, plan, radar, scene, motion, acquisition, dtype, batch_size,
                 batch_chunk):
    """One realization, or a batch: the simulator vmapped over the motion's leading axis,
    ``batch_chunk`` realizations at a time (sequentially) when fewer than all. The one
    place the kernel is lifted over realizations."""

    def one(realization):
        return simulator.simulate(plan, radar, scene, realization, acquisition, dtype)

    if batch_size is None:
        return one(motion)
    if batch_chunk is None or batch_chunk >= batch_size:
        return jax.vmap(one)(motion)
    return jax.lax.map(one, motion, batch_size=batch_chunk)


def sharded(simulator, plan, radar, scene, motion, acquisition, dtype, call):
    """The call split over a (batch, pulse) device mesh with ``shard_map``: realizations
    over ``batch``, blocks of pulses (pulse-local simulators) over ``pulse``. Pulses and
    realizations are padded (edge values) to whole blocks and cut off afterwards.

    ``plan`` is the simulator's plan for one block of pulses; ``call`` the call plan
    (``_simulate.CallPlan``)."""
    n_batch, n_pulse = call.batch_shards, call.pulse_shards
    mesh = Mesh(np.asarray(call.devices, dtype=object).reshape(n_batch, n_pulse),
                ("batch", "pulse"))
    num_pulses = acquisition.num_pulses
    block_pulses = -(-num_pulses // n_pulse)
    batched = call.batch_size is not None
    block_batch = -(-call.batch_size // n_batch) if batched else None

    def pad(values):
        widths = [(0, 0)] * values.ndim
        widths[-1] = (0, block_pulses * n_pulse - num_pulses)
        if batched:
            widths[0] = (0, block_batch * n_batch - call.batch_size)
        return jnp.pad(values, widths, mode="edge")

    motion = jax.tree_util.tree_map(pad, motion)
    # x' of the middle pulse of block s (pulses s·n … s·n + n − 1 of the acquisition)
    offsets = jnp.arange(n_pulse) * block_pulses + (block_pulses - 1) / 2 - (num_pulses - 1) / 2
    centres = acquisition.azimuth_center + offsets * radar.azimuth_spacing

    def local(motion_block, centre):
        block = Acquisition(num_pulses=block_pulses, num_range=acquisition.num_range,
                            near_range=acquisition.near_range, azimuth_center=centre[0])
        return realizations(simulator, plan, radar, scene, motion_block, block, dtype,
                            block_batch, call.batch_chunk)

    spec = PartitionSpec("batch", "pulse") if batched else PartitionSpec("pulse")
    # check_vma=False: the simulators' loops start from unvarying carries (zeros)
    data = jax.shard_map(local, mesh=mesh, in_specs=(spec, PartitionSpec("pulse")),
                         out_specs=spec, check_vma=False)(motion, centres)
    return data[: call.batch_size, :num_pulses] if batched else data[:num_pulses]


def resolve_devices(devices) -> tuple:
    """``devices=``: None (every device of the default backend), a count n (the first n)
    or a sequence of ``jax.Device``."""
    available = jax.devices()
    if devices is None:
        return tuple(available)
    if isinstance(devices, (int, np.integer)) and not isinstance(devices, bool):
        if not 1 <= devices <= len(available):
            raise ValueError(
                f"devices={devices} must be between 1 and the {len(available)} available "
                f"device(s) {available}"
            )
        return tuple(available[: int(devices)])
    given = devices
    if isinstance(devices, jax.Device):
        devices = (devices,)
    if isinstance(devices, (str, bytes)):
        devices = (devices,)
    try:
        devices = tuple(devices)
    except TypeError:
        raise ValueError(
            f"devices={given!r} must be None, a number of devices or a sequence of "
            "jax.Device"
        ) from None
    bad = [d for d in devices if not isinstance(d, jax.Device)]
    if not devices or bad:
        raise ValueError(
            f"devices={given!r} must be a non-empty sequence of jax.Device "
            f"(not {bad[:3]})"
        )
    if len(set(devices)) != len(devices):
        raise ValueError(f"devices={given!r} lists a device twice")
    return devices


def shards(num_devices, batch_size, num_pulses, pulse_local):
    """(batch shards, pulse shards): realizations first, then pulse blocks (pulse-local
    simulators) on the devices left over."""
    n_batch = 1
    if batch_size is not None:
        per_device = -(-batch_size // min(num_devices, batch_size))
        n_batch = -(-batch_size // per_device)
    n_pulse = min(num_devices // n_batch, num_pulses) if pulse_local else 1
    return n_batch, max(n_pulse, 1)
