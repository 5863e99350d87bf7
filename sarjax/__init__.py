"""sarjax: differentiable stripmap SAR raw-data simulation and inversion in JAX.

Importing sarjax enables ``jax_enable_x64``: slant ranges and phases are formed in
float64 (a float32 slant range at 5 km is already 0.2 rad of phase). The per-sample
kernels can still run in complex64 (``dtype=`` of :func:`simulate`).
"""

from typing import TYPE_CHECKING as _TYPE_CHECKING

import jax as _jax

_jax.config.update("jax_enable_x64", True)

from . import constants as constants  # noqa: E402
from . import geometry as geometry  # noqa: E402
from . import metrics as metrics  # noqa: E402
from . import presets as presets  # noqa: E402
from ._allocator import FreedMemoryWarning as FreedMemoryWarning  # noqa: E402
from ._allocator import retain_freed_memory as retain_freed_memory  # noqa: E402
from ._compilation_cache import enable_compilation_cache as enable_compilation_cache  # noqa: E402
from ._data import Acquisition as Acquisition  # noqa: E402
from ._data import Image as Image  # noqa: E402
from ._data import RawData as RawData  # noqa: E402
from ._simulate import simulate as simulate  # noqa: E402
from ._simulate import simulation_memory as simulation_memory  # noqa: E402
from ._validate import FocusWarning as FocusWarning  # noqa: E402
from ._validate import SwathWarning as SwathWarning  # noqa: E402
from ._validate import ValidityWarning as ValidityWarning  # noqa: E402
from .antenna import AbstractPattern as AbstractPattern  # noqa: E402
from .antenna import GaussianPattern as GaussianPattern  # noqa: E402
from .antenna import Sinc2Pattern as Sinc2Pattern  # noqa: E402
from .metrics import point_target_metrics as point_target_metrics  # noqa: E402
from .motion import Motion as Motion  # noqa: E402
from .motion import seed_pointing_jitter as seed_pointing_jitter  # noqa: E402
from .motion import sinusoidal_pointing as sinusoidal_pointing  # noqa: E402
from .motion import smooth_deviation as smooth_deviation  # noqa: E402
from .radar import Radar as Radar  # noqa: E402
from .scene import PointTargets as PointTargets  # noqa: E402
from .scene import ReflectivityGrid as ReflectivityGrid  # noqa: E402
from .scene import pyramid_height as pyramid_height  # noqa: E402
from .simulators import AbstractSimulator as AbstractSimulator  # noqa: E402
from .simulators import Fourier2D as Fourier2D  # noqa: E402
from .simulators import ModerateDeviation as ModerateDeviation  # noqa: E402
from .simulators import SmallDeviation as SmallDeviation  # noqa: E402
from .simulators import TimeDomain as TimeDomain  # noqa: E402
from .simulators import TimeDomainNUFFT as TimeDomainNUFFT  # noqa: E402
from .validity import Budget as Budget  # noqa: E402
from .validity import Validity as Validity  # noqa: E402
from .validity import explain_choice as explain_choice  # noqa: E402
from .validity import validity as validity  # noqa: E402

if _TYPE_CHECKING:  # the names imported on first use (below), for checkers and the docs
    from . import inverse as inverse
    from . import processing as processing
    from .inverse import BSpline as BSpline
    from .inverse import Fourier as Fourier
    from .inverse import MotionModel as MotionModel
    from .inverse import PerPulse as PerPulse
    from .inverse import SinusoidalJitter as SinusoidalJitter
    from .inverse import SmoothJitter as SmoothJitter
    from .inverse import crb as crb
    from .inverse import fit_motion as fit_motion
    from .processing import focus as focus

try:
    from importlib.metadata import PackageNotFoundError as _NotFound
    from importlib.metadata import version as _version

    __version__ = _version("sarjax")
except _NotFound:  # a source tree that is not installed
    __version__ = "0+unknown"

# the optional-dependency modules are imported when first used (xarray, matplotlib,
# sarkit load in seconds): ``sj.io``, ``sj.export``, ``sj.plot``; so are focusing and the
# inverse problems (scipy, optimistix: seconds that ``sarjax simulate`` does not need)
_LAZY = ("io", "export", "plot", "inverse", "processing")
_LAZY_NAMES = {
    **dict.fromkeys(("BSpline", "Fourier", "MotionModel", "PerPulse", "SinusoidalJitter",
                     "SmoothJitter", "crb", "fit_motion"), "inverse"),
    "focus": "processing",
}


def __getattr__(name):
    if name in _LAZY or name in _LAZY_NAMES:
        import importlib

        module = importlib.import_module(f".{_LAZY_NAMES.get(name, name)}", __name__)
        value = module if name in _LAZY else getattr(module, name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'sarjax' has no attribute {name!r}")


def __dir__():
    return sorted({*globals(), *_LAZY, *_LAZY_NAMES})

