"""Export to NGA standard files through sarkit: CPHD 1.1.0 (FX domain) and CRSD 1.0 of
raw data, SICD 1.4.0 of focused images.

The flat sarjax geometry is laid on the WGS-84 Earth by a
:class:`GeoReference` (see :mod:`sarjax.export._frame`); the conventions (phase sign,
reference point, which track goes into the metadata, pulse timing) are in the docstrings
of :func:`to_cphd`, :func:`to_crsd` and :func:`to_sicd`. A batched simulation is
exported one realization at a time (:func:`realization`).
"""

from ._common import realization as realization
from ._cphd import to_cphd as to_cphd
from ._crsd import to_crsd as to_crsd
from ._frame import GeoReference as GeoReference
from ._frame import LocalFrame as LocalFrame
from ._sicd import to_sicd as to_sicd

__all__ = ["GeoReference", "LocalFrame", "realization", "to_cphd", "to_crsd", "to_sicd"]
