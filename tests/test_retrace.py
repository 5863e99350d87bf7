"""``sj.simulate`` compiles once per structure: physical values never retrace.

Every physical number (radar parameters, deviations, reflectivities, near range,
azimuth centre) is an array leaf of the jitted ``_run``; only the grid sizes, the
number of scatterers, the dtype and the simulator options are static.

Traces are counted in the simulator's ``simulate``, which runs only while ``_run`` is
being traced. To keep the count independent of what other tests compiled earlier in
the session, each test uses a fresh cache key: a simulator subclass defined inside the
test, or (for the default ``method="time_domain"`` path) a unique ``memory_budget=``
option, which is a static field of :class:`~sarjax.TimeDomain` and leaves the chunking
unchanged at these sizes.
"""

from __future__ import annotations

import contextlib
import itertools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import sarjax as sj
import sarjax._simulate as _simulate_module

NUM_PULSES = 24
NUM_RANGE = 96
NEAR_RANGE = 4990.0

_unique = itertools.count(1)


def _radar(**overrides):
    return sj.presets.airborne_xband(
        carrier_frequency=9.65e9,
        bandwidth=40e6,
        chirp_duration=1e-6,
        prf=16.0,
        height=3000.0,
        **overrides,
    )


def _scene(reflectivity=(1.0, 0.5j)):
    return sj.PointTargets(azimuth=[0.0, 20.0], range=[5100.0, 5150.0],
                           reflectivity=list(reflectivity))


def _motion(scale=0.0, num_pulses=NUM_PULSES):
    x = np.linspace(-1.0, 1.0, num_pulses)
    return sj.Motion(horizontal=scale * 0.01 * np.sin(3 * x), vertical=scale * 0.02 * x,
                     pointing=scale * 1e-3 * np.cos(5 * x))


@pytest.fixture(autouse=True)
def _jit_path_only():
    """These tests count jax's traces and jit cache entries: the simulation programs kept
    on disk (``sarjax._exported``, off unless a caller opts in) would bypass both."""
    from sarjax import _exported

    kept = _exported.folder()
    _exported.set_folder(None)
    yield
    _exported.set_folder(kept)


def _unique_budget():
    """A memory budget unique to this call (large enough not to change the chunks)."""
    return 256 * 2**20 + next(_unique)


def _counting_simulator():
    """A TimeDomain subclass private to the calling test, counting its traces."""
    traces = []

    class CountingTimeDomain(sj.TimeDomain):
        def simulate(self, plan, radar, scene, motion, acquisition, dtype):
            traces.append(acquisition.num_pulses)
            return super().simulate(plan, radar, scene, motion, acquisition, dtype)

    return CountingTimeDomain(), traces


def _value_changes():
    """Calls that change only values (same shapes and dtypes) of every kind of leaf."""
    radar = _radar()
    return [
        dict(radar=radar, scene=_scene(), motion=_motion()),
        dict(radar=radar.replace(carrier_frequency=9.7e9), scene=_scene(), motion=_motion()),
        # an int given for a float field is converted, not a new dtype
        dict(radar=radar.replace(carrier_frequency=9_600_000_000), scene=_scene(),
             motion=_motion()),
        # tree_at bypasses the converter: give a (non-weak) float64 array. (A weakly typed
        # jnp.asarray(9.5e9) is a different abstract value to jit and would retrace.)
        dict(radar=eqx.tree_at(lambda r: r.carrier_frequency, radar,
                               jnp.asarray(9.5e9, dtype=jnp.float64)),
             scene=_scene(), motion=_motion()),
        dict(radar=radar.replace(velocity=110.0, prf=17.0, bandwidth=35e6),
             scene=_scene(), motion=_motion()),
        dict(radar=radar, scene=_scene(), motion=_motion(scale=1.0)),
        dict(radar=radar, scene=_scene(), motion=_motion(scale=-2.5)),
        dict(radar=radar, scene=_scene(reflectivity=(0.3 - 2j, 7.0)), motion=_motion()),
        # real reflectivities are stored as complex: same dtype
        dict(radar=radar, scene=_scene(reflectivity=(2.0, 3.0)), motion=_motion()),
        dict(radar=radar, scene=_scene(), motion=_motion(), near_range=NEAR_RANGE + 3.0,
             azimuth_center=12.5),
    ]


def _call(simulator_or_name, call, num_pulses=NUM_PULSES, **options):
    call = dict(call)
    if num_pulses != NUM_PULSES:  # one deviation value per pulse
        call["motion"] = _motion(num_pulses=num_pulses)
    return sj.simulate(
        call.pop("radar"),
        call.pop("scene"),
        call.pop("motion"),
        method=simulator_or_name,
        num_pulses=num_pulses,
        num_range=NUM_RANGE,
        near_range=call.pop("near_range", NEAR_RANGE),
        **call,
        **options,
    )


def test_value_changes_do_not_retrace():
    simulator, traces = _counting_simulator()
    outputs = [_call(simulator, call).data for call in _value_changes()]
    assert traces == [NUM_PULSES], traces
    # the values did reach the computation
    for a, b in itertools.pairwise(outputs):
        assert not np.allclose(np.asarray(a), np.asarray(b))

    # sanity: the counter does see retraces; a new grid size is new structure
    _call(simulator, _value_changes()[0], num_pulses=NUM_PULSES + 1)
    assert traces == [NUM_PULSES, NUM_PULSES + 1], traces
    # ... and the original size is still cached
    _call(simulator, _value_changes()[1])
    assert len(traces) == 2, traces


def test_default_method_does_not_retrace(monkeypatch):
    """The ``method="time_domain"`` path (a new TimeDomain per call) hits the cache too."""
    traces = []
    original = sj.TimeDomain.simulate

    def counting_call(self, plan, radar, scene, motion, acquisition, dtype):
        traces.append(acquisition.num_pulses)
        return original(self, plan, radar, scene, motion, acquisition, dtype)

    monkeypatch.setattr(sj.TimeDomain, "simulate", counting_call)
    budget = _unique_budget()
    cached = getattr(_simulate_module._run, "_cached", None)
    cache_size = getattr(cached, "_cache_size", None)  # jax's jit cache, when exposed

    calls = _value_changes()
    _call("time_domain", calls[0], memory_budget=budget)
    size_after_first = cache_size() if cache_size else None
    for call in calls[1:]:
        _call("time_domain", call, memory_budget=budget)
    assert traces == [NUM_PULSES], traces
    if cache_size:
        assert cache_size() == size_after_first

    _call("time_domain", calls[0], num_pulses=NUM_PULSES + 2, memory_budget=budget)
    assert traces == [NUM_PULSES, NUM_PULSES + 2], traces
    if cache_size:
        assert cache_size() == size_after_first + 1


def test_max_traces_with_equinox_debug():
    """The same property with ``eqx.debug.assert_max_traces`` on the traced kernel."""

    @eqx.debug.assert_max_traces(max_traces=2)
    def kernel(simulator, plan, radar, scene, motion, acquisition, dtype):
        return sj.TimeDomain.simulate(simulator, plan, radar, scene, motion, acquisition, dtype)

    class DebugTimeDomain(sj.TimeDomain):
        def simulate(self, plan, radar, scene, motion, acquisition, dtype):
            return kernel(self, plan, radar, scene, motion, acquisition, dtype)

    simulator = DebugTimeDomain()
    for call in _value_changes():
        _call(simulator, call)
    assert eqx.debug.get_num_traces(kernel) == 1
    _call(simulator, _value_changes()[0], num_pulses=NUM_PULSES + 3)
    assert eqx.debug.get_num_traces(kernel) == 2
    # a third structure would exceed max_traces=2: the counter is live
    with pytest.raises(RuntimeError, match="traced"):
        _call(simulator, _value_changes()[0], num_pulses=NUM_PULSES + 4)


def test_gradient_calls_do_not_retrace():
    """Repeated ``jax.grad`` through ``simulate`` at new values reuses the trace."""
    simulator, traces = _counting_simulator()
    radar = _radar()

    def loss(frequency, horizontal, reflectivity):
        call = dict(
            radar=eqx.tree_at(lambda r: r.carrier_frequency, radar, frequency),
            scene=eqx.tree_at(lambda s: s.reflectivity, _scene(), reflectivity),
            motion=sj.Motion(horizontal=horizontal),
        )
        return jnp.sum(jnp.abs(_call(simulator, call).data) ** 2)

    grad = jax.grad(loss, argnums=(0, 1, 2))
    for k in range(3):
        frequency = jnp.asarray(9.6e9 + 1e6 * k, dtype=jnp.float64)
        horizontal = jnp.full(NUM_PULSES, 0.01 * k)
        reflectivity = jnp.asarray([1.0 + k, 0.5j], dtype=jnp.complex128)
        grad(frequency, horizontal, reflectivity)
    assert traces == [NUM_PULSES], traces


def test_dtype_and_scene_size_are_structure():
    """Sanity of the counter on the other static inputs: dtype and scatterer count."""
    simulator, traces = _counting_simulator()
    call = _value_changes()[0]
    _call(simulator, call)
    _call(simulator, call, dtype=jnp.complex64)
    _call(simulator, {**call, "scene": sj.PointTargets(azimuth=[0.0], range=[5100.0])})
    assert len(traces) == 3, traces
    _call(simulator, call, dtype=jnp.complex64)
    assert len(traces) == 3, traces


@contextlib.contextmanager
def _traces_of(name):
    """A list that collects, while the block runs, one entry per trace of a jitted
    function whose name contains ``name`` (JAX's trace-duration events)."""
    from jax import monitoring

    traces = []

    def count(event, duration, **kwargs):
        if event.endswith("jaxpr_trace_duration") and name in str(kwargs.get("fun_name", "")):
            traces.append(duration)

    monitoring.register_event_duration_secs_listener(count)
    try:
        yield traces
    finally:
        monitoring.unregister_event_duration_listener(count)


def test_the_checks_chirp_spectrum_is_one_program_for_every_chirp():
    """The eager chirp spectrum of the budget checks (``chirp_spectrum_values``) takes the
    chirp rate and half-length as inputs: three chirps on one length bucket trace its
    program once (as Python floats they were static, a program per radar), and each
    value is the chirp's own spectrum (``chirp_spectrum``; within 1e-12 of the peak: the
    same float64 Fresnel evaluation, compiled once with the chirp as an input rather than
    a constant)."""
    from sarjax.simulators import _fourier_engine as engine

    eta = np.linspace(-2.0, 2.0, 2049 + next(_unique))  # its own bucket: 4096 samples
    with _traces_of("_chirp_spectrum_program") as traces:
        for duration, bandwidth in ((1e-6, 40e6), (2e-6, 40e6), (1e-6, 100e6)):
            radar = sj.presets.airborne_xband(chirp_duration=duration, bandwidth=bandwidth)
            values = engine.chirp_spectrum_values(radar.chirp_rate, radar.pulse_half_length,
                                                  eta)
            expected = np.asarray(engine.chirp_spectrum(radar, jnp.asarray(eta)))
            assert np.max(np.abs(values - expected)) <= 1e-12 * np.max(np.abs(expected))
    assert len(traces) <= 1, traces


def test_omega_k_of_apertures_with_one_transform_length_is_one_program():
    """ω-k's azimuth padding, a static argument, is passed as the transform length it
    gives less the pulses: two carriers whose full-band apertures differ by a pulse (the
    window's far range seen over 1494 and 1495 pulses) but give one transform length
    (2000) trace the focusing program once, not twice, and each focuses its target (the
    padding's one use is that length)."""
    from sarjax.processing import _focus
    from sarjax.processing._omega_k import azimuth_aperture

    num_pulses, num_range = 503, 211  # a window no other test focuses: a fresh program
    apertures, images, traces = [], [], []
    for carrier in (9.65e9, 9.644e9):
        radar = sj.presets.airborne_xband(carrier_frequency=carrier)
        x = (np.arange(num_pulses) - (num_pulses - 1) / 2) * float(radar.azimuth_spacing)
        motion = sj.Motion(horizontal=0.01 * np.sin(x / 30), vertical=0.01 * np.cos(x / 40))
        raw = sj.simulate(radar, sj.PointTargets(azimuth=[3.0], range=[5140.0]), motion,
                          num_pulses=num_pulses, num_range=num_range, near_range=5000.0)
        window = _focus._lag_axis(radar, jnp.asarray(raw.range),
                                  _focus.recorded_lags(radar, jnp.asarray(raw.range)))
        apertures.append(azimuth_aperture(radar, window))
        with _traces_of("_focus_omega_k") as focusing:
            images.append(sj.focus(radar, raw, motion=motion))
        traces += focusing
    assert apertures[0] != apertures[1], apertures  # the case this test is about
    assert len(traces) <= 1, (apertures, traces)
    for image in images:  # each focuses its target at (3 m, 5140 m): peak within 0.1 m
        metrics = sj.point_target_metrics(image, azimuth=3.0, range=5140.0)
        assert abs(metrics.peak_azimuth - 3.0) < 0.1, metrics
        assert abs(metrics.peak_range - 5140.0) < 0.1, metrics
        assert metrics.pslr_azimuth < -10.0, metrics  # focused, not smeared
