"""Bad input raises ValueError naming the offending field or value; valid edge cases
give finite data."""

from __future__ import annotations

import re

import jax.numpy as jnp
import numpy as np
import pytest

import sarjax as sj

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
@pytest.mark.parametrize("shape", [(NUM_PULSES, 1), (1, NUM_PULSES), (2, NUM_PULSES // 2), ()])
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
    # fourier_2d implements neither (time_domain implements both)
    with pytest.raises(ValueError, match="squint"):
        _simulate(_radar(squint=0.1), method="fourier_2d")
    scene = sj.PointTargets(azimuth=[0.0], range=[5140.0], velocity_range=[1.0])
    with pytest.raises(ValueError, match="velocit"):
        _simulate(scene=scene, method="fourier_2d")
