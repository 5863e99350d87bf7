"""Genie-aided Cramér–Rao references for autofocus on an unknown scene.

An autofocus estimator does not know the scene; any estimator that does (a genie gives it
the reflectivity) can only do better. The Cramér–Rao bound of the known-scene problem is
therefore a lower bound on the error of an unbiased unknown-scene estimator.

In the range-compressed domain a trajectory deviation multiplies the sample of range bin r
and pulse p by ``exp[−jφ(p, r)]``, ``φ = k₀ δr_xr(Δy(p), Δz(p), r)`` (the few scatterers
within one range cell share their line of sight); with complex white noise of power σ²
per compressed sample, the Fisher information of φ(p, r) is ``2|s(p, r)|²/σ²`` (s the
noiseless compressed sample), and that of the B-spline coefficients c of Δy, Δz is

    F = Σ_{p,r} 2|s(p, r)|²/σ² · ∇_c φ(p, r) ∇_c φ(p, r)ᵀ,
    ∇_c φ = k₀ [−sin ϑ(r) B(p, :), cos ϑ(r) B(p, :)]

(the line-of-sight deviation linearised: ``δr_xr ≈ −Δy sin ϑ + Δz cos ϑ``). The bound on
the residual metric of :func:`sarjax.inverse.residual_phase_rms` (the constant and linear
trend removed within every synthetic aperture) is the rms over the same windows of the
detrended error covariance ``P A F⁻¹ Aᵀ Pᵀ``.

Two references are computed from the same expression:

* ``scene``: s the whole noiseless scene (clutter and points) — the strict genie bound;
* ``points``: s the bright points only and σ² the noise plus the local clutter power
  (clutter treated as interference, its structure not used) — what an estimator that
  learns the motion from the points alone can reach. It is not a strict bound for
  estimators that exploit the clutter's edges.

A third, :func:`clutter_information`, adds what the clutter carries when its reflectivity
is *not* known: the clutter of range bin r as a circular Gaussian process along the pulses,
stationary over a footprint, with the azimuth spectrum of its echo (the two-way pattern
seen through the Doppler history) and its local power. The phase error multiplies it by
``D = diag(e^{−jφ})``, so its covariance is ``D C₀ Dᴴ + σ²I`` and the Fisher information
of φ is

    F_pq = tr(C⁻¹ ∂_p C C⁻¹ ∂_q C) = 2 Re(K_pq conj G_pq) − 2 |H_pq|²,
    G = (C₀ + σ²I)⁻¹, H = G C₀, K = C₀ G C₀

(evaluated at φ = 0: D is unitary), a band matrix along the pulses: the clutter tells
phase *differences* between pulses within its correlation length, nothing about a phase
common to all. With C₀ circulant (the spectrum S(f) of the echo at the local
clutter-to-noise ratio q), ``g, h, k`` are the inverse DFTs of ``1/(qS + 1)``,
``qS/(qS + 1)`` and ``(qS)²/(qS + 1)``. With the points known and counted as above, the
sum of the two informations bounds any unbiased estimator that does not know the clutter's
reflectivity (knowing its statistics only helps).

The points need not be known either: ``phase_bound(..., points=[...])`` takes each
point's own information and removes from it what a phase constant and a phase slope over
the pulses, both unknown per point, absorb (the Schur complement of the Fisher matrix of
(c, ν_k), ``φ(p, r) + ν_k0 + ν_k1 (p − p̄)`` at the point's range bins): the point's
reflectivity phase and its azimuth position, ``δφ ≈ k₀ (x' − x_k) δx_k / r_k``. Its
slant range is taken as known (range compression fixes it to a fraction of a cell; an
error δr changes the phase curvature by ``k₀ (x' − x_k)² δr / 2r²``, ignored).
"""

from __future__ import annotations

import numpy as np

from .._data import RawData
from ._parametrisations import BSpline
from ._sharpness import make_focuser


def _compressed(radar, raw_data, azimuth, ranges):
    raw = RawData(data=raw_data, azimuth=azimuth, range=ranges)
    focuser = make_focuser(radar, raw)
    n = int(focuser.num_pulses)
    return np.asarray(focuser.compressed)[:, :n], np.asarray(focuser.range)


def _compressed_noise_power(radar, noise_power, shape, azimuth, ranges):
    """σ²: the power per range-compressed sample of complex white noise of ``noise_power``
    per raw sample (a (pulse, sample) ``shape`` draw, compressed as the data)."""
    rng = np.random.default_rng(0)
    noise = np.sqrt(noise_power / 2) * (rng.normal(size=shape) + 1j * rng.normal(size=shape))
    return float(np.mean(np.abs(_compressed(radar, noise, azimuth, ranges)[0]) ** 2))


def _footprint_pulses(radar):
    """Pulses in one footprint at the reference range (≥ 1)."""
    return max(int(round(float(radar.footprint(radar.reference_range))
                         / float(radar.azimuth_spacing))), 1)


def phase_information(radar, signal, noise_power, azimuth, ranges, *, interference=None,
                      smoothing=None):
    """(range, pulse) Fisher information 2|s|²/σ² of the line-of-sight phase per
    range-compressed sample, and the (range,) slant ranges of the kept bins.

    Args:
        signal: (pulse, sample) noiseless raw data s.
        noise_power: power of the complex white noise per raw sample.
        interference: optional (pulse, sample) raw data counted as noise (clutter): its
            compressed power, averaged along azimuth over ``smoothing`` pulses (default one
            footprint at the reference range), is added to σ².
    """
    s, r = _compressed(radar, np.asarray(signal), azimuth, ranges)
    sigma2 = np.full(s.shape, _compressed_noise_power(radar, noise_power, np.shape(signal),
                                                      azimuth, ranges))
    if interference is not None:
        c, _ = _compressed(radar, np.asarray(interference), azimuth, ranges)
        width = smoothing or _footprint_pulses(radar)
        kernel = np.ones(width) / width
        local = np.apply_along_axis(lambda v: np.convolve(v, kernel, mode="same"), 1,
                                    np.abs(c) ** 2)
        sigma2 = sigma2 + local
    return 2 * np.abs(s) ** 2 / sigma2, r


def clutter_information(radar, clutter, noise_power, azimuth, ranges, *, phase=None,
                        segment: int | None = None, levels: int = 64, max_lag: int = 32):
    """(3, pulse, lag) band of the Fisher information of the line-of-sight phase that
    clutter of unknown reflectivity carries (module docstring), summed over the range bins
    with the look-angle weights ``sin²ϑ, −sin ϑ cos ϑ, cos²ϑ`` of :func:`phase_bound`:
    ``band[w, p, l]`` is the (p, p + l) element (l = 0 … ``max_lag``; the matrix is
    symmetric).

    The clutter's power changes along the pulses (fields, edges): the information is that
    of stationary pieces, ``Σ_s W_s^½ F(q_s) W_s^½`` over windows ``W_s`` of ``segment``
    pulses (Hann, half-overlapping: they sum to one), ``q_s`` the window's mean
    clutter-to-noise ratio in the range bin. Each piece is positive semi-definite, so the
    sum is (pairs of pulses lose ``1 − Σ_s √(w_s(p) w_s(p + l))`` of their information,
    < 0.1 % for the lags the clutter informs). The echo of one pulse sums the scene over a
    footprint, so its power changes on that scale: the default window is one footprint at
    the reference range. Shorter windows count the speckle of the particular echo as
    changes of its power, which the convexity of the information in q turns into
    information (measured on benchmark draws 100 and 107, against one footprint of 646
    pulses: 32 pulses lower the bound by about 35 %, 128 pulses by about 5 %; half or
    twice a footprint change it by less than 1 %).

    Args:
        clutter: (pulse, sample) noiseless raw data of the clutter.
        noise_power: power of the complex white noise per raw sample.
        phase: optional ``ranges ↦ (range, pulse)`` line-of-sight phase [rad] the clutter
            was simulated with (removed before its azimuth spectrum is measured: the bound
            is that of the unperturbed process).
        segment: pulses per stationary window (default one footprint at the reference
            range; rounded to an even number).
        levels: clutter-to-noise ratios tabulated (log-spaced; each window interpolates).
        max_lag: the band's half-width in pulses.
    """
    c, r = _compressed(radar, np.asarray(clutter), azimuth, ranges)
    if phase is not None:
        c = c * np.exp(1j * np.asarray(phase(r))[:, :c.shape[1]])
    sigma2 = _compressed_noise_power(radar, noise_power, np.shape(clutter), azimuth, ranges)
    n = c.shape[1]
    spectrum = np.mean(np.abs(np.fft.fft(c, axis=1)) ** 2, axis=0)
    spectrum = spectrum / spectrum.mean()
    segment = max(2 * (int(segment or _footprint_pulses(radar)) // 2), 4)
    lags = min(int(max_lag), n - 1, segment - 1)
    # Hann windows of `segment` pulses every segment/2, starting half a window before the
    # first pulse: Σ_s w_s(p) = 1 on every pulse
    hop = segment // 2
    window = np.sin(np.pi * (np.arange(segment) + 0.5) / segment) ** 2
    starts = np.arange(-hop, n, hop)
    power = np.abs(c) ** 2 / sigma2  # (range, pulse)
    cnr = np.empty((r.size, starts.size))
    for i, s0 in enumerate(starts):
        lo, hi = max(s0, 0), min(s0 + segment, n)
        w = window[lo - s0:hi - s0]
        cnr[:, i] = power[:, lo:hi] @ w / w.sum()
    floor = max(float(cnr.min()), 1e-6)
    grid = np.geomspace(floor, max(float(cnr.max()), floor * 1.0001), levels)
    table = np.stack([lag_information(spectrum, q)[:lags + 1] for q in grid])
    position = np.interp(np.log(np.maximum(cnr, floor)), np.log(grid), np.arange(levels))
    lo = np.clip(np.floor(position).astype(int), 0, levels - 2)
    t = (position - lo)[..., None]
    per_window = table[lo] * (1 - t) + table[lo + 1] * t  # (range, window, lag)
    summed = np.einsum("wr,rsl->wsl", _look_weights(radar, r), per_window)
    # √(w(p) w(p + l)) within a window, zero past its end
    overlap = np.zeros((segment, lags + 1))
    for lag in range(lags + 1):
        overlap[:segment - lag, lag] = np.sqrt(window[:segment - lag] * window[lag:])
    band = np.zeros((3, n + 2 * segment, lags + 1))
    for i, s0 in enumerate(starts):
        band[:, s0 + segment:s0 + 2 * segment] += overlap[None] * summed[:, i, None, :]
    band = band[:, segment:segment + n]
    # pairs (p, p + l) past the last pulse do not exist
    for lag in range(1, lags + 1):
        band[:, n - lag:, lag] = 0.0
    return band, r


def lag_information(spectrum, cnr):
    """(n,) ``F_l``, l = 0 … n − 1: the Fisher information of the phases of n pulses of a
    circular Gaussian process with the (n,) azimuth power spectrum ``cnr · spectrum``
    (``spectrum`` of mean 1, ``cnr`` the clutter-to-noise ratio) in unit white noise, as
    the circulant matrix ``F_pq = F_{(q − p) mod n}`` (module docstring). Its rows sum to
    zero: a phase common to every pulse is not observable."""
    qs = cnr * np.asarray(spectrum, float)
    g = np.fft.ifft(1 / (qs + 1))
    h = np.fft.ifft(qs / (qs + 1))
    k = np.fft.ifft(qs**2 / (qs + 1))
    return 2 * np.real(k * np.conj(g)) - 2 * np.abs(h) ** 2


def _look_weights(radar, info_ranges):
    """(3, range) ``sin²ϑ, −sin ϑ cos ϑ, cos²ϑ`` of the look angle ϑ at each range."""
    look = np.arccos(np.clip(float(radar.height) / np.asarray(info_ranges), -1.0, 1.0))
    return np.stack([np.sin(look) ** 2, -np.sin(look) * np.cos(look), np.cos(look) ** 2])


def _band_matrix(band):
    """(n, n) symmetric matrix from its (n, lag) band (element (p, p + l) = band[p, l])."""
    n, lags = band.shape
    out = np.zeros((n, n))
    rows = np.arange(n)
    out[rows, rows] = band[:, 0]
    for lag in range(1, lags):
        i = rows[:n - lag]
        out[i, i + lag] = band[:n - lag, lag]
        out[i + lag, i] = band[:n - lag, lag]
    return out


def _coefficient_information(radar, design, info_ranges, information):
    """(2b, 2b) information on the B-spline coefficients of Δy, Δz from the (range, pulse)
    ``information`` on φ: ``Σ_r Σ_p info(r, p) k₀² [−sin ϑ B, cos ϑ B]ᵀ[−sin ϑ B, cos ϑ B]``."""
    per_pulse = _look_weights(radar, info_ranges) @ information  # (3, pulse)
    f = [design.T @ (w[:, None] * design) for w in per_pulse]
    return float(radar.wavenumber) ** 2 * np.block([[f[0], f[1]], [f[1], f[2]]])


def _point_information(radar, design, info_ranges, information):
    """(2b, 2b) information on the B-spline coefficients that one point's (range, pulse)
    ``information`` carries when its phase constant and slope are unknown (module
    docstring): ``F_cc − F_cν F_νν⁻¹ F_νc``."""
    k0 = float(radar.wavenumber)
    n = information.shape[1]
    t = np.arange(n, dtype=float)
    nuisance = np.stack([np.ones(n), (t - t.mean()) / n], axis=1)  # (pulse, 2)
    look = np.arccos(np.clip(float(radar.height) / np.asarray(info_ranges), -1.0, 1.0))
    f_cc = _coefficient_information(radar, design, info_ranges, information)
    sin_w = np.sin(look) @ information  # (pulse,) Σ_r info sin ϑ
    cos_w = np.cos(look) @ information
    f_cn = k0 * np.concatenate([-design.T @ (sin_w[:, None] * nuisance),
                                design.T @ (cos_w[:, None] * nuisance)], axis=0)  # (2b, 2)
    f_nn = nuisance.T @ (information.sum(axis=0)[:, None] * nuisance)
    return f_cc - f_cn @ np.linalg.solve(f_nn, f_cn.T)


def phase_bound(radar, information, info_ranges, num_basis: int, blocks, *,
                samples: int = 16, ridge: float = 1e-12, clutter=None, points=None):
    """(block,) lower bound [rad] on the aperture-detrended residual line-of-sight phase
    rms of :func:`sarjax.inverse.residual_phase_rms` for a cubic B-spline model of
    ``num_basis`` functions per component, from the (range, pulse) ``information`` of
    :func:`phase_information`. Pulses no scatterer informs give an unbounded error; the
    ``ridge`` (relative to the mean diagonal) keeps the inverse finite there. ``clutter``:
    the (3, pulse, lag) band of :func:`clutter_information`, added to the information.
    ``points``: a sequence of (range, pulse) informations, one per point (each from
    :func:`phase_information` of that point's echo alone), whose phase constant and
    azimuth position are unknown (module docstring); ``information`` may then be None
    (nothing else known) or hold what is known besides."""
    if information is None and not points:
        raise ValueError("phase_bound needs information or points")
    n = (information if information is not None else points[0]).shape[1]
    x = np.arange(n, dtype=float)
    design = np.asarray(BSpline(num_basis).bind(x).design(x))
    k0 = float(radar.wavenumber)
    height = float(radar.height)
    fisher = np.zeros((2 * num_basis, 2 * num_basis))
    if information is not None:
        fisher += _coefficient_information(radar, design, info_ranges, information)
    if clutter is not None:
        band_f = [design.T @ _band_matrix(band[:n]) @ design for band in clutter]
        fisher += k0**2 * np.block([[band_f[0], band_f[1]], [band_f[1], band_f[2]]])
    for info in points or ():
        fisher = fisher + _point_information(radar, design, info_ranges, np.asarray(info))
    fisher += ridge * np.trace(fisher) / fisher.shape[0] * np.eye(fisher.shape[0])
    cov = np.linalg.inv(fisher)
    spacing = float(radar.azimuth_spacing)
    out = []
    for lo, hi in np.asarray(blocks, float):
        squares = []
        for r in np.linspace(lo, hi, samples):
            theta = np.arccos(np.clip(height / r, -1.0, 1.0))
            a = k0 * np.concatenate([-np.sin(theta) * design, np.cos(theta) * design], axis=1)
            width = int(round(float(radar.footprint(r)) / spacing))
            starts = np.arange(0, n - width + 1, max(width // 16, 1))
            t = np.arange(width, dtype=float)
            basis = np.stack([np.ones(width), t - t.mean()], axis=1)
            proj = np.eye(width) - basis @ np.linalg.pinv(basis)
            total = 0.0
            for s0 in starts:
                m = proj @ a[s0:s0 + width]
                total += float(np.sum((m @ cov) * m)) / width
            squares.append(total / starts.size)
        out.append(float(np.sqrt(np.mean(squares))))
    return np.asarray(out)
