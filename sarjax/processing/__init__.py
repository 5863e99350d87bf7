"""Focusing for validation: range compression, ω-k, back-projection, motion compensation."""

from ._backprojection import backprojection as backprojection
from ._exact_backprojection import backprojection_exact as backprojection_exact
from ._exact_backprojection import doppler_centroid as doppler_centroid
from ._exact_backprojection import moving_target_shift as moving_target_shift
from ._focus import focus as focus
from ._focus import range_compressed as range_compressed
from ._motion_compensation import first_order as first_order
from ._motion_compensation import second_order as second_order
from ._omega_k import omega_k as omega_k
from ._range_compression import range_compress as range_compress
