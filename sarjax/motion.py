"""Platform motion: trajectory deviations and antenna pointing error (physics.md §2, §6).

Per pulse: horizontal cross-track deviation Δy (positive towards the scene), vertical
deviation Δz (positive up), both [m], and azimuth pointing error δ_az [rad].
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np


def _optional(v):
    if v is None:
        return None
    if jnp.iscomplexobj(v):
        raise ValueError(f"motion arrays must be real, got dtype {jnp.asarray(v).dtype}")
    return jnp.asarray(v, dtype=float)


class Motion(eqx.Module):
    """Per-pulse platform motion errors; a missing component is zero.

    Attributes:
        horizontal: (azimuth,) Δy [m], positive towards the illuminated scene, or None.
        vertical: (azimuth,) Δz [m], positive up, or None.
        pointing: (azimuth,) azimuth antenna pointing error δ_az [rad], or None.

    ``Motion()`` is the ideal straight, nominally pointed track.
    """

    horizontal: jnp.ndarray | None = eqx.field(default=None, converter=_optional)
    vertical: jnp.ndarray | None = eqx.field(default=None, converter=_optional)
    pointing: jnp.ndarray | None = eqx.field(default=None, converter=_optional)

    def resolve(self, num_pulses: int):
        """(Δy, Δz, δ_az), each (azimuth,) with zeros for missing components."""
        zero = jnp.zeros(num_pulses)
        pick = lambda v: zero if v is None else jnp.broadcast_to(v, (num_pulses,))
        return pick(self.horizontal), pick(self.vertical), pick(self.pointing)

    @property
    def is_ideal(self) -> bool:
        """True when no component is given (static)."""
        return self.horizontal is None and self.vertical is None and self.pointing is None


def sinusoidal_pointing(azimuth, *, amplitude, period, velocity, phase=0.0):
    """Sinusoidal azimuth pointing jitter (seed 000 eq. 55).

    δ_az(x') = δ_m sin(2π x' / (v T_b) + φ₀)

    Args:
        azimuth: (azimuth,) pulse positions x' [m].
        amplitude: δ_m [rad] (seed 000: λ/(20 L)).
        period: jitter period T_b [s] (seed 000: T_s / 10, T_s = λ r₀ / (L v)).
        velocity: platform speed v [m/s].
        phase: φ₀ [rad].

    Returns:
        (azimuth,) δ_az [rad].
    """
    azimuth = jnp.asarray(azimuth, dtype=float)
    return amplitude * jnp.sin(2 * jnp.pi * azimuth / (velocity * period) + phase)


def seed_pointing_jitter(radar, azimuth, *, amplitude_fraction=1 / 20, period_fraction=1 / 10,
                         phase=0.0):
    """The seed 000 §4 test jitter: δ_m = λ/(20L), T_b = T_s/10 at the reference range.

    Args:
        radar: the :class:`~sarjax.Radar`.
        azimuth: (azimuth,) pulse positions x' [m].
        amplitude_fraction: δ_m in units of λ/L.
        period_fraction: T_b in units of T_s.
        phase: φ₀ [rad].
    """
    return sinusoidal_pointing(
        azimuth,
        amplitude=amplitude_fraction * radar.wavelength / radar.antenna_length,
        period=period_fraction * radar.integration_time(),
        velocity=radar.velocity,
        phase=phase,
    )


def smooth_deviation(azimuth, *, key, rms, max_cycles, aperture):
    """A random smooth deviation profile: a few random Fourier terms (NumPy, float64).

    Args:
        azimuth: (azimuth,) pulse positions x' [m].
        key: integer seed or ``numpy.random.Generator``.
        rms: target rms of the profile [m].
        max_cycles: highest number of cycles per ``aperture`` metres.
        aperture: length over which ``max_cycles`` is counted [m] (e.g. the footprint X).

    Returns:
        (azimuth,) NumPy array [m] with the requested rms.
    """
    rng = key if isinstance(key, np.random.Generator) else np.random.default_rng(key)
    x = np.asarray(azimuth, float)
    profile = np.zeros_like(x)
    span = max(np.ptp(x), aperture)
    n_terms = 8
    for _ in range(n_terms):
        cycles = rng.uniform(0.2, max_cycles) / aperture
        profile += rng.normal() * np.sin(2 * np.pi * cycles * x + rng.uniform(0, 2 * np.pi))
    profile += rng.normal() * (x - x.mean()) / span  # slow drift
    profile -= profile.mean()
    return profile * (rms / np.sqrt(np.mean(profile**2)))
