"""Radar and acquisition parameters (physics.md §1, §12).

Every physical number is an array leaf, so changing a value between calls never
recompiles and every value can be differentiated. Only the acquisition grid size
(number of pulses and range samples) is structure.

:func:`radar_attributes` / :func:`radar_from_attributes` turn a radar into plain numbers
and strings and back (the attributes of sarjax files and the parameters of exports).
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .antenna import AbstractPattern, GaussianPattern, Sinc2Pattern
from .constants import SPEED_OF_LIGHT


def _leaf():
    return eqx.field(converter=lambda v: jnp.asarray(v, dtype=float))


class Radar(eqx.Module):
    """Monostatic stripmap radar with a linear-FM chirp, flying along ``x`` at height ``H``.

    Attributes (SI units; symbols of physics.md §1):
        carrier_frequency: f [Hz].
        bandwidth: chirp bandwidth Δf [Hz].
        chirp_duration: τ [s].
        sampling_rate: range sampling rate f_s [Hz] (complex baseband).
        prf: pulse repetition frequency [Hz].
        velocity: platform speed v [m/s].
        height: nominal platform height H [m].
        antenna_length: azimuth antenna length L [m].
        reference_range: scene-centre slant range r₀ [m] (motion-compensation reference).
        near_range: default slant range of the first range sample [m].
        squint: squint angle φ_d [rad] (0 = broadside).
        pattern: two-way azimuth pattern W²(u) (default sinc²).
        num_pulses: default number of pulses (static: decides shapes).
        num_range: default number of range samples (static).
    """

    carrier_frequency: jnp.ndarray = _leaf()
    bandwidth: jnp.ndarray = _leaf()
    chirp_duration: jnp.ndarray = _leaf()
    sampling_rate: jnp.ndarray = _leaf()
    prf: jnp.ndarray = _leaf()
    velocity: jnp.ndarray = _leaf()
    height: jnp.ndarray = _leaf()
    antenna_length: jnp.ndarray = _leaf()
    reference_range: jnp.ndarray = _leaf()
    near_range: jnp.ndarray = _leaf()
    squint: jnp.ndarray = _leaf()
    pattern: AbstractPattern = Sinc2Pattern()
    num_pulses: int = eqx.field(static=True, default=1024)
    num_range: int = eqx.field(static=True, default=1024)

    def __check_init__(self):
        for name in ("num_pulses", "num_range"):
            n = getattr(self, name)
            if not isinstance(n, int) or isinstance(n, bool) or n < 1:
                raise ValueError(f"Radar.{name}={n!r} must be a positive integer")

    # ---- derived quantities (physics.md §1) -------------------------------------------
    @property
    def wavelength(self):
        """λ = c / f [m]."""
        return SPEED_OF_LIGHT / self.carrier_frequency

    @property
    def wavenumber(self):
        """Two-way carrier wavenumber k₀ = 4π/λ [rad/m]."""
        return 4 * jnp.pi / self.wavelength

    @property
    def chirp_rate(self):
        """Chirp rate in range coordinates b = (4π/λ)(Δf/f)/(cτ) = 4πΔf/(c²τ) [rad/m²]
        (seed 000 eq. 26)."""
        return 4 * jnp.pi * self.bandwidth / (SPEED_OF_LIGHT**2 * self.chirp_duration)

    @property
    def pulse_half_length(self):
        """Half the pulse extent in range coordinates, cτ/4 [m] (rect support)."""
        return SPEED_OF_LIGHT * self.chirp_duration / 4

    @property
    def range_spacing(self):
        """Range sample spacing c/(2 f_s) [m]."""
        return SPEED_OF_LIGHT / (2 * self.sampling_rate)

    @property
    def azimuth_spacing(self):
        """Pulse spacing along track v / PRF [m]."""
        return self.velocity / self.prf

    @property
    def range_resolution(self):
        """Unweighted range IRW 0.886 c/(2Δf) [m]."""
        return 0.886 * SPEED_OF_LIGHT / (2 * self.bandwidth)

    @property
    def chirp_samples(self):
        """Number of range samples spanned by one chirp, f_s τ (float)."""
        return self.sampling_rate * self.chirp_duration

    def footprint(self, slant_range):
        """Azimuth footprint X = λ r / L [m] at closest-approach range ``r`` [m]."""
        return self.wavelength * slant_range / self.antenna_length

    def integration_time(self, slant_range=None):
        """Integration time T_s = X / v [s] (at ``reference_range`` by default)."""
        r = self.reference_range if slant_range is None else slant_range
        return self.footprint(r) / self.velocity

    def replace(self, **changes) -> Radar:
        """Return a copy with some fields changed (values are converted to arrays)."""
        import dataclasses

        return dataclasses.replace(self, **changes)


# ---- radar <-> attributes -------------------------------------------------------------

_RADAR_SCALARS = ("carrier_frequency", "bandwidth", "chirp_duration", "sampling_rate", "prf",
                  "velocity", "height", "antenna_length", "reference_range", "near_range",
                  "squint")


def radar_attributes(radar: Radar) -> dict:
    """Every field of ``radar`` as plain numbers / strings (SI units)."""
    out = {name: float(np.asarray(getattr(radar, name))) for name in _RADAR_SCALARS}
    out["num_pulses"] = int(radar.num_pulses)
    out["num_range"] = int(radar.num_range)
    pattern = radar.pattern
    out["pattern"] = type(pattern).__name__
    if isinstance(pattern, GaussianPattern):
        out["pattern_width"] = float(np.asarray(pattern.width))
    elif not isinstance(pattern, Sinc2Pattern):
        raise ValueError(f"pattern {type(pattern).__name__} cannot be written to a file: "
                         "only Sinc2Pattern and GaussianPattern are known")
    return out


def radar_from_attributes(attrs: dict, prefix: str = "") -> Radar:
    """Inverse of :func:`radar_attributes` (keys optionally prefixed)."""
    get = lambda k: attrs[prefix + k]

    def number(name, kind):
        try:
            value = get(name)
        except KeyError:
            raise ValueError(f"radar parameter {name!r} missing from the file") from None
        try:
            return kind(value)
        except (TypeError, ValueError):
            raise ValueError(f"radar parameter {name}={value!r} in the file is not a "
                             f"{kind.__name__}") from None

    kwargs = {name: number(name, float) for name in _RADAR_SCALARS}
    kwargs["num_pulses"] = number("num_pulses", int)
    kwargs["num_range"] = number("num_range", int)
    try:
        pattern = str(get("pattern"))
    except KeyError:
        raise ValueError("radar parameter 'pattern' missing from the file") from None
    if pattern == "GaussianPattern":
        kwargs["pattern"] = GaussianPattern(width=number("pattern_width", float))
    elif pattern != "Sinc2Pattern":
        raise ValueError(f"unknown antenna pattern {pattern!r} in the file")
    return Radar(**kwargs)
