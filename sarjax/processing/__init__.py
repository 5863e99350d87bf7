"""Focusing for validation: range compression, ω-k, back-projection, motion compensation."""

from ._backprojection import backprojection as backprojection
from ._focus import focus as focus
from ._focus import range_compressed as range_compressed
from ._motion_compensation import first_order as first_order
from ._motion_compensation import second_order as second_order
from ._omega_k import omega_k as omega_k
from ._range_compression import range_compress as range_compress
