"""The one jitted simulation entry point."""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp

from . import _validate
from ._data import Acquisition, RawData
from .motion import Motion
from .scene import PointTargets, ReflectivityGrid
from .validity import choose_method
from .simulators import (
    AbstractSimulator,
    ChirpScaling,
    Fourier2D,
    HighSpeed,
    ModerateDeviation,
    SmallDeviation,
    TimeDomain,
    TimeDomainNUFFT,
)
from .simulators._squint import SquintModerateDeviation, SquintSmallDeviation

_METHODS = {
    "time_domain": TimeDomain,
    "time_domain_nufft": TimeDomainNUFFT,
    "fourier_2d": Fourier2D,
    # at any squint (broadside: the broadside classes, unchanged)
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


@eqx.filter_jit
def _run(simulator, radar, scene, motion, acquisition, dtype, name):
    data = simulator(radar, scene, motion, acquisition, dtype)
    return RawData(
        data=data,
        azimuth=acquisition.pulse_azimuths(radar),
        range=acquisition.range_axis(radar),
        method=name,
    )


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
    **options,
) -> RawData:
    """Simulate stripmap raw data h(x', r').

    Args:
        radar: :class:`~sarjax.Radar` (e.g. ``sj.presets.airborne_xband()``).
        scene: :class:`~sarjax.PointTargets` or :class:`~sarjax.ReflectivityGrid`.
        motion: :class:`~sarjax.Motion` (per-pulse Δy, Δz [m], δ_az [rad]); None = ideal.
        method: ``"time_domain"`` (exact model, physics.md §3), ``"fourier_2d"`` (ideal
            straight track, §4), ``"small_deviation"`` / ``"algorithm_a"``,
            ``"moderate_deviation"`` / ``"algorithm_b"`` (§5–6), ``"auto"`` (the fastest
            method whose validity budgets hold, see :func:`sarjax.validity`; the choice is
            in ``RawData.method``) or a simulator instance.
        num_pulses: pulses N_x (default ``radar.num_pulses``).
        num_range: range samples N_r (default ``radar.num_range``).
        near_range: r' of the first range sample [m] (default ``radar.near_range``).
        azimuth_center: x' of the middle pulse [m].
        dtype: complex dtype of the kernel and output. Geometry and phases are always
            formed in float64; complex64 keeps the phase error ≲ 1e-3 rad rms.
        **options: simulator options (e.g. ``pulse_chunk=``, ``scatterer_chunk=``).

    Returns:
        :class:`~sarjax.RawData` with ``.data`` (azimuth, range), ``.azimuth`` x' [m],
        ``.range`` r' [m].

    Raises:
        ValueError: on non-physical or inconsistent input, naming the value.
    """
    dtype = jnp.dtype(dtype)
    if dtype not in (jnp.complex64, jnp.complex128):
        raise ValueError(f"dtype={dtype} must be complex64 or complex128")
    motion = Motion() if motion is None else motion
    if not isinstance(scene, (PointTargets, ReflectivityGrid)):
        raise ValueError(f"scene={type(scene).__name__} is not PointTargets or ReflectivityGrid")
    num_pulses = radar.num_pulses if num_pulses is None else num_pulses
    num_range = radar.num_range if num_range is None else num_range
    _validate.check_grid(num_pulses, num_range)
    _validate.check_radar(radar)
    _validate.check_scene(scene, radar)
    _validate.check_motion(motion, num_pulses)
    acquisition = Acquisition(
        num_pulses=int(num_pulses),
        num_range=int(num_range),
        near_range=radar.near_range if near_range is None else near_range,
        azimuth_center=azimuth_center,
    )
    _validate.require_positive(acquisition, ["near_range"], "acquisition")
    _validate.check_finite_scalar(azimuth_center, "azimuth_center")
    if method == "auto":
        method, _ = choose_method(
            radar, scene, motion, num_pulses=acquisition.num_pulses,
            azimuth_center=float(azimuth_center),
            pointing_order=options.get("pointing_order", 2),
        )
    name = method if isinstance(method, str) else type(method).__name__
    simulator = _resolve_method(method, options)
    _validate.check_supported(simulator, radar, scene)
    simulator = simulator.prepare(radar, scene, acquisition)
    return _run(simulator, radar, scene, motion, acquisition, dtype, name)
