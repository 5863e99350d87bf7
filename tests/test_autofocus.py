"""Autofocus on scenes nobody described (``sarjax.inverse.autofocus``), its PGA baseline
and its metrics.

The CI problem is the airborne set with a 2 m antenna (footprint X ≈ 80 m) and a 2.5 µs
chirp on a 384-pulse × 128-sample grid (r = 4750…5130 m), so that a simulation and an
autofocus take seconds. The full-size acceptance runs (1941 × 830, clutter with edges and
bright points, SNR 10 dB) are the ``slow`` tests and ``benchmarks/bench_autofocus.py``.
"""

from __future__ import annotations

import dataclasses
import json
import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import sarjax as sj
from sarjax.inverse import _autofocus as af
from sarjax.inverse import _sharpness

NUM_PULSES = 384
NUM_RANGE = 128
NEAR_RANGE = 4750.0
PROPERTY = settings(max_examples=2)


def _radar(**overrides):
    return sj.presets.airborne_xband(antenna_length=2.0, chirp_duration=2.5e-6,
                                     num_pulses=NUM_PULSES, num_range=NUM_RANGE,
                                     near_range=NEAR_RANGE, **overrides)


def _axis(radar):
    n = radar.num_pulses
    return (np.arange(n) - (n - 1) / 2) * float(radar.azimuth_spacing)


def _scene(radar, seed):
    rng = np.random.default_rng(seed)
    x = _axis(radar)
    n_points = 8
    px = rng.uniform(x.min() + 10, x.max() - 10, n_points)
    pr = rng.uniform(4800.0, 5080.0, n_points)
    amp = rng.uniform(1.0, 2.0, n_points) * np.exp(1j * rng.uniform(-np.pi, np.pi, n_points))
    return sj.PointTargets(azimuth=px, range=pr, reflectivity=amp)


def _motion(radar, rms, seed):
    x = _axis(radar)
    if rms == 0:
        return sj.Motion()
    rng = np.random.default_rng(seed + 1000)
    footprint = float(radar.footprint(radar.reference_range))
    dy = sj.smooth_deviation(x, key=rng, rms=rms, max_cycles=1.5, aperture=footprint)
    dz = sj.smooth_deviation(x, key=rng, rms=rms, max_cycles=1.5, aperture=footprint)
    return sj.Motion(horizontal=dy, vertical=dz)


def _noisy(radar, scene, motion, seed, snr_db=20.0):
    clean = sj.simulate(radar, scene, motion, method="time_domain_nufft")
    data = np.asarray(clean.data)
    rng = np.random.default_rng(seed + 2000)
    power = np.mean(np.abs(data) ** 2) / 10 ** (snr_db / 10)
    noise = np.sqrt(power / 2) * (rng.normal(size=data.shape) + 1j * rng.normal(size=data.shape))
    return sj.RawData(data=data + noise, azimuth=clean.azimuth, range=clean.range)


@pytest.fixture(scope="module")
def radar():
    return _radar()


def test_sharpness_gradient_matches_finite_differences(radar):
    """The reverse-mode derivative of each objective (entropy, contrast) w.r.t. the
    B-spline coefficients of Δy, Δz, along three random directions, equals the central
    finite difference (step 0.02 rad of line-of-sight phase per coefficient; float64 data
    so the quotient is not float32 rounding), at a point away from the optimum; tolerance
    2 % (the quotient's truncation error at this step is ≈ 0.1 %)."""
    raw = _noisy(radar, _scene(radar, 1), _motion(radar, 0.004, 1), 1)
    focuser = _sharpness.make_focuser(radar, raw, dtype=jnp.complex128)
    x = np.asarray(raw.azimuth)
    design = jnp.asarray(sj.inverse.BSpline(12).bind(x).design(jnp.asarray(x)))
    k0 = float(radar.wavenumber)
    rng = np.random.default_rng(0)
    theta = jnp.asarray(rng.normal(scale=0.5, size=24))
    directions = rng.normal(size=(3, 24))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    for objective in _sharpness.OBJECTIVES:
        def loss(theta, objective=objective):
            phase = focuser.line_of_sight_phase(design @ theta[:12] / k0,
                                                design @ theta[12:] / k0)
            return _sharpness.sharpness_loss(focuser.image(phase), focuser.energy, objective)

        value_and_grad = jax.jit(jax.value_and_grad(loss))
        grad = np.asarray(value_and_grad(theta)[1])
        step = 0.02
        for v in directions:
            fd = (float(value_and_grad(theta + step * v)[0])
                  - float(value_and_grad(theta - step * v)[0])) / (2 * step)
            assert grad @ v == pytest.approx(fd, rel=0.02, abs=0.02 * np.linalg.norm(grad))


def test_energy_is_independent_of_the_motion(radar):
    """The focuser is unitary along azimuth: Σ|I|² is the same for any compensation
    (relative 1e-5, float32 sums), so the objectives' normaliser is a constant."""
    raw = _noisy(radar, _scene(radar, 2), sj.Motion(), 2)
    focuser = _sharpness.make_focuser(radar, raw)
    n = raw.azimuth.shape[0]
    for phase in (jnp.zeros(n), jnp.asarray(np.random.default_rng(0).normal(size=n)) * 3):
        image = focuser.image(phase[None, :])
        energy = float(jnp.sum(jnp.abs(image) ** 2))
        assert energy == pytest.approx(float(focuser.energy), rel=1e-5)


def test_no_harm_without_motion_error(radar):
    """Data with no motion error: the estimate is ≈ 0 (line-of-sight phase ≤ 0.1 rad
    after the unobservable terms are removed, aperture-detrended) and the refocused image is
    not less sharp than the true-track one (entropy within 0.5 %). The restarts (1 rad rms of
    phase, its floor, from the straight track) come back to it: they agree, no warning."""
    raw = _noisy(radar, _scene(radar, 3), sj.Motion(), 3)
    with warnings.catch_warnings():
        warnings.simplefilter("error", sj.inverse.AutofocusWarning)
        result = sj.inverse.autofocus(radar, raw, max_steps=20, estimate_pointing=False)
    assert result.agreement.shape == (3,) and np.all(result.agreement <= 0.1), result.agreement
    assert result.agreeing == 3
    blocks = af.range_blocks(radar, raw.range)
    residual = af.residual_phase_rms(radar, result, sj.Motion(horizontal=np.zeros(NUM_PULSES)),
                                     blocks)
    assert np.all(residual <= 0.1), residual
    reference = sj.focus(radar, raw)
    assert (af.image_entropy(result.image.data)
            <= af.image_entropy(reference.data) * 1.005)


def test_started_at_the_true_track_it_stays_there(radar):
    """``initial=``: started from the true Δy, Δz (as from navigation data), the estimate
    stays within 0.1 rad of it (aperture-detrended; measured 0.008 rad) on data whose
    uncorrected error is 2.2–2.4 rad; a motion of the wrong type is refused by name."""
    truth = _motion(radar, 0.008, 5)
    raw = _noisy(radar, _scene(radar, 5), truth, 5)
    blocks = af.range_blocks(radar, raw.range)
    result = sj.inverse.autofocus(radar, raw, max_steps=20, estimate_pointing=False,
                                  initial=truth, restarts=0)
    assert result.agreement is None and result.agreeing is None
    assert np.all(af.residual_phase_rms(radar, af.no_estimate(raw), truth, blocks) > 1.0)
    residual = af.residual_phase_rms(radar, result, truth, blocks)
    assert np.all(residual <= 0.1), residual
    with pytest.raises(ValueError, match="initial"):
        sj.inverse.autofocus(radar, raw, initial=np.zeros(NUM_PULSES))


@PROPERTY
@given(seed=st.integers(0, 50), rms=st.sampled_from([0.004, 0.008]))
def test_autofocus_reduces_the_phase_error(seed, rms):
    """Drawn point scenes and smooth deviations of several λ/4π (4–8 mm rms, 1.5 cycles per
    footprint), SNR 20 dB: the model-based estimate removes at least 75 % of the
    aperture-detrended line-of-sight phase error in every range block, and does at least as
    well as single-history PGA on the same data (measured on seeds 0, 7, 23: 88–99 % removed,
    0.014–0.11 rad left against PGA's 0.05–0.15 rad; 75 % leaves room for other draws).

    The estimate kept is what is asserted. Where the starts land on different optima the
    call says so (an AutofocusWarning naming the disagreement, allowed here; any other
    warning fails): on seed 39 (4 mm) one of three starts moves by 0.141 rad when the data
    change by 3e-7 of their peak (the NUFFT simulator's rounding, within its 1e-4
    tolerance) while the estimate kept removes 98.5 % and beats PGA."""
    radar = _radar()
    truth = _motion(radar, rms, seed)
    raw = _noisy(radar, _scene(radar, seed), truth, seed)
    blocks = af.range_blocks(radar, raw.range)
    zero = af.residual_phase_rms(radar, af.no_estimate(raw), truth, blocks)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", sj.inverse.AutofocusWarning)
        result = sj.inverse.autofocus(radar, raw, max_steps=20, estimate_pointing=False)
    assert all("starts differ" in str(w.message) for w in caught), [str(w.message) for w in caught]
    ours = af.residual_phase_rms(radar, result, truth, blocks)
    assert np.all(ours <= 0.25 * zero), (ours, zero)
    pga = sj.inverse.pga(radar, raw)
    theirs = af.residual_phase_rms(radar, pga, truth, blocks)
    assert np.mean(ours) <= np.mean(theirs) * 1.1, (ours, theirs)


def _exact_products_fit(radar, rng):
    """One draw for the test below: (residual rms per block after one fit, before) [rad]."""
    from types import SimpleNamespace

    from sarjax.inverse import _pga

    x = _axis(radar)
    footprint = float(radar.footprint(radar.reference_range))
    truth = sj.Motion(
        horizontal=sj.smooth_deviation(x, key=rng, rms=0.02, max_cycles=2, aperture=footprint),
        vertical=sj.smooth_deviation(x, key=rng, rms=0.02, max_cycles=2, aperture=footprint))
    ranges = np.asarray(sj.Acquisition(num_pulses=x.size, num_range=radar.num_range,
                                       near_range=radar.near_range,
                                       azimuth_center=0.0).range_axis(radar))
    ranges = ranges[ranges * np.cos(_sharpness.MIN_LOOK_ANGLE) >= float(radar.height)]
    rows = np.sort(rng.choice(ranges.size, 12, replace=False))
    centres = rng.uniform(x[0], x[-1], rows.size)
    los = af.true_line_of_sight_phase(radar, truth, ranges[rows])  # (target, pulse)
    envelope = np.sinc((x[None, :] - centres[:, None]) / footprint) ** 2  # two-way pattern
    slopes = rng.uniform(-0.8, 0.8, rows.size)
    products = (np.sqrt(envelope[:, 1:] * envelope[:, :-1])
                * np.exp(-1j * np.diff(los, axis=1) + 1j * slopes[:, None]))
    design = np.asarray(af._default_model(radar, x).horizontal.bind(x).design(jnp.asarray(x)))
    c_y, c_z = _pga.motion_increment(products, rows, SimpleNamespace(radar=radar, range=ranges),
                                     design)
    raw_range = np.linspace(ranges[0], ranges[-1], 64)
    zero = af.no_estimate(sj.RawData(data=np.zeros((x.size, 1)), azimuth=x, range=raw_range[:1]))
    estimate = dataclasses.replace(zero, motion=sj.Motion(
        horizontal=af._remove_trend(design @ c_y), vertical=af._remove_trend(design @ c_z)))
    blocks = af.range_blocks(radar, raw_range)
    return (af.residual_phase_rms(radar, estimate, truth, blocks),
            af.residual_phase_rms(radar, zero, truth, blocks))


@settings(max_examples=2)
@given(seed=st.integers(0, 10_000))
def test_motion_increment_recovers_the_motion_from_exact_products(seed):
    """The phase-gradient fit of ``_pga.motion_increment`` on exact products, full-size
    airborne set (1941 pulses; 12 scatterers drawn across the swath and the pulses, each
    seen over its footprint through the two-way pattern with its own unknown slope s_k;
    Δy, Δz smooth 2 cm rms at 2 cycles per footprint: 3–7 rad of aperture-detrended error),
    8 draws per example: one solve leaves a median worst block ≤ 0.13 rad and none above
    0.45 rad. Measured over 40 draws: solving the slopes jointly with the motion, median
    0.088, 90th percentile 0.19, max 0.32 rad; alternating with them (the earlier fit)
    median 0.19, max 0.43 rad, which the median bound rejects."""
    radar = sj.presets.airborne_xband()
    rng = np.random.default_rng(seed)
    worst = []
    for _ in range(8):
        after, before = _exact_products_fit(radar, rng)
        assert np.all(before > 1.5), before  # each draw a real test: rad to remove
        worst.append(after.max())
    assert np.median(worst) <= 0.13 and max(worst) <= 0.45, np.round(worst, 3)


def test_starts_that_disagree_are_reported(radar):
    """Restarts that cannot converge (30 cm rms: a blur of ≈ ±100 m, beyond the first
    48 m window) end elsewhere: the disagreement (> 1 rad) exceeds ``agreement_tolerance``
    and an AutofocusWarning names it; the estimate kept is the first start's, whose
    windows are sharper (the same as without restarts, residual within 0.1 rad of the
    truth); ``strict=True`` refuses instead."""
    truth = _motion(radar, 0.008, 6)
    raw = _noisy(radar, _scene(radar, 6), truth, 6)
    blocks = af.range_blocks(radar, raw.range)
    options = dict(max_steps=20, estimate_pointing=False, restart_rms=0.3)
    with pytest.warns(sj.inverse.AutofocusWarning,
                      match="starts differ.*[01] of the other 2 agree with the estimate kept"):
        result = sj.inverse.autofocus(radar, raw, **options)
    assert np.max(result.agreement) > 1.0, result.agreement
    assert result.agreeing in (1, 2)  # the kept one at least; not all: they disagree
    assert result.history[-1][0] == "start 0 of 3 kept"
    assert np.all(af.residual_phase_rms(radar, result, truth, blocks) <= 0.1)
    assert result.attributes()["autofocus_agreement_rad"] == list(result.agreement)
    with pytest.raises(ValueError, match="agreement_tolerance"):
        sj.inverse.autofocus(radar, raw, strict=True, **options)


@given(st.integers(2, 8), st.integers(0, 2**32 - 1))
@settings(max_examples=30)
def test_the_estimate_kept_is_the_one_most_starts_agree_with(count, seed):
    """Starts in clusters (within 0.02 rad of a centre: agree at tolerance 0.1) and strays
    (≥ 1 rad from everything): the estimate kept lies in the largest cluster, and is that
    cluster's sharpest (lowest value) even where a stray's windows are sharper; the
    support counts the starts within the tolerance of it, itself included."""
    rng = np.random.default_rng(seed)
    labels = rng.integers(0, max(count // 2, 1) + 2, count)  # cluster per start
    centres = 10.0 * rng.permutation(labels.max() + 1)[labels]  # clusters 10 rad apart
    position = centres + rng.uniform(-0.02, 0.02, count)
    differences = np.abs(position[:, None] - position[None, :])[..., None] * np.array(
        [1.0, 0.5, 0.8])  # (start, start, block)
    values = rng.normal(size=count)
    kept, support = af._consensus(differences, values, 0.1)
    sizes = np.bincount(labels)
    assert support == sizes[labels[kept]] == sizes.max()
    rivals = [i for i in range(count) if sizes[labels[i]] == sizes.max()]
    assert values[kept] == min(values[i] for i in rivals)


def test_consensus_on_the_benchmark_draw_that_kept_its_worst_start():
    """Modelled on draw 109 of bench_autofocus with seven restarts: converged starts
    within 0.015–0.044 rad of each other (0.07 / 0.10 / 0.15 rad from the truth), strays
    1.5–4.7 rad away from them, the sharpest windows a stray's. With agreement first a
    converged start is kept (the sharpest of the five within 0.1 rad), and the warning
    still fires (the strays disagree with it)."""
    offsets = np.array([[0.0, 0, 0], [0.005, 0, 0], [0, 0.004, 0], [0, 0, 0.006],
                        [1.7, 3.2, 4.0], [1.75, 3.3, 4.1], [0.05, 0.05, 0.06],
                        [2.1, 4.0, 5.2]])
    differences = np.abs(offsets[:, None] - offsets[None, :])
    values = np.array([0.3, 0.2, 0.4, 0.5, 0.1, 0.15, 0.25, 0.0])  # the stray sharpest
    kept, support = af._consensus(differences, values, 0.1)
    assert kept == 1 and support == 5
    assert np.max(np.delete(differences[kept], kept, axis=0)) > 0.1


def test_bad_inputs(radar):
    raw = _noisy(radar, _scene(radar, 4), sj.Motion(), 4)
    with pytest.raises(ValueError, match="objective"):
        sj.inverse.autofocus(radar, raw, objective="variance")
    with pytest.raises(ValueError, match="windows"):
        sj.inverse.autofocus(radar, raw, windows=())
    with pytest.raises(ValueError, match="max_steps"):
        sj.inverse.autofocus(radar, raw, max_steps=-1)
    with pytest.raises(ValueError, match="gradient_targets"):
        sj.inverse.autofocus(radar, raw, gradient_targets=2)
    with pytest.raises(ValueError, match="min_window"):
        sj.inverse.autofocus(radar, raw, min_window=0.0)
    with pytest.raises(ValueError, match="raw"):
        sj.inverse.autofocus(radar, raw.data)
    for bad in (dict(restarts=-1), dict(restarts=1.5), dict(restart_rms=0.0),
                dict(agreement_tolerance=0.0)):
        with pytest.raises(ValueError, match=next(iter(bad))):
            sj.inverse.autofocus(radar, raw, **bad)
    with pytest.raises(ValueError, match="detrend"):
        af.residual_phase_rms(radar, af.no_estimate(raw), sj.Motion(), [[4800, 4900]],
                              detrend="none")


def test_cli_autofocus_writes_the_refocused_image(radar, tmp_path, capsys):
    """``sarjax autofocus raw.nc -o image.nc``: the file holds the estimated motion and the
    image focused with it (ω-k, second-order motion compensation of Δy, Δz)."""
    import sarjax.cli
    from sarjax import io

    raw = _noisy(radar, _scene(radar, 5), _motion(radar, 0.004, 5), 5)
    io.save(tmp_path / "raw.nc", raw, radar=radar)
    code = sarjax.cli.main(["autofocus", str(tmp_path / "raw.nc"), "-o",
                            str(tmp_path / "image.nc"), "--max-steps", "5"])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "of 3 starts agree with the estimate kept" in out, out
    stored = io.load(tmp_path / "image.nc")
    motion = sj.Motion(horizontal=stored.motion.horizontal, vertical=stored.motion.vertical)
    assert np.std(np.asarray(motion.horizontal)) > 0
    direct = sj.focus(radar, raw, motion=motion)
    np.testing.assert_allclose(np.asarray(stored.product.data), np.asarray(direct.data),
                               rtol=1e-6, atol=1e-9 * float(np.abs(direct.data).max()))
    assert stored.attrs["autofocus_method"] == "model"
    assert len(json.loads(stored.attrs["autofocus_agreement_rad"])) == 3  # JSON attribute
    assert 1 <= int(stored.attrs["autofocus_agreeing_starts"]) <= 3


# ---- full size (slow): the acceptance setup of issue 18 -----------------------------------


def _acceptance_draw(seed):
    """Airborne preset 1941 × 830, ``random_scene`` (clutter fields, road, 12 bright
    points), Δy, Δz smooth 2 cm rms (2 cycles per footprint), seed pointing jitter,
    SNR 10 dB (as ``benchmarks/bench_autofocus.py``)."""
    radar = sj.presets.airborne_xband()
    rng = np.random.default_rng(seed)
    x = _axis(radar)
    footprint = float(radar.footprint(radar.reference_range))
    clutter, points = sj.inverse.random_scene(radar, x, key=rng)
    truth = sj.Motion(
        horizontal=sj.smooth_deviation(x, key=rng, rms=0.02, max_cycles=2, aperture=footprint),
        vertical=sj.smooth_deviation(x, key=rng, rms=0.02, max_cycles=2, aperture=footprint),
        pointing=sj.seed_pointing_jitter(radar, x, phase=rng.uniform(-np.pi, np.pi)))
    parts = [sj.simulate(radar, s, truth, method="time_domain_nufft") for s in (clutter, points)]
    data = np.asarray(parts[0].data) + np.asarray(parts[1].data)
    power = np.mean(np.abs(data) ** 2) / 10
    data = data + np.sqrt(power / 2) * (rng.normal(size=data.shape)
                                        + 1j * rng.normal(size=data.shape))
    return radar, sj.RawData(data=data, azimuth=parts[0].azimuth, range=parts[0].range), truth


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="issue 18 acceptance not reached: 0.035–0.35 rad per "
                   "block on 15 of 20 drawn scenes (100–119), worst block 0.6–2.8 rad on five; "
                   "the Cramér–Rao bound with the clutter (and the points' positions) "
                   "unknown is 0.022–0.073 rad, above 0.02 in every block of every draw "
                   "(docs/autofocus.md, benchmarks/RESULTS.md)")
def test_acceptance_residual_below_0p02_rad_in_9_of_10_draws():
    """The issue's acceptance: ≤ 0.02 rad (aperture-detrended) in every range block in at
    least 9 of 10 drawn scenes and motions (seeds the benchmark does not use)."""
    successes = 0
    for seed in range(500, 510):
        radar, raw, truth = _acceptance_draw(seed)
        result = sj.inverse.autofocus(radar, raw, estimate_pointing=False)
        blocks = af.range_blocks(radar, raw.range)
        successes += bool(np.all(af.residual_phase_rms(radar, result, truth, blocks) <= 0.02))
        if seed - 500 + 1 - successes > 1:
            break
    assert successes >= 9


@pytest.mark.slow
def test_full_size_autofocus_improves_on_no_correction_and_runs_in_two_minutes():
    """One full-size acceptance draw: the model-based estimate removes at least half of the
    aperture-detrended line-of-sight error in every range block (a loose bound: the
    benchmark's draws are in RESULTS.md) and the call, compilation included, takes at most
    150 s (2 min asked, on a shared 2-core machine)."""
    import time

    radar, raw, truth = _acceptance_draw(501)
    blocks = af.range_blocks(radar, raw.range)
    before = af.residual_phase_rms(radar, af.no_estimate(raw), truth, blocks)
    t0 = time.perf_counter()
    result = sj.inverse.autofocus(radar, raw)
    seconds = time.perf_counter() - t0
    after = af.residual_phase_rms(radar, result, truth, blocks)
    assert np.all(after <= 0.5 * before), (after, before)
    assert seconds <= 150.0


def test_genie_bound_scales_with_the_noise(radar):
    """The known-scene Cramér–Rao reference of ``_autofocus_bound``: finite, positive, and
    10× lower for 100× less noise (the information is 2|s|²/σ²); counting a second scene as
    interference raises it."""
    from sarjax.inverse import _autofocus_bound as bound

    scene = _scene(radar, 6)
    clean = sj.simulate(radar, scene, sj.Motion(), method="time_domain_nufft")
    signal = np.asarray(clean.data)
    noise = float(np.mean(np.abs(signal) ** 2)) / 10
    blocks = af.range_blocks(radar, clean.range)
    x = np.asarray(clean.azimuth)
    values = []
    for power in (noise, noise / 100):
        info, ranges = bound.phase_information(radar, signal, power, x, clean.range)
        values.append(bound.phase_bound(radar, info, ranges, 16, blocks))
    assert np.all(np.isfinite(values[0])) and np.all(values[0] > 0)
    np.testing.assert_allclose(values[1], values[0] / 10, rtol=1e-3)
    info, ranges = bound.phase_information(radar, signal, noise, x, clean.range,
                                           interference=signal)
    interfered = bound.phase_bound(radar, info, ranges, 16, blocks)
    assert np.all(interfered > values[0])
    # the same scene's echo as clutter of unknown reflectivity adds information: the bound
    # can only fall, and stays above the known-scene one
    band, _ = bound.clutter_information(radar, signal, noise, x, clean.range)
    assert np.all(np.isfinite(band))
    both = bound.phase_bound(radar, info, ranges, 16, blocks, clutter=band)
    assert np.all(both <= interfered * (1 + 1e-9)) and np.all(both > values[0])


def test_point_with_unknown_position_carries_no_information_on_a_line():
    """``phase_bound(points=...)``: a point whose phase and azimuth position are unknown
    tells nothing about a line-of-sight phase that is constant or linear over the pulses at
    its look angle (its Fisher matrix annihilates those coefficient vectors, to 1e-9 of its
    scale), and the bound is never below the bound of the same point known."""
    from sarjax.inverse import _autofocus_bound as bound

    radar = sj.presets.airborne_xband()
    n, num_basis = 1500, 24
    t = np.arange(n, dtype=float)
    ranges = np.array([5000.0, 5010.0, 5400.0])
    info = np.zeros((ranges.size, n))
    info[1] = 50.0 * np.sinc((t - 700.0) / 645.0) ** 2  # one point, one range bin
    design = np.asarray(sj.inverse.BSpline(num_basis).bind(t).design(t))
    fisher = bound._point_information(radar, design, ranges, info)
    look = np.arccos(float(radar.height) / ranges[1])
    unit = np.linalg.lstsq(design, np.ones(n), rcond=None)[0]
    ramp = np.linalg.lstsq(design, t / n, rcond=None)[0]
    # Δy, Δz with −Δy sin ϑ + Δz cos ϑ constant (or linear) at the point's look angle
    for shape in (unit, ramp):
        v = np.concatenate([-np.sin(look) * shape, np.cos(look) * shape])
        assert abs(v @ fisher @ v) <= 1e-9 * np.trace(fisher) * (v @ v)
    blocks = [[5000.0, 5100.0], [5300.0, 5400.0]]
    known = bound.phase_bound(radar, info, ranges, num_basis, blocks)
    unknown = bound.phase_bound(radar, None, ranges, num_basis, blocks, points=[info])
    assert np.all(unknown >= known * (1 - 1e-9)), (unknown, known)
    with pytest.raises(ValueError, match="information or points"):
        bound.phase_bound(radar, None, ranges, num_basis, blocks)


def test_clutter_lag_information_is_the_gaussian_fisher_information():
    """``lag_information`` against the Fisher information of a circular Gaussian vector
    evaluated densely, ``tr(C⁻¹ ∂_p C C⁻¹ ∂_q C)`` with ``C = D C₀ Dᴴ + I``: the closed
    form (circulant g, h, k) must equal it to rounding (1e-9 relative), and a white
    spectrum carries no phase information (its phases are those of noise)."""
    from sarjax.inverse import _autofocus_bound as bound

    n, cnr = 12, 3.0
    rng = np.random.default_rng(4)
    spectrum = rng.uniform(0.1, 2.0, n)
    spectrum /= spectrum.mean()
    dft = np.fft.fft(np.eye(n)) / np.sqrt(n)
    c0 = dft.conj().T @ np.diag(cnr * spectrum) @ dft  # circulant, eigenvalues q·S
    inverse = np.linalg.inv(c0 + np.eye(n))
    derivatives = []
    for p in range(n):
        e = np.zeros((n, n))
        e[p, p] = 1.0
        derivatives.append(-1j * (e @ c0 - c0 @ e))  # ∂/∂φ_p of D C₀ Dᴴ at φ = 0
    dense = np.array([[np.trace(inverse @ a @ inverse @ b).real for b in derivatives]
                      for a in derivatives])
    closed = bound.lag_information(spectrum, cnr)
    expected = np.array([[closed[(q - p) % n] for q in range(n)] for p in range(n)])
    np.testing.assert_allclose(dense, expected, rtol=1e-9, atol=1e-9 * np.abs(dense).max())
    np.testing.assert_allclose(expected.sum(axis=1), 0.0, atol=1e-9 * np.abs(dense).max())
    np.testing.assert_allclose(bound.lag_information(np.ones(n), cnr), 0.0, atol=1e-12)
