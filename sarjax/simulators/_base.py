"""What every raw-data simulator declares, and the plan it runs with.

A simulator is an ``eqx.Module`` whose fields are the options a user sets; its class
says what it is (``names``, ``physics``, ``motion``, ``supports_squint``,
``supports_moving_targets``, ``exact``, ``pulse_local``) and answers, for concrete
inputs and without simulating, how valid (:meth:`AbstractSimulator.budgets`), how large
(:meth:`AbstractSimulator.memory`) and how costly (:meth:`AbstractSimulator.cost`) a run
would be. :meth:`AbstractSimulator.prepare` turns the concrete inputs into a private
plan (static sizes); :meth:`AbstractSimulator.simulate` is the pure kernel that
:func:`sarjax.simulate` jits. The registry (``_registry``) is built from these classes.
"""

from __future__ import annotations

import abc
from typing import ClassVar, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp

from . import _budgets

MOTION_KINDS = ("straight", "small", "moderate", "any")


class Cost(NamedTuple):
    """Estimated time of one call [s]: ``compile`` (first call only) and ``steady``."""

    compile: float
    steady: float

    def total(self, first_call: bool = True) -> float:
        """The time a caller waits: steady, plus compile on a first call."""
        return self.steady + (self.compile if first_call else 0.0)


class AbstractPlan(eqx.Module):
    """Static sizes a simulator fixed from concrete inputs (``prepare()``): part of the
    jit cache key, never set by a user."""


class NoPlan(AbstractPlan):
    """The plan of a simulator with nothing to fix ahead of the call."""


def is_traced(*values) -> bool:
    """True when any value is a tracer (its concrete value is unknown)."""
    return any(isinstance(v, jax.core.Tracer) for v in jax.tree_util.tree_leaves(values))


class AbstractSimulator(eqx.Module):
    """A raw-data simulator: ``simulator(radar, scene, motion, acquisition, dtype)``.

    Returns the (azimuth, range) complex raw data on ``acquisition``'s grid. Options are
    module fields; :func:`sarjax.simulate` is the one jitted entry point.

    Class attributes (declarations):
        names: method names accepted by :func:`sarjax.simulate` (the first is canonical).
        physics: the section of physics.md (and the seed) the simulator implements.
        motion: the platform motion it models: ``"straight"`` (none), ``"small"``,
            ``"moderate"`` or ``"any"`` (exact).
        supports_squint, supports_moving_targets: model features it implements.
        exact: it evaluates the exact model (no approximation budgets).
        pulse_local: its pulses are independent (a block of pulses can be simulated on
            its own, so pulses can be split across devices).
        splits_columns: a Fourier-domain method whose range-wavenumber columns can be
            split across devices (its column loops go through
            ``_fourier_engine.split_columns``): one scene over several devices, each
            left with a block of the pulses.
        in_auto: ``method="auto"`` may choose it (its approximation budgets are measured
            against the exact model).
        accepts_motion: False for a straight-track model that refuses any motion (rather
            than ignoring it).
        compile_time: its cost model's compile time [s], a lower bound of its cost that
            ``method="auto"`` knows before planning (it plans no dearer candidate).
    """

    names: ClassVar[tuple[str, ...]] = ()
    physics: ClassVar[str] = ""
    motion: ClassVar[str] = "any"
    supports_squint: ClassVar[bool] = False
    supports_moving_targets: ClassVar[bool] = False
    exact: ClassVar[bool] = False
    pulse_local: ClassVar[bool] = False
    splits_columns: ClassVar[bool] = False
    in_auto: ClassVar[bool] = False
    accepts_motion: ClassVar[bool] = True
    compile_time: ClassVar[float] = 0.0

    @abc.abstractmethod
    def simulate(self, plan, radar, scene, motion, acquisition, dtype):
        """The pure kernel: (num_pulses, num_range) raw data with the plan's sizes."""

    def __call__(self, radar, scene, motion, acquisition, dtype, plan=None):
        """Simulate raw data (see :func:`sarjax.simulate`); without ``plan`` the plan is
        made here from the concrete inputs."""
        if plan is None:
            plan = self.prepare(radar, scene, acquisition, motion)
        return self.simulate(plan, radar, scene, motion, acquisition, dtype)

    def prepare(self, radar, scene, acquisition, motion=None) -> AbstractPlan:
        """Eager checks and static sizes from concrete values: the private plan (the
        motion, when given, bounds the line-of-sight deviation)."""
        return NoPlan()

    # ---- declarations evaluated on concrete inputs ----------------------------------

    def approximation_budgets(self, radar, scene, motion, acquisition):
        """The budgets of the approximations this method makes (none for exact ones)."""
        return (), 0.0

    def azimuth_period(self, radar, scene, motion, acquisition) -> int:
        """Pulses over which this method's data repeat along track
        (:attr:`sarjax.RawData.azimuth_period`); 0 (default): they do not."""
        return 0

    def window_budgets(self, radar, scene, motion, acquisition, dtype=jnp.complex128):
        """Budgets of the grid the method synthesises on (default: none; the
        Fourier-domain methods: its azimuth aliases, wrap and extent, and the track
        methods' complex64 rounding)."""
        return ()

    def budgets(self, radar, scene, motion, acquisition, dtype=jnp.complex128, *,
                outside=None) -> _budgets.Validity:
        """Every budget of this run in ``dtype``: the approximations', then window and
        sampling.

        Every method reports the range window (scatterers whose echo misses it are not
        recorded: only a window that records nothing is a violation); the Fourier-domain
        methods add their grid's (``window_budgets``) and the chirp ends' Gibbs residual
        (``chirp_edges``), and the approximate ones their
        approximation budgets (:mod:`sarjax.simulators._budgets`). ``outside``: the
        scatterers whose echoes miss the window, when the caller has them
        (:func:`~sarjax.simulators._budgets.echoes_outside_window` of the same inputs).
        """
        found = list(_budgets.range_window_budget(radar, scene, motion, acquisition,
                                                  outside))
        found += self.window_budgets(radar, scene, motion, acquisition, dtype)
        if not self.exact:  # synthesised from the chirp's spectrum: its ends ring
            found += _budgets.chirp_edge_budget(
                radar, scene, motion, acquisition, getattr(self, "range_aliases", 0),
                outside, getattr(self, "alias_tolerance", None))
        approximations, pointing_ratio = self.approximation_budgets(
            radar, scene, motion, acquisition)
        found = tuple(approximations) + tuple(found)
        if not self.exact:  # errors that each hold can add up
            found += (_budgets.combined_budget(found),)
        return _budgets.Validity(self.names[0], found, pointing_ratio)

    def memory(self, plan, radar, scene, acquisition, dtype) -> int:
        """Workspace of one realization [bytes] beyond the output and inputs (default:
        eight complex128 copies of the output)."""
        return int(8 * 16 * acquisition.num_pulses * acquisition.num_range)

    def smaller_chunks(self, plan, acquisition, scene, dtype):
        """Simulators with the same output and smaller chunks, larger first (for the
        memory plan; default: none)."""
        return ()

    def cost(self, plan, radar, scene, acquisition, dtype) -> Cost:
        """Estimated compile and steady time [s] of one call on a 2-core CPU (used by
        ``method="auto"``); a simulator without a cost model is never chosen."""
        return Cost(float("inf"), float("inf"))


class AbstractExactSimulator(AbstractSimulator):
    """An exact model: any motion, squint and moving scatterers; pulses independent; no
    approximation budgets (its window budget only)."""

    # every feature of the model: the exact simulators are the judge
    supports_squint = supports_moving_targets = exact = pulse_local = in_auto = True
