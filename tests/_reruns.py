"""Comparing two runs of the same computation: equal to rounding, not bit for bit.

XLA's CPU FFT (DUCC) transforms the rows of a batch in SIMD blocks and splits the rows
across its thread pool at run time. A row that falls in a block's scalar remainder is
rounded differently from one transformed in a vector block, and where the split falls
depends on how many workers pick up the work, i.e. on the machine's load. Measured on
the development machine (jax 0.10.2, 2 cores, another process busy): an inverse FFT of
a c128[60, 1080] batch along its rows differs in its last bits in rows 28, 29, 58 and 59
on 149 of 300 reruns, never for 56 or 64 rows; a 60-pulse ``fourier_2d`` run differed
from its rerun by 6.7e-16 at a peak of 2e-3 (3e-13 of the peak).

So a rerun (another call, a recompiled program, a new process) is held to
``RERUN_RTOL`` of the peak magnitude: 30× the largest difference measured, and 10⁵× below
the smallest change any option or plan makes (≳ 1e-6 of the peak).
"""

from __future__ import annotations

import numpy as np

RERUN_RTOL = 1e-11  # of the peak |desired|


def assert_same_to_rounding(actual, desired, rtol=RERUN_RTOL):
    """``actual`` equals ``desired`` within ``rtol`` × max|desired| everywhere (same shape
    and dtype)."""
    actual, desired = np.asarray(actual), np.asarray(desired)
    assert actual.shape == desired.shape and actual.dtype == desired.dtype, (
        f"{actual.shape} {actual.dtype} != {desired.shape} {desired.dtype}")
    peak = float(np.abs(desired).max()) if desired.size else 0.0
    np.testing.assert_allclose(actual, desired, rtol=0, atol=rtol * peak)
