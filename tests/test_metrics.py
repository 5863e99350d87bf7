"""Tests of sarjax.metrics against analytic point-target responses (sarjax.reference).

The test images are analytic IRFs sampled at 1.1× the Nyquist rate (spacing
``1/(1.1 B)``, as in real SAR products) with the target off the grid by fractions of
a sample, so the measurement has to interpolate; the expectations are computed
independently by sarjax.reference (root finding and quadrature on the continuous
IRF, or on a numerical Fourier transform of the weighted spectrum).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from sarjax import metrics, reference

OVERSAMPLING = 1.1
DA, DR = 0.9, 1.2  # azimuth / range sample spacing [m]
BA, BR = 1.0 / (OVERSAMPLING * DA), 1.0 / (OVERSAMPLING * DR)  # bandwidths [cycles/m]
N_AZ, N_RG = 128, 112
AZ = -40.0 + DA * np.arange(N_AZ)
RG = 5000.0 + DR * np.arange(N_RG)
I_AZ, I_RG = 64, 55  # sample next to the target

OFFSETS = [(0.0, 0.0), (0.37, -0.23), (0.5, 0.5), (-0.11, 0.29)]  # [samples]


@dataclasses.dataclass
class _Img:
    """Minimal image-like container (data, azimuth, range)."""

    data: object
    azimuth: object
    range: object


def _target(offset):
    return AZ[I_AZ] + offset[0] * DA, RG[I_RG] + offset[1] * DR


def _image(offset, weighting=None, *, fa=0.0, fr=0.0, amplitude=1.0):
    a0, r0 = _target(offset)
    data = reference.sinc_image(
        AZ, RG, azimuth0=a0, range0=r0, azimuth_bandwidth=BA, range_bandwidth=BR,
        azimuth_weighting=weighting, range_weighting=weighting,
        azimuth_centre_frequency=fa, range_centre_frequency=fr, amplitude=amplitude,
    )
    return _Img(data, AZ, RG)


@pytest.fixture(scope="module")
def expectations():
    return {
        None: reference.sinc_irf_expectation(),
        "hamming": reference.weighted_irf_expectation("hamming"),
        "taylor": reference.weighted_irf_expectation("taylor"),
    }


def _check_against(m, exp, offset):
    a0, r0 = _target(offset)
    # IRW: 0.5 % — the -3 dB crossings are linearly interpolated on a 1/16-sample grid
    # (bias ≈ 0.03 %) and the ±32-sample neighbourhood truncation is far below that.
    assert m.irw_azimuth == pytest.approx(exp.irw(BA), rel=5e-3)
    assert m.irw_range == pytest.approx(exp.irw(BR), rel=5e-3)
    # PSLR / ISLR: 0.05 dB — neighbourhood truncation (measured ≤ 0.01 dB for the sinc,
    # ≤ 0.03 dB for weighted IRFs with half_window=64) plus grid quadrature errors.
    assert m.pslr_azimuth == pytest.approx(exp.pslr_db, abs=0.05)
    assert m.pslr_range == pytest.approx(exp.pslr_db, abs=0.05)
    assert m.islr_azimuth == pytest.approx(exp.islr_db, abs=0.05)
    assert m.islr_range == pytest.approx(exp.islr_db, abs=0.05)
    # Peak position: 0.01 sample — parabolic refinement on the 1/16-sample grid (measured
    # ≤ 2e-4 sample); an unrefined grid maximum could be off by 1/32 sample.
    assert abs(m.peak_azimuth - a0) / DA < 0.01
    assert abs(m.peak_range - r0) / DR < 0.01
    # Peak amplitude 1 (0 dB): band-limited interpolation of the truncated neighbourhood
    # (measured ≤ 0.003 dB); 0.01 dB catches a wrong interpolation normalisation (e.g. a
    # missing factor or a lost half gap bin) — a value taken at the 1/16-sample grid
    # maximum instead of the refined peak is only ≤ 0.01 dB low per axis.
    assert m.peak_db == pytest.approx(0.0, abs=0.01)


# --------------------------------------------------------------------------------------
# reference.py
# --------------------------------------------------------------------------------------


def test_sinc_expectation_matches_textbook_values():
    e = reference.sinc_irf_expectation()
    # Textbook values (4 significant digits): IRW 0.8859/B, PSLR −13.26 dB,
    # ISLR −9.68 dB to infinity; nulls of sinc at ±1.
    assert e.irw_factor == pytest.approx(0.88589, abs=2e-5)
    assert e.pslr_db == pytest.approx(-13.2615, abs=1e-3)
    assert e.islr_infinite_db == pytest.approx(-9.680, abs=2e-3)
    assert e.first_null == pytest.approx(1.0, abs=1e-6)
    # ±10 IRW window: the sidelobe tail beyond W = 8.86/B holds ≈ 1/(π² W) of the
    # (unit) energy; the 1/u² average ignores an O(1/W²) oscillating term (≈ 0.01 dB).
    main = 1.0 / (1.0 + 10 ** (e.islr_infinite_db / 10))  # ∫_{-1}^{1} sinc²
    tail = 1.0 / (math.pi**2 * 10 * e.irw_factor)
    assert e.islr_db == pytest.approx(10 * math.log10((1.0 - main - tail) / main), abs=0.02)
    assert e.islr_db == pytest.approx(-10.216, abs=2e-3)


def test_range_irw_theory():
    # 0.8859 · c / (2 · 100 MHz) = 1.32792 m (5 significant digits of the factor).
    assert reference.range_irw_theory(100e6) == pytest.approx(1.32792, rel=1e-5)
    with pytest.raises(ValueError, match="bandwidth"):
        reference.range_irw_theory(0.0)


@pytest.mark.parametrize(
    "weighting", [reference.hamming_weighting(), reference.taylor_weighting(4, -35.0)]
)
def test_cosine_weighting_closed_form_matches_numerical_transform(weighting):
    u = np.linspace(-20.0, 20.0, 801)
    # Both are exact up to rounding (512-node Gauss–Legendre of a smooth integrand).
    np.testing.assert_allclose(
        reference.numerical_irf(weighting)(u).real, weighting.irf(u), atol=1e-12
    )
    np.testing.assert_allclose(reference.numerical_irf(weighting)(u).imag, 0.0, atol=1e-12)


def test_taylor_weighting_matches_scipy():
    windows = pytest.importorskip("scipy.signal.windows")
    n = 257
    nu = (np.arange(n) - (n - 1) / 2) / n
    # Same formula, rounding-level agreement expected.
    np.testing.assert_allclose(
        reference.taylor_weighting(5, -30.0)(nu), windows.taylor(n, 5, 30, norm=False),
        atol=1e-12,
    )


def test_weighted_expectations(expectations):
    h = expectations["hamming"]
    # Hamming: PSLR −42.7 dB, IRW 1.30/B, first null at 2/B (textbook, 3 digits).
    assert h.pslr_db == pytest.approx(-42.68, abs=0.02)
    assert h.irw_factor == pytest.approx(1.303, abs=1e-3)
    assert h.first_null == pytest.approx(2.0, abs=1e-6)
    assert h.islr_db < h.islr_infinite_db < -30.0
    t = expectations["taylor"]
    # Taylor n̄=4, −35 dB design: the realised PSLR is within ~0.2 dB of the design, the
    # IRW between sinc and Hamming.
    assert t.pslr_db == pytest.approx(-35.0, abs=0.3)
    assert 0.886 < t.irw_factor < 1.303


# --------------------------------------------------------------------------------------
# point_target_metrics
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("offset", OFFSETS)
def test_sinc_metrics_match_analytic(offset, expectations):
    a0, r0 = _target(offset)
    # Start the search a few samples away from the target: the search box must find it.
    m = metrics.point_target_metrics(_image(offset), azimuth=a0 + 2.5 * DA, range=r0 - 3 * DR)
    _check_against(m, expectations[None], offset)


@pytest.mark.parametrize("offset", OFFSETS[1:3])
@pytest.mark.parametrize("weighting", ["hamming", "taylor"])
def test_weighted_metrics_match_analytic(weighting, offset, expectations):
    a0, r0 = _target(offset)
    # Low sidelobes need a larger neighbourhood (see the point_target_metrics docstring).
    m = metrics.point_target_metrics(
        _image(offset, weighting), azimuth=a0, range=r0, half_window=64
    )
    _check_against(m, expectations[weighting], offset)


@pytest.mark.parametrize("offset", OFFSETS[:2])
def test_doppler_shifted_spectrum_gives_same_metrics(offset, expectations):
    a0, r0 = _target(offset)
    base = _image(offset)
    x = AZ[:, None] / DA
    # Spectrum centred at +0.3 cycles/sample in azimuth (wraps around Nyquist) and at
    # −0.41 cycles/sample in range: zeros inserted at Nyquist would alias both.
    shift = np.exp(2j * np.pi * 0.3 * x) * np.exp(-2j * np.pi * 0.41 * RG[None, :] / DR)
    shifted = _Img(base.data * shift, AZ, RG)
    m0 = metrics.point_target_metrics(base, azimuth=a0, range=r0)
    m1 = metrics.point_target_metrics(shifted, azimuth=a0, range=r0)
    _check_against(m1, expectations[None], offset)
    # Against the unshifted measurement: only the truncation leakage changes (measured
    # ≤ 2e-3 dB, ≤ 5e-5 relative IRW).
    assert m1.irw_azimuth == pytest.approx(m0.irw_azimuth, rel=5e-4)
    assert m1.irw_range == pytest.approx(m0.irw_range, rel=5e-4)
    assert m1.pslr_azimuth == pytest.approx(m0.pslr_azimuth, abs=0.01)
    assert m1.islr_range == pytest.approx(m0.islr_range, abs=0.01)
    # The complex peak value carries the modulation phase at the true peak position:
    # checks that the interpolant has the right band (not just the right modulus).
    expected = np.exp(2j * np.pi * (0.3 * a0 / DA - 0.41 * r0 / DR))
    assert abs(m1.peak_value - expected) < 2e-3  # truncation error of the interpolant


def test_upsample_fft_gap_position():
    a0 = AZ[I_AZ] + 0.37 * DA
    fa = 0.3 / DA  # 0.3 cycles/sample
    x = reference.sinc_image(
        AZ, RG[:1], azimuth0=a0, range0=RG[0], azimuth_bandwidth=BA, range_bandwidth=BR,
        azimuth_centre_frequency=fa,
    )[:, 0]
    factor = 8
    t = AZ[0] + DA * np.arange(N_AZ * factor) / factor
    exact = reference.sinc_image(
        t, RG[:1], azimuth0=a0, range0=RG[0], azimuth_bandwidth=BA, range_bandwidth=BR,
        azimuth_centre_frequency=fa,
    )[:, 0]
    centre = slice(40 * factor, 90 * factor)  # away from the truncated ends
    good = metrics.upsample_fft(x, factor)
    nyquist = metrics.upsample_fft(x, factor, gap=N_AZ // 2)
    # Input samples reproduced exactly; least-energy gap interpolates to truncation level
    # (measured 1e-4); the Nyquist gap cuts the shifted band and errs by O(0.5).
    np.testing.assert_allclose(good[::factor], x, atol=1e-12)
    assert np.max(np.abs(good[centre] - exact[centre])) < 2e-3
    assert np.max(np.abs(nyquist[centre] - exact[centre])) > 0.1
    # The least-energy bin sits in the spectral gap, half a band away from the centre.
    gap = metrics.least_energy_bin(np.fft.fft(x))
    assert abs(((gap / N_AZ - 0.3 - 0.5) + 0.5) % 1.0 - 0.5) < 0.05


def test_accepts_jax_arrays_and_sarjax_image(expectations):
    import jax.numpy as jnp

    import sarjax

    offset = OFFSETS[1]
    a0, r0 = _target(offset)
    img = _image(offset)
    m_np = metrics.point_target_metrics(img, azimuth=a0, range=r0)
    jimg = sarjax.Image(data=jnp.asarray(img.data), azimuth=jnp.asarray(AZ), range=jnp.asarray(RG))
    m_jx = metrics.point_target_metrics(jimg, azimuth=a0, range=r0)
    # Same numbers up to the dtype of the JAX array (complex64 without x64: ~1e-6).
    assert m_jx.irw_azimuth == pytest.approx(m_np.irw_azimuth, rel=1e-5)
    assert m_jx.pslr_range == pytest.approx(m_np.pslr_range, abs=1e-4)
    assert m_jx.peak_range == pytest.approx(m_np.peak_range, abs=1e-5 * DR)


def test_search_box_selects_the_requested_target():
    a0, r0 = _target(OFFSETS[1])
    # A 3× brighter target 40 samples away in azimuth, outside the ±8-sample search box.
    other = reference.sinc_image(
        AZ, RG, azimuth0=a0 - 40 * DA, range0=r0, azimuth_bandwidth=BA, range_bandwidth=BR,
        amplitude=3.0,
    )
    img = _Img(_image(OFFSETS[1]).data + other, AZ, RG)
    m = metrics.point_target_metrics(img, azimuth=a0 + 4 * DA, range=r0)
    # The other target's sinc tail (≈ 3/(π·44) ≈ 0.02) perturbs the peak slightly.
    assert abs(m.peak_azimuth - a0) < 0.05 * DA
    m2 = metrics.point_target_metrics(img, azimuth=a0 - 38 * DA, range=r0)
    assert abs(m2.peak_azimuth - (a0 - 40 * DA)) < 0.05 * DA
    assert m2.peak_db == pytest.approx(20 * math.log10(3.0), abs=0.2)


def test_result_formatting():
    a0, r0 = _target(OFFSETS[0])
    m = metrics.point_target_metrics(_image(OFFSETS[0]), azimuth=a0, range=r0)
    assert len(m.as_row().split()) == 9
    assert len(m.header()) == len(m.as_row())
    assert "PSLR" in str(m) and "ISLR" in str(m)
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.irw_range = 0.0  # type: ignore[misc]


def _bad_cases():
    a0, r0 = _target(OFFSETS[1])
    good = _image(OFFSETS[1])
    nan = good.data.copy()
    nan[I_AZ + 1, I_RG] = np.nan
    bent = AZ.copy()
    bent[5] += 0.1 * DA
    ptm = metrics.point_target_metrics
    return {
        "azimuth outside": (lambda: ptm(good, azimuth=AZ[-1] + 2 * DA, range=r0), "azimuth="),
        "range outside": (lambda: ptm(good, azimuth=a0, range=RG[0] - 5.0), "range="),
        "nan target": (lambda: ptm(good, azimuth=float("nan"), range=r0), "azimuth"),
        "nan data": (lambda: ptm(_Img(nan, AZ, RG), azimuth=a0, range=r0), "non-finite"),
        "upsample 0": (lambda: ptm(good, azimuth=a0, range=r0, upsample=0), "upsample"),
        "upsample 1.5": (lambda: ptm(good, azimuth=a0, range=r0, upsample=1.5), "upsample"),
        "half_window 2": (lambda: ptm(good, azimuth=a0, range=r0, half_window=2), "half_window"),
        "sidelobe_cells 0": (
            lambda: ptm(good, azimuth=a0, range=r0, sidelobe_cells=0.0), "sidelobe_cells"
        ),
        "window too large": (
            lambda: ptm(good, azimuth=a0, range=r0, sidelobe_cells=40.0), "half_window"
        ),
        "window inside lobe": (
            lambda: ptm(good, azimuth=a0, range=r0, sidelobe_cells=1.0), "first nulls"
        ),
        "search -1": (lambda: ptm(good, azimuth=a0, range=r0, search=-1), "search"),
        "non-uniform axis": (lambda: ptm(_Img(good.data, bent, RG), azimuth=a0, range=r0),
                             "uniformly"),
        "axis length": (lambda: ptm(_Img(good.data, AZ[:-1], RG), azimuth=a0, range=r0),
                        "azimuth"),
        "1-D data": (lambda: ptm(_Img(good.data[0], AZ, RG), azimuth=a0, range=r0), "2-D"),
        "zero image": (lambda: ptm(_Img(0 * good.data, AZ, RG), azimuth=a0, range=r0),
                       "no signal"),
    }


@pytest.mark.parametrize("case", list(_bad_cases()))
def test_invalid_inputs_raise(case):
    call, match = _bad_cases()[case]
    with pytest.raises(ValueError, match=match):
        call()


def test_missing_attributes_raise_type_error():
    with pytest.raises(TypeError, match="azimuth"):
        metrics.point_target_metrics(np.ones((8, 8)), azimuth=0.0, range=0.0)


# --------------------------------------------------------------------------------------
# Image comparisons
# --------------------------------------------------------------------------------------


def test_nmse_db():
    b = _image(OFFSETS[1]).data
    # A uniform 1 % relative error is exactly −40 dB.
    assert metrics.nmse_db(b * 1.01, b) == pytest.approx(-40.0, abs=1e-9)
    assert metrics.nmse_db(_Img(b * 1.01, AZ, RG), _Img(b, AZ, RG)) == pytest.approx(-40.0)
    assert metrics.nmse_db(b, b) == -math.inf
    with pytest.raises(ValueError, match="shape"):
        metrics.nmse_db(b[:-1], b)
    with pytest.raises(ValueError, match="zero energy"):
        metrics.nmse_db(b, 0 * b)
    with pytest.raises(ValueError, match="non-finite"):
        metrics.nmse_db(b * np.nan, b)


def test_nmse_db_near():
    a0, r0 = _target(OFFSETS[1])
    ref = _image(OFFSETS[1])
    test = ref.data * 1.001  # −60 dB everywhere
    test[I_AZ + 30, :] += 1.0  # large error 30 rows away: outside a ±16-sample box
    near = metrics.nmse_db_near(_Img(test, AZ, RG), ref, azimuth=a0, range=r0, cells=16)
    assert near == pytest.approx(-60.0, abs=1e-6)
    assert metrics.nmse_db(test, ref.data) > -20.0
    wide = metrics.nmse_db_near(_Img(test, AZ, RG), ref, azimuth=a0, range=r0, cells=31)
    assert wide > -20.0  # the box now includes the bad row
    with pytest.raises(ValueError, match="range="):
        metrics.nmse_db_near(ref, ref, azimuth=a0, range=RG[-1] + 10.0)
    with pytest.raises(ValueError, match="axis"):
        metrics.nmse_db_near(_Img(ref.data, AZ + DA, RG), ref, azimuth=a0, range=r0)


def test_phase_error_rms():
    b = _image(OFFSETS[1]).data
    assert metrics.phase_error_rms(b * np.exp(0.1j), b) == pytest.approx(0.1, abs=1e-12)
    # Wrapped: a −(2π − 0.1) rotation is a 0.1 rad error.
    assert metrics.phase_error_rms(b * np.exp(-1j * (2 * np.pi - 0.1)), b) == pytest.approx(0.1)
    # Errors on samples more than 20 dB below the peak are ignored...
    mag = np.abs(b)
    weak = mag < 0.1 * mag.max()
    bad = np.where(weak, b * 1j, b * np.exp(0.05j))
    assert metrics.phase_error_rms(bad, b, within_db=20.0) == pytest.approx(0.05, abs=1e-12)
    # ... and counted with a larger dynamic range.
    assert metrics.phase_error_rms(bad, b, within_db=60.0) > 0.5
    with pytest.raises(ValueError, match="within_db"):
        metrics.phase_error_rms(b, b, within_db=-1.0)
    with pytest.raises(ValueError, match="zero"):
        metrics.phase_error_rms(b, 0 * b)
