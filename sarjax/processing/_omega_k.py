"""Wavenumber-domain (ω-k) focusing for a straight track (physics.md §11).

Point target, range-compressed, in the 2-D wavenumber domain (POSP):
``S(ξ, η) ∝ exp[−j √(η̄² − ξ²) r − j ξ x]``, ``η̄ = η + 4π/λ``. Reference-function
multiply at (x_c, r₀), Stolt mapping ``κ = √(η̄² − ξ²) − 4π/λ`` by windowed-sinc
interpolation onto a uniform κ grid, then a 2-D inverse FFT onto the raw grid. The
focused sample of a target at (x, r) carries the phase ``exp(−j 4π r/λ)``.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from .._numerics.interpolation import next_fast_len, sinc_interpolate
from .._numerics.phasor import broadcast_phasor


def omega_k(
    radar, compressed, azimuth_axis, range_axis, *, row_chunk: int = 64,
    equalize_pattern: bool = False, pattern_floor: float = 0.05,
):
    """Focus range-compressed data with the ω-k algorithm.

    Args:
        radar: the :class:`~sarjax.Radar` (straight nominal track, broadside).
        compressed: (azimuth, range) range-compressed data on (x', r').
        azimuth_axis: (azimuth,) x' [m], uniform.
        range_axis: (range,) r' [m], uniform.
        row_chunk: azimuth-wavenumber rows interpolated together (memory bound).
        equalize_pattern: divide the azimuth spectrum by the two-way pattern at its
            stationary point, ``W²(u*)``, ``u* = −ξL / (λ√(k₀² − ξ²))`` (floored at
            ``pattern_floor``): the whole PRF band is then processed with near-uniform
            weight (azimuth IRW ≈ 0.886 v/PRF, as in seed 000 Table 3). Default: the
            natural antenna weighting.
        pattern_floor: lower bound of ``W²`` in the equalisation.

    Returns:
        (azimuth, range) complex image on the same (x, r) grid.
    """
    n_az, n_rg = compressed.shape
    n_x = next_fast_len(n_az)
    n_r = next_fast_len(2 * n_rg)  # ≥ 2× oversampled in η for the Stolt interpolation
    dx = radar.azimuth_spacing
    dr = radar.range_spacing
    k0 = radar.wavenumber
    r_ref = radar.reference_range
    x0, near = azimuth_axis[0], range_axis[0]
    x_c = x0 + (n_az - 1) / 2 * dx

    eta = 2 * jnp.pi * jnp.fft.fftshift(jnp.fft.fftfreq(n_r, dr))  # ascending
    xi = 2 * jnp.pi * jnp.fft.fftfreq(n_x, dx)
    d_eta = 2 * jnp.pi / (n_r * dr)

    spec = jnp.fft.fftshift(jnp.fft.fft(compressed, n=n_r, axis=-1), axes=-1)
    # per-axis phasors formed once (broadcast_phasor), not once per element
    spec = spec * broadcast_phasor(-eta * (near - r_ref))[None, :]
    spec = jnp.fft.fft(spec, n=n_x, axis=0) * broadcast_phasor(-xi * (x0 - x_c))[:, None]

    # reference-function multiply (RFM) exp[j(√(η̄² − ξ²) − η) r₀], written as
    # (√(η̄² − ξ²) − η̄) r₀ + k₀ r₀ with the small first term in closed form
    eta_bar = eta[None, :] + k0
    xi2 = xi[:, None] ** 2
    kz = jnp.sqrt(jnp.maximum(eta_bar**2 - xi2, 0.0))
    spec = spec * jnp.exp(1j * (-xi2 / (kz + eta_bar) * r_ref + jnp.mod(k0 * r_ref, 2 * jnp.pi)))
    if equalize_pattern:
        u_star = -xi * radar.antenna_length / (radar.wavelength * jnp.sqrt(k0**2 - xi**2))
        # 1/W² per row formed once: a division last is not copied into the product
        inverse_gain = 1 / jnp.maximum(radar.pattern(u_star), pattern_floor)
        spec = spec * inverse_gain[:, None]
    # materialise before the gathers (else XLA recomputes the RFM once per tap)
    spec = jax.lax.optimization_barrier(spec)

    def stolt_rows(args):
        rows, xi_rows = args
        # value at uniform κ = η (new grid) is read at η_src = √((κ + k0)² + ξ²) − k0
        eta_src = jnp.sqrt((eta[None, :] + k0) ** 2 + xi_rows[:, None] ** 2) - k0
        return sinc_interpolate(rows, (eta_src - eta[0]) / d_eta)

    chunk = min(row_chunk, n_x)
    n_chunks = -(-n_x // chunk)
    pad = n_chunks * chunk - n_x
    spec_p = jnp.pad(spec, ((0, pad), (0, 0))).reshape(n_chunks, chunk, n_r)
    xi_p = jnp.pad(xi, (0, pad)).reshape(n_chunks, chunk)
    stolt = jax.lax.map(stolt_rows, (spec_p, xi_p)).reshape(n_chunks * chunk, n_r)[:n_x]

    # back to (x, r): phase references so that output sample (i, j) is at (x'_i, r'_j)
    stolt = stolt * broadcast_phasor(eta * (near - r_ref))[None, :] * jnp.exp(
        -1j * jnp.mod(k0 * r_ref, 2 * jnp.pi)
    )
    stolt = stolt * broadcast_phasor(xi * (x0 - x_c))[:, None]
    image = jnp.fft.ifft(stolt, axis=0)[:n_az]
    image = jnp.fft.ifft(jnp.fft.ifftshift(image, axes=-1), axis=-1)[:, :n_rg]
    # exp(+jπ/4) undoes the stationary-phase constant of the azimuth transform, so a
    # target focuses with phase arg γ − 4πr/λ
    return image * (n_x / n_az) * jnp.exp(1j * jnp.pi / 4)
