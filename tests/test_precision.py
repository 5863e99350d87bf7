"""float32 kernels against float64 (style Rule 7): phase error ≤ 0.01 rad rms, airborne
X-band at 5 km and spaceborne C-band at 800 km, with deviations and pointing jitter."""

import jax.numpy as jnp
import numpy as np
import pytest

import sarjax as sj
from sarjax.metrics import nmse_db


def _phase_error_rms(test, ref, within_db=20.0):
    """rms of the phase difference over samples within ``within_db`` of the peak [rad],
    per target so that interference nulls between targets do not dominate."""
    mask = np.abs(ref) >= np.abs(ref).max() * 10 ** (-within_db / 20)
    return np.sqrt(np.mean(np.angle(test[mask] * np.conj(ref[mask])) ** 2))


CASES = {
    "airborne": (sj.presets.airborne_xband(num_pulses=512), [5140.0, 4990.0], 0.02),
    "cband_800km": (sj.presets.spaceborne_cband(num_pulses=256), [799.1e3, 799.3e3], 0.5),
}


@pytest.mark.parametrize("name", list(CASES))
def test_float32_phase_error(name):
    radar, ranges, rms = CASES[name]
    n = radar.num_pulses
    x = (np.arange(n) - (n - 1) / 2) * float(radar.azimuth_spacing)
    motion = sj.Motion(
        horizontal=sj.smooth_deviation(x, key=3, rms=rms, max_cycles=2, aperture=np.ptp(x)),
        vertical=sj.smooth_deviation(x, key=4, rms=rms, max_cycles=2, aperture=np.ptp(x)),
        pointing=sj.seed_pointing_jitter(radar, x),
    )
    for r in ranges:
        scene = sj.PointTargets(azimuth=[3.0], range=[r], reflectivity=[1.0 - 0.5j])
        ref = np.asarray(sj.simulate(radar, scene, motion, dtype=jnp.complex128).data)
        raw32 = sj.simulate(radar, scene, motion, dtype=jnp.complex64)
        assert raw32.data.dtype == jnp.complex64
        err = _phase_error_rms(np.asarray(raw32.data), ref)
        # geometry and carrier phase are float64; the float32 part is the chirp term
        # b (r' − R)² with |r' − R| ≤ cτ/4: measured ≈ 2e-5 rad
        assert err <= 0.01, f"{name} r={r}: float32 phase error {err:.3g} rad rms"
        assert err <= 1e-3  # a tighter bound that documents the measured margin


def test_complex64_many_scatterers_keeps_the_pulse_extent_exact():
    """The complex64 kernel decides each scatterer's pulse extent in float64: with float32
    r' − ρ, samples within ~1e-4 m of a pulse edge fell on the wrong side, a full-amplitude
    error per sample (about −70 dB NMSE for 1000 scatterers; −93 dB measured now, the
    float32 rounding of the chirp phase)."""
    radar = sj.presets.airborne_xband(num_pulses=128, num_range=830)
    rng = np.random.default_rng(0)
    n = 1000
    scene = sj.PointTargets(azimuth=rng.uniform(-20, 20, n), range=rng.uniform(5000, 5300, n),
                            reflectivity=rng.normal(size=n) + 1j * rng.normal(size=n))
    x = (np.arange(128) - 64) * 0.25
    motion = sj.Motion(horizontal=0.05 * np.sin(x / 7), vertical=0.03 * np.cos(x / 5))
    double = sj.simulate(radar, scene, motion).data
    single = sj.simulate(radar, scene, motion, dtype=jnp.complex64).data
    assert nmse_db(single, double) <= -85.0
