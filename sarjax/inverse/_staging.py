"""Cold-start stages of :func:`sarjax.fit_motion` (NumPy, outside jit).

The least-squares cost on the raw phase has a local minimum every ≈ λ/2 of line-of-sight
deviation, so the joint fit starts from estimates made on the range-compressed data:

1. *envelopes*: per pulse and scatterer, the position of the compressed peak near the
   nominal range R_n gives R − R_n to a fraction of the range resolution; a weighted
   least-squares fit of the smooth deviation model to these (weights |peak|²) gives a
   coarse, smooth line-of-sight estimate for every scatterer;
2. *phase*: the compressed sample at the predicted range carries exp(−j4πR/λ); its phase
   relative to the prediction varies slowly from pulse to pulse (the coarse estimate's
   error is smooth), so it unwraps safely from the strongest pulse outward; the unwrapped
   phase gives R to a fraction of λ (up to one constant per scatterer, which the
   reflectivity phase absorbs), and a second weighted fit gives Δy, Δz;
3. *jitter*: the pointing error shifts each scatterer's two-way pattern W²((x' − x −
   r δ_az)/X); the compressed amplitudes give a per-pulse δ_az (linearised in δ_az) and a
   weighted periodogram of it the jitter period, then linear least squares its amplitude
   and phase.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from ._parametrisations import SinusoidalJitter

UPSAMPLE = 16


def upsample_lines(compressed, factor=UPSAMPLE):
    """Band-limited (FFT zero-padding at the Nyquist bin) upsampling of (azimuth, range)
    lines; sample k/factor of the output is r'_0 + (k/factor)·Δr."""
    n = compressed.shape[-1]
    spec = jnp.fft.fft(compressed, axis=-1)
    half = (n + 1) // 2
    padded = jnp.zeros(compressed.shape[:-1] + (n * factor,), spec.dtype)
    padded = padded.at[..., :half].set(spec[..., :half])
    padded = padded.at[..., n * factor - (n - half):].set(spec[..., half:])
    return np.asarray(jnp.fft.ifft(padded, axis=-1) * factor)


def sample_lines(lines_up, position):
    """Linear interpolation of upsampled lines at fractional upsampled positions
    ``position`` (azimuth, target)."""
    base = np.clip(np.floor(position).astype(int), 0, lines_up.shape[-1] - 2)
    frac = position - base
    rows = np.arange(lines_up.shape[0])[:, None]
    return lines_up[rows, base] * (1 - frac) + lines_up[rows, base + 1] * frac


def envelope_peaks(lines_up, nominal_position, search):
    """Peak of |line| within ±search upsampled samples of ``nominal_position``
    (azimuth, target): (position, amplitude), parabolic refinement on |·|²."""
    offsets = np.arange(-search, search + 1)
    centre = np.rint(nominal_position).astype(int)
    idx = np.clip(centre[..., None] + offsets, 1, lines_up.shape[-1] - 2)
    rows = np.arange(lines_up.shape[0])[:, None, None]
    power = np.abs(lines_up[rows, idx]) ** 2
    k = np.argmax(power, axis=-1)
    best = np.take_along_axis(idx, k[..., None], axis=-1)[..., 0]
    p0 = np.abs(lines_up[rows[..., 0], best - 1]) ** 2
    p1 = np.abs(lines_up[rows[..., 0], best]) ** 2
    p2 = np.abs(lines_up[rows[..., 0], best + 1]) ** 2
    denom = p0 - 2 * p1 + p2
    shift = np.where(denom < 0, 0.5 * (p0 - p2) / np.where(denom < 0, denom, -1.0), 0.0)
    return best + np.clip(shift, -0.5, 0.5), np.sqrt(p1)


def linear_design(model, azimuth, line_of_sight):
    """(azimuth, 2, K) design of (Δy, Δz) on the deviation parameters (gauge included),
    and the split of K between horizontal and vertical."""
    x = jnp.asarray(azimuth)

    def dev(params_h, params_v):
        dy = model.horizontal(params_h, x)
        if line_of_sight is not None:
            s, c = line_of_sight
            return jnp.stack([-s * dy, c * dy], axis=-1)
        dz = model.vertical(params_v, x)
        return jnp.stack([dy, dz], axis=-1)

    kh = model.horizontal.num_params()
    kv = 0 if (line_of_sight is not None or model.vertical is None) else \
        model.vertical.num_params()
    zh, zv = jnp.zeros(kh), jnp.zeros(kv)
    jh = jax.jacfwd(dev, argnums=0)(zh, zv)
    jv = jax.jacfwd(dev, argnums=1)(zh, zv) if kv else jnp.zeros(jh.shape[:-1] + (0,))
    return np.concatenate([np.asarray(jh), np.asarray(jv)], axis=-1), kh


def fit_los(design, los_weights, observed, weights, *, per_target_constant, ridge=1e-9):
    """Weighted LS of per-target line-of-sight observations.

    observed[p, t] ≈ (−sin ϑ_t, cos ϑ_t)·(Δy_p, Δz_p) (+ κ_t), rows weighted by weights[p, t].
    ``los_weights``: (target, 2) rows (−sin ϑ_t, cos ϑ_t).

    Returns (coefficients (K,), constants (target,)).
    """
    n_p, n_t = observed.shape
    rows = np.einsum("tk,pkj->ptj", los_weights, design)  # (p, t, K)
    k = rows.shape[-1]
    if per_target_constant:
        extra = np.broadcast_to(np.eye(n_t)[None], (n_p, n_t, n_t))
        rows = np.concatenate([rows, extra], axis=-1)
    w = np.sqrt(weights).reshape(-1)
    a = rows.reshape(n_p * n_t, -1) * w[:, None]
    b = observed.reshape(-1) * w
    normal = a.T @ a
    normal += ridge * np.trace(normal) / normal.shape[0] * np.eye(normal.shape[0])
    sol = np.linalg.solve(normal, a.T @ b)
    return sol[:k], (sol[k:] if per_target_constant else np.zeros(n_t))


def unwrap_from_peak(residual, amplitude, valid, half_window=8):
    """Unwrap the phase of ``residual`` (azimuth,) complex (data × conj(prediction)) by
    integrating its smoothed pulse-to-pulse phase gradient from the strongest valid pulse
    outward (a phase-gradient estimate: the products z_p z*_{p−1} are summed over
    ±half_window pulses before taking the angle, so noise does not cause 2π slips as long
    as the prediction's slope error stays below π per pulse).

    Returns ``(phase, mask)``: the unwrapped phase and the valid pulses used.
    """
    if not valid.any():
        return np.zeros(residual.shape), np.zeros_like(valid)
    z = np.where(valid, residual, 0.0)
    products = z[1:] * np.conj(z[:-1])
    kernel = np.ones(2 * half_window + 1)
    smoothed = np.convolve(products, kernel, mode="same")
    slope = np.angle(smoothed)  # (azimuth − 1,): phase step from pulse p−1 to p
    peak = int(np.argmax(np.where(valid, amplitude, -np.inf)))
    trend = np.zeros(residual.shape)
    trend[peak + 1:] = np.cumsum(slope[peak:])
    trend[:peak] = -np.cumsum(slope[:peak][::-1])[::-1]
    trend += np.angle(residual[peak])
    phase = trend + np.angle(residual * np.exp(-1j * trend))
    return phase, valid.copy()


def weighted_periodogram(x, values, weights, frequencies):
    """Weighted least-squares sinusoid fit power at each frequency [1/m]:
    reduction of Σ w (v − a sin − b cos)² over Σ w v²."""
    arg = 2 * np.pi * frequencies[:, None] * x[None, :]
    s, c = np.sin(arg), np.cos(arg)
    w = weights[None, :]
    ss, cc, sc = (w * s * s).sum(1), (w * c * c).sum(1), (w * s * c).sum(1)
    sv, cv = (w * s * values).sum(1), (w * c * values).sum(1)
    det = ss * cc - sc**2
    a = (cc * sv - sc * cv) / det
    b = (ss * cv - sc * sv) / det
    return (a * sv + b * cv) / np.sum(weights * values**2), a, b


def sinusoid_initial(jitter: SinusoidalJitter, x, values, weights, frequency_bounds):
    """Periodogram peak (coarse grid, then a fine grid about it) and the LS amplitude and
    phase there: SinusoidalJitter parameters θ = (a, b, ν) about its centre."""
    xc = np.asarray(x) - float(jitter.centre)
    span = np.ptp(xc)
    lo, hi = frequency_bounds
    coarse = np.arange(lo, hi, 1 / (8 * span))
    power, _, _ = weighted_periodogram(xc, values, weights, coarse)
    best = coarse[int(np.argmax(power))]
    fine = np.linspace(best - 1 / (8 * span), best + 1 / (8 * span), 129)
    power, a, b = weighted_periodogram(xc, values, weights, fine)
    k = int(np.argmax(power))
    return np.array([a[k], b[k], fine[k]]), float(power[k])
