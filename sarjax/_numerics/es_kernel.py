"""The "exponential of semicircle" kernel (Barnett, Magland & af Klinteberg 2019, the
kernel of FINUFFT) ``φ(z) = exp(β(√(1 − z²) − 1))`` over ``w`` cells, as polynomials in the
fractional offset, and its Fourier transform: the spreading kernel of the NUFFT simulator
(type 1, ``simulators._nufft``) and the interpolation kernel of the Fourier simulators'
inverse Stolt mapping (type 2, :func:`interpolation.kernel_interpolate_rows`)."""

from __future__ import annotations

import functools
import math

import numpy as np


def kernel_width(tolerance):
    """Cells w of the spreading kernel for a relative error ≈ ``tolerance`` (2× grid)."""
    if not (isinstance(tolerance, (int, float)) and 1e-14 <= tolerance < 1):
        raise ValueError(f"tolerance={tolerance!r} must be a number in [1e-14, 1)")
    return int(min(16, max(2, math.ceil(math.log10(1.0 / tolerance)) + 1)))


@functools.lru_cache(maxsize=32)
def spreading_kernel(width, oversampling, beta_scale=1.0):
    """Polynomial coefficients of the ES kernel's taps and its Fourier transform.

    ``beta_scale`` multiplies the β of the formula below (a kernel tuned for one use).

    Returns:
        ``(coefficients, beta)``: (degree + 1, width) float64, ``coefficients[k, i]`` of
        ``f^k`` for tap i, where tap i of a point at grid position t sits at cell
        ``⌈t − w/2⌉ + i`` and ``f = ⌈t − w/2⌉ − (t − w/2) ∈ [0, 1)``; and β.
    """
    # β for a 2× grid (FINUFFT's choice, 2.30 w), scaled for other oversampling factors
    beta = beta_scale * 2.30 * width * (1.0 - 0.5 / oversampling) / 0.75
    # degree w + 1: its worst errors equal those of w + 4 to 0.2 dB, for the inverse Stolt
    # interpolation over 2–16 taps (test_interpolation's worst cases and 6 draws per
    # width: 2 taps −21.7, 4: −60.8, 8: −130.2, 16: −250.6 dB) and for the NUFFT at
    # tolerances 1e-2 … 1e-10 (−51.1 … −214.3 dB against the direct sum); each weight is
    # then three Horner steps shorter
    degree = width + 1
    f = 0.5 * (1 - np.cos(np.pi * (np.arange(4 * degree) + 0.5) / (4 * degree)))
    coefficients = np.empty((degree + 1, width))
    for i in range(width):
        values = _es(f + i - width / 2, width, beta)
        # fitted on [−1, 1] and converted (a power-basis fit on [0, 1] is ill-conditioned
        # from degree 19, 15 taps, and warns; the two agree to 1e-13 below it)
        fit = np.polynomial.Polynomial.fit(f, values, degree, domain=[0.0, 1.0])
        coefficients[:, i] = fit.convert().coef
    return coefficients, beta


def _es(distance, width, beta):
    z2 = np.clip((2.0 * np.asarray(distance) / width) ** 2, 0.0, 1.0)
    return np.exp(beta * (np.sqrt(1.0 - z2) - 1.0))


@functools.lru_cache(maxsize=32)
def kernel_transform(width, oversampling, grid, modes, beta_scale=1.0):
    """(modes,) ψ̂(2πq/G) in FFT order of the modes q: ∫ φ(t) e^{−j2πqt/G} dt over the
    kernel's support (Gauss–Legendre on each half; the kernel is even)."""
    _, beta = spreading_kernel(width, oversampling, beta_scale)
    nodes, weights = np.polynomial.legendre.leggauss(400)
    t = 0.25 * width * (nodes + 1)  # [0, w/2]
    w = 0.25 * width * weights
    q = np.fft.fftfreq(modes, 1.0 / modes)
    values = _es(t, width, beta)
    return 2 * np.cos(2 * np.pi * np.outer(q, t) / grid) @ (values * w)
