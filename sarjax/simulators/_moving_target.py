"""The 2-D spectrum of a moving scatterer's echo beyond stop-and-go at its azimuth
stationary point (seed 004 eq. 4, 10–11; the derivation is in ``_high_speed``'s module
docstring): the factors the high-speed simulator synthesises, and the pattern argument
that ``_extent`` maps a Doppler band's edges through to choose the bands."""

from __future__ import annotations

import jax.numpy as jnp

from ..constants import SPEED_OF_LIGHT

_TWO_PI = 2 * jnp.pi


def spectrum_terms(radar, xi, k, velocity_range, velocity_azimuth, stop_and_go=False):
    """Per-(ξ, k) factors of one velocity group (module docstring).

    Args:
        radar: the :class:`~sarjax.Radar`.
        xi: azimuth wavenumbers ξ [rad/m]; k: two-way range wavenumbers η + 4π/λ [rad/m]
            (broadcastable).
        velocity_range, velocity_azimuth: the group's (v_r, v_a) [m/s] (scalars).
        stop_and_go: the stop-and-go spectrum instead.

    Returns:
        ``(kappa_rel, amplitude, u)``: ``κ − 4π/λ`` [rad/m] (the range-line phase per metre,
        azimuth shift included), ``A / √r`` [complex, per √m] and the pattern argument at
        the stationary point.
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
    # beyond the target's Doppler horizon (|β| ≥ 1: |ξ| v/k ≳ v_eq, inside the synthesised
    # bands when it moves away along track) the echo has no stationary point and no
    # energy; the clamped root's amplitude there grew as (10⁻¹²)^(−3/4) (30° squint,
    # 30 m/s along track: −11.5 dB against the exact model, no warning)
    amplitude = jnp.where(beta**2 < 1, jnp.sqrt(
        _TWO_PI * alpha * v**2 / (k * alpha0 * v_eq2 * root**3)
    ) / radar.azimuth_spacing, 0.0) * jnp.exp(-1j * jnp.pi / 4)
    # look angle at the stationary point, per metre of r (everything scales with r)
    s_star = -v_r / v_eq2
    transmit = -beta * alpha / (v_eq * root) + s_star  # s / r [s/m]
    echo = alpha0 * (alpha / root + v_eq2 * inv_c * transmit + v_r * inv_c)  # ρ / r
    middle = transmit + echo * inv_c  # (t − τ₀) / r at the middle of the echo
    along = (v - v_a) * middle / (1 + v_r * middle)  # (x_A − x_P) / (current range)
    t = jnp.tan(radar.squint)
    u = radar.antenna_length / radar.wavelength * (along + t) / (1 - along * t)
    return kappa_rel, amplitude, u
