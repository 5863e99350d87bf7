"""Autodiff against central finite differences, shared by the gradient tests.

A loss L(θ) (θ an array or a pytree of arrays, float64) is differentiated once with
``jax.grad``; the directional derivative ∇L·v along a direction v is compared with the
central difference (L(θ + h v) − L(θ − h v)) / (2h). Its error is the truncation
(L'''/6) h² plus the round-off ≈ ε |L| / h, so each test states its step h and its
tolerance with the reason.

``values_from_gradient=True`` takes L(θ ± h v) from ``jax.value_and_grad`` instead of
``loss``: the two shifted points then run the differentiated program already compiled for
∇L(θ) instead of compiling the forward one (the cheaper choice when compiling dominates).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np


def _dot(a, b):
    leaves = zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b), strict=True)
    return sum(float(jnp.vdot(x, y)) for x, y in leaves)


def _shift(theta, direction, h):
    return jax.tree_util.tree_map(lambda t, v: t + h * v, theta, direction)


def random_direction(theta, rng):
    """A direction v of θ's structure with standard-normal entries (float64)."""
    return jax.tree_util.tree_map(
        lambda t: jnp.asarray(rng.normal(size=np.shape(t))), theta)


def directional_check(loss, theta, direction, step, grad=None, values_from_gradient=False):
    """(analytic ∇L·v, central difference, relative error |analytic − numeric| / |numeric|).

    ``grad``: the gradient at θ when already computed (else ``jax.grad(loss)(theta)``);
    it must be finite and float64 with θ's structure.
    """
    if grad is None:
        grad = jax.grad(loss)(theta)
    value = (lambda t: jax.value_and_grad(loss)(t)[0]) if values_from_gradient else loss
    for g, t in zip(jax.tree_util.tree_leaves(grad), jax.tree_util.tree_leaves(theta),
                    strict=True):
        assert np.shape(g) == np.shape(t)
        assert jnp.asarray(g).dtype == jnp.float64
        assert np.all(np.isfinite(np.asarray(g)))
    analytic = _dot(grad, direction)
    numeric = (float(value(_shift(theta, direction, step)))
               - float(value(_shift(theta, direction, -step)))) / (2 * step)
    rel = abs(numeric - analytic) / abs(numeric) if numeric else float("inf")
    return analytic, numeric, rel


def assert_gradient_matches(loss, theta, direction, step, rel_tol, grad=None, label="",
                            values_from_gradient=False):
    """Assert the autodiff directional derivative equals the central difference to
    ``rel_tol`` (relative to the central difference, which must be non-zero: the loss
    depends on θ along v). Returns (analytic, numeric, rel)."""
    analytic, numeric, rel = directional_check(loss, theta, direction, step, grad=grad,
                                               values_from_gradient=values_from_gradient)
    print(f"{label}: grad·v={analytic:.12e} fd={numeric:.12e} rel={rel:.2e}")
    assert numeric != 0.0 and analytic != 0.0, (label, analytic, numeric)
    assert rel <= rel_tol, (label, analytic, numeric, rel)
    return analytic, numeric, rel
