"""Fourier-domain simulators for a squinted beam, Acquisition-Doppler geometry (seed 002 §2,
§3.2; physics.md §8).

The beam looks ahead by the squint φ_d: a scatterer at closest approach ``(x, r)`` is
illuminated about the pulse ``x_c = x − r tan φ_d`` (its Acquisition-Doppler azimuth, seed
002 eq. 1, range along the beam ``r / cos φ_d``), and its azimuth spectrum is centred on
the Doppler centroid ``ξ_d = k₀ sin φ_d`` — at the airborne set's PRF, 1 PRF band (4°) to
4 bands (15°) away from ξ = 0. The engine of :mod:`._fourier` (range lines ``F_j(ξ)``,
inverse-Stolt range synthesis, column-blocked assembly) is used with:

* **True wavenumbers.** Each sampled ξ is replaced by its alias ``ξ + 2πm/Δx`` nearest ξ_d;
  every ξ-function (scene phase ``e^{−jξ(x − x0)}``, stationary amplitude, STF, pattern)
  is evaluated there. The samples ``x0 + nΔx`` see every alias alike, so the inverse FFT
  returns the pulses directly. In these coordinates the STF of seed 002 eq. 49,
  ``exp[−j(√(η̄² − ξ²) cos φ_d − η̄) r_AD − jξ r_AD sin φ_d]`` with
  ``r = r_AD cos φ_d``, ``x = x_AD + r_AD sin φ_d``, is the broadside one,
  ``exp[−j(√(η̄² − ξ²) − η̄) r − jξ(x − x_AD)]``: the scene stays in closest-approach
  coordinates, as in the exact model.
* **Squinted pattern at the stationary point.** The exact model's pattern argument
  ``u = (a + r T − (r + δr_xr) δ_az) / (X (1 − aT/r))`` (``a = x' − x``, ``T = tan φ_d``) at
  ``a/r = −t``, ``t = ξ/√(η̄² − ξ²)``, is ``u* = (L/λ)(T − t)/(1 + tT)``; with the pointing
  error, ``∂u/∂δ_az = −(L/λ)(1 + δr_xr/r)/(1 + tT)``, so the n-th pointing term carries
  ``(−(L/λ)/(1 + tT))ⁿ W²⁽ⁿ⁾(u*)/n!`` (seed 002 eq. 34). ``u*`` depends on η̄ through
  ``t`` — at 15° by ≈ 0.02 across the range band, a ≈ 7 % slope of the beam's flank —
  so the pattern is applied as ``W²(u₀) + W²′(u₀) (∂u*/∂η) η`` (u₀ at η = 0; the next
  term is < 10⁻³).
* **Deviation along the squinted line of sight** (seed 002 eq. 4, 8). With
  ``R = √((r + δr_xr)² + a²)``, a deviation moves the range by ``δr_xr r/R``: by
  ``δr_xr cos φ_d`` at the beam centre, and in the 2-D spectrum the phase is
  ``−δr_xr √(η̄² − ξ²) ≈ −δr_xr (k₀ cos φ_d + η / cos φ_d)`` near ξ_d. The per-pulse factor
  of the scene-centre deviation δr(x') is therefore
  ``exp[−j(k₀ cos φ_d + η / cos φ_d) δr(x')]`` (exact at ξ_d for a constant deviation),
  and the range-variant part ψ enters as ``exp[−j k₀ cos φ_d ψ]``.

  - **Small deviation** (seed 002 §2, Fig. 3): ψ is moved onto the scene at the
    beam-centre pulse, ``γ̃ = γ exp[−j k₀ cos φ_d ψ(x_c, r)]``. Neglected: the coupling
    ``ϕ = R − R_n − δr_xr cos φ_d`` — at squint it is first order in the beam angle,
    ``≈ −δr_xr sin φ_d (φ − φ_d)`` — the envelope of ψ and its variation over the aperture
    (see :func:`sarjax.validity`).
  - **Moderate deviation** (seed 002 §3.2, Fig. 14–15): per range line, ``G_A`` in ξ, the
    motion phase ``exp[−j k₀ cos φ_d ψ(x', r_j)]`` in x', and the coupling
    ``exp[−j(√(k₀² − ξ²) − k₀ cos φ_d) δr_xr(x', r_j)]`` (zero at ξ_d; a Taylor series in
    the deviation about its mean, as at broadside); the envelope of ψ (slope
    ``1/cos φ(ξ) = k₀/√(k₀² − ξ²)``) and the migration error of its Doppler shift
    (``R(ξ) = r k₀/√(k₀² − ξ²)`` moved by ``R′(ξ) k₀ cos φ_d ∂ψ/∂x'``) to first order.

With φ_d = 0 every squint term above reduces to the broadside engine's; the simulators
below run the broadside engine itself (same program, same bits) when the squint is zero.
"""

from __future__ import annotations

import dataclasses
import math
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import geometry
from .._numerics.interpolation import next_fast_len
from .._numerics.phasor import unit_phasor
from . import _fourier
from ._fourier import (
    _coupled_inverse,
    _grid_azimuth_fft,
    _interp_motion,
    _kappa_b,
    _kappa_full,
    chirp_spectrum,
    columns_to_pulses,
    grid_dtft,
    pattern_term,
    prepare_scene,
    range_alias_sets,
    range_wavenumbers,
    stationary_amplitude,
    synthesize_direct,
    synthesize_grid,
)

_TWO_PI = 2 * jnp.pi


def _concrete(value):
    if isinstance(value, jax.core.Tracer):  # not known eagerly
        return None
    return float(np.asarray(value))


def squinted_wavenumbers(radar, n_x):
    """(n_x,) the alias ``ξ + 2πm/Δx`` of each sampled azimuth wavenumber nearest the
    Doppler centroid ``ξ_d = k₀ sin φ_d`` [rad/m] (DFT order kept)."""
    dx = radar.azimuth_spacing
    period = _TWO_PI / dx
    xi = period * jnp.fft.fftfreq(n_x, 1.0)
    xi_d = radar.wavenumber * jnp.sin(radar.squint)
    return xi + period * jnp.round((xi_d - xi) / period)


def squinted_pattern_argument(radar, xi):
    """``(u₀, ∂u*/∂η)`` at the stationary point (module docstring): u₀ (dimensionless) and
    its slope in the range wavenumber [m/rad], each (n_x,)."""
    k0 = radar.wavenumber
    kz = jnp.sqrt(k0**2 - xi**2)
    t = xi / kz
    T = jnp.tan(radar.squint)
    ratio = radar.antenna_length / radar.wavelength
    u0 = ratio * (T - t) / (1 + t * T)
    # ∂u/∂t · ∂t/∂η̄ at η̄ = k₀: −(1 + T²)/(1 + tT)² · (−ξ k₀ / kz³)
    slope = ratio * (1 + T**2) / (1 + t * T) ** 2 * xi * k0 / kz**3
    return u0, slope


def pattern_weights(radar, xi, order):
    """``(w_n, w_n′)`` (n_x,): the n-th pointing term of the pattern at η = 0 and its slope
    in η, ``(−(L/λ)/(1 + tT))ⁿ W²⁽ⁿ⁾(u₀)/n!`` and ``… W²⁽ⁿ⁺¹⁾(u₀)/n! · ∂u*/∂η``."""
    k0 = radar.wavenumber
    t = xi / jnp.sqrt(k0**2 - xi**2)
    u0, slope = squinted_pattern_argument(radar, xi)
    scale = (-(radar.antenna_length / radar.wavelength) / (1 + t * jnp.tan(radar.squint))) ** order
    base = scale * pattern_term(radar.pattern, order)(u0)
    steep = scale * (order + 1) * pattern_term(radar.pattern, order + 1)(u0) * slope
    return base, steep


def _line_height_under_beam(prepared, x_full, ranges, tan_squint):
    """(n_lines, n_x) grid height at the scatterer the beam centre of pulse x' crosses on
    each line, ``x = x' + r_j tan φ_d`` (nearest grid row; 0 outside the grid)."""
    az = prepared.azimuth
    step = jnp.where(az.shape[0] > 1, az[-1] - az[0], 1.0) / jnp.maximum(az.shape[0] - 1, 1)
    x_beam = x_full[None, :] + ranges[:, None] * tan_squint
    idx = jnp.round((x_beam - az[0]) / step).astype(jnp.int32)
    inside = (idx >= 0) & (idx < az.shape[0])
    heights = prepared.height.T  # (n_lines, n_az)
    rows = jnp.take_along_axis(heights, jnp.clip(idx, 0, az.shape[0] - 1), axis=1)
    return jnp.where(inside, rows, 0.0)


def run_squinted(sim, radar, scene, motion, acquisition, dtype, mode):
    """The squinted engine (module docstring); ``sim`` supplies the options of
    :class:`._fourier._FourierBase`, ``mode`` is ``"ideal"``, ``"small"`` or
    ``"moderate"``. Returns (num_pulses, num_range) raw data."""
    n_pulses, n_range = acquisition.num_pulses, acquisition.num_range
    prepared = prepare_scene(scene)
    pad, n_r, n_x, block = sim.work_sizes(acquisition)

    dx = radar.azimuth_spacing
    k0 = radar.wavenumber
    cos_d = jnp.cos(radar.squint)
    tan_d = jnp.tan(radar.squint)
    x_pulses = acquisition.pulse_azimuths(radar)
    x0 = x_pulses[0] - pad * dx
    xi = squinted_wavenumbers(radar, n_x)
    kz = jnp.sqrt(k0**2 - xi**2)  # √(k₀² − ξ²)
    eta = range_wavenumbers(radar, n_r)
    horizontal, vertical, pointing = motion.resolve(n_pulses)
    ranges = prepared.ranges

    delta_kept = geometry.reference_deviation(horizontal, vertical, radar)  # δr(x')
    orders = range(sim.pointing_order + 1) if mode != "ideal" else range(1)
    if mode != "ideal" and motion.pointing is None:
        orders = range(1)
    weights = [pattern_weights(radar, xi, n) for n in orders]

    kappa_fn = _kappa_b if mode == "moderate" else _kappa_full
    alias_sets = range_alias_sets(eta, radar.range_spacing, sim.range_aliases,
                                  sim.alias_columns)  # as at broadside

    # ---- scene → range lines F_j(ξ) ----------------------------------------------------
    if prepared.gridded:
        gamma = prepared.reflectivity.T  # (n_lines, n_az)
        xs = prepared.azimuth[None, :]
        hs = prepared.height.T
    else:
        gamma = prepared.reflectivity[:, None]
        xs = prepared.azimuth[:, None]
        hs = prepared.height[:, None]
    rs = ranges[:, None]
    if mode == "small":
        # γ̃ = γ exp[−j k₀ cos φ_d ψ(x_c, r)], ψ at the beam-centre pulse x_c = x − r tan φ_d
        x_beam = xs - rs * tan_d
        dy_s = _interp_motion(horizontal, x_beam, x_pulses[0], dx)
        dz_s = _interp_motion(vertical, x_beam, x_pulses[0], dx)
        psi_s = geometry.range_variant_deviation(dy_s, dz_s, rs, hs, radar)
        gamma = gamma * unit_phasor(-k0 * cos_d * psi_s)
    line_factor = jnp.sqrt(ranges) * unit_phasor(-jnp.mod(k0 * ranges, _TWO_PI))
    gamma = gamma * line_factor[:, None]
    column_weight = stationary_amplitude(radar, xi, 1.0)
    if prepared.gridded:
        spectrum = _grid_azimuth_fft(gamma, n_x)
        column_weight = column_weight * unit_phasor(-xi * (prepared.azimuth[0] - x0))
    else:
        spectrum = gamma * unit_phasor(-xi[None, :] * (prepared.azimuth[:, None] - x0))

    def moderate_lines(lines, envelope):
        """Along-track part of the squinted Algorithm B: G_A, the coupling and the motion
        phase in x', back to ξ; with ``envelope`` the first-order envelope lines
        ``s(ξ) ψ + R′(ξ) k₀ cos φ_d ∂ψ/∂x'`` instead. (n_lines, n_x)."""
        lines = lines * unit_phasor(-(kz - k0)[None, :] * ranges[:, None])
        dy_full = jnp.pad(horizontal, (pad, n_x - n_pulses - pad), mode="edge")
        dz_full = jnp.pad(vertical, (pad, n_x - n_pulses - pad), mode="edge")
        x_full = x0 + jnp.arange(n_x) * dx
        if prepared.gridded:
            h_line = _line_height_under_beam(prepared, x_full, ranges, tan_d)
        else:
            h_line = prepared.height[:, None]
        los = geometry.line_of_sight_deviation(
            dy_full[None, :], dz_full[None, :], ranges[:, None], h_line, radar.height
        )  # δr_xr(x', r_j)
        psi = los - geometry.reference_deviation(dy_full, dz_full, radar)[None, :]
        if sim.coupling_order:
            along = _coupled_inverse(lines, los, kz - k0 * cos_d, sim.coupling_order)
        else:
            along = jnp.fft.ifft(lines, axis=1)
        along = along * unit_phasor(-k0 * cos_d * psi)
        if not envelope:
            return jnp.fft.fft(along, axis=1)
        slope = jnp.gradient(psi, axis=1) / dx
        spread = (k0 / kz)[None, :] * jnp.fft.fft(along * psi, axis=1)
        migration = (k0 * cos_d) * ranges[:, None] * (k0 * xi / kz**3)[None, :]
        return spread + migration * jnp.fft.fft(along * slope, axis=1)

    # line sets: per pointing order (moderate: the pattern precedes the motion phase), and
    # the set multiplied by η in the synthesis: −j × envelope + the pattern's η-slope
    eta_set = None
    if mode == "moderate":
        line_sets = [moderate_lines(spectrum * (column_weight * w)[None, :], False)
                     for w, _ in weights]
        eta_set = moderate_lines(spectrum * (column_weight * weights[0][1])[None, :], False)
        if sim.envelope_correction:
            envelope = moderate_lines(spectrum * (column_weight * weights[0][0])[None, :], True)
            eta_set = eta_set - 1j * envelope
    else:
        line_sets = [spectrum]

    gridded = prepared.gridded and ranges.shape[0] > 1
    dtfts = [grid_dtft(lines) for lines in line_sets] if gridded else line_sets
    if eta_set is not None and gridded:
        eta_set = grid_dtft(eta_set)

    near = acquisition.near_range
    pointing_scale = (1 + delta_kept / radar.reference_range) * pointing
    scale_powers = {n: pointing_scale**n for n in orders if n}
    # per-pulse exp[−j(k₀ cos φ_d + η/cos φ_d) δr] = exp[−j(η + k₀ cos² φ_d)(δr / cos φ_d)]
    per_pulse = None if mode == "ideal" else delta_kept / cos_d
    total = jnp.zeros((n_r, n_pulses), jnp.complex128)
    for m, cols, eta_m in alias_sets:
        taps = sim.taps if m == 0 else min(sim.taps, 6)
        n_terms = len(weights) if m == 0 else 1

        def produce(eta_block, taps=taps, n_terms=n_terms):
            kappa = kappa_fn(radar, xi[None, :], eta_block[:, None])  # (size, n_x)

            def synth(table):
                if gridded:
                    return synthesize_grid(table, ranges, kappa, taps=taps)
                return synthesize_direct(table, ranges, kappa)

            factor = chirp_spectrum(radar, eta_block) * unit_phasor(eta_block * near)
            phase = None
            out = []
            for q in range(n_terms):
                if mode == "moderate":
                    rel, r_ref = synth(dtfts[q])
                    if q == 0 and eta_set is not None:
                        rel = rel + eta_block[:, None] * synth(eta_set)[0]
                else:
                    if q == 0:
                        summed, r_ref = synth(dtfts[0])
                    base, steep = weights[q]
                    rel = summed * ((column_weight * base)[None, :]
                                    + (column_weight * steep)[None, :] * eta_block[:, None])
                out.append(rel)
                if phase is None:
                    phase = unit_phasor(-kappa * r_ref) * (factor / radar.range_spacing)[:, None]
            return [rel * phase for rel in out]

        terms = [(q, None, orders[q]) for q in range(n_terms)]
        per_alias = columns_to_pulses(
            produce, terms, eta_m, per_pulse, scale_powers, k0 * cos_d**2,
            pad=pad, num_pulses=n_pulses, block=block, loops=sim.column_loops,
        )
        total = total + per_alias if cols is None else total.at[cols, :].add(per_alias)
    raw = jnp.fft.ifft(total.T, axis=1)[:, :n_range]
    return raw.astype(dtype)


def squinted_sizes(sim, radar, scene, acquisition):
    """Static sizes for a squinted acquisition: azimuth padding over the squinted footprint
    ``λ r / (L cos² φ_d)`` and room in the range FFT for the range walk of an echo over
    the padded azimuth window (``span · |sin φ_d|``), beyond which it would wrap."""
    squint = float(np.asarray(radar.squint))
    footprint = float(radar.footprint(np.max(np.asarray(scene.range)))) / math.cos(squint) ** 2
    dx = float(radar.azimuth_spacing)
    pad = int(math.ceil(sim.azimuth_padding * footprint / dx))
    pad = -(-pad // 128) * 128
    span = (acquisition.num_pulses + 2 * pad) * dx
    walk = span * abs(math.sin(squint))
    chirp = int(float(radar.chirp_samples)) + 2
    n_r = next_fast_len(acquisition.num_range + chirp + int(walk / float(radar.range_spacing)))
    return pad, n_r


def _prepare(sim, parent, radar, scene, acquisition):
    squint = _concrete(radar.squint)
    if squint == 0.0:
        return dataclasses.replace(parent.prepare(sim, radar, scene, acquisition),
                                   squinted=False)
    if squint is not None and sim.azimuth_pad is None and sim.range_fft_size is None:
        pad, n_r = squinted_sizes(sim, radar, scene, acquisition)
        sim = dataclasses.replace(sim, azimuth_pad=pad, range_fft_size=n_r)
    return dataclasses.replace(parent.prepare(sim, radar, scene, acquisition), squinted=True)


def _squinted(sim, radar):
    if sim.squinted is not None:
        return sim.squinted
    return _concrete(radar.squint) != 0.0


class SquintFourier2D(_fourier.Fourier2D):
    """Ideal straight-track 2-D Fourier simulation at any squint (seed 002 eq. 49 without
    motion; module docstring). Broadside: :class:`._fourier.Fourier2D` unchanged.

    Attributes:
        squinted: whether the squinted engine runs (set by ``prepare()``; None decides
            from the concrete squint at call time).
    """

    supports_squint: ClassVar[bool] = True
    squinted: bool | None = eqx.field(static=True, default=None)

    def prepare(self, radar, scene, acquisition):
        """Static sizes (squinted footprint and range walk) and the engine to run."""
        return _prepare(self, _fourier.Fourier2D, radar, scene, acquisition)

    def __call__(self, radar, scene, motion, acquisition, dtype):
        if not _squinted(self, radar):
            return super().__call__(radar, scene, motion, acquisition, dtype)
        return run_squinted(self, radar, scene, motion, acquisition, dtype, "ideal")


class SquintSmallDeviation(_fourier.SmallDeviation):
    """Small trajectory deviations and pointing errors at any squint ("Algorithm A" in
    Acquisition-Doppler geometry, seed 002 §2 and §3.2; module docstring). Broadside:
    :class:`._fourier.SmallDeviation` unchanged.

    Attributes:
        squinted: as :class:`SquintFourier2D`.
    """

    supports_squint: ClassVar[bool] = True
    squinted: bool | None = eqx.field(static=True, default=None)

    def prepare(self, radar, scene, acquisition):
        """Static sizes (squinted footprint and range walk) and the engine to run."""
        return _prepare(self, _fourier.SmallDeviation, radar, scene, acquisition)

    def __call__(self, radar, scene, motion, acquisition, dtype):
        if not _squinted(self, radar):
            return super().__call__(radar, scene, motion, acquisition, dtype)
        return run_squinted(self, radar, scene, motion, acquisition, dtype, "small")


class SquintModerateDeviation(_fourier.ModerateDeviation):
    """Moderate trajectory deviations and pointing errors at any squint ("Algorithm B" in
    Acquisition-Doppler geometry, seed 002 §3.2, Fig. 14–15; module docstring). Broadside:
    :class:`._fourier.ModerateDeviation` unchanged.

    Attributes:
        squinted: as :class:`SquintFourier2D`.
    """

    supports_squint: ClassVar[bool] = True
    squinted: bool | None = eqx.field(static=True, default=None)

    def prepare(self, radar, scene, acquisition):
        """Static sizes (squinted footprint and range walk) and the engine to run."""
        return _prepare(self, _fourier.ModerateDeviation, radar, scene, acquisition)

    def __call__(self, radar, scene, motion, acquisition, dtype):
        if not _squinted(self, radar):
            return super().__call__(radar, scene, motion, acquisition, dtype)
        return run_squinted(self, radar, scene, motion, acquisition, dtype, "moderate")
