"""Fourier-domain simulators of the stripmap track: ideal 2-D, small deviation
("Algorithm A") and moderate deviation ("Algorithm B"), at any squint (physics.md §4–8;
seed 000 §2–3, seed 002 §2–3).

One engine runs all three; what differs is the track model (``_tracks``). Per pulse
(seed 000 eq. 6, 22–24; seed 002 eq. 34)

    h(x', η) = exp[−j (k₀ cos φ_d + η / cos φ_d) δr(x')] Σ_n δ_az(x')ⁿ h̃_n(x', η),

where ``h̃_n`` is simulated with the pattern replaced by its n-th Taylor term
``W²⁽ⁿ⁾(u*) (−(L/λ)(1 + δr/r₀)/(1 + tT))ⁿ / n!`` at the stationary point
(``_fourier_engine.pattern_weights``), and the raw spectrum of ``h̃_n`` is synthesised as

    H(ξ, η) = e^{jη r'_0} C(η) Σ_j F_j(ξ) exp[−j κ(ξ, η) r_j],
    F_j = A(ξ, r_j) W²(u*) Γ(ξ, r_j) e^{−j k₀ r_j},

``A(ξ, r) = (1/Δx) √(2π k₀² r / (k₀² − ξ²)^{3/2}) e^{−jπ/4}`` the stationary-phase
amplitude of the azimuth transform. **Squint** enters as a parameter: each sampled ξ is
replaced by its alias nearest the Doppler centroid ``ξ_d = k₀ sin φ_d``, and every
ξ-function is evaluated there; the samples ``x0 + nΔx`` see every alias alike, so the
inverse FFT returns the pulses directly. In these coordinates the STF of seed 002 eq. 49
is the broadside one, and the scene stays in closest-approach coordinates, as in the
exact model. φ_d = 0 is broadside, not a separate code path.

The azimuth is synthesised on a window padded by ``azimuth_padding`` footprints on each
side and the range on ``n_r`` samples (``_extent.work_grid``), then cropped.
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp

from .. import geometry
from .._numerics.interpolation import next_fast_len
from .._numerics.phasor import reduced_phasor, unit_phasor
from ..motion import Motion
from ..scene import ReflectivityGrid
from . import _extent as extent
from . import _fourier_engine as engine
from ._base import AbstractPlan, AbstractSimulator, Cost, is_traced
from ._budgets import (
    LobeGeometry,
    azimuth_budgets,
    line_of_sight_span,
    rounding_budgets,
    scene_samples,
)
from ._tracks import ModerateDeviationTrack, SmallDeviationTrack, StraightTrack

_TWO_PI = 2 * jnp.pi
_C128 = 16


class FourierPlan(AbstractPlan):
    """Static sizes of a Fourier-domain run (from ``prepare()``).

    Attributes:
        azimuth_pad: pulses synthesised before (and after) the window.
        range_fft_size: n_r, the range FFT length.
        alias_columns: columns per range alias (None: every column).
        bands: Doppler alias bands synthesised on each side of the principal one.
        included: (scatterer,) 1 for the scatterers the grid holds, else 0.
        coupling_order: the Taylor order of Algorithm B's coupling (0: none).
    """

    azimuth_pad: int = eqx.field(static=True)
    range_fft_size: int = eqx.field(static=True)
    alias_columns: int | None = eqx.field(static=True)
    bands: int = eqx.field(static=True)
    included: jnp.ndarray
    coupling_order: int = eqx.field(static=True, default=0)

    def sizes(self, acquisition, column_block=None):
        """(azimuth pad, n_r, n_x, column block)."""
        n_x = next_fast_len(acquisition.num_pulses + 2 * self.azimuth_pad)
        block = column_block or max(8, (1 << 20) // (16 * n_x))
        return self.azimuth_pad, self.range_fft_size, n_x, block


class AbstractFourierSimulator(AbstractSimulator):
    """Options shared by the Fourier-domain track simulators.

    Attributes:
        pointing_order: order n of the pointing-error expansion (0, 1 or 2; seed 000
            eq. 21); 0 ignores δ_az.
        azimuth_padding: None (default): the azimuth grid holds every scatterer's echo
            support that reaches the window (``_extent.work_grid``: cost grows with
            the scene's extent); a number: that many footprints X on each side, whatever
            the scene (0: the circular window; ``azimuth_window`` says what wraps).
        azimuth_aliases: Doppler alias bands ±1 … ±n synthesised beside the principal one
            (azimuth ambiguities: the exact model samples the pattern at the PRF, so echo
            energy beyond ±PRF/2 folds back); None (default): as many as hold all but
            ``azimuth_tolerance`` of the echo energy ``∫|W²(u)|² du``, at most
            ``max_azimuth_aliases``; 0: the principal band only.
        azimuth_tolerance: echo energy left out of the support and the alias bands
            (default 10⁻³·⁵; sinc²: the echo synthesised over ``|u| ≤ 2.3``).
        max_azimuth_aliases: the most alias bands on each side (each costs about one
            synthesis; beyond, ``azimuth_aliases`` says what is left out).
        taps: width [cells] of the inverse Stolt interpolation's kernel (grids): the
            exponential of semicircle on the range lines' 1.8× oversampled DTFT, divided
            by its transform (``_fourier_engine.grid_dtft``); worst NMSE against the
            exact sum over 1–420 lines: 4 (default) −61 dB, 2: −22 dB, 3: −44 dB, 5: −79
            dB, 6: −92 dB, 8: −130 dB (complex64's floor), 16: −250 dB.
        range_aliases: range-spectrum aliases ±m summed (the chirp's spectrum extends past
            ±f_s/2 when f_s/Δf is close to 1; 1 matches the sampled model closely).
        alias_tolerance: energy of the aliases' spectra left out, relative to the main
            band (sets the plan's ``alias_columns``). The hard-edged chirp's spectrum
            decays slowly past ±f_s/2 (its sampled ends alias); at the default −45 dB the
            focused NMSE against the sampled time-domain echo is within 0.4 dB of summing
            every column (at −35 dB, 1.5 dB worse on a speckle grid; ``range_aliases=0``,
            the seed's model, is the fastest and least faithful at the chirp ends).
        coupling_order: moderate deviation only: Taylor order of the coupling correction
            (0 = the seed's Algorithm B); None (default): the smallest of 1 … 3 whose
            remainder is within ``coupling_tolerance`` for this motion and scene
            (``_tracks.ModerateDeviationTrack.coupling_order``). The seed neglects
            ``ϕ = √((r + δ)² + (x' − x)²) − √(r² + (x' − x)²) − δ ≈ δ (r/R − 1)``
            (its condition (11)); with ``r/R = √(k₀² − ξ²)/k₀`` at the stationary point,
            ``k₀ϕ = α(ξ) δ(x')``, ``α = √(k₀² − ξ²) − k₀``, a product of a ξ- and an
            x'-function, applied here by a Taylor series in δ about its mean.
        coupling_tolerance: the largest Taylor remainder [rad] of the coupling that
            ``coupling_order=None`` accepts (default 1e-3: an NMSE below −60 dB).
        envelope_correction: moderate deviation only: apply the range-envelope shift of
            ψ(x', r) to first order (``e^{−jηψ} ≈ 1 − jηψ``, one extra range synthesis);
            the seed neglects it (its condition (12), ``η_max |ψ| ≪ 1``).
        column_block: range columns per block of the range synthesis, azimuth inverse
            transform and per-pulse assembly (None: about 1 MiB of complex128 per block).
        column_loops: independent loops the column blocks are split into (they may run
            concurrently).
    """

    track: ClassVar = StraightTrack()
    supports_squint: ClassVar[bool] = True
    in_auto: ClassVar[bool] = True
    splits_columns: ClassVar[bool] = True
    compile_time: ClassVar[float] = 5.0

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        cls.motion = cls.track.kind  # what the track models

    pointing_order: int = eqx.field(static=True, default=2)
    azimuth_padding: float | None = eqx.field(static=True, default=None)
    azimuth_aliases: int | None = eqx.field(static=True, default=None)
    azimuth_tolerance: float = eqx.field(static=True, default=10 ** -3.5)
    max_azimuth_aliases: int = eqx.field(static=True, default=4)
    taps: int = eqx.field(static=True, default=4)
    range_aliases: int = eqx.field(static=True, default=1)
    alias_tolerance: float = eqx.field(static=True, default=10 ** -4.5)
    coupling_order: int | None = eqx.field(static=True, default=None)
    coupling_tolerance: float = eqx.field(static=True, default=1e-3)
    envelope_correction: bool = eqx.field(static=True, default=True)
    column_block: int | None = eqx.field(static=True, default=None)
    column_loops: int = eqx.field(static=True, default=2)

    def __check_init__(self):
        if not (isinstance(self.alias_tolerance, (int, float))
                and 0 < self.alias_tolerance < 1):
            raise ValueError(f"alias_tolerance={self.alias_tolerance!r} must be in (0, 1)")
        if self.coupling_order is not None and not (
                isinstance(self.coupling_order, int) and self.coupling_order >= 0):
            raise ValueError(f"coupling_order={self.coupling_order!r} must be None or an "
                             "integer >= 0")
        if not (isinstance(self.coupling_tolerance, (int, float))
                and self.coupling_tolerance > 0):
            raise ValueError(f"coupling_tolerance={self.coupling_tolerance!r} must be > 0 [rad]")
        if self.column_block is not None and not (
                isinstance(self.column_block, int) and self.column_block >= 1):
            raise ValueError(f"column_block={self.column_block!r} must be a positive integer")
        engine.check_stolt_taps(self.taps)

    def support(self, radar, scene, acquisition):
        """The Doppler alias bands synthesised for this scene
        (:func:`._extent.azimuth_support`)."""
        return extent.azimuth_support(radar, scene, acquisition, self.azimuth_tolerance,
                                      self.azimuth_aliases, self.max_azimuth_aliases)

    def grid(self, radar, scene, motion, acquisition):
        """(:class:`._extent.AzimuthSupport`, :class:`._extent.WorkGrid`)."""
        return extent.band_grid(radar, scene, motion, acquisition, self.azimuth_padding,
                                self.support(radar, scene, acquisition))

    def prepare(self, radar, scene, acquisition, motion=None) -> FourierPlan:
        """Check grid scenes; fix the grid (extent, crop, FFT sizes, alias bands and the
        scatterers it holds) from concrete values."""
        if isinstance(scene, ReflectivityGrid):
            engine.check_grid_scene(scene, radar)
        support, grid = self.grid(radar, scene, motion, acquisition)

        def span():  # None where traced (differentiated): the order cannot be chosen
            given = Motion() if motion is None else motion  # (pulse,) or (batch, pulse)
            dy, dz = (jnp.zeros(acquisition.num_pulses) if v is None else v
                      for v in (given.horizontal, given.vertical))
            if is_traced((dy, dz, scene.range, scene.height)):
                return None
            _, rs, hs = scene_samples(scene)
            return line_of_sight_span(radar, dy, dz, rs, hs)

        return FourierPlan(grid.lead, grid.n_r,
                           engine.alias_column_count(radar, grid.n_r, self.alias_tolerance),
                           support.bands, jnp.asarray(grid.included, dtype=float),
                           self.track.coupling_order(self, radar, span))

    def azimuth_period(self, radar, scene, motion, acquisition) -> int:
        return extent.data_period(self, radar, scene, motion, acquisition)

    def window_budgets(self, radar, scene, motion, acquisition, dtype=jnp.complex128):
        support, grid = self.grid(radar, scene, motion, acquisition)
        return azimuth_budgets(support, grid) + rounding_budgets(support, dtype)

    def simulate(self, plan, radar, scene, motion, acquisition, dtype):
        return synthesize(self, plan, radar, scene, motion, acquisition, dtype)

    def approximation_budgets(self, radar, scene, motion, acquisition):
        near = float(acquisition.near_range)
        lobe = LobeGeometry(radar, scene, motion, acquisition.num_pulses,
                            float(acquisition.azimuth_center),
                            range_window=(near, near + (acquisition.num_range - 1)
                                          * float(radar.range_spacing)))
        budgets, ratio = self.track.approximation_budgets(self, radar, lobe)
        return budgets + self.track.band_budgets(self, radar, scene, acquisition, lobe), ratio

    def memory(self, plan, radar, scene, acquisition, dtype, shards=1) -> int:
        """Workspace [bytes] of one realization; with its columns split over ``shards``
        devices, of one device (the column work and the pulses' spectra divide, the
        scene's range-line tables do not)."""
        _, n_r, n_x, _ = plan.sizes(acquisition, self.column_block)
        grids, lines, per_range, per_azimuth = self.track.workspace_factors
        n = acquisition.num_pulses
        return int(_C128 * ((grids * n_x * n_r + per_range * n * n_r) / shards
                            + lines * engine.range_line_count(scene) * n_x
                            + per_azimuth * n * n_x))

    def cost(self, plan, radar, scene, acquisition, dtype) -> Cost:
        _, n_r, n_x, _ = plan.sizes(acquisition, self.column_block)
        # one complex128 FFT2 ≈ 8 ns per element (2560 × 675 in 14 ms); a point scene's
        # direct range synthesis adds one phasor per (line, ξ, η), ≈ 3 ns
        steady = self.track.fft_equivalents * 8e-9 * n_x * n_r
        if not isinstance(scene, ReflectivityGrid):
            steady += 3e-9 * engine.range_line_count(scene) * n_x * n_r
        return Cost(compile=self.compile_time, steady=steady)


class Fourier2D(AbstractFourierSimulator):
    """Ideal straight-track 2-D Fourier simulation from the system transfer function
    (seed 000 eq. 7–9, seed 002 eq. 49 without motion; physics.md §4): ``F_j = A W²(u*) Γ
    e^{−j k₀ r_j}``, ``κ = √(η̄² − ξ²) − k₀``. Motion, if given, is not modelled (its
    budget ``epsilon_motion`` says how much that costs)."""

    names: ClassVar[tuple[str, ...]] = ("fourier_2d",)
    physics: ClassVar[str] = "physics.md §4, §8 (seed 000 eq. 7–9; seed 002 eq. 49)"
    track: ClassVar = StraightTrack()


class SmallDeviation(AbstractFourierSimulator):
    """Small trajectory deviations and pointing errors, "Algorithm A" (seed 000 §2.1,
    §3.1; seed 002 §2; physics.md §5–6, §8): the scene ``γ̃ = γ exp[−j k₀ cos φ_d
    ψ(x_c, r)]`` and the per-pulse ``δr(x')`` factor."""

    names: ClassVar[tuple[str, ...]] = ("small_deviation", "algorithm_a")
    physics: ClassVar[str] = "physics.md §5–6, §8 (seed 000 §2.1, §3.1; seed 002 §2)"
    track: ClassVar = SmallDeviationTrack()


class ModerateDeviation(AbstractFourierSimulator):
    """Moderate trajectory deviations and pointing errors, "Algorithm B" (seed 000 §2.2,
    §3.2, eq. 14–18, 39–47; seed 002 §3.2; physics.md §5–6, §8), with the range
    accumulation done as an inverse Stolt sum: per range line ``G_A`` in ξ, the motion
    phase in x', back to ξ, and the remaining ``G_B`` with ``κ_B = √(η̄² − ξ²) −
    √(k₀² − ξ²)`` in the range synthesis."""

    names: ClassVar[tuple[str, ...]] = ("moderate_deviation", "algorithm_b")
    physics: ClassVar[str] = "physics.md §5–6, §8 (seed 000 §2.2, §3.2; seed 002 §3.2)"
    track: ClassVar = ModerateDeviationTrack()


# --------------------------------------------------------------------------------------
# the engine's run
# --------------------------------------------------------------------------------------


def _scene_lines(ctx, track, prepared, grid_2d):
    """The scene as the engine synthesises it: (γ, the layout's x, r, h)."""
    ranges = prepared.ranges
    if grid_2d:  # (n_az, n_lines): one 2-D FFT makes the azimuth DFT and the line DTFT
        gamma, xs, hs, rs = (prepared.reflectivity, prepared.azimuth[:, None],
                             prepared.height, ranges[None, :])
    elif prepared.gridded:  # (n_lines, n_az)
        gamma, xs, hs, rs = (prepared.reflectivity.T, prepared.azimuth[None, :],
                             prepared.height.T, ranges[:, None])
    else:  # points: (n_s, 1)
        gamma, xs, hs, rs = (prepared.reflectivity[:, None], prepared.azimuth[:, None],
                             prepared.height[:, None], ranges[:, None])
    gamma = track.modulate_scene(ctx, gamma, xs, rs, hs)
    line_factor = engine.line_carrier(ctx.k0, ranges)
    return gamma * (line_factor[None, :] if grid_2d else line_factor[:, None])


def synthesize(sim, plan, radar, scene, motion, acquisition, dtype):
    """Raw data (num_pulses, num_range) of ``sim`` (its ``track`` and options) with the
    sizes of ``plan`` (module docstring): the principal Doppler band and ``plan.bands``
    alias bands on each side, summed on the pulses."""
    n_pulses, n_range = acquisition.num_pulses, acquisition.num_range
    prepared = engine.prepare_scene(extent.within_support(scene, plan.included))
    pad, n_r, n_x, block = plan.sizes(acquisition, sim.column_block)
    horizontal, vertical, _ = motion.resolve(n_pulses)
    k0 = radar.wavenumber
    ctx = SimpleNamespace(
        radar=radar, prepared=prepared, ranges=prepared.ranges, k0=k0,
        cos_d=jnp.cos(radar.squint), tan_d=jnp.tan(radar.squint),
        dx=radar.azimuth_spacing, x_pulses=acquisition.pulse_azimuths(radar),
        horizontal=horizontal, vertical=vertical, pad=pad, n_x=n_x, n_pulses=n_pulses,
        coupling_order=plan.coupling_order)
    ctx.x0 = ctx.x_pulses[0] - pad * ctx.dx  # DFT origin: the padded window's first pulse
    principal = engine.squinted_wavenumbers(radar, n_x)

    # with alias bands, the bin at the lower edge of the covered ξ range, whose partner
    # at the upper edge is not synthesised, is left out: the covered band stays symmetric
    # (its pattern weight is below the tolerance there)
    lower = radar.wavenumber * jnp.sin(radar.squint) - (2 * plan.bands + 1) * jnp.pi / ctx.dx
    half_bin = jnp.pi / (n_x * ctx.dx)

    def band_ctx(band):
        """Band k: the same DFT bins at ξ + 2πk/Δx (the samples see every alias alike)."""
        xi = principal + band * (_TWO_PI / ctx.dx)
        keep = (xi > lower + half_bin) if plan.bands else jnp.ones(n_x, bool)
        return SimpleNamespace(**{**vars(ctx), "xi": xi, "kz": jnp.sqrt(k0**2 - xi**2),
                                  "keep": keep})

    ctx.work = jnp.dtype(dtype)
    total = engine.add_alias_bands(  # (η, x')
        _band(sim, plan, band_ctx(0), motion, acquisition, n_r, block),
        lambda k: _band(sim, plan, band_ctx(k), motion, acquisition, n_r, block),
        plan.bands)
    raw = jnp.fft.ifft(total.T, axis=1)[:, :n_range]
    return raw.astype(dtype)


def _band(sim, plan, ctx, motion, acquisition, n_r, block):
    """(n_r, num_pulses) range spectrum of one Doppler band on the pulses. Every band,
    principal or alias, takes the range aliases and the pointing terms of the method: an
    alias band can hold most of a scatterer's echo (PRF below the Doppler band 2v/L, as
    on the spaceborne sets: a target seen 0.3 beamwidths off the beam centre has its echo
    at 1.5 PRF), and without them such an echo was 21 dB (pointing jitter of 0.05 λ/L)
    or 28 dB (none) from the exact model instead of 35 dB.

    Precision (``ctx.work``): the scene's and the track's factors are formed in float64 /
    complex128; the tables, the range synthesis, the transforms and the sums run in the
    output's dtype, with the phases (κ r, η r'_0, the per-pulse motion phase) formed in
    float64 and reduced before a complex64 phasor (``reduced_phasor``)."""
    track, radar, prepared, ranges = sim.track, ctx.radar, ctx.prepared, ctx.ranges
    xi, k0, n_x, n_pulses = ctx.xi, ctx.k0, ctx.n_x, ctx.n_pulses
    _, _, pointing = motion.resolve(n_pulses)
    delta_kept = geometry.reference_deviation(ctx.horizontal, ctx.vertical, radar)  # δr(x')
    order = track.pointing_order(sim) if motion.pointing is not None else 0
    orders = range(order + 1)
    weights = engine.pattern_weights(radar, xi, order)
    alias_sets = engine.range_alias_sets(engine.range_wavenumbers(radar, n_r),
                                         radar.range_spacing,
                                         sim.range_aliases,
                                         plan.alias_columns)
    if len(alias_sets) > 2:  # the aliases m ≠ 0 share one program: their columns together
        everything = jnp.arange(n_r)
        cols = jnp.concatenate([everything if c is None else jnp.asarray(c)
                                for _, c, _ in alias_sets[1:]])
        alias_sets = [alias_sets[0],
                      (1, cols, jnp.concatenate([e for _, _, e in alias_sets[1:]]))]
    # with one term per column (no pointing terms) the main band and the aliases run in one
    # column loop, its output split after: one compiled loop body instead of two (a
    # second body was a third of the program's compile time)
    pieces = None
    if len(weights) == 1 and len(alias_sets) > 1:
        pieces = alias_sets
        alias_sets = [(0, None, jnp.concatenate([e for _, _, e in pieces]))]
    # ---- scene → range lines F_j(ξ) -------------------------------------------------------
    gridded = prepared.gridded and ranges.shape[0] > 1
    sets = None
    grid_2d = gridded and track.kind != "moderate"
    gamma = _scene_lines(ctx, track, prepared, grid_2d)
    # the per-ξ factors: the band's mask, a grid's azimuth ramp and (applied with each
    # pattern weight by stationary_amplitude) A(ξ, r)/√r
    work = ctx.work
    real = jnp.finfo(work).dtype
    column_factor = ctx.keep
    if prepared.gridded:
        column_factor = column_factor * engine.grid_azimuth_ramp(prepared.azimuth, ctx.x0, xi)
        spectrum = None if grid_2d else engine.grid_azimuth_fft(gamma.astype(work), n_x)
    else:
        spectrum = (gamma * unit_phasor(-xi[None, :] * (prepared.azimuth[:, None] - ctx.x0))
                    ).astype(work)
    if not grid_2d:
        sets = track.line_sets(ctx, sim, spectrum, column_factor, weights)
    if sets is None:  # the pattern is a per-ξ factor: one set, weighted per order
        eta_set = None
        if grid_2d:
            tables = [engine.grid_spectrum_dtft(gamma.astype(work), n_x, sim.taps)]
        else:
            tables = [engine.grid_dtft(spectrum, sim.taps) if gridded else spectrum]
    else:
        line_sets, eta_set = sets
        tables = [engine.grid_dtft(lines, sim.taps) if gridded else lines
                  for lines in line_sets]
        if gridded:
            eta_set = engine.grid_dtft(eta_set, sim.taps)

    near = acquisition.near_range
    pointing_scale = (1 + delta_kept / radar.reference_range) * pointing
    scale_powers = {n: pointing_scale**n for n in orders if n}
    # per-pulse exp[−j(k₀ cos φ_d + η/cos φ_d) δr] = exp[−j(η + k₀ cos² φ_d)(δr / cos φ_d)]
    per_pulse = delta_kept / ctx.cos_d if track.per_pulse else None
    total = None  # (η, x'); the main band (m = 0, every column) comes first
    for m, cols, eta_m in alias_sets:
        # pointing terms are ≲ 5 % of the echo, their range aliases (≲ −25 dB of them)
        # negligible
        n_terms = len(weights) if m == 0 else 1

        def produce(eta_block, n_terms=n_terms):
            """(size, n_x) spectra for the columns η of one block."""
            kappa = track.kappa(radar, xi[None, :], eta_block[:, None])

            def synth(table):
                if gridded:
                    return engine.synthesize_grid(table, ranges, kappa)
                return engine.synthesize_direct(table, ranges, kappa)

            out = []
            for q in range(n_terms if sets is not None else 1):
                rel, r_ref = synth(tables[q])
                if q == 0 and eta_set is not None:
                    rel = rel + eta_block.astype(real)[:, None] * synth(eta_set)[0]
                out.append(rel)
            factor = engine.chirp_spectrum(radar, eta_block) * unit_phasor(eta_block * near)
            phase = (reduced_phasor(-kappa * r_ref, work)
                     * (factor / radar.range_spacing).astype(work)[:, None])
            return [rel * phase for rel in out]

        if sets is not None:
            terms = [(q, None, orders[q]) for q in range(n_terms)]
        else:
            terms = [(0, tuple(engine.stationary_amplitude(radar, xi, 1.0, column_factor * w)
                               for w in (base, steep)), orders[q])
                     for q, (base, steep) in enumerate(weights[:n_terms])]
        per_alias = engine.columns_to_pulses(
            produce, terms, eta_m, per_pulse, scale_powers, k0 * ctx.cos_d**2,
            pad=ctx.pad, num_pulses=n_pulses, block=block, loops=sim.column_loops,
        )
        if total is None:
            total = per_alias
        else:
            total = total + per_alias if cols is None else total.at[cols, :].add(per_alias)
    if pieces is not None:  # the one loop's rows: the main band's n_r, then each alias's
        merged, total, offset = total, total[:n_r], n_r
        for _, cols, eta_m in pieces[1:]:
            part = merged[offset:offset + eta_m.shape[0]]
            total = total + part if cols is None else total.at[cols, :].add(part)
            offset += eta_m.shape[0]
    return total
