"""Peak-memory estimates and the memory limit of a :func:`sarjax.simulate` or
:func:`sarjax.focus` call.

Every call estimates its peak memory before any work, from the array sizes and the dtype:

    peak = output + inputs + workspace(batch_chunk),

``output`` the result (all realizations of a batch), ``inputs`` the scene and motion arrays
and ``workspace`` the intermediates of the ``batch_chunk`` realizations evaluated together
(each simulator's ``memory()`` declares it: pulses × scatterers × range samples for the
exact model, the padded (ξ, η) grid for the Fourier methods). The per-method workspaces are
upper bounds of what XLA allocates (``Compiled.memory_analysis()``; tests/test_memory.py
checks them within a factor 1–4).

The limit is, in order: the ``memory_limit=`` argument, the ``SARJAX_MEMORY_LIMIT``
environment variable (bytes, ``"512MiB"``, ``"2GB"`` …), or :data:`DEFAULT_FRACTION` of the
memory available now (``MemAvailable`` of ``/proc/meminfo``, else ``os.sysconf``; on
accelerators, the free memory of the devices used). Over the limit the caller chunks
(smaller pulse / scatterer chunks, fewer realizations at a time); when even the smallest
chunks do not fit, it raises :class:`MemoryLimitError` stating the estimate and the limit.
"""

from __future__ import annotations

import math
import os
import re
from typing import NamedTuple

import jax
import numpy as np

from ._numerics.interpolation import next_fast_len

ENV_LIMIT = "SARJAX_MEMORY_LIMIT"
DEFAULT_FRACTION = 0.5  # of the memory available at the call

_UNITS = {
    "": 1, "b": 1,
    "k": 10**3, "kb": 10**3, "m": 10**6, "mb": 10**6, "g": 10**9, "gb": 10**9,
    "t": 10**12, "tb": 10**12,
    "kib": 2**10, "mib": 2**20, "gib": 2**30, "tib": 2**40,
}


class MemoryLimitError(MemoryError, ValueError):
    """A call whose estimated peak memory exceeds the limit even at its smallest chunks."""


class Estimate(NamedTuple):
    """Estimated peak memory of one call [bytes].

    Attributes:
        output: the result (every realization of a batch).
        inputs: scene, motion and other input arrays.
        workspace: intermediates of the realizations evaluated together.
    """

    output: int
    inputs: int
    workspace: int

    @property
    def total(self) -> int:
        """output + inputs + workspace [bytes]."""
        return int(self.output + self.inputs + self.workspace)


def format_bytes(n) -> str:
    """``n`` bytes as a short human-readable string (binary units)."""
    n = float(n)
    for unit in ("B", "KiB", "MiB", "GiB"):
        if abs(n) < 1024 or unit == "GiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} GiB"


def parse_bytes(value, name="memory_limit") -> int:
    """A memory size: a number of bytes (int or float) or a string such as ``"512MiB"``,
    ``"2 GB"``, ``"1.5g"`` (SI and binary units). Raises ValueError naming ``name``."""
    if isinstance(value, bool):
        raise ValueError(f"{name}={value!r} is not a memory size")
    if isinstance(value, (int, float, np.integer, np.floating)):
        number = float(value)
    elif isinstance(value, str):
        match = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([A-Za-z]*)\s*", value)
        unit = match.group(2).lower() if match else None
        if match is None or unit not in _UNITS:
            raise ValueError(
                f"{name}={value!r} is not a memory size (e.g. 2000000000, '512MiB', '2GB')"
            )
        number = float(match.group(1)) * _UNITS[unit]
    else:
        raise ValueError(f"{name}={value!r} is not a memory size")
    if not math.isfinite(number) or number <= 0:
        raise ValueError(f"{name}={value!r} must be a positive, finite number of bytes")
    return int(number)


def _meminfo_available() -> int | None:
    """``MemAvailable`` [bytes] from ``/proc/meminfo``; None when it cannot be read (not
    Linux, or an unexpected format: the caller falls back to ``os.sysconf``)."""
    try:
        with open("/proc/meminfo") as f:
            lines = f.read().splitlines()
    except OSError:
        return None
    for line in lines:
        fields = line.split()
        if fields[:1] == ["MemAvailable:"] and len(fields) > 1 and fields[1].isdigit():
            return int(fields[1]) * 1024
    return None


def available_memory() -> int | None:
    """Host memory available now [bytes]: ``MemAvailable`` from ``/proc/meminfo``, else
    ``os.sysconf`` available pages; None when neither can be read."""
    meminfo = _meminfo_available()
    if meminfo is not None:
        return meminfo
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (OSError, ValueError, AttributeError):
        return None


def _device_memory(devices) -> int | None:
    """Free memory summed over accelerator devices [bytes] (None on CPU or if unknown)."""
    total = 0
    for device in devices:
        if device.platform == "cpu":
            return None
        stats = device.memory_stats() or {}
        if "bytes_limit" not in stats:
            return None
        total += int(stats["bytes_limit"]) - int(stats.get("bytes_in_use", 0))
    return total or None


def memory_limit(limit=None, devices=None) -> int:
    """The memory limit of a call [bytes]: ``limit`` if given, else ``$SARJAX_MEMORY_LIMIT``,
    else :data:`DEFAULT_FRACTION` of the available memory (see the module docstring).

    Args:
        limit: bytes, or a string such as ``"4GiB"``; None for the default.
        devices: the devices the call runs on (default: ``jax.devices()[:1]``).
    """
    if limit is not None:
        return parse_bytes(limit, "memory_limit")
    env = os.environ.get(ENV_LIMIT)
    if env:
        return parse_bytes(env, ENV_LIMIT)
    devices = jax.devices()[:1] if devices is None else devices
    free = _device_memory(devices)
    if free is None:
        free = available_memory()
    if free is None:  # nothing readable: no limit rather than a made-up one
        return 2**62
    return int(DEFAULT_FRACTION * free)


def refuse(what: str, estimate: Estimate, limit: int, *, chunked: bool = True):
    """Raise :class:`MemoryLimitError` stating the estimate and the limit."""
    how = "even at the smallest chunks" if chunked else "(this call is not chunked)"
    raise MemoryLimitError(
        f"{what}: estimated peak memory {format_bytes(estimate.total)} "
        f"(output {format_bytes(estimate.output)}, inputs {format_bytes(estimate.inputs)}, "
        f"workspace {format_bytes(estimate.workspace)}) exceeds the memory limit "
        f"{format_bytes(limit)} {how}; raise memory_limit= (or ${ENV_LIMIT}) or reduce "
        "the problem size"
    )


_C128 = 16  # the processors work in complex128 whatever the output dtype


def scene_bytes(scene) -> int:
    """Bytes of a scene's arrays."""
    return int(sum(np.size(leaf) * np.dtype(leaf.dtype).itemsize
                   for leaf in jax.tree_util.tree_leaves(scene) if hasattr(leaf, "dtype")))


def focus_estimate(method, num_pulses, num_range, n_fft, *, image_shape=None,
                   upsample=8, azimuth_padding=0, kappa_oversampling=1,
                   range_transform=None) -> Estimate:
    """Estimated peak memory of :func:`sarjax.focus` [bytes] (complex128 processing).

    ω-k: the range-compressed data and ≈ 4 padded (n_x, n_r) spectra (n_x the pulses
    and ``azimuth_padding``, n_r ``range_transform``, default 2 N_r; the Stolt rows
    ``kappa_oversampling`` times wider, counted in two of the four); back-projection:
    7 (exact back-projection: 18) complex128 arrays the size of the data and of the image
    (compressed and upsampled pulse blocks, per-pixel ranges and weights), fitted to
    XLA's memory analysis with a margin of ≈ 1.3.
    """
    n_img = num_pulses * num_range if image_shape is None else int(np.prod(image_shape))
    n_data = num_pulses * num_range
    if method == "omega_k":
        n_x = next_fast_len(num_pulses + azimuth_padding)
        n_r = next_fast_len(2 * num_range) if range_transform is None else range_transform
        workspace = _C128 * (2 * num_pulses * n_fft + (2 + 2 * kappa_oversampling) * n_x * n_r)
    else:
        arrays = 7.0 if method == "backprojection" else 18.0
        workspace = _C128 * arrays * (n_data + n_img) * max(1.0, upsample / 8)
    return Estimate(int(_C128 * n_img), int(_C128 * n_data), int(workspace))
