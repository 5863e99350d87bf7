"""Multi-look map drift: a coarse motion estimate from the backscatter's structure.

The phase-gradient stage of :func:`sarjax.inverse.autofocus` needs isolated dominant
scatterers; where the scene has few, or where the initial error blurs them into the
clutter, it can settle in a wrong optimum of the sharpness. The backscatter's structure
(field edges, roads, bright areas) carries the error too, in a form that survives the
speckle: the image formed from one part of the Doppler band (one *look*) is displaced.

A scatterer at (x, r) is seen at the azimuth wavenumber ξ from the pulse
x' = x − r ξ/k₀ (k₀ = 4π/λ; broadside stationary phase). A residual line-of-sight phase
e(x', r) = k₀ δr_xr(x', r) (what is left after compensating the current estimate) adds
its gradient to the history there, so that the look centred at ξ_l images the scatterer at

    x + Δx_l(x),    Δx_l(x) = −(r/k₀) ∂e/∂x' (x − r ξ_l/k₀)

(Mancill & Swiger 1981; Calloway & Donohoe 1994 for many looks). The absolute displacement
is not observable (the scene's position is unknown); the displacement of adjacent looks
relative to each other is: the cross-correlation of their speckled amplitudes over a tile
(a range block × an azimuth segment) peaks at Δx_{l+1} − Δx_l. With
e = k₀ (−Δy sin ϑ + Δz cos ϑ) to first order (ϑ the look angle at the block's range), each
tile and pair of looks gives one linear equation in the B-spline coefficients of Δy and
Δz; the best-correlated quarter of them, weighted by their normalised peak, is solved by
ridge-regularised least squares for an increment of the estimate.

Accuracy: speckle limits each displacement to ≈ 1.6 m rms (16 looks, tiles of X/4 ×
a sixth of the swath, the benchmark's clutter at the true track), so the estimate is
coarse: eight steps bring the benchmark draws' 2.6–7.6 rad of line-of-sight phase
(aperture-detrended) to 0.75–3.5 rad, and from the true track they walk 0.8–3.2 rad away.
That is why :func:`sarjax.inverse.autofocus` keeps a step only when it sharpens the
windows about the dominant scatterers, and why the finer stages follow.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from .._numerics.interpolation import next_fast_len
from ._sharpness import AzimuthFocuser


def look_geometry(focuser: AzimuthFocuser, num_looks: int):
    """Look centres ξ_l [rad/m] (num_looks,), the triangular look windows' half-width
    [rad/m] and the decimated image length K (samples over the padded azimuth period).

    The looks tile the antenna's two-way Doppler band |ξ| ≤ k₀ X/(2r) (X the footprint at
    r) with 50 % overlap; each look's amplitude is sampled at 2.5× the Nyquist rate of
    its intensity."""
    radar = focuser.radar
    r0 = float(radar.reference_range)
    k0 = float(radar.wavenumber)
    band = k0 * float(radar.footprint(r0)) / (2 * r0)
    centres = np.linspace(-band, band, num_looks + 2)[1:-1]
    half = float(centres[1] - centres[0]) if num_looks > 1 else band
    n_fft = int(focuser.compressed.shape[-1])
    spacing = float(radar.azimuth_spacing)
    # a look's intensity occupies |ξ| ≤ 2·half: sampled at 2.5× the rate that needs
    # (4·half rad/m), so that the correlation peak is resolved
    period = n_fft * spacing
    length = next_fast_len(int(np.ceil(2.5 * period * 4 * half / (2 * np.pi))))
    return centres, half, min(length, n_fft)


@functools.partial(jax.jit, static_argnames=("length",))
def look_amplitudes(focuser: AzimuthFocuser, phase, centres, half, length):
    """(look, range, K) amplitudes |I_l(x, r)| of the looks after compensating ``phase``
    ((range, pulse) [rad]), on K samples over the padded azimuth period.

    Each look is the focused spectrum times a triangular window of half-width ``half``
    about ξ_l, shifted to baseband and inverse-transformed on K points (the amplitude does
    not depend on the shift)."""
    n_fft = focuser.compressed.shape[-1]
    spacing = focuser.radar.azimuth_spacing
    spectrum = focuser.spectrum(phase)
    d_xi = 2 * jnp.pi / (n_fft * spacing)
    offsets = jnp.fft.fftfreq(length, 1.0 / length).astype(jnp.int32)  # baseband bins

    def one(centre):
        bins = jnp.round(centre / d_xi).astype(jnp.int32) + offsets
        window = jnp.clip(1.0 - jnp.abs(bins * d_xi - centre) / half, 0.0, None)
        look = spectrum[:, bins % n_fft] * window.astype(spectrum.dtype)[None, :]
        return jnp.abs(jnp.fft.ifft(look, axis=-1))

    return jax.lax.map(one, centres)


def look_displacements(amplitudes, row_blocks, segment: int, max_lag: int,
                       separation: int = 1):
    """Relative displacement of looks ``separation`` apart per tile, by amplitude
    cross-correlation.

    Args:
        amplitudes: (look, range, K) from :func:`look_amplitudes`.
        row_blocks: list of (start, stop) range-row slices.
        segment: tile length [samples] (tiles overlap by half).
        max_lag: largest displacement searched [samples].
        separation: s, the pairs (l, l + s) compared.

    Returns:
        (block, tile, look − s) displacement of look l+s relative to look l [samples],
        (block, tile, look − s) normalised correlation peak, and (tile,) the tiles' first
        samples.
    """
    a = np.asarray(amplitudes)
    num_looks, _, length = a.shape
    starts = np.arange(0, length - segment + 1, segment // 2)
    taper = np.hanning(segment)
    cols = starts[:, None] + np.arange(segment)[None, :]
    shifts, peaks = [], []
    for lo, hi in row_blocks:
        tiles = a[:, lo:hi][:, :, cols]  # (look, rows, tile, segment)
        tiles = (tiles - tiles.mean(axis=-1, keepdims=True)) * taper
        spectra = np.fft.rfft(tiles, 2 * segment, axis=-1)
        sep = separation
        cross = np.sum(np.conj(spectra[:-sep]) * spectra[sep:], axis=1)  # (look−s, tile, f)
        corr = np.fft.irfft(cross, 2 * segment, axis=-1)
        corr = np.concatenate([corr[..., -max_lag:], corr[..., : max_lag + 1]], axis=-1)
        power = np.sum(tiles**2, axis=(1, -1))  # (look, tile): the zero-lag autocorrelation
        norm = np.sqrt(power[:-sep] * power[sep:]) + 1e-300
        k = np.clip(np.argmax(corr, axis=-1), 1, 2 * max_lag - 1)
        y0, y1, y2 = (np.take_along_axis(corr, (k + d)[..., None], -1)[..., 0]
                      for d in (-1, 0, 1))
        curvature = y0 - 2 * y1 + y2
        frac = np.where(curvature < 0, 0.5 * (y0 - y2) / np.where(curvature < 0, curvature, -1),
                        0.0)
        shifts.append((k - max_lag + np.clip(frac, -0.5, 0.5)).T)
        peaks.append((y1 / norm).T)
    return np.stack(shifts), np.stack(peaks), starts


def displacement_rows(focuser: AzimuthFocuser, derivatives, block_ranges, starts,
                      segment: int, sample: float, centres, separation: int = 1,
                      min_inside: float = 0.8):
    """Linear model of :func:`look_displacements`: (block, tile, look − 1, basis_y +
    basis_z) rows mapping the increments of the Δy and Δz coefficients [m] to the
    displacement [m], and a (block, tile, look − 1) mask of the equations whose looks see
    the pulses (at least ``min_inside`` of the tile's pulse positions x − r ξ_l/k₀ lie
    within the pulses).

    ``derivatives``: (∂B_y/∂x', ∂B_z/∂x'), each (pulse, basis) [1/m], of the B-spline
    designs of Δy and Δz."""
    radar = focuser.radar
    k0 = float(radar.wavenumber)
    height = float(radar.height)
    x = np.asarray(focuser.azimuth, float)
    spacing = float(radar.azimuth_spacing)
    taper = np.hanning(segment)
    design = np.concatenate(derivatives, axis=1)
    split = derivatives[0].shape[1]
    rows = np.zeros((len(block_ranges), starts.size, centres.size - separation,
                     design.shape[1]))
    mask = np.zeros(rows.shape[:-1], bool)
    for b, r in enumerate(block_ranges):
        cos_t = height / r
        sin_t = np.sqrt(max(1.0 - cos_t**2, 0.0))
        for t, s in enumerate(starts):
            xc = x[0] + (s + np.arange(segment)) * sample  # image positions of the tile
            slopes = []
            for c in centres:  # (basis,) ∂Δx_l/∂c per unit coefficient: −r ∂B/∂x'
                xp = xc - r * c / k0
                inside = (xp >= x[0]) & (xp <= x[-1])
                weight = taper * inside
                if inside.mean() < min_inside:
                    slopes.append(None)
                    continue
                index = np.clip(np.round((xp - x[0]) / spacing).astype(int), 0, x.size - 1)
                slopes.append(-r * (weight @ design[index]) / weight.sum())
            for ell in range(centres.size - separation):
                if slopes[ell] is None or slopes[ell + separation] is None:
                    continue
                g = slopes[ell + separation] - slopes[ell]
                rows[b, t, ell] = np.concatenate([-sin_t * g[:split], cos_t * g[split:]])
                mask[b, t, ell] = True
    return rows, mask


def map_drift_increment(focuser: AzimuthFocuser, phase, derivatives, *,
                        num_looks: int = 16, num_blocks: int = 6, segment_m: float | None = None,
                        keep: float = 0.25, ridge: float = 3e-2, separations=(1,)):
    """One map-drift step: (Δc_y, Δc_z) [m] increments of the B-spline coefficients from
    the looks of the data compensated by ``phase``, and the number of equations used.

    Args:
        focuser: the :class:`AzimuthFocuser`.
        phase: (range, pulse) line-of-sight phase of the current estimate [rad].
        derivatives: (∂B_y/∂x', ∂B_z/∂x'), each (pulse, basis) [1/m]: the derivatives of
            the B-spline designs of Δy and Δz.
        num_looks: looks across the Doppler band (adjacent pairs give the equations).
        num_blocks: range blocks (rows of the kept range bins).
        segment_m: tile length [m] (default X/6, X the footprint at the reference range).
        keep: fraction of the equations kept, the best-correlated.
        ridge: Tikhonov weight relative to the mean diagonal of the normal equations.
        separations: the look separations s whose pairs (l, l + s) give equations. On five
            benchmark draws (100, 103, 106 at 2 cm; 201, 205 at 5 cm), eight steps with
            (1, 2) left a worst block smaller on four (e.g. 1.33 → 0.75 rad) and larger on
            one (10.5 → 11.6 rad), at 1.7× the time per step (0.83 against 0.50 s); (2,)
            alone was worse than (1,) on three.
    """
    radar = focuser.radar
    centres, half, length = look_geometry(focuser, num_looks)
    sample = int(focuser.compressed.shape[-1]) * float(radar.azimuth_spacing) / length
    if segment_m is None:
        segment_m = float(radar.footprint(radar.reference_range)) / 6
    segment = max(int(round(segment_m / sample)), 8)
    max_lag = max(segment // 3, 2)
    amplitudes = look_amplitudes(focuser, jnp.asarray(phase), jnp.asarray(centres),
                                 float(half), length)
    n_rows = int(focuser.range.shape[0])
    edges = np.linspace(0, n_rows, num_blocks + 1).astype(int)
    row_blocks = list(zip(edges[:-1], edges[1:], strict=True))
    ranges = np.asarray(focuser.range, float)
    block_ranges = [float(ranges[lo:hi].mean()) for lo, hi in row_blocks]
    y, q, a = [], [], []
    for sep in separations:
        shifts, peaks, starts = look_displacements(amplitudes, row_blocks, segment, max_lag,
                                                   sep)
        rows, mask = displacement_rows(focuser, derivatives, block_ranges, starts, segment,
                                       sample, centres, sep)
        y.append(shifts[mask] * sample)
        q.append(peaks[mask])
        a.append(rows[mask])
    y, q, a = np.concatenate(y), np.concatenate(q), np.concatenate(a)
    if y.size < a.shape[1]:
        return None, int(y.size)
    chosen = q >= np.quantile(q, 1.0 - keep)
    w = np.clip(q[chosen], 0.0, None)
    aw = a[chosen] * w[:, None]
    normal = aw.T @ aw
    lam = ridge * np.trace(normal) / normal.shape[0]
    c = np.linalg.solve(normal + lam * np.eye(normal.shape[0]), aw.T @ (y[chosen] * w))
    n = derivatives[0].shape[1]
    return (c[:n], c[n:]), int(chosen.sum())
