"""Gradients through ``sj.simulate`` against central finite differences.

For each parameter θ (per-pulse Δy, Δz, δ_az, the complex reflectivity, the carrier
frequency) the autodiff directional derivative ∇L·v along a random direction v is
compared with the central difference (L(θ + h v) − L(θ − h v)) / (2h), all in float64.

The loss is L = Σ |h(x', r') − target|² with a target simulated at *different*
parameters (carrier offset 2 kHz, perturbed motion and reflectivities) plus complex
noise, so the gradient along every parameter is coherent (not a sum of random-sign
terms that nearly cancels) and the base point is not a stationary point.

Choice of h (relative error of the central difference ≈ truncation + round-off):
  * truncation ≈ (L'''/L') h² / 6. Every parameter enters mainly through the two-way
    phase 4πR f / c, so the scale is set by how fast that phase moves;
  * round-off ≈ ε_phase / (h · |∂phase/∂θ|), ε_phase ≈ ulp(4πR/λ ≈ 2e6 rad) ≈ 5e-10 rad.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import sarjax as sj

try:
    from _gradients import assert_gradient_matches
except ImportError:
    from tests._gradients import assert_gradient_matches

REL_TOL = 1e-5

# 48 pulses spaced v/PRF = 6.25 m span ±147 m, about the footprint λr/L ≈ 160 m, so
# the antenna pattern (hence the pointing error) matters. τ = 1 µs: the chirp spans
# cτ/2 ≈ 150 m ≈ 50 range samples of c/(2 f_s) ≈ 3 m; the window 4900 … 5377 m holds
# all three echoes (5020 … 5260 m ± 75 m plus a range migration of ≲ 3 m).
NUM_PULSES = 48
NUM_RANGE = 160
NEAR_RANGE = 4900.0
RADAR_OVERRIDES = dict(
    carrier_frequency=9.65e9,
    bandwidth=40e6,
    chirp_duration=1e-6,
    sampling_rate=50e6,
    prf=16.0,
    velocity=100.0,
    height=3000.0,
    antenna_length=1.0,
    num_pulses=NUM_PULSES,
    num_range=NUM_RANGE,
    near_range=NEAR_RANGE,
)
TARGETS = dict(
    azimuth=[-40.0, 0.0, 55.0],
    range=[5020.0, 5140.0, 5260.0],
    reflectivity=[1.0 + 0.0j, 0.6 - 0.8j, -0.3 + 0.45j],
    height=[0.0, 20.0, -10.0],
)

# Step sizes (see the module docstring). Measured relative errors over several random
# directions: Δy, Δz ≲ 7e-9, δ_az ≲ 5e-8, γ ≲ 1e-14, f ≈ 2e-8 … 3e-7.
#  * Δy, Δz: ∂phase/∂Δ = 4π/λ · (cos/sin of the look angle) ≲ 400 rad/m. h = 1e-7 m
#    moves the phase by 4e-5 rad: truncation ~ (4e-5)²/6 ~ 3e-10, round-off in R − r
#    (a few m, ulp ~ 1e-15 m) ~ 1e-8 relative.
#  * δ_az: enters only through the pattern, u = (x' − x − r δ_az)/X with r/X = L/λ ≈ 32.
#    The truncation constant is ≲ 1e5 rad⁻² (measured: h = 1e-5 rad → ≲ 1e-5), so
#    h = 1e-9 rad gives ≲ 1e-13 truncation; round-off grows as 1/h and is measured at
#    ≲ 5e-8 for h = 1e-9 (≈ 1e-7 at h = 1e-10), still 200× below the tolerance.
#  * γ: L is quadratic in (Re γ, Im γ), so the central difference is exact for any h;
#    h = 0.1 keeps round-off at the 1e-15 level.
#  * f: ∂phase/∂f = 4πR/c ≈ 2.1e-4 rad/Hz. The rounding of 4πR/λ (~5e-10 rad) is
#    common to all pulses of a target, giving round-off ~1e-6 / (h/Hz); truncation is
#    ~1.4e-8 (h/Hz)² (measured). h = 4 Hz balances them at ~3e-7 total; h = 1e-3 Hz
#    would be dominated by round-off (~1e-3) and h = 100 Hz by truncation (~1e-4).
STEPS = dict(
    horizontal=1e-7,
    vertical=1e-7,
    pointing=1e-9,
    reflectivity=0.1,
    carrier_frequency=4.0,
)


def _radar():
    return sj.presets.airborne_xband(**RADAR_OVERRIDES)


def _pulse_azimuths(radar):
    index = np.arange(NUM_PULSES) - (NUM_PULSES - 1) / 2
    return index * float(radar.azimuth_spacing)


def _simulate(radar, scene, horizontal, vertical, pointing, dtype=jnp.complex128, **options):
    motion = sj.Motion(horizontal=horizontal, vertical=vertical, pointing=pointing)
    return sj.simulate(
        radar,
        scene,
        motion,
        num_pulses=NUM_PULSES,
        num_range=NUM_RANGE,
        near_range=NEAR_RANGE,
        dtype=dtype,
        **options,
    ).data


@pytest.fixture(scope="module")
def problem():
    """A non-zero base point (cm-level smooth Δy, Δz; seed jitter δ_m = λ/(20L))."""
    radar = _radar()
    scene = sj.PointTargets(**TARGETS)
    x = _pulse_azimuths(radar)
    footprint = float(radar.footprint(radar.reference_range))
    base = dict(
        horizontal=sj.smooth_deviation(x, key=1, rms=0.03, max_cycles=3, aperture=footprint),
        vertical=sj.smooth_deviation(x, key=2, rms=0.02, max_cycles=3, aperture=footprint),
        pointing=np.asarray(sj.seed_pointing_jitter(radar, x)),
    )
    # δ_m = λ/(20 L) ≈ 1.55e-3 rad
    assert np.isclose(np.max(np.abs(base["pointing"])), float(radar.wavelength) / 20, rtol=0.05)

    # Target: the same scene seen with a 2 kHz carrier offset, perturbed motion and
    # reflectivities, plus noise.
    rng = np.random.default_rng(12345)
    truth = _simulate(
        radar.replace(carrier_frequency=radar.carrier_frequency + 2e3),
        sj.PointTargets(**{**TARGETS, "reflectivity": np.array(TARGETS["reflectivity"]) * 1.1j}),
        base["horizontal"] + 2e-3 * np.sin(x / 30.0),
        1.1 * base["vertical"],
        0.8 * base["pointing"],
    )
    noise = rng.normal(size=truth.shape) + 1j * rng.normal(size=truth.shape)
    target = np.asarray(truth) + 0.05 * noise
    return dict(radar=radar, scene=scene, base=base, target=target, rng=rng)


def _loss_fn(problem, name, dtype=jnp.complex128, **options):
    """(L(θ), θ₀) for one parameter, the others held at the base point."""
    radar, scene, base = problem["radar"], problem["scene"], problem["base"]
    target = jnp.asarray(problem["target"])

    def misfit(data):
        return jnp.sum(jnp.abs(data.astype(jnp.complex128) - target) ** 2)

    if name in ("horizontal", "vertical", "pointing"):

        def loss(theta):
            return misfit(_simulate(radar, scene, **{**base, name: theta}, dtype=dtype,
                                    **options))

        return loss, jnp.asarray(base[name])

    if name == "reflectivity":
        # real parametrisation θ = (Re γ, Im γ), shape (2, scatterer)
        def loss(theta):
            s = eqx.tree_at(lambda s: s.reflectivity, scene, theta[0] + 1j * theta[1])
            return misfit(_simulate(radar, s, **base, dtype=dtype, **options))

        gamma = np.asarray(scene.reflectivity)
        return loss, jnp.asarray(np.stack([gamma.real, gamma.imag]))

    if name == "carrier_frequency":

        def loss(theta):
            r = eqx.tree_at(lambda r: r.carrier_frequency, radar, theta)
            return misfit(_simulate(r, scene, **base, dtype=dtype, **options))

        return loss, jnp.asarray(radar.carrier_frequency)

    raise AssertionError(name)


@pytest.mark.parametrize("name", list(STEPS))
def test_directional_derivative_matches_central_difference(problem, name):
    loss, theta0 = _loss_fn(problem, name)
    v = jnp.asarray(problem["rng"].normal(size=theta0.shape))
    if theta0.ndim == 0:
        v = jnp.asarray(1.0)
    assert_gradient_matches(loss, theta0, v, STEPS[name], REL_TOL, label=name)


def _joint_loss(problem, dtype=jnp.complex128, **options):
    """(L(θ), θ₀) with θ a dict of every parameter (one gradient for all of them)."""
    radar, scene = problem["radar"], problem["scene"]
    target = jnp.asarray(problem["target"])
    gamma = np.asarray(scene.reflectivity)
    theta0 = {name: jnp.asarray(problem["base"][name])
              for name in ("horizontal", "vertical", "pointing")}
    theta0["reflectivity"] = jnp.asarray(np.stack([gamma.real, gamma.imag]))
    theta0["carrier_frequency"] = jnp.asarray(radar.carrier_frequency)

    def loss(theta):
        r = eqx.tree_at(lambda r: r.carrier_frequency, radar, theta["carrier_frequency"])
        s = eqx.tree_at(lambda s: s.reflectivity, scene,
                        theta["reflectivity"][0] + 1j * theta["reflectivity"][1])
        data = _simulate(r, s, theta["horizontal"], theta["vertical"], theta["pointing"],
                         dtype=dtype, **options)
        return jnp.sum(jnp.abs(data.astype(jnp.complex128) - target) ** 2)

    return loss, theta0


def _relative_differences(grad, reference):
    return {
        name: float(np.linalg.norm(np.asarray(grad[name]) - np.asarray(reference[name]))
                    / np.linalg.norm(np.asarray(reference[name])))
        for name in reference
    }


def test_gradient_independent_of_chunking(problem):
    """Chunking that pads scatterers (3 → 2 chunks of 2, γ = 0 padding) and leaves a
    partial pulse batch (48 = 2·20 + 8) gives the same gradient as the default."""
    loss, theta0 = _joint_loss(problem)
    loss_chunked, _ = _joint_loss(problem, pulse_chunk=20, scatterer_chunk=2)
    reference = jax.grad(loss)(theta0)
    chunked = jax.grad(loss_chunked)(theta0)
    for name, err in _relative_differences(chunked, reference).items():
        assert err < 1e-12, (name, err)


def test_gradients_at_beam_centre_on_ideal_track():
    """Zero deviations and a target exactly under a pulse (x' − x = 0, u = 0, sinc² peak,
    δr_xr = 0): the gradients are finite and still match finite differences."""
    radar = _radar()
    x = _pulse_azimuths(radar)
    scene = sj.PointTargets(azimuth=[x[NUM_PULSES // 2]], range=[5140.0])
    rng = np.random.default_rng(7)
    weight = jnp.asarray(rng.normal(size=(NUM_PULSES, NUM_RANGE))
                         + 1j * rng.normal(size=(NUM_PULSES, NUM_RANGE)))
    names = ("horizontal", "vertical", "pointing")
    theta0 = {name: jnp.zeros(NUM_PULSES) for name in names}

    def loss(theta):
        data = _simulate(radar, scene, **theta)
        # Re/Im-weighted sum plus a quadratic term
        return jnp.sum(jnp.real(weight * data)) + jnp.sum(jnp.abs(data) ** 2)

    grad = jax.grad(loss)(theta0)
    for name in names:
        v = {**{other: jnp.zeros(NUM_PULSES) for other in names},
             name: jnp.asarray(rng.normal(size=NUM_PULSES))}
        assert_gradient_matches(loss, theta0, v, STEPS[name], REL_TOL, grad=grad, label=name)


def test_complex64_gradients_are_finite(problem):
    """complex64 kernels: finite, non-zero gradients for every parameter, close to the
    complex128 ones (complex64 keeps the phase error ≲ 1e-3 rad)."""
    loss64, theta0 = _joint_loss(problem, dtype=jnp.complex64)
    loss128, _ = _joint_loss(problem)
    grad64 = jax.grad(loss64)(theta0)
    for name, g in grad64.items():
        g = np.asarray(g)
        assert g.dtype == np.float64, name
        assert np.all(np.isfinite(g)), name
        assert np.any(g != 0), name
    grad128 = jax.grad(loss128)(theta0)
    for name, err in _relative_differences(grad64, grad128).items():
        assert err < 1e-3, (name, err)
