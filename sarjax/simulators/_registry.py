"""The registry of simulators, built from the classes' own declarations (``names``).

:func:`sarjax.simulate`, :func:`sarjax.validity`, :func:`sarjax.simulation_memory`,
``method="auto"`` and the command line all resolve a method here. Adding a simulator is
one class (with its ``names``) added to ``SIMULATORS`` below, and its tests.
"""

from __future__ import annotations

import dataclasses

from ._base import AbstractSimulator
from ._chirp_scaling import ChirpScaling
from ._fourier import Fourier2D, ModerateDeviation, SmallDeviation
from ._high_speed import HighSpeed
from ._nufft import TimeDomainNUFFT
from ._time_domain import TimeDomain

# the simulator classes, in the order ``method="auto"`` breaks ties (cheaper first)
SIMULATORS: tuple[type[AbstractSimulator], ...] = (
    Fourier2D, SmallDeviation, ModerateDeviation, ChirpScaling, HighSpeed, TimeDomain,
    TimeDomainNUFFT,
)

AUTO = "auto"


def _build():
    by_name = {}
    for cls in SIMULATORS:
        if not cls.names:
            raise TypeError(f"{cls.__name__} declares no method names")
        for name in cls.names:
            if name in by_name or name == AUTO:
                raise TypeError(f"method name {name!r} of {cls.__name__} is taken")
            by_name[name] = cls
    return by_name


_BY_NAME = _build()


def method_names(*, aliases: bool = True) -> tuple[str, ...]:
    """Every method name :func:`sarjax.simulate` accepts (without ``"auto"``); with
    ``aliases=False`` only each class's canonical (first) name."""
    if aliases:
        return tuple(_BY_NAME)
    return tuple(cls.names[0] for cls in SIMULATORS)


def simulator_class(method) -> type[AbstractSimulator]:
    """The class of a method name; ValueError naming the choices for an unknown one."""
    try:
        return _BY_NAME[method]
    except (KeyError, TypeError):
        raise ValueError(
            f"unknown method={method!r}; choose one of {sorted(_BY_NAME) + [AUTO]} or pass "
            "a simulator instance"
        ) from None


def canonical_name(method) -> str:
    """The canonical name of a method name or simulator instance."""
    if isinstance(method, AbstractSimulator):
        return type(method).names[0] if type(method).names else type(method).__name__
    return simulator_class(method).names[0]


def build(method, options=None) -> AbstractSimulator:
    """A simulator instance from a method name (with ``options``) or an instance."""
    options = dict(options or {})
    if isinstance(method, AbstractSimulator):
        if options:
            raise ValueError(f"options {sorted(options)} given with a simulator instance")
        return method
    cls = simulator_class(method)
    try:
        return cls(**options)
    except TypeError:
        known = sorted(f.name for f in dataclasses.fields(cls) if not f.name.startswith("_"))
        raise ValueError(
            f"unknown option(s) {sorted(options)} for method={method!r}; known: {known}"
        ) from None


def auto_candidates() -> tuple[type[AbstractSimulator], ...]:
    """The classes ``method="auto"`` chooses among (their budgets are measured)."""
    return tuple(cls for cls in SIMULATORS if cls.in_auto)
