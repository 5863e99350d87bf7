"""Unit phasors e^{jφ} from multiply–adds.

XLA on the CPU evaluates ``exp(1j φ)`` (and ``cos``/``sin``) through scalar library calls,
about 20 ns per element on the reference machine: for the Fourier simulators, whose
per-sample work is otherwise a handful of multiply–adds, the phasors dominated the run
time. :func:`unit_phasor` reduces ``φ`` by multiples of π/2 (three-part Cody–Waite
constants) and evaluates the sine and cosine of the remainder
``|r| ≤ π/4`` by their Taylor series to degree 17 / 16 (truncation < 1e-17), all in
vectorisable arithmetic; the quadrant is applied by selection.

Error against ``numpy.exp(1j φ)``: ≤ 2e-16 + 2e-16·|φ| in float64 (the second term is the
rounding of φ itself); in float32, ≤ 1e-6 + 1.2e-7·|φ|. The derivative is the exact
``d e^{jφ} = j e^{jφ} dφ`` (a custom JVP).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

# π/2 = _P1 + _P2 + _P3 (+ 5e-36): _P1 and _P2 have 30 significant bits, so that n·_P1
# and n·_P2 are exact for |n| < 2²³ and their rounding stays below 2⁻⁵³·|n·_P| beyond
_P1 = 1.5707963276654482
_P2 = -8.705515692000731e-10
_P3 = -3.50343439808993e-19
_TWO_OVER_PI = 2.0 / np.pi

# Taylor coefficients (−1)^k / (2k+1)! and (−1)^k / (2k)!
_SIN = [(-1) ** k / float(np.prod(np.arange(1, 2 * k + 2))) for k in range(9)]
_COS = [(-1) ** k / float(np.prod(np.arange(1, 2 * k + 1))) for k in range(9)]


def horner(coefficients, x):
    """``Σ cᵢ xⁱ`` by Horner's rule (coefficients lowest power first)."""
    out = jnp.full_like(x, coefficients[-1])
    for c in coefficients[-2::-1]:
        out = out * x + c
    return out


# One nested jit: a program forms its phasors at a few shapes, and jax traces and lowers
# the ~60 operations below once per shape and dtype instead of once per phasor (XLA inlines
# the call, so the compiled program is the same). Moderate deviation's program on a
# 512 × 256 grid (28 phasors): traced and lowered in 0.9-1.0 s instead of 1.6-1.7 s,
# compiled in 1.6-1.8 s instead of 1.7-1.9 s.
@jax.jit
def _sin_cos(phase):
    """(sin φ, cos φ) for real floating φ."""
    n = jnp.round(phase * _TWO_OVER_PI)
    r = ((phase - n * _P1) - n * _P2) - n * _P3  # |r| ≤ π/4
    r2 = r * r
    # float32: the series to r⁹ and r¹⁰ (next terms ≤ 2e-9 at |r| = π/4, below float32's
    # rounding; the same max error, 1.9e-7 on 2²⁰ draws, in 0.47 ms against 0.62 ms)
    terms_sin, terms_cos = (5, 6) if jnp.dtype(r.dtype) == jnp.float32 else (9, 9)
    sin_r = r * horner(_SIN[:terms_sin], r2)
    cos_r = horner(_COS[:terms_cos], r2)
    # 0, 1, 2, 3: n − 4⌊n/4⌋, exact for the integer-valued float n (|n| < 2²⁴ in float32);
    # jnp.mod's remainder and sign fix-up cost 10–15 % more of the whole phasor
    quadrant = n - 4.0 * jnp.floor(n * 0.25)
    swap = (quadrant == 1.0) | (quadrant == 3.0)
    sin_q = jnp.where(swap, cos_r, sin_r)
    cos_q = jnp.where(swap, sin_r, cos_r)
    sin_sign = jnp.where(quadrant >= 2.0, -1.0, 1.0)
    cos_sign = jnp.where((quadrant == 1.0) | (quadrant == 2.0), -1.0, 1.0)
    return sin_sign * sin_q, cos_sign * cos_q


@jax.custom_jvp
def sine(x):
    """sin x for real x, by the same reduction and series as :func:`unit_phasor`."""
    return _sin_cos(jnp.asarray(x))[0]


@sine.defjvp
def _sine_jvp(primals, tangents):
    (x,), (dx,) = primals, tangents
    s, c = _sin_cos(jnp.asarray(x))
    return s, c * dx


@jax.custom_jvp
def sine_cosine(x):
    """(sin x, cos x) for real x, by the same reduction and series as :func:`unit_phasor`
    (one reduction for both)."""
    return _sin_cos(jnp.asarray(x))


@sine_cosine.defjvp
def _sine_cosine_jvp(primals, tangents):
    (x,), (dx,) = primals, tangents
    s, c = sine_cosine(x)
    return (s, c), (c * dx, -s * dx)


@jax.custom_jvp
def unit_phasor(phase):
    """e^{jφ} for real φ (any shape), complex128 for float64 input, complex64 for float32.

    Args:
        phase: φ [rad], real.

    Returns:
        complex array of the same shape, ``cos φ + j sin φ``.
    """
    phase = jnp.asarray(phase)
    if not jnp.issubdtype(phase.dtype, jnp.floating):
        phase = phase.astype(jnp.result_type(float))
    s, c = _sin_cos(phase)
    return jax.lax.complex(c, s)


@unit_phasor.defjvp
def _unit_phasor_jvp(primals, tangents):
    (phase,), (dphase,) = primals, tangents
    out = unit_phasor(phase)
    return out, out * (1j * jnp.asarray(dphase, phase.dtype if hasattr(phase, "dtype") else
                                       jnp.result_type(float)))


def wrap_phase(phase):
    """φ − 2πk, the multiple k = round(φ/2π) removed: in [−π, π] [rad], float64 in,
    float64 out (for the carrier k₀r of a slant range before a small phase is added).

    ``jnp.mod(φ, 2π)`` does the same up to a whole turn, but XLA's floating-point
    remainder is a scalar library call, about 30 ns per element on the reference machine
    against 0.4 ns for this multiply–round–subtract; the extra rounding, ≤ 2e-16·|φ|
    (5e-10 rad at k₀r = 2·10⁶ rad), is far below what a float64 range carries."""
    phase = jnp.asarray(phase)
    return phase - jnp.round(phase * (1 / (2 * np.pi))) * (2 * np.pi)


def reduced_phasor(phase, dtype):
    """e^{jφ} of complex ``dtype`` for a float64 phase φ of any size: complex128 as
    :func:`unit_phasor`; complex64 from φ reduced to [−π, π] in float64 and the float32
    series (error ≤ 1e-6 whatever |φ|, where φ cast to float32 first would carry
    6e-8·|φ|)."""
    if jnp.dtype(dtype) == jnp.complex128:
        return unit_phasor(phase)
    return unit_phasor(wrap_phase(phase).astype(jnp.float32))


def broadcast_phasor(phase):
    """e^{jφ} of a vector φ that a product broadcasts over a larger array (one factor per
    row or per column), formed as 1 / e^{−jφ}.

    XLA on the CPU copies elementwise multiply–adds into every consumer that broadcasts
    them: the phasor's series (or XLA's own sine and cosine, multiply–adds too by then)
    was formed again for every element of the product. A division it counts as costly
    and does not copy, so with one last the vector is formed once: a 972 × 864
    complex128 array times a row and a column phasor, then an FFT, one core, 11.4 →
    3.3 ms. The division adds one rounding (relative 2⁻⁵³ in complex128, 2⁻²⁴ in
    complex64)."""
    return 1 / unit_phasor(-jnp.asarray(phase))
