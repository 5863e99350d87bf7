"""Unit phasors from multiply-adds (sarjax._numerics.phasor) against NumPy's libm."""

import hypothesis
import hypothesis.strategies as st
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sarjax._numerics.phasor import (
    broadcast_phasor,
    reduced_phasor,
    sine,
    unit_phasor,
    wrap_phase,
)


@pytest.mark.parametrize("scale", [1.0, 1e3, 1e6, 1e9])
def test_unit_phasor_matches_numpy(scale):
    """Documented bound: |error| ≤ 2e-16 + 2e-16·|φ| (the second term is the rounding of
    φ itself: carrier phases at 800 km slant range are ~1e8 rad)."""
    rng = np.random.default_rng(0)
    phase = np.concatenate([rng.uniform(-scale, scale, 100_000),
                            np.arange(-8, 9) * np.pi / 4])  # quadrant boundaries
    got = np.asarray(jax.jit(unit_phasor)(jnp.asarray(phase)))
    error = np.abs(got - np.exp(1j * phase))
    assert np.all(error <= 2e-16 + 2e-16 * np.abs(phase) + 1e-16), error.max()
    assert got.dtype == np.complex128


@hypothesis.settings(max_examples=50)
@hypothesis.given(phase=st.floats(-1e9, 1e9))
def test_wrap_phase_is_the_phase_less_whole_turns(phase):
    """In [−π, π], and φ less a whole number of turns to ≤ 2e-16·|φ| + 1e-15 rad (its
    documented rounding; a carrier k₀r of the spaceborne sets is ~1e8 rad)."""
    wrapped = float(wrap_phase(jnp.float64(phase)))
    assert -np.pi <= wrapped <= np.pi
    turns = (phase - wrapped) / (2 * np.pi)
    assert abs(turns - round(turns)) * 2 * np.pi <= 2e-16 * abs(phase) + 1e-15
    assert abs(np.exp(1j * wrapped) - np.exp(1j * np.fmod(phase, 2 * np.pi))) <= (
        4e-16 * abs(phase) + 1e-15)


def test_unit_phasor_float32_and_sine():
    rng = np.random.default_rng(1)
    phase = rng.uniform(-1e3, 1e3, 10_000).astype(np.float32)
    got = np.asarray(unit_phasor(jnp.asarray(phase)))
    assert got.dtype == np.complex64
    exact = np.exp(1j * phase.astype(np.float64))
    assert np.max(np.abs(got - exact)) <= 1e-6 + 1.2e-7 * 1e3
    x = rng.uniform(-50, 50, 10_000)
    assert np.max(np.abs(np.asarray(sine(jnp.asarray(x))) - np.sin(x))) <= 1e-15


def test_derivatives_are_exact():
    """d e^{jφ}/dφ = j e^{jφ}, d sin x/dx = cos x (custom JVPs; reverse mode too)."""
    phase = jnp.linspace(-20.0, 20.0, 101)
    tangent = jax.jvp(unit_phasor, (phase,), (jnp.ones_like(phase),))[1]
    np.testing.assert_allclose(tangent, 1j * np.exp(1j * np.asarray(phase)), atol=1e-15)
    grad = jax.grad(lambda p: jnp.sum(jnp.real(unit_phasor(p) * (0.3 - 0.7j))))(phase)
    np.testing.assert_allclose(grad, np.real(1j * np.exp(1j * np.asarray(phase)) * (0.3 - 0.7j)),
                               atol=1e-15)
    np.testing.assert_allclose(jax.vmap(jax.grad(sine))(phase), np.cos(phase), atol=1e-15)


@hypothesis.settings(max_examples=25)
@hypothesis.given(scale=st.floats(1e-3, 1e6), seed=st.integers(0, 2**16))
def test_reduced_phasor_float32_error_does_not_grow_with_the_phase(scale, seed):
    """complex64 phasors of float64 phases of any size (κ r ~ 10⁴ rad in the Fourier
    engine): reduced in float64 first, the float32 series keeps 1e-6 whatever |φ|, where
    casting φ first would carry 6e-8·|φ| (0.06 rad at 10⁶)."""
    phase = np.random.default_rng(seed).uniform(-scale, scale, 4096)
    got = np.asarray(reduced_phasor(jnp.asarray(phase), jnp.complex64))
    assert got.dtype == np.complex64
    assert np.max(np.abs(got - np.exp(1j * phase))) <= 1e-6
    # complex128: the unreduced float64 phasor, unchanged
    np.testing.assert_array_equal(np.asarray(reduced_phasor(jnp.asarray(phase), jnp.complex128)),
                                  np.asarray(unit_phasor(jnp.asarray(phase))))


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_broadcast_phasor_is_the_phasor_and_its_derivative(dtype):
    """1 / e^{−jφ} equals e^{jφ} to the phasor's bound plus one rounding of the division
    (2⁻⁵³ / 2⁻²⁴ relative), also inside a jitted product that broadcasts it (the form it
    exists for); its derivative is j e^{jφ} (autodiff through the division)."""
    rng = np.random.default_rng(2)
    phase = rng.uniform(-1e3, 1e3, 4096).astype(dtype)
    exact = np.exp(1j * phase.astype(np.float64))
    bound = (2e-16 + 2e-16 * 1e3 + 3e-16) if dtype == np.float64 else (1e-6 + 1.2e-7 * 1e3
                                                                         + 1.2e-7)
    got = np.asarray(broadcast_phasor(jnp.asarray(phase)))
    assert got.dtype == (np.complex128 if dtype == np.float64 else np.complex64)
    assert np.max(np.abs(got - exact)) <= bound
    rows = jnp.asarray(rng.normal(size=(7, phase.size)).astype(dtype))
    product = np.asarray(jax.jit(lambda a, p: a * broadcast_phasor(p)[None, :])(
        rows, jnp.asarray(phase)))
    assert np.max(np.abs(product - np.asarray(rows) * exact[None, :])) <= 5 * bound
    small = jnp.linspace(-20.0, 20.0, 101)
    tangent = jax.jvp(broadcast_phasor, (small,), (jnp.ones_like(small),))[1]
    np.testing.assert_allclose(np.asarray(tangent), 1j * np.exp(1j * np.asarray(small)),
                               atol=1e-14)
