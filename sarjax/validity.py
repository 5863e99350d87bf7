"""Validity of a simulation before running it, and ``method="auto"`` (physics.md §7).

Every simulator declares its budgets (``AbstractSimulator.budgets``): the window and
grid budgets (``range_window`` for every method; ``azimuth_aliases``, ``azimuth_window``,
``azimuth_extent``, ``azimuth_sidelobes``, ``azimuth_amplitude`` for the Fourier-domain
methods) and the approximation budgets of the approximate ones (the phase each neglected
deviation term can cause over the pulses that illuminate a scatterer, ``epsilon_11``,
``epsilon_12``, ``epsilon_13``, ``epsilon_motion``, and the pointing expansion's
``epsilon_az``; formulas in ``sarjax.simulators._tracks``, thresholds in
``sarjax.simulators._budgets``: 0.1 rad for phases and 0.02 for the relative pattern
error, chosen on the calibration grid of ``tests/test_validity.py`` so that every case
called valid is accurate — focused NMSE ≤ −25 dB, IRW within 1 %, PSLR/ISLR within
0.3 dB of the exact model).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ._data import Acquisition
from ._validate import check_dtype
from .motion import Motion
from .simulators import AbstractSimulator, _registry
from .simulators._budgets import PATTERN_THRESHOLD as PATTERN_THRESHOLD
from .simulators._budgets import PHASE_THRESHOLD as PHASE_THRESHOLD
from .simulators._budgets import Budget as Budget
from .simulators._budgets import Validity as Validity

# the methods ``auto`` chooses among, cheapest first on a typical scene (derived from the
# registry; kept for callers that order methods)
FASTEST_FIRST = tuple(cls.names[0] for cls in _registry.auto_candidates())


def _acquisition(radar, num_pulses, num_range, near_range, azimuth_center):
    return Acquisition(
        num_pulses=int(radar.num_pulses if num_pulses is None else num_pulses),
        num_range=int(radar.num_range if num_range is None else num_range),
        near_range=radar.near_range if near_range is None else near_range,
        azimuth_center=azimuth_center,
    )


def _simulator(method, options):
    """The simulator of ``method`` with the options among ``options`` that it has."""
    cls = _registry.simulator_class(method)
    fields = {f.name for f in dataclasses.fields(cls)}
    return cls(**{k: v for k, v in options.items() if k in fields})


def validity(radar, scene, motion=None, *, method, num_pulses=None, num_range=None,
             near_range=None, azimuth_center=0.0, dtype="complex128",
             **options) -> Validity:
    """Validity budgets of ``method`` for this acquisition, without simulating.

    Args:
        radar: :class:`~sarjax.Radar`.
        scene: :class:`~sarjax.PointTargets` or :class:`~sarjax.ReflectivityGrid`.
        motion: :class:`~sarjax.Motion` (None = ideal).
        method: any method :func:`sarjax.simulate` accepts
            (``sarjax.simulators.method_names()``), or a simulator instance.
        num_pulses, num_range, near_range: the acquisition (defaults: the radar's).
        azimuth_center: x' of the middle pulse [m].
        dtype: the output's dtype; complex64 adds the Fourier-domain track methods'
            ``complex64_rounding`` budget.
        **options: simulator options that change its budgets (e.g. ``pointing_order``,
            ``coupling_order``, ``envelope_correction``); options a method does not have
            are ignored.

    Returns:
        :class:`Validity` with each budget's value, threshold and verdict and ``.valid``:
        the window and sampling budgets of every method, and the approximation budgets of
        the approximate ones.
    """
    if isinstance(method, str) and method == _registry.AUTO:
        raise ValueError("method='auto' has no budgets of its own: see choose_method()")
    dtype = check_dtype(dtype)
    simulator = (method if isinstance(method, AbstractSimulator)
                 else _simulator(method, options))
    motion = Motion() if motion is None else motion
    acquisition = _acquisition(radar, num_pulses, num_range, near_range, azimuth_center)
    report = simulator.budgets(radar, scene, motion, acquisition, dtype)
    name = method if isinstance(method, str) else report.method
    return dataclasses.replace(report, method=name)


def choose_method(radar, scene, motion=None, *, num_pulses=None, num_range=None,
                  near_range=None, azimuth_center=0.0, dtype="complex128",
                  **options) -> tuple[str, dict]:
    """``method="auto"``: the cheapest method whose budgets hold, by each simulator's cost
    model (``AbstractSimulator.cost``: compile and steady time on a 2-core CPU, the
    compile time counted, as for a single call). The exact models are always valid, so
    for a few scatterers on a small grid they are the cheapest (no FFT program to
    compile); for extended scenes the Fourier-domain methods are.

    Candidates are the registered simulators that declare ``in_auto`` and support the
    scene (squint, moving scatterers); they are checked cheapest first, and the dearer
    ones are neither checked nor (when their compile time alone costs more) planned once
    one is valid. Returns (name, {name: Validity}
    of the candidates checked); :func:`explain_choice` says why.
    """
    name, report, _, _ = _choose(radar, scene, motion, num_pulses=num_pulses,
                                 num_range=num_range, near_range=near_range,
                                 azimuth_center=azimuth_center, dtype=dtype, **options)
    return name, report


def explain_choice(radar, scene, motion=None, **kwargs) -> tuple[str, str]:
    """(name, reason) of ``method="auto"`` (same arguments as :func:`choose_method`): the
    reason lists the candidates by estimated cost, each with its cost and, for those
    checked (the cheaper ones, up to the first valid), the budget that rules it out, e.g.
    ``"cheapest valid by the cost models: time_domain 0.41 s (compile 0.40 + steady
    0.01); not checked, dearer: fourier_2d 5.2 s, …"``. It is kept in
    ``RawData.method_reason``."""
    name, report, costs, unplanned = _choose(radar, scene, motion, **kwargs)
    ruled_out, dearer = [], []
    for method, cost in sorted(costs.items(), key=lambda item: item[1].total()):
        if method not in report:
            dearer.append(f"{method} {cost.total():.3g} s")
        elif not report[method].valid:
            worst = max(report[method].violated, key=lambda b: b.ratio)
            ruled_out.append(f"{method} {cost.total():.3g} s: {worst.name}="
                             f"{worst.value:.3g} > {worst.threshold:.3g}")
    if name not in report or not report[name].valid:
        return name, "no candidate is valid, so the exact model: " + "; ".join(ruled_out)
    cost = costs[name]
    parts = [f"{name} {cost.total():.3g} s (compile {cost.compile:.3g} + steady "
             f"{cost.steady:.3g})"]
    if ruled_out:
        parts.append("cheaper but not valid: " + "; ".join(ruled_out))
    dearer += [f"{method} ≥ {floor:.3g} s" for method, floor in unplanned.items()]
    if dearer:
        parts.append("not checked, dearer: " + ", ".join(dearer))
    return name, "cheapest valid by the cost models: " + "; ".join(parts)


def _choose(radar, scene, motion=None, *, num_pulses=None, num_range=None, near_range=None,
            azimuth_center=0.0, dtype="complex128", **options):
    """(name, {name: Validity} of the candidates checked, {name: Cost} of those planned,
    {name: compile time} of those not planned, dearer than the choice).
    Candidates are checked cheapest first and the first valid one is taken: the budgets
    of dearer ones are not evaluated, and one whose ``compile_time`` alone exceeds the
    valid choice's cost is not even planned."""
    motion = Motion() if motion is None else motion
    acquisition = _acquisition(radar, num_pulses, num_range, near_range, azimuth_center)
    moving = any(hasattr(scene, f) and bool(np.any(np.asarray(getattr(scene, f)) != 0))
                 for f in ("velocity_range", "velocity_azimuth"))
    squinted = float(radar.squint) != 0.0
    classes = [cls for cls in _registry.auto_candidates()
               if (cls.supports_squint or not squinted)
               and (cls.supports_moving_targets or not moving)]
    classes.sort(key=lambda cls: cls.compile_time)  # a lower bound of each one's cost
    simulators, costs, report = {}, {}, {}
    while True:
        unchecked = [n for n in costs if n not in report]
        best = min(unchecked, key=lambda n: costs[n].total(), default=None)
        if classes and (best is None or classes[0].compile_time < costs[best].total()):
            # a candidate not planned yet may be cheaper than the best planned one
            name = classes.pop(0).names[0]
            simulator = _simulator(name, options)
            try:
                plan = simulator.prepare(radar, scene, acquisition, motion)
            except ValueError:  # e.g. a grid off the pulse lattice: not this method
                continue
            simulators[name] = simulator
            costs[name] = simulator.cost(plan, radar, scene, acquisition, dtype)
            continue
        if best is None:
            return "time_domain", report, costs, {}
        report[best] = simulators[best].budgets(radar, scene, motion, acquisition, dtype)
        if report[best].valid:
            return best, report, costs, {cls.names[0]: cls.compile_time for cls in classes}
