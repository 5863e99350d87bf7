"""High-speed simulator beyond stop-and-go, with moving targets (seed 004 §2–3;
physics.md §10).

Echo range (seed 004 eq. 4, the exact solution of its eq. 3 for a straight track): for a
scatterer with closest-approach range ``r`` at the time its azimuth is crossed, moving at
``(v_r, v_a)``, ``s`` the transmit time from that crossing,

    ρ(s) = c τ_d / 2 = α₀ [R(s) + (v_eq²/c) s + r v_r / c],
    R(s)² = v_eq² (s − s*)² + r² α²,   s* = −r v_r / v_eq²,
    v_eq² = v_r² + (v − v_a)²,  α = √(1 − v_r²/v_eq²),  α₀ = 1 / (1 − v_eq²/c²).

**2-D spectrum (seed 004 eq. 10–11, derived here).** With ``k = η + 4π/λ`` (two-way range
wavenumber, ``k = 4π(f₀ + f_t)/c``) and ``ξ`` the azimuth wavenumber of ``x' = v t``
(``ξ = 2π f_τ / v``), the azimuth stationary point of ``k ρ(s) + ξ v s`` satisfies
``k α₀ (v_eq² (s − s*)/R + v_eq²/c) = −ξ v``, i.e. ``(s − s*)/R = −β / v_eq`` with

    β = ξ v / (k α₀ v_eq) + v_eq / c,

so ``s − s* = −β r α / (v_eq √(1 − β²))`` and ``R = r α / √(1 − β²)``. Substituting,
the terms ``k α₀ r v_r / c`` and ``k α₀ (v_eq²/c) s*`` cancel exactly and the phase is

    Ψ(ξ, k) = ξ (x + v s*) + k α₀ α r √(1 − β²)
            = ξ x + r κ(ξ, k),   κ = α₀ α √(k² − (ξ v / (α₀ v_eq) + k v_eq / c)²) − ξ v v_r / v_eq².

In seed 004's frequencies, ``k α₀ α √(1 − β²) r = (4π r α₀ α / c)
√((f₀ + f_t)² − [(v_eq/c)(f₀ + f_t) + c f_τ / (2 α₀ v_eq)]²)``: eq. 11's first term, and the
range-frequency mapping of eq. 17 is ``f_t → √((f₀ + f_t)² − [(v_eq/c)(f₀ + f_t) +
c f_τ/(2α₀ v_eq)]²) − f₀`` — with ``v_eq/c``, not the ``v_eq²/c`` eq. 17 prints (which is
not even dimensionless). ``−ξ v v_r r / v_eq²`` is the range-velocity azimuth shift of
eq. 14 (``2π f_τ r v_r / v_eq²``). The constant ``r v_r`` terms that eq. 11 keeps (its
second and fourth) cancel in this derivation (they cannot both be right: eq. 11 has them
proportional to ``f₀ − f_t``, not ``f₀ + f_t``); the exact-model tests decide.

Stationary-phase amplitude (per metre of pulse spacing):
``A = (1/Δx) √(2π r α v² / (k α₀ v_eq² (1 − β²)^{3/2})) e^{−jπ/4}``, which reduces to the
stop-and-go ``(1/Δx) √(2π k² r / (k² − ξ²)^{3/2})``. The antenna pattern is taken at the
stationary point: all of ``s − s*``, ``s*``, ``R``, ``ρ`` scale with ``r``, so the look
angle — and ``W²`` — is a function of ``(ξ, k)`` only (evaluated at the middle of the echo,
as in the exact model, with its squint form).

**Steps** (seed 004 §3, Fig. 3): the scene is split into velocity groups (one per distinct
``(v_r, v_a)``; static scatterers are one group); per group, range lines ``F_j(ξ)``
(azimuth FFT of the reflectivity, carrier ``e^{−j k₀ r_j}``), the sum
``Σ_j F_j(ξ) √r_j e^{−j (κ − k₀) r_j}`` — the inverse Stolt (range-frequency) mapping,
for a grid an FFT over lines and interpolation by a compact kernel — then × chirp spectrum
(reference function of range), × ``A W²``; groups summed; 2-D inverse FFT. The azimuth
wavenumbers are centred on the Doppler centroid ``ξ_d = (4π/λ) sin φ_d``, so squinted
(and PRF-aliased) spectra are synthesised at their true ξ. The work is done in chunks of
range-wavenumber columns, each taken to pulses at once, so memory is
``O(N_x N_r + N_x' · chunk)``.

``stop_and_go=True`` gives the same construction with ``α₀ = 1`` and no ``v_eq/c``
(the stop-and-go spectrum), for comparison.
"""

from __future__ import annotations

from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._numerics.phasor import reduced_phasor, unit_phasor
from ..scene import ReflectivityGrid
from . import _extent as extent
from . import _fourier_engine as engine
from ._base import AbstractPlan, Cost
from ._moving_target import spectrum_terms
from ._tracks import AbstractStraightTrackSimulator

_TWO_PI = 2 * jnp.pi


def nearest_alias(xi, k, squint, dx):
    """(n_x, n_c) the alias ``ξ + 2πm/Δx`` of each sampled azimuth wavenumber nearest the
    Doppler centroid at that range wavenumber, ``k sin φ_d`` (the centroid moves with k:
    across a wide band at large squint by more than the PRF band)."""
    period = _TWO_PI / dx
    return xi + period * engine.alias_shift((k * jnp.sin(squint) - xi) / period)


def _grid_spectra(values, offset, n_x, taps):
    """Azimuth DFT of grid rows aligned with the pulses, then the DTFT over range lines
    about the middle line (the inverse Stolt sum of
    :func:`._fourier_engine.synthesize_grid`).

    Args:
        values: (n_lines, n_az) modulated reflectivity, one row per range line.
        offset: (x_first − x0)/Δx, the first grid row in pulse spacings from the DFT origin.
        n_x: azimuth DFT length.
        taps: the interpolation kernel's width [cells].

    Returns:
        :class:`._fourier_engine.StoltTable` of ``D(ξ, ω_k) = Σ_j F_j(ξ) e^{−jω_k (j − j_c)}``.
    """
    spectrum = jnp.fft.fft(values, n=n_x, axis=1)
    spectrum = spectrum * reduced_phasor(-_TWO_PI * jnp.fft.fftfreq(n_x) * offset,
                                         spectrum.dtype)[None, :]
    return engine.grid_dtft(spectrum, taps)


def _direct_sum(weights, azimuths, ranges, x0, xi, kappa, dtype, held=None):
    """(n_x, n_c) Σ_j w_j e^{−jξ (x_j − x0)} e^{−jκ r_j} for points, with ξ and κ given per
    (ξ, η) cell, in the complex ``dtype`` (phases formed in float64, reduced before the
    phasor: ``reduced_phasor``), one elementwise pass per chunk of points
    (:func:`._fourier_engine.sum_of_terms`).

    ``held = (offset, period)``: only the cells whose echo is recorded on the grid's
    pulses, ``0 ≤ x_j − x0 + r_j·offset < period`` (``offset`` per cell: the stationary
    pulse's distance from the scatterer's azimuth per metre of its range, [m/m]); the
    rest would wrap around the circular grid (a moving scatterer's echo near its Doppler
    horizon, :class:`HighSpeed`)."""

    def term(w, x, r):
        value = w.astype(dtype) * reduced_phasor(-(xi * (x - x0) + kappa * r), dtype)
        if held is None:
            return value
        offset, period = held
        position = (x - x0) + r * offset
        return jnp.where((position >= 0) & (position < period), value, 0)

    return engine.sum_of_terms(term, (weights, azimuths, ranges), kappa.shape, dtype)


class HighSpeedPlan(AbstractPlan):
    """Static plan of a high-speed run.

    Attributes:
        groups: velocity groups ``((v_r, v_a, indices), ...)`` (indices None: a grid).
        azimuth_pad, azimuth_size, range_fft_size: the padded grid: pulses before the
            window, the azimuth and range FFT lengths.
        bands: Doppler alias bands synthesised on each side of the principal one.
        alias_columns: columns per range alias (None: every column).
    """

    groups: tuple = eqx.field(static=True)
    azimuth_pad: int = eqx.field(static=True)
    azimuth_size: int = eqx.field(static=True)
    range_fft_size: int = eqx.field(static=True)
    included: jnp.ndarray
    bands: int = eqx.field(static=True, default=0)
    alias_columns: int | None = eqx.field(static=True, default=None)


def velocity_groups(radar, scene) -> tuple:
    """One group ``(v_r, v_a, indices)`` per distinct scatterer velocity (eager)."""
    if isinstance(scene, ReflectivityGrid):
        return ((0.0, 0.0, None),)
    vr = np.asarray(scene.velocity_range, dtype=float)
    va = np.asarray(scene.velocity_azimuth, dtype=float)
    pairs = np.stack([vr, va], axis=1)
    if float(np.max(np.abs(pairs))) >= float(radar.velocity):
        raise ValueError(
            f"scene velocities up to {np.max(np.abs(pairs)):g} m/s reach the "
            f"platform velocity {float(radar.velocity):g} m/s"
        )
    return tuple((float(a), float(b), tuple(int(i) for i in np.flatnonzero((vr == a) & (va == b))))
                 for a, b in np.unique(pairs, axis=0))


class HighSpeed(AbstractStraightTrackSimulator):
    """High-speed (non-stop-and-go) 2-D Fourier simulator with moving targets, seed 004
    §3; the derivation and steps are in the module docstring.

    Attributes:
        stop_and_go: False (default): seed 004's spectrum; True: the stop-and-go one.
        azimuth_padding: None (default): the azimuth grid holds every scatterer's echo
            support that reaches the window, within the synthesised Doppler bands
            (``_extent.work_grid``); a number: that many footprints X on each side.
        azimuth_aliases, azimuth_tolerance, max_azimuth_aliases: the Doppler alias bands
            (azimuth ambiguities, ``AbstractStraightTrackSimulator``): each band is the
            same construction at ``ξ + 2πk/Δx``, summed before the azimuth IFFT.
        range_aliases: range-spectrum aliases ±m summed (the chirp spectrum extends past
            ±f_s/2 when f_s/Δf is close to 1).
        alias_tolerance: energy of the aliases' spectra left out, relative to the main
            band: alias m is synthesised only on the columns its spectrum reaches at this
            level, counted from the band edge (as the track simulators'; seed 004's
            40 µs chirp needs none at the default −45 dB, its 1 µs one half the columns).
        taps: width [cells] of the inverse Stolt interpolation's kernel (grids; see
            ``AbstractFourierSimulator``).
        column_chunk: range-wavenumber columns per step (memory bound).
    """

    names: ClassVar[tuple[str, ...]] = ("high_speed",)
    physics: ClassVar[str] = "physics.md §10 (seed 004 §2–3)"
    supports_squint = supports_moving_targets = splits_columns = True
    # non-stop-and-go: a different model from the (stop-and-go) exact default, so
    # ``method="auto"`` does not substitute it (the base says so)
    grid_rules: ClassVar[dict] = dict(curvature=True)

    stop_and_go: bool = eqx.field(static=True, default=False)
    azimuth_padding: float | None = eqx.field(static=True, default=None)
    range_aliases: int = eqx.field(static=True, default=1)
    alias_tolerance: float = eqx.field(static=True, default=10 ** -4.5)
    taps: int = eqx.field(static=True, default=4)
    column_chunk: int = eqx.field(static=True, default=256)

    def __check_init__(self):
        engine.check_stolt_taps(self.taps)

    def prepare(self, radar, scene, acquisition, motion=None) -> HighSpeedPlan:
        """Velocity groups and FFT sizes from the concrete inputs: room in range for the
        walk and curvature of an echo over the window's pulses (squinted echoes walk
        across the range window: beyond it they would wrap)."""
        if isinstance(scene, ReflectivityGrid):
            engine.check_grid_scene(scene, radar)
        groups = velocity_groups(radar, scene)
        support, grid = self.grid(radar, scene, motion, acquisition)
        return HighSpeedPlan(groups, grid.lead, grid.n_x, grid.n_r,
                             jnp.asarray(grid.included, dtype=float), support.bands,
                             engine.alias_column_count(radar, grid.n_r, self.alias_tolerance))

    def memory(self, plan, radar, scene, acquisition, dtype, shards=1) -> int:
        """Workspace [bytes] of one realization (or of one of ``shards`` devices its
        columns are split over): the range lines' tables (grids), one chunk of columns
        on the padded azimuth grid, with per velocity group its float64 κ and the
        group's terms (XLA keeps a set per group: its peak grew 1.5–3.7× from 1 to 16
        groups), and the pulses' range spectra with their transform. Coefficients
        fitted to XLA's memory analysis over points and grids, 1–16 groups, 0 and 2
        Doppler bands, 64 and 256 columns a chunk, both dtypes: the estimate is
        1.17–2.20× XLA's peak there."""
        n_x = plan.azimuth_size
        chunk = min(max(16, self.column_chunk // shards), -(-plan.range_fft_size // shards))
        item = jnp.dtype(dtype).itemsize
        groups = len(plan.groups)
        cells = n_x * chunk  # one chunk of columns
        lines = (engine.range_line_count(scene) * n_x
                 if isinstance(scene, ReflectivityGrid) else 0)
        spectra = acquisition.num_pulses * plan.range_fft_size / shards
        return int(item * (3.4 * spectra + 7.4 * cells + 2.6 * lines)
                   + groups * cells * (2.2 * 8 + 0.6 * item))

    def cost(self, plan, radar, scene, acquisition, dtype) -> Cost:
        """≈ 2 + 0.6 per velocity group FFT2-equivalents of the padded grid per Doppler
        band (benchmarks/RESULTS.md, seed 004 Table 1: 2.5 for one group, 4.1 for four)."""
        n_x = plan.azimuth_size
        steady = ((2 + 0.6 * len(plan.groups)) * 8e-9 * n_x * plan.range_fft_size
                  * (2 * plan.bands + 1))
        return Cost(compile=3.0, steady=steady)

    def simulate(self, plan, radar, scene, motion, acquisition, dtype):
        if not motion.is_ideal:
            raise ValueError(
                "method='high_speed' simulates a straight track: motion errors are not "
                "implemented (use method='time_domain', stop_and_go=False)"
            )
        return self._simulate(plan, radar, extent.within_support(scene, plan.included),
                              acquisition, dtype)

    def _simulate(self, plan, radar, scene, acquisition, dtype):
        n_pulses, n_range = acquisition.num_pulses, acquisition.num_range
        pad, n_x, n_r = plan.azimuth_pad, plan.azimuth_size, plan.range_fft_size
        dx = radar.azimuth_spacing
        dr = radar.range_spacing
        k0 = radar.wavenumber
        x_pulses = acquisition.pulse_azimuths(radar)
        x0 = x_pulses[0] - pad * dx
        xi_c = k0 * jnp.sin(radar.squint)  # Doppler centroid wavenumber ξ_d
        offsets = _TWO_PI * jnp.fft.fftfreq(n_x, 1.0) / dx
        xi = xi_c + offsets  # (n_x,), about ξ_d
        eta = _TWO_PI * jnp.fft.fftfreq(n_r, 1.0) / dr
        near = acquisition.near_range
        gridded = isinstance(scene, ReflectivityGrid)
        # the tables, the synthesis and the transforms in the output's precision, the
        # phases formed in float64 (complex64: reduced before a float32 phasor)
        work = jnp.dtype(dtype)
        real = jnp.finfo(work).dtype

        # per velocity group: grid → DTFT over range lines of F_j(ξ) √r_j e^{−j k₀ r_j} on
        # the sampled ξ; points → weights γ √r e^{−j k₀ r} (their ξ phase per cell)
        groups = []
        for v_r, v_a, index in plan.groups:
            if gridded:
                # e^{−jξ_d (x_i − x0)} first: the FFT then supplies the offsets from ξ_d
                ranges = scene.range
                line_factor = engine.line_carrier(k0, ranges)
                values = (scene.reflectivity * unit_phasor(-xi_c * (scene.azimuth - x0))[:, None]
                          * line_factor[None, :]).T  # (n_lines, n_az)
                # ξ + 2πm/Δx on a grid aligned with the pulses: a phase e^{−j2πm·offset}
                offset = (scene.azimuth[0] - x0) / dx
                groups.append((v_r, v_a, _grid_spectra(values.astype(work), offset, n_x, self.taps),
                               ranges, offset))
            else:
                idx = jnp.asarray(index)
                ranges = scene.range[idx]
                weight = scene.reflectivity[idx] * engine.line_carrier(k0, ranges)
                groups.append((v_r, v_a, weight, ranges, scene.azimuth[idx]))

        # with alias bands, the lowest bin of the covered ξ range (its partner at the top
        # is not synthesised) is left out: the covered band stays symmetric about ξ_d
        lower = -(2 * plan.bands + 1) * jnp.pi / dx + jnp.pi / (n_x * dx)

        def band(band_k, eta_m):
            """(chunk, n_x) Σ over groups of one Doppler band ξ + 2πk/Δx, range alias η_m
            (the columns as rows: the azimuth transform then runs along contiguous rows,
            with no transpose of this fused synthesis)."""
            k = eta_m[:, None] + k0
            centroid = k * jnp.sin(radar.squint)
            xi_cells = nearest_alias(xi[None, :], k, radar.squint, dx) + band_k * _TWO_PI / dx
            keep = (xi_cells - centroid > lower) if plan.bands else True
            acc = 0.0
            for v_r, v_a, data, ranges, where in groups:
                # κ in float64 (it multiplies ranges in a phase); the amplitude and the
                # pattern in the output's precision
                kappa, amplitude, u, transmit = spectrum_terms(
                    radar, xi_cells, k, v_r, v_a, self.stop_and_go, real_dtype=real,
                    with_transmit=True)
                if gridded:
                    summed, r_ref = engine.synthesize_grid(data, ranges, kappa)
                    alias = jnp.round((xi_cells - xi[None, :]) * dx / _TWO_PI)
                    summed = summed * reduced_phasor(
                        -(_TWO_PI * alias * where + kappa * r_ref), work)
                else:
                    # a moving scatterer's echo near its Doppler horizon (inside the
                    # synthesised bands) is recorded ever farther away: the cells whose
                    # pulse lies beyond the grid are left out rather than wrapped in
                    held = ((radar.velocity * transmit, n_x * dx) if (v_r, v_a) != (0.0, 0.0)
                            else None)
                    summed = _direct_sum(data, where, ranges, x0, xi_cells, kappa, work,
                                         held)
                acc = acc + summed * (amplitude * radar.pattern(u)).astype(work)
            return jnp.where(keep, acc, 0.0)

        def columns(eta_m):
            """(chunk, n_pulses) raw range-spectrum columns of the range wavenumbers η_m
            (a column's η, or its alias η + 2πm/Δr)."""
            acc = engine.add_alias_bands(band(0.0, eta_m),
                                         lambda k: band(k, eta_m), plan.bands)
            factor = engine.chirp_spectrum(radar, eta_m) * unit_phasor(eta_m * near) / dr
            along = jnp.fft.ifft(acc * factor.astype(work)[:, None], axis=1)[:, pad:pad + n_pulses]
            # back from the ξ_d-centred grid
            carrier = reduced_phasor(xi_c * (x_pulses - x0), work)
            return (along * carrier[None, :]).astype(dtype)

        def chunked(eta_cols):
            """(n, n_pulses) columns η, ``column_chunk`` at a time."""
            n = eta_cols.shape[0]
            # a device of a column split holds 1/shards of the chunk (its memory with it)
            chunk = min(max(16, self.column_chunk // engine.column_shards()), n)
            n_chunks = -(-n // chunk)
            eta_p = jnp.pad(eta_cols, (0, n_chunks * chunk - n)).reshape(n_chunks, chunk)
            spectra = jax.lax.map(columns, eta_p)  # (n_chunks, chunk, n_pulses)
            return spectra.reshape(n_chunks * chunk, n_pulses)[:n]

        # (n_r, pulses): every pulse, or this device's block in a column split; the range
        # aliases m ≠ 0 on the columns they reach (one program for all of them)
        sets = engine.range_alias_sets(eta, dr, self.range_aliases, plan.alias_columns)
        spectra = engine.split_columns(chunked, sets[0][2], n_pulses)
        if len(sets) > 1:
            cols = np.concatenate([np.arange(n_r) if c is None else c for _, c, _ in sets[1:]])
            eta_alias = jnp.concatenate([e for _, _, e in sets[1:]])
            spectra = spectra.at[cols].add(engine.split_columns(chunked, eta_alias, n_pulses))
        return jnp.fft.ifft(spectra.T, axis=1)[:, :n_range].astype(dtype)
