"""Raw-data simulators (physics.md §3–10): the classes, and the registry built from
their declarations."""

from ._base import MOTION_KINDS as MOTION_KINDS
from ._base import AbstractPlan as AbstractPlan
from ._base import AbstractSimulator as AbstractSimulator
from ._base import Cost as Cost
from ._budgets import Budget as Budget
from ._budgets import Validity as Validity
from ._chirp_scaling import ChirpScaling as ChirpScaling
from ._fourier import AbstractFourierSimulator as AbstractFourierSimulator
from ._fourier import Fourier2D as Fourier2D
from ._fourier import ModerateDeviation as ModerateDeviation
from ._fourier import SmallDeviation as SmallDeviation
from ._high_speed import HighSpeed as HighSpeed
from ._nufft import TimeDomainNUFFT as TimeDomainNUFFT
from ._registry import build as build
from ._registry import method_names as method_names
from ._registry import simulator_class as simulator_class
from ._time_domain import TimeDomain as TimeDomain


def __getattr__(name):
    """Names that moved: the squinted classes are the classes themselves now (squint is
    a parameter of the one engine)."""
    import warnings

    moved = {"SquintFourier2D": Fourier2D, "SquintSmallDeviation": SmallDeviation,
             "SquintModerateDeviation": ModerateDeviation}
    if name in moved:
        warnings.warn(f"sarjax.simulators.{name} is deprecated: use "
                      f"{moved[name].__name__} (any squint)", DeprecationWarning, stacklevel=2)
        return moved[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
