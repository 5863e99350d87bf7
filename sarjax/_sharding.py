"""Devices and the sharded run: realizations of a batch across devices, and one scene
across the devices left over: blocks of pulses for the pulse-local (exact) simulators,
range-wavenumber columns for the Fourier-domain ones (each device left with a block of
the pulses by one all-to-all, ``_fourier_engine.split_columns``)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, PartitionSpec

from .simulators import _fourier_engine


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
    over ``batch``; over ``pulse``, blocks of pulses (pulse-local simulators: each device
    simulates its block as a shorter acquisition) or the range-wavenumber columns
    (``splits_columns`` simulators: each device synthesises its columns on every pulse
    and an all-to-all leaves it its block of pulses). Pulses and realizations are padded
    (edge values) to whole blocks and cut off afterwards.

    ``plan`` is the simulator's plan for the pulses one device simulates; ``call`` the
    call plan (``_simulate.CallPlan``)."""
    n_batch, n_pulse = call.batch_shards, call.pulse_shards
    mesh = Mesh(np.asarray(call.devices, dtype=object).reshape(n_batch, n_pulse),
                ("batch", "pulse"))
    num_pulses = acquisition.num_pulses
    block_pulses = -(-num_pulses // n_pulse)
    batched = call.batch_size is not None
    block_batch = -(-call.batch_size // n_batch) if batched else None
    by_columns = n_pulse > 1 and not type(simulator).pulse_local

    def pad(values):
        widths = [(0, 0)] * values.ndim
        if not by_columns:
            widths[-1] = (0, block_pulses * n_pulse - num_pulses)
        if batched:
            widths[0] = (0, block_batch * n_batch - call.batch_size)
        return jnp.pad(values, widths, mode="edge")

    motion = jax.tree_util.tree_map(pad, motion)
    # block s holds pulses s·n … s·n + n − 1 of the acquisition (the last padded)
    firsts = jnp.arange(n_pulse) * block_pulses

    def local(motion_block, first):
        if by_columns:  # every pulse here; the columns split inside the kernel
            with _fourier_engine.columns_across("pulse", n_pulse):
                return realizations(simulator, plan, radar, scene, motion_block,
                                    acquisition, dtype, block_batch, call.batch_chunk)
        block = acquisition.pulse_block(first[0], block_pulses)
        return realizations(simulator, plan, radar, scene, motion_block, block, dtype,
                            block_batch, call.batch_chunk)

    spec = PartitionSpec("batch", "pulse") if batched else PartitionSpec("pulse")
    motion_spec = (PartitionSpec("batch") if batched else PartitionSpec()) if by_columns else spec
    # check_vma=False: the simulators' loops start from unvarying carries (zeros)
    data = jax.shard_map(local, mesh=mesh, in_specs=(motion_spec, PartitionSpec("pulse")),
                         out_specs=spec, check_vma=False)(motion, firsts)
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


def shards(num_devices, batch_size, num_pulses, splits):
    """(batch shards, pulse shards): realizations first, then the scene (pulse blocks or
    range columns, for simulators that split one scene: ``splits``) on the devices left
    over."""
    n_batch = 1
    if batch_size is not None:
        per_device = -(-batch_size // min(num_devices, batch_size))
        n_batch = -(-batch_size // per_device)
    n_pulse = min(num_devices // n_batch, num_pulses) if splits else 1
    return n_batch, max(n_pulse, 1)
