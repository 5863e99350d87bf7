"""Models, presets, chunking and scene conversions."""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import sarjax as sj
from sarjax.constants import SPEED_OF_LIGHT


def test_airborne_preset_matches_seed_table_2():
    radar = sj.presets.airborne_xband()
    assert float(radar.wavelength) == pytest.approx(0.0314, rel=1e-12)
    assert float(radar.carrier_frequency) == pytest.approx(SPEED_OF_LIGHT / 0.0314)
    assert (radar.num_pulses, radar.num_range) == (1941, 830)
    assert float(radar.azimuth_spacing) == pytest.approx(0.25)
    assert float(radar.range_spacing) == pytest.approx(2.998, abs=1e-3)
    assert float(radar.height) == 4000.0 and float(radar.reference_range) == 5140.0
    raw_range_centre = float(radar.near_range) + 415 * float(radar.range_spacing)
    assert raw_range_centre == pytest.approx(5140.0)
    # b = (4π/λ)(Δf/f)/(cτ) (seed 000 eq. 26)
    b = 4 * np.pi / 0.0314 * (45e6 / float(radar.carrier_frequency)) / (SPEED_OF_LIGHT * 5e-6)
    assert float(radar.chirp_rate) == pytest.approx(b, rel=1e-12)


def test_other_presets_and_overrides():
    c = sj.presets.spaceborne_cband()
    assert float(c.carrier_frequency) == 5.33e9 and float(c.bandwidth) == 16e6
    h = sj.presets.highspeed_xband(squint=np.deg2rad(30))
    assert float(h.velocity) == 7500.0 and float(h.squint) == pytest.approx(np.pi / 6)
    assert float(h.wavelength / h.antenna_length) == pytest.approx(0.005)
    with pytest.raises(ValueError, match="carrier_freq"):
        sj.presets.airborne_xband(carrier_freq=1e9)


def test_physical_values_are_array_leaves():
    radar = sj.presets.airborne_xband()
    leaves = jax.tree_util.tree_leaves(radar)
    assert all(isinstance(leaf, jax.Array) for leaf in leaves)
    dynamic, static = eqx.partition(radar, eqx.is_array)
    assert dynamic.carrier_frequency is not None and static.num_pulses == 1941


def _small_radar(**kw):
    return sj.presets.airborne_xband(
        prf=16.0, chirp_duration=1e-6, num_pulses=40, num_range=200, near_range=4950.0, **kw
    )


def test_chunking_does_not_change_the_result():
    radar = _small_radar()
    rng = np.random.default_rng(0)
    scene = sj.PointTargets(azimuth=rng.uniform(-50, 50, 13), range=rng.uniform(5000, 5400, 13),
                            reflectivity=rng.normal(size=13) + 1j * rng.normal(size=13))
    x = np.linspace(-1, 1, 40)
    motion = sj.Motion(horizontal=0.3 * x, vertical=0.1 * x**2, pointing=1e-3 * x)
    ref = np.asarray(sj.simulate(radar, scene, motion).data)
    for pulse_chunk, scatterer_chunk in [(1, 1), (7, 5), (40, 13), (3, 64)]:
        out = np.asarray(sj.simulate(radar, scene, motion, pulse_chunk=pulse_chunk,
                                     scatterer_chunk=scatterer_chunk).data)
        # same sums in a different order: float64 round-off only
        np.testing.assert_allclose(out, ref, rtol=0, atol=1e-12 * np.abs(ref).max())


def test_reflectivity_grid_equals_its_points():
    radar = _small_radar()
    az = np.array([-10.0, 0.0, 10.0])
    rg = np.array([5100.0, 5150.0, 5200.0])
    gamma = np.arange(9).reshape(3, 3) * (1 + 0.5j)
    heights = sj.pyramid_height(az, rg, peak=30.0)
    grid = sj.ReflectivityGrid(gamma, az, rg, height=heights)
    xx, rr = np.meshgrid(az, rg, indexing="ij")
    points = sj.PointTargets(azimuth=xx.ravel(), range=rr.ravel(),
                             reflectivity=gamma.ravel(), height=heights.ravel())
    a = np.asarray(sj.simulate(radar, grid).data)
    b = np.asarray(sj.simulate(radar, points).data)
    np.testing.assert_array_equal(a, b)
    assert heights.max() == pytest.approx(30.0) and heights.min() == 0.0
    # on a straight track the closest-approach range r fixes the echo whatever the height;
    # with deviations, heights change the look angle and so the line-of-sight deviation
    assert np.array_equal(
        np.asarray(sj.simulate(radar, sj.ReflectivityGrid(gamma, az, rg)).data), a)
    motion = sj.Motion(horizontal=np.full(40, 0.5), vertical=np.full(40, 0.3))
    hilly = np.asarray(sj.simulate(radar, grid, motion).data)
    flat = np.asarray(sj.simulate(radar, sj.ReflectivityGrid(gamma, az, rg), motion).data)
    assert np.linalg.norm(flat - hilly) > 0.1 * np.linalg.norm(hilly)


def test_pattern_is_pluggable():
    radar = _small_radar()
    gauss = _small_radar(pattern=sj.GaussianPattern(width=0.3))
    scene = sj.PointTargets(azimuth=[0.0], range=[5200.0])
    a = np.abs(np.asarray(sj.simulate(radar, scene).data)).max(axis=1)
    b = np.abs(np.asarray(sj.simulate(gauss, scene).data)).max(axis=1)
    x = (np.arange(40) - 19.5) * 6.25
    u = x / float(radar.footprint(5200.0))
    np.testing.assert_allclose(a, np.sinc(u) ** 2, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(b, np.exp(-0.5 * (u / 0.3) ** 2), rtol=1e-9)


def test_sinusoidal_pointing_profile():
    radar = sj.presets.airborne_xband()
    x = np.linspace(-100, 100, 11)
    daz = np.asarray(sj.seed_pointing_jitter(radar, x, phase=0.3))
    ts = 0.0314 * 5140 / 1.0 / 100.0
    expected = 0.0314 / 20 * np.sin(2 * np.pi * x / (100.0 * ts / 10) + 0.3)
    np.testing.assert_allclose(daz, expected, rtol=1e-12, atol=1e-15)


def test_smooth_deviation_rms_and_smoothness():
    x = (np.arange(1941) - 970) * 0.25
    d = sj.smooth_deviation(x, key=0, rms=0.02, max_cycles=2, aperture=160.0)
    assert np.sqrt(np.mean(d**2)) == pytest.approx(0.02)
    # ≤ 2 cycles per 160 m: pulse-to-pulse steps ≤ 2π (2/160 m) (0.25 m) rms ≈ 0.02 rms
    steps = np.diff(d)
    assert np.sqrt(np.mean(steps**2)) <= 0.025 * 0.02
    assert np.sqrt(np.mean(steps**2)) >= 1e-4 * 0.02  # not constant


def test_complex64_output_dtype():
    radar = _small_radar()
    raw = sj.simulate(radar, sj.PointTargets(azimuth=[0.0], range=[5200.0]), dtype=jnp.complex64)
    assert raw.data.dtype == jnp.complex64


def _sinc2_derivative_reference(u, n):
    """d^n/du^n sinc²(u) in long double, independently of sarjax: the Maclaurin series
    (60 terms) for |πu| < 1.5, else Leibniz on s = sin x / x with x s⁽ᵏ⁾ = sin⁽ᵏ⁾x − k s⁽ᵏ⁻¹⁾."""
    x = np.longdouble(np.pi) * np.longdouble(u)
    if abs(x) < 1.5:
        total = np.longdouble(0)
        for j in range(60):
            if 2 * j >= n:
                c = np.longdouble((-1) ** j * 2.0 ** (2 * j + 1)) / math.factorial(2 * j + 2)
                total += c * (math.factorial(2 * j) // math.factorial(2 * j - n)) * x ** (2 * j - n)
        return total * np.longdouble(np.pi) ** n
    sin_x, cos_x = np.sin(x), np.cos(x)
    cycle, s = (sin_x, cos_x, -sin_x, -cos_x), [np.sin(x) / x]
    for k in range(1, n + 1):
        s.append((cycle[k % 4] - k * s[-1]) / x)
    return sum(math.comb(n, k) * s[k] * s[n - k] for k in range(n + 1)) * np.longdouble(np.pi) ** n


def test_pattern_derivatives_closed_form():
    """The built-in patterns' closed-form derivatives (orders 0–4, what the pointing terms
    and the budgets use) against references that share no code with them, across the
    whole pattern table's range, both sides of sinc²'s series switch (|πu| = 0.3) and at
    u = 0; and against autodiff of the pattern (AbstractPattern.derivatives), the path a
    user's pattern takes."""
    u = np.concatenate([np.linspace(-64.0, 64.0, 1201), np.linspace(-0.15, 0.15, 301),
                        [0.0, 0.3 / np.pi, np.nextafter(0.3 / np.pi, 0), 0.05, -1.0, 2.0]])
    sinc2 = sj.Sinc2Pattern().derivatives(jnp.asarray(u), 4)
    for n in range(5):
        reference = np.array([_sinc2_derivative_reference(v, n) for v in u], float)
        # float64 rounding of sin/cos and of πu, amplified by the recursion near the switch:
        # ≤ 2e-15 at order 0, growing ≈ k!/x^k · 2⁻⁵³ (x = 0.3) with the order
        np.testing.assert_allclose(np.asarray(sinc2[n]), reference, rtol=0,
                                   atol=[1e-15, 1e-14, 1e-13, 1e-11, 1e-9][n] * np.pi ** n)
    width = 0.37
    gauss = sj.GaussianPattern(width=width).derivatives(jnp.asarray(u), 4)
    t = u / width
    hermite = [np.ones_like(t), t, t**2 - 1, t**3 - 3 * t, t**4 - 6 * t**2 + 3]
    for n in range(5):
        np.testing.assert_allclose(np.asarray(gauss[n]),
                                   (-1 / width) ** n * hermite[n] * np.exp(-0.5 * t**2),
                                   rtol=1e-12, atol=1e-13 * width ** -n)
    for pattern, closed in ((sj.Sinc2Pattern(), sinc2), (sj.GaussianPattern(width=width), gauss)):
        auto = sj.antenna.AbstractPattern.derivatives(pattern, jnp.asarray(u), 4)
        for n in range(5):
            # autodiff of sinc²'s __call__ is the less accurate side: its series stops at
            # x⁸ (switched at |u| = 0.05, x = πu), so it differs by the next term's n-th
            # derivative there, c₅ 10!/(10 − n)! x¹⁰⁻ⁿ πⁿ (measured: 3.9e-14 … 3.2e-5)
            x, c5 = 0.05 * np.pi, 2.0**11 / math.factorial(12)
            truncation = c5 * math.factorial(10) / math.factorial(10 - n) * x ** (10 - n)
            np.testing.assert_allclose(np.asarray(closed[n]), np.asarray(auto[n]), rtol=0,
                                       atol=1.5 * truncation * np.pi**n + 1e-14)


def test_pattern_derivatives_are_differentiable():
    """Each closed-form derivative's own derivative (autodiff, through the series switch
    and the sine-cosine's JVP) is the next order."""
    u = jnp.asarray(np.concatenate([np.linspace(-3.0, 3.0, 61), [0.0, 0.0954, 0.0956]]))
    for pattern in (sj.Sinc2Pattern(), sj.GaussianPattern(width=0.4)):
        values = pattern.derivatives(u, 3)
        for n in range(3):
            slope = jax.vmap(jax.grad(lambda v, n=n, p=pattern: p.derivatives(v, n)[n]))(u)
            np.testing.assert_allclose(np.asarray(slope), np.asarray(values[n + 1]),
                                       rtol=1e-9, atol=1e-9)
