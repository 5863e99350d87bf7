"""The one jitted simulation entry point."""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, PartitionSpec

from . import _memory, _validate
from ._data import Acquisition, RawData
from .motion import Motion
from .scene import PointTargets, ReflectivityGrid
from .simulators import (
    AbstractSimulator,
    ChirpScaling,
    HighSpeed,
    TimeDomain,
    TimeDomainNUFFT,
)
from .simulators._squint import SquintFourier2D, SquintModerateDeviation, SquintSmallDeviation
from .validity import FASTEST_FIRST, choose_method

_METHODS = {
    "time_domain": TimeDomain,
    "time_domain_nufft": TimeDomainNUFFT,
    # at any squint (broadside: the broadside classes, unchanged)
    "fourier_2d": SquintFourier2D,
    "small_deviation": SquintSmallDeviation,
    "algorithm_a": SquintSmallDeviation,
    "moderate_deviation": SquintModerateDeviation,
    "algorithm_b": SquintModerateDeviation,
    "high_speed": HighSpeed,
    "chirp_scaling": ChirpScaling,
}


def _resolve_method(method, options):
    if isinstance(method, AbstractSimulator):
        if options:
            raise ValueError(f"options {sorted(options)} given with a simulator instance")
        return method
    try:
        cls = _METHODS[method]
    except (KeyError, TypeError):
        raise ValueError(
            f"unknown method={method!r}; choose one of {sorted(_METHODS)} or pass a simulator"
        ) from None
    try:
        return cls(**options)
    except TypeError:
        known = sorted(f for f in cls.__dataclass_fields__ if not f.startswith("_"))
        raise ValueError(
            f"unknown option(s) {sorted(options)} for method={method!r}; known: {known}"
        ) from None


# Simulators whose pulses are independent: a block of pulses is simulated on its own, as
# a shorter acquisition centred on the block, so pulses can be split across devices. (The
# Fourier-domain simulators transform along the whole aperture: they need every pulse.)
_PULSE_LOCAL = (TimeDomain, TimeDomainNUFFT)


def _is_pulse_local(simulator) -> bool:
    return isinstance(simulator, _PULSE_LOCAL) or bool(getattr(simulator, "pulse_local", False))


@dataclasses.dataclass(frozen=True)
class _Plan:
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


_SINGLE = _Plan()


def _realizations(simulator, radar, scene, motion, acquisition, dtype, batch_size,
                  batch_chunk):
    """One realization, or a batch: the simulator vmapped over the motion's leading axis,
    ``batch_chunk`` realizations at a time (sequentially) when fewer than all."""

    def one(realization):
        return simulator(radar, scene, realization, acquisition, dtype)

    if batch_size is None:
        return one(motion)
    if batch_chunk is None or batch_chunk >= batch_size:
        return jax.vmap(one)(motion)
    return jax.lax.map(one, motion, batch_size=batch_chunk)


def _sharded(simulator, radar, scene, motion, acquisition, dtype, plan):
    """The call split over a (batch, pulse) device mesh with ``shard_map``: realizations
    over ``batch``, blocks of pulses (pulse-local simulators) over ``pulse``. Pulses and
    realizations are padded (edge values) to whole blocks and cut off afterwards."""
    n_batch, n_pulse = plan.batch_shards, plan.pulse_shards
    mesh = Mesh(np.asarray(plan.devices, dtype=object).reshape(n_batch, n_pulse),
                ("batch", "pulse"))
    num_pulses = acquisition.num_pulses
    block_pulses = -(-num_pulses // n_pulse)
    batched = plan.batch_size is not None
    block_batch = -(-plan.batch_size // n_batch) if batched else None

    def pad(values):
        widths = [(0, 0)] * values.ndim
        widths[-1] = (0, block_pulses * n_pulse - num_pulses)
        if batched:
            widths[0] = (0, block_batch * n_batch - plan.batch_size)
        return jnp.pad(values, widths, mode="edge")

    motion = jax.tree_util.tree_map(pad, motion)
    # x' of the middle pulse of block s (pulses s·n … s·n + n − 1 of the acquisition)
    offsets = jnp.arange(n_pulse) * block_pulses + (block_pulses - 1) / 2 - (num_pulses - 1) / 2
    centres = acquisition.azimuth_center + offsets * radar.azimuth_spacing

    def local(motion_block, centre):
        block = Acquisition(num_pulses=block_pulses, num_range=acquisition.num_range,
                            near_range=acquisition.near_range, azimuth_center=centre[0])
        return _realizations(simulator, radar, scene, motion_block, block, dtype,
                             block_batch, plan.batch_chunk)

    spec = PartitionSpec("batch", "pulse") if batched else PartitionSpec("pulse")
    # check_vma=False: the simulators' loops start from unvarying carries (zeros)
    data = jax.shard_map(local, mesh=mesh, in_specs=(spec, PartitionSpec("pulse")),
                         out_specs=spec, check_vma=False)(motion, centres)
    return data[: plan.batch_size, :num_pulses] if batched else data[:num_pulses]


def _broadcast_batch(motion, batch_size, num_pulses):
    """Every given motion component as (batch, pulses) (unbatched ones are shared)."""
    return jax.tree_util.tree_map(
        lambda v: jnp.broadcast_to(v, (batch_size, num_pulses)), motion)


@eqx.filter_jit
def _run(simulator, radar, scene, motion, acquisition, dtype, name, plan=_SINGLE):
    if plan.batch_size is not None:
        motion = _broadcast_batch(motion, plan.batch_size, acquisition.num_pulses)
    if len(plan.devices) > 1:
        data = _sharded(simulator, radar, scene, motion, acquisition, dtype, plan)
    else:
        data = _realizations(simulator, radar, scene, motion, acquisition, dtype,
                             plan.batch_size, plan.batch_chunk)
    return RawData(
        data=data,
        azimuth=acquisition.pulse_azimuths(radar),
        range=acquisition.range_axis(radar),
        method=name,
    )


# --------------------------------------------------------------------------------------
# devices and memory
# --------------------------------------------------------------------------------------


def _resolve_devices(devices) -> tuple:
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


def _shards(num_devices, batch_size, num_pulses, pulse_local):
    """(batch shards, pulse shards): realizations first, then pulse blocks (pulse-local
    simulators) on the devices left over."""
    n_batch = 1
    if batch_size is not None:
        per_device = -(-batch_size // min(num_devices, batch_size))
        n_batch = -(-batch_size // per_device)
    n_pulse = min(num_devices // n_batch, num_pulses) if pulse_local else 1
    return n_batch, max(n_pulse, 1)


def _smaller_chunks(simulator, acquisition, scene, dtype):
    """Simulators with the same output and smaller chunks, larger first."""
    n, n_r, n_s = acquisition.num_pulses, acquisition.num_range, scene.num_scatterers
    if isinstance(simulator, TimeDomain):
        pulse, scat = simulator.chunks(n, n_r, n_s, dtype)
        while pulse > 1:  # fewer pulses at a time first: the scatterer chunk sets the speed
            pulse //= 2
            yield dataclasses.replace(simulator, pulse_chunk=pulse, scatterer_chunk=scat)
        while scat > 1:
            scat //= 2
            yield dataclasses.replace(simulator, pulse_chunk=1, scatterer_chunk=scat)
    elif isinstance(simulator, TimeDomainNUFFT):
        pulse = simulator.chunk(n, n_r, n_s, dtype)
        while pulse > 1:
            pulse //= 2
            yield dataclasses.replace(simulator, pulse_chunk=pulse)
        if simulator.loops > 1:
            yield dataclasses.replace(simulator, pulse_chunk=1, loops=1)


class MemoryPlan(NamedTuple):
    """How :func:`sarjax.simulate` runs a call within its memory limit.

    Attributes:
        estimate: the estimated peak memory (:class:`sarjax._memory.Estimate`, bytes;
            ``.total``, ``.output``, ``.inputs``, ``.workspace``).
        limit: the memory limit [bytes].
        batch_size: realizations B (None: unbatched).
        batch_chunk: realizations evaluated together on a device (None: all).
        simulator: the simulator as it runs (its chunk options set).
        devices: the devices the call is split over (empty: one device);
            ``batch_shards`` × ``pulse_shards`` their mesh.
    """

    estimate: _memory.Estimate
    limit: int
    batch_size: int | None
    batch_chunk: int | None
    simulator: AbstractSimulator
    devices: tuple
    batch_shards: int
    pulse_shards: int


def _memory_plan(simulator, radar, scene, motion_bytes, acquisition, dtype, batch_size,
                 devices, memory_limit, name) -> MemoryPlan:
    """Chunks and shards within the memory limit (see :mod:`sarjax._memory`); raises
    :class:`~sarjax._memory.MemoryLimitError` when even the smallest chunks exceed it."""
    limit = _memory.memory_limit(memory_limit, devices)
    n_batch, n_pulse = _shards(len(devices), batch_size, acquisition.num_pulses,
                               _is_pulse_local(simulator))
    used = n_batch * n_pulse
    block_pulses = -(-acquisition.num_pulses // n_pulse)
    block = dataclasses.replace(acquisition, num_pulses=block_pulses)
    block_batch = None if batch_size is None else -(-batch_size // n_batch)
    item = jnp.dtype(dtype).itemsize
    output = ((block_batch or 1) * n_batch * block_pulses * n_pulse
              * acquisition.num_range * item)
    inputs = used * _memory.scene_bytes(scene) + motion_bytes

    def estimate(sim, batch_chunk):
        together = 1 if block_batch is None else min(batch_chunk or block_batch, block_batch)
        workspace = _memory.simulation_workspace(sim, radar, scene, block, dtype)
        return _memory.Estimate(int(output), int(inputs), int(used * together * workspace))

    def plan(sim, batch_chunk, est):
        return MemoryPlan(
            estimate=est, limit=limit, batch_size=batch_size, batch_chunk=batch_chunk,
            simulator=sim, devices=tuple(devices[:used]) if used > 1 else (),
            batch_shards=n_batch, pulse_shards=n_pulse,
        )

    est = estimate(simulator, None)
    if est.total <= limit:
        return plan(simulator, None, est)
    chunk = None
    if block_batch is not None:  # fewer realizations at a time
        chunk = block_batch
        while chunk > 1:
            chunk = max(1, chunk // 2)
            est = estimate(simulator, chunk)
            if est.total <= limit:
                return plan(simulator, chunk, est)
    for smaller in _smaller_chunks(simulator, block, scene, dtype):
        est = estimate(smaller, chunk)
        if est.total <= limit:
            return plan(smaller, chunk, est)
    _memory.refuse(f"simulate(method={name!r})", est, limit)


# --------------------------------------------------------------------------------------
# the public entry point
# --------------------------------------------------------------------------------------


def _choose_batched_method(radar, scene, motion, batch_size, **kwargs):
    """``method="auto"`` for a batch: the most exact of the methods chosen for each
    realization."""
    if batch_size is None:
        return choose_method(radar, scene, motion, **kwargs)[0]
    order = {name: i for i, name in enumerate(FASTEST_FIRST)}
    chosen = FASTEST_FIRST[0]
    for b in range(batch_size):
        realization = Motion(**{
            name: (None if v is None else (v[b] if v.ndim == 2 else v))
            for name, v in (("horizontal", motion.horizontal), ("vertical", motion.vertical),
                            ("pointing", motion.pointing))
        })
        method = choose_method(radar, scene, realization, **kwargs)[0]
        if order.get(method, len(order)) > order.get(chosen, len(order)):
            chosen = method
    return chosen


def _prepare(radar, scene, motion, *, method, num_pulses, num_range, near_range,
             azimuth_center, dtype, devices, memory_limit, options):
    """Validate, resolve the method and plan the call (everything but running it)."""
    strict = _validate.check_arguments(radar, options)
    dtype = jnp.dtype(dtype)
    if dtype not in (jnp.complex64, jnp.complex128):
        raise ValueError(f"dtype={dtype} must be complex64 or complex128")
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
    devices = _resolve_devices(devices)
    if method == "auto":
        method = _choose_batched_method(
            radar, scene, motion, batch_size, num_pulses=acquisition.num_pulses,
            azimuth_center=float(azimuth_center),
            pointing_order=options.get("pointing_order", 2),
        )
    name = str(method) if isinstance(method, str) else type(method).__name__
    simulator = _resolve_method(method, options)
    _validate.check_supported(simulator, radar, scene)
    simulator = simulator.prepare(radar, scene, acquisition)
    _validate.check_model(simulator, radar, scene, motion, acquisition, strict)
    motion_bytes = sum(math.prod(np.shape(v)) * 8 for v in jax.tree_util.tree_leaves(motion))
    memory = _memory_plan(simulator, radar, scene, motion_bytes, acquisition, dtype,
                          batch_size, devices, memory_limit, name)
    plan = _Plan(batch_size=batch_size, batch_chunk=memory.batch_chunk,
                 devices=memory.devices, batch_shards=memory.batch_shards,
                 pulse_shards=memory.pulse_shards)
    return memory.simulator, motion, acquisition, dtype, name, plan, memory


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
            ``"chirp_scaling"`` (§9), ``"auto"`` (the fastest method whose validity
            budgets hold, see :func:`sarjax.validity`, for every realization of a batch;
            the choice is in ``RawData.method``) or a simulator instance.
        num_pulses: pulses N_x (default ``radar.num_pulses``).
        num_range: range samples N_r (default ``radar.num_range``).
        near_range: r' of the first range sample [m] (default ``radar.near_range``).
        azimuth_center: x' of the middle pulse [m].
        dtype: complex dtype of the kernel and output. Geometry and phases are always
            formed in float64; complex64 keeps the phase error ≲ 1e-3 rad rms.
        devices: the JAX devices to run on: None (default: all devices of the default
            backend), a count n (the first n) or a sequence of ``jax.Device``; 1 runs on
            one device. With several, the call is split with ``shard_map`` over a
            (batch, pulse) mesh: realizations of a batch across devices, and for the
            pulse-local exact models (``time_domain``, ``time_domain_nufft``) blocks of
            pulses across the devices left over. The Fourier-domain methods transform
            along the whole aperture, so only their batch axis is split (an unbatched
            call runs on one device). Results equal the one-device results to rounding.
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
    simulator, motion, acquisition, dtype, name, plan, _ = _prepare(
        radar, scene, motion, method=method, num_pulses=num_pulses, num_range=num_range,
        near_range=near_range, azimuth_center=azimuth_center, dtype=dtype, devices=devices,
        memory_limit=memory_limit, options=options,
    )
    return _run(simulator, radar, scene, motion, acquisition, dtype, name, plan)


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
    )[-1]
