"""Raw-data simulators (physics.md §3–10)."""

from ._base import AbstractSimulator as AbstractSimulator
from ._chirp_scaling import ChirpScaling as ChirpScaling
from ._fourier import Fourier2D as Fourier2D
from ._fourier import ModerateDeviation as ModerateDeviation
from ._fourier import SmallDeviation as SmallDeviation
from ._high_speed import HighSpeed as HighSpeed
from ._nufft import TimeDomainNUFFT as TimeDomainNUFFT
from ._squint import SquintFourier2D as SquintFourier2D
from ._squint import SquintModerateDeviation as SquintModerateDeviation
from ._squint import SquintSmallDeviation as SquintSmallDeviation
from ._time_domain import TimeDomain as TimeDomain
