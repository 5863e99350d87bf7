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
    rng = np.random.default_rng(0)
    shape = np.shape(signal)
    noise = np.sqrt(noise_power / 2) * (rng.normal(size=shape) + 1j * rng.normal(size=shape))
    n_c, _ = _compressed(radar, noise, azimuth, ranges)
    sigma2 = np.full(s.shape, float(np.mean(np.abs(n_c) ** 2)))
    if interference is not None:
        c, _ = _compressed(radar, np.asarray(interference), azimuth, ranges)
        width = smoothing or max(int(round(float(radar.footprint(radar.reference_range))
                                           / float(radar.azimuth_spacing))), 1)
        kernel = np.ones(width) / width
        local = np.apply_along_axis(lambda v: np.convolve(v, kernel, mode="same"), 1,
                                    np.abs(c) ** 2)
        sigma2 = sigma2 + local
    return 2 * np.abs(s) ** 2 / sigma2, r


def phase_bound(radar, information, info_ranges, num_basis: int, blocks, *,
                samples: int = 16, ridge: float = 1e-12):
    """(block,) lower bound [rad] on the aperture-detrended residual line-of-sight phase
    rms of :func:`sarjax.inverse.residual_phase_rms` for a cubic B-spline model of
    ``num_basis`` functions per component, from the (range, pulse) ``information`` of
    :func:`phase_information`. Pulses no scatterer informs give an unbounded error; the
    ``ridge`` (relative to the mean diagonal) keeps the inverse finite there."""
    n = information.shape[1]
    x = np.arange(n, dtype=float)
    design = np.asarray(BSpline(num_basis).bind(x).design(x))
    k0 = float(radar.wavenumber)
    height = float(radar.height)
    look = np.arccos(np.clip(height / np.asarray(info_ranges), -1.0, 1.0))
    # F = Σ_r Σ_p info(r, p) k0² [−sin B, cos B]ᵀ[−sin B, cos B]
    weights = np.stack([np.sin(look) ** 2, -np.sin(look) * np.cos(look), np.cos(look) ** 2])
    per_pulse = weights @ information  # (3, pulse)
    blocks_f = [design.T @ (w[:, None] * design) for w in per_pulse]
    fisher = k0**2 * np.block([[blocks_f[0], blocks_f[1]], [blocks_f[1], blocks_f[2]]])
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
