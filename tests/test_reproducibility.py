"""Reproducibility: the same inputs give the same raw data on a rerun, after the
compiled programs are dropped, and in a fresh Python process (bit for bit for the exact
time-domain model; to rounding for the FFT-based methods, whose XLA CPU FFT rounds a few
rows differently depending on its run-time thread split, see tests/_reruns.py); complex64
output agrees with complex128 within a measured, per-method tolerance.

complex64 against complex128 (geometry and carrier phase are float64 in both; the kernel
and output are single precision): airborne X-band, 64 pulses × 128 samples, two targets,
centimetre deviations and pointing jitter (straight track for ``high_speed`` and
``chirp_scaling``), measured on the development machine (CPU, jax 0.10.2):

=====================  =========  ====================  ===========================
method                 NMSE [dB]  phase error [rad rms]  tolerance (NMSE, phase)
=====================  =========  ====================  ===========================
time_domain            −138.0     1.6e-7                −128 dB, 1.6e-6
time_domain_nufft      −137.6     9.5e-8                −125 dB, 1e-6
fourier_2d             −135.6     1.1e-7                −125 dB, 1.1e-6
small_deviation        −134.8     1.3e-7                −124 dB, 1.3e-6
moderate_deviation     −132.1     2.3e-7                −122 dB, 2.3e-6
high_speed             −139.5     6.9e-8                −129 dB, 6.9e-7
chirp_scaling          −152.5     1.3e-8                −140 dB, 1.3e-7
=====================  =========  ====================  ===========================

The phase error is the rms over samples within 20 dB of the peak; tolerances are ≥ 10 dB
(NMSE) and 10× (phase) above the measurement. The exact model's error is the float32
chirp phase of each sample, from float64 phases reduced to [−π, π] (test_precision.py
bounds it at the seed sizes); the track methods (``fourier_2d``, ``small_deviation``,
``moderate_deviation``) run their tables, range synthesis and transforms in complex64
with the phases formed in float64 (their float32 sums and FFTs: −132 to −136 dB);
``high_speed`` and ``chirp_scaling`` synthesise in double precision and round once at
the end.
``python tests/test_reproducibility.py`` prints the measurement.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import textwrap
import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import sarjax as sj

try:
    from _reruns import assert_same_to_rounding
except ImportError:
    from tests._reruns import assert_same_to_rounding

NUM_PULSES, NUM_RANGE, NEAR_RANGE = 64, 128, 5100.0
RADAR = sj.presets.airborne_xband(chirp_duration=1e-6, num_pulses=NUM_PULSES,
                                  num_range=NUM_RANGE, near_range=NEAR_RANGE)
SCENE = sj.PointTargets(azimuth=[-1.5, 2.0], range=[5200.0, 5260.0],
                        reflectivity=[1.0, 0.4 - 0.7j])
STRAIGHT_ONLY = ("high_speed", "chirp_scaling")
# fourier_2d ignores motion (its budget would warn about it): run on the straight track
WITHOUT_MOTION = STRAIGHT_ONLY + ("fourier_2d",)


def _motion():
    x = (np.arange(NUM_PULSES) - (NUM_PULSES - 1) / 2) * float(RADAR.azimuth_spacing)
    return sj.Motion(horizontal=0.015 * np.sin(2 * np.pi * x / 11.0 + 0.3),
                     vertical=0.01 * np.cos(2 * np.pi * x / 7.0),
                     pointing=np.asarray(sj.seed_pointing_jitter(RADAR, x)))


def _simulate(method, dtype=jnp.complex128):
    motion = None if method in WITHOUT_MOTION else _motion()
    with warnings.catch_warnings():
        # runs are compared with each other (reruns, complex64 against complex128), not
        # with the exact model: small_deviation's ε13 flags this 1.5 cm motion
        warnings.simplefilter("ignore", sj.ValidityWarning)
        return np.asarray(sj.simulate(RADAR, SCENE, motion, method=method, dtype=dtype,
                                      near_range=NEAR_RANGE).data)


def _digest(data):
    return hashlib.sha256(np.ascontiguousarray(data).tobytes()).hexdigest()


# ---- reruns --------------------------------------------------------------------------


def test_rerun_is_bit_identical():
    """The exact model sums per pulse without an FFT: the same bits."""
    first = _simulate("time_domain")
    assert np.array_equal(_simulate("time_domain"), first)
    assert np.all(np.isfinite(first)) and np.abs(first).max() > 0.5


@pytest.mark.parametrize("method", ["time_domain_nufft", "moderate_deviation"])
def test_rerun_is_the_same_to_rounding(method):
    first = _simulate(method)
    assert_same_to_rounding(_simulate(method), first)
    assert np.all(np.isfinite(first)) and np.abs(first).max() > 0.5


def test_recompiled_program_is_bit_identical():
    first = _simulate("time_domain")
    jax.clear_caches()  # the next call traces and compiles again (not from the disk cache)
    enabled = jax.config.jax_enable_compilation_cache
    jax.config.update("jax_enable_compilation_cache", False)
    try:
        assert _digest(_simulate("time_domain")) == _digest(first)
    finally:
        jax.config.update("jax_enable_compilation_cache", enabled)


def test_fresh_process_reproduces_the_run(tmp_path):
    """A new interpreter (new compilation, new thread pools) gives the same data: the
    same bits for the exact model, the same to rounding for ``fourier_2d``."""
    script = textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {str(__import__("pathlib").Path(__file__).parent)!r})
        import test_reproducibility as t
        import numpy as np
        np.save("time_domain.npy", t._simulate("time_domain"))
        np.save("fourier_2d.npy", t._simulate("fourier_2d"))
    """)
    env = {**os.environ, "JAX_ENABLE_COMPILATION_CACHE": "false"}  # compiles afresh
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=600, cwd=tmp_path, env=env)
    assert done.returncode == 0, done.stderr
    assert _digest(np.load(tmp_path / "time_domain.npy")) == _digest(_simulate("time_domain"))
    assert_same_to_rounding(np.load(tmp_path / "fourier_2d.npy"), _simulate("fourier_2d"))


# ---- complex64 against complex128 --------------------------------------------------


def _float32_errors(method):
    """(NMSE [dB], rms phase error [rad] within 20 dB of the peak) of complex64 output."""
    double = _simulate(method)
    single = _simulate(method, jnp.complex64)
    assert single.dtype == jnp.complex64
    single = np.asarray(single).astype(complex)
    nmse = 10 * np.log10(np.sum(np.abs(single - double) ** 2) / np.sum(np.abs(double) ** 2))
    strong = np.abs(double) >= 0.1 * np.abs(double).max()
    phase = np.sqrt(np.mean(np.angle(single[strong] * np.conj(double[strong])) ** 2))
    return float(nmse), float(phase)


# the module docstring's table: measured values with ≥ 10 dB / 10× margin
FLOAT32_TOLERANCE = {
    "time_domain": (-128.0, 1.6e-6),
    "time_domain_nufft": (-125.0, 1e-6),
    "fourier_2d": (-125.0, 1.1e-6),
    "small_deviation": (-124.0, 1.3e-6),
    "moderate_deviation": (-122.0, 2.3e-6),
    "high_speed": (-129.0, 6.9e-7),
    "chirp_scaling": (-140.0, 1.3e-7),
}


@pytest.mark.parametrize("method", [
    "time_domain", "time_domain_nufft", "fourier_2d", "moderate_deviation",
    pytest.param("small_deviation", marks=pytest.mark.slow),  # moderate's engine, in CI
    pytest.param("high_speed", marks=pytest.mark.slow),
    pytest.param("chirp_scaling", marks=pytest.mark.slow),
])
def test_complex64_against_complex128(method):
    nmse, phase = _float32_errors(method)
    max_nmse, max_phase = FLOAT32_TOLERANCE[method]
    assert nmse <= max_nmse, f"{method}: complex64 NMSE {nmse:.1f} dB"
    assert phase <= max_phase, f"{method}: complex64 phase error {phase:.2g} rad rms"


if __name__ == "__main__":  # the measurement behind the table
    for name in FLOAT32_TOLERANCE:
        nmse, phase = _float32_errors(name)
        print(f"{name:<20} {nmse:8.1f} dB  {phase:.2g} rad rms")
