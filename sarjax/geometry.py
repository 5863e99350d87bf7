"""Stripmap geometry with trajectory deviations (physics.md §2, seed 000 eq. 2–5).

Nominal antenna ``(x', 0, H)``; actual ``(x', Δy, H + Δz)``; scatterer at
``(x, y_P, h)`` with ground range ``y_P = √(r² − (H − h)²)``. Ranges are formed as
differences from the scatterer's closest-approach range ``r`` so that no large
number is subtracted from another: ``R − r`` and ``δr_xr`` keep full relative
precision in any dtype, and the absolute phase ``4πR/λ`` is reduced modulo 2π in
float64 (physics.md §3, style Rule 7).
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np


def _sqrt(x):
    """√x in NumPy for NumPy input (eager budget checks: no per-operation compile), in
    JAX otherwise (traced or device arrays)."""
    if isinstance(x, (np.ndarray, np.floating, float, int)):
        return np.sqrt(x)
    return jnp.sqrt(x)


def ground_range(slant_range, height, platform_height):
    """y_P = √(r² − (H − h)²) [m]: horizontal distance from the nominal track."""
    drop = platform_height - height
    return _sqrt((slant_range - drop) * (slant_range + drop))


def line_of_sight_deviation(horizontal, vertical, slant_range, height, platform_height):
    """Exact line-of-sight deviation δr_xr = √((y_P − Δy)² + (H + Δz − h)²) − r [m].

    The seed's first-order form is ``δr_xr ≈ −d sin(ϑ − β)`` (seed 000 eq. 4); the exact
    cross-track distance is used here, so that ``R = √((r + δr_xr)² + (x' − x)²)`` holds
    exactly (seed 000 eq. 3). Computed as ``q / (√(r² + q) + r)`` with
    ``q = −2 y_P Δy + Δy² + 2 (H − h) Δz + Δz²`` (no cancellation).

    Args:
        horizontal: Δy [m] (positive towards the scene), broadcastable.
        vertical: Δz [m] (positive up).
        slant_range: closest-approach slant range r from the nominal track [m].
        height: scatterer height h [m].
        platform_height: nominal platform height H [m].
    """
    drop = platform_height - height
    y = ground_range(slant_range, height, platform_height)
    return line_of_sight_deviation_across(horizontal, vertical, slant_range, y, drop)


def line_of_sight_deviation_across(horizontal, vertical, slant_range, ground, drop):
    """:func:`line_of_sight_deviation` from the scatterer's cross-track position: ground
    range ``y_P`` (:func:`ground_range`) and ``drop = H − h`` [m], which do not change
    from pulse to pulse (a per-pulse loop forms them once)."""
    q = horizontal * (horizontal - 2 * ground) + vertical * (vertical + 2 * drop)
    return q / (_sqrt(slant_range**2 + q) + slant_range)


def range_offset(along_track, slant_range, los_deviation):
    """Exact ``R − r`` [m] with ``R = √((r + δr_xr)² + (x' − x)²)``.

    Args:
        along_track: x' − x [m].
        slant_range: r [m].
        los_deviation: δr_xr [m].
    """
    numerator = los_deviation * (2 * slant_range + los_deviation) + along_track**2
    full = _sqrt((slant_range + los_deviation) ** 2 + along_track**2)
    return numerator / (full + slant_range)


def reference_deviation(horizontal, vertical, radar):
    """δr(x'): the deviation projected on the scene centre (x', r₀, h = 0) [m] (seed 000 eq. 5)."""
    return line_of_sight_deviation(
        horizontal, vertical, radar.reference_range, 0.0, radar.height
    )


def range_variant_deviation(horizontal, vertical, slant_range, height, radar):
    """ψ(x', r) = δr_xr(x', x', r) − δr(x') [m] (seed 000 eq. 5), broadcast over inputs."""
    return line_of_sight_deviation(
        horizontal, vertical, slant_range, height, radar.height
    ) - reference_deviation(horizontal, vertical, radar)
