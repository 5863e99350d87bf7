"""The bad-input catalogue: bad input raises ValueError naming the offending field or
value (Python API, ``sarjax`` command line, file loading); valid edge cases give finite
data; strict mode refuses input outside a model's validity; the command line answers bad
input with one line on stderr and a non-zero status, never a traceback."""

from __future__ import annotations

import re

import jax.numpy as jnp
import numpy as np
import pytest

import sarjax as sj

try:
    from _reruns import assert_same_to_rounding
except ImportError:
    from tests._reruns import assert_same_to_rounding

NUM_PULSES = 48
NUM_RANGE = 160
NEAR_RANGE = 4900.0
RADAR_OVERRIDES = dict(
    carrier_frequency=9.65e9,
    bandwidth=40e6,
    chirp_duration=1e-6,
    sampling_rate=50e6,
    prf=16.0,
    velocity=100.0,
    height=3000.0,
    antenna_length=1.0,
)


def _radar(**overrides):
    return sj.presets.airborne_xband(**{**RADAR_OVERRIDES, **overrides})


def _scene(**fields):
    defaults = dict(azimuth=[-20.0, 30.0], range=[5100.0, 5200.0],
                    reflectivity=[1.0, 0.5 - 0.5j], height=[0.0, 10.0])
    return sj.PointTargets(**{**defaults, **fields})


def _simulate(radar=None, scene=None, motion=None, **kwargs):
    kwargs = {"num_pulses": NUM_PULSES, "num_range": NUM_RANGE, "near_range": NEAR_RANGE,
              **kwargs}
    return sj.simulate(_radar() if radar is None else radar,
                       _scene() if scene is None else scene, motion, **kwargs)


def _assert_finite(raw, expect_signal=True):
    data = np.asarray(raw.data)
    assert data.shape == (NUM_PULSES, NUM_RANGE)
    assert np.all(np.isfinite(data))
    assert np.all(np.isfinite(np.asarray(raw.azimuth)))
    assert np.all(np.isfinite(np.asarray(raw.range)))
    if expect_signal:
        assert np.max(np.abs(data)) > 0.1


# ---- motion ------------------------------------------------------------------------


@pytest.mark.parametrize("field", ["horizontal", "vertical", "pointing"])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_motion(field, bad):
    values = np.zeros(NUM_PULSES)
    values[5] = bad
    expected = rf"motion\.{field} has non-finite values .* at pulses \[5\]"
    with pytest.raises(ValueError, match=expected):
        _simulate(motion=sj.Motion(**{field: values}))


@pytest.mark.parametrize("field", ["horizontal", "vertical", "pointing"])
@pytest.mark.parametrize("length", [NUM_PULSES - 1, NUM_PULSES + 1, 1])
def test_motion_length_mismatch(field, length):
    motion = sj.Motion(**{field: np.zeros(length)})
    expected = re.escape(f"motion.{field} has shape ({length},), expected ({NUM_PULSES},)")
    with pytest.raises(ValueError, match=expected):
        _simulate(motion=motion)


def test_motion_lengths_differ_between_components():
    motion = sj.Motion(horizontal=np.zeros(NUM_PULSES), vertical=np.zeros(NUM_PULSES - 2))
    with pytest.raises(ValueError, match=r"motion\.vertical has shape \(46,\)"):
        _simulate(motion=motion)


@pytest.mark.parametrize("field", ["horizontal", "vertical", "pointing"])
@pytest.mark.parametrize("shape", [(NUM_PULSES, 1), (2, 3, NUM_PULSES), (2, NUM_PULSES // 2),
                                   ()])
def test_motion_not_one_dimensional(field, shape):
    motion = sj.Motion(**{field: np.zeros(shape)})
    expected = re.escape(f"motion.{field} has shape {shape}, expected ({NUM_PULSES},)")
    with pytest.raises(ValueError, match=expected):
        _simulate(motion=motion)


# ---- radar -------------------------------------------------------------------------


@pytest.mark.parametrize("prf", [0.0, -16.0])
def test_prf_not_positive(prf):
    with pytest.raises(ValueError, match=rf"radar\.prf={prf}.* must be > 0"):
        _simulate(_radar(prf=prf))


@pytest.mark.parametrize("prf", [np.nan, np.inf])
def test_prf_not_finite(prf):
    with pytest.raises(ValueError, match=rf"radar\.prf={prf} is not finite"):
        _simulate(_radar(prf=prf))


@pytest.mark.parametrize("bandwidth", [0.0, -40e6])
def test_bandwidth_not_positive(bandwidth):
    with pytest.raises(ValueError, match=r"radar\.bandwidth=.* must be > 0"):
        _simulate(_radar(bandwidth=bandwidth))


@pytest.mark.parametrize(
    "field",
    ["carrier_frequency", "chirp_duration", "sampling_rate", "velocity", "height",
     "antenna_length", "reference_range", "near_range"],
)
def test_other_radar_fields_not_positive(field):
    with pytest.raises(ValueError, match=rf"radar\.{field}=.* must be > 0"):
        _simulate(_radar(**{field: 0.0}))
    with pytest.raises(ValueError, match=rf"radar\.{field}=nan is not finite"):
        _simulate(_radar(**{field: np.nan}))


def test_squint_not_finite():
    with pytest.raises(ValueError, match=r"radar\.squint=nan is not finite"):
        _simulate(_radar(squint=np.nan))


def test_sampling_rate_below_bandwidth():
    radar = _radar(sampling_rate=30e6, bandwidth=40e6)
    with pytest.raises(ValueError, match=r"radar\.sampling_rate=3e\+07 Hz is below "
                                         r"radar\.bandwidth=4e\+07 Hz"):
        _simulate(radar)


def test_sampling_rate_equal_to_bandwidth_is_valid():
    _assert_finite(_simulate(_radar(sampling_rate=40e6, bandwidth=40e6)))


@pytest.mark.parametrize(
    "preset", [sj.presets.airborne_xband, sj.presets.spaceborne_cband, sj.presets.highspeed_xband]
)
def test_unknown_preset_override(preset):
    with pytest.raises(ValueError, match=r"unknown radar parameter\(s\) \['frequency'\]"):
        preset(frequency=9.65e9)
    with pytest.raises(ValueError, match=r"\['bogus', 'wavelength'\]"):
        preset(wavelength=0.03, bogus=1, prf=100.0)
    with pytest.raises(ValueError, match=r"prf='fast' is not a number"):
        preset(prf="fast")


# ---- scene -------------------------------------------------------------------------


def test_empty_scene():
    scene = sj.PointTargets(azimuth=[], range=[])
    assert scene.num_scatterers == 0
    with pytest.raises(ValueError, match=r"scene is empty \(0 scatterers\)"):
        _simulate(scene=scene)


@pytest.mark.parametrize("field", ["azimuth", "range", "reflectivity", "height"])
@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_scene(field, bad):
    values = {"azimuth": [-20.0, 30.0], "range": [5100.0, 5200.0],
              "reflectivity": [1.0, 0.5 - 0.5j], "height": [0.0, 10.0]}[field]
    values = list(values)
    values[1] = bad
    expected = rf"scene\.{field} has non-finite values .* at indices \[1\]"
    with pytest.raises(ValueError, match=expected):
        _simulate(scene=_scene(**{field: values}))


def test_complex_nan_reflectivity():
    with pytest.raises(ValueError, match=r"scene\.reflectivity has non-finite values"):
        _simulate(scene=_scene(reflectivity=[1.0, complex(0.0, np.nan)]))


@pytest.mark.parametrize(
    "rng, height",
    [
        (2900.0, 0.0),  # below the platform height H = 3000 m
        (3000.0, 0.0),  # exactly at nadir: no ground position
        (2700.0, 250.0),  # H − h = 2750 m
        (-5100.0, 0.0),
    ],
)
def test_scene_range_not_beyond_platform_height(rng, height):
    scene = _scene(range=[5100.0, rng], height=[0.0, height])
    with pytest.raises(ValueError, match=rf"scene\.range=\[{rng:.0f}\.\] m is not beyond the "
                                         r"platform height"):
        _simulate(scene=scene)


def test_scene_range_beyond_terrain_adjusted_height_is_valid():
    # r = 2800 m < H = 3000 m but > H − h = 2750 m for a hill of h = 250 m
    scene = _scene(range=[2800.0, 5100.0], height=[250.0, 0.0])
    _assert_finite(_simulate(scene=scene), expect_signal=False)


@pytest.mark.parametrize(
    "fields, name",
    [
        (dict(azimuth=[0.0, 1.0], range=[5100.0]), "range"),
        (dict(azimuth=[0.0, 1.0], range=[5100.0, 5110.0], reflectivity=[1.0, 2.0, 3.0]),
         "reflectivity"),
        (dict(azimuth=[0.0, 1.0], range=[5100.0, 5110.0], height=[0.0]), "height"),
        (dict(azimuth=[0.0], range=[5100.0], velocity_range=[0.0, 1.0]), "velocity_range"),
    ],
)
def test_point_targets_mismatched_lengths(fields, name):
    with pytest.raises(ValueError, match=rf"PointTargets\.{name} has shape"):
        sj.PointTargets(**fields)


def test_point_targets_two_dimensional():
    with pytest.raises(ValueError, match=r"PointTargets\.\w+ has shape|must be 1-D"):
        sj.PointTargets(azimuth=[[0.0, 1.0]], range=[[5100.0, 5110.0]],
                        reflectivity=[[1.0, 1.0]], height=[[0.0, 0.0]],
                        velocity_range=[[0.0, 0.0]], velocity_azimuth=[[0.0, 0.0]])


def test_scene_of_wrong_type():
    with pytest.raises(ValueError, match=r"scene=dict is not PointTargets"):
        _simulate(scene={"azimuth": [0.0], "range": [5100.0]})


# ---- call arguments ----------------------------------------------------------------


@pytest.mark.parametrize("method", ["omega_k", "TimeDomain", "", None, 3])
def test_unknown_method(method):
    with pytest.raises(ValueError, match=re.escape(f"unknown method={method!r}")):
        _simulate(method=method)


def test_options_with_simulator_instance():
    with pytest.raises(ValueError, match=r"options \['pulse_chunk'\] given with a simulator"):
        _simulate(method=sj.TimeDomain(), pulse_chunk=4)


@pytest.mark.parametrize("dtype", [jnp.float32, jnp.float64, jnp.int32, np.float16])
def test_wrong_dtype(dtype):
    name = jnp.dtype(dtype).name
    with pytest.raises(ValueError, match=rf"dtype={name} must be complex64 or complex128"):
        _simulate(dtype=dtype)


@pytest.mark.parametrize("field", ["num_pulses", "num_range"])
@pytest.mark.parametrize("value", [0, -3, 4.0, 2.5])
def test_grid_size_not_positive_integer(field, value):
    expected = re.escape(f"{field}={value!r} must be a positive integer")
    with pytest.raises(ValueError, match=expected):
        _simulate(**{field: value})


@pytest.mark.parametrize("near_range", [0.0, -100.0, np.nan])
def test_near_range_invalid(near_range):
    with pytest.raises(ValueError, match=r"acquisition\.near_range="):
        _simulate(near_range=near_range)


def test_azimuth_center_not_finite():
    try:
        raw = _simulate(azimuth_center=np.nan)
    except ValueError as err:
        assert "azimuth_center" in str(err)
    else:
        raise AssertionError(f"no ValueError; NaN in data: {bool(np.isnan(raw.data).any())}")


@pytest.mark.parametrize("field", ["carrier_frequency", "sampling_rate"])
def test_radar_field_not_scalar(field):
    value = {"carrier_frequency": [9.6e9, 9.7e9], "sampling_rate": [50e6, 60e6]}[field]
    try:
        _simulate(_radar(**{field: value}))
    except ValueError as err:
        assert f"radar.{field}" in str(err), str(err)
    else:
        raise AssertionError(f"radar.{field} of shape (2,) accepted")


# ---- valid edge cases: no NaN ------------------------------------------------------


def _pulse_azimuths(radar):
    return (np.arange(NUM_PULSES) - (NUM_PULSES - 1) / 2) * float(radar.azimuth_spacing)


@pytest.mark.parametrize("dtype", [jnp.complex128, jnp.complex64])
def test_target_exactly_at_a_pulse_position(dtype):
    """x' − x = 0 at one pulse (u = 0: sinc² at its removable singularity)."""
    radar = _radar()
    x_pulse = _pulse_azimuths(radar)[NUM_PULSES // 2]
    scene = _scene(azimuth=[x_pulse, 0.0], range=[5140.0, 5140.0], height=[0.0, 0.0])
    raw = _simulate(radar, scene, dtype=dtype)
    _assert_finite(raw)
    # with an ideal track the peak of that pulse is |γ| W²(0) = 1 (plus the other target)
    assert np.max(np.abs(np.asarray(raw.data)[NUM_PULSES // 2])) > 0.9


def test_target_at_pulse_position_with_zero_but_given_motion():
    radar = _radar()
    x_pulse = _pulse_azimuths(radar)[0]
    scene = _scene(azimuth=[x_pulse], range=[5140.0], reflectivity=[1.0], height=[0.0])
    zero = np.zeros(NUM_PULSES)
    raw = _simulate(radar, scene, sj.Motion(horizontal=zero, vertical=zero, pointing=zero))
    _assert_finite(raw)


@pytest.mark.parametrize("edge", ["near", "far", "beyond_near", "beyond_far"])
def test_target_at_swath_edge(edge):
    """Targets at (and half a chirp beyond) the first and last range samples."""
    radar = _radar()
    spacing = float(radar.range_spacing)
    half = float(radar.pulse_half_length)
    far = NEAR_RANGE + (NUM_RANGE - 1) * spacing
    rng = {"near": NEAR_RANGE, "far": far, "beyond_near": NEAR_RANGE - half + 1.0,
           "beyond_far": far + half - 1.0}[edge]
    scene = _scene(azimuth=[0.0], range=[rng], reflectivity=[1.0], height=[0.0])
    x = _pulse_azimuths(radar)
    motion = sj.Motion(horizontal=0.02 * np.sin(x / 40), vertical=0.01 * np.cos(x / 25),
                       pointing=np.asarray(sj.seed_pointing_jitter(radar, x)))
    raw = _simulate(radar, scene, motion)
    _assert_finite(raw)


def test_target_far_outside_window_gives_zeros():
    scene = _scene(azimuth=[0.0], range=[9000.0], reflectivity=[1.0], height=[0.0])
    with pytest.warns(sj.SwathWarning, match=r"no scatterer's echo reaches the range window "
                                             r"r' = 4900 … 5376\.67 m \(scene\.range = \[9000\.\]"):
        raw = _simulate(scene=scene)
    _assert_finite(raw, expect_signal=False)
    assert np.all(np.asarray(raw.data) == 0)


def test_target_just_beyond_nadir():
    """r barely above H − h: ground range ≈ 0 (a square root of a tiny number)."""
    scene = _scene(azimuth=[0.0, 0.0], range=[3000.0 + 1e-6, 5100.0], height=[0.0, 0.0])
    x = _pulse_azimuths(_radar())
    raw = _simulate(scene=scene, motion=sj.Motion(horizontal=0.01 * np.sin(x / 40)))
    _assert_finite(raw)


def test_reflectivity_grid_scene():
    grid = sj.ReflectivityGrid(
        reflectivity=np.ones((3, 4)) * (1 - 1j),
        azimuth=[-10.0, 0.0, 10.0],
        range=[5100.0, 5110.0, 5120.0, 5130.0],
    )
    _assert_finite(_simulate(scene=grid))


def test_unknown_simulator_option():
    with pytest.raises(ValueError, match="unknown option"):
        _simulate(not_an_option=1)


def test_unsupported_squint_and_moving_targets_are_refused():
    # chirp_scaling implements no squint, fourier_2d no moving targets (time_domain both)
    with pytest.raises(ValueError, match="squint"):
        _simulate(_radar(squint=0.1), method="chirp_scaling")
    scene = sj.PointTargets(azimuth=[0.0], range=[5140.0], velocity_range=[1.0])
    with pytest.raises(ValueError, match="velocit"):
        _simulate(scene=scene, method="fourier_2d")


# ---- wrong dtypes ------------------------------------------------------------------


@pytest.mark.parametrize("field, value, expected", [
    ("azimuth", [1j, 0.0], r"PointTargets\.azimuth must be real, got complex"),
    ("azimuth", np.array([0.0, 1.0]) + 0j, r"PointTargets\.azimuth must be real"),
    ("range", ["far", "farther"], r"PointTargets\.range must be real numbers"),
    ("height", [None, 0.0], r"PointTargets\.height must be real numbers"),
    ("reflectivity", ["bright", 1.0], r"PointTargets\.reflectivity must be complex numbers"),
])
def test_point_targets_wrong_dtype(field, value, expected):
    """Complex positions are refused, never silently truncated to their real part."""
    with pytest.raises(ValueError, match=expected):
        _scene(**{field: value})


def test_reflectivity_grid_wrong_dtype():
    with pytest.raises(ValueError, match=r"ReflectivityGrid\.range must be real"):
        sj.ReflectivityGrid(np.ones((2, 2)), [0.0, 1.0], [5100.0 + 1j, 5101.0])


def test_motion_complex_is_refused():
    with pytest.raises(ValueError, match=r"motion arrays must be real, got dtype complex"):
        sj.Motion(horizontal=np.zeros(NUM_PULSES) * 1j)


@pytest.mark.parametrize("radar", [None, "airborne", {"prf": 16.0}])
def test_radar_of_wrong_type(radar):
    with pytest.raises(ValueError, match=rf"radar={type(radar).__name__} is not a sarjax\.Radar"):
        sj.simulate(radar, _scene(), num_pulses=NUM_PULSES, num_range=NUM_RANGE)


# ---- targets outside the swath; strict mode ----------------------------------------

# a radar whose PRF samples the Doppler band: the strict aliasing check stays quiet
WELL_SAMPLED = dict(prf=400.0)


def test_doppler_band_full_aperture_and_short_window():
    """2v/L once the window holds the beam's half-width; 2vA/(λr) for a shorter one."""
    radar = sj.presets.airborne_xband()  # v = 100 m/s, L = 1 m, λ = 3.1 cm
    scene = sj.PointTargets(azimuth=[0.0], range=[5140.0])
    long = sj.Acquisition(num_pulses=1024, num_range=8, near_range=5000.0, azimuth_center=0.0)
    assert sj._validate.doppler_band(radar, scene, long) == pytest.approx(200.0, rel=1e-3)
    short = sj.Acquisition(num_pulses=64, num_range=8, near_range=5000.0, azimuth_center=0.0)
    span = 63 * float(radar.azimuth_spacing)  # 15.75 m < the half-width λr/(2L) = 80 m
    expected = 2 * 100.0 * span / (float(radar.wavelength) * 5140.0)
    assert sj._validate.doppler_band(radar, scene, short) == pytest.approx(expected, rel=1e-4)
    # a target beyond the window's end by more than the half-width: no visible pulse
    far = sj.PointTargets(azimuth=[500.0], range=[5140.0])
    assert sj._validate.doppler_band(radar, far, short) == 0.0


@pytest.mark.parametrize("method", ["fourier_2d", "small_deviation", "moderate_deviation",
                                    "high_speed", "chirp_scaling"])
def test_strict_refuses_aliased_azimuth_sampling_for_fourier_methods(method):
    """PRF = 16 Hz ≪ 2v/L = 200 Hz: the echo spans 25 Doppler bands; the Fourier-domain
    synthesis holds at most 2 × 4 + 1 of them, so the folded energy it misses is named."""
    with pytest.raises(ValueError, match=r"strict=True: method='.*' is outside its "
                                         r"validity: azimuth_aliases="):
        _simulate(method=method, strict=True)


def test_strict_accepts_aliased_sampling_for_the_exact_model():
    """The exact model samples the echo at the pulses: its aliased record is right."""
    strict = _simulate(strict=True)
    np.testing.assert_array_equal(np.asarray(strict.data), np.asarray(_simulate().data))


def test_strict_refuses_targets_outside_the_swath():
    scene = _scene(range=[5100.0, 9000.0])
    with pytest.raises(ValueError, match=r"strict=True: 1 of 2 scatterers' echoes miss the "
                                         r"range window r' = 4900 … 5376\.67 m "
                                         r"\(scene\.range = \[9000\.\]"):
        _simulate(scene=scene, strict=True)
    _assert_finite(_simulate(scene=scene))  # without strict: simulated, no warning
    with pytest.raises(ValueError, match=r"no scatterer's echo reaches the range window"):
        _simulate(scene=_scene(range=[9000.0, 9100.0]), strict=True)


def test_swath_check_counts_the_echo_extent():
    """Half a pulse (cτ/4 = 75 m) beyond the window's ends still reaches it; a grid scene
    is checked cell by cell."""
    radar = _radar()
    far = NEAR_RANGE + (NUM_RANGE - 1) * float(radar.range_spacing)
    inside = _scene(range=[NEAR_RANGE - 70.0, far + 70.0])
    _assert_finite(_simulate(scene=inside, strict=True))
    grid = sj.ReflectivityGrid(np.ones((2, 2)), [0.0, 5.0], [5100.0, far + 200.0])
    with pytest.raises(ValueError, match=r"2 of 4 scatterers' echoes miss"):
        _simulate(scene=grid, strict=True)


def _deviating(radar, amplitude):
    x = _pulse_azimuths(radar)
    return sj.Motion(horizontal=amplitude * np.sin(2 * np.pi * x / 7.0),
                     vertical=0.5 * amplitude * np.cos(2 * np.pi * x / 5.0))


@pytest.mark.parametrize("method, amplitude, budget", [
    ("fourier_2d", 0.01, "epsilon_motion"),
    ("small_deviation", 0.5, "epsilon_1[123]"),
    ("moderate_deviation", 3.0, "epsilon_1[12]"),
])
def test_strict_refuses_approximations_outside_their_validity(method, amplitude, budget):
    radar = _radar(**WELL_SAMPLED)
    motion = _deviating(radar, amplitude)
    report = sj.validity(radar, _scene(), motion, method=method, num_pulses=NUM_PULSES)
    assert not report.valid, str(report)
    with pytest.raises(ValueError, match=rf"strict=True: method='{method}' is outside its "
                                         rf"validity: {budget}=[\d.e+-]+ > 0\.1"):
        _simulate(radar, motion=motion, method=method, strict=True)


def test_strict_runs_approximations_within_their_validity_unchanged():
    radar = _radar(**WELL_SAMPLED)
    assert sj.validity(radar, _scene(), method="fourier_2d", num_pulses=NUM_PULSES).valid
    strict = _simulate(radar, method="fourier_2d", strict=True)
    plain = _simulate(radar, method="fourier_2d")
    # same program and inputs: equal to the FFT's run-to-run rounding (tests/_reruns.py)
    assert_same_to_rounding(strict.data, plain.data)
    _assert_finite(strict)


@pytest.mark.parametrize("strict", ["yes", 1, None])
def test_strict_must_be_a_bool(strict):
    with pytest.raises(ValueError, match=re.escape(f"strict={strict!r} must be True or False")):
        _simulate(strict=strict)


# ---- focus -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def raw():
    return _simulate()


def _with_data(raw, data):
    return sj.RawData(data=data, azimuth=raw.azimuth, range=raw.range, method=raw.method)


@pytest.mark.parametrize("method", ["omega_k", "backprojection", "exact_backprojection"])
@pytest.mark.parametrize("bad", [np.nan, np.inf, complex(0, np.nan)])
def test_focus_non_finite_raw_data(raw, method, bad):
    data = np.array(raw.data)
    data[7, 11] = bad
    with pytest.raises(ValueError, match=r"raw\.data has non-finite samples at "
                                         r"\(pulse, sample\) \[\(7, 11\)\]"):
        sj.focus(_radar(), _with_data(raw, data), method=method)


@pytest.mark.parametrize("field, value, expected", [
    ("prf", 0.0, r"radar\.prf=0\.0 must be > 0"),
    ("bandwidth", np.nan, r"radar\.bandwidth=nan is not finite"),
    ("velocity", -100.0, r"radar\.velocity=-100\.0 must be > 0"),
    ("chirp_duration", np.inf, r"radar\.chirp_duration=inf is not finite"),
    ("sampling_rate", 30e6, r"radar\.sampling_rate=3e\+07 Hz is below radar\.bandwidth"),
])
def test_focus_bad_radar(raw, field, value, expected):
    with pytest.raises(ValueError, match=expected):
        sj.focus(_radar(**{field: value}), raw)


@pytest.mark.parametrize("method", ["omega_k", "backprojection"])
@pytest.mark.parametrize("field", ["horizontal", "vertical", "pointing"])
def test_focus_non_finite_or_short_motion(raw, method, field):
    values = np.zeros(NUM_PULSES)
    values[3] = np.nan
    with pytest.raises(ValueError, match=rf"motion\.{field} has non-finite values \[nan\] "
                                         r"at pulses \[3\]"):
        sj.focus(_radar(), raw, method=method, motion=sj.Motion(**{field: values}))
    with pytest.raises(ValueError, match=rf"motion\.{field} has shape \(47,\), expected "
                                         rf"\({NUM_PULSES},\)"):
        sj.focus(_radar(), raw, method=method,
                 motion=sj.Motion(**{field: np.zeros(NUM_PULSES - 1)}))


def test_focus_axes_must_match_the_data(raw):
    short = sj.RawData(data=raw.data, azimuth=raw.azimuth[:-1], range=raw.range)
    with pytest.raises(ValueError, match=r"raw\.azimuth has shape \(47,\), raw\.data has "
                                         r"shape \(48, 160\)"):
        sj.focus(_radar(), short)
    bad = np.array(raw.range)
    bad[0] = np.nan
    with pytest.raises(ValueError, match=r"raw\.range has non-finite values \[nan\]"):
        sj.focus(_radar(), sj.RawData(data=raw.data, azimuth=raw.azimuth, range=bad))
    with pytest.raises(ValueError, match=r"radar=NoneType is not a sarjax\.Radar"):
        sj.focus(None, raw)


# ---- files -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def raw_file(raw, tmp_path_factory):
    from sarjax import io

    path = tmp_path_factory.mktemp("files") / "raw.nc"
    attrs = io.simulate_attributes(method="time_domain", num_pulses=NUM_PULSES,
                                   num_range=NUM_RANGE, near_range=NEAR_RANGE)
    io.save(path, raw, radar=_radar(), scene=_scene(), attrs=attrs)
    return path


def _foreign_netcdf(path):
    import xarray as xr

    xr.Dataset({"temperature": ("time", np.arange(3.0))}).to_netcdf(path, engine="h5netcdf")


def _tampered(path, source, **changes):
    """A copy of ``source`` with attributes changed or (value None) removed."""
    import xarray as xr

    with xr.open_dataset(source, engine="h5netcdf") as ds:
        ds = ds.load()
    for key, value in changes.items():
        if value is None:
            del ds.attrs[key]
        else:
            ds.attrs[key] = value
    ds.to_netcdf(path, engine="h5netcdf")


def _dropped(path, source, *variables):
    import xarray as xr

    with xr.open_dataset(source, engine="h5netcdf") as ds:
        ds.load().drop_vars(list(variables)).to_netcdf(path, engine="h5netcdf")


BAD_FILES = {
    # name: (how to make it from the good raw file, message of io.load)
    "truncated": (lambda p, src: p.write_bytes(src.read_bytes()[: src.stat().st_size // 2]),
                  r"cannot read .*truncated\.nc: not a NetCDF-4/HDF5 file sarjax can open "
                  r"\(OSError: .*truncated file"),
    "text": (lambda p, src: p.write_text("preset = 'airborne'\n"),
             r"cannot read .*text\.nc: not a NetCDF-4/HDF5 file .*signature not found"),
    "empty": (lambda p, src: p.write_bytes(b""), r"cannot read .*empty\.nc"),
    "foreign": (lambda p, src: _foreign_netcdf(p),
                r"foreign\.nc is not a valid sarjax file: dataset attribute "
                r"sarjax_product=None is neither RawData nor Image"),
    "negative_prf": (lambda p, src: _tampered(p, src, radar_prf=-400.0),
                     r"negative_prf\.nc is not a valid sarjax file: radar\.prf=-400\.0 "
                     r"must be > 0"),
    "text_prf": (lambda p, src: _tampered(p, src, radar_prf="fast"),
                 r"radar parameter prf='fast' in the file is not a float"),
    "no_bandwidth": (lambda p, src: _tampered(p, src, radar_bandwidth=None),
                     r"radar parameter 'bandwidth' missing from the file"),
    "no_samples": (lambda p, src: _dropped(p, src, "raw_real", "raw_imag"),
                   r"the RawData file holds no 'raw' variable"),
    "half_scene": (lambda p, src: _dropped(p, src, "scatterer_range"),
                   r"half_scene\.nc is not a valid sarjax file: .*scatterer_range"),
}


@pytest.fixture(scope="module")
def bad_files(raw_file, tmp_path_factory):
    folder = tmp_path_factory.mktemp("bad_files")
    paths = {}
    for name, (make, _) in BAD_FILES.items():
        paths[name] = folder / f"{name}.nc"
        make(paths[name], raw_file)
    return paths


@pytest.mark.parametrize("name", sorted(BAD_FILES))
def test_loading_a_bad_file(bad_files, name):
    from sarjax import io

    with pytest.raises(ValueError, match=BAD_FILES[name][1]):
        io.load(bad_files[name])


def test_save_refuses_existing_and_missing_paths(raw, tmp_path):
    from sarjax import io

    path = io.save(tmp_path / "raw.nc", raw)
    before = path.read_bytes()
    with pytest.raises(FileExistsError, match=r"raw\.nc exists \(pass overwrite=True"):
        io.save(path, raw)
    with pytest.raises(FileNotFoundError, match=r"folder .*missing does not exist"):
        io.save(tmp_path / "missing" / "raw.nc", raw)
    assert path.read_bytes() == before


def test_writes_are_atomic(raw, tmp_path, monkeypatch):
    """A write that fails half-way leaves neither a partial file nor debris, and an
    existing file untouched even with overwrite=True."""
    import xarray as xr

    from sarjax import io

    path = io.save(tmp_path / "raw.nc", raw)
    before = path.read_bytes()

    def crash(target, *args, **kwargs):
        with open(target, "wb") as f:
            f.write(b"\x89HDF\r\n\x1a\n half a file")
        raise OSError("disk full")

    # both writers: h5netcdf's direct one and xarray's (without h5netcdf)
    monkeypatch.setattr(io, "_write_h5netcdf", crash)
    monkeypatch.setattr(xr.Dataset, "to_netcdf", lambda self, *a, **k: crash(*a, **k))
    with pytest.raises(OSError, match="disk full"):
        io.save(tmp_path / "new.nc", raw)
    with pytest.raises(OSError, match="disk full"):
        io.save(path, raw, overwrite=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["raw.nc"]
    assert path.read_bytes() == before


# ---- the command line --------------------------------------------------------------

CONFIG = """
preset = "airborne"
[radar]
num_pulses = 33
num_range = 64
[scene]
azimuth = [0.0, 2.0]
range = [5140.0, 5150.0]
[simulate]
near_range = 5130.0
"""


def _cli(*args):
    import sarjax.cli

    return sarjax.cli.main([str(a) for a in args])


def _one_line_error(capsys, status, code=2):
    err = capsys.readouterr().err
    assert status == code, err
    assert err.startswith("sarjax: error: ") and err.count("\n") == 1, err
    assert "Traceback" not in err
    return err


# (config edit: (section line or None, text appended), --set overrides, message)
CLI_CONFIG_CASES = {
    "malformed_toml": ("[radar\nprf = 1\n", (), r"run\.toml: .*\(at line \d+, column \d+\)"),
    "unknown_section": ("[wobble]\nx = 1\n", (), r"unknown configuration entries \['wobble'\]"),
    "unknown_scene_key": ("", ("scene.colour=1",), r"unknown \[scene\] entries \['colour'\]"),
    "unknown_motion_key": ("", ("motion.wobble=2",), r"unknown \[motion\] entries \['wobble'\]"),
    "unknown_simulate_option": ("", ("simulate.turbo=true",),
                                r"unknown option\(s\) \['turbo'\] for method='time_domain'"),
    "unknown_radar_key": ("", ("radar.frequency=9e9",),
                          r"unknown radar parameter\(s\) \['frequency'\]"),
    "radar_not_a_table": ("", ("radar=5",), r"\[radar\] must be a table, got radar = 5"),
    "set_without_value": ("", ("radar.prf",), r"--set 'radar\.prf': expected section\.key=value"),
    "prf_text": ("", ("radar.prf='fast'",), r"radar\.prf='fast' must be a number"),
    "prf_infinite": ("", ("radar.prf=inf",), r"radar\.prf=inf must be finite"),
    "prf_zero": ("", ("radar.prf=0",), r"radar\.prf=0\.0 must be > 0"),
    "speed_negative": ("", ("radar.velocity=-100",), r"radar\.velocity=-100\.0 must be > 0"),
    "duration_zero": ("", ("radar.chirp_duration=0",), r"radar\.chirp_duration=0\.0 must be > 0"),
    "bandwidth_negative": ("", ("radar.bandwidth=-1e6",), r"radar\.bandwidth=-1000000\.0"),
    "fs_below_bandwidth": ("", ("radar.sampling_rate=40e6",),
                           r"radar\.sampling_rate=4e\+07 Hz is below radar\.bandwidth"),
    "scene_nan": ("", ("scene.range=[5140.0, nan]",),
                  r"scene\.range has non-finite values \[nan\] at indices \[1\]"),
    "scene_text": ("", ("scene.azimuth='here'",),
                   r"scene\.azimuth='here' must be a number or a list of numbers"),
    "scene_lengths": ("", ("scene.range=[5140.0, 5150.0, 5160.0]",),
                      r"PointTargets\.range has shape \(3,\), azimuth has shape \(2,\)"),
    "below_nadir": ("", ("scene.range=[3000.0, 5150.0]",),
                    r"scene\.range=\[3000\.\] m is not beyond the platform height"),
    "pulses_fraction": ("", ("simulate.num_pulses=2.5",),
                        r"simulate\.num_pulses=2\.5 must be an integer"),
    "dtype_real": ("", ("simulate.dtype='float32'",), r"dtype=float32 must be complex64"),
    "dtype_unknown": ("", ("simulate.dtype='bogus'",), r"simulate\.dtype='bogus'"),
    "method_unknown": ("", ("simulate.method='magic'",), r"unknown method='magic'"),
    "deviation_negative": ("", ("motion.deviation_rms=-0.1",),
                           r"motion\.deviation_rms=-0\.1 must be ≥ 0"),
    "deviation_nan": ("", ("motion.deviation_rms=nan",), r"motion\.deviation_rms=nan must be "
                                                          r"finite"),
    "jitter_period_zero": ("", ("motion.jitter=0.05", "motion.jitter_period=0"),
                           r"motion\.jitter_period=0 must be > 0"),
    "seed_negative": ("", ("motion.deviation_rms=0.01", "motion.seed=-1"),
                      r"motion\.seed=-1 must be ≥ 0"),
    "preset_unknown": ("", ("preset='moon'",), r"preset='moon'; choose one of"),
    "strict_outside_validity": ("", ("simulate.method='fourier_2d'", "simulate.strict=true",
                                     "motion.deviation_rms=0.05"),
                                r"strict=True: method='fourier_2d' is outside its validity: "
                                r"epsilon_motion="),
    "strict_outside_swath": ("", ("simulate.strict=true", "scene.range=[5140.0, 9000.0]"),
                             r"strict=True: 1 of 2 scatterers' echoes miss the range window"),
}


@pytest.mark.parametrize("case", sorted(CLI_CONFIG_CASES))
def test_cli_bad_configuration(case, tmp_path, capsys):
    extra, overrides, expected = CLI_CONFIG_CASES[case]
    (tmp_path / "run.toml").write_text(CONFIG + extra)
    args = ["simulate", tmp_path / "run.toml", "-o", tmp_path / "raw.nc"]
    for item in overrides:
        args += ["--set", item]
    err = _one_line_error(capsys, _cli(*args))
    assert re.search(expected, err), (expected, err)
    assert not (tmp_path / "raw.nc").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.toml"]  # no debris


@pytest.mark.parametrize("case", ["missing", "folder", "binary"])
def test_cli_configuration_file_unreadable(case, tmp_path, capsys):
    path = {"missing": tmp_path / "none.toml", "folder": tmp_path,
            "binary": tmp_path / "run.toml"}[case]
    if case == "binary":
        path.write_bytes(b"\x89HDF\r\n\x1a\n\xff\xfe")
    err = _one_line_error(capsys, _cli("simulate", path, "-o", tmp_path / "raw.nc"))
    assert {"missing": "does not exist", "folder": "is a directory",
            "binary": "is not a text (TOML) file"}[case] in err


@pytest.mark.parametrize("name", sorted(BAD_FILES))
@pytest.mark.parametrize("command", ["focus", "plot", "export"])
def test_cli_bad_input_file(bad_files, name, command, tmp_path, capsys):
    extra = ["--format", "cphd"] if command == "export" else []
    out = tmp_path / "out"
    err = _one_line_error(capsys, _cli(command, bad_files[name], "-o", out, *extra))
    assert re.search(BAD_FILES[name][1], err), err
    assert not out.exists()


def test_cli_focus_refuses_non_finite_samples(raw, tmp_path, capsys):
    from sarjax import io

    data = np.array(raw.data)
    data[0, 0] = np.nan
    io.save(tmp_path / "nan.nc", _with_data(raw, data), radar=_radar())
    err = _one_line_error(capsys, _cli("focus", tmp_path / "nan.nc", "-o", tmp_path / "i.nc"))
    assert "raw.data has non-finite samples at (pulse, sample) [(0, 0)]" in err
    assert not (tmp_path / "i.nc").exists()


def test_cli_wrong_kind_of_file(raw_file, tmp_path, capsys):
    err = _one_line_error(capsys, _cli("metrics", raw_file))
    assert re.search(r"raw\.nc holds RawData, expected Image", err)


@pytest.mark.parametrize("command", ["simulate", "focus", "plot", "export"])
def test_cli_output_paths(command, raw_file, tmp_path, capsys):
    """An existing output is kept (and nothing is computed) without --force; a folder or a
    missing parent folder is refused before any work."""
    (tmp_path / "run.toml").write_text(CONFIG)
    source = tmp_path / "run.toml" if command == "simulate" else raw_file
    extra = ["--format", "cphd"] if command == "export" else []
    existing = tmp_path / "existing.out"
    existing.write_bytes(b"keep me")
    for out, expected in ((existing, r"existing\.out exists \(pass --force to replace it\)"),
                          (tmp_path, r"'--out': File .* is a directory"),
                          (tmp_path / "no" / "x.out", r"folder .*no of the output does not "
                                                      r"exist")):
        err = _one_line_error(capsys, _cli(command, source, "-o", out, *extra))
        assert re.search(expected, err), err
    assert existing.read_bytes() == b"keep me"


@pytest.mark.filterwarnings("default::sarjax.SwathWarning")
def test_cli_warning_is_one_line(tmp_path, capsys):
    """A scene entirely outside the range window: written (zeros), with one warning line."""
    (tmp_path / "run.toml").write_text(CONFIG)
    status = _cli("simulate", tmp_path / "run.toml", "-o", tmp_path / "raw.nc",
                  "--set", "scene.range=[9000.0, 9100.0]")
    captured = capsys.readouterr()
    assert status == 0, captured.err
    # off a terminal the progress comes as log lines of its own ("sarjax: simulate: step
    # 1/2 done after 0.6 s"); the warning is one line among them, once
    lines = captured.err.splitlines()
    progress = [line for line in lines if re.fullmatch(
        r"sarjax: simulate: step \d/\d done after [\d.]+ s", line)]
    warning = [line for line in lines if line not in progress]
    assert len(warning) == 1, captured.err
    assert re.fullmatch(r"sarjax: warning: no scatterer's echo reaches the range window "
                        r"r' = 5130 … 5318\.87 m \(scene\.range = \[9000\. 9100\.\] m …\): "
                        r"the raw data is identically zero \(SwathWarning\)", warning[0])
    from sarjax import io

    assert np.all(np.asarray(io.load(tmp_path / "raw.nc").product.data) == 0)


def test_cli_warning_as_error_and_internal_error(tmp_path, capsys, monkeypatch):
    import sarjax.cli

    (tmp_path / "run.toml").write_text(CONFIG)
    args = ["simulate", tmp_path / "run.toml", "-o", tmp_path / "raw.nc"]
    # warnings as errors (pytest's filterwarnings = error, as ``python -W error``): status 2
    err = _one_line_error(capsys, _cli(*args, "--set", "scene.range=[9000.0, 9100.0]"))
    assert "no scatterer's echo reaches the range window" in err

    def broken(config):
        raise RuntimeError("a bug\nover two lines")

    monkeypatch.setattr(sarjax.cli, "simulate_config", broken)
    err = _one_line_error(capsys, _cli(*args), code=1)
    assert "internal error (RuntimeError: a bug over two lines)" in err
    monkeypatch.setenv("SARJAX_TRACEBACK", "1")
    with pytest.raises(RuntimeError, match="a bug"):
        _cli(*args)


def test_cli_shell_bad_input_has_no_traceback(tmp_path):
    """From a shell: one line on stderr, status 2, nothing written."""
    import subprocess
    import sys

    (tmp_path / "run.toml").write_text(CONFIG + "[wobble]\n")
    done = subprocess.run([sys.executable, "-m", "sarjax.cli", "simulate", "run.toml", "-o",
                           "raw.nc", "--set", "radar.prf=nan"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr, done.stderr
    assert done.stderr.startswith("sarjax: error: ")
    assert not (tmp_path / "raw.nc").exists()


@pytest.mark.parametrize("method", ["fourier_2d", "small_deviation", "moderate_deviation",
                                    "high_speed"])
@pytest.mark.parametrize("taps", [0, 1, 17, 2.5, True])
def test_stolt_kernel_width_outside_its_range(method, taps):
    """The inverse Stolt interpolation's kernel must fit the table's 16-cell guard."""
    with pytest.raises(ValueError, match=f"taps={taps!r} must be an integer from 2 to 16"):
        _simulate(method=method, taps=taps)
