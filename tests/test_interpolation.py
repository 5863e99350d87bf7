"""Windowed-sinc interpolation of periodic rows (the inverse Stolt mapping's kernel)."""

import hypothesis
import hypothesis.strategies as st
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sarjax._numerics.interpolation import _sinc_weights, periodic_rows, sinc_interpolate_rows
from sarjax.simulators._fourier_engine import dtft_length


def _rows_and_exact(n_lines, n_rows, positions, rng):
    """DTFT table (n_rows, p) of random sequences on j ∈ [−n/2, n/2) and the exact DTFT at
    ``positions`` (m, n_rows) in table samples."""
    p = dtft_length(n_lines)
    f = rng.normal(size=(n_rows, n_lines)) + 1j * rng.normal(size=(n_rows, n_lines))
    j = np.arange(n_lines) - n_lines // 2
    padded = np.zeros((n_rows, p), complex)
    padded[:, j % p] = f
    omega = 2 * np.pi * positions / p
    exact = np.einsum("rj,crj->cr", f, np.exp(-1j * omega[..., None] * j))
    return np.fft.fft(padded, axis=1), exact


@pytest.mark.parametrize("taps, bound_db", [(8, -45.0), (6, -31.0)])
def test_matches_exact_dtft_across_the_period(taps, bound_db):
    """8 taps on rows oversampled 1.8×: −49 dB measured (the kernel's own limit, as at
    2×); 6 taps (range aliases): −34.5 dB. Positions cover the wrap at both ends of the
    period and beyond it (negative, > p)."""
    rng = np.random.default_rng(3)
    n_lines, n_rows = 101, 16
    p = dtft_length(n_lines)
    positions = rng.uniform(-0.5 * p, 1.5 * p, size=(64, n_rows))
    positions[:4] = np.array([0.0, p - 0.3, p - 3.7, -0.01])[:, None]
    table, exact = _rows_and_exact(n_lines, n_rows, positions, rng)
    for given in (jnp.asarray(table), periodic_rows(jnp.asarray(table))):
        got = np.asarray(sinc_interpolate_rows(given, jnp.asarray(positions), taps=taps))
        err = 10 * np.log10(np.sum(np.abs(got - exact) ** 2) / np.sum(np.abs(exact) ** 2))
        assert err <= bound_db, err


def test_integer_positions_return_the_samples():
    rng = np.random.default_rng(4)
    table = rng.normal(size=(5, 40)) + 1j * rng.normal(size=(5, 40))
    positions = np.array([[0.0, 7.0, 39.0, 40.0, -1.0]])
    got = np.asarray(sinc_interpolate_rows(jnp.asarray(table), jnp.asarray(positions)))
    want = table[np.arange(5), np.mod(positions[0].astype(int), 40)]
    np.testing.assert_allclose(got[0], want, rtol=1e-12, atol=1e-12)


def test_guard_shorter_than_taps_is_refused():
    rows = periodic_rows(jnp.ones((3, 32), complex), guard=4)
    with pytest.raises(ValueError, match="taps=8"):
        sinc_interpolate_rows(rows, jnp.zeros((2, 3)), taps=8)


_WEIGHTS = jax.jit(_sinc_weights, static_argnums=(1, 2))  # one program per (taps, dtype)


@hypothesis.settings(max_examples=20, deadline=None)
@hypothesis.given(taps=st.sampled_from([4, 8, 16]), seed=st.integers(0, 2**16),
                  edge=st.floats(1e-9, 1e-3))
def test_float32_weights_keep_their_relative_precision_at_the_samples(taps, seed, edge):
    """The kernel weights in float32 (complex64 tables) from positions in float64, drawn
    anywhere and just either side of a sample (f → 0 and f → 1, where sin πf and f − 1
    are small): within 5e-7 of the float64 closed form. Formed from f ∈ [0, 1) cast to
    float32 they were off by up to 8e-3 near f = 1."""
    rng = np.random.default_rng(seed)
    whole = rng.integers(0, 700, 512).astype(float)
    positions = np.concatenate([rng.uniform(0, 700, 512), whole + edge, whole - edge])
    half = taps // 2
    frac = positions - np.floor(positions)
    d = frac[:, None] - np.arange(-half + 1, half + 1)[None, :]
    expected = np.sinc(d) * np.clip(1 - (d / half) ** 2, 0, 1) ** 3
    for dtype, bound in ((jnp.float64, 1e-14), (jnp.float32, 5e-7)):
        base, weights, _ = _WEIGHTS(jnp.asarray(positions), taps, dtype)
        np.testing.assert_array_equal(np.asarray(base), np.floor(positions))
        assert np.max(np.abs(np.asarray(weights, float) - expected)) <= bound, dtype
