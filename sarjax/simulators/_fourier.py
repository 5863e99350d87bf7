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
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import geometry
from ..processing._interpolation import next_fast_len, sinc_interpolate
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
    b = radar.chirp_rate
    half = radar.pulse_half_length
    scale = jnp.sqrt(2 * b / jnp.pi)
    t1 = (-half + eta / (2 * b)) * scale
    t2 = (half + eta / (2 * b)) * scale
    s1, c1 = jax.scipy.special.fresnel(t1)
    s2, c2 = jax.scipy.special.fresnel(t2)
    return (
        jnp.exp(1j * eta**2 / (4 * b))
        * jnp.sqrt(jnp.pi / (2 * b))
        * ((c2 - c1) - 1j * (s2 - s1))
    )


def stationary_amplitude(radar, xi, slant_range):
    """A(ξ, r) = (1/Δx) √(2π k₀² r / (k₀² − ξ²)^{3/2}) e^{−jπ/4} (azimuth POSP)."""
    k0 = radar.wavenumber
    kz2 = k0**2 - xi**2
    mag = jnp.sqrt(2 * jnp.pi * k0**2 * slant_range / kz2**1.5) / radar.azimuth_spacing
    return mag * jnp.exp(-1j * jnp.pi / 4)


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
    """Direct sum over range lines.

    Args:
        lines: (n_x, n_lines) F_j(ξ).
        line_ranges: (n_lines,) r_j [m].
        kappa: (n_x, n_r) κ(ξ, η) [rad/m].

    Returns:
        (n_x, n_r) Σ_j F_j(ξ) e^{−jκ r_j}.
    """
    n_lines = lines.shape[1]
    chunk = min(chunk, n_lines)
    n_chunks = -(-n_lines // chunk)
    pad = n_chunks * chunk - n_lines
    lines_p = jnp.pad(lines, ((0, 0), (0, pad))).T.reshape(n_chunks, chunk, -1)
    ranges_p = jnp.pad(line_ranges, (0, pad), constant_values=line_ranges[0]).reshape(
        n_chunks, chunk
    )
    r_c = line_ranges[0]

    def body(acc, block):
        f, r = block  # (chunk, n_x), (chunk,)
        phase = kappa[None, :, :] * (r - r_c)[:, None, None]
        return acc + jnp.sum(f[:, :, None] * jnp.exp(-1j * phase), axis=0), None

    init = jnp.zeros(kappa.shape, lines.dtype)
    out, _ = jax.lax.scan(body, init, (lines_p, ranges_p))
    return out * jnp.exp(-1j * kappa * r_c)


def synthesize_grid(lines, first_range, range_step, kappa, taps=8):
    """Inverse Stolt mapping over a uniform range grid r_j = r₀ + j Δr.

    Σ_j F_j e^{−jκ r_j} = e^{−jκ r_c} D(κ Δr), ``D(ω) = Σ_j F_j e^{−jω(j − j_c)}`` the
    2π-periodic DTFT about the middle line ``j_c`` (so its harmonics span ±n/2), sampled
    by a 2×-oversampled FFT and interpolated with a windowed sinc.
    """
    n_lines = lines.shape[1]
    p = next_fast_len(2 * n_lines)
    centre = n_lines // 2
    padded = jnp.roll(jnp.pad(lines, ((0, 0), (0, p - n_lines))), -centre, axis=1)
    dtft = jnp.fft.fft(padded, axis=1)  # D(ω_k), ω_k = 2πk/p
    dtft = jax.lax.optimization_barrier(dtft)
    position = kappa * range_step * (p / (2 * jnp.pi))
    out = sinc_interpolate(dtft, position, taps=taps, periodic=True)
    return out * jnp.exp(-1j * kappa * (first_range + centre * range_step))


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


def _grid_azimuth_fft(values, scene_azimuth, x0, dx, n_x):
    """(n_x, n_lines) Σ_i v[i, j] e^{−jξ(x_i − x0)} for grid rows aligned on the pulses."""
    first = jnp.round((scene_azimuth[0] - x0) / dx)
    frac = (scene_azimuth[0] - x0) / dx - first
    spectrum = jnp.fft.fft(values, n=n_x, axis=0)  # rows at offsets 0 … n_az−1
    xi = 2 * jnp.pi * jnp.fft.fftfreq(n_x, dx)
    return spectrum * jnp.exp(-1j * xi * (first + frac) * dx)[:, None]


def _interp_motion(values, x_query, x0, dx):
    """Linear interpolation of per-pulse values at azimuths x (edge values outside)."""
    position = jnp.clip((x_query - x0) / dx, 0.0, values.shape[0] - 1.0)
    i0 = jnp.clip(jnp.floor(position).astype(jnp.int32), 0, values.shape[0] - 2)
    t = position - i0
    return values[i0] * (1 - t) + values[i0 + 1] * t


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
        coupling_order: moderate deviation only: Taylor order of the coupling correction
            (0 = the seed's Algorithm B). The seed neglects
            ``ϕ = √((r + δ)² + (x' − x)²) − √(r² + (x' − x)²) − δ ≈ δ (r/R − 1)``
            (its condition (11)); with ``r/R = √(k₀² − ξ²)/k₀`` at the stationary point,
            ``k₀ϕ = α(ξ) δ(x')``, ``α = √(k₀² − ξ²) − k₀``, a product of a ξ- and an
            x'-function, applied here by a Taylor series in δ about its mean.
        envelope_correction: moderate deviation only: apply the range-envelope shift of
            ψ(x', r) to first order (``e^{−jηψ} ≈ 1 − jηψ``, one extra range synthesis);
            the seed neglects it (its condition (12), ``η_max |ψ| ≪ 1``).
    """

    pointing_order: int = eqx.field(static=True, default=2)
    azimuth_padding: float = eqx.field(static=True, default=1.0)
    taps: int = eqx.field(static=True, default=8)
    range_aliases: int = eqx.field(static=True, default=1)
    coupling_order: int = eqx.field(static=True, default=3)
    envelope_correction: bool = eqx.field(static=True, default=True)
    azimuth_pad: int | None = eqx.field(static=True, default=None)
    range_fft_size: int | None = eqx.field(static=True, default=None)
    alias_columns: int | None = eqx.field(static=True, default=None)

    def prepare(self, radar, scene, acquisition):
        """Check grid scenes; fix the padding and FFT sizes from concrete values."""
        if isinstance(scene, ReflectivityGrid):
            check_grid_scene(scene, radar)
        if self.azimuth_pad is not None and self.range_fft_size is not None:
            return self
        footprint = float(radar.footprint(np.max(np.asarray(scene.range))))
        pad = int(math.ceil(self.azimuth_padding * footprint / float(radar.azimuth_spacing)))
        pad = -(-pad // 128) * 128  # coarse steps: new target ranges rarely recompile
        chirp = int(float(radar.chirp_samples)) + 2
        n_r = next_fast_len(acquisition.num_range + chirp)
        # columns per range alias where |C(η ± 2π/Δr)| exceeds 1e-4 of the peak
        eta = np.asarray(range_wavenumbers(radar, n_r))
        peak = float(np.max(np.abs(np.asarray(chirp_spectrum(radar, eta)))))
        shifted = np.abs(np.asarray(chirp_spectrum(radar, np.sort(eta) + 2 * np.pi / float(
            radar.range_spacing))))
        significant = np.flatnonzero(shifted > 1e-4 * peak)
        columns = int(significant.max() + 1) if significant.size else 0
        return dataclasses.replace(
            self, azimuth_pad=pad, range_fft_size=n_r, alias_columns=columns
        )

    def _run(self, radar, scene, motion, acquisition, dtype, mode):
        n_pulses, n_range = acquisition.num_pulses, acquisition.num_range
        prepared = prepare_scene(scene)
        # static sizes fixed by prepare() (eagerly); without it, generous defaults
        pad = n_pulses if self.azimuth_pad is None else self.azimuth_pad
        n_r = self.range_fft_size or next_fast_len(2 * n_range)
        n_x = next_fast_len(n_pulses + 2 * pad)

        dx = radar.azimuth_spacing
        k0 = radar.wavenumber
        x_pulses = acquisition.pulse_azimuths(radar)
        x0 = x_pulses[0] - pad * dx  # DFT origin: the padded window starts pad pulses early
        xi = azimuth_wavenumbers(radar, n_x)
        eta = range_wavenumbers(radar, n_r)
        horizontal, vertical, pointing = motion.resolve(n_pulses)
        # padded per-pulse motion (edge values continue beyond the acquisition)
        dy_full = jnp.pad(horizontal, (pad, n_x - n_pulses - pad), mode="edge")
        dz_full = jnp.pad(vertical, (pad, n_x - n_pulses - pad), mode="edge")
        x_full = x0 + jnp.arange(n_x) * dx

        u_star = stationary_pattern_argument(radar, xi)
        alpha = jnp.sqrt(k0**2 - xi**2) - k0  # azimuth phase per metre of range [rad/m]
        delta_r = geometry.reference_deviation(dy_full, dz_full, radar)  # δr(x'), (n_x,)
        orders = range(self.pointing_order + 1) if mode != "ideal" else range(1)
        if mode != "ideal" and motion.pointing is None:
            orders = range(1)

        kappa_fn = _kappa_b if mode == "moderate" else _kappa_full
        alias_step = 2 * jnp.pi / radar.range_spacing
        # alias m only matters for the columns whose η + 2πm/Δr lies near the band edge:
        # a static count per alias (prepare()), taken next to the Nyquist column
        half = n_r // 2
        alias_sets = []  # (column indices or None for all, wavenumbers)
        for m in range(-self.range_aliases, self.range_aliases + 1):
            if m == 0:
                alias_sets.append((0, None, eta + 0.0))
                continue
            count = n_r if self.alias_columns is None else min(self.alias_columns, n_r)
            if count == 0:
                continue
            if count >= n_r:
                alias_sets.append((m, None, eta + m * alias_step))
                continue
            # m > 0 reaches the upper band edge from the most negative η (columns half…)
            cols = (half + np.arange(count)) if m > 0 else (half - 1 - np.arange(count))
            cols = np.mod(cols, n_r)
            alias_sets.append((m, cols, eta[cols] + m * alias_step))

        def row_weight(order):
            """(n_x,) the n-th pattern term at the stationary point, (−L/λ)ⁿ W²⁽ⁿ⁾(u*)/n!."""
            scale = (-radar.antenna_length / radar.wavelength) ** order
            return scale * pattern_term(radar.pattern, order)(u_star)

        def line_spectra(order, envelope=False):
            """(n_x, n_lines) F_j(ξ), with pattern term ``order`` (None: no pattern). With
            ``envelope`` (moderate only) the lines weighted by ψ(x', r_j) in x', for the
            first-order range-envelope correction."""
            if prepared.gridded:
                gamma = prepared.reflectivity  # (n_az, n_lines)
                xs = prepared.azimuth[:, None]
                rs = prepared.ranges[None, :]
                hs = prepared.height
            else:
                gamma = prepared.reflectivity[None, :]
                xs = prepared.azimuth[None, :]
                rs = prepared.ranges[None, :]
                hs = prepared.height[None, :]
            if mode == "small":
                # γ̃ = γ exp[−j k₀ ψ(x, r)]: ψ at the pulse above the scatterer
                dy_s = _interp_motion(horizontal, xs, x_pulses[0], dx)
                dz_s = _interp_motion(vertical, xs, x_pulses[0], dx)
                psi = geometry.range_variant_deviation(dy_s, dz_s, rs, hs, radar)
                gamma = gamma * jnp.exp(-1j * k0 * psi)
            carrier = jnp.exp(-1j * jnp.mod(k0 * prepared.ranges, _TWO_PI))  # (n_lines,)
            if prepared.gridded:
                spectrum = _grid_azimuth_fft(gamma, prepared.azimuth, x0, dx, n_x)
            else:
                spectrum = gamma * jnp.exp(-1j * xi[:, None] * (prepared.azimuth[None, :] - x0))
            amp = stationary_amplitude(radar, xi[:, None], prepared.ranges[None, :])
            weight = amp if order is None else amp * row_weight(order)[:, None]
            if mode == "moderate":
                g_a_phase = (jnp.sqrt(k0**2 - xi**2) - k0)[:, None] * prepared.ranges[None, :]
                lines = spectrum * weight * jnp.exp(-1j * g_a_phase)
                # motion phase exp[−j k₀ ψ(x', r_j)] with the scene height under the pulse
                if prepared.gridded:
                    h_line = _line_height_under_pulses(prepared, x_full)
                else:
                    h_line = prepared.height[None, :]
                los = geometry.line_of_sight_deviation(
                    dy_full[:, None], dz_full[:, None], prepared.ranges[None, :], h_line,
                    radar.height,
                )  # δr_xr(x', r_j) = ψ + δr  (n_x, n_lines)
                psi = los - delta_r[:, None]
                if self.coupling_order:
                    along = _coupled_inverse(lines, los, alpha, self.coupling_order)
                else:
                    along = jnp.fft.ifft(lines, axis=0)  # (x', line): the seed's B
                along = along * jnp.exp(-1j * k0 * psi)
                if envelope:
                    # envelope shift ψ, plus the migration error of the Doppler shift
                    # −k₀ ∂ψ/∂x' (the migration at ξ sits at r k₀/√(k₀² − ξ²): moved by
                    # −(r ξ/k₀) ∂ψ/∂x'), both to first order
                    slope = jnp.gradient(psi, axis=0) / dx
                    doppler = (xi[:, None] * prepared.ranges[None, :] / k0) * jnp.fft.fft(
                        along * slope, axis=0
                    )
                    lines = jnp.fft.fft(along * psi, axis=0) + doppler
                else:
                    lines = jnp.fft.fft(along, axis=0)
            else:
                lines = spectrum * weight
            return lines * carrier[None, :]

        near = acquisition.near_range

        def synthesize(lines, envelope=False, all_aliases=True):
            """Per range alias m: (1/Δr) C(η_m) e^{jη_m r'_0} Σ_j F_j e^{−jκ(ξ, η_m) r_j}, as a
            list of (ξ, columns) arrays (None for skipped aliases); with ``envelope`` also
            multiplied by −jη_m; ``all_aliases=False`` keeps only m = 0."""
            out = []
            for m, _cols, eta_m in alias_sets:
                if m and not all_aliases:
                    out.append(None)
                    continue
                kappa = kappa_fn(radar, xi[:, None], eta_m[None, :])
                if prepared.gridded and prepared.ranges.shape[0] > 1:
                    step = prepared.ranges[1] - prepared.ranges[0]
                    # the aliases carry ≲ −20 dB of the echo: 4 taps (≈ −30 dB) suffice there
                    taps = self.taps if m == 0 else min(self.taps, 4)
                    summed = synthesize_grid(lines, prepared.ranges[0], step, kappa, taps=taps)
                else:
                    summed = synthesize_direct(lines, prepared.ranges, kappa)
                factor = chirp_spectrum(radar, eta_m) * jnp.exp(1j * eta_m * near)
                if envelope:
                    factor = factor * (-1j * eta_m)
                out.append(summed * (factor / radar.range_spacing)[None, :])
            return out

        pointing_full = jnp.pad(pointing, (pad, n_x - n_pulses - pad))
        # δx/X = (r + δr_xr) δ_az / X ≈ (L/λ)(1 + δr/r₀) δ_az; (−L/λ)ⁿ is in line_spectra
        pointing_scale = (1 + delta_r / radar.reference_range) * pointing_full
        if mode == "moderate":  # the pattern precedes the motion phase: one synthesis each
            # pointing terms are ≲ 5 % of the echo: their range aliases (≲ −25 dB of them)
            # are negligible, so they are synthesised for the main alias only
            spectra = [synthesize(line_spectra(order), all_aliases=order == 0)
                       for order in orders]
            if self.envelope_correction:
                # range envelope of ψ (the seed's condition (12)) to first order,
                # e^{−jηψ} ≈ 1 − jηψ, on the main term (pointing terms are already small)
                correction = synthesize(line_spectra(0, envelope=True), True)
                spectra[0] = [a + b for a, b in zip(spectra[0], correction, strict=True)]
        else:  # the pattern is a per-ξ factor: synthesise once, weight per order
            common = [None if a is None else jax.lax.optimization_barrier(a)
                      for a in synthesize(line_spectra(None))]
            spectra = [
                [None if (a is None or (m and order)) else a * row_weight(order)[:, None]
                 for (m, _, _), a in zip(alias_sets, common, strict=True)]
                for order in orders
            ]

        # per pulse: Σ_n δ_azⁿ h̃_n, then the deviation δr(x') shifts envelope and phase,
        # exp[−j(η_m + k₀) δr(x')], separately for each range alias (a fractional shift of
        # the sampled echo moves each alias with its own wavenumber)
        keep = slice(pad, pad + n_pulses)  # per-pulse work only on the acquired pulses
        scale_kept = pointing_scale[keep]
        delta_kept = delta_r[keep]
        total = jnp.zeros((n_r, n_pulses), jnp.complex128)  # (η, x'): FFTs on the last axis
        for index, (_, cols, eta_m) in enumerate(alias_sets):
            per_alias = 0.0
            for order, per_order in zip(orders, spectra, strict=True):
                if per_order[index] is None:
                    continue
                along = jnp.fft.ifft(per_order[index].T, axis=-1)[:, keep]  # (η, x')
                per_alias = per_alias + along * (scale_kept**order)[None, :]
            if mode != "ideal":
                per_alias = per_alias * jnp.exp(-1j * (eta_m[:, None] + k0) * delta_kept[None, :])
            total = total + per_alias if cols is None else total.at[cols, :].add(per_alias)
        raw = jnp.fft.ifft(total.T, axis=1)[:, :n_range]
        return raw.astype(dtype)


def _coupled_inverse(lines, los, alpha, order):
    """(n_x, n_lines) ``Σ_ξ Y(ξ) e^{jξx'} e^{−jα(ξ) δ(x')}`` by a Taylor series of order
    ``order`` in ``δ − δ̄`` (δ̄ the mean over pulses of each line)."""
    mean = jnp.mean(los, axis=0, keepdims=True)  # (1, n_lines)
    base = lines * jnp.exp(-1j * alpha[:, None] * mean)
    delta = los - mean
    out = jnp.fft.ifft(base, axis=0)
    term = base
    coef = jnp.ones_like(delta, dtype=base.dtype)
    for n in range(1, order + 1):
        term = term * alpha[:, None]
        coef = coef * (-1j * delta) / n
        out = out + coef * jnp.fft.ifft(term, axis=0)
    return out


def _line_height_under_pulses(prepared, x_full):
    """(n_x, n_lines) grid height h(x', r_j) at the pulse azimuths (nearest grid row; 0
    outside the grid)."""
    az = prepared.azimuth
    step = jnp.where(az.shape[0] > 1, az[-1] - az[0], 1.0) / jnp.maximum(az.shape[0] - 1, 1)
    idx = jnp.round((x_full - az[0]) / step).astype(jnp.int32)
    inside = (idx >= 0) & (idx < az.shape[0])
    rows = prepared.height[jnp.clip(idx, 0, az.shape[0] - 1)]
    return jnp.where(inside[:, None], rows, 0.0)


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
