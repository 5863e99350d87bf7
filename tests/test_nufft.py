"""The exact model through one non-uniform FFT per pulse (method="time_domain_nufft")."""

import jax.numpy as jnp
import numpy as np
import pytest

import sarjax as sj
from sarjax.metrics import nmse_db

try:
    from _gradients import assert_gradient_matches
except ImportError:
    from tests._gradients import assert_gradient_matches

RADAR = sj.presets.airborne_xband(num_pulses=96, num_range=320)
N = RADAR.num_pulses
X = (np.arange(N) - N / 2) * float(RADAR.azimuth_spacing)
DR = float(RADAR.range_spacing)
NEAR = 5140.0 - 160 * DR
KW = dict(num_pulses=N, num_range=320, near_range=NEAR)


def _grid(n_az=64, n_rg=64, seed=0):
    rng = np.random.default_rng(seed)
    az = (np.arange(n_az) - n_az // 2) * float(RADAR.azimuth_spacing)
    rg = 5140.0 + (np.arange(n_rg) - n_rg // 2) * DR
    gamma = rng.normal(size=(n_az, n_rg)) + 1j * rng.normal(size=(n_az, n_rg))
    return sj.ReflectivityGrid(gamma, az, rg, height=sj.pyramid_height(az, rg, peak=30.0))


def _cm_motion():
    return sj.Motion(
        horizontal=sj.smooth_deviation(X, key=1, rms=0.02, max_cycles=1, aperture=171.0),
        vertical=sj.smooth_deviation(X, key=2, rms=0.02, max_cycles=1, aperture=171.0),
        pointing=sj.seed_pointing_jitter(RADAR, X))


@pytest.fixture(scope="module")
def grid_direct():
    """64 × 64 grid with pyramid heights, cm-level deviations and the seed jitter: the
    same band-limited model summed directly over the 4096 scatterers."""
    grid, motion = _grid(), _cm_motion()
    direct = sj.simulate(RADAR, grid, motion, method="time_domain_nufft", engine="direct",
                         **KW)
    return grid, motion, np.asarray(direct.data)


def test_nufft_matches_direct_sum_at_the_default_tolerance(grid_direct):
    """Acceptance: NMSE ≤ −60 dB at the default tolerance (1e-4: measured −94 dB)."""
    grid, motion, direct = grid_direct
    raw = sj.simulate(RADAR, grid, motion, method="time_domain_nufft", **KW)
    assert raw.method == "time_domain_nufft"
    assert nmse_db(raw.data, direct) <= -60.0


@pytest.mark.parametrize("tolerance,bound", [(1e-3, -55.0), (1e-8, -140.0)])
def test_tolerance_sets_the_error(grid_direct, tolerance, bound):
    """The kernel width follows the tolerance (measured −70 dB at 1e-3, −174 dB at 1e-8):
    the tolerance is a real knob, not a label."""
    grid, motion, direct = grid_direct
    raw = sj.simulate(RADAR, grid, motion, method="time_domain_nufft", tolerance=tolerance,
                      **KW)
    assert nmse_db(raw.data, direct) <= bound


def test_approaches_the_sampled_hard_edged_echo_with_more_bands():
    """Against the direct time-domain simulator (the sampled hard-edged chirp), the
    difference is the chirp spectrum beyond the 2M + 1 bands: for an off-grid point target
    −23 dB with M = 0 and −44 dB with M = 2 (measured), and smaller with every band."""
    scene = sj.PointTargets(azimuth=[0.0, 2.1], range=[5140.3, 5155.77],
                            reflectivity=[1.0, 0.5j])
    motion = _cm_motion()
    ref = np.asarray(sj.simulate(RADAR, scene, motion, **KW).data)
    errors = [nmse_db(sj.simulate(RADAR, scene, motion, method="time_domain_nufft",
                                  range_bands=m, **KW).data, ref) for m in (0, 1, 2)]
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] <= -40.0, errors


def test_general_model_squint_moving_and_non_stop_and_go():
    """Squint, moving scatterers and the non-stop-and-go delay share the time-domain
    geometry: the NUFFT equals the direct sum of the same model."""
    radar = sj.presets.airborne_xband(num_pulses=64, num_range=320, squint=np.deg2rad(4.0))
    # the 4° beam crosses a scatterer at x' = x − r tan φ_d ≈ x − 359 m
    scene = sj.PointTargets(azimuth=[0.0, 5.0], range=[5140.3, 5160.1],
                            velocity_range=[3.0, 0.0], velocity_azimuth=[0.0, -5.0])
    kw = dict(num_pulses=64, num_range=320, near_range=NEAR, azimuth_center=-360.0)
    for stop_and_go in (True, False):
        fast = sj.simulate(radar, scene, method="time_domain_nufft", stop_and_go=stop_and_go,
                           **kw)
        direct = sj.simulate(radar, scene, method="time_domain_nufft", engine="direct",
                             stop_and_go=stop_and_go, **kw)
        assert float(np.max(np.abs(fast.data))) > 0.1  # the beam sees the targets
        assert nmse_db(fast.data, direct.data) <= -80.0


def test_chunking_and_loops_do_not_change_the_result():
    scene = _grid(8, 8, seed=3)
    motion = _cm_motion()
    runs = [np.asarray(sj.simulate(RADAR, scene, motion, method="time_domain_nufft",
                                   pulse_chunk=chunk, loops=loops, **KW).data)
            for chunk, loops in ((1, 1), (7, 2), (96, 1), (1, 5))]
    for other in runs[1:]:
        np.testing.assert_allclose(other, runs[0], rtol=0, atol=1e-12 * np.abs(runs[0]).max())


@pytest.mark.parametrize("name,step", [("horizontal", 1e-7), ("vertical", 1e-7),
                                       ("pointing", 1e-8)])
def test_gradient_matches_finite_differences(name, step):
    """Differentiable w.r.t. deviations and pointing (through the spreading kernel's
    polynomial taps and the scatter-add), float64 central differences."""
    radar = sj.presets.airborne_xband(prf=16.0, chirp_duration=1e-6, num_pulses=48,
                                      num_range=160, near_range=5000.0)
    x = (np.arange(48) - 23.5) * float(radar.azimuth_spacing)
    scene = sj.PointTargets(azimuth=[-20.0, 15.0], range=[5100.0, 5180.0],
                            reflectivity=[1.0, 0.6 - 0.3j])
    base = {"horizontal": 0.01 * np.sin(2 * np.pi * x / 300.0),
            "vertical": 0.008 * np.cos(2 * np.pi * x / 250.0),
            "pointing": np.asarray(sj.seed_pointing_jitter(radar, x))}
    rng = np.random.default_rng(0)
    weights = jnp.asarray(rng.normal(size=(48, 160)) + 1j * rng.normal(size=(48, 160)))

    def loss(params):
        raw = sj.simulate(radar, scene, sj.Motion(**params), method="time_domain_nufft",
                          num_pulses=48, num_range=160)
        return jnp.sum(jnp.real(raw.data * weights)) + 0.1 * jnp.sum(jnp.abs(raw.data) ** 2)

    params = {k: jnp.asarray(v) for k, v in base.items()}
    direction = {k: jnp.zeros(48) for k in params}
    direction[name] = jnp.asarray(rng.normal(size=48))
    # truncation O(step² L''') ≈ 1e-6 relative at these steps; round-off ≈ 1e-8
    assert_gradient_matches(loss, params, direction, step, 1e-5, label=name)


@pytest.mark.parametrize("options,match", [
    ({"tolerance": 0.0}, "tolerance"),
    ({"tolerance": 2.0}, "tolerance"),
    ({"engine": "fast"}, "engine"),
    ({"range_bands": -1}, "range_bands"),
])
def test_bad_options_are_refused(options, match):
    scene = sj.PointTargets(azimuth=[0.0], range=[5140.0])
    with pytest.raises(ValueError, match=match):
        sj.simulate(RADAR, scene, method="time_domain_nufft", **KW, **options)
