"""High-speed platforms and moving targets (seed 004; physics.md §10).

* The exact model beyond stop-and-go and with moving scatterers against the naive NumPy
  oracle (``tests/reference_numpy.py``), and its delay against the closed form of seed 004
  eq. 4.
"""

from __future__ import annotations

import numpy as np
import pytest

import sarjax as sj
from sarjax.constants import SPEED_OF_LIGHT
from sarjax.simulators import _time_domain

try:
    from reference_numpy import simulate_reference
except ImportError:
    from tests.reference_numpy import simulate_reference

# Relative tolerance against the oracle: both float64, phases ≈ 2e6 rad (see
# test_time_domain_reference.py); 1e-9 catches any modelling error (1 mm of range
# is 0.4 rad, the non-stop-and-go displacement here is v R / c ≈ 0.13 m).
REL_TOL = 1e-9

# a fast platform on a small geometry: 7500 m/s at PRF 1200 Hz keeps the 6.25 m pulse
# spacing of the broadside oracle test, so 64 pulses span the ±200 m aperture
FAST = dict(carrier_frequency=9.65e9, bandwidth=40e6, chirp_duration=1e-6,
            sampling_rate=50e6, prf=1200.0, velocity=7500.0, height=3000.0,
            antenna_length=1.0)
NUM_PULSES, NUM_RANGE, NEAR_RANGE = 64, 300, 4700.0
TARGETS = dict(
    azimuth=np.array([-35.0, 10.0, 60.0]),
    range=np.array([4840.0, 5140.0, 5440.0]),
    reflectivity=np.array([1.0 + 0.0j, 0.6 - 0.8j, -0.3 + 0.45j]),
    height=np.array([0.0, 25.0, -12.0]),
)
VELOCITIES = dict(velocity_range=np.array([0.0, 3.0, -2.0]),
                  velocity_azimuth=np.array([0.0, 20.0, -15.0]))


def _motion(scale):
    if not scale:
        return None, {}
    xp = (np.arange(NUM_PULSES) - 0.5 * (NUM_PULSES - 1)) * FAST["velocity"] / FAST["prf"]
    dy = scale * np.sin(xp / 50.0)
    dz = 0.7 * scale * np.cos(xp / 70.0)
    daz = 1e-3 * np.sin(xp / 30.0)
    return (sj.Motion(horizontal=dy, vertical=dz, pointing=daz),
            dict(horizontal=dy, vertical=dz, pointing=daz))


def _compare(radar_kw, targets, motion_scale, stop_and_go):
    radar = sj.presets.airborne_xband(**radar_kw)
    motion, mkw = _motion(motion_scale)
    raw = sj.simulate(radar, sj.PointTargets(**targets), motion, num_pulses=NUM_PULSES,
                      num_range=NUM_RANGE, near_range=NEAR_RANGE, stop_and_go=stop_and_go)
    oracle_kw = {k: v for k, v in radar_kw.items() if k in FAST or k == "squint"}
    ref, _, _ = simulate_reference(
        **oracle_kw, target_azimuth=targets["azimuth"], target_range=targets["range"],
        target_reflectivity=targets["reflectivity"], target_height=targets["height"],
        target_velocity_range=targets.get("velocity_range"),
        target_velocity_azimuth=targets.get("velocity_azimuth"), **mkw,
        num_pulses=NUM_PULSES, num_range=NUM_RANGE, near_range=NEAR_RANGE,
        stop_and_go=stop_and_go,
    )
    data = np.asarray(raw.data)
    # the setup is meaningful: chirps inside the window, the pattern tapers
    assert np.all(ref[:, 0] == 0) and np.all(ref[:, -1] == 0)
    power = np.sum(np.abs(ref) ** 2, axis=1)
    assert power.min() < 0.2 * power.max()
    return float(np.linalg.norm(data - ref) / np.linalg.norm(ref)), data, ref


@pytest.mark.parametrize("stop_and_go", [True, False], ids=["stop_and_go", "non_stop_and_go"])
@pytest.mark.parametrize("moving", [False, True], ids=["static", "moving"])
@pytest.mark.parametrize("motion_scale", [0.0, 0.3], ids=["ideal", "deviations"])
def test_exact_model_matches_oracle(stop_and_go, moving, motion_scale):
    targets = {**TARGETS, **(VELOCITIES if moving else {})}
    err, _, _ = _compare(FAST, targets, motion_scale, stop_and_go)
    assert err <= REL_TOL


def test_non_stop_and_go_differs_from_stop_and_go():
    """The two models differ by much more than the oracle tolerance (the comparison above
    can fail): the echo moves by ≈ v R/c along track."""
    radar = sj.presets.airborne_xband(**FAST)
    scene = sj.PointTargets(**TARGETS)
    common = dict(num_pulses=NUM_PULSES, num_range=NUM_RANGE, near_range=NEAR_RANGE)
    a = np.asarray(sj.simulate(radar, scene, **common).data)
    b = np.asarray(sj.simulate(radar, scene, stop_and_go=False, **common).data)
    assert np.linalg.norm(a - b) / np.linalg.norm(a) > 0.1


@pytest.mark.parametrize("v_r, v_a", [(0.0, 0.0), (0.5, 0.0), (1.0, 1.0), (-3.0, 20.0)])
def test_delay_matches_closed_form(v_r, v_a):
    """Straight track: the iterated solution of seed 004 eq. 3 equals eq. 4,
    τ_d = 2α₀ [R(τ)/c + β₀ (τ − τ₀) + r₀ v_r / c²], α₀ = 1/(1 − β₀),
    β₀ = (v_r² + (v − v_a)²)/c²."""
    radar = sj.presets.highspeed_xband()
    v = float(radar.velocity)
    c = SPEED_OF_LIGHT
    r0, x = 800e3, 100.0
    x_pulse = np.linspace(-3000.0, 3000.0, 13)
    n = x_pulse.size
    targets = tuple(np.full(n, val) for val in (x, r0, 0.0, 1.0, v_r, v_a))
    pulse = (x_pulse, np.zeros(n), np.zeros(n), np.zeros(n))
    echo, _ = _time_domain.echo_range_offset(radar, pulse, targets, stop_and_go=False)
    s = (x_pulse - x) / v
    w = v - v_a
    R = np.sqrt((r0 + v_r * s) ** 2 + (w * s) ** 2)
    beta0 = (v_r**2 + w**2) / c**2
    alpha0 = 1 / (1 - beta0)
    tau_d = 2 * alpha0 * (R / c + beta0 * s + r0 * v_r / c**2)
    expected = c * tau_d / 2 - r0
    # float64 closed form at 800 km: ~1e-10 m; the displacement itself is ~v·R/c·sinφ
    np.testing.assert_allclose(np.asarray(echo), expected, rtol=0, atol=1e-8)
    # not the stop-and-go range: differs by ≈ (v/c)(x' − x) ≈ 7.5 cm at the ends (0.17 rad
    # per mm at 9.6 GHz)
    assert np.max(np.abs(expected - (R - r0))) > 0.05
