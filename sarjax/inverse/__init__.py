"""Inverse problems: fit platform motion to raw data of a known scene, and its Cramér–Rao
bound.

Unobservable components (named in :attr:`FitResult.fixed`):

* with unknown complex reflectivities, a constant deviation (mean Δy, Δz over the
  illuminated pulses) changes each scatterer's two-way phase by a constant, which its
  reflectivity phase absorbs, and delays its echo by a fraction of a range cell (it trades
  with the scene position): the fit holds those means at zero;
* Δy and Δz separate only through look-angle diversity (δr ≈ −Δy sin ϑ + Δz cos ϑ): with
  all scatterers at one look angle only the line-of-sight profile is fitted.
"""

from ._autofocus import AutofocusResult as AutofocusResult
from ._autofocus import AutofocusWarning as AutofocusWarning
from ._autofocus import autofocus as autofocus
from ._autofocus import pga as pga
from ._autofocus import random_scene as random_scene
from ._autofocus import range_blocks as range_blocks
from ._autofocus import residual_phase_rms as residual_phase_rms
from ._autofocus import sharpness_phase as sharpness_phase
from ._crb import CRB as CRB
from ._crb import crb as crb
from ._fit import FitResult as FitResult
from ._fit import Stage as Stage
from ._fit import align as align
from ._fit import fit_motion as fit_motion
from ._parametrisations import AbstractParametrisation as AbstractParametrisation
from ._parametrisations import BSpline as BSpline
from ._parametrisations import Fourier as Fourier
from ._parametrisations import MotionModel as MotionModel
from ._parametrisations import PerPulse as PerPulse
from ._parametrisations import SinusoidalJitter as SinusoidalJitter
from ._parametrisations import SmoothJitter as SmoothJitter
from ._setup import Fixed as Fixed
