"""Two-way azimuth antenna patterns W²(u) (physics.md §1, §6).

A pattern is a callable module mapping the normalised azimuth offset
``u = (x' − x − δx) / X`` (dimensionless; ``X = λ r / L`` is the footprint) to the
two-way power gain. Derivatives needed by the pointing-error expansion (seed 000
eq. 21) come from :meth:`AbstractPattern.derivatives`: by autodiff of the pattern itself,
so any pattern works, or by a pattern's own closed form (the built-in ones).
"""

from __future__ import annotations

import abc
import functools
import math

import equinox as eqx
import jax
import jax.numpy as jnp

from . import _exported
from ._numerics.phasor import horner, sine, sine_cosine


@_exported.cached  # kept on disk with the compilation cache (traced once per shape)
@eqx.filter_jit
def evaluate(pattern, u):
    """``pattern(u)`` as one compiled program (for eager use on concrete values: a
    pattern's operations run one by one otherwise, each compiled on its first use)."""
    return pattern(u)


def pattern_derivative(pattern, order: int):
    """``u ↦ W²⁽ⁿ⁾(u)`` elementwise, n = ``order`` (:meth:`AbstractPattern.derivatives`)."""
    return lambda u: pattern.derivatives(u, order)[order]


def _with_next_derivative(f, u):
    """``f`` returns ``(g(u), g′(u), …, g⁽ᵏ⁾(u))``: the same and ``g⁽ᵏ⁺¹⁾(u)``, by one JVP
    with a unit tangent (g is elementwise)."""
    values, slopes = jax.jvp(f, (u,), (jnp.ones_like(u),))
    return (*values, slopes[-1])


@_exported.cached
@eqx.filter_jit
def evaluate_derivative(pattern, order, u):
    """``W²⁽ⁿ⁾(u)``, n = ``order`` (static), as one compiled program (eager use)."""
    return pattern_derivative(pattern, order)(u)


@_exported.cached
@eqx.filter_jit
def derivative_peak(pattern, order, u):
    """max over ``u`` of ``|W²⁽ⁿ⁾(u)|``, n = ``order`` (static), by autodiff."""
    return jnp.max(jnp.abs(pattern_derivative(pattern, order)(u)))


class AbstractPattern(eqx.Module):
    """Two-way azimuth illumination ``W²(u)``; ``u`` dimensionless, result dimensionless."""

    @abc.abstractmethod
    def __call__(self, u):
        """Evaluate ``W²(u)`` elementwise."""

    def derivatives(self, u, order: int):
        """``(W²(u), W²′(u), …, W²⁽ⁿ⁾(u))``, n = ``order`` (static), each shaped as ``u``.

        Here by nested forward-mode autodiff of :meth:`__call__`, every order from one
        pass (a pattern is elementwise, so each derivative is one JVP with a unit
        tangent); patterns with a closed form override it."""
        f = lambda v: (self(v),)  # noqa: E731
        for _ in range(order):
            f = functools.partial(_with_next_derivative, f)
        return f(jnp.asarray(u))


class Sinc2Pattern(AbstractPattern):
    """Uniform aperture: ``W²(u) = sinc²(u)``, ``sinc(u) = sin(πu)/(πu)`` (physics.md §1).

    With ``X = λr/L`` the first nulls are at ``x' − x = ±X`` and the azimuth spectrum
    occupies ``|ξ| ≤ Ω_x = 4π/L`` (seed 000 eq. 9).
    """

    @eqx.filter_jit  # one program per shape where called eagerly (op by op: ~20)
    def __call__(self, u):
        # Near u = 0 a Taylor polynomial, so that autodiff derivatives of any order stay
        # accurate (the quotient sin(πu)/(πu) loses them to cancellation as u → 0).
        small = jnp.abs(u) < 0.05
        safe = jnp.where(small, 0.1, u)
        quotient = (sine(jnp.pi * safe) / (jnp.pi * safe)) ** 2  # sine: multiply-adds
        x2 = (jnp.pi * u) ** 2
        # sinc²(u) = 1 − x²/3 + 2x⁴/45 − x⁶/315 + 2x⁸/14175 − …,  x = πu
        series = 1 - x2 / 3 + 2 * x2**2 / 45 - x2**3 / 315 + 2 * x2**4 / 14175
        return jnp.where(small, series, quotient)

    def derivatives(self, u, order: int):
        """``(W²(u), …, W²⁽ⁿ⁾(u))`` in closed form, n = ``order`` (static).

        With ``x = πu`` and ``s(x) = sin x / x``: ``x s⁽ᵏ⁾ = sin⁽ᵏ⁾x − k s⁽ᵏ⁻¹⁾`` (the
        k-th derivative of ``x s = sin x``), ``(s²)⁽ⁿ⁾ = Σ C(n, k) s⁽ᵏ⁾ s⁽ⁿ⁻ᵏ⁾`` and
        ``d/du = π d/dx``; for ``|x| < 0.3``, where the recursion loses digits to
        cancellation, the derivatives of the Maclaurin series
        ``sinc² = Σ (−1)ʲ 2²ʲ⁺¹ x²ʲ / (2j + 2)!`` to ``x²⁰`` (remainder < 1e-25). One
        sine and cosine for every order: nested autodiff of :meth:`__call__` traced
        and compiled a program several times larger (the pointing terms need orders
        0–3)."""
        u = jnp.asarray(u)
        x = jnp.pi * u
        small = jnp.abs(x) < _SINC2_SERIES_LIMIT
        safe = jnp.where(small, 1.0, x)
        sin_x, cos_x = sine_cosine(safe)
        cycle = (sin_x, cos_x, -sin_x, -cos_x)  # sin⁽ᵏ⁾
        s = [sin_x / safe]
        for k in range(1, order + 1):
            s.append((cycle[k % 4] - k * s[-1]) / safe)
        out = []
        for n in range(order + 1):
            quotient = sum(math.comb(n, k) * s[k] * s[n - k] for k in range(n + 1))
            series = horner(_sinc2_series_derivative(n), x)
            out.append(jnp.where(small, series, quotient) * jnp.pi**n)
        return tuple(out)


_SINC2_SERIES_LIMIT = 0.3  # |πu| below which Sinc2Pattern.derivatives uses the series


@functools.cache
def _sinc2_series_derivative(n: int):
    """Coefficients (lowest power first) of the n-th derivative in x of the Maclaurin
    series of sinc²: ``Σ_{j ≤ 10} (−1)ʲ 2²ʲ⁺¹ x²ʲ / (2j + 2)!``."""
    coefficients = [0.0] * 21
    for j in range(11):
        coefficients[2 * j] = (-1) ** j * 2.0 ** (2 * j + 1) / math.factorial(2 * j + 2)
    for _ in range(n):
        coefficients = [p * c for p, c in enumerate(coefficients)][1:] or [0.0]
    return tuple(coefficients)


class GaussianPattern(AbstractPattern):
    """Gaussian two-way beam ``W²(u) = exp(−u²/(2 width²))`` (a smooth alternative)."""

    width: object = eqx.field(converter=lambda v: jnp.asarray(v, dtype=float), default=0.37)

    @eqx.filter_jit
    def __call__(self, u):
        return jnp.exp(-0.5 * (u / self.width) ** 2)

    def derivatives(self, u, order: int):
        """``(W²(u), …, W²⁽ⁿ⁾(u))`` in closed form: ``W²⁽ᵏ⁾ = (−1/w)ᵏ Heₖ(u/w) W²``, with
        the probabilists' Hermite polynomials ``Heₖ₊₁(t) = t Heₖ(t) − k Heₖ₋₁(t)``."""
        t = jnp.asarray(u) / self.width
        value = jnp.exp(-0.5 * t**2)
        hermite = [jnp.ones_like(t), t]
        for k in range(1, order):
            hermite.append(t * hermite[k] - k * hermite[k - 1])
        return tuple(value * hermite[k] * (-1 / self.width) ** k for k in range(order + 1))
