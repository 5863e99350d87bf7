"""The native spreading kernel of the NUFFT exact model (sarjax._numerics.native) against
its JAX formulation (simulators._nufft._spread_xla), which stays the reference.

Drawn cases cover every kernel width (2 … 16), both precisions, points inside the grid,
at its edges and within the reach outside it that wraps, and points far outside (which
carry zero amplitude in the simulator and are clamped)."""

from __future__ import annotations

import functools
import shutil

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import sarjax as sj
from sarjax._data import Acquisition
from sarjax._numerics import native
from sarjax._numerics.es_kernel import spreading_kernel
from sarjax.simulators import _nufft

try:
    from _gradients import assert_gradient_matches
    from _strategies import NOT_THE_SIMPLEST
except ImportError:
    from tests._gradients import assert_gradient_matches
    from tests._strategies import NOT_THE_SIMPLEST

COMPILER = any(shutil.which(name) for name in ("c++", "g++", "clang++"))
needs_native = pytest.mark.skipif(not native.available(),
                                  reason=f"native kernels: {native.status()}")
POINTS = 192  # one length for every draw: one program per (width, dtype, grid)


def test_a_machine_with_a_compiler_builds_the_kernel():
    """Where a C++ compiler is on the PATH (CI), the kernel must build and load: the
    comparisons below would otherwise skip and the simulator run the slower path."""
    if not COMPILER:
        pytest.skip("no C++ compiler on this machine")
    assert native.available(), native.status()
    assert native.status() == "native"


def _spread(points, amplitude, width, grid, use_native):
    coefficients, _ = spreading_kernel(width, 2.0)
    return _nufft._spread(points, amplitude, width, grid, coefficients, grid / 2, use_native)


_programs = {}


def _program(width, grid, use_native):
    key = (width, grid, use_native)
    if key not in _programs:
        _programs[key] = jax.jit(lambda p, a: _spread(p, a, width, grid, use_native))
    return _programs[key]


@st.composite
def spreads(draw):
    draw(NOT_THE_SIMPLEST)
    width = draw(st.integers(2, 16))
    grid = draw(st.sampled_from([16, 96]))
    dtype = draw(st.sampled_from([np.complex64, np.complex128]))
    seed = draw(st.integers(0, 2**31 - 1))
    rng = np.random.default_rng(seed)
    reach = grid / 2
    # where the points lie: inside, on the grid's edges, in the reach that wraps
    kind = rng.integers(0, 3, POINTS)
    inside = rng.uniform(0, grid, POINTS)
    edge = rng.choice([0.0, grid, -reach, grid + reach], POINTS) + rng.uniform(-1e-9, 1e-9,
                                                                               POINTS)
    wrap = rng.uniform(-reach, grid + reach, POINTS)
    points = np.select([kind == 0, kind == 1], [inside, np.clip(edge, -reach, grid + reach)],
                       wrap)
    amplitude = rng.normal(size=POINTS) + 1j * rng.normal(size=POINTS)
    # far outside (the simulator masks these to zero amplitude; they are clamped)
    far = rng.random(POINTS) < 0.1
    points[far] = rng.choice([-1e9, -5.0 * grid, 7.0 * grid, 1e12], far.sum())
    amplitude[far] = 0.0
    amplitude[rng.random(POINTS) < 0.1] = 0.0
    return width, grid, points, amplitude.astype(dtype)


@needs_native
@settings(max_examples=10)
@given(spreads())
def test_native_spread_equals_the_jax_formulation(case):
    """Equal to rounding, and so is the JAX formulation's form for other backends (real
    and imaginary parts scattered apart): the same float64 fraction and first cell, the
    same polynomial taps in the amplitude's precision; only the order of the additions
    differs (bound:
    a few units of the precision's rounding times Σ|a_P|, the taps being ≤ 1)."""
    width, grid, points, amplitude = case
    p, a = jnp.asarray(points), jnp.asarray(amplitude)
    reference = np.asarray(_program(width, grid, False)(p, a))
    ours = np.asarray(_program(width, grid, True)(p, a))
    # the JAX formulation other backends run (real and imaginary parts scattered apart)
    coefficients, _ = spreading_kernel(width, 2.0)
    pairs = np.asarray(jax.jit(functools.partial(
        _nufft._spread_taps, width=width, grid=grid, coefficients=coefficients,
        reach=grid / 2, pairs=True))(p, a))
    eps = np.finfo(np.asarray(amplitude).real.dtype).eps
    bound = 8 * width * eps * np.abs(amplitude).sum()
    assert ours.dtype == pairs.dtype == amplitude.dtype
    assert np.max(np.abs(ours - reference)) <= bound
    assert np.max(np.abs(pairs - reference)) <= bound


@needs_native
def test_nonfinite_positions_stay_in_bounds():
    """A NaN or infinite position is clamped to the grid's reach like any point far
    outside (no write outside the buffer). A NaN position's taps are NaN, as in the JAX
    formulation (which places them in other cells: both outputs show it, neither hides
    it); the finite point lands alike in both."""
    p = jnp.asarray([np.nan, np.inf, -np.inf, 3.2])
    a = jnp.asarray([0.0, 0.0, 0.0, 1.0 + 0.5j])
    ours = np.asarray(_program(5, 24, True)(p, a))
    reference = np.asarray(_program(5, 24, False)(p, a))
    assert ours.shape == (24,)
    assert np.isnan(ours).any() and np.isnan(reference).any()
    both = ~np.isnan(ours) & ~np.isnan(reference)
    np.testing.assert_allclose(ours[both], reference[both], rtol=0, atol=1e-14)
    finite = np.asarray(_program(5, 24, True)(p[3:], a[3:]))
    assert np.count_nonzero(finite) == 5


@needs_native
def test_vmap_equals_one_call_per_row():
    rng = np.random.default_rng(3)
    p = jnp.asarray(rng.uniform(-10, 40, (3, POINTS)))
    a = jnp.asarray(rng.normal(size=(3, POINTS)) + 1j * rng.normal(size=(3, POINTS)))
    batched = jax.jit(jax.vmap(lambda p, a: _spread(p, a, 5, 24, True)))(p, a)
    for row in range(3):
        np.testing.assert_allclose(batched[row], _program(5, 24, True)(p[row], a[row]),
                                   rtol=0, atol=1e-13)


@needs_native
def test_gradient_through_the_native_kernel_matches_finite_differences():
    """Differentiable w.r.t. positions and amplitudes: its derivatives are the JAX
    formulation's (custom JVP), checked here against float64 central differences."""
    rng = np.random.default_rng(5)
    points = jnp.asarray(rng.uniform(0, 24, 40))
    amplitude = jnp.asarray(rng.normal(size=40) + 1j * rng.normal(size=40))
    weights = jnp.asarray(rng.normal(size=24) + 1j * rng.normal(size=24))

    def loss(theta):
        out = _spread(theta["points"], theta["re"] + 1j * theta["im"], 6, 24, True)
        return jnp.sum(jnp.real(out * weights)) + 0.1 * jnp.sum(jnp.abs(out) ** 2)

    theta = {"points": points, "re": jnp.real(amplitude), "im": jnp.imag(amplitude)}
    direction = {k: jnp.asarray(rng.normal(size=40)) for k in theta}
    # the loss is a polynomial of degree 2·7 in the fractions: truncation ≈ 1e-9 at
    # h = 1e-5, round-off ≈ 1e-11
    assert_gradient_matches(loss, theta, direction, 1e-5, 1e-7, label="native spread")


@needs_native
def test_simulator_uses_the_kernel_and_agrees_with_the_jax_path(monkeypatch):
    """``time_domain_nufft`` plans the native kernel where it is available and gives the
    JAX path's data to rounding; ``SARJAX_NATIVE=0`` plans the JAX path."""
    radar = sj.presets.airborne_xband(num_pulses=64, num_range=128)
    scene = sj.PointTargets(azimuth=[-3.0, 0.5, 40.0], range=[5120.0, 5140.0, 5300.0],
                            reflectivity=[1.0, 0.5j, 2.0])
    kw = dict(method="time_domain_nufft", num_pulses=64, num_range=128, near_range=5100.0)
    acquisition = Acquisition(num_pulses=64, num_range=128, near_range=5100.0,
                              azimuth_center=0.0)
    simulator = sj.simulators.TimeDomainNUFFT()
    assert simulator.prepare(radar, scene, acquisition).native
    ours = sj.simulate(radar, scene, **kw)
    monkeypatch.setenv(native.ENV_SWITCH, "0")
    assert not native.available()
    assert not simulator.prepare(radar, scene, acquisition).native
    jax_path = sj.simulate(radar, scene, **kw)
    scale = np.abs(np.asarray(jax_path.data)).max()
    # complex128: the two differ by the order of the spreading's additions
    np.testing.assert_allclose(ours.data, jax_path.data, rtol=0, atol=1e-12 * scale)


def test_a_failed_build_is_an_error_the_loader_reports(monkeypatch, tmp_path):
    """A compiler that fails leaves no library behind and raises (``available`` turns
    that into the JAX path, with the reason in ``status``)."""
    monkeypatch.setenv("CXX", "false")
    monkeypatch.setenv(native.ENV_DIR, str(tmp_path))
    with pytest.raises(RuntimeError, match="false failed"):
        native._build()
    assert list(tmp_path.iterdir()) == []


@needs_native
def test_programs_for_other_backends_take_the_jax_formulation():
    """The kernel is registered for the CPU only: a program lowered for a GPU (here by
    ``jax.export``, no GPU needed) must not call it, one for the CPU must."""
    program = _program(5, 96, True)
    args = (jnp.zeros(8), jnp.zeros(8, jnp.complex64))
    allow = [jax.export.DisabledSafetyCheck.custom_call(native.TARGETS[np.dtype(np.complex64)])]
    for platforms, calls in ((["cpu"], True), (["cuda"], False), (["rocm"], False)):
        exported = jax.export.export(program, platforms=platforms, disabled_checks=allow)(*args)
        assert ("sarjax_spread" in exported.mlir_module()) == calls, platforms


def test_a_changed_kernel_source_keys_new_programs(tmp_path):
    """The serialised programs' key digests the package's ``.cc`` files too: an edited
    kernel never runs under a program kept from before (``sarjax._exported``)."""
    from sarjax import _exported

    (tmp_path / "module.py").write_text("x = 1\n")
    (tmp_path / "native").mkdir()
    kernel = tmp_path / "native" / "kernel.cc"
    kernel.write_text("int f() { return 1; }\n")
    before = _exported._source_digest(tmp_path)
    kernel.write_text("int f() { return 2; }\n")
    assert _exported._source_digest(tmp_path) != before
    assert native.SOURCE.suffix == ".cc" and native.SOURCE.exists()


def test_without_a_working_compiler_the_simulator_runs_the_jax_path(monkeypatch, tmp_path):
    """A process whose build fails (here a compiler that always fails) reports why in
    ``status``, plans the JAX path and simulates as before."""
    monkeypatch.setattr(native, "_library", None)
    monkeypatch.setattr(native, "_reason", "not tried")
    monkeypatch.setenv("CXX", "false")
    monkeypatch.setenv(native.ENV_DIR, str(tmp_path))
    assert not native.available()
    assert native.status().startswith("unavailable: false failed")
    radar = sj.presets.airborne_xband(num_pulses=32, num_range=96)
    scene = sj.PointTargets(azimuth=[0.0], range=[5140.0])
    acquisition = Acquisition(num_pulses=32, num_range=96, near_range=5100.0,
                              azimuth_center=0.0)
    assert not sj.simulators.TimeDomainNUFFT().prepare(radar, scene, acquisition).native
    raw = sj.simulate(radar, scene, method="time_domain_nufft", num_pulses=32, num_range=96,
                      near_range=5100.0)
    assert np.isfinite(np.asarray(raw.data)).all() and np.abs(np.asarray(raw.data)).max() > 0
