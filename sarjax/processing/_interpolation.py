"""Band-limited interpolation helpers (used by the Stolt mapping and back-projection)."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from .._phasor import sine


def next_fast_len(n: int) -> int:
    """Smallest 2^a 3^b 5^c ≥ n (a fast FFT length)."""
    best = 2 ** int(np.ceil(np.log2(max(n, 1))))
    p2 = 1
    while p2 < best:
        p3 = p2
        while p3 < best:
            p5 = p3
            while p5 < n:
                p5 *= 5
            best = min(best, p5)
            p3 *= 3
            if p3 >= n:
                best = min(best, p3)
        p2 *= 2
    return int(best)


def sinc_interpolate(values, positions, *, taps: int = 12, periodic: bool = False):
    """Windowed-sinc interpolation of uniformly sampled values.

    Kernel ``sinc(d) · (1 − (d/h)²)³`` with ``h = taps/2``: on 2× oversampled data its
    error is ≈ −63 dB (12 taps) and −73 dB (16 taps) relative to the signal; one ``sin``
    per output (``sin π(f − o) = (−1)^o sin πf`` for integer tap offsets ``o``).

    Args:
        values: (..., n) samples at integer positions 0 … n−1 (band-limited, preferably
            oversampled ≥ 2×).
        positions: (..., m) fractional sample positions; taps beyond the ends read zero
            (or wrap around with ``periodic``).
        taps: kernel length (even).
        periodic: treat ``values`` as one period of a periodic sequence.

    Returns:
        (..., m) interpolated values.
    """
    n = values.shape[-1]
    half = taps // 2
    base = jnp.floor(positions)
    frac = positions - base
    offsets = jnp.arange(-half + 1, half + 1).reshape((1,) * positions.ndim + (taps,))
    distance = frac[..., None] - offsets  # (..., m, taps)
    sign = jnp.where(offsets % 2 == 0, 1.0, -1.0)
    sin_term = sine(jnp.pi * frac)[..., None] * sign
    tiny = jnp.abs(distance) < 1e-12
    sinc = jnp.where(tiny, 1.0, sin_term / (jnp.pi * jnp.where(tiny, 1.0, distance)))
    window = jnp.clip(1.0 - (distance / half) ** 2, 0.0, 1.0) ** 3
    index = base.astype(jnp.int32)[..., None] + offsets
    if periodic:
        return jnp.sum(sinc * window * _gather(values, jnp.mod(index, n)), axis=-1)
    valid = (index >= 0) & (index < n)
    gathered = _gather(values, jnp.clip(index, 0, n - 1))
    return jnp.sum(jnp.where(valid, sinc * window, 0.0) * gathered, axis=-1)


def _gather(values, index):
    """values (..., n), index (..., m, taps) -> (..., m, taps)."""
    flat = index.reshape(index.shape[:-2] + (-1,))
    out = jnp.take_along_axis(values, flat, axis=-1)
    return out.reshape(index.shape)


def linear_interpolate(values, positions):
    """Linear interpolation along the last axis; zero outside [0, n−1].

    Args:
        values: (n,) samples at integer positions.
        positions: (...) fractional positions.
    """
    n = values.shape[-1]
    base = jnp.floor(positions)
    frac = positions - base
    i0 = base.astype(jnp.int32)
    inside = (i0 >= 0) & (i0 < n - 1)
    i0c = jnp.clip(i0, 0, n - 2)
    v = values[i0c] * (1 - frac) + values[i0c + 1] * frac
    return jnp.where(inside, v, 0.0)
