"""Interpolation kernels: the inverse Stolt mapping's (exponential of semicircle on a
deapodized DTFT table) and the windowed sinc of back-projection."""

import functools

import hypothesis
import hypothesis.strategies as st
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sarjax._numerics.es_kernel import spreading_kernel
from sarjax._numerics.interpolation import _sinc_weights, kernel_interpolate_rows, periodic_rows
from sarjax.simulators import _fourier_engine as engine

# worst NMSE against the exact DTFT over the drawn line counts (measured over 1–40 lines and
# 41–420 in steps of 13, two draws each, both precisions: 3 taps −43.6 dB, 4 taps −60.8 dB,
# 5 taps −78.6 dB, all at 10–13 lines, where the period is 1.8× the lines; with the ES
# formula's β instead of the tuned one a drawn 10-line case reached −37.5 / −54.0 / −71.9 dB).
# The other allowed widths, complex128, over 1–59 lines with 8 draws (2, 6, 8 taps) or
# 1–40 and 41–420 in steps of 37 with 2: 2 taps −21.6 dB, 6: −91.8, 7: −113.2, 8: −130.2,
# 9: −149.5, 10: −164.1, 11: −180.5, 12: −199.3, 13: −220.9, 14: −238.3, 15: −251.0,
# 16: −249.9 dB; the bounds leave 2–7 dB (2 taps 1.6 dB: −21.6 dB the worst of 1 732 cases)
_BOUND_DB = {2: -20.0, 3: -38.0, 4: -56.0, 5: -75.0, 6: -88.0, 7: -108.0, 8: -125.0,
             9: -144.0, 10: -158.0, 11: -175.0, 12: -193.0, 13: -215.0, 14: -232.0,
             15: -244.0, 16: -244.0}
# complex64: the table's rounding (1e-7 per value) floors the error at −130 dB (measured
# −129.7 dB at 8 taps, −130.6 dB at 16)
_COMPLEX64_FLOOR_DB = -125.0


@functools.partial(jax.jit, static_argnums=0)
def _stolt_sum(taps, lines, ranges, kappa):
    """``synthesize_grid(grid_dtft(lines, taps), ranges, kappa)`` as in the simulators: in
    one compiled program (each drawn line count is a new shape; op by op, every operation
    compiled again for it)."""
    return engine.synthesize_grid(engine.grid_dtft(lines, taps), ranges, kappa)


@hypothesis.settings(max_examples=15)
@hypothesis.given(n_lines=st.integers(1, 420), taps=st.sampled_from(sorted(_BOUND_DB)),
                  seed=st.integers(0, 2**16))
# the worst cases measured (a period of 1.8–2× the lines): always run
@hypothesis.example(n_lines=10, taps=3, seed=3)
@hypothesis.example(n_lines=10, taps=4, seed=1)
@hypothesis.example(n_lines=13, taps=5, seed=0)
@hypothesis.example(n_lines=10, taps=2, seed=5)
@hypothesis.example(n_lines=15, taps=8, seed=0)
def test_stolt_table_gives_the_exact_dtft_anywhere(n_lines, taps, seed):
    """``grid_dtft`` + ``synthesize_grid`` against the DTFT summed directly,
    ``Σ_j F_j e^{−jκΔr (j − j_c)}``, at positions over the whole period, its wrap at both
    ends and beyond it (κ of either sign), for any number of lines (the table's
    oversampling is ≥ 1.8 whatever the count), for every width allowed (2–16 taps). Both
    precisions: the complex64 table's rounding (1e-7) is far below the kernel's error up
    to 7 taps and is the error from 8."""
    rng = np.random.default_rng(seed)
    n_rows, step = 16, 3.0
    lines = rng.normal(size=(n_lines, n_rows)) + 1j * rng.normal(size=(n_lines, n_rows))
    ranges = 5000.0 + step * np.arange(n_lines)
    p = engine.dtft_length(n_lines)
    positions = rng.uniform(-0.5 * p, 1.5 * p, size=(48, n_rows))
    positions[:4] = np.array([0.0, p - 0.3, p - 3.7, -0.01])[:, None]
    kappa = positions * 2 * np.pi / (p * step)
    j = np.arange(n_lines) - n_lines // 2
    exact = np.einsum("jr,crj->cr", lines, np.exp(-1j * (kappa * step)[..., None] * j))
    for dtype in (jnp.complex128, jnp.complex64):
        got, centre = _stolt_sum(taps, jnp.asarray(lines, dtype), jnp.asarray(ranges),
                                 jnp.asarray(kappa))
        assert float(centre) == ranges[n_lines // 2]
        got = np.asarray(got, complex)
        err = 10 * np.log10(np.sum(np.abs(got - exact) ** 2) / np.sum(np.abs(exact) ** 2))
        bound = _BOUND_DB[taps]
        if dtype == jnp.complex64:
            bound = max(bound, _COMPLEX64_FLOOR_DB)
        assert err <= bound, (dtype, err)


def test_the_grid_table_made_by_one_2d_fft_is_the_lines_table():
    """``grid_spectrum_dtft`` (azimuth DFT and line DTFT in one 2-D FFT, deapodized per
    line) equals ``grid_dtft`` of the azimuth-transformed lines."""
    rng = np.random.default_rng(5)
    values = rng.normal(size=(24, 37)) + 1j * rng.normal(size=(24, 37))
    one = engine.grid_spectrum_dtft(jnp.asarray(values), 32, 4)
    lines = np.fft.fft(values, n=32, axis=0).T  # (n_lines, n_x)
    two = engine.grid_dtft(jnp.asarray(lines), 4)
    assert one.taps == two.taps == 4
    np.testing.assert_allclose(np.asarray(one.rows.values), np.asarray(two.rows.values),
                               rtol=0, atol=1e-11 * np.abs(np.asarray(two.rows.values)).max())


def test_a_kernel_wider_than_the_guard_is_refused():
    rows = periodic_rows(jnp.ones((3, 32), complex), guard=4)
    coefficients, _ = spreading_kernel(6, engine.STOLT_OVERSAMPLING)
    with pytest.raises(ValueError, match="6 taps"):
        kernel_interpolate_rows(rows, jnp.zeros((2, 3)), coefficients)


_WEIGHTS = jax.jit(_sinc_weights, static_argnums=(1, 2))  # one program per (taps, dtype)


@hypothesis.settings(max_examples=20)
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
