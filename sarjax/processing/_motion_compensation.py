"""Motion compensation for the Fourier focusers (physics.md §11, seed 000 eq. 5).

First order removes the range- and azimuth-invariant deviation δr(x') projected on the
scene centre (envelope shift and phase, in the range-frequency domain); second order
removes the range-variant phase ψ(x', r) = δr_xr(x', x', r) − δr(x') per range sample.
Squinted, a cross-track deviation δ moves the slant range to a target in the beam by
cos φ_d δ (R = r / cos φ_d from the beam's along-track offset r tan φ_d: ∂R/∂r = cos φ_d),
as the simulators' ``k₀ cos φ_d ψ`` (physics.md §8).
"""

from __future__ import annotations

import jax.numpy as jnp

from .. import geometry
from .._numerics.interpolation import next_fast_len


def first_order(radar, compressed, horizontal, vertical, range_axis):
    """Remove δr(x'): multiply the range spectrum by exp[+j η̄ cos φ_d δr(x')], η̄ = η + 4π/λ.

    Args:
        radar: the :class:`~sarjax.Radar`.
        compressed: (azimuth, range) range-compressed data.
        horizontal, vertical: (azimuth,) Δy, Δz [m].
        range_axis: (range,) r' [m].
    """
    n_range = compressed.shape[-1]
    n_fft = next_fast_len(n_range + 64)
    delta_r = (geometry.reference_deviation(horizontal, vertical, radar)
               * jnp.cos(radar.squint))  # (azimuth,), along the beam
    eta = 2 * jnp.pi * jnp.fft.fftfreq(n_fft, radar.range_spacing)
    spectrum = jnp.fft.fft(compressed, n=n_fft, axis=-1)
    shift = jnp.exp(1j * (eta[None, :] + radar.wavenumber) * delta_r[:, None])
    return jnp.fft.ifft(spectrum * shift, axis=-1)[..., :n_range]


def second_order(radar, compressed, horizontal, vertical, range_axis):
    """Remove ψ(x', r'): multiply by exp[+j (4π/λ) cos φ_d ψ(x', r' cos φ_d)] at each range
    sample r' (slant range; r' cos φ_d the closest approach the beam centre sees there)."""
    # the sample at slant range r' sees, through the beam centre, the ground at closest
    # approach r' cos φ_d; range samples nearer than the platform height have no ground
    # position: ψ = 0 there
    closest = range_axis * jnp.cos(radar.squint)
    has_ground = closest > radar.height
    safe_range = jnp.where(has_ground, closest, radar.reference_range)
    psi = geometry.range_variant_deviation(
        horizontal[:, None], vertical[:, None], safe_range[None, :], 0.0, radar
    )
    psi = jnp.where(has_ground[None, :], psi, 0.0)
    return compressed * jnp.exp(1j * radar.wavenumber * jnp.cos(radar.squint) * psi)
