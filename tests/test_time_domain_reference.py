"""Compare ``sarjax`` time-domain simulation against a naive NumPy oracle.

The oracle (``tests/reference_numpy.py``) is an explicit float64 triple loop
over pulses, range samples and scatterers written directly from the model
equations (seed 000, eqs. 19-20), independently of the sarjax code.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import sarjax as sj

try:  # tests/ on sys.path (pytest's default rootdir-relative import)
    from reference_numpy import SPEED_OF_LIGHT, simulate_reference
except ImportError:  # tests/ is a package
    from tests.reference_numpy import SPEED_OF_LIGHT, simulate_reference

# Tolerance on ||sarjax - oracle|| / ||oracle||.  Both sides are float64: the
# two-way phase 4*pi*R/lambda is ~2e6 rad at R ~ 5 km, lambda ~ 3 cm, so one
# ulp of R or of the phase (~2.2e-16 * 2e6 ~ 4e-10 rad) already gives ~1e-10
# relative differences when the two implementations round differently.  1e-9
# leaves margin for that while still catching any modelling error (a 1 mm
# range error alone gives ~0.4 rad of phase).
REL_TOL = 1e-9

# Small geometry so the naive loop stays fast; 64 pulses spaced v/PRF = 6.25 m
# span about +-200 m, i.e. more than the footprint lambda*r/L ~ 150-170 m, so
# the two-way antenna pattern (and the pointing jitter) matter.
RADAR_OVERRIDES = dict(
    carrier_frequency=9.65e9,
    bandwidth=40e6,
    chirp_duration=1e-6,  # chirp half-length c*tau/4 ~ 75 m
    sampling_rate=50e6,  # range spacing c/(2 fs) ~ 3 m
    prf=16.0,
    velocity=100.0,
    height=3000.0,
    antenna_length=1.0,
)
NUM_PULSES = 64
NUM_RANGE = 300
NEAR_RANGE = 4700.0  # window 4700 ... ~5597 m holds all three chirps

TARGETS = dict(
    azimuth=np.array([-35.0, 10.0, 60.0]),
    range=np.array([4840.0, 5140.0, 5440.0]),
    reflectivity=np.array([1.0 + 0.0j, 0.6 - 0.8j, -0.3 + 0.45j]),
    height=np.array([0.0, 25.0, -12.0]),
)


def _f(x):
    return float(np.asarray(x))


def _radar():
    return sj.presets.airborne_xband(**RADAR_OVERRIDES)


def _radar_kwargs(radar):
    """Radar parameters as plain Python floats for the oracle."""
    names = (
        "carrier_frequency",
        "bandwidth",
        "chirp_duration",
        "sampling_rate",
        "prf",
        "velocity",
        "height",
        "antenna_length",
    )
    return {n: _f(getattr(radar, n)) for n in names}


def _smooth_track(xp, scale, rng):
    """Smooth random deviation (sum of a few sinusoids + trend), |.| ~ scale."""
    out = np.zeros_like(xp)
    for _ in range(3):
        period = rng.uniform(100.0, 800.0)  # metres of along-track
        out += rng.uniform(0.3, 1.0) * np.sin(
            2 * np.pi * xp / period + rng.uniform(0, 2 * np.pi)
        )
    out += rng.uniform(-0.5, 0.5) * xp / np.max(np.abs(xp))
    return scale * out / np.max(np.abs(out))


def _pointing_jitter(xp, kw, period_s=2.0):
    """delta_az = delta_m sin(2 pi x' / (v T_b)), delta_m = lambda / (20 L)."""
    wavelength = SPEED_OF_LIGHT / kw["carrier_frequency"]
    delta_m = wavelength / (20.0 * kw["antenna_length"])
    return delta_m * np.sin(2 * np.pi * xp / (kw["velocity"] * period_s))


def _rel_err(a, b):
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


@pytest.mark.parametrize("scale", [0.0, 0.03, 1.5], ids=["ideal", "cm", "m"])
def test_matches_numpy_oracle(scale):
    radar = _radar()
    kw = _radar_kwargs(radar)
    # Oracle's pulse positions (needed to build the motion arrays).
    dx = kw["velocity"] / kw["prf"]
    xp = (np.arange(NUM_PULSES) - 0.5 * (NUM_PULSES - 1)) * dx

    if scale == 0.0:
        motion = sj.Motion()
        mkw = {}
    else:
        rng = np.random.default_rng(1234 + int(100 * scale))
        dy = _smooth_track(xp, scale, rng)
        dz = _smooth_track(xp, scale, rng)
        daz = _pointing_jitter(xp, kw)
        motion = sj.Motion(horizontal=dy, vertical=dz, pointing=daz)
        mkw = dict(horizontal=dy, vertical=dz, pointing=daz)

    scene = sj.PointTargets(**TARGETS)
    raw = sj.simulate(
        radar,
        scene,
        motion,
        method="time_domain",
        num_pulses=NUM_PULSES,
        num_range=NUM_RANGE,
        near_range=NEAR_RANGE,
        azimuth_center=0.0,
    )
    ref, x_axis, r_axis = simulate_reference(
        **kw,
        target_azimuth=TARGETS["azimuth"],
        target_range=TARGETS["range"],
        target_reflectivity=TARGETS["reflectivity"],
        target_height=TARGETS["height"],
        **mkw,
        num_pulses=NUM_PULSES,
        num_range=NUM_RANGE,
        near_range=NEAR_RANGE,
        azimuth_center=0.0,
    )

    data = np.asarray(raw.data)
    assert data.shape == (NUM_PULSES, NUM_RANGE)
    assert data.dtype == np.complex128
    np.testing.assert_allclose(np.asarray(raw.azimuth), x_axis, rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.asarray(raw.range), r_axis, rtol=0, atol=1e-9)

    # Sanity of the setup itself: every chirp lies inside the range window and
    # the antenna pattern actually tapers over the 64 pulses.
    assert np.all(ref[:, 0] == 0) and np.all(ref[:, -1] == 0)
    power = np.sum(np.abs(ref) ** 2, axis=1)
    assert power.min() < 0.2 * power.max()

    err = _rel_err(data, ref)
    print(f"scale={scale}: relative error {err:.3e}")
    assert err <= REL_TOL


def test_zero_motion_equals_ideal_motion():
    radar = _radar()
    scene = sj.PointTargets(**TARGETS)
    common = dict(
        method="time_domain",
        num_pulses=NUM_PULSES,
        num_range=NUM_RANGE,
        near_range=NEAR_RANGE,
        azimuth_center=0.0,
    )
    zeros = np.zeros(NUM_PULSES)
    raw0 = sj.simulate(
        radar,
        scene,
        sj.Motion(horizontal=zeros, vertical=zeros, pointing=zeros),
        **common,
    )
    raw_ideal = sj.simulate(radar, scene, sj.Motion(), **common)
    np.testing.assert_array_equal(np.asarray(raw0.data), np.asarray(raw_ideal.data))
    assert np.any(np.asarray(raw_ideal.data) != 0)


def test_single_sample_by_hand():
    """One target, one pulse: evaluate eq. 19-20 by hand at one sample."""
    radar = _radar()
    kw = _radar_kwargs(radar)
    c = SPEED_OF_LIGHT

    x_t, r_t, h_t, gamma = 0.0, 5140.0, 15.0, 0.7 - 0.4j
    x_c = 12.0  # single pulse -> x'_0 = azimuth_center
    dy, dz, daz = 0.3, -0.2, 1.0e-3
    near, n_r = 5040.0, 64

    raw = sj.simulate(
        radar,
        sj.PointTargets(
            azimuth=[x_t], range=[r_t], reflectivity=[gamma], height=[h_t]
        ),
        sj.Motion(horizontal=[dy], vertical=[dz], pointing=[daz]),
        method="time_domain",
        num_pulses=1,
        num_range=n_r,
        near_range=near,
        azimuth_center=x_c,
    )
    data = np.asarray(raw.data)
    assert data.shape == (1, n_r)
    assert float(np.asarray(raw.azimuth)[0]) == pytest.approx(x_c, abs=1e-12)

    # Hand evaluation.
    lam = c / kw["carrier_frequency"]
    b = 4 * math.pi * kw["bandwidth"] / (c**2 * kw["chirp_duration"])
    H = kw["height"]
    y_p = math.sqrt(r_t**2 - (H - h_t) ** 2)
    R = math.sqrt((x_c - x_t) ** 2 + (dy - y_p) ** 2 + (H + dz - h_t) ** 2)
    dr = c / (2 * kw["sampling_rate"])
    k = int(round((R - near) / dr)) + 7  # a sample 7 bins past the target
    r_k = near + k * dr
    assert abs(r_k - R) < c * kw["chirp_duration"] / 4
    dr_xr = math.sqrt((y_p - dy) ** 2 + (H + dz - h_t) ** 2) - r_t
    u = (x_c - x_t - (r_t + dr_xr) * daz) / (lam * r_t / kw["antenna_length"])
    w2 = (math.sin(math.pi * u) / (math.pi * u)) ** 2
    expected = gamma * np.exp(-1j * (4 * math.pi * R / lam + b * (r_k - R) ** 2)) * w2

    assert abs(data[0, k] - expected) <= REL_TOL * abs(expected)
    # Outside the chirp support the echo is zero.
    assert data[0, 0] == 0 and data[0, -1] == 0

    # The oracle agrees with the hand value too (guards the oracle itself).
    ref, _, _ = simulate_reference(
        **kw,
        target_azimuth=[x_t],
        target_range=[r_t],
        target_reflectivity=[gamma],
        target_height=[h_t],
        horizontal=[dy],
        vertical=[dz],
        pointing=[daz],
        num_pulses=1,
        num_range=n_r,
        near_range=near,
        azimuth_center=x_c,
    )
    assert abs(ref[0, k] - expected) <= 1e-12 * abs(expected)
