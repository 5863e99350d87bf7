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

import dataclasses
import functools
import time

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import _setup
from ._parametrisations import SinusoidalJitter

UPSAMPLE = 16


def upsample_lines(compressed, factor=UPSAMPLE):
    """Band-limited (FFT zero-padding at the Nyquist bin) upsampling of (azimuth, range)
    lines; sample k/factor of the output is r'_0 + (k/factor)·Δr."""
    return np.asarray(_upsample_lines(jnp.asarray(compressed), factor))


@functools.partial(jax.jit, static_argnums=1)
def _upsample_lines(compressed, factor):
    n = compressed.shape[-1]
    spec = jnp.fft.fft(compressed, axis=-1)
    half = (n + 1) // 2
    padded = jnp.zeros(compressed.shape[:-1] + (n * factor,), spec.dtype)
    padded = padded.at[..., :half].set(spec[..., :half])
    padded = padded.at[..., n * factor - (n - half):].set(spec[..., half:])
    return jnp.fft.ifft(padded, axis=-1) * factor


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
    kh = model.horizontal.num_params()
    kv = 0 if (line_of_sight is not None or model.vertical is None) else \
        model.vertical.num_params()
    los = None if line_of_sight is None else jnp.asarray(line_of_sight, dtype=float)
    jh, jv = _deviation_jacobians(model, jnp.asarray(azimuth), los, kh, kv)
    return np.concatenate([np.asarray(jh), np.asarray(jv)], axis=-1), kh


@eqx.filter_jit
def _deviation_jacobians(model, x, los, kh, kv):
    """∂(Δy, Δz)/∂θ_h and ∂(Δy, Δz)/∂θ_v, (azimuth, 2, kh) and (azimuth, 2, kv); with a
    line of sight ``los`` = (sin, cos) only Δy is fitted, along it."""

    def dev(params_h, params_v):
        dy = model.horizontal(params_h, x)
        if los is not None:
            return jnp.stack([-los[0] * dy, los[1] * dy], axis=-1)
        dz = model.vertical(params_v, x)
        return jnp.stack([dy, dz], axis=-1)

    zh, zv = jnp.zeros(kh), jnp.zeros(kv)
    jh = jax.jacfwd(dev, argnums=0)(zh, zv)
    jv = jax.jacfwd(dev, argnums=1)(zh, zv) if kv else jnp.zeros(jh.shape[:-1] + (0,))
    return jh, jv


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


# ---- the stages ---------------------------------------------------------------------------


def cold_start(radar, scene, model, los, compressed, x, near, sigma_sq, max_deviation,
               period_bounds, min_snr, record):
    """Envelope, phase and jitter stages from the compressed lines (azimuth, range) of the
    support pulses ``x`` (first sample at ``near``); each stage is passed to
    ``record(name, seconds, params)``.

    Returns ``(params, phase)``: the model parameters and the :class:`PhaseFit` that
    re-unwraps about another profile (None when no deviation is fitted).
    """
    rs = np.asarray(scene.range)[None, :]
    along = x[:, None] - np.asarray(scene.azimuth)[None, :]
    angles = _setup.look_angles(radar, scene)
    los_rows = np.stack([-np.sin(angles), np.cos(angles)], axis=-1)  # (target, 2)

    t0 = time.perf_counter()
    lines = upsample_lines(compressed)
    params, pred, design, kh = envelope_stage(
        radar, model, los, lines, rs, along, los_rows, x, near, sigma_sq, max_deviation,
        min_snr)
    record("envelope", time.perf_counter() - t0, params)

    t0 = time.perf_counter()
    phase = PhaseFit(model=model, los=los, lines=lines, rs=rs, along=along,
                     los_rows=los_rows, design=design, kh=kh, near=near,
                     range_spacing=float(radar.range_spacing),
                     wavenumber=float(radar.wavenumber), wavelength=float(radar.wavelength),
                     noise=sigma_sq, min_snr=min_snr)
    dev_params, pred, amp, valid = phase.fit(pred)
    params.update(dev_params)
    record("phase", time.perf_counter() - t0, params)

    if model.pointing is not None:
        t0 = time.perf_counter()
        params["pointing"] = jitter_stage(radar, scene, model, x, rs, along, amp, valid,
                                          period_bounds)
        record("jitter", time.perf_counter() - t0, params)
    if model.horizontal is None:
        return params, None
    return params, phase


def envelope_stage(radar, model, los, lines, rs, along, los_rows, x, near, sigma_sq,
                   max_deviation, min_snr):
    """The envelope stage (the compressed peaks' ranges): returns ``(params, prediction,
    design, kh)``, every component's parameters (zero where the envelopes say nothing), the
    (azimuth, target) line-of-sight prediction [m] and the deviations' linear design and
    split (None, 0 without deviations)."""
    dr = float(radar.range_spacing)
    up = UPSAMPLE
    nominal = np.sqrt(rs**2 + along**2)  # R_n (azimuth, target)
    params = {}
    gain_noise = sigma_sq  # the unitary filter keeps the noise power per sample
    search = int(np.ceil(max_deviation / dr * up)) + up // 2
    pos, amp = envelope_peaks(lines, (nominal - near) / dr * up, search)
    valid = amp**2 > min_snr * gain_noise
    if valid.sum() < 8:
        raise ValueError(
            f"fewer than 8 pulses have a compressed SNR above min_snr={min_snr}: the data "
            "are too noisy for a cold start"
        )
    peak_range = near + pos / up * dr
    los_env = np.sqrt(np.maximum(peak_range**2 - along**2, 0)) - rs
    design, kh = None, 0
    if model.horizontal is not None:
        design, kh = linear_design(model, x, los)
        coef, const = fit_los(design, los_rows, los_env, amp**2 * valid,
                              per_target_constant=True)
        params.update(_split(model, coef, kh, los))
        pred = np.einsum("tk,pkj,j->pt", los_rows, design, coef) + const[None, :]
    else:
        pred = np.zeros_like(los_env)
    params.update(_zero_rest(model, params, x))
    return params, pred, design, kh


@dataclasses.dataclass(frozen=True)
class PhaseFit:
    """The phase stage's data and geometry: the upsampled compressed ``lines``, the
    scatterers' ranges ``rs`` (1, target) and along-track offsets ``along`` (azimuth,
    target) [m], their line-of-sight rows (target, 2) (−sin ϑ_t, cos ϑ_t), the
    deviations' linear design and split (:func:`linear_design`), the first sample's range
    ``near``, and the per-sample noise power with the SNR threshold of a usable pulse."""

    model: object
    los: tuple | None
    lines: np.ndarray
    rs: np.ndarray
    along: np.ndarray
    los_rows: np.ndarray
    design: np.ndarray | None
    kh: int
    near: float
    range_spacing: float
    wavenumber: float
    wavelength: float
    noise: float
    min_snr: float

    def fit(self, pred, half_window=8):
        """Unwrapped-phase line-of-sight fit from the prediction ``pred`` (azimuth, target)
        [m]: returns (deviation parameters, prediction, compressed amplitudes, valid)."""
        model, los, design, kh = self.model, self.los, self.design, self.kh
        rs, along, los_rows = self.rs, self.along, self.los_rows
        near, dr, k0, up = self.near, self.range_spacing, self.wavenumber, UPSAMPLE
        has_dev = model.horizontal is not None
        out = {}
        weights = np.zeros(pred.shape)
        phase_based = False
        for _ in range(8 if has_dev else 1):
            r_pred = np.sqrt((rs + pred) ** 2 + along**2)
            z = sample_lines(self.lines, (r_pred - near) / dr * up)
            amp = np.abs(z)
            valid = amp**2 > self.min_snr * self.noise
            if not has_dev:
                break
            residual = z * np.exp(1j * k0 * r_pred)
            fine = np.zeros(residual.shape)
            for t in range(residual.shape[1]):
                unwrapped, mask = unwrap_from_peak(residual[:, t], amp[:, t], valid[:, t],
                                                   half_window)
                fine[:, t] = unwrapped
                weights[:, t] = amp[:, t] ** 2 * mask
            r_fine = r_pred - fine / k0
            los_fine = np.sqrt(np.maximum(r_fine**2 - along**2, 0)) - rs
            if phase_based:
                # robust: pulses a slip put ≥ λ/8 off the previous (phase-based) prediction
                # do not pull the fit, unless that would drop most of a scatterer's pulses
                misfit = los_fine - pred
                misfit -= np.median(misfit, axis=0)[None, :]
                keep = np.abs(misfit) < self.wavelength / 8
                enough = keep.sum(axis=0) >= 0.5 * np.maximum((weights > 0).sum(axis=0), 1)
                weights = weights * np.where(enough[None, :], keep, True)
            phase_based = True
            coef, const = fit_los(design, los_rows, los_fine, weights,
                                  per_target_constant=True)
            out.update(_split(model, coef, kh, los))
            new_pred = np.einsum("tk,pkj,j->pt", los_rows, design, coef) + const[None, :]
            change = np.max(np.abs(new_pred - pred - np.median(new_pred - pred, axis=0)))
            pred = new_pred
            if change < self.wavelength / 1000:
                break
        return out, pred, amp, valid

    def rephase(self, m3, half_window, keep=None):
        """Deviation parameters re-unwrapped about the line of sight of ``m3`` (azimuth,
        3) (Δy, Δz, δ_az): ℓ_t = −Δy sin ϑ_t + Δz cos ϑ_t per scatterer. With ``keep``
        (azimuth,) bool, the profile is first refitted on the kept pulses only, the
        others (where the fit is off by a slip) following the smooth model with its
        data-free coefficients held near zero."""
        prediction = np.asarray(m3)[:, :2] @ self.los_rows.T
        if keep is not None:
            w = np.broadcast_to(keep[:, None].astype(float), prediction.shape)
            coef, const = fit_los(self.design, self.los_rows, prediction, w,
                                  per_target_constant=False, ridge=1e-3)
            prediction = np.einsum("tk,pkj,j->pt", self.los_rows, self.design, coef) \
                + const[None, :]
        return self.fit(prediction, half_window)[0]


def jitter_stage(radar, scene, model, x, rs, along, amp, valid, period_bounds):
    """The pointing parameters from the modulation of the compressed amplitudes ``amp``
    (azimuth, target) by the two-way pattern (``valid``: the pulses used)."""
    footprint = np.asarray(radar.footprint(scene.range))[None, :]
    u = along / footprint
    pattern = np.asarray(jax.vmap(radar.pattern)(jnp.asarray(u.ravel()))).reshape(u.shape)
    slope = np.asarray(jax.vmap(jax.grad(radar.pattern))(jnp.asarray(u.ravel())))
    slope = slope.reshape(u.shape)
    w = valid.astype(float)
    gain = (amp * pattern * w).sum(0) / np.maximum((pattern**2 * w).sum(0), 1e-300)
    observed = amp / gain[None, :] - pattern
    sensitivity = -slope * rs / footprint  # ∂W²/∂δ_az
    info_t = gain[None, :] ** 2 * sensitivity**2 * w
    info = info_t.sum(1)
    delta = np.where(info > 0, (gain[None, :] ** 2 * sensitivity * observed * w).sum(1)
                     / np.where(info > 0, info, 1.0), 0.0)
    if isinstance(model.pointing, SinusoidalJitter):
        v = float(radar.velocity)
        span = np.ptp(x)
        t_min, t_max = (4.0 / float(radar.prf), span / (2 * v)) if period_bounds is None \
            else period_bounds
        if not (0 < t_min < t_max):
            raise ValueError(f"jitter_period_bounds={period_bounds!r} must be 0 < T_min < "
                             "T_max [s]")
        theta, _ = sinusoid_initial(model.pointing, x, delta, info,
                                    (1 / (v * t_max), 1 / (v * t_min)))
        return jnp.asarray(theta)
    design_p = np.asarray(model.pointing.design(jnp.asarray(x)))
    if model.pointing.gauge is not None:
        design_p = design_p @ np.asarray(model.pointing.gauge)
    sw = np.sqrt(info)[:, None]
    a = design_p * sw
    normal = a.T @ a
    normal += 1e-9 * np.trace(normal) / normal.shape[0] * np.eye(normal.shape[0])
    return jnp.asarray(np.linalg.solve(normal, a.T @ (delta * sw[:, 0])))


def _split(model, coef, kh, los):
    out = {"horizontal": jnp.asarray(coef[:kh])}
    if model.vertical is not None and los is None:
        out["vertical"] = jnp.asarray(coef[kh:])
    return out


def _zero_rest(model, params, x):
    out = {}
    for n in model.components:
        if n in params:
            continue
        p = getattr(model, n)
        if isinstance(p, SinusoidalJitter):
            # zero amplitude at a mid-band frequency: a neutral start for the amplitude
            out[n] = jnp.asarray([0.0, 0.0, 4.0 / np.ptp(x)])
        else:
            out[n] = jnp.zeros(p.num_params())
    return out
