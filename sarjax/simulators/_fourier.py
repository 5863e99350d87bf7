"""Fourier-domain simulators (physics.md §4–6; seed 000 §2–3).

All three share one engine. The scene is a set of *range lines* ``j`` at slant range
``r_j`` (one per point scatterer, or one per column of a reflectivity grid), each with an
azimuth spectrum ``F_j(ξ)``. The raw spectrum is synthesised as

    H(ξ, η) = e^{jη r'_0} C(η) Σ_j F_j(ξ) exp[−j κ(ξ, η) r_j]

with ``C(η)`` the DFT of the sampled chirp (exact, rather than its POSP form), and the
sum over ``j`` evaluated directly (point scatterers) or, for a uniform range grid, as an
inverse Stolt mapping: an FFT over ``j`` and windowed-sinc interpolation at the
non-uniform wavenumbers ``κ(ξ, η) Δr``. Then, per pulse (seed 000 eq. 6, 22–24),

    h(x', η) = exp[−j η̄ δr(x')] Σ_n δ_az(x')ⁿ h̃_n(x', η),   η̄ = η + 4π/λ,

where ``h̃_n`` is simulated with the pattern replaced by its n-th Taylor term
``W²⁽ⁿ⁾(u) (−(L/λ)(1 + δr/r₀))ⁿ / n!`` (derivatives by autodiff of the pattern).

* **Ideal 2-D** (seed 000 eq. 7–9): ``F_j = A(ξ, r_j) W²(u*) Γ(ξ, r_j) e^{−j k₀ r_j}`` and
  ``κ = √(η̄² − ξ²) − k₀``; no motion.
* **Small deviation, "Algorithm A"** (seed 000 §2.1, §3.1): as ideal 2-D, with the scene
  ``γ̃ = γ exp[−j k₀ ψ(x, r)]`` (ψ taken at the pulse above the scatterer) and the per-pulse
  ``δr(x')`` factor.
* **Moderate deviation, "Algorithm B"** (seed 000 §2.2, §3.2, eq. 14–18, 39–47): per range
  line, ``G_A(ξ, r) = A W²(u*) exp[−j(√(k₀² − ξ²) − k₀) r]`` in ξ, the motion phase
  ``exp[−j k₀ ψ(x', r)]`` in x', back to ξ, and the remaining ``G_B`` with
  ``κ_B = √(η̄² − ξ²) − √(k₀² − ξ²)`` in the range synthesis. The seed accumulates over r at
  cost N_x N_r²; here that accumulation is the same inverse-Stolt sum, so B costs a few
  FFTs more than A.

``A(ξ, r) = (1/Δx) √(2π k₀² r / (k₀² − ξ²)^{3/2}) e^{−jπ/4}`` is the stationary-phase
amplitude of the azimuth transform (kept, since its √r varies across the swath), and
``u* = −ξ L / (λ √(k₀² − ξ²))`` the stationary point of the pattern argument.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import geometry
from .._numerics.interpolation import (
    next_fast_len,
    periodic_rows,
    sinc_interpolate_rows,
)
from .._numerics.phasor import unit_phasor
from ..scene import PointTargets, ReflectivityGrid
from ._base import AbstractSimulator

_TWO_PI = 2 * jnp.pi


# --------------------------------------------------------------------------------------
# building blocks
# --------------------------------------------------------------------------------------


def pattern_term(pattern, order: int):
    """u ↦ W²⁽ⁿ⁾(u) / n!: the n-th Taylor coefficient of the pattern (autodiff)."""
    f = pattern.__call__
    for _ in range(order):
        f = jax.grad(f)
    scale = 1.0 / math.factorial(order)
    return lambda u: jnp.vectorize(f)(u) * scale


def azimuth_wavenumbers(radar, n_x):
    """(n_x,) ξ grid [rad/m] of an n_x-point azimuth DFT at the pulse spacing."""
    return 2 * jnp.pi * jnp.fft.fftfreq(n_x, 1.0) / radar.azimuth_spacing


def range_wavenumbers(radar, n_r):
    """(n_r,) η grid [rad/m] of an n_r-point range DFT at the sample spacing."""
    return 2 * jnp.pi * jnp.fft.fftfreq(n_r, 1.0) / radar.range_spacing


def chirp_spectrum(radar, eta):
    """Continuous spectrum of the chirp in range coordinates (Fresnel integrals).

        C(η) = ∫_{−cτ/4}^{cτ/4} exp(−j b o² − j η o) do
             = e^{jη²/(4b)} √(π/(2b)) [ (C(t₂) − C(t₁)) − j (S(t₂) − S(t₁)) ],
        t₁,₂ = (∓cτ/4 + η/(2b)) √(2b/π)

    The DFT of the sampled echo of a scatterer at any (non-integer) range is
    ``(1/Δr) Σ_m C(η + 2πm/Δr) exp[−j(η + 2πm/Δr)(R − r'_0)]``; the simulators sum the
    aliases m (``range_aliases``), which matches the sampled time-domain model.

    Args:
        radar: the :class:`~sarjax.Radar`.
        eta: range wavenumbers [rad/m] (any shape).
    """
    return _chirp_spectrum(radar.chirp_rate, radar.pulse_half_length, eta)


def _chirp_spectrum(b, half, eta):
    """C(η) for chirp rate b [rad/m²] and half-length cτ/4 [m] (see :func:`chirp_spectrum`)."""
    scale = jnp.sqrt(2 * b / jnp.pi)
    t1 = (-half + eta / (2 * b)) * scale
    t2 = (half + eta / (2 * b)) * scale
    s1, c1 = jax.scipy.special.fresnel(t1)
    s2, c2 = jax.scipy.special.fresnel(t2)
    return (
        unit_phasor(eta**2 / (4 * b))
        * jnp.sqrt(jnp.pi / (2 * b))
        * ((c2 - c1) - 1j * (s2 - s1))
    )


def stationary_amplitude(radar, xi, slant_range):
    """A(ξ, r) = (1/Δx) √(2π k₀² r / (k₀² − ξ²)^{3/2}) e^{−jπ/4} (azimuth POSP)."""
    k0 = radar.wavenumber
    kz2 = k0**2 - xi**2
    mag = jnp.sqrt(2 * jnp.pi * k0**2 * slant_range / kz2**1.5) / radar.azimuth_spacing
    return mag * unit_phasor(-jnp.pi / 4)


def stationary_pattern_argument(radar, xi):
    """u* = −ξ L / (λ √(k₀² − ξ²)) (dimensionless)."""
    k0 = radar.wavenumber
    return -xi * radar.antenna_length / (radar.wavelength * jnp.sqrt(k0**2 - xi**2))


def _kappa_full(radar, xi, eta):
    """κ = √(η̄² − ξ²) − k₀ [rad/m] (ideal 2-D and Algorithm A)."""
    k0 = radar.wavenumber
    eta_bar = eta + k0
    return jnp.sqrt(eta_bar**2 - xi**2) - k0


def _kappa_b(radar, xi, eta):
    """κ_B = √(η̄² − ξ²) − √(k₀² − ξ²) [rad/m] (Algorithm B's G_B)."""
    k0 = radar.wavenumber
    eta_bar = eta + k0
    a = eta_bar**2 - xi**2
    b = k0**2 - xi**2
    return (a - b) / (jnp.sqrt(a) + jnp.sqrt(b))


# --------------------------------------------------------------------------------------
# range synthesis: Σ_j F_j(ξ) exp(−j κ(ξ, η) r_j)
# --------------------------------------------------------------------------------------


def synthesize_direct(lines, line_ranges, kappa, chunk=16):
    """Direct sum over range lines, relative to the first line's range.

    Args:
        lines: (n_lines, n_x) F_j(ξ), one row per range line.
        line_ranges: (n_lines,) r_j [m].
        kappa: (n_c, n_x) κ(ξ, η) [rad/m].

    Returns:
        ((n_c, n_x) Σ_j F_j(ξ) e^{−jκ (r_j − r_ref)}, r_ref = r_0 [m]); the caller applies
        ``e^{−jκ r_ref}`` (together with the other per-(ξ, η) factors, in one pass).
    """
    n_lines = lines.shape[0]
    chunk = min(chunk, n_lines)
    n_chunks = -(-n_lines // chunk)
    pad = n_chunks * chunk - n_lines
    lines_p = jnp.pad(lines, ((0, pad), (0, 0))).reshape(n_chunks, chunk, -1)
    ranges_p = jnp.pad(line_ranges, (0, pad), constant_values=line_ranges[0]).reshape(
        n_chunks, chunk
    )
    r_ref = line_ranges[0]

    def body(acc, block):
        f, r = block  # (chunk, n_x), (chunk,)
        phase = kappa[None, :, :] * (r - r_ref)[:, None, None]
        return acc + jnp.sum(f[:, None, :] * unit_phasor(-phase), axis=0), None

    init = jnp.zeros(kappa.shape, lines.dtype)
    out, _ = jax.lax.scan(body, init, (lines_p, ranges_p))
    return out, r_ref


def grid_dtft(lines):
    """(n_x, p) DTFT over a uniform grid of range lines, about the middle line.

    ``D(ξ, ω_k) = Σ_j F_j(ξ) e^{−jω_k (j − j_c)}``, ``ω_k = 2πk/p``, ``p ≥ 1.8 n_lines``
    (oversampled, so that a short windowed sinc interpolates it; its harmonics span
    ±n/2).

    Args:
        lines: (n_lines, n_x) F_j(ξ).

    Returns:
        :class:`PeriodicRows` of the (n_x, p) table.
    """
    n_lines = lines.shape[0]
    p = dtft_length(n_lines)
    padded = jnp.roll(jnp.pad(lines, ((0, p - n_lines), (0, 0))), -(n_lines // 2), axis=0)
    return periodic_rows(jnp.fft.fft(padded.T, axis=1))


def dtft_length(n_lines):
    """DTFT length p of :func:`grid_dtft`: ≥ 1.8 n_lines. The 8-tap windowed sinc
    interpolates 1.8× oversampled rows as well as 2× ones (−49 dB); the smaller table
    stays below the size where the allocator hands out fresh pages on every call."""
    return next_fast_len(max(-(-9 * n_lines // 5), 2))


def grid_spectrum_dtft(values, n_x):
    """Azimuth DFT and range-line DTFT of a grid in one 2-D FFT (:class:`PeriodicRows`
    of the (n_x, p) table).

    ``D(ξ, ω_k) = Σ_j Σ_i v[i, j] e^{−jξ iΔx} e^{−jω_k (j − j_c)}``: :func:`grid_dtft` of
    the rows of :func:`_grid_azimuth_fft`, made without the (n_lines, n_x) intermediate
    and its transpose.

    Args:
        values: (n_az, n_lines) reflectivity on the grid (cell i at offset i from the
            grid's first row; see :func:`_grid_azimuth_ramp`).
        n_x: azimuth DFT length (≥ n_az).
    """
    n_az, n_lines = values.shape
    p = dtft_length(n_lines)
    centre = n_lines // 2
    # line j_c at index 0, the lines before it at the end of the period
    rolled = jnp.concatenate([values[:, centre:], values[:, :centre]], axis=1)
    padded = jnp.zeros((n_x, p), values.dtype)
    padded = jax.lax.dynamic_update_slice(padded, rolled[:, :n_lines - centre], (0, 0))
    padded = jax.lax.dynamic_update_slice(padded, rolled[:, n_lines - centre:],
                                          (0, p - centre))
    return periodic_rows(jnp.fft.fft2(padded))


def synthesize_grid(dtft, line_ranges, kappa, taps=8):
    """Inverse Stolt mapping over a uniform range grid ``r_j = r_0 + j Δr``:
    ``Σ_j F_j e^{−jκ r_j} = e^{−jκ r_c} D(κ Δr)``, D from :func:`grid_dtft` interpolated
    with a windowed sinc at the non-uniform ``κ Δr``.

    Args:
        dtft: :class:`PeriodicRows` of the (n_x, p) table from :func:`grid_dtft`.
        line_ranges: (n_lines,) r_j [m].
        kappa: (n_c, n_x) κ(ξ, η) [rad/m].

    Returns:
        ((n_c, n_x) D(ξ, κ Δr), r_c = range of the middle line [m]); the caller applies
        ``e^{−jκ r_c}``.
    """
    p = dtft.period
    centre = line_ranges.shape[0] // 2
    step = line_ranges[1] - line_ranges[0]
    position = kappa * step * (p / (2 * jnp.pi))
    return sinc_interpolate_rows(dtft, position, taps=taps), line_ranges[centre]


def columns_to_pulses(produce, terms, eta, delta_r, scale_powers, wavenumber, *, pad,
                      num_pulses, block, loops=2):
    """Range synthesis, azimuth inverse transform and per-pulse assembly, a block of range
    columns at a time.

    For columns ``η`` (of ``eta``):
    ``Σ_terms s(x')ⁿ IFFT_ξ[A_i(ξ, η) w(ξ)](x') · e^{−j(η + k₀) δr(x')}`` on the acquired
    pulses (seed 000 eq. 22–24), with ``A_i`` made by ``produce`` for the block's columns.
    A block of ``block`` columns (its synthesis, transpose, inverse FFTs and per-pulse
    products) stays in cache; the blocks run in ``loops`` independent loops.

    Args:
        produce: (size,) η → list of (size, n_x) spectra A_i(ξ, η).
        terms: list of (array index i, per-ξ weight (n_x,) or None, power n of s).
        eta: (n_c,) range wavenumbers of the columns [rad/m].
        delta_r: (num_pulses,) δr(x') [m], or None for no per-pulse motion.
        scale_powers: {n: (num_pulses,) s(x')ⁿ} for the powers n ≥ 1 used by ``terms``.
        wavenumber: k₀ = 4π/λ [rad/m].
        pad: azimuth padding (pulses before the first acquired pulse).

    Returns:
        (n_c, num_pulses) in (η, x') layout.
    """
    n_c = eta.shape[0]

    # terms that weight the same spectrum run in a scan over (weight, s(x')ⁿ): the
    # spectrum is then a loop operand, made once per block (fused into each term's
    # weighting, XLA would redo its synthesis per term)
    groups = {}
    for index, weight, power in terms:
        groups.setdefault(index, []).append((weight, power))

    def along_track(values, weight, power):
        """IFFT_ξ[values · weight] on the acquired pulses, times the per-pulse power."""
        if weight is not None:
            values = values * weight[None, :]
        along = jnp.fft.ifft(values, axis=1)[:, pad:pad + num_pulses]
        return along if power is None else along * power[None, :]

    def run(eta_block):
        block_arrays = produce(eta_block)
        acc = 0.0
        for index, group in groups.items():
            values = block_arrays[index]
            if len(group) == 1:
                weight, n = group[0]
                acc = acc + along_track(values, weight, scale_powers[n] if n else None)
                continue
            n_x = values.shape[1]
            weights = jnp.stack([jnp.ones(n_x) if w is None else w for w, _ in group])
            powers = jnp.stack([jnp.ones(num_pulses) if n == 0 else scale_powers[n]
                                for _, n in group])

            def term(total, weight_power, values=values):
                return total + along_track(values, *weight_power), None

            zero = jnp.zeros((values.shape[0], num_pulses), values.dtype)
            acc = acc + jax.lax.scan(term, zero, (weights, powers))[0]
        if delta_r is not None:
            acc = acc * unit_phasor(-(eta_block[:, None] + wavenumber) * delta_r[None, :])
        return acc

    n_blocks = n_c // block
    per_loop = -(-n_blocks // max(loops, 1)) if n_blocks else 0
    parts = []
    start = 0
    while start < n_blocks * block:
        count = min(per_loop, n_blocks - start // block)
        chunk = eta[start:start + count * block].reshape(count, block)
        out = jax.lax.map(run, chunk) if count > 1 else run(chunk[0])[None]
        parts.append(out.reshape(count * block, num_pulses))
        start += count * block
    if n_c - start:
        parts.append(run(eta[start:]))
    return parts[0] if len(parts) == 1 else jnp.concatenate(parts, axis=0)


# --------------------------------------------------------------------------------------
# scene → range lines
# --------------------------------------------------------------------------------------


class _Scene(eqx.Module):
    """A scene prepared for the Fourier engine."""

    reflectivity: jnp.ndarray  # points: (n_s,); grid: (n_az, n_lines)
    azimuth: jnp.ndarray  # points: (n_s,); grid: (n_az,)
    ranges: jnp.ndarray  # (n_lines,)
    height: jnp.ndarray  # points: (n_s,); grid: (n_az, n_lines)
    gridded: bool = eqx.field(static=True)


def check_grid_scene(scene, radar):
    """A reflectivity grid must share the pulse spacing in azimuth and have a uniform
    range axis (eager check on concrete values)."""
    az = np.asarray(scene.azimuth)
    rg = np.asarray(scene.range)
    if az.size > 1:
        step = np.diff(az)
        dx = float(radar.azimuth_spacing)
        if not np.allclose(step, dx, rtol=1e-9, atol=1e-9 * dx):
            raise ValueError(
                f"ReflectivityGrid azimuth spacing {step.mean():.6g} m differs from the "
                f"pulse spacing v/PRF = {dx:.6g} m; the Fourier simulators need them "
                "equal (resample the grid, or pass the grid as PointTargets)"
            )
    if rg.size > 1 and not np.allclose(np.diff(rg), np.diff(rg)[0], rtol=1e-9):
        raise ValueError("ReflectivityGrid range axis is not uniform")


def prepare_scene(scene) -> _Scene:
    """Point scatterers stay points; a reflectivity grid becomes range lines."""
    if isinstance(scene, PointTargets):
        return _Scene(scene.reflectivity, scene.azimuth, scene.range, scene.height, False)
    if isinstance(scene, ReflectivityGrid):
        return _Scene(scene.reflectivity, scene.azimuth, scene.range, scene.height, True)
    raise ValueError(f"scene={type(scene).__name__} is not PointTargets or ReflectivityGrid")


def _grid_azimuth_fft(values, n_x):
    """(n_lines, n_x) Σ_i v[j, i] e^{−jξ i Δx}: the azimuth DFT of grid rows, cell i at
    offset i from the grid's first row (see :func:`_grid_azimuth_ramp` for the rest).

    Args:
        values: (n_lines, n_az) reflectivity, one row per range line.
    """
    # written into a zero buffer (an in-place update): the scene factors are computed once
    # per cell, not once per padded sample as a fused zero padding would
    padded = jnp.zeros(values.shape[:1] + (n_x,), values.dtype)
    padded = jax.lax.dynamic_update_slice(padded, values, (0, 0))
    return jnp.fft.fft(padded, axis=1)


def _grid_azimuth_ramp(scene_azimuth, x0, dx, n_x):
    """(n_x,) e^{−jξ (x_0,grid − x0)}: the grid's first row relative to the DFT origin."""
    xi = 2 * jnp.pi * jnp.fft.fftfreq(n_x, dx)
    return unit_phasor(-xi * (scene_azimuth[0] - x0))


def _interp_motion(values, x_query, x0, dx):
    """Linear interpolation of per-pulse values at azimuths x (edge values outside)."""
    position = jnp.clip((x_query - x0) / dx, 0.0, values.shape[0] - 1.0)
    i0 = jnp.clip(jnp.floor(position).astype(jnp.int32), 0, values.shape[0] - 2)
    t = position - i0
    return values[i0] * (1 - t) + values[i0 + 1] * t


def range_alias_sets(eta, range_spacing, range_aliases, alias_columns):
    """The range aliases to synthesise: a list of (m, column indices or None for all,
    (count,) wavenumbers η + 2πm/Δr of those columns), the main band m = 0 first.

    Alias m ≠ 0 only matters for the columns whose η + 2πm/Δr lies near the band edge: a
    static count per alias (``alias_columns``, from :func:`alias_column_count`; None:
    every column), counted from the Nyquist column.

    Args:
        eta: (n_r,) range wavenumbers of the DFT columns [rad/m].
        range_spacing: Δr [m].
        range_aliases: aliases ±1 … ±range_aliases are synthesised.
        alias_columns: columns per alias, or None.
    """
    n_r = eta.shape[0]
    step = _TWO_PI / range_spacing
    half = n_r // 2
    sets = []
    for m in sorted(range(-range_aliases, range_aliases + 1), key=abs):  # m = 0 first
        if m == 0:
            sets.append((0, None, eta + 0.0))
            continue
        count = n_r if alias_columns is None else min(alias_columns, n_r)
        if count == 0:
            continue
        if count >= n_r:
            sets.append((m, None, eta + m * step))
            continue
        # m > 0 reaches the upper band edge from the most negative η (columns half…)
        cols = np.mod((half + np.arange(count)) if m > 0 else (half - 1 - np.arange(count)),
                      n_r)
        sets.append((m, cols, eta[cols] + m * step))
    return sets


def alias_column_count(radar, n_r, tolerance):
    """Columns per range alias (m = ±1) so that the alias energy left out is at most
    ``tolerance`` of the main band's energy (eager, on concrete values).

    The hard-edged chirp's spectrum extends past ±f_s/2 with a slowly decaying Fresnel
    ripple; the alias m = +1 enters the sampled band from its lower edge (and m = −1 from
    the upper edge), so its columns are counted from there.
    """
    key = tuple(float(v) for v in (radar.chirp_rate, radar.pulse_half_length,
                                   radar.range_spacing)) + (int(n_r), float(tolerance))
    return _alias_column_count(*key)


@functools.lru_cache(maxsize=256)
def _alias_column_count(chirp_rate, half_length, range_spacing, n_r, tolerance):
    eta = np.sort(2 * np.pi * np.fft.fftfreq(n_r, range_spacing))
    step = 2 * np.pi / range_spacing
    with jax.ensure_compile_time_eval():
        main = np.abs(np.asarray(_chirp_spectrum(chirp_rate, half_length, eta))) ** 2
        alias = np.abs(np.asarray(_chirp_spectrum(chirp_rate, half_length, eta + step))) ** 2
    left_out = alias.sum() - np.cumsum(alias)  # energy beyond the first k + 1 columns
    if alias.sum() <= tolerance * main.sum():
        return 0
    return int(np.flatnonzero(left_out <= tolerance * main.sum())[0] + 1)


# --------------------------------------------------------------------------------------
# the engine
# --------------------------------------------------------------------------------------


class _FourierBase(AbstractSimulator):
    """Options shared by the Fourier simulators.

    Attributes:
        pointing_order: order n of the pointing-error expansion (0, 1 or 2; seed 000
            eq. 21); 0 ignores δ_az.
        azimuth_padding: extra azimuth samples on each side, in footprints X (avoids
            circular wrap of targets' apertures).
        taps: windowed-sinc length of the inverse Stolt interpolation (grids).
        range_aliases: range-spectrum aliases ±m summed (the chirp's spectrum extends past
            ±f_s/2 when f_s/Δf is close to 1; 1 matches the sampled model closely).
        alias_tolerance: energy of the aliases' spectra left out, relative to the main
            band (sets ``alias_columns``). The hard-edged chirp's spectrum decays slowly
            past ±f_s/2 (its sampled ends alias); at the default −45 dB the focused NMSE
            against the sampled time-domain echo is within 0.4 dB of summing every
            column (at −35 dB, 1.5 dB worse on a speckle grid; ``range_aliases=0``, the
            seed's model, is the fastest and least faithful at the chirp ends).
        coupling_order: moderate deviation only: Taylor order of the coupling correction
            (0 = the seed's Algorithm B). The seed neglects
            ``ϕ = √((r + δ)² + (x' − x)²) − √(r² + (x' − x)²) − δ ≈ δ (r/R − 1)``
            (its condition (11)); with ``r/R = √(k₀² − ξ²)/k₀`` at the stationary point,
            ``k₀ϕ = α(ξ) δ(x')``, ``α = √(k₀² − ξ²) − k₀``, a product of a ξ- and an
            x'-function, applied here by a Taylor series in δ about its mean.
        envelope_correction: moderate deviation only: apply the range-envelope shift of
            ψ(x', r) to first order (``e^{−jηψ} ≈ 1 − jηψ``, one extra range synthesis);
            the seed neglects it (its condition (12), ``η_max |ψ| ≪ 1``).
        column_block: range columns per block of the range synthesis, azimuth inverse
            transform and per-pulse assembly (None: about 1 MiB of complex128 per block).
        column_loops: independent loops the column blocks are split into (they may run
            concurrently).
        azimuth_pad, range_fft_size, alias_columns: static sizes fixed by ``prepare``.
    """

    pointing_order: int = eqx.field(static=True, default=2)
    azimuth_padding: float = eqx.field(static=True, default=1.0)
    taps: int = eqx.field(static=True, default=8)
    range_aliases: int = eqx.field(static=True, default=1)
    alias_tolerance: float = eqx.field(static=True, default=10 ** -4.5)
    coupling_order: int = eqx.field(static=True, default=3)
    envelope_correction: bool = eqx.field(static=True, default=True)
    column_block: int | None = eqx.field(static=True, default=None)
    column_loops: int = eqx.field(static=True, default=2)
    azimuth_pad: int | None = eqx.field(static=True, default=None)
    range_fft_size: int | None = eqx.field(static=True, default=None)
    alias_columns: int | None = eqx.field(static=True, default=None)

    def prepare(self, radar, scene, acquisition):
        """Check grid scenes; fix the padding and FFT sizes from concrete values."""
        if isinstance(scene, ReflectivityGrid):
            check_grid_scene(scene, radar)
        if not (isinstance(self.alias_tolerance, (int, float))
                and 0 < self.alias_tolerance < 1):
            raise ValueError(f"alias_tolerance={self.alias_tolerance!r} must be in (0, 1)")
        if self.column_block is not None and not (
                isinstance(self.column_block, int) and self.column_block >= 1):
            raise ValueError(f"column_block={self.column_block!r} must be a positive integer")
        if (self.azimuth_pad is not None and self.range_fft_size is not None
                and self.alias_columns is not None):
            return self
        footprint = float(radar.footprint(np.max(np.asarray(scene.range))))
        pad = int(math.ceil(self.azimuth_padding * footprint / float(radar.azimuth_spacing)))
        pad = -(-pad // 128) * 128  # coarse steps: new target ranges rarely recompile
        chirp = int(float(radar.chirp_samples)) + 2
        n_r = next_fast_len(acquisition.num_range + chirp)
        return dataclasses.replace(
            self,
            azimuth_pad=pad if self.azimuth_pad is None else self.azimuth_pad,
            range_fft_size=n_r if self.range_fft_size is None else self.range_fft_size,
            alias_columns=(alias_column_count(radar, n_r, self.alias_tolerance)
                           if self.alias_columns is None else self.alias_columns),
        )

    def work_sizes(self, acquisition):
        """Static (azimuth pad, n_r, n_x, column block) of the engine's grids: those fixed
        by ``prepare()`` (eagerly), or generous defaults without it."""
        n_pulses, n_range = acquisition.num_pulses, acquisition.num_range
        pad = n_pulses if self.azimuth_pad is None else self.azimuth_pad
        n_r = self.range_fft_size or next_fast_len(2 * n_range)
        n_x = next_fast_len(n_pulses + 2 * pad)
        block = self.column_block or max(8, (1 << 20) // (16 * n_x))
        return pad, n_r, n_x, block

    def _run(self, radar, scene, motion, acquisition, dtype, mode):
        n_pulses, n_range = acquisition.num_pulses, acquisition.num_range
        prepared = prepare_scene(scene)
        pad, n_r, n_x, block = self.work_sizes(acquisition)

        dx = radar.azimuth_spacing
        k0 = radar.wavenumber
        x_pulses = acquisition.pulse_azimuths(radar)
        x0 = x_pulses[0] - pad * dx  # DFT origin: the padded window starts pad pulses early
        xi = azimuth_wavenumbers(radar, n_x)
        eta = range_wavenumbers(radar, n_r)
        horizontal, vertical, pointing = motion.resolve(n_pulses)
        ranges = prepared.ranges

        u_star = stationary_pattern_argument(radar, xi)
        delta_kept = geometry.reference_deviation(horizontal, vertical, radar)  # δr(x')
        orders = range(self.pointing_order + 1) if mode != "ideal" else range(1)
        if mode != "ideal" and motion.pointing is None:
            orders = range(1)

        kappa_fn = _kappa_b if mode == "moderate" else _kappa_full
        alias_sets = range_alias_sets(eta, radar.range_spacing, self.range_aliases,
                                      self.alias_columns)

        def row_weight(order):
            """(n_x,) the n-th pattern term at the stationary point, (−L/λ)ⁿ W²⁽ⁿ⁾(u*)/n!."""
            scale = (-radar.antenna_length / radar.wavelength) ** order
            return scale * pattern_term(radar.pattern, order)(u_star)

        # ---- scene → range lines F_j(ξ), (n_lines, n_x) ----------------------------------
        # a grid of the small deviation / ideal 2-D methods stays (n_az, n_lines): one 2-D
        # FFT makes the azimuth DFT and the DTFT over its lines
        grid_2d = prepared.gridded and ranges.shape[0] > 1 and mode != "moderate"
        if grid_2d:
            gamma = prepared.reflectivity  # (n_az, n_lines)
            xs = prepared.azimuth[:, None]
            hs = prepared.height
            rs = ranges[None, :]
        elif prepared.gridded:
            gamma = prepared.reflectivity.T  # (n_lines, n_az)
            xs = prepared.azimuth[None, :]
            hs = prepared.height.T
            rs = ranges[:, None]
        else:
            gamma = prepared.reflectivity[:, None]
            xs = prepared.azimuth[:, None]
            hs = prepared.height[:, None]
            rs = ranges[:, None]
        if mode == "small":
            # γ̃ = γ exp[−j k₀ ψ(x, r)]: ψ at the pulse above the scatterer
            dy_s = _interp_motion(horizontal, xs, x_pulses[0], dx)
            dz_s = _interp_motion(vertical, xs, x_pulses[0], dx)
            psi_s = geometry.range_variant_deviation(dy_s, dz_s, rs, hs, radar)
            gamma = gamma * unit_phasor(-k0 * psi_s)
        # per-line factors: √r_j of the stationary amplitude and the carrier e^{−jk₀r_j}
        line_factor = jnp.sqrt(ranges) * unit_phasor(-jnp.mod(k0 * ranges, _TWO_PI))
        gamma = gamma * (line_factor[None, :] if grid_2d else line_factor[:, None])
        # A(ξ, r) / √r = (1/Δx) √(2π k₀² / (k₀² − ξ²)^{3/2}) e^{−jπ/4}: a per-ξ factor,
        # applied with the grid's azimuth ramp as a weight of the columns (small
        # deviation, ideal 2-D) or of the lines (moderate deviation)
        column_weight = stationary_amplitude(radar, xi, 1.0)
        if grid_2d:
            spectrum = None
            column_weight = column_weight * _grid_azimuth_ramp(prepared.azimuth, x0, dx, n_x)
        elif prepared.gridded:
            spectrum = _grid_azimuth_fft(gamma, n_x)
            column_weight = column_weight * _grid_azimuth_ramp(prepared.azimuth, x0, dx, n_x)
        else:
            spectrum = gamma * unit_phasor(-xi[None, :] * (prepared.azimuth[:, None] - x0))

        def moderate_lines(lines, envelope):
            """Algorithm B along-track part: G_A, the motion phase exp[−j k₀ ψ(x', r_j)]
            (and the first-order envelope terms), back to ξ. (n_lines, n_x)."""
            alpha = jnp.sqrt(k0**2 - xi**2) - k0  # azimuth phase per metre of range
            lines = lines * unit_phasor(-alpha[None, :] * ranges[:, None])
            dy_full = jnp.pad(horizontal, (pad, n_x - n_pulses - pad), mode="edge")
            dz_full = jnp.pad(vertical, (pad, n_x - n_pulses - pad), mode="edge")
            x_full = x0 + jnp.arange(n_x) * dx
            if prepared.gridded:
                h_line = _line_height_under_pulses(prepared, x_full)
            else:
                h_line = prepared.height[:, None]
            los = geometry.line_of_sight_deviation(
                dy_full[None, :], dz_full[None, :], ranges[:, None], h_line, radar.height
            )  # δr_xr(x', r_j) = ψ + δr  (n_lines, n_x)
            psi = los - geometry.reference_deviation(dy_full, dz_full, radar)[None, :]
            if self.coupling_order:
                along = _coupled_inverse(lines, los, alpha, self.coupling_order)
            else:
                along = jnp.fft.ifft(lines, axis=1)  # (line, x'): the seed's B
            along = along * unit_phasor(-k0 * psi)
            if not envelope:
                return jnp.fft.fft(along, axis=1)
            # envelope shift ψ, plus the migration error of the Doppler shift −k₀ ∂ψ/∂x'
            # (the migration at ξ sits at r k₀/√(k₀² − ξ²): moved by −(r ξ/k₀) ∂ψ/∂x'),
            # both to first order
            slope = jnp.gradient(psi, axis=1) / dx
            doppler = (ranges[:, None] * xi[None, :] / k0) * jnp.fft.fft(along * slope, axis=1)
            return jnp.fft.fft(along * psi, axis=1) + doppler

        # line sets to synthesise: (lines, all aliases?); and the terms of each alias
        if mode == "moderate":  # the pattern precedes the motion phase: one set per order
            line_sets = []
            for order in orders:
                weighted = spectrum * (column_weight * row_weight(order))[None, :]
                line_sets.append(moderate_lines(weighted, False))
            envelope_set = None
            if self.envelope_correction:
                # range envelope of ψ (the seed's condition (12)) to first order,
                # e^{−jηψ} ≈ 1 − jηψ, on the main term (pointing terms are already small)
                weighted = spectrum * (column_weight * row_weight(0))[None, :]
                envelope_set = moderate_lines(weighted, True)
        else:  # the pattern is a per-ξ factor: synthesise once, weight per order
            line_sets = [spectrum]
            envelope_set = None

        gridded = prepared.gridded and ranges.shape[0] > 1
        if grid_2d:
            dtfts = [grid_spectrum_dtft(gamma, n_x)]
        else:
            dtfts = [grid_dtft(lines) for lines in line_sets] if gridded else line_sets
        env_dtft = None
        if envelope_set is not None:
            env_dtft = grid_dtft(envelope_set) if gridded else envelope_set

        near = acquisition.near_range
        pointing_scale = (1 + delta_kept / radar.reference_range) * pointing
        # δx/X = (r + δr_xr) δ_az / X ≈ (L/λ)(1 + δr/r₀) δ_az; (−L/λ)ⁿ is in row_weight
        scale_powers = {n: pointing_scale**n for n in orders if n}
        total = None  # (η, x'); the main band (m = 0, every column) comes first
        for m, cols, eta_m in alias_sets:
            # the aliases carry ≲ −20 dB of the echo: 6 taps (−34 dB on 1.8× oversampled
            # rows; 4 taps: −21 dB) suffice there, and cost about what 8 do
            taps = self.taps if m == 0 else min(self.taps, 6)
            # pointing terms are ≲ 5 % of the echo: their range aliases (≲ −25 dB of them)
            # are negligible, so (moderate deviation) they are synthesised for m = 0 only
            n_sets = len(line_sets) if m == 0 else 1

            def produce(eta_block, taps=taps, n_sets=n_sets):
                """(size, n_x) spectra for the columns η of one block."""
                kappa = kappa_fn(radar, xi[None, :], eta_block[:, None])

                def synth(table):
                    if gridded:
                        return synthesize_grid(table, ranges, kappa, taps=taps)
                    return synthesize_direct(table, ranges, kappa)

                factor = chirp_spectrum(radar, eta_block) * unit_phasor(eta_block * near)
                out = []
                for q in range(n_sets):
                    rel, r_ref = synth(dtfts[q])
                    if q == 0 and env_dtft is not None:
                        rel = rel + (-1j * eta_block)[:, None] * synth(env_dtft)[0]
                    out.append(rel)
                phase = unit_phasor(-kappa * r_ref) * (factor / radar.range_spacing)[:, None]
                return [rel * phase for rel in out]

            if mode == "moderate":
                terms = [(q, None, order) for q, order in zip(range(n_sets), orders, strict=False)]
            elif m == 0:
                terms = [(0, column_weight * row_weight(order), order) for order in orders]
            else:
                terms = [(0, column_weight * row_weight(0), 0)]
            per_alias = columns_to_pulses(
                produce, terms, eta_m, None if mode == "ideal" else delta_kept, scale_powers,
                k0, pad=pad, num_pulses=n_pulses, block=block, loops=self.column_loops,
            )
            if total is None:
                total = per_alias
            else:
                total = total + per_alias if cols is None else total.at[cols, :].add(per_alias)
        raw = jnp.fft.ifft(total.T, axis=1)[:, :n_range]
        return raw.astype(dtype)


def _coupled_inverse(lines, los, alpha, order):
    """(n_lines, n_x) ``Σ_ξ Y(ξ) e^{jξx'} e^{−jα(ξ) δ(x')}`` by a Taylor series of order
    ``order`` in ``δ − δ̄`` (δ̄ the mean over pulses of each line)."""
    mean = jnp.mean(los, axis=1, keepdims=True)  # (n_lines, 1)
    base = lines * unit_phasor(-alpha[None, :] * mean)
    delta = los - mean
    out = jnp.fft.ifft(base, axis=1)
    term = base
    coef = jnp.ones_like(delta, dtype=base.dtype)
    for n in range(1, order + 1):
        term = term * alpha[None, :]
        coef = coef * (-1j * delta) / n
        out = out + coef * jnp.fft.ifft(term, axis=1)
    return out


def _line_height_under_pulses(prepared, x_full):
    """(n_lines, n_x) grid height h(x', r_j) at the pulse azimuths (nearest grid row; 0
    outside the grid)."""
    az = prepared.azimuth
    step = jnp.where(az.shape[0] > 1, az[-1] - az[0], 1.0) / jnp.maximum(az.shape[0] - 1, 1)
    idx = jnp.round((x_full - az[0]) / step).astype(jnp.int32)
    inside = (idx >= 0) & (idx < az.shape[0])
    rows = prepared.height.T[:, jnp.clip(idx, 0, az.shape[0] - 1)]
    return jnp.where(inside[None, :], rows, 0.0)


class Fourier2D(_FourierBase):
    """Ideal straight-track 2-D Fourier simulation from the system transfer function
    (seed 000 eq. 7–9; physics.md §4). Motion, if given, is ignored."""

    def __call__(self, radar, scene, motion, acquisition, dtype):
        return self._run(radar, scene, motion, acquisition, dtype, "ideal")


class SmallDeviation(_FourierBase):
    """Small trajectory deviations, "Algorithm A" (seed 000 §2.1, §3.1; physics.md §5–6)."""

    def __call__(self, radar, scene, motion, acquisition, dtype):
        return self._run(radar, scene, motion, acquisition, dtype, "small")


class ModerateDeviation(_FourierBase):
    """Moderate trajectory deviations, "Algorithm B" (seed 000 §2.2, §3.2;
    physics.md §5–6), with the range accumulation done as an inverse Stolt sum."""

    def __call__(self, radar, scene, motion, acquisition, dtype):
        return self._run(radar, scene, motion, acquisition, dtype, "moderate")
