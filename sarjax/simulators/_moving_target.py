"""The 2-D spectrum of a moving scatterer's echo beyond stop-and-go at its azimuth
stationary point (seed 004 eq. 4, 10–11; the derivation is in ``_high_speed``'s module
docstring): the factors the high-speed simulator synthesises, and the pattern argument
that ``_extent`` maps a Doppler band's edges through to choose the bands."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from ..constants import SPEED_OF_LIGHT

_TWO_PI = 2 * jnp.pi


def spectrum_terms(radar, xi, k, velocity_range, velocity_azimuth, stop_and_go=False,
                   real_dtype=None, with_transmit=False):
    """Per-(ξ, k) factors of one velocity group (module docstring).

    Args:
        radar: the :class:`~sarjax.Radar`.
        xi: azimuth wavenumbers ξ [rad/m]; k: two-way range wavenumbers η + 4π/λ [rad/m]
            (broadcastable).
        velocity_range, velocity_azimuth: the group's (v_r, v_a) [m/s] (scalars).
        stop_and_go: the stop-and-go spectrum instead.
        real_dtype: precision of the amplitude and the pattern argument (default: that of
            the inputs); κ is formed in the inputs' precision (float64: it multiplies
            ranges of kilometres in a phase). float32 for a complex64 run: its amplitude
            and look angle carry 1e-7 relative error, the output's own precision.

    Returns:
        ``(kappa_rel, amplitude, u)``: ``κ − 4π/λ`` [rad/m] (the range-line phase per metre,
        azimuth shift included), ``A / √r`` [complex, per √m] and the pattern argument at
        the stationary point; ``with_transmit``: and ``s / r`` [s/m], the stationary
        transmit time from the crossing of the scatterer's azimuth per metre of ``r``
        (the pulse that records the cell's echo is at ``x' = x + v s``).
    """
    v = radar.velocity
    v_r, v_a = velocity_range, velocity_azimuth
    v_eq2 = v_r**2 + (v - v_a) ** 2
    v_eq = jnp.sqrt(v_eq2)
    alpha = jnp.sqrt(1 - v_r**2 / v_eq2)
    inv_c = 0.0 if stop_and_go else 1.0 / SPEED_OF_LIGHT
    alpha0 = 1 / (1 - v_eq2 * inv_c**2)
    beta = xi * v / (k * alpha0 * v_eq) + v_eq * inv_c
    root = jnp.sqrt(jnp.maximum(1 - beta**2, 1e-12))
    k0 = radar.wavenumber
    kappa = k * alpha0 * alpha * root - xi * v * v_r / v_eq2
    kappa_rel = (kappa - k0)
    if real_dtype is not None:  # amplitude and look angle in the output's precision
        beta, root, k, v, v_r, v_a, v_eq, v_eq2, alpha, alpha0, inv_c = (
            jnp.asarray(a).astype(real_dtype)
            for a in (beta, root, k, v, v_r, v_a, v_eq, v_eq2, alpha, alpha0, inv_c))
    real = jnp.result_type(beta, root, k)
    # beyond the target's Doppler horizon (|β| ≥ 1: |ξ| v/k ≳ v_eq, inside the synthesised
    # bands when it moves away along track) the echo has no stationary point and no
    # energy; the clamped root's amplitude there grew as (10⁻¹²)^(−3/4) (30° squint,
    # 30 m/s along track: −11.5 dB against the exact model, no warning)
    scale = jnp.asarray(_TWO_PI * alpha * v**2 / (alpha0 * v_eq2), real)
    spacing = jnp.asarray(radar.azimuth_spacing, real)
    amplitude = jnp.where(beta**2 < 1, jnp.sqrt(scale / (k * root**3)) / spacing, 0.0)
    amplitude = amplitude * np.exp(-1j * np.pi / 4).astype(jnp.result_type(real, 1j))
    # look angle at the stationary point, per metre of r (everything scales with r)
    s_star = -v_r / v_eq2
    transmit = -beta * alpha / (v_eq * root) + s_star  # s / r [s/m]
    echo = alpha0 * (alpha / root + v_eq2 * inv_c * transmit + v_r * inv_c)  # ρ / r
    middle = transmit + echo * inv_c  # (t − τ₀) / r at the middle of the echo
    along = (v - v_a) * middle / (1 + v_r * middle)  # (x_A − x_P) / (current range)
    t = jnp.asarray(jnp.tan(radar.squint), real)
    u = jnp.asarray(radar.antenna_length / radar.wavelength, real) * (along + t) / (1 - along * t)
    if with_transmit:
        return kappa_rel, amplitude, u, transmit
    return kappa_rel, amplitude, u
