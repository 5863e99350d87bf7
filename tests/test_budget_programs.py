"""The validity budgets' (pulse, scatterer) programs against a plain NumPy evaluation.

The budgets' maxima and recorded-error sums run over every pair of a pulse and a scene
sample (972 × 1024 on the seed 000 scene). They are formed in blocks of pulses
(``_budgets.over_pulse_blocks``) so that their intermediates stay in cache: the blocks,
the padding of the last one and the per-pulse operands must give what the whole plane
gives, whatever the pulse count and the block size (one pulse, a block of one, a count
that the block does not divide, a block larger than the window).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import sarjax as sj
from sarjax._data import Acquisition
from sarjax.simulators import _budgets

RADAR = sj.presets.airborne_xband()
LAMBDA = float(RADAR.wavelength)
RATIO = float(RADAR.antenna_length) / LAMBDA
H = float(RADAR.height)
K0 = 4 * np.pi / LAMBDA


def _pairs(seed, num_pulses, num_samples, squint):
    """Pulses 0.25 m apart about x' = 0, samples within ±60 m of it at 4.9–5.4 km, cm-level
    Δy, Δz: many pairs in the main lobe, many outside it."""
    rng = np.random.default_rng(seed)
    x_p = (np.arange(num_pulses) - (num_pulses - 1) / 2) * 0.25
    xs = rng.uniform(-60.0, 60.0, num_samples)
    rs = rng.uniform(4900.0, 5400.0, num_samples)
    hs = rng.uniform(0.0, 50.0, num_samples)
    dy = 0.03 * np.sin(x_p / 5.0 + rng.uniform(0, 6))
    dz = 0.02 * np.cos(x_p / 3.0 + rng.uniform(0, 6))
    ground = np.sqrt(rs**2 - (H - hs) ** 2)
    return (x_p, xs, rs, ground, dy, dz, np.asarray(RATIO), np.asarray(np.tan(squint)),
            H - hs)


def _reference_plane(pairs):
    """(along, |u| ≤ 1, δr_xr, u) of every pair, in NumPy."""
    x_p, xs, rs, ground, dy, dz, ratio, tan_d, drop = pairs
    along = x_p[:, None] - xs[None, :]
    r = rs[None, :]
    u = ratio * (along / r + tan_d) / (1 - along * tan_d / r)
    ground, drop = ground[None, :], drop[None, :]
    q = dy[:, None] * (dy[:, None] - 2 * ground) + dz[:, None] * (dz[:, None] + 2 * drop)
    los = q / (np.sqrt(r**2 + q) + r)
    return along, np.abs(u) <= 1.0, los, u


CASES = st.tuples(st.sampled_from([1, 7, 64, 97]), st.sampled_from([1, 13]),
                  st.sampled_from([1, 5, 32, 128]), st.sampled_from([0.0, 0.2]),
                  st.integers(0, 2**16))


@settings(max_examples=10)
@given(CASES)
def test_pulse_blocks_give_the_whole_plane(case):
    """Maxima and sums over blocks of pulses (with a per-pulse operand) equal those over the
    whole plane: relative 1e-12 (summation order)."""
    num_pulses, num_samples, block, squint, seed = case
    pairs = _pairs(seed, num_pulses, num_samples, squint)
    weight = np.random.default_rng(seed + 1).uniform(0.5, 2.0, num_pulses)

    def block_fn(along, lobe, los, weight_b, live):
        peaks = jnp.stack([_budgets.lobe_peak(lobe, los), _budgets.lobe_peak(lobe, along)])
        sums = jnp.stack([jnp.sum(live * weight_b[:, None] * los**2), jnp.sum(live + 0 * los)])
        return peaks, sums

    peaks, sums = jax.jit(lambda p, w: _budgets.over_pulse_blocks(block_fn, p, (w,), block))(
        pairs, weight)
    along, lobe, los, _ = _reference_plane(pairs)
    want_peaks = [np.max(np.abs(np.where(lobe, v, 0.0)), initial=0.0) for v in (los, along)]
    want_sums = [np.sum(weight[:, None] * los**2), los.size]
    np.testing.assert_allclose(np.asarray(peaks), want_peaks, rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(np.asarray(sums), want_sums, rtol=1e-12, atol=1e-18)


@settings(max_examples=6)
@given(CASES)
def test_line_of_sight_errors_match_numpy(case):
    """The straight track's budget program (max |δr_xr| in the lobe; the recorded phase
    error's sums Σ |γ|² W²(u)² 4 sin²(φ/2), Σ |γ|² W²(u)², φ = k₀ (R − R_n)) against the
    same sums in NumPy over the whole plane (W² = sinc²): relative 1e-9 (R − R_n is a
    difference of two slant ranges in NumPy: 1e-12 m of 1e-3 m)."""
    num_pulses, num_samples, _, squint, seed = case
    pairs = _pairs(seed, num_pulses, num_samples, squint)
    power = np.random.default_rng(seed + 2).uniform(0.1, 1.0, num_samples)
    got = [float(v) for v in _budgets._line_of_sight_errors(pairs, RADAR.pattern, power,
                                                            np.asarray(K0))]
    along, lobe, los, u = _reference_plane(pairs)
    r = pairs[2][None, :]
    phase = K0 * (np.sqrt((r + los) ** 2 + along**2) - np.sqrt(r**2 + along**2))
    w = np.sinc(u) ** 4 * power[None, :]
    want = [np.max(np.abs(np.where(lobe, los, 0.0)), initial=0.0),
            np.sum(w * 4 * np.sin(phase / 2) ** 2), np.sum(w)]
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-300)


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 40), st.integers(1, 40), st.floats(0.0, 4.0), st.integers(0, 2**31 - 1),
       st.sampled_from(["sorted", "reversed", "ties"]), st.booleans())
def test_grid_pair_count_matches_the_listing(n_az, n_rg, reach, seed, order, masked):
    """``_budgets._grid_candidates``, the pairs of a grid's cells within ``reach`` along
    track counted by column (so that a large grid's check stops before listing its cells),
    equals the count of the cells' listing sorted by azimuth, whatever the columns' order,
    ties and the cells left out: exact (integers)."""
    rng = np.random.default_rng(seed)
    azimuth = np.sort(rng.uniform(-5.0, 5.0, n_az))
    if order == "reversed":
        azimuth = azimuth[::-1].copy()
    elif order == "ties":
        azimuth = np.round(azimuth)
    kept = rng.random((n_az, n_rg)) < rng.random() if masked else None
    x = np.ravel(np.broadcast_to(azimuth[:, None], (n_az, n_rg)))
    x = np.sort(x if kept is None else x[np.ravel(kept)], kind="stable")
    listed = int(np.sum(np.searchsorted(x, x + reach, side="right") - np.arange(x.size) - 1))
    assert _budgets._grid_candidates(azimuth, kept, (n_az, n_rg), reach) == listed


def _budget_values(method, radar, scene, motion, num_pulses, centre, precision):
    """{budget name: (value, threshold)} of ``method``'s approximation budgets, its pair
    programs run in ``precision``."""
    from sarjax.simulators import _registry

    sim = _registry.simulator_class(method)()
    r0 = float(radar.reference_range)
    lobe = _budgets.LobeGeometry(radar, scene, motion, num_pulses, centre,
                                 range_window=(r0 - 500.0, r0 + 500.0), precision=precision)
    budgets, _ = sim.track.approximation_budgets(sim, radar, lobe)
    return {b.name: (b.value, b.threshold) for b in budgets}


@settings(max_examples=8, deadline=None)
@given(st.sampled_from(["airborne_xband", "spaceborne_cband"]),
       st.sampled_from([0.0, 0.1, -0.4]), st.sampled_from([0.0, 2.0e4]),
       st.floats(-4.0, 0.3), st.booleans(), st.integers(0, 2**16))
def test_single_precision_pairs_keep_the_budgets(preset, squint, centre, log_amplitude,
                                                 grid, seed):
    """The pair programs run on float32 inputs (``LobeGeometry.single``): each budget of the
    three track methods, and the chirp ends' (whose echo positions float32 keeps to ~1e-4
    of a sample), agrees with float64's within 2e-3 of max(value, threshold), on
    drawn radars, squints, track positions (20 km along the track), deviations of 0.1 mm
    to 2 m and scenes inside and outside the window. Reason for the tolerance: float32
    keeps ~1e-7 of δr_xr, up to 8e-5 rad of phase at 2 m on X band (8e-4 of the 0.1 rad
    phase threshold), and a pair at the main lobe's edge may fall on either side of it
    (measured worst of 110 drawn cases: 5e-4)."""
    rng = np.random.default_rng(seed)
    radar = getattr(sj.presets, preset)(squint=squint)
    n, dx = 300, float(radar.azimuth_spacing)
    x = centre + (np.arange(n) - (n - 1) / 2) * dx
    amplitude = 10.0**log_amplitude
    motion = sj.Motion(
        horizontal=amplitude * (np.sin(x / rng.uniform(3, 300) + rng.uniform(0, 6))
                                + 0.1 * rng.normal(size=n)),
        vertical=amplitude * np.cos(x / rng.uniform(3, 300) + rng.uniform(0, 6)))
    r0 = float(radar.reference_range)
    if grid:  # 40 × 40 cells (a 32 × 32 lattice of samples), some beyond the window
        cells = 40
        scene = sj.ReflectivityGrid(
            rng.normal(size=(cells, cells)) + 0j,
            centre + (np.arange(cells) - cells / 2) * 2 * dx * rng.uniform(0.5, 8),
            r0 + (np.arange(cells) - cells / 2) * 3 * float(radar.range_spacing),
            height=rng.uniform(0, 30, (cells, cells)))
    else:  # 24 points, within 3 windows' lengths of the centre, half of them moving
        moving = rng.uniform(-30, 30, (2, 24)) * (np.arange(24) % 2)
        scene = sj.PointTargets(azimuth=centre + rng.uniform(-1.5, 1.5, 24) * n * dx,
                                range=r0 * (1 + rng.uniform(-0.05, 0.05, 24)),
                                reflectivity=np.ones(24), height=rng.uniform(0, 50, 24),
                                velocity_range=moving[0], velocity_azimuth=moving[1])
    for method in ("fourier_2d", "small_deviation", "moderate_deviation"):
        single, double = (_budget_values(method, radar, scene, motion, n, centre, p)
                          for p in ("single", "double"))
        assert single.keys() == double.keys()
        for name, (value, threshold) in double.items():
            assert abs(single[name][0] - value) <= 2e-3 * max(abs(value), threshold), (
                method, name, single[name][0], value, threshold)
    # the chirp ends' budget, its window cutting the scene's echoes (a range window of
    # 300 samples from 400 samples before the scene's near edge to 100 after it)
    near = float(np.min(np.asarray(scene.range))) + rng.uniform(-400, 100) * float(
        radar.range_spacing)
    acquisition = Acquisition(num_pulses=n, num_range=300, near_range=near,
                              azimuth_center=centre)
    single, double = (_budgets.chirp_edge_budget(radar, scene, motion, acquisition, 1,
                                                 precision=p)[0]
                      for p in ("single", "double"))
    assert abs(single.value - double.value) <= 2e-3 * max(double.value, single.threshold), (
        single.value, double.value, single.threshold)
