"""Raw data by inverting a chirp-scaling processor (seed 003, its Appendix A listing;
physics.md §9).

Range-Doppler model (stop-and-go, straight track, broadside), derived in this project's
range coordinates (``r' = c t/2``, chirp ``e^{−j b o²}``, ``k₀ = 4π/λ``): with
``D(ξ) = √(1 − ξ²/k₀²)`` and ``C = 1/D − 1`` (the listing's ``D``, ``C``), the azimuth
spectrum of a target at (x, r) is, by stationary phase in both dimensions,

    S(ξ, r') ≈ A W²(u*) e^{−jξx} e^{−j k₀ D r} e^{−j b_m (r' − r (1 + C))²},
    1/b_m = 1/b + 2 r_ref ξ² / (k₀³ D³)

(``b_m`` the range chirp rate in the range-Doppler domain, the listing's ``k``, taken at
``r_ref``: secondary range compression). The chirp-scaling processor multiplies by
``Φ₁ = e^{−j b_m C (r' − r_ref (1 + C))²}``, which moves every chirp to ``r + C r_ref``
(the reference migration) with rate ``b_m (1 + C)`` and leaves
``e^{−j b_m C (1 + C)(r − r_ref)²}``; range compression and bulk migration ``Φ₃``;
azimuth compression and that residual ``Φ₂ = H₁ H₂``. The simulator runs it backwards
(seed 003 Fig. 3, the listing's order):

1. azimuth FFT of the reflectivity γ(x, r) (range lines on the raw range grid);
2. × ``Φ₂⁻¹ = e^{−j k₀ D r} e^{−j b_m C (1 + C)(r − r_ref)²}``, × the azimuth pattern
   ``W²(u*)`` and the stationary-phase amplitude ``A(ξ, r)`` (√r per line);
3. range FFT, × ``Φ₃⁻¹ = e^{−jη C r_ref} e^{jη²/(4 b_m (1 + C))}`` and the chirp's band
   (the spectrum of the sampled chirp's magnitude and edges, ``C(η) e^{−jη²/(4b)}``),
   summed over the range aliases ``η + 2πm/Δr`` (``range_aliases``: the sampled model);
4. range IFFT; × ``Φ₁⁻¹ = e^{+j b_m C (r' − r_ref (1 + C))²}``;
5. azimuth IFFT.

**Azimuth ambiguities.** The exact model samples the echo at the pulses, so its Doppler
spectrum beyond ±PRF/2 folds back. Steps 1–4 are per azimuth wavenumber: they are run
again at ``ξ + 2πk/Δx`` for ``k = ±1 … ±bands`` (the same DFT bins, which the pulses see
alike) and the range-Doppler data summed before step 5; ``bands`` holds all but
``azimuth_tolerance`` of the echo energy (``_extent.azimuth_support``).

Cost: four FFT passes and three phase multiplies per sample and band — the fastest method;
its approximations (the range-Doppler chirp rate at ``r_ref`` only, the quadratic
expansion of the 2-D phase in η) grow with the swath and the bandwidth. The listing's
``dt = 1/(2 f_s)`` range sampling is not reproduced (``f_s`` is used). Broadside only.
"""

from __future__ import annotations

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .._numerics.interpolation import next_fast_len
from .._numerics.phasor import broadcast_phasor, wrap_phase
from ..scene import ReflectivityGrid
from . import _extent as extent
from . import _fourier_engine as engine
from ._base import AbstractPlan, Cost
from ._tracks import AbstractStraightTrackSimulator

_TWO_PI = 2 * jnp.pi


def range_doppler_terms(radar, xi, reference_range):
    """(D, C, b_m) of the range-Doppler model at azimuth wavenumbers ξ [rad/m]."""
    k0 = radar.wavenumber
    d = jnp.sqrt(1 - (xi / k0) ** 2)
    curvature = 1 / d - 1
    b_m = 1 / (1 / radar.chirp_rate + 2 * reference_range * xi**2 / (k0**3 * d**3))
    return d, curvature, b_m


class ChirpScalingPlan(AbstractPlan):
    """Static sizes: the azimuth padding (pulses on each side), the range FFT length and
    the Doppler alias bands on each side."""

    azimuth_pad: int = eqx.field(static=True)
    range_fft_size: int = eqx.field(static=True)
    included: jnp.ndarray
    bands: int = eqx.field(static=True, default=0)


class ChirpScaling(AbstractStraightTrackSimulator):
    """Inverse chirp-scaling simulator (seed 003), see the module docstring.

    Attributes:
        azimuth_padding: None (default): the azimuth grid holds every scatterer's echo
            support that reaches the window, within the synthesised Doppler bands
            (``_extent.work_grid``); a number: that many footprints X on each side
            (0: the seed's circular setup; ``azimuth_window`` says what wraps).
        reference_range: r_ref [m]; None = the middle of the range window (the listing's
            ``r_ref``).
        azimuth_aliases, azimuth_tolerance, max_azimuth_aliases: the Doppler alias bands
            (``AbstractStraightTrackSimulator``).
        range_aliases: range-spectrum aliases ±m summed before the range IFFT (the
            hard-edged chirp's spectrum extends past ±f_s/2; 0: the seed's model, −24 dB
            raw NMSE against the exact model for a 5 µs, 45 MHz chirp at f_s = 50 MHz;
            1: −44 dB).
    """

    names: ClassVar[tuple[str, ...]] = ("chirp_scaling",)
    physics: ClassVar[str] = "physics.md §9 (seed 003, Appendix A)"
    # the range-Doppler approximations (chirp rate at r_ref, quadratic phase in η) have
    # no measured budget yet: ``method="auto"`` does not choose it (the base says so)
    grid_rules: ClassVar[dict] = dict(doppler_limited=True, migration=True)

    azimuth_padding: float | None = eqx.field(static=True, default=None)
    reference_range: float | None = eqx.field(static=True, default=None)
    range_aliases: int = eqx.field(static=True, default=1)

    def prepare(self, radar, scene, acquisition, motion=None) -> ChirpScalingPlan:
        """Check a grid scene; fix the padding and FFT sizes from concrete values."""
        if isinstance(scene, ReflectivityGrid):
            engine.check_grid_scene(scene, radar)
            rg = np.asarray(scene.range)
            dr = float(radar.range_spacing)
            if rg.size > 1 and not np.allclose(np.diff(rg), dr, rtol=1e-9):
                raise ValueError(
                    f"ReflectivityGrid range spacing {np.diff(rg).mean():.6g} m differs "
                    f"from the range sample spacing c/(2 f_s) = {dr:.6g} m "
                    "(method='chirp_scaling')")
        # an echo's extent along track: its support, or (a fixed padding) the footprint
        # or where its Doppler leaves the PRF band; in range the migration at the band edge
        support, grid = self.grid(radar, scene, motion, acquisition)
        return ChirpScalingPlan(grid.lead, grid.n_r, jnp.asarray(grid.included, dtype=float),
                                support.bands)

    def memory(self, plan, radar, scene, acquisition, dtype) -> int:
        n_x = next_fast_len(acquisition.num_pulses + 2 * plan.azimuth_pad)
        # one (n_x, n_r) spectrum more per range alias, alive together before their sum
        grids = 2.4 + 1.0 * 2 * self.range_aliases
        return int(16 * (grids * n_x * plan.range_fft_size + 0.1 * acquisition.num_pulses
                         * plan.range_fft_size))

    def cost(self, plan, radar, scene, acquisition, dtype) -> Cost:
        """Four FFT passes and three phase multiplies per sample (≈ 5 FFT2-equivalents),
        three of them per Doppler band."""
        n_x = next_fast_len(acquisition.num_pulses + 2 * plan.azimuth_pad)
        per_band = 3 * 8e-9 * n_x * plan.range_fft_size
        return Cost(compile=2.0, steady=2 * 8e-9 * n_x * plan.range_fft_size
                    + (2 * plan.bands + 1) * per_band)

    def simulate(self, plan, radar, scene, motion, acquisition, dtype):
        if not motion.is_ideal:
            raise ValueError("method='chirp_scaling' simulates a straight track: motion errors "
                             "are not implemented (use method='moderate_deviation')")
        scene = extent.within_support(scene, plan.included)
        n_pulses, n_range = acquisition.num_pulses, acquisition.num_range
        pad, n_r = plan.azimuth_pad, plan.range_fft_size
        n_x = next_fast_len(n_pulses + 2 * pad)
        dx, dr = radar.azimuth_spacing, radar.range_spacing
        near = acquisition.near_range
        x0 = acquisition.pulse_azimuths(radar)[0] - pad * dx
        r_ref = near + (n_range // 2) * dr if self.reference_range is None else self.reference_range
        principal = _TWO_PI * jnp.fft.fftfreq(n_x, 1.0) / dx
        eta = _TWO_PI * jnp.fft.fftfreq(n_r, 1.0) / dr
        etas = [eta + m * (_TWO_PI / dr)
                for m in range(-self.range_aliases, self.range_aliases + 1)]
        if isinstance(scene, ReflectivityGrid):  # the azimuth DFT, shared by every band
            grid_spectrum = jnp.fft.fft(scene.reflectivity, n=n_x, axis=0)
        # with alias bands, the lowest bin (its partner at the top is not synthesised) is
        # left out: the covered band stays symmetric, its pattern weight is negligible
        lower = -(2 * plan.bands + 1) * jnp.pi / dx + jnp.pi / (n_x * dx)

        def band(k):
            """Steps 1–4 (range-Doppler data (n_x, n_range)) at ξ + 2πk/Δx."""
            xi = principal + k * (_TWO_PI / dx)
            keep = (xi > lower) if plan.bands else jnp.ones(n_x, bool)
            xi = jnp.where(keep, xi, 0.0)  # left-out bins: finite, then zeroed
            d, curv, b_m = range_doppler_terms(radar, xi, r_ref)
            # steps 1–3 in one: Σ_lines γ(ξ, r) Φ₂⁻¹ √r e^{−jη (r − r'_0)} (a DFT over lines),
            # at every range alias η + 2πm/Δr (the sampled chirp's spectrum passes ±f_s/2)
            if isinstance(scene, ReflectivityGrid):
                first = (scene.azimuth[0] - x0) / dx
                spec = grid_spectrum * broadcast_phasor(-xi * first * dx)[:, None]
                lines = spec * _azimuth_terms(radar, xi, d, curv, b_m, scene.range, r_ref)
                # lines on the raw range grid from r_first: a range FFT (circular, padded),
                # the same for every alias; the sub-sample shift per alias
                line_spectrum = jnp.fft.fft(lines, n=n_r, axis=1)
                shift = scene.range[0] - near
                spectra = [line_spectrum * broadcast_phasor(-eta_m * shift)[None, :]
                           for eta_m in etas]
            else:
                phase_x = xi[:, None] * (scene.azimuth - x0)[None, :]
                lines = (scene.reflectivity[None, :] * jnp.exp(-1j * phase_x)
                         * _azimuth_terms(radar, xi, d, curv, b_m, scene.range, r_ref))
                spectra = [lines @ jnp.exp(-1j * eta_m[None, :] * (scene.range - near)[:, None])
                           for eta_m in etas]
            # Φ₃⁻¹ and the chirp's band, per alias
            b = radar.chirp_rate
            sampled = 0.0
            for eta_m, spectrum in zip(etas, spectra, strict=True):
                # e^{−jη²/4b}/Δr formed once per η, not per (ξ, η): broadcast_phasor
                chirp = engine.chirp_spectrum(radar, eta_m) * broadcast_phasor(
                    -eta_m**2 / (4 * b)) / dr
                phi3 = jnp.exp(-1j * eta_m[None, :] * (curv * r_ref)[:, None]
                               + 1j * eta_m[None, :] ** 2 / (4 * (b_m * (1 + curv))[:, None]))
                sampled = sampled + spectrum * phi3 * chirp[None, :]
            rd = jnp.fft.ifft(sampled, axis=1)  # range-Doppler, r'
            # Φ₁⁻¹ at r'_n = near + n Δr
            offsets = near + jnp.arange(n_r)[None, :] * dr - (r_ref * (1 + curv))[:, None]
            rd = rd * jnp.exp(1j * (b_m * curv)[:, None] * offsets**2)
            return rd[:, :n_range] * keep[:, None]

        total = engine.add_alias_bands(band(0.0), band, plan.bands)
        raw = jnp.fft.ifft(total, axis=0)[pad:pad + n_pulses]  # step 5
        return raw.astype(dtype)


def _azimuth_terms(radar, xi, d, curv, b_m, ranges, r_ref):
    """(n_x, n_lines) Φ₂⁻¹ W²(u*) A(ξ, r): azimuth phase, residual scaling phase,
    pattern and stationary-phase amplitude."""
    k0 = radar.wavenumber
    carrier = broadcast_phasor(-wrap_phase(k0 * ranges))[None, :]
    azimuth = jnp.exp(-1j * k0 * (d - 1)[:, None] * ranges[None, :])
    residual = jnp.exp(-1j * (b_m * curv * (1 + curv))[:, None]
                       * (ranges - r_ref)[None, :] ** 2)
    u_star = engine.stationary_pattern_argument(radar, xi)
    amplitude = engine.stationary_amplitude(radar, xi[:, None], ranges[None, :])
    return carrier * azimuth * residual * radar.pattern(u_star)[:, None] * amplitude
