"""The Fourier-domain engine: what every Fourier-domain simulator shares (physics.md
§4–10; seed 000 §2–3, seed 002 §2–3, seed 003, seed 004 §3).

The scene is a set of *range lines* ``j`` at slant range ``r_j`` (one per point
scatterer, or one per column of a reflectivity grid), each with an azimuth spectrum
``F_j(ξ)``. The raw spectrum is synthesised as

    H(ξ, η) = e^{jη r'_0} C(η) Σ_j F_j(ξ) exp[−j κ(ξ, η) r_j]

with ``C(η)`` the spectrum of the hard-edged chirp (exact, rather than its POSP form,
its range aliases ``η + 2πm/Δr`` summed), and the sum over ``j`` evaluated directly
(point scatterers) or, for a uniform range grid, as an inverse Stolt mapping: an FFT
over ``j`` and interpolation at the non-uniform wavenumbers ``κ(ξ, η) Δr`` (the type-2 step
of a non-uniform FFT: the lines divided by the kernel's transform, an exponential-of-semicircle
kernel of a few cells).

This module holds those pieces once: the wavenumber grids (with the squinted alias
nearest the Doppler centroid), the chirp spectrum, the stationary-phase amplitude and
pattern argument, the range synthesis (direct and inverse Stolt), the range-alias
bands, the column-blocked assembly of pulses; ``_extent`` decides the grid they run on. The
simulators (``_fourier``, ``_chirp_scaling``, ``_high_speed``) compose them.
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import math
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import _exported
from .._numerics.es_kernel import kernel_transform, spreading_kernel
from .._numerics.interpolation import (
    PeriodicRows,
    kernel_interpolate_rows,
    next_fast_len,
    periodic_rows,
)
from .._numerics.phasor import reduced_phasor, unit_phasor, wrap_phase
from ..scene import PointTargets, ReflectivityGrid

_TWO_PI = 2 * jnp.pi


# --------------------------------------------------------------------------------------
# building blocks
# --------------------------------------------------------------------------------------


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


@jax.jit  # traced once per shape; the Fresnel integrals are ~300 operations
def _chirp_spectrum(b, half, eta):
    """C(η) for chirp rate b [rad/m²] and half-length cτ/4 [m] (see :func:`chirp_spectrum`).
    Both ends' Fresnel integrals in one evaluation (one copy of the approximation in the
    compiled program instead of two)."""
    scale = jnp.sqrt(2 * b / jnp.pi)
    ends = jnp.stack([(-half + eta / (2 * b)) * scale, (half + eta / (2 * b)) * scale])
    s, c = jax.scipy.special.fresnel(ends)
    return (
        unit_phasor(eta**2 / (4 * b))
        * jnp.sqrt(jnp.pi / (2 * b))
        * ((c[1] - c[0]) - 1j * (s[1] - s[0]))
    )


def stationary_amplitude(radar, xi, slant_range, weight=1.0):
    """``weight`` · A(ξ, r), A(ξ, r) = (1/Δx) √(2π k₀² r / (k₀² − ξ²)^{3/2}) e^{−jπ/4}
    (azimuth POSP).

    Formed as ``(weight k₀ √(2πr) e^{−jπ/4} / Δx) / (k₀² − ξ²)^{3/4}``, a division last,
    so that XLA forms it once (``_numerics.phasor.broadcast_phasor`` says why): ending in a
    multiply, it and the phasor and pattern series of ``weight`` were formed again for
    every element of the products that broadcast it (B's zeroth-order set: once per line
    and ξ, 2.9 ms of 175 on one core)."""
    k0 = radar.wavenumber
    kz2 = k0**2 - xi**2
    scale = k0 * jnp.sqrt(2 * jnp.pi * slant_range) / radar.azimuth_spacing
    return (weight * scale * unit_phasor(-jnp.pi / 4)) / kz2**0.75


def line_carrier(wavenumber, ranges):
    """(n_lines,) √r_j e^{−jk₀r_j} of range lines at slant ranges r_j [m] (the √r of the
    stationary amplitude and the carrier), complex128, the phase reduced in float64.

    Formed as e^{−jk₀r_j} / r_j^{−1/2}, a division last, so that XLA forms it once
    (``_numerics.phasor.broadcast_phasor``): ending in a multiply, its phasor series was
    formed again in every cell of the products that broadcast it (972 × 416 grid, one
    core: 5.6 → 1.9 ms for that product and its padded copy)."""
    return unit_phasor(-wrap_phase(wavenumber * ranges)) / jax.lax.rsqrt(ranges)


def stationary_pattern_argument(radar, xi):
    """u* = −ξ L / (λ √(k₀² − ξ²)) (dimensionless)."""
    k0 = radar.wavenumber
    return -xi * radar.antenna_length / (radar.wavelength * jnp.sqrt(k0**2 - xi**2))


def kappa_full(radar, xi, eta):
    """κ = √(η̄² − ξ²) − k₀ [rad/m] (ideal 2-D and Algorithm A)."""
    k0 = radar.wavenumber
    eta_bar = eta + k0
    return jnp.sqrt(eta_bar**2 - xi**2) - k0


def kappa_b(radar, xi, eta):
    """κ_B = √(η̄² − ξ²) − √(k₀² − ξ²) [rad/m] (Algorithm B's G_B)."""
    k0 = radar.wavenumber
    eta_bar = eta + k0
    a = eta_bar**2 - xi**2
    b = k0**2 - xi**2
    return (a - b) / (jnp.sqrt(a) + jnp.sqrt(b))


# --------------------------------------------------------------------------------------
# range synthesis: Σ_j F_j(ξ) exp(−j κ(ξ, η) r_j)
# --------------------------------------------------------------------------------------


def sum_of_terms(term, operands, shape, dtype, chunk=16):
    """``Σ_j term(*operands[j])`` of (``shape``) arrays in ``dtype``, ``chunk`` terms per
    elementwise pass (a ``lax.scan`` over the chunks beyond one).

    Written as one accumulation per term rather than a reduction over a stacked axis: XLA
    fused the per-cell inputs of the terms (κ(ξ, η), with its square roots) into the
    reduction and formed them once per term, and ran 9× slower per term (17 points against
    16 with ``small_deviation`` on the airborne preset: 5.0 s against 0.57 s; 4 groups of
    ``high_speed``'s quick scene: 0.88 s against 0.24 s).

    Args:
        term: (*operand rows) → an array broadcastable to ``shape``.
        operands: arrays with the terms along their first axis (n,).
        shape, dtype: of the sum.
    """
    n = operands[0].shape[0]
    n_chunks = max(-(-n // chunk), 1)
    # chunks of ``chunk`` even where fewer would pad less: 3 chunks of 14 or 15 terms ran
    # 3× slower than 3 of 16 (45 points: 3.9 s against 1.2 s for 48)
    size = chunk if n_chunks > 1 else n

    def accumulate(acc, block):
        for j in range(block[0].shape[0]):
            acc = acc + term(*(a[j] for a in block)).astype(dtype)
        return acc, None

    init = jnp.zeros(shape, dtype)
    if n_chunks == 1:
        return accumulate(init, operands)[0]
    pad = n_chunks * size - n
    # padded terms repeat the last operands with a zero first operand (the weight)
    blocks = [jnp.concatenate([a, jnp.broadcast_to(a[-1:], (pad,) + a.shape[1:])
                               * (0 if i == 0 else 1)]).reshape((n_chunks, size) + a.shape[1:])
              for i, a in enumerate(operands)]
    return jax.lax.scan(accumulate, init, tuple(blocks))[0]


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
    r_ref = line_ranges[0]

    def term(line, r):
        return line[None, :] * reduced_phasor(-kappa * (r - r_ref), lines.dtype)

    return sum_of_terms(term, (lines, line_ranges), kappa.shape, lines.dtype, chunk), r_ref


STOLT_OVERSAMPLING = 1.8  # the range-line DTFT's period over the lines (≥)
# β of the Stolt kernel relative to the ES formula's for 1.8× (es_kernel.spreading_kernel),
# per width, each scale the best of a 0.80–1.10 scan: the formula's β lets the table's
# aliases through at this oversampling. Worst NMSE against the exact DTFT over 1–420 lines
# (tests/test_interpolation.py), formula → tuned: 3 taps −37.5 → −43.6 dB, 4: −54.0 →
# −60.8 dB, 5: −71.9 → −78.6 dB; other widths keep the formula's
STOLT_BETA_SCALE = {3: 0.89, 4: 0.94, 5: 0.97}


class StoltTable(NamedTuple):
    """The range-line DTFT of a grid, ready for :func:`synthesize_grid`: the
    :class:`PeriodicRows` of the (n_x, p) table of the lines divided by the transform of
    the ``taps``-cell interpolation kernel it is made for."""

    rows: PeriodicRows
    taps: int


def check_stolt_taps(taps):
    """A Stolt kernel width the table's guard holds: an integer of 2 … 16 cells."""
    if isinstance(taps, bool) or not isinstance(taps, (int, np.integer)) or not 2 <= taps <= 16:
        raise ValueError(f"taps={taps!r} must be an integer from 2 to 16 (the width of the "
                         "inverse Stolt interpolation's kernel, in cells; 4 by default)")


def stolt_deapodization(n_lines, taps):
    """(n_lines,) 1/φ̂ of each line's offset ``j − j_c`` from the middle line: the factor
    that makes the ``taps``-cell exponential-of-semicircle interpolation of the table
    return the lines' DTFT (:func:`grid_dtft`). Static (NumPy, from the sizes)."""
    p = dtft_length(n_lines)
    return 1.0 / np.fft.fftshift(kernel_transform(taps, STOLT_OVERSAMPLING, p, n_lines,
                                                  STOLT_BETA_SCALE.get(taps, 1.0)))


def grid_dtft(lines, taps):
    """(n_x, p) DTFT over a uniform grid of range lines, about the middle line.

    ``D(ξ, ω_k) = Σ_j F_j(ξ) e^{−jω_k (j − j_c)}``, ``ω_k = 2πk/p``, ``p ≥ 1.8 n_lines``,
    of the lines divided by the interpolation kernel's transform
    (:func:`stolt_deapodization`): :func:`synthesize_grid` then evaluates the DTFT of the
    lines themselves at any ω, as the type-2 step of a non-uniform FFT (Dutt & Rokhlin
    1993; Barnett et al. 2019 for the kernel). Worst measured NMSE against the exact DTFT:
    4 taps −60.8 dB, 3: −43.6 dB, 5: −78.6 dB (``tests/test_interpolation.py``).

    Args:
        lines: (n_lines, n_x) F_j(ξ).
        taps: the interpolation kernel's width [cells].

    Returns:
        :class:`StoltTable` of the (n_x, p) table.
    """
    n_lines = lines.shape[0]
    p = dtft_length(n_lines)
    factor = stolt_deapodization(n_lines, taps).astype(jnp.finfo(lines.dtype).dtype)
    padded = jnp.roll(jnp.pad(lines * factor[:, None], ((0, p - n_lines), (0, 0))),
                      -(n_lines // 2), axis=0)
    return StoltTable(periodic_rows(jnp.fft.fft(padded.T, axis=1)), taps)


def dtft_length(n_lines):
    """DTFT length p of :func:`grid_dtft`: ≥ 1.8 n_lines, a fast FFT length, and at least
    16 (a kernel's window must fit in one period of a grid of a few lines); the smaller
    table stays below the size where the allocator hands out fresh pages on every call."""
    return next_fast_len(max(-(-9 * n_lines // 5), 16))  # ⌈STOLT_OVERSAMPLING · n⌉ in integers


def grid_spectrum_dtft(values, n_x, taps):
    """Azimuth DFT and range-line DTFT of a grid in one 2-D FFT (:class:`StoltTable` of
    the (n_x, p) table).

    ``D(ξ, ω_k) = Σ_j Σ_i v[i, j] e^{−jξ iΔx} e^{−jω_k (j − j_c)}``: :func:`grid_dtft` of
    the rows of :func:`grid_azimuth_fft`, made without the (n_lines, n_x) intermediate
    and its transpose.

    Args:
        values: (n_az, n_lines) reflectivity on the grid (cell i at offset i from the
            grid's first row; see :func:`grid_azimuth_ramp`).
        n_x: azimuth DFT length (≥ n_az).
        taps: the interpolation kernel's width [cells].
    """
    n_az, n_lines = values.shape
    p = dtft_length(n_lines)
    centre = n_lines // 2
    factor = stolt_deapodization(n_lines, taps).astype(jnp.finfo(values.dtype).dtype)
    values = values * factor[None, :]
    # line j_c at index 0, the lines before it at the end of the period
    rolled = jnp.concatenate([values[:, centre:], values[:, :centre]], axis=1)
    padded = jnp.zeros((n_x, p), values.dtype)
    padded = jax.lax.dynamic_update_slice(padded, rolled[:, :n_lines - centre], (0, 0))
    padded = jax.lax.dynamic_update_slice(padded, rolled[:, n_lines - centre:],
                                          (0, p - centre))
    return StoltTable(periodic_rows(jnp.fft.fft2(padded)), taps)


def synthesize_grid(dtft, line_ranges, kappa):
    """Inverse Stolt mapping over a uniform range grid ``r_j = r_0 + j Δr``:
    ``Σ_j F_j e^{−jκ r_j} = e^{−jκ r_c} D(κ Δr)``, D from :func:`grid_dtft` interpolated
    at the non-uniform ``κ Δr`` with the kernel the table was made for.

    Args:
        dtft: :class:`StoltTable` from :func:`grid_dtft` or :func:`grid_spectrum_dtft`.
        line_ranges: (n_lines,) r_j [m].
        kappa: (n_c, n_x) κ(ξ, η) [rad/m].

    Returns:
        ((n_c, n_x) D(ξ, κ Δr), r_c = range of the middle line [m]); the caller applies
        ``e^{−jκ r_c}``.
    """
    rows, taps = dtft
    p = rows.period
    centre = line_ranges.shape[0] // 2
    step = line_ranges[1] - line_ranges[0]
    position = kappa * step * (p / (2 * jnp.pi))
    coefficients, _ = spreading_kernel(taps, STOLT_OVERSAMPLING, STOLT_BETA_SCALE.get(taps, 1.0))
    return kernel_interpolate_rows(rows, position, coefficients), line_ranges[centre]


# --------------------------------------------------------------------------------------
# range columns split across devices
# --------------------------------------------------------------------------------------


class ColumnSplit(NamedTuple):
    """Range-wavenumber columns split over the mesh axis ``axis`` of ``shards`` devices
    (inside ``shard_map``): each device synthesises its contiguous share of the columns
    on every pulse; one all-to-all then leaves it every column of its share of the
    pulses, ready for the range transform."""

    axis: str
    shards: int


_COLUMN_SPLIT: contextvars.ContextVar = contextvars.ContextVar("column_split", default=None)


@contextlib.contextmanager
def columns_across(axis: str, shards: int):
    """Trace the simulators' column loops (:func:`split_columns`) split over the mesh axis
    ``axis`` (``shards`` devices); used by ``_sharding.sharded`` around the kernel."""
    token = _COLUMN_SPLIT.set(ColumnSplit(axis, int(shards)))
    try:
        yield
    finally:
        _COLUMN_SPLIT.reset(token)


def column_shards() -> int:
    """Devices the columns are split over while tracing (1 outside a split): a column
    loop sizes its chunks by it, so that a device's workspace shrinks with the split."""
    split = _COLUMN_SPLIT.get()
    return 1 if split is None else split.shards


def split_columns(compute, eta, num_pulses):
    """``compute(eta)``, (n_c, num_pulses) spectra of the columns ``eta`` (n_c,) on the
    pulses, split across devices when traced inside :func:`columns_across`.

    In a split over D devices the columns (padded with the last η to D·k) are cut into D
    contiguous shares of k; device d computes ``compute`` of its share, (k, num_pulses),
    and one ``all_to_all`` (the transpose as an explicit collective) gives it every
    column of its block of pulses: (n_c, ceil(num_pulses/D)), block d of the pulses
    (the last one padded past ``num_pulses``).
    Per device, the column work and the result are 1/D of the whole; the scene's tables
    are each device's own.
    """
    split = _COLUMN_SPLIT.get()
    if split is None or split.shards == 1:
        return compute(eta)
    n_c, shards = eta.shape[0], split.shards
    share = -(-n_c // shards)
    if share * shards > n_c:
        eta = jnp.concatenate([eta, jnp.broadcast_to(eta[-1], (share * shards - n_c,))])
    mine = jax.lax.dynamic_slice_in_dim(eta, jax.lax.axis_index(split.axis) * share, share)
    local = compute(mine)  # (share, num_pulses)
    block = -(-num_pulses // shards)
    local = jnp.pad(local, ((0, 0), (0, block * shards - num_pulses)))
    # chunk p of the pulses to device p; device d's rows arrive in column order
    gathered = jax.lax.all_to_all(local, split.axis, split_axis=1, concat_axis=0,
                                  tiled=True)
    return gathered[:n_c]


def columns_to_pulses(produce, terms, eta, delta_r, scale_powers, wavenumber, *, pad,
                      num_pulses, block, loops=2):
    """Range synthesis, azimuth inverse transform and per-pulse assembly, a block of range
    columns at a time (split across devices by :func:`split_columns`).

    For columns ``η`` (of ``eta``):
    ``Σ_terms s(x')ⁿ IFFT_ξ[A_i(ξ, η) w(ξ)](x') · e^{−j(η + k₀) δr(x')}`` on the acquired
    pulses (seed 000 eq. 22–24), with ``A_i`` made by ``produce`` for the block's columns.
    A block of ``block`` columns (its synthesis, transpose, inverse FFTs and per-pulse
    products) stays in cache; ``loops`` blocks are processed at once (one loop over the
    blocks, vectorised over ``loops``: one compiled body).

    Args:
        produce: (size,) η → list of (size, n_x) spectra A_i(ξ, η).
        terms: list of (array index i, weight, power n of s); the weight is None, a
            per-ξ weight (n_x,), or a pair (a, b) of them for the weight ``a(ξ) + η b(ξ)``
            (a pattern whose argument moves with η, see :func:`pattern_weights`).
        eta: (n_c,) range wavenumbers of the columns [rad/m].
        delta_r: (num_pulses,) δr(x') [m], or None for no per-pulse motion.
        scale_powers: {n: (num_pulses,) s(x')ⁿ} for the powers n ≥ 1 used by ``terms``.
        wavenumber: k₀ = 4π/λ [rad/m].
        pad: azimuth padding (pulses before the first acquired pulse).

    Returns:
        (n_c, num_pulses) in (η, x') layout; in a column split the device's block of
        pulses, (n_c, ceil(num_pulses / devices)).
    """
    return split_columns(
        lambda columns: _columns_to_pulses(produce, terms, columns, delta_r, scale_powers,
                                           wavenumber, pad, num_pulses, block, loops),
        eta, num_pulses)


def _columns_to_pulses(produce, terms, eta, delta_r, scale_powers, wavenumber, pad,
                       num_pulses, block, loops):
    """:func:`columns_to_pulses` of the columns ``eta`` on one device."""
    n_c = eta.shape[0]

    # terms that weight the same spectrum run in a scan over (weight, s(x')ⁿ): the
    # spectrum is then a loop operand, made once per block (fused into each term's
    # weighting, XLA would redo its synthesis per term)
    groups = {}
    for index, weight, power in terms:
        groups.setdefault(index, []).append((weight, power))

    def along_track(values, eta_block, weight, power):
        """IFFT_ξ[values · weight] on the acquired pulses, times the per-pulse power (in
        the precision of ``values``)."""
        real = jnp.finfo(values.dtype).dtype
        if isinstance(weight, tuple):
            a, b = (w.astype(values.dtype) for w in weight)
            values = values * (a[None, :] + eta_block.astype(real)[:, None] * b[None, :])
        elif weight is not None:
            values = values * weight.astype(values.dtype)[None, :]
        along = jnp.fft.ifft(values, axis=1)[:, pad:pad + num_pulses]
        return along if power is None else along * power.astype(real)[None, :]

    def stacked(weights, n_x):
        """The weights of a group as one (terms, n_x) array, or a pair of them."""
        if any(isinstance(w, tuple) for w in weights):
            pairs = [w if isinstance(w, tuple) else (w, None) for w in weights]
            return (jnp.stack([jnp.ones(n_x) if a is None else a for a, _ in pairs]),
                    jnp.stack([jnp.zeros(n_x) if b is None else b for _, b in pairs]))
        return jnp.stack([jnp.ones(n_x) if w is None else w for w in weights])

    def run(eta_block):
        block_arrays = produce(eta_block)
        acc = 0.0
        for index, group in groups.items():
            values = block_arrays[index]
            if len(group) == 1:
                weight, n = group[0]
                acc = acc + along_track(values, eta_block, weight,
                                        scale_powers[n] if n else None)
                continue
            weights = stacked([w for w, _ in group], values.shape[1])
            powers = jnp.stack([jnp.ones(num_pulses) if n == 0 else scale_powers[n]
                                for _, n in group])

            def term(total, weight_power, values=values, eta_block=eta_block):
                weight, power = weight_power
                return total + along_track(values, eta_block, weight, power), None

            zero = jnp.zeros((values.shape[0], num_pulses), values.dtype)
            acc = acc + jax.lax.scan(term, zero, (weights, powers))[0]
        if delta_r is not None:
            acc = acc * reduced_phasor(-(eta_block[:, None] + wavenumber) * delta_r[None, :],
                                       acc.dtype)
        return acc

    # one compiled body for every block: the columns are padded (with the last η, cut
    # off after) to ``loops`` × blocks, and the loops are one vmapped map
    loops = max(int(loops), 1)
    block = max(1, min(block, -(-n_c // loops)))
    per_loop = -(-n_c // (loops * block))
    padded = loops * per_loop * block
    if padded > n_c:
        eta = jnp.concatenate([eta, jnp.broadcast_to(eta[-1], (padded - n_c,))])
    chunks = eta.reshape(loops, per_loop, block)
    out = jax.vmap(lambda chunk: jax.lax.map(run, chunk))(chunks)
    return out.reshape(padded, num_pulses)[:n_c]


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


def range_line_count(scene) -> int:
    """Range lines of the engine: one per point scatterer or per grid column."""
    shape = np.shape(scene.reflectivity)
    if len(np.shape(scene.range)) == 1 and len(shape) == 2:
        return int(shape[-1])
    return int(np.size(scene.range))


def prepare_scene(scene) -> _Scene:
    """Point scatterers stay points; a reflectivity grid becomes range lines."""
    if isinstance(scene, PointTargets):
        return _Scene(scene.reflectivity, scene.azimuth, scene.range, scene.height, False)
    if isinstance(scene, ReflectivityGrid):
        return _Scene(scene.reflectivity, scene.azimuth, scene.range, scene.height, True)
    raise ValueError(f"scene={type(scene).__name__} is not PointTargets or ReflectivityGrid")


def grid_azimuth_fft(values, n_x):
    """(n_lines, n_x) Σ_i v[j, i] e^{−jξ i Δx}: the azimuth DFT of grid rows, cell i at
    offset i from the grid's first row (see :func:`grid_azimuth_ramp` for the rest).

    Args:
        values: (n_lines, n_az) reflectivity, one row per range line.
    """
    # written into a zero buffer (an in-place update): the scene factors are computed once
    # per cell, not once per padded sample as a fused zero padding would
    padded = jnp.zeros(values.shape[:1] + (n_x,), values.dtype)
    padded = jax.lax.dynamic_update_slice(padded, values, (0, 0))
    return jnp.fft.fft(padded, axis=1)


def grid_azimuth_ramp(scene_azimuth, x0, xi):
    """(n_x,) e^{−jξ (x_0,grid − x0)}: the grid's first row relative to the DFT origin, at
    the true wavenumbers ξ (a grid on the pulse lattice sees every alias alike, so the
    FFT of its rows holds for any alias; the ramp takes the true ξ)."""
    return unit_phasor(-xi * (scene_azimuth[0] - x0))


def interp_motion(values, x_query, x0, dx):
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


@_exported.cached
@eqx.filter_jit
def _chirp_spectrum_program(chirp_rate, half_length, eta):
    return _chirp_spectrum(chirp_rate, half_length, eta)


def chirp_spectrum_values(chirp_rate, half_length, eta):
    """:func:`chirp_spectrum` as a NumPy array, for eager checks on concrete values: one
    compiled program per length bucket, kept between processes with the simulation
    programs (``_exported``), so a later process neither traces it nor imports SciPy.
    The wavenumbers are flattened and padded to a power of two (≥ 256): the checks ask
    for many lengths (every range FFT size and alias count; 50 in the test suite), which
    compiled one program each (0.5 s apiece). The chirp rate and half-length are passed
    as arrays, inputs of the program: as Python floats they were static arguments of the
    jitted function, and every radar compiled its own program (0.3 s of tracing, lowering
    and compiling each; 39 compiles in a run of the test suite)."""
    eta = np.asarray(eta, float)
    bucket = max(256, 1 << (eta.size - 1).bit_length())
    padded = np.zeros(bucket)
    padded[:eta.size] = eta.reshape(-1)
    with jax.ensure_compile_time_eval():  # one compiled program, not one per operation
        values = np.asarray(_chirp_spectrum_program(np.asarray(chirp_rate, float),
                                                    np.asarray(half_length, float), padded))
    return values[:eta.size].reshape(eta.shape)


def add_alias_bands(principal, band, bands):
    """``principal + Σ_{k = ±1 … ±bands} band(k)``: the Doppler alias bands ξ + 2πk/Δx
    (azimuth ambiguities) summed in one scan, so that they share one compiled program."""
    if not bands:
        return principal
    others = jnp.asarray([k for k in range(-bands, bands + 1) if k], float)
    return jax.lax.scan(lambda acc, k: (acc + band(k), None), principal, others)[0]


@functools.lru_cache(maxsize=256)
def _alias_column_count(chirp_rate, half_length, range_spacing, n_r, tolerance):
    eta = np.sort(2 * np.pi * np.fft.fftfreq(n_r, range_spacing))
    step = 2 * np.pi / range_spacing
    both = chirp_spectrum_values(chirp_rate, half_length, np.stack([eta, eta + step]))
    main, alias = np.abs(both) ** 2
    return alias_columns_kept(alias, main.sum(), tolerance)


def alias_columns_kept(alias, main, tolerance):
    """How many of an alias's columns, ``alias`` (their energies, from the band edge it
    enters), leave out at most ``tolerance`` of the main band's energy ``main``."""
    left_out = alias.sum() - np.cumsum(alias)  # energy beyond the first k + 1 columns
    if alias.sum() <= tolerance * main:
        return 0
    enough = np.flatnonzero(left_out <= tolerance * main)
    return int(enough[0] + 1) if enough.size else int(alias.size)  # else: every column




# --------------------------------------------------------------------------------------
# squint: true wavenumbers and the pattern at the stationary point
# --------------------------------------------------------------------------------------


def alias_shift(turns):
    """``round(turns)``, the whole periods 2π/Δx that bring a sampled wavenumber nearest
    the Doppler centroid, with the tie (``turns`` = k + ½: the bin at exactly ±PRF/2 from
    the centroid, which both aliases share, at broadside the Nyquist bin of an even grid)
    always resolved upward. Computed plainly, ``turns`` lands an ulp either side of the
    tie depending on how XLA fuses its arithmetic, so two compilations of one call (one
    device or several) would pick different aliases for that bin; ties closer than 1e-9
    of a period are resolved alike."""
    return jnp.floor(turns + (0.5 + 1e-9))


def squinted_wavenumbers(radar, n_x):
    """(n_x,) the alias ``ξ + 2πm/Δx`` of each sampled azimuth wavenumber nearest the
    Doppler centroid ``ξ_d = k₀ sin φ_d`` [rad/m] (DFT order kept; at broadside the DFT's
    own wavenumbers)."""
    period = _TWO_PI / radar.azimuth_spacing
    xi = period * jnp.fft.fftfreq(n_x, 1.0)
    xi_d = radar.wavenumber * jnp.sin(radar.squint)
    return xi + period * alias_shift((xi_d - xi) / period)


def squinted_pattern_argument(radar, xi):
    """``(u₀, ∂u*/∂η)`` at the stationary point ``a/r = −t``, ``t = ξ/√(η̄² − ξ²)``: the
    exact model's ``u = (a + r T)/(X (1 − aT/r))`` becomes ``u* = (L/λ)(T − t)/(1 + tT)``
    (``T = tan φ_d``); u₀ at η = 0 (dimensionless) and its slope in the range wavenumber
    [m/rad], each (n_x,). At broadside ``u₀ = −ξ L / (λ √(k₀² − ξ²))``."""
    k0 = radar.wavenumber
    kz = jnp.sqrt(k0**2 - xi**2)
    t = xi / kz
    T = jnp.tan(radar.squint)
    ratio = radar.antenna_length / radar.wavelength
    u0 = ratio * (T - t) / (1 + t * T)
    # ∂u/∂t · ∂t/∂η̄ at η̄ = k₀: −(1 + T²)/(1 + tT)² · (−ξ k₀ / kz³)
    slope = ratio * (1 + T**2) / (1 + t * T) ** 2 * xi * k0 / kz**3
    return u0, slope


def pattern_weights(radar, xi, max_order):
    """``[(w_n, w_n′) for n = 0 … max_order]``, each (n_x,): the n-th pointing term of the
    pattern at η = 0 and its slope in η, ``(−(L/λ)/(1 + tT))ⁿ W²⁽ⁿ⁾(u₀)/n!`` and
    ``… W²⁽ⁿ⁺¹⁾(u₀)/n! · ∂u*/∂η`` (seed 000 eq. 21–24, seed 002 eq. 34): the pattern
    applied as ``w_n + η w_n′``. u* moves with η through ``t``, by ≈ ξ/k₀ · η/k₀ relative
    (at 15° squint ≈ 0.02 across the band, a ≈ 7 % slope of the beam's flank); the next
    term is < 10⁻³. The pattern's derivatives of every order are formed together
    (:meth:`~sarjax.antenna.AbstractPattern.derivatives`)."""
    k0 = radar.wavenumber
    t = xi / jnp.sqrt(k0**2 - xi**2)
    u0, slope = squinted_pattern_argument(radar, xi)
    derivative = radar.pattern.derivatives(u0, max_order + 1)  # W²⁽ⁿ⁾(u₀), n ≤ max + 1
    step = -(radar.antenna_length / radar.wavelength) / (1 + t * jnp.tan(radar.squint))
    weights = []
    for n in range(max_order + 1):
        scale = step**n / math.factorial(n)
        weights.append((scale * derivative[n], scale * derivative[n + 1] * slope))
    return weights


def coupling_factors(los, alpha, order, dtype):
    """The per-(line, x') factors of :func:`coupled_inverse`, formed once for every line
    set: ``(e^{−jα δ̄}`` (n_lines, n_x) over ξ, ``[(−jδ)ⁿ/n!`` (n_lines, n_x) over x' for
    n = 1 … order]``), δ = δr_xr − δ̄ (δ̄ the mean over pulses of each line), in the
    complex ``dtype`` (phases in float64)."""
    mean = jnp.mean(los, axis=1, keepdims=True)  # (n_lines, 1)
    real = jnp.finfo(dtype).dtype
    delta = (los - mean).astype(real)
    coefs, coef = [], jnp.ones_like(delta, dtype=dtype)
    for n in range(1, order + 1):
        coef = coef * (-1j * delta) / n
        coefs.append(coef)
    return reduced_phasor(-alpha[None, :] * mean, dtype), coefs


def coupled_inverse(lines, alpha, factors):
    """(n_lines, n_x) ``Σ_ξ Y(ξ) e^{jξx'} e^{−jα(ξ) δ(x')}`` by a Taylor series in
    ``δ − δ̄`` of the order of ``factors`` (:func:`coupling_factors`)."""
    base_phasor, coefs = factors
    base = lines * base_phasor
    alpha = alpha.astype(jnp.finfo(lines.dtype).dtype)
    out = jnp.fft.ifft(base, axis=-1)
    term = base
    for coef in coefs:
        term = term * alpha[None, :]
        out = out + coef * jnp.fft.ifft(term, axis=-1)
    return out


def line_height_under_beam(prepared, x_full, ranges, tan_squint):
    """(n_lines, n_x) grid height at the scatterer the beam centre of pulse x' crosses on
    each line, ``x = x' + r_j tan φ_d`` (nearest grid row; beyond the grid, its edge row:
    the cells the beam sees then are those nearest the edge)."""
    az = prepared.azimuth
    step = jnp.where(az.shape[0] > 1, az[-1] - az[0], 1.0) / jnp.maximum(az.shape[0] - 1, 1)
    x_beam = x_full[None, :] + ranges[:, None] * tan_squint
    idx = jnp.round((x_beam - az[0]) / step).astype(jnp.int32)
    heights = prepared.height.T  # (n_lines, n_az)
    return jnp.take_along_axis(heights, jnp.clip(idx, 0, az.shape[0] - 1), axis=1)
