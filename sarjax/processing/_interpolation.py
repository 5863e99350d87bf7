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
    base, weights, offsets = _sinc_weights(positions, taps)
    index = base.astype(jnp.int32)[..., None] + offsets
    if periodic:
        return jnp.sum(weights * _gather(values, jnp.mod(index, n)), axis=-1)
    valid = (index >= 0) & (index < n)
    gathered = _gather(values, jnp.clip(index, 0, n - 1))
    return jnp.sum(jnp.where(valid, weights, 0.0) * gathered, axis=-1)


def sinc_interpolate_rows(table, positions, *, taps: int = 8):
    """Periodic windowed-sinc interpolation of each row of ``table``, output transposed.

    ``out[c, i]`` interpolates row ``i`` of ``table`` (periodic) at ``positions[c, i]``;
    same kernel as :func:`sinc_interpolate`. Producing the (column, row) layout directly
    lets the consumer transform along the rows' axis without a transpose of a fused
    interpolation (XLA would recompute it per consumer, with strided reads).

    Args:
        table: (n_rows, p) one period per row.
        positions: (m, n_rows) fractional positions along the rows.

    Returns:
        (m, n_rows).
    """
    n_rows, p = table.shape
    base, weights, offsets = _sinc_weights(positions, taps)
    index = jnp.mod(base.astype(jnp.int32)[..., None] + offsets, p)  # (m, n_rows, taps)
    flat = index + (jnp.arange(n_rows, dtype=jnp.int32) * p)[None, :, None]
    return jnp.sum(weights * table.reshape(-1)[flat], axis=-1)


def _sinc_weights(positions, taps):
    """(floor(positions), (..., taps) kernel weights, (…, taps) integer tap offsets)."""
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
    return base, sinc * window, offsets


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
