"""A gradient check for every simulator and for ``focus``, through the public API.

Each test differentiates a loss of the output once (``jax.grad``, complex128 kernels) and
compares ∇L·v along random directions v with central differences (``tests/_gradients.py``).
The time-domain, NUFFT and broadside Fourier simulators (small and moderate deviation)
are checked w.r.t. the motion in test_gradients.py, test_nufft.py and
test_fourier_gradients.py; here: ``fourier_2d``, the squinted Fourier simulators,
``chirp_scaling``, ``high_speed`` (static and moving targets) and ``focus``.

What is not differentiable through ``sj.simulate``: the Fourier-domain simulators fix their
FFT sizes, paddings and (``high_speed``) velocity groups from concrete scatterer ranges,
velocities and radar parameters when the call is prepared, so those enter as constants;
they are differentiable in the reflectivities and the scatterer azimuths (and the
squinted deviation simulators in the motion; A and B in the scatterer heights).

Small grids (64 pulses × 128 range samples, 1 µs chirps, two targets) keep every test to
one compilation of the differentiated program: the shifted losses are taken from it
(``values_from_gradient=True``).
"""

from __future__ import annotations

import warnings

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

NUM_PULSES, NUM_RANGE = 64, 128
RANGE = 5140.0
# 6.25 m pulse spacing: 64 pulses span 400 m, about 2.5 footprints, so the antenna pattern
# tapers the echoes within the window; a 1 µs chirp is 50 of the 128 range samples.
SMALL = dict(prf=16.0, chirp_duration=1e-6, num_pulses=NUM_PULSES, num_range=NUM_RANGE)
# the high-speed platform of test_high_speed.py (7500 m/s at 1200 Hz: 6.25 m spacing)
FAST = dict(carrier_frequency=9.65e9, bandwidth=40e6, chirp_duration=1e-6,
            sampling_rate=50e6, prf=1200.0, velocity=7500.0, height=3000.0,
            antenna_length=1.0, num_pulses=NUM_PULSES, num_range=NUM_RANGE)

# Steps: the loss is quadratic in (Re γ, Im γ), so the central difference is exact up to
# round-off at any step; an azimuth shift moves the phase history by ≲ (4π/λ)(200 m / r)
# ≈ 16 rad/m, so 1e-6 m keeps the truncation ~1e-11 and the round-off ~1e-9; the
# deviations and pointing steps are those of test_fourier_gradients.py.
STEPS = dict(reflectivity=0.1, azimuth=1e-6, height=1e-4, horizontal=1e-7, vertical=1e-7,
             pointing=1e-8)
# measured ≲ 1e-8 (azimuth, motion) and ~1e-14 (reflectivity): the tolerance of the other
# gradient tests, 1e-5, leaves the room that a wrong gradient (≳ 1e-3) never has
REL_TOL = 1e-5


def _radar(squint_deg=0.0, **overrides):
    return sj.presets.airborne_xband(**{**SMALL, "squint": np.deg2rad(squint_deg),
                                        **overrides})


def _window(radar):
    """The acquisition about the beam-centre range of the middle target."""
    near = RANGE / np.cos(float(radar.squint)) - NUM_RANGE // 2 * float(radar.range_spacing)
    return dict(num_pulses=NUM_PULSES, num_range=NUM_RANGE, near_range=near)


def _scene(radar, **extra):
    """Two targets the beam sees at the middle pulses (squint: shifted by r tan φ_d)."""
    shift = RANGE * np.tan(float(radar.squint))
    return sj.PointTargets(azimuth=[-20.0 + shift, 15.0 + shift], range=[5110.0, 5170.0],
                           reflectivity=[1.0, 0.6 - 0.3j], **extra)


def _motion_base(radar):
    x = (np.arange(NUM_PULSES) - (NUM_PULSES - 1) / 2) * float(radar.azimuth_spacing)
    return {"horizontal": jnp.asarray(0.01 * np.sin(2 * np.pi * x / 300.0)),
            "vertical": jnp.asarray(0.008 * np.cos(2 * np.pi * x / 250.0)),
            "pointing": jnp.asarray(sj.seed_pointing_jitter(radar, x))}


def _functional(shape, seed=0):
    """L(data) = Σ Re(W · data) + 0.1 Σ |data|², W random: every sample counts with its
    own phase, so the gradient is not a sum that cancels."""
    rng = np.random.default_rng(seed)
    weights = jnp.asarray(rng.normal(size=shape) + 1j * rng.normal(size=shape))

    def functional(data):
        return jnp.sum(jnp.real(weights * data)) + 0.1 * jnp.sum(jnp.abs(data) ** 2)

    return functional


def _single(name, theta, rng):
    """A random direction along one component of θ (zero along the others)."""
    direction = {k: jnp.zeros_like(v) for k, v in theta.items()}
    direction[name] = jnp.asarray(rng.normal(size=np.shape(theta[name])))
    return direction


def _check_components(loss, theta, seed=1, label=""):
    """One gradient, then a random direction along each component of θ."""
    rng = np.random.default_rng(seed)
    grad = jax.grad(loss)(theta)
    for name in theta:
        assert_gradient_matches(loss, theta, _single(name, theta, rng), STEPS[name], REL_TOL,
                                grad=grad, label=f"{label} {name}", values_from_gradient=True)


def _scene_loss(radar, scene, method, **options):
    """L(θ) with θ = {reflectivity: (Re γ, Im γ), azimuth: x} of the scatterers."""
    functional = _functional((NUM_PULSES, NUM_RANGE))
    window = _window(radar)

    def loss(theta):
        gamma = theta["reflectivity"][0] + 1j * theta["reflectivity"][1]
        s = eqx.tree_at(lambda s: (s.reflectivity, s.azimuth), scene, (gamma, theta["azimuth"]))
        return functional(sj.simulate(radar, s, method=method, **window, **options).data)

    gamma = np.asarray(scene.reflectivity)
    theta = {"reflectivity": jnp.asarray(np.stack([gamma.real, gamma.imag])),
             "azimuth": jnp.asarray(scene.azimuth)}
    return loss, theta


@pytest.mark.parametrize("squint_deg", [0.0, 6.0], ids=["broadside", "squint6"])
def test_fourier_2d_scene(squint_deg):
    """fourier_2d (straight track) w.r.t. the reflectivities and the scatterer azimuths."""
    radar = _radar(squint_deg)
    loss, theta = _scene_loss(radar, _scene(radar), "fourier_2d")
    _check_components(loss, theta, label=f"fourier_2d {squint_deg}°")


@pytest.mark.parametrize("method, options", [
    ("small_deviation", {"azimuth_padding": 0.1}), ("moderate_deviation", {})])
def test_deviation_simulators_heights(method, options):
    """W.r.t. the scatterer heights with the reflectivities fixed (concrete), under a
    deviating track (the heights set each scatterer's line-of-sight deviation), two of
    the three targets at one place. The checks weigh concrete reflectivities at traced
    heights (the deviation budgets' lobe samples; a fixed padding's wrapped echo, whose
    budget is not the subject here and warns) and must leave the heights alone: they once
    converted them to NumPy, an error instead of a gradient."""
    radar = sj.presets.airborne_xband(num_pulses=128, num_range=64)
    scene = sj.PointTargets(azimuth=[0.0, 0.0, 3.0], range=[5140.0, 5140.0, 5150.0],
                            reflectivity=[1.0, 0.5j, 0.8], height=[1.0, 1.0, 2.0])
    x = np.linspace(0.0, 3.0, 128)
    motion = sj.Motion(horizontal=0.01 * np.sin(x), vertical=0.005 * np.cos(x))
    functional = _functional((128, 64))

    def loss(theta):
        s = eqx.tree_at(lambda s: s.height, scene, theta["height"])
        return functional(sj.simulate(radar, s, motion, method=method, near_range=5100.0,
                                      **options).data)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sj.ValidityWarning)
        _check_components(loss, {"height": jnp.asarray(scene.height)}, label=method)


@pytest.mark.parametrize("method", ["small_deviation", "moderate_deviation"])
def test_squinted_deviation_simulators_motion(method):
    """At 6° squint (the squinted engine, not the broadside one) w.r.t. Δy, Δz and δ_az."""
    radar = _radar(6.0)
    scene, window = _scene(radar), _window(radar)
    functional = _functional((NUM_PULSES, NUM_RANGE))

    def loss(motion):
        return functional(sj.simulate(radar, scene, sj.Motion(**motion), method=method,
                                      **window).data)

    _check_components(loss, _motion_base(radar), label=f"{method} 6°")


def test_chirp_scaling_scene():
    """chirp_scaling (broadside straight track) w.r.t. reflectivities and azimuths."""
    radar = _radar()
    loss, theta = _scene_loss(radar, _scene(radar), "chirp_scaling")
    _check_components(loss, theta, label="chirp_scaling")


def test_high_speed_scene():
    """high_speed (7500 m/s, beyond stop-and-go) w.r.t. reflectivities and azimuths of a
    static target and a moving one (3 m/s in range, 20 m/s along track): two velocity
    groups, each its own spectrum. The velocities themselves set the groups when the call
    is prepared: not differentiable."""
    radar = sj.presets.airborne_xband(**FAST)
    scene = _scene(radar, velocity_range=[0.0, 3.0], velocity_azimuth=[0.0, 20.0])
    loss, theta = _scene_loss(radar, scene, "high_speed")
    _check_components(loss, theta, label="high_speed")


def test_focus_motion_compensation():
    """ω-k focusing with second-order motion compensation: a functional of the image
    w.r.t. the Δy, Δz passed to ``focus`` (the raw data fixed, simulated with them)."""
    radar = _radar()
    base = _motion_base(radar)
    del base["pointing"]  # motion compensation uses Δy, Δz only
    raw = sj.simulate(radar, _scene(radar), sj.Motion(**base), **_window(radar))
    functional = _functional(raw.data.shape, seed=2)

    def loss(motion):
        return functional(sj.focus(radar, raw, motion=sj.Motion(**motion)).data)

    _check_components(loss, base, label="focus")
