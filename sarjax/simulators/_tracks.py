"""Track models of the Fourier-domain engine: what differs between the ideal 2-D,
small-deviation ("Algorithm A") and moderate-deviation ("Algorithm B") simulators, at any
squint (φ_d = 0 is broadside; seed 000 §2–3, seed 002 §2–3; physics.md §4–8).

The engine (``_fourier``) synthesises ``Σ_j F_j(ξ) e^{−jκ(ξ, η) r_j}`` and assembles the
pulses; a track supplies

* ``kappa``: the range-synthesis wavenumber (``√(η̄² − ξ²) − k₀``, or B's
  ``κ_B = √(η̄² − ξ²) − √(k₀² − ξ²)``),
* ``modulate_scene``: a phase on the scene (A: ``γ̃ = γ exp[−j k₀ cos φ_d ψ(x_c, r)]``, ψ at
  the beam-centre pulse ``x_c = x − r tan φ_d``),
* ``line_sets``: B's along-track part per range line — ``G_A`` in ξ, the coupling
  ``exp[−j(√(k₀² − ξ²) − k₀ cos φ_d) δr_xr]`` (a Taylor series in the deviation about its
  mean) and the motion phase ``exp[−j k₀ cos φ_d ψ(x', r_j)]`` in x', back to ξ; and the
  first-order envelope lines of ψ and of its Doppler shift's migration,
* ``per_pulse``: whether the scene-centre deviation enters as the per-pulse factor
  ``exp[−j(k₀ cos φ_d + η / cos φ_d) δr(x')]`` (exact at ξ_d for a constant deviation),
* ``approximation_budgets``: the phase budgets of what it neglects (below).

Budgets over the pulses within the squinted main lobe (``_budgets.LobeGeometry``; with
``c = r/R_n`` the cosine of the look direction, ``c_d = cos φ_d``, ``a = x' − x``):

* straight: ``epsilon_motion = (4π/λ) max|δr_xr|`` (the deviation is not modelled).
* small deviation: ``epsilon_11 = (4π/λ) max|R − R_n − c_d δr_xr|`` (the coupling, seed
  eq. 11; at squint first order in the beam angle); ``epsilon_12 = η_max max(|ψ|/c +
  |δr||1/c − 1/c_d|)`` (the envelope of ψ, seed eq. 12); ``epsilon_13 = (4π/λ) c_d
  max|ψ(x', r) − ψ(x_c, r)|`` (ψ moved onto the scene, seed eq. 13).
* moderate deviation: ``epsilon_11`` = the coupling left by the order-n Taylor series
  over the PRF band about ξ_d, ``(α_max max|δ − δ̄|)^{n+1}/(n+1)!``, plus
  ``(4π/λ) max|R − R_n − δr_xr r/R_n|``; ``epsilon_12`` = the squared corrected envelope
  terms over 2 (``|ψ|/c`` and the migration of ψ's Doppler shift to second order,
  ``c_d |a| |∂ψ/∂x'| / c² + r (c_d ∂ψ/∂x')² (3 − 2c²) / (2c⁵)``) plus the uncorrected
  ones: ``|δr||1/c − 1/c_d|``, the migration of the coupling's Doppler shift,
  ``|a| |√(k₀² − ξ²) − k₀ c_d| |∂δr_xr/∂x'| / (k₀ c²)``, and the third and fourth orders
  of ψ's; on a grid with heights, ``epsilon_height``: the energy-weighted rms phase of
  forming each range line's deviation with one height per pulse, the grid's under the
  beam centre, for each cell's own (``LobeGeometry.height_under_beam_rms``); with alias
  bands, ``band_edge_motion`` (:func:`band_edge_budget`, a track's ``band_budgets``): the
  echo its per-line motion phase moves across the edges between them; at squint,
  ``doppler_migration`` (``LobeGeometry.doppler_migration_nmse``): the motion phase's
  Doppler sidebands, which the range synthesis places on their own migration.
* every track with a deviation: ``recorded_phase_error``, the raw NMSE of its phase
  error (straight: ``k₀ (R − R_n)``; small: ``k₀ (R − R_n − c_d (δr + ψ(x_c, r)))``;
  moderate: ``k₀ (R − R_n − δr_xr r/R_n)``) over every recorded pair, sidelobes
  included, weighted by the echo (``_budgets.recorded_phase_budget``): the maxima above
  see the main lobe only.
* every track: the pointing expansion of its order (``_budgets.pointing_budget``).
"""

from __future__ import annotations

import math
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import _exported, geometry
from .._numerics.phasor import reduced_phasor, unit_phasor
from . import _extent as extent
from . import _fourier_engine as engine
from ._base import AbstractSimulator
from ._budgets import (
    COMBINED_THRESHOLD,
    HEIGHT_THRESHOLD,
    NMSE,
    PHASE_MAXIMUM,
    PHASE_THRESHOLD,
    RMS_PHASE,
    Budget,
    LobeGeometry,
    azimuth_budgets,
    beam_coordinate,
    coupling_rest,
    lobe_pairs,
    lobe_peak,
    over_pulse_blocks,
    pointing_budget,
    range_difference,
    recorded_mean_square,
    recorded_phase_budget,
)


class AbstractTrack(eqx.Module):
    """A track model (module docstring). Stateless; the simulator's options are passed
    in."""

    kind: ClassVar[str] = "straight"
    per_pulse: ClassVar[bool] = False
    # XLA's peak memory of the engine with this track [complex128 elements]:
    # a·n_x n_r + b·n_lines n_x + c·N_x n_r + d·N_x n_x; least-squares fits over grids and
    # point scenes (N_x 256–2048, N_r 256–1024, 3–400 range lines), scaled by 1.2–1.5
    # into upper bounds (tests/test_memory.py)
    workspace_factors: ClassVar[tuple[float, float, float, float]] = (0.15, 3.5, 3.4, 0.13)
    # steady time in FFT2-equivalents of the padded grid (benchmarks/RESULTS.md)
    fft_equivalents: ClassVar[float] = 13.0

    # κ(ξ, η) [rad/m] of the range synthesis: √(η̄² − ξ²) − k₀
    kappa: ClassVar = staticmethod(engine.kappa_full)

    def modulate_scene(self, ctx, gamma, xs, rs, hs):
        """The scene as the engine synthesises it (default: unchanged)."""
        return gamma

    def line_sets(self, ctx, sim, spectrum, column_factor, weights):
        """(line sets, η-weighted set) when the pattern precedes the motion phase; None
        when the pattern is a per-ξ factor of one synthesised set (default).
        ``column_factor``: the per-ξ factors other than A(ξ, r)/√r and the pattern's."""
        return None

    def pointing_order(self, sim) -> int:
        """The order of the pointing expansion the engine runs."""
        return sim.pointing_order

    def phase_budgets(self, sim, lobe) -> list[Budget]:
        """The phase budgets of the deviation terms this track neglects."""
        return []

    def coupling_order(self, sim, radar, span) -> int:
        """The Taylor order of the coupling the kernel runs (none here). ``span``: a
        callable returning :func:`~._budgets.line_of_sight_span` [m] of the run."""
        return 0

    def band_budgets(self, sim, radar, scene, acquisition, lobe) -> list[Budget]:
        """Budgets of what the track's per-band processing does at the edges between the
        synthesised Doppler bands (none here)."""
        return []

    def approximation_budgets(self, sim, radar, lobe):
        """Phase budgets and the pointing budget; (budgets, max|δ_az| L/λ)."""
        budgets = self.phase_budgets(sim, lobe)
        pointing, ratio = pointing_budget(radar, lobe.pointing, self.pointing_order(sim))
        return budgets + [pointing], ratio


class StraightTrack(AbstractTrack):
    """The nominal straight track: no deviation, no pointing error modelled."""

    kind: ClassVar[str] = "straight"

    def pointing_order(self, sim) -> int:
        return 0

    def phase_budgets(self, sim, lobe):
        peak, error, recorded = (0.0, 0.0, 0.0) if lobe.still else lobe.line_of_sight_errors()
        budgets = [Budget("epsilon_motion", lobe.k0 * peak, PHASE_THRESHOLD,
                          "(4π/λ) max|δr_xr|: the deviation is not modelled",
                          error=PHASE_MAXIMUM)]
        if not lobe.still:
            budgets.append(recorded_phase_budget(error, recorded, "k₀ (R − R_n)"))
        return budgets


class AbstractStraightTrackSimulator(AbstractSimulator):
    """A Fourier-domain model of the straight track only (chirp scaling, high speed), on
    the grid of ``_extent.work_grid`` with the Doppler bands the scene's echo energy needs
    (principal and alias bands, ``_extent.azimuth_support``): it refuses motion, reports
    the straight track's budgets and the azimuth ambiguities it leaves out, and
    ``method="auto"`` does not choose it. ``grid_rules``: the range terms its echoes need
    (``work_grid``'s keywords).

    Attributes:
        azimuth_aliases: Doppler alias bands ±1 … ±n summed beside the principal one
            (azimuth ambiguities); None (default): as many as hold all but
            ``azimuth_tolerance`` of the echo energy, at most ``max_azimuth_aliases``;
            0: the principal band only (the seeds' models).
        azimuth_tolerance: echo energy left out of the support and the alias bands.
        max_azimuth_aliases: the most alias bands on each side.
    """

    motion: ClassVar[str] = "straight"
    in_auto = accepts_motion = False
    grid_rules: ClassVar[dict] = {}

    azimuth_aliases: int | None = eqx.field(static=True, default=None, kw_only=True)
    azimuth_tolerance: float = eqx.field(static=True, default=extent.AZIMUTH_TOLERANCE,
                                         kw_only=True)
    max_azimuth_aliases: int = eqx.field(static=True, default=4, kw_only=True)

    def grid(self, radar, scene, motion, acquisition):
        """(support, grid): the Doppler bands the echo energy needs on the grid of
        ``_extent.work_grid``."""
        support = extent.azimuth_support(radar, scene, acquisition, self.azimuth_tolerance,
                                         self.azimuth_aliases, self.max_azimuth_aliases)
        return extent.band_grid(radar, scene, motion, acquisition, self.azimuth_padding,
                                support, **self.grid_rules)

    def azimuth_period(self, radar, scene, motion, acquisition) -> int:
        return extent.data_period(self, radar, scene, motion, acquisition)

    def window_budgets(self, radar, scene, motion, acquisition, dtype=jnp.complex128):
        # computed in complex128 whatever the output's dtype: no rounding budget
        return azimuth_budgets(*self.grid(radar, scene, motion, acquisition))

    def approximation_budgets(self, radar, scene, motion, acquisition):
        """The straight track's budgets (``epsilon_motion``, pointing of order 0)."""
        return straight_track_budgets(radar, scene, motion, acquisition)


def straight_track_budgets(radar, scene, motion, acquisition):
    """The straight track's budgets (``epsilon_motion``, pointing of order 0) of a
    simulator that models neither deviation nor pointing error."""
    lobe = LobeGeometry(radar, scene, motion, acquisition.num_pulses,
                        float(acquisition.azimuth_center))
    return StraightTrack().approximation_budgets(None, radar, lobe)


@_exported.cached
@eqx.filter_jit
def _small_deviation_maxima(pairs, pattern, power, delta_r, beam_pulse, constants):
    """Algorithm A's three lobe maxima over the (pulse, scatterer) pairs, in one fused
    program: max|R − R_n − cos φ_d δr_xr|, max(|ψ|/c + |δr||1/c − 1/c_d|) and
    max|ψ(x', r) − ψ(x_c, r)| (``c = r/R_n``; ``beam_pulse`` the beam-centre pulse of
    each scatterer in pulse spacings from the first, ψ interpolated linearly there, edge
    values outside, as the simulator has it; the pairs from
    :func:`~._budgets.lobe_pairs`); then :func:`~._budgets.recorded_mean_square` of A's
    phase error ``k₀ (R − R_n − cos φ_d (δr + ψ(x_c, r)))``, the first and the third
    terms signed and added (``constants``: k₀, cos φ_d). Blocks of pulses
    (:func:`~._budgets.over_pulse_blocks`)."""
    k0, c_d = constants[0], constants[1]
    _, _, rs, ground, dy, dz, _, _, drop = pairs
    n = dy.shape[0]
    # ψ at each scatterer's beam-centre pulse, linear between the two pulses around it
    position = jnp.clip(beam_pulse, 0.0, n - 1.0)
    i0 = jnp.minimum(jnp.floor(position).astype(jnp.int32), max(n - 2, 0))
    t = position - i0

    def psi_at(i):  # (scatterer,) ψ = δr_xr − δr at pulse i of each scatterer
        return (geometry.line_of_sight_deviation_across(dy[i], dz[i], rs, ground, drop)
                - delta_r[i, 0])

    psi_beam = psi_at(i0) * (1 - t) + psi_at(jnp.minimum(i0 + 1, n - 1)) * t
    rs = rs[None, :]
    inverse_range = 1 / rs  # per scatterer: the pairs' divisions by r become products

    def block(along, lobe, los, delta_r_b, live):
        nominal = jnp.sqrt(rs**2 + along**2)
        secant = nominal * inverse_range  # 1/c
        psi = los - delta_r_b
        coupling = range_difference(along, rs, los, nominal) - c_d * los
        variation = psi - psi_beam[None, :]
        peaks = jnp.stack([
            lobe_peak(lobe, coupling),
            lobe_peak(lobe, jnp.abs(psi) * secant
                      + jnp.abs(delta_r_b) * jnp.abs(secant - 1 / c_d)),
            lobe_peak(lobe, variation)])
        sums = recorded_mean_square(
            pattern, beam_coordinate(along, rs, pairs[6], pairs[7]), power[None, :] * live,
            k0 * (coupling + c_d * variation))
        return peaks, jnp.stack(sums)

    peaks, sums = over_pulse_blocks(block, pairs, (delta_r,))
    return tuple(peaks) + tuple(sums)


class SmallDeviationTrack(AbstractTrack):
    """Small deviations, "Algorithm A" (seed 000 §2.1, §3.1; seed 002 §2, Fig. 3)."""

    kind: ClassVar[str] = "small"
    per_pulse: ClassVar[bool] = True
    workspace_factors: ClassVar[tuple[float, float, float, float]] = (0.4, 3.0, 2.9, 0.15)
    fft_equivalents: ClassVar[float] = 15.0

    def modulate_scene(self, ctx, gamma, xs, rs, hs):
        # γ̃ = γ exp[−j k₀ cos φ_d ψ(x_c, r)], ψ at the beam-centre pulse x_c = x − r tan φ_d
        x_beam = xs - rs * ctx.tan_d
        dy_s = engine.interp_motion(ctx.horizontal, x_beam, ctx.x_pulses[0], ctx.dx)
        dz_s = engine.interp_motion(ctx.vertical, x_beam, ctx.x_pulses[0], ctx.dx)
        psi_s = geometry.range_variant_deviation(dy_s, dz_s, rs, hs, ctx.radar)
        return gamma * unit_phasor(-ctx.k0 * ctx.cos_d * psi_s)

    def phase_budgets(self, sim, lobe):
        c_d = math.cos(lobe.squint)
        # ψ at the beam-centre pulse x_c = x − r tan φ_d of each scatterer
        x_beam = lobe.xs - lobe.rs * math.tan(lobe.squint)
        pairs, power, delta_r = lobe.inputs()
        coupling, envelope, variation, error, recorded = (
            float(v) for v in _small_deviation_maxima(
                pairs, lobe.pattern, power, delta_r,
                np.asarray((x_beam - lobe.x_p[0]) / lobe.dx, pairs[0].dtype),
                np.asarray([lobe.k0, c_d], pairs[0].dtype)))
        return [
            Budget("epsilon_11", lobe.k0 * coupling, PHASE_THRESHOLD,
                   "(4π/λ) max|R − R_n − cos φ_d δr_xr| (seed eq. 11)", error=PHASE_MAXIMUM),
            Budget("epsilon_12", lobe.eta_max * envelope, PHASE_THRESHOLD,
                   "η_max max(|ψ|/c + |δr||1/c − 1/c_d|) (seed eq. 12)", error=PHASE_MAXIMUM),
            Budget("epsilon_13", lobe.k0 * c_d * variation, PHASE_THRESHOLD,
                   "(4π/λ) cos φ_d max|ψ(x', r) − ψ(x_c, r)| (seed eq. 13; seed 002 eq. 10)",
                   error=PHASE_MAXIMUM),
            recorded_phase_budget(error, recorded, "k₀ (R − R_n − cos φ_d (δr + ψ(x_c, r)))"),
        ]


@_exported.cached
@eqx.filter_jit
def _moderate_deviation_maxima(pairs, pattern, power, delta_r, constants, coupled,
                               envelope_corrected):
    """Algorithm B's lobe maxima over the (pulse, scatterer) pairs that its budgets use,
    in one program: ``coupled`` (a coupling series of order ≥ 1): max|R − R_n − δr_xr c|
    and the spread max|δr_xr − mean over pulses|, else max|R − R_n − cos φ_d δr_xr|;
    ``envelope_corrected``: the envelope terms' maxima, corrected and uncorrected, else
    their sum's (``c = r/R_n``, slopes along the pulses as ``numpy.gradient``); then the
    sums of :func:`~._budgets.recorded_mean_square` of B's phase error
    ``k₀ (R − R_n − δr_xr c)`` (``power`` |γ|² (scatterer,)). Returns (maxima, sums).
    Only the maxima the budgets use are formed: XLA forms each maximum's terms again in
    its own reduction, so the unused ones cost a fifth of the program. Blocks of
    scatterers at a time (all pulses each: the slopes and the mean are along them), so
    that the dozen intermediates stay in cache, each block's pairs formed inside it
    (:func:`~._budgets.lobe_pairs` of its scatterers): formed over the whole plane
    first, they were a dozen (pulse, scatterer) arrays written and transposed into
    blocks."""
    k0, c_d, dx = constants
    x_p, xs, rs, ground, dy, dz, ratio, tan_d, drop = pairs
    n_scatterers = xs.shape[0]
    width = min(_SCATTERER_BLOCK, n_scatterers)
    blocks = -(-n_scatterers // width)
    fill = blocks * width - n_scatterers

    def split(values):  # (scatterer,) → (block, width), edge-padded
        return jnp.pad(values, (0, fill), mode="edge").reshape(blocks, width)

    # padded scatterers: outside the lobe, no echo
    real = (jnp.arange(blocks * width) < n_scatterers).reshape(blocks, width)
    # ψ = δr_xr − δr: its slope is δr_xr's less δr's (per pulse), not a second
    # gradient over the pairs
    reference_slope = jnp.gradient(delta_r, dx, axis=0)

    def block(args):
        xs, rs, ground, drop, power, real = args
        # the block's pairs formed here, from its scatterers (1-D) and every pulse
        along, lobe, los = lobe_pairs((x_p, xs, rs, ground, dy, dz, ratio, tan_d, drop))
        lobe = lobe & real[None, :]
        rs, power = rs[None, :], jnp.where(real, power, 0.0)[None, :]
        nominal = jnp.sqrt(rs**2 + along**2)
        exact = jnp.sqrt((rs + los) ** 2 + along**2)
        deviated = range_difference(along, rs, los, nominal, exact)  # R − R_n
        # c = r/R_n and its powers' reciprocals from one division per pair and one per
        # scatterer (1/r), not one per term
        cos_look = rs / nominal
        inverse_range = 1 / rs
        secant = nominal * inverse_range
        secant2 = secant * secant
        secant5 = secant2 * secant2 * secant
        secant7 = secant5 * secant2
        psi = los - delta_r
        # stationary ξ of each (pulse, scatterer): ξ = −k₀ a/R_n, √(k₀² − ξ²) = k₀ c
        alpha = k0 * jnp.abs(cos_look - c_d)
        los_slope = jnp.gradient(los, dx, axis=0)
        psi_slope = los_slope - reference_slope
        # ψ's Doppler shift Δξ = k₀ c_d ∂ψ/∂x' moves its echo by R(ξ) − R(ξ − Δξ), R(ξ) =
        # r k₀/√(k₀² − ξ²) the envelope's migration: corrected to second order in Δξ
        # (R′Δξ = c_d |a ∂ψ/∂x'|/c², R″Δξ²/2 = r (c_d ∂ψ/∂x')² (3 − 2c²)/(2c⁵)); the
        # third and fourth orders are left
        doppler = c_d * jnp.abs(psi_slope)
        sine = jnp.abs(along) * cos_look * inverse_range  # |a|/R_n
        corrected = (jnp.abs(psi) * secant + c_d * jnp.abs(along * psi_slope) * secant2
                     + rs * doppler**2 * (3 - 2 * cos_look**2) * secant5 / 2)
        higher = (rs * doppler**3 * sine * (9 * cos_look**2 + 15 * sine**2) * secant7 / 6
                  + 3 * rs * doppler**4 * secant7 * secant2 / 8)
        uncorrected = (jnp.abs(delta_r) * jnp.abs(secant - 1 / c_d)
                       + jnp.abs(along) * alpha * jnp.abs(los_slope) * secant2 / k0
                       + higher)
        rest = coupling_rest(along, rs, los, nominal, exact)  # R − R_n − δr_xr c
        recorded = recorded_mean_square(
            pattern, beam_coordinate(along, rs, pairs[6], pairs[7]), power, k0 * rest)
        terms = ([rest, los - jnp.mean(los, axis=0, keepdims=True)] if coupled
                 else [deviated - c_d * los])
        terms += [corrected, uncorrected] if envelope_corrected else [corrected + uncorrected]
        return jnp.stack([lobe_peak(lobe, t) for t in terms]), jnp.stack(recorded)

    peaks, sums = jax.lax.map(block, (*(split(v) for v in (xs, rs, ground, drop, power)), real))
    return tuple(jnp.max(peaks, axis=0)), tuple(jnp.sum(sums, axis=0))


_SCATTERER_BLOCK = 128  # scatterers per block of _moderate_deviation_maxima (fastest of 8–1024)
# the highest coupling order chosen by tolerance (the workspace factors are fitted to it)
MAX_AUTO_COUPLING_ORDER = 3


def coupling_alpha_max(radar) -> float:
    """max |α(ξ)| = max |√(k₀² − ξ²) − k₀ cos φ_d| over the PRF band about ξ_d [rad/m]:
    the coupling's wavenumber, ``k₀ϕ = α(ξ) δ(x')``."""
    k0, squint = float(radar.wavenumber), float(np.asarray(radar.squint))
    dx = float(radar.azimuth_spacing)
    xi_band = k0 * math.sin(squint) + np.linspace(-np.pi / dx, np.pi / dx, 257)
    return float(np.max(np.abs(np.sqrt(k0**2 - xi_band**2) - k0 * math.cos(squint))))


BAND_EDGE_THRESHOLD = 10 ** -2.8  # −28 dB
BAND_EDGE_SCALE = 10.0  # [m], measured (band_edge_budget)


def band_edge_budget(radar, scene, acquisition, lobe, bands):
    """``band_edge_motion`` of Algorithm B: its per-line motion phase
    ``e^{−jk₀ cos φ_d ψ(x', r)}`` multiplies one Doppler band's echo on the pulses, and the
    band's transform back to ξ wraps what that moves past the band's edge to its other
    edge, where the range synthesis gives it the wrong band's migration.

    Predicted NMSE ``K · S · Δξ``: ``S`` the recorded echo energy within
    ``Δξ = k₀ cos φ_d max|∂ψ/∂x'|`` of an edge between two synthesised bands
    (``_extent.band_edge_spill``), ``K = 10 m`` measured: the airborne set, a target whose
    beam-centre crossing is 172 m before a 512-pulse window (recorded through bands 0 and
    −1), Δy of 0.02–0.3 m rms, squint 5–20°, L = 0.5–2 m, PRF 250–400 Hz: within 1.5 dB
    of the raw NMSE against the exact model where it dominates (10°, PRF 250 Hz: 0.3 m
    −15.1 dB measured, −14.5 dB predicted; 0.1 m −23.6 / −24.1 dB), above it elsewhere
    (5°, L = 0.6 m: −21.1 / −11.9 dB); at 30° it fell 4–16 dB short, where ``epsilon_12``
    warns. The error grows as Δξ², not as the energy moved: part of what crosses stays
    near its place. Threshold −28 dB."""
    spread = lobe.k0 * math.cos(lobe.squint) * lobe.deviation_slope_max()
    value = BAND_EDGE_SCALE * spread * extent.band_edge_spill(radar, scene, acquisition,
                                                             bands, spread)
    return Budget("band_edge_motion", value, BAND_EDGE_THRESHOLD,
                  f"predicted NMSE of the echo the per-line motion phase (Doppler spread "
                  f"{spread:.3g} rad/m) moves across the edges between Doppler bands", error=NMSE)


class ModerateDeviationTrack(AbstractTrack):
    """Moderate deviations, "Algorithm B" (seed 000 §2.2, §3.2, eq. 14–18, 39–47; seed 002
    §3.2, Fig. 14–15), the range accumulation done as an inverse Stolt sum."""

    kind: ClassVar[str] = "moderate"
    per_pulse: ClassVar[bool] = True
    workspace_factors: ClassVar[tuple[float, float, float, float]] = (0.75, 16.5, 1.5, 0.2)
    fft_equivalents: ClassVar[float] = 37.0

    kappa: ClassVar = staticmethod(engine.kappa_b)  # B's κ_B = √(η̄² − ξ²) − √(k₀² − ξ²)

    def _factors(self, ctx, sim, work):
        """The per-(line, x') factors every line set shares: the ``G_A`` carrier
        ``e^{−j(k_z − k₀) r_j}`` (over ξ), ψ, the coupling's factors and the motion phase
        ``e^{−jk₀ cos φ_d ψ}`` (operands of :meth:`line_sets`' loop over the sets, so
        formed once)."""
        k0, kz, ranges = ctx.k0, ctx.kz, ctx.ranges
        carrier = reduced_phasor(-(kz - k0)[None, :] * ranges[:, None], work)
        fill = (ctx.pad, ctx.n_x - ctx.n_pulses - ctx.pad)
        dy_full = jnp.pad(ctx.horizontal, fill, mode="edge")
        dz_full = jnp.pad(ctx.vertical, fill, mode="edge")
        x_full = ctx.x0 + jnp.arange(ctx.n_x) * ctx.dx
        if ctx.prepared.gridded:
            h_line = engine.line_height_under_beam(ctx.prepared, x_full, ranges, ctx.tan_d)
        else:
            h_line = ctx.prepared.height[:, None]
        los = geometry.line_of_sight_deviation(
            dy_full[None, :], dz_full[None, :], ranges[:, None], h_line, ctx.radar.height
        )  # δr_xr(x', r_j)
        psi = los - geometry.reference_deviation(dy_full, dz_full, ctx.radar)[None, :]
        coupling = (engine.coupling_factors(los, kz - k0 * ctx.cos_d, ctx.coupling_order, work)
                    if ctx.coupling_order else None)
        motion_phase = reduced_phasor(-k0 * ctx.cos_d * psi, work)
        return carrier, psi, coupling, motion_phase

    def _along_track(self, ctx, lines, factors):
        """(n_lines, n_x) along-track part of B on the pulses x' for one line set
        (n_lines, n_x) over ξ, with the shared ``factors`` (:meth:`_factors`): ``G_A``,
        the coupling, the motion phase."""
        carrier, _, coupling, motion_phase = factors
        lines = lines * carrier
        if coupling is not None:
            along = engine.coupled_inverse(lines, ctx.kz - ctx.k0 * ctx.cos_d, coupling)
        else:
            along = jnp.fft.ifft(lines, axis=1)  # (line, x'): the seed's B
        return along * motion_phase

    def _envelope(self, ctx, along, psi):
        """The first-order envelope lines ``s(ξ) ψ + R′(ξ) Δξ + R″(ξ) Δξ²/2`` of one set
        (``along`` from :meth:`_along_track`): ψ, and the range migration
        ``R(ξ) = r k₀/√(k₀² − ξ²)`` that ψ's Doppler shift ``Δξ = k₀ cos φ_d ∂ψ/∂x'``
        moves its echo by, to second order."""
        k0, kz, xi, ranges = ctx.k0, ctx.kz, ctx.xi, ctx.ranges
        real = jnp.finfo(along.dtype).dtype
        slope = (jnp.gradient(psi, axis=1) / ctx.dx).astype(real)
        spread = (k0 / kz).astype(real)[None, :] * jnp.fft.fft(along * psi.astype(real), axis=1)
        doppler = k0 * ctx.cos_d  # ψ's Doppler shift per unit slope, Δξ = k₀ cos φ_d ∂ψ/∂x'
        migration = (doppler * ranges[:, None] * (k0 * xi / kz**3)[None, :]).astype(real)
        curvature = (doppler**2 / 2 * ranges[:, None]
                     * (k0 * (kz**2 + 3 * xi**2) / kz**5)[None, :]).astype(real)
        return (spread + migration * jnp.fft.fft(along * slope, axis=1)
                + curvature * jnp.fft.fft(along * slope**2, axis=1))

    def line_sets(self, ctx, sim, spectrum, column_factor, weights):
        # per pointing order (the pattern precedes the motion phase), and the set the
        # synthesis multiplies by η: the pattern's η-slope, −j × the envelope lines of
        # the zeroth order's set; in the spectrum's precision (the per-ξ weights cast to
        # it). The sets run in a loop over their per-ξ weights: its operands (the weights,
        # the shared factors) are formed once; written as separate sets, XLA fused the
        # weights' and the factors' formation (the pattern's derivatives, the phasors)
        # into each set's products and formed them once per (line, ξ) sample and set.
        work = spectrum.dtype
        stacked = jnp.stack([
            engine.stationary_amplitude(ctx.radar, ctx.xi, 1.0, column_factor * w).astype(work)
            for w in [w for w, _ in weights] + [weights[0][1]]])
        factors = self._factors(ctx, sim, work)

        def one_set(_, weight):
            along = self._along_track(ctx, spectrum * weight[None, :], factors)
            return None, jnp.fft.fft(along, axis=1)

        if not sim.envelope_correction:
            spectra = list(jax.lax.scan(one_set, None, stacked)[1])
            return spectra[:-1], spectra[-1]
        # the zeroth order's set outside the loop: its along-track lines serve the
        # envelope lines too
        along = self._along_track(ctx, spectrum * stacked[0][None, :], factors)
        spectra = [jnp.fft.fft(along, axis=1)] + list(jax.lax.scan(one_set, None, stacked[1:])[1])
        sets, eta_set = spectra[:-1], spectra[-1]
        eta_set = eta_set - 1j * self._envelope(ctx, along, factors[1])
        return sets, eta_set

    def coupling_order(self, sim, radar, span):
        """``sim.coupling_order``, or where it is None the smallest order n of 1 …
        :data:`MAX_AUTO_COUPLING_ORDER` whose Taylor remainder ``(α_max P)^{n+1}/(n+1)!``
        is within ``sim.coupling_tolerance`` [rad] (P = ``span()``, the deviation's
        largest peak-to-peak over the pulses, which bounds ``|δ − δ̄|``; None where the
        motion or the scene is traced: then the highest): each order costs one inverse
        transform of every line set (on the seed 000 scene order 1 leaves 6e-5 rad and
        runs 10 % faster than order 3, equal to −122 dB in complex64)."""
        if sim.coupling_order is not None:
            return sim.coupling_order
        peak_to_peak = span()
        if peak_to_peak is None:
            return MAX_AUTO_COUPLING_ORDER
        spread = coupling_alpha_max(radar) * peak_to_peak
        for order in range(1, MAX_AUTO_COUPLING_ORDER + 1):
            if spread ** (order + 1) / math.factorial(order + 1) <= sim.coupling_tolerance:
                return order
        return MAX_AUTO_COUPLING_ORDER

    def band_budgets(self, sim, radar, scene, acquisition, lobe):
        """``band_edge_motion`` (:func:`band_edge_budget`) where the track deviates."""
        if lobe.still:
            return []
        bands = sim.support(radar, scene, acquisition).bands
        return [band_edge_budget(radar, scene, acquisition, lobe, bands)]

    def phase_budgets(self, sim, lobe):
        squint = lobe.squint
        c_d = math.cos(squint)
        k0, dx = lobe.k0, lobe.dx
        order = self.coupling_order(sim, lobe.radar, lobe.line_of_sight_span)
        corrected = bool(sim.envelope_correction)
        pairs, power, delta_r = lobe.inputs()
        maxima, sums = _moderate_deviation_maxima(
            pairs, lobe.pattern, power, delta_r, np.asarray([k0, c_d, dx], pairs[0].dtype),
            bool(order), corrected)
        maxima = [float(v) for v in maxima]
        error, recorded = (float(v) for v in sums)
        coupling, envelope = (maxima[:2], maxima[2:]) if order else (maxima[:1], maxima[1:])
        if order:
            rest, spread = coupling
            value = (coupling_alpha_max(lobe.radar) * spread) ** (order + 1) / math.factorial(
                order + 1) + k0 * rest
            meaning = f"coupling after its order-{order} correction"
        else:
            value = k0 * coupling[0]  # max|R − R_n − cos φ_d δr_xr|
            meaning = "(4π/λ) max|R − R_n − cos φ_d δr_xr| (seed eq. 11)"
        budgets = [Budget("epsilon_11", value, PHASE_THRESHOLD, meaning, error=PHASE_MAXIMUM)]
        eta_max = lobe.eta_max
        if corrected:
            value = (eta_max * envelope[0]) ** 2 / 2 + eta_max * envelope[1]
            meaning = "envelope terms after the first-order correction"
        else:
            value = eta_max * envelope[0]  # the envelope terms' sum
            meaning = "η_max max(envelope terms) (seed eq. 12; seed 002 eq. 11)"
        budgets.append(Budget("epsilon_12", value, PHASE_THRESHOLD, meaning, error=PHASE_MAXIMUM))
        budgets.append(Budget("epsilon_height", lobe.height_under_beam_rms(), HEIGHT_THRESHOLD,
                              "rms phase of one height per range line and pulse (the "
                              "grid's under the beam centre) for each cell's own", error=RMS_PHASE))
        budgets.append(recorded_phase_budget(error, recorded, "k₀ (R − R_n − δr_xr r/R_n)"))
        budgets.append(Budget(
            "doppler_migration", lobe.doppler_migration_nmse(sim.envelope_correction),
            COMBINED_THRESHOLD, "raw NMSE of the range migration of the motion phase's "
            "Doppler sidebands", error=NMSE))
        return budgets
