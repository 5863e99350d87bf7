"""Accuracy of the squinted Fourier simulators against the exact model (issue acceptance).

As :mod:`_accuracy` (same criteria: focused NMSE ≤ −25 dB within ±16 cells, IRW within
1 %, PSLR/ISLR within 0.3 dB, raw phase error rms ≤ π/20 within 20 dB of the raw
maximum), with the focuser that images squinted data: the exact back-projection
(``sj.focus(..., method="exact_backprojection")``) on the actual track, uniform azimuth
weighting over the PRF band about the Doppler centroid, evaluated on a ±48-sample
closest-approach grid about the target. Test and reference are focused identically.

Cases: one unit target at closest approach ``(x, r)`` with ``x = r tan φ_d`` (its beam
centre crosses it at the middle pulse, x' = 0) on the airborne set with the squint
overridden, smooth random Δy, Δz of a given rms and the seed 000 eq. 55 pointing jitter.
"""

from __future__ import annotations

import numpy as np

import sarjax as sj

try:
    import _accuracy as acc
except ImportError:
    from tests import _accuracy as acc

_HALF = 48  # image half-size [samples], as _accuracy's crops


def radar_of(degrees, **overrides):
    """The airborne set at squint ``degrees`` (preset overrides as the issue writes)."""
    return sj.presets.airborne_xband(squint=np.deg2rad(degrees), **overrides)


def target(radar, range_):
    """A unit target whose beam-centre crossing is the middle pulse (x' = 0)."""
    return acc.single_target(range_, azimuth=range_ * np.tan(float(radar.squint)))


def motion_of(radar, rms, profile="slow", fraction=0.05, num_pulses=None, seed=7):
    """Smooth Δy, Δz of rms ``rms`` [m] and the seed 000 jitter (``fraction`` λ/L)."""
    n = radar.num_pulses if num_pulses is None else num_pulses
    azimuth = (np.arange(n) - (n - 1) / 2) * float(radar.azimuth_spacing)
    return acc.make_motion(rms, profile, fraction, seed=seed, radar=radar, azimuth=azimuth)


def focus(radar, raw, motion, azimuth, range_):
    """Exact back-projection about (azimuth, range) on the actual track."""
    dx, dr = float(radar.azimuth_spacing), float(radar.range_spacing)
    offsets = np.arange(-_HALF, _HALF + 1)
    return sj.focus(radar, raw, method="exact_backprojection", motion=motion,
                    azimuth=azimuth + offsets * dx, range=range_ + offsets * dr)


_REFERENCES: dict = {}


def reference(radar, scene, motion, **kw):
    """The exact model's raw data, focused image and metrics (cached by content)."""
    key = acc.digest(radar, scene, motion, repr(sorted(kw.items())))
    if key not in _REFERENCES:
        x = float(np.asarray(scene.azimuth)[0])
        r = float(np.asarray(scene.range)[0])
        raw = sj.simulate(radar, scene, motion, method="time_domain", **kw)
        image = focus(radar, raw, motion, x, r)
        _REFERENCES.clear()  # one reference at a time (raw data up to 26 MB)
        _REFERENCES[key] = (acc.reference_of(radar, raw, image, x, r), image)
    return _REFERENCES[key]


def accuracy(radar, scene, motion, method, **kw) -> acc.Accuracy:
    """The issue's figures of ``method`` against the exact model for one target."""
    ref, _ = reference(radar, scene, motion, **kw)
    x = float(np.asarray(scene.azimuth)[0])
    r = float(np.asarray(scene.range)[0])
    raw = sj.simulate(radar, scene, motion, method=method, **kw)
    image = focus(radar, raw, motion, x, r)
    return acc.compare(raw, image, ref, x, r, method=method)


def metrics_rows(radar, scene, motion, methods, **kw):
    """Seed 002 Table 2 rows: (method, PointTargetMetrics) for the exact model and each
    method, all focused by the same exact back-projection."""
    x = float(np.asarray(scene.azimuth)[0])
    r = float(np.asarray(scene.range)[0])
    rows = []
    for method in ("time_domain",) + tuple(methods):
        raw = sj.simulate(radar, scene, motion, method=method, **kw)
        image = focus(radar, raw, motion, x, r)
        rows.append((method, sj.point_target_metrics(image, azimuth=x, range=r)))
    return rows
