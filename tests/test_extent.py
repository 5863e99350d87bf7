"""The azimuth analysis kept between calls gives what a fresh analysis gives.

A Fourier-domain call decides its Doppler bands and grid from where each scatterer's
echo is recorded (``_extent.azimuth_support``, ``_extent.work_grid``). The part that does
not depend on the reflectivity (``_extent._RecordedGeometry``) is kept for the next call
on the same radar, window and cells, so that a Monte Carlo over speckle does not redo it.
Whatever came before — the same cells with another reflectivity, other cells, other
velocities — the support, the band-edge spill and the grids must equal, to the bit,
those of an analysis made afresh.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import sarjax as sj
from sarjax._data import Acquisition
from sarjax.simulators import _extent

NUM_PULSES, NUM_RANGE = 512, 256
R0 = 5140.0
NEAR = R0 - NUM_RANGE // 2 * 2.99792458
RADARS = {squint: sj.presets.airborne_xband(
    chirp_duration=5e-6, num_pulses=NUM_PULSES, num_range=NUM_RANGE, near_range=NEAR,
    squint=np.deg2rad(squint)) for squint in (0.0, 10.0, 25.0)}
ACQUISITION = Acquisition(num_pulses=NUM_PULSES, num_range=NUM_RANGE, near_range=NEAR,
                          azimuth_center=0.0)


def _fresh(compute):
    """``compute()`` with nothing kept from an earlier call."""
    _extent._LAST_GEOMETRY[0] = None
    return compute()


def _analysis(radar, scene, bands):
    """Everything the support, the spill and the grids give, as one comparable tuple: the
    grid sized by the scene (with a motion margin) and by a fixed padding."""
    support = _extent._azimuth_support(radar, scene, ACQUISITION, 1e-3, bands, 4)
    grids = (_extent.work_grid(radar, scene, ACQUISITION, support=support, motion_margin=0.05),
             _extent.work_grid(radar, scene, ACQUISITION, 1.0, support=support,
                               doppler_limited=True, curvature=True, migration=True))
    return (tuple(support), _extent.band_edge_spill(radar, scene, ACQUISITION, 2, 0.5),
            tuple(tuple(grid) for grid in grids))


def _equal(a, b):
    if isinstance(a, tuple | list):
        return len(a) == len(b) and all(_equal(p, q) for p, q in zip(a, b, strict=True))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True)
    return a == b


# a point inside the ±64 m window, at its edge, beyond it, at a squinted beam's centre
# (−r tan φ from the window: its main lobe far outside), in range inside and beyond
AZIMUTH = st.one_of(st.floats(-64.0, 64.0), st.floats(60.0, 400.0), st.floats(-400.0, -60.0),
                    st.floats(-2500.0, 2500.0))
POINTS = st.lists(st.tuples(AZIMUTH, st.floats(4700.0, 5600.0)), min_size=1, max_size=6)
VELOCITY = st.one_of(st.none(), st.tuples(st.floats(-40.0, 40.0), st.floats(-30.0, 30.0)))


def _points(cells, velocity, reflectivity):
    kwargs = {}
    if velocity is not None:
        kwargs = dict(velocity_range=[velocity[0]] * len(cells),
                      velocity_azimuth=[velocity[1]] * len(cells))
    return sj.PointTargets(azimuth=[x for x, _ in cells], range=[r for _, r in cells],
                           reflectivity=reflectivity, **kwargs)


@settings(max_examples=25, deadline=None)
@given(squint=st.sampled_from(sorted(RADARS)), cells=POINTS, velocity=VELOCITY,
       moved=st.booleans(), bands=st.sampled_from([None, 0, 2]), seed=st.integers(0, 2**31 - 1))
def test_a_kept_analysis_equals_a_fresh_one(squint, cells, velocity, moved, bands, seed):
    """Scene A, then B on A's cells with another reflectivity (A's geometry reused), then C
    (B's reflectivity; one cell moved by 1 mm, or the same cells without the velocity):
    each equals its analysis made afresh."""
    radar = RADARS[squint]
    rng = np.random.default_rng(seed)
    n = len(cells)
    gamma_a, gamma_b = (rng.uniform(0.01, 1.0, n) * np.exp(2j * np.pi * rng.uniform(size=n))
                        for _ in range(2))
    scene_a = _points(cells, velocity, gamma_a)
    scene_b = _points(cells, velocity, gamma_b)
    if moved:
        other = [(cells[0][0] + 1e-3, cells[0][1])] + cells[1:]
        scene_c = _points(other, velocity, gamma_b)
    else:
        scene_c = _points(cells, None if velocity is not None else (5.0, 0.0), gamma_b)
    fresh = [_fresh(lambda s=s: _analysis(radar, s, bands)) for s in (scene_a, scene_b, scene_c)]
    _extent._LAST_GEOMETRY[0] = None
    kept = [_analysis(radar, s, bands) for s in (scene_a, scene_b, scene_c)]
    for name, a, b in zip("ABC", kept, fresh, strict=True):
        assert _equal(a, b), (name, a, b)


def test_a_new_speckle_on_a_grid_reuses_the_geometry():
    """A grid with heights: a new reflectivity on it reuses the kept geometry (the same
    object) and equals a fresh analysis; other range lines do not reuse it. The arrays
    every call's grid shares are read-only."""
    radar = RADARS[10.0]
    rng = np.random.default_rng(3)
    azimuth = np.linspace(-150.0, 150.0, 61)
    ranges = np.linspace(4950.0, 5350.0, 41)
    height = rng.uniform(0.0, 20.0, (61, 41))

    def grid(ranges=ranges):
        gamma = rng.normal(size=(61, 41)) + 1j * rng.normal(size=(61, 41))
        return sj.ReflectivityGrid(gamma, azimuth, ranges, height=height)

    first, second = grid(), grid()
    _extent._LAST_GEOMETRY[0] = None
    kept = [_analysis(radar, s, None) for s in (first, second)]
    geometry = _extent._LAST_GEOMETRY[0][2]
    assert _extent._recorded_geometry(radar, second, ACQUISITION) is geometry
    for scene, analysis in zip((first, second), kept, strict=True):
        assert _equal(analysis, _fresh(lambda s=scene: _analysis(radar, s, None)))
    shifted = grid(ranges + 0.5)
    assert _extent._recorded_geometry(radar, shifted, ACQUISITION) is not geometry
    for cells in geometry._grids.values():
        assert not cells.included.flags.writeable and not cells.span.flags.writeable
