"""The exact time-domain kernel's parts: the pulse extent and the factored chirp.

``test_time_domain_reference.py`` checks a few scatterers (the kernel's loop over
scatterers) against the float64 NumPy oracle; here the many-scatterer branch (a complex
matrix product over three separable masks) meets the same oracle, and the pulse extent
is checked against the float64 test it stands for, at the edges too.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

import sarjax as sj
from sarjax.simulators import _time_domain as td

try:  # tests/ on sys.path (pytest's default rootdir-relative import)
    from reference_numpy import simulate_reference
    from test_time_domain_reference import RADAR_OVERRIDES, _radar_kwargs
except ImportError:  # tests/ is a package
    from tests.reference_numpy import simulate_reference
    from tests.test_time_domain_reference import RADAR_OVERRIDES, _radar_kwargs


def test_pulse_extent_is_the_float64_test():
    """(first, last) are exactly the samples with |β + kΔr| < cτ/4 in float64, also for
    echoes placed on an edge to the last bit (where the closed-form bound alone rounds
    to either side), and empty for echoes outside the window."""
    radar = sj.presets.airborne_xband()
    n = 830
    dr, half = float(radar.range_spacing), float(radar.pulse_half_length)
    rng = np.random.default_rng(0)
    k_edge = rng.integers(0, n, 200).astype(float)
    on_edge = np.concatenate([-half - k_edge * dr, half - k_edge * dr])
    nudged = np.concatenate([np.nextafter(on_edge, np.inf), np.nextafter(on_edge, -np.inf)])
    base = np.concatenate([rng.uniform(-(n * dr + 2 * half), 2 * half, 2000), on_edge,
                           nudged, [-1e5, 1e5]])
    first, last = td.pulse_extent(radar, jnp.asarray(base), n)
    k = np.arange(n) * dr
    inside = np.abs(base[:, None] + k[None, :]) < half
    index = np.arange(n)[None, :]
    got = (index >= np.asarray(first)[:, None]) & (index <= np.asarray(last)[:, None])
    assert np.array_equal(got, inside)


def test_many_scatterers_match_the_numpy_oracle():
    """36 scatterers in one chunk take the matrix-product branch, by default the loop
    over chunks of 32: both against the float64 oracle within 1e-9 (the reference test's
    bound: float64 rounding of ~2e6 rad phases); complex64 within 1e-5 (its tables'
    rounding, measured ≈ 3e-7)."""
    radar = sj.presets.airborne_xband(**RADAR_OVERRIDES)
    kw = _radar_kwargs(radar)
    num_pulses, num_range, near = 6, 300, 4700.0
    rng = np.random.default_rng(5)
    n = 36
    targets = dict(azimuth=rng.uniform(-60, 60, n), range=rng.uniform(4750, 5550, n),
                   reflectivity=rng.normal(size=n) + 1j * rng.normal(size=n),
                   height=rng.uniform(-10, 30, n))
    xp = (np.arange(num_pulses) - 0.5 * (num_pulses - 1)) * kw["velocity"] / kw["prf"]
    deviation = dict(horizontal=0.03 * np.sin(xp / 40), vertical=0.02 * np.cos(xp / 30),
                     pointing=1e-4 * np.sin(xp / 50))
    ref, _, _ = simulate_reference(
        **kw, target_azimuth=targets["azimuth"], target_range=targets["range"],
        target_reflectivity=targets["reflectivity"], target_height=targets["height"],
        **deviation, num_pulses=num_pulses, num_range=num_range, near_range=near)
    scene = sj.PointTargets(**targets)
    motion = sj.Motion(**deviation)
    assert n > td._LOOPED_SCATTERERS  # scatterer_chunk=n: the product
    for dtype, bound in ((jnp.complex128, 1e-9), (jnp.complex64, 1e-5)):
        for chunk in (None, n):  # the default (loops over chunks of 32), the product
            raw = sj.simulate(radar, scene, motion, num_pulses=num_pulses,
                              num_range=num_range, near_range=near, dtype=dtype,
                              scatterer_chunk=chunk)
            data = np.asarray(raw.data, np.complex128)
            assert np.linalg.norm(data - ref) / np.linalg.norm(ref) <= bound, (dtype, chunk)
