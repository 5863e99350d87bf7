"""Squinted acquisition (seed 002; physics.md §8).

* The exact model with squint against the naive NumPy oracle; the beam centre and the
  Doppler centroid where the model says they are.
"""

from __future__ import annotations

import numpy as np
import pytest

import sarjax as sj

try:
    from reference_numpy import simulate_reference
except ImportError:
    from tests.reference_numpy import simulate_reference

REL_TOL = 1e-9  # as tests/test_time_domain_reference.py (float64 on both sides)

SMALL = dict(carrier_frequency=9.65e9, bandwidth=40e6, chirp_duration=1e-6,
             sampling_rate=50e6, prf=16.0, velocity=100.0, height=3000.0,
             antenna_length=1.0)
NUM_PULSES, NUM_RANGE, NEAR_RANGE = 64, 300, 4700.0


def _targets(squint):
    # closest-approach azimuths placed so that the beam centre (x' = x − r tan φ_d)
    # crosses each target inside the 64 pulses (±197 m)
    r = np.array([4840.0, 5140.0, 5440.0])
    return dict(azimuth=np.array([-35.0, 10.0, 60.0]) + r * np.tan(squint), range=r,
                reflectivity=np.array([1.0 + 0.0j, 0.6 - 0.8j, -0.3 + 0.45j]),
                height=np.array([0.0, 25.0, -12.0]))


@pytest.mark.parametrize("degrees", [4.0, 15.0, -10.0])
@pytest.mark.parametrize("with_motion", [False, True], ids=["ideal", "deviations"])
def test_squinted_exact_model_matches_oracle(degrees, with_motion):
    squint = np.deg2rad(degrees)
    radar = sj.presets.airborne_xband(**SMALL, squint=squint)
    t = _targets(squint)
    mkw = {}
    if with_motion:
        xp = (np.arange(NUM_PULSES) - 0.5 * (NUM_PULSES - 1)) * 6.25
        mkw = dict(horizontal=0.3 * np.sin(xp / 50), vertical=-0.2 * np.cos(xp / 70),
                   pointing=(0.0314 / 20) * np.sin(xp / 40))
    raw = sj.simulate(radar, sj.PointTargets(**t), sj.Motion(**mkw),
                      num_pulses=NUM_PULSES, num_range=NUM_RANGE, near_range=NEAR_RANGE)
    ref, _, _ = simulate_reference(
        **SMALL, squint=squint, target_azimuth=t["azimuth"], target_range=t["range"],
        target_reflectivity=t["reflectivity"], target_height=t["height"], **mkw,
        num_pulses=NUM_PULSES, num_range=NUM_RANGE, near_range=NEAR_RANGE)
    data = np.asarray(raw.data)
    power = np.sum(np.abs(ref) ** 2, axis=1)
    assert power.min() < 0.2 * power.max()  # the squinted beam tapers within the window
    assert np.linalg.norm(data - ref) / np.linalg.norm(ref) <= REL_TOL


@pytest.mark.parametrize("degrees", [4.0, 15.0])
def test_beam_centre_and_doppler_centroid(degrees):
    """One target: the echo power peaks where the beam centre crosses it,
    x' = x − r tan φ_d, and the azimuth spectrum of its range line is centred on the
    Doppler centroid 2 v sin φ_d / λ (modulo the PRF)."""
    squint = np.deg2rad(degrees)
    radar = sj.presets.airborne_xband(squint=squint)
    r, x = 5140.0, 0.0
    centre = x - r * np.tan(squint)
    raw = sj.simulate(radar, sj.PointTargets(azimuth=[x], range=[r]), num_pulses=1024,
                      num_range=64, near_range=r / np.cos(squint) - 96.0,
                      azimuth_center=centre)
    data = np.asarray(raw.data)
    power = np.sum(np.abs(data) ** 2, axis=1)
    peak = np.asarray(raw.azimuth)[np.argmax(power)]
    assert abs(peak - centre) < 2.0  # [m]; pulses every 0.25 m, footprint 161 m
    # Doppler centroid from the pulse-to-pulse phase (correlation Doppler estimator)
    line = data[:, np.argmax(np.sum(np.abs(data) ** 2, axis=0))]
    f_dc = np.angle(np.sum(line[1:] * np.conj(line[:-1]))) / (2 * np.pi) * float(radar.prf)
    expected = 2 * float(radar.velocity) * np.sin(squint) / float(radar.wavelength)
    prf = float(radar.prf)
    wrapped = (expected + prf / 2) % prf - prf / 2
    assert abs(f_dc - wrapped) < 0.01 * prf
