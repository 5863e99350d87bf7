"""Image-quality metrics for focused SAR images (NumPy, outside ``jit``).

The functions take any object with attributes

* ``data``: (n_azimuth, n_range) complex image (NumPy or JAX array),
* ``azimuth``: (n_azimuth,) uniformly spaced azimuth coordinates [m],
* ``range``: (n_range,) uniformly spaced range coordinates [m],

e.g. :class:`sarjax.Image`. The array-comparison helpers also accept plain arrays.

Point-target conventions (:func:`point_target_metrics`, shared with
:mod:`sarjax.reference`):

* The neighbourhood of the target is interpolated by FFT zero-padding (band-limited
  interpolation). The zeros are inserted at the spectral bin of least energy along each
  axis (circularly), so squinted / Doppler-shifted spectra that wrap around Nyquist are
  interpolated correctly.
* IRW: width of the power cut ``|I|²`` at half its peak (−3 dB) [m], crossings linearly
  interpolated on the upsampled grid.
* First nulls: first local minima of the power cut on each side of the peak.
* PSLR: highest power outside the first nulls and within the sidelobe window (below),
  relative to the peak [dB].
* ISLR: energy outside the first nulls but within ``±sidelobe_cells`` resolution cells
  of the peak, over the energy between the first nulls [dB]. One resolution cell is the
  measured IRW of that cut. For an unweighted sinc and 10 cells: ≈ −10.2 dB (−9.68 dB if
  the sidelobes were integrated to infinity).
"""

from __future__ import annotations

import dataclasses
import math
import operator

import numpy as np

__all__ = [
    "PointTargetMetrics",
    "least_energy_bin",
    "nmse_db",
    "nmse_db_near",
    "phase_error_rms",
    "point_target_metrics",
    "upsample_fft",
]


# --------------------------------------------------------------------------------------
# Result container
# --------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class PointTargetMetrics:
    """Quality figures of one point-target response.

    Attributes:
        irw_azimuth: azimuth −3 dB impulse-response width [m].
        irw_range: range −3 dB impulse-response width [m].
        pslr_azimuth: azimuth peak sidelobe ratio [dB].
        pslr_range: range peak sidelobe ratio [dB].
        islr_azimuth: azimuth integrated sidelobe ratio [dB] (module convention).
        islr_range: range integrated sidelobe ratio [dB].
        peak_azimuth: refined azimuth position of the peak [m].
        peak_range: refined range position of the peak [m].
        peak_value: complex band-limited interpolated image value at the refined peak.
        peak_db: ``20 log10 |peak_value|`` [dB].
    """

    irw_azimuth: float
    irw_range: float
    pslr_azimuth: float
    pslr_range: float
    islr_azimuth: float
    islr_range: float
    peak_azimuth: float
    peak_range: float
    peak_value: complex
    peak_db: float

    @staticmethod
    def header() -> str:
        """Column header matching :meth:`as_row`."""
        return (
            f"{'IRW az [m]':>11} {'IRW rg [m]':>11} {'PSLR az [dB]':>12} {'PSLR rg [dB]':>12} "
            f"{'ISLR az [dB]':>12} {'ISLR rg [dB]':>12} {'peak az [m]':>14} {'peak rg [m]':>14} "
            f"{'peak [dB]':>9}"
        )

    def as_row(self) -> str:
        """One fixed-width line (see :meth:`header`); ratios in dB."""
        return (
            f"{self.irw_azimuth:11.4f} {self.irw_range:11.4f} {self.pslr_azimuth:12.2f} "
            f"{self.pslr_range:12.2f} {self.islr_azimuth:12.2f} {self.islr_range:12.2f} "
            f"{self.peak_azimuth:14.4f} {self.peak_range:14.4f} {self.peak_db:9.2f}"
        )

    def as_dict(self) -> dict[str, float | complex]:
        """The fields as a plain dict."""
        return dataclasses.asdict(self)

    def __str__(self) -> str:
        return (
            f"IRW az/rg = {self.irw_azimuth:.4f} / {self.irw_range:.4f} m, "
            f"PSLR az/rg = {self.pslr_azimuth:.2f} / {self.pslr_range:.2f} dB, "
            f"ISLR az/rg = {self.islr_azimuth:.2f} / {self.islr_range:.2f} dB, "
            f"peak at ({self.peak_azimuth:.4f}, {self.peak_range:.4f}) m, "
            f"{self.peak_db:.2f} dB"
        )


# --------------------------------------------------------------------------------------
# Band-limited interpolation with the gap at the least-energy bin
# --------------------------------------------------------------------------------------


def least_energy_bin(spectrum, axis: int = -1) -> int:
    """Index of the DFT bin of least energy along ``axis`` (circularly smoothed).

    The energy ``Σ|X|²`` over all other axes is smoothed with a circular boxcar of
    ``2·max(1, round(n/32)) + 1`` bins, so that the middle of a spectral gap is found
    rather than an isolated leakage minimum.

    Args:
        spectrum: (..., n, ...) DFT along ``axis``.
        axis: spectral axis.

    Returns:
        Bin index in ``[0, n)``.
    """
    x = np.moveaxis(np.asarray(spectrum), axis, 0)
    n = x.shape[0]
    energy = np.sum(np.abs(x.reshape(n, -1)) ** 2, axis=1)
    half = min(max(1, round(n / 32)), (n - 1) // 2)
    smooth = energy.copy()
    for k in range(1, half + 1):
        smooth += np.roll(energy, k) + np.roll(energy, -k)
    return int(np.argmin(smooth))


def _band(n: int, gap: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """DFT bins, their integer frequencies and weights for a band with its gap at ``gap``.

    The band is the contiguous set of frequencies ``gap − n, …, gap``; the gap bin is
    split half/half between its two ends (as the Nyquist bin in the usual scheme).
    """
    freqs = np.arange(gap - n, gap + 1)
    bins = np.mod(freqs, n)
    weights = np.ones(n + 1)
    weights[0] = weights[-1] = 0.5
    return bins, freqs, weights


def _check_gap(gap, n: int) -> int:
    try:
        gap = operator.index(gap)
    except TypeError:
        raise ValueError(f"gap must be an integer DFT bin, got {gap!r}") from None
    if not 0 <= gap < n:
        raise ValueError(f"gap must be in [0, {n}), got {gap}")
    return gap


def upsample_fft(x, factor: int, *, axis: int = -1, gap: int | None = None) -> np.ndarray:
    """Band-limited upsampling by FFT zero-padding.

    The zeros are inserted at the bin ``gap`` (default: :func:`least_energy_bin`), not
    blindly at Nyquist, so a spectrum centred anywhere (squint, residual Doppler) is
    interpolated without aliasing. Output sample ``i`` lies at input position
    ``i / factor`` (the input samples are reproduced exactly at ``i = k·factor``).

    Args:
        x: (..., n, ...) complex samples.
        factor: integer upsampling factor ≥ 1.
        axis: axis to upsample.
        gap: DFT bin where the zeros go, or None for the least-energy bin.

    Returns:
        (..., n·factor, ...) complex128.
    """
    factor = _check_int(factor, "factor", minimum=1)
    x = np.moveaxis(np.asarray(x, dtype=np.complex128), axis, 0)
    n = x.shape[0]
    spectrum = np.fft.fft(x, axis=0)
    gap = least_energy_bin(spectrum, 0) if gap is None else _check_gap(gap, n)
    bins, freqs, weights = _band(n, gap)
    m = n * factor
    padded = np.zeros((m,) + x.shape[1:], dtype=np.complex128)
    wshape = (n + 1,) + (1,) * (x.ndim - 1)
    np.add.at(padded, np.mod(freqs, m), weights.reshape(wshape) * spectrum[bins])
    out = np.fft.ifft(padded, axis=0) * factor
    return np.moveaxis(out, 0, axis)


def _evaluate(x: np.ndarray, positions, axis: int, gap: int) -> np.ndarray:
    """Band-limited interpolant of ``x`` at fractional sample ``positions`` along ``axis``.

    Identical to :func:`upsample_fft` with the same ``gap`` at the positions ``i/factor``.
    """
    x = np.moveaxis(np.asarray(x, dtype=np.complex128), axis, 0)
    n = x.shape[0]
    spectrum = np.fft.fft(x, axis=0)
    bins, freqs, weights = _band(n, gap)
    pos = np.atleast_1d(np.asarray(positions, dtype=float))
    kernel = weights * np.exp(2j * np.pi * np.multiply.outer(pos, freqs) / n) / n
    out = np.tensordot(kernel, spectrum[bins], axes=(1, 0))
    return np.moveaxis(out, 0, axis)


# --------------------------------------------------------------------------------------
# Input handling
# --------------------------------------------------------------------------------------


def _check_int(value, name: str, *, minimum: int) -> int:
    if isinstance(value, bool):
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    try:
        v = operator.index(value)
    except TypeError:
        if isinstance(value, float) and value.is_integer():
            v = int(value)
        else:
            raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}") from None
    if v < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return v


def _check_float(value, name: str, *, positive: bool = False, nonnegative: bool = False) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real number, got {value!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if positive and not v > 0.0:
        raise ValueError(f"{name} must be > 0, got {value!r}")
    if nonnegative and not v >= 0.0:
        raise ValueError(f"{name} must be >= 0, got {value!r}")
    return v


def _is_image(obj) -> bool:
    return all(hasattr(obj, a) for a in ("data", "azimuth", "range")) and not isinstance(
        obj, np.ndarray
    )


def _unpack_image(image, name: str = "image"):
    """(data (n_az, n_rg) complex128, (az0, daz), (rg0, drg)) with checks."""
    if not _is_image(image):
        raise TypeError(
            f"{name} must have .data, .azimuth and .range attributes, got {type(image).__name__}"
        )
    data = np.asarray(image.data)
    if data.ndim != 2:
        raise ValueError(f"{name}.data must be 2-D (n_azimuth, n_range), got shape {data.shape}")
    data = data.astype(np.complex128, copy=False)
    az = _axis(image.azimuth, f"{name}.azimuth", data.shape[0])
    rg = _axis(image.range, f"{name}.range", data.shape[1])
    return data, az, rg


def _axis(values, name: str, n: int) -> tuple[float, float]:
    """(origin, spacing) of a uniform axis of length ``n``."""
    axis = np.asarray(values, dtype=float)
    if axis.ndim != 1 or axis.size != n:
        raise ValueError(f"{name} must be 1-D of length {n} (data shape), got shape {axis.shape}")
    if n < 2:
        raise ValueError(f"{name} must have at least 2 samples, got {n}")
    if not np.all(np.isfinite(axis)):
        raise ValueError(f"{name} contains non-finite values")
    d = (axis[-1] - axis[0]) / (n - 1)
    if d == 0.0:
        raise ValueError(f"{name} has zero spacing")
    dev = np.max(np.abs(axis - (axis[0] + d * np.arange(n))))
    if dev > 1e-6 * abs(d):
        raise ValueError(
            f"{name} must be uniformly spaced: deviation {dev:.3g} m for spacing {d:.6g} m"
        )
    return float(axis[0]), float(d)


def _index_of(value: float, axis: tuple[float, float], n: int, name: str) -> float:
    """Fractional sample index of a coordinate; ValueError outside the image."""
    origin, d = axis
    idx = (value - origin) / d
    if not -0.5 <= idx <= n - 0.5:
        lo, hi = sorted((origin, origin + (n - 1) * d))
        raise ValueError(f"{name}={value!r} m is outside the image extent [{lo:.6g}, {hi:.6g}] m")
    return idx


def _as_array(x, name: str) -> np.ndarray:
    data = x.data if _is_image(x) else x
    arr = np.asarray(data)
    if not (np.issubdtype(arr.dtype, np.number) or arr.dtype == np.bool_):
        raise ValueError(f"{name} must be numeric, got dtype {arr.dtype}")
    arr = arr.astype(np.complex128, copy=False)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains non-finite values")
    return arr


# --------------------------------------------------------------------------------------
# 1-D cut analysis
# --------------------------------------------------------------------------------------


def _parabola(ym: float, y0: float, yp: float) -> tuple[float, float]:
    """Vertex (offset in steps, value) of the parabola through (−1, ym), (0, y0), (1, yp)."""
    den = ym - 2.0 * y0 + yp
    if den == 0.0:
        return 0.0, y0
    delta = 0.5 * (ym - yp) / den
    delta = min(max(delta, -1.0), 1.0)
    return delta, y0 - 0.25 * (ym - yp) * delta


def _integrate(p: np.ndarray, step: float, a: float, b: float) -> float:
    """∫_a^b of the piecewise-linear interpolant of samples ``p`` at ``i·step``."""
    if b <= a:
        return 0.0
    fa, fb = a / step, b / step
    ia, ib = math.ceil(fa), math.floor(fb)
    idx = np.arange(len(p), dtype=float)
    t = np.concatenate(([fa], np.arange(ia, ib + 1, dtype=float), [fb]))
    y = np.interp(t, idx, p)
    return float(np.trapezoid(y, t) * step)


def _cut_metrics(
    p: np.ndarray, step: float, centre: float, sidelobe_cells: float, name: str
) -> tuple[float, float, float, float]:
    """IRW [samples], PSLR [dB], ISLR [dB] and peak position [samples] of a power cut.

    Args:
        p: (m,) power samples at positions ``i·step`` (input-sample units).
        step: grid step [samples] (1/upsample).
        centre: expected peak position [samples].
        sidelobe_cells: sidelobe window half-width [IRWs].
        name: axis name for error messages.
    """
    m = p.size
    c = int(round(centre / step))
    reach = int(math.ceil(1.0 / step))
    lo, hi = max(1, c - reach), min(m - 2, c + reach)
    i0 = lo + int(np.argmax(p[lo : hi + 1]))
    delta, p_pk = _parabola(p[i0 - 1], p[i0], p[i0 + 1])
    t_pk = (i0 + delta) * step
    if not p_pk > 0.0:
        raise ValueError(f"{name} cut has no signal (peak power {p_pk})")
    half = 0.5 * p_pk
    hint = "; increase half_window"

    # −3 dB crossings.
    i = i0
    while i + 1 < m and p[i + 1] >= half:
        i += 1
    if i + 1 >= m:
        raise ValueError(f"{name} cut never falls to −3 dB after the peak{hint}")
    t_right = (i + (p[i] - half) / (p[i] - p[i + 1])) * step
    i = i0
    while i - 1 >= 0 and p[i - 1] >= half:
        i -= 1
    if i - 1 < 0:
        raise ValueError(f"{name} cut never falls to −3 dB before the peak{hint}")
    t_left = (i - (p[i] - half) / (p[i] - p[i - 1])) * step
    irw = t_right - t_left

    # First nulls: first local minima.
    jr = i0
    while jr + 1 < m and p[jr + 1] < p[jr]:
        jr += 1
    jl = i0
    while jl - 1 >= 0 and p[jl - 1] < p[jl]:
        jl -= 1
    if jr + 1 >= m or jl - 1 < 0:
        raise ValueError(f"{name} cut has no first null inside the neighbourhood{hint}")
    null_r = (jr + _parabola(p[jr - 1], p[jr], p[jr + 1])[0]) * step
    null_l = (jl + _parabola(p[jl - 1], p[jl], p[jl + 1])[0]) * step

    window = sidelobe_cells * irw
    a, b = t_pk - window, t_pk + window
    if a < 0.0 or b > (m - 1) * step:
        raise ValueError(
            f"{name} sidelobe window ±{window:.3g} samples (sidelobe_cells={sidelobe_cells}) "
            f"exceeds the neighbourhood of ±{0.5 * m * step:.3g} samples{hint}"
        )
    if window <= max(t_pk - null_l, null_r - t_pk):
        raise ValueError(
            f"{name} sidelobe window (sidelobe_cells={sidelobe_cells}) does not reach "
            "beyond the first nulls"
        )

    # PSLR over the grid samples in the sidelobe window, local maxima refined.
    ia, ib = math.ceil(a / step), math.floor(b / step)
    best = 0.0
    for seg_lo, seg_hi in ((ia, jl - 1), (jr + 1, ib)):
        if seg_hi < seg_lo:
            continue
        k = seg_lo + int(np.argmax(p[seg_lo : seg_hi + 1]))
        value = float(p[k])
        if seg_lo < k < seg_hi or (0 < k < m - 1 and p[k - 1] <= p[k] >= p[k + 1]):
            value = max(value, _parabola(p[k - 1], p[k], p[k + 1])[1])
        best = max(best, value)
    pslr = 10.0 * math.log10(best / p_pk) if best > 0.0 else -math.inf

    main = _integrate(p, step, null_l, null_r)
    sides = _integrate(p, step, a, null_l) + _integrate(p, step, null_r, b)
    islr = 10.0 * math.log10(sides / main) if sides > 0.0 else -math.inf
    return irw, pslr, islr, t_pk


# --------------------------------------------------------------------------------------
# Point-target metrics
# --------------------------------------------------------------------------------------


def point_target_metrics(
    image,
    *,
    azimuth: float,
    range: float,  # shadows the builtin on purpose: mirrors Image.range
    upsample: int = 16,
    half_window: int = 32,
    sidelobe_cells: float = 10.0,
    search: int = 8,
) -> PointTargetMetrics:
    """IRW, PSLR, ISLR and refined peak of the point target near ``(azimuth, range)``.

    Steps: (1) brightest sample within ``±search`` samples of the sample nearest to
    ``(azimuth, range)``; (2) a ``(2·half_window)²`` neighbourhood centred on it
    (zero-padded beyond the image borders); (3) 2-D band-limited upsampling by
    ``upsample`` (spectral zero-padding) with the zeros at the least-energy spectral bin
    of each axis (see :func:`upsample_fft`); (4) the upsampled maximum within ±1 sample
    of the brightest sample, refined by a parabola along each axis; (5) azimuth and
    range cuts of ``|I|²`` through the refined peak (band-limited interpolation, same
    spectral gap), upsampled by ``upsample``; (6) IRW/PSLR/ISLR of each cut with the
    module conventions: IRW at −3 dB with linear interpolation of the crossings; first
    nulls = first local minima; PSLR = highest sidelobe outside the first nulls within
    the sidelobe window; ISLR = energy outside the first nulls but within
    ``±sidelobe_cells × IRW`` of the peak over the energy between the first nulls (one
    resolution cell = the measured IRW of that cut).

    The 2-D upsampled grid is only needed around the peak, so it is evaluated there by
    a matrix DFT (identical values to full FFT zero-padding, without its
    ``(2·half_window·upsample)²`` memory); the cuts are upsampled by FFT zero-padding.
    The neighbourhood truncation limits the accuracy of low sidelobes: with the default
    ``half_window=32`` an unweighted sinc's ISLR is within ≈0.01 dB, a Hamming-weighted
    response's within ≈0.06 dB; use ``half_window=64`` or more for weighted responses.

    Args:
        image: object with ``.data`` (n_azimuth, n_range) complex, ``.azimuth``
            (n_azimuth,) [m] and ``.range`` (n_range,) [m], uniformly spaced.
        azimuth: approximate target azimuth [m], inside the image.
        range: approximate target range [m], inside the image.
        upsample: upsampling factor (integer ≥ 1; ≥ 16 recommended).
        half_window: neighbourhood half-size [samples] (integer ≥ 4); must exceed
            ``sidelobe_cells × IRW`` in samples.
        sidelobe_cells: sidelobe window half-width [IRWs] (> 0).
        search: half-size of the peak search box [samples] (integer ≥ 0).

    Returns:
        :class:`PointTargetMetrics`.

    Raises:
        TypeError: ``image`` lacks ``data``/``azimuth``/``range``.
        ValueError: malformed image or axes, target outside the image, non-finite
            samples in the searched/analysed region, no signal, bad keyword values, or
            a neighbourhood too small for the response.
    """
    data, az_axis, rg_axis = _unpack_image(image)
    n_az, n_rg = data.shape
    upsample = _check_int(upsample, "upsample", minimum=1)
    half_window = _check_int(half_window, "half_window", minimum=4)
    search = _check_int(search, "search", minimum=0)
    sidelobe_cells = _check_float(sidelobe_cells, "sidelobe_cells", positive=True)
    ia = _index_of(_check_float(azimuth, "azimuth"), az_axis, n_az, "azimuth")
    ir = _index_of(_check_float(range, "range"), rg_axis, n_rg, "range")

    # (1) brightest sample in the search box.
    ca, cr = round(ia), round(ir)
    a0, a1 = max(0, ca - search), min(n_az, ca + search + 1)
    r0, r1 = max(0, cr - search), min(n_rg, cr + search + 1)
    box = data[a0:a1, r0:r1]
    if not np.all(np.isfinite(box)):
        raise ValueError("image.data has non-finite samples in the peak search box")
    k = int(np.argmax(np.abs(box)))
    pa, pr = a0 + k // box.shape[1], r0 + k % box.shape[1]
    if not np.abs(data[pa, pr]) > 0.0:
        raise ValueError(f"no signal near azimuth={azimuth!r}, range={range!r} (all zeros)")

    # (2) neighbourhood, zero-padded at the borders; sample hw ↔ image sample (pa, pr).
    hw = half_window
    nb = np.zeros((2 * hw, 2 * hw), dtype=np.complex128)
    sa0, sa1 = max(0, pa - hw), min(n_az, pa + hw)
    sr0, sr1 = max(0, pr - hw), min(n_rg, pr + hw)
    nb[sa0 - (pa - hw) : sa1 - (pa - hw), sr0 - (pr - hw) : sr1 - (pr - hw)] = data[
        sa0:sa1, sr0:sr1
    ]
    if not np.all(np.isfinite(nb)):
        raise ValueError("image.data has non-finite samples in the analysed neighbourhood")

    # (3) 2-D upsampling with the zeros at the least-energy bins, evaluated on the
    # ±(1 + 1/upsample)-sample box around the brightest sample only: a matrix DFT that
    # equals the FFT zero-padded grid (upsample_fft along both axes) at those points.
    spectrum = np.fft.fft2(nb)
    gap_a = least_energy_bin(spectrum, 0)
    gap_r = least_energy_bin(spectrum, 1)
    reach = upsample + 1
    fine = hw + np.arange(-reach, reach + 1) / upsample  # neighbourhood samples
    box = _evaluate(_evaluate(nb, fine, axis=0, gap=gap_a), fine, axis=1, gap=gap_r)

    # (4) maximum within ±1 sample of the brightest sample, parabolic refinement.
    pw = np.abs(box) ** 2
    inner = pw[1:-1, 1:-1]
    k = int(np.argmax(inner))
    ua, ur = 1 + k // inner.shape[1], 1 + k % inner.shape[1]
    da, _ = _parabola(pw[ua - 1, ur], pw[ua, ur], pw[ua + 1, ur])
    dr, _ = _parabola(pw[ua, ur - 1], pw[ua, ur], pw[ua, ur + 1])
    ta = hw + (ua - reach + da) / upsample  # refined peak [neighbourhood samples]
    tr = hw + (ur - reach + dr) / upsample

    # (5) cuts through the refined peak.
    col = _evaluate(nb, [tr], axis=1, gap=gap_r)  # (2hw, 1): range fixed at tr
    row = _evaluate(nb, [ta], axis=0, gap=gap_a)  # (1, 2hw): azimuth fixed at ta
    peak_value = complex(_evaluate(col, [ta], axis=0, gap=gap_a)[0, 0])
    cut_a = np.abs(upsample_fft(col[:, 0], upsample, gap=gap_a)) ** 2
    cut_r = np.abs(upsample_fft(row[0, :], upsample, gap=gap_r)) ** 2

    # (6) per-cut metrics.
    step = 1.0 / upsample
    irw_a, pslr_a, islr_a, _ = _cut_metrics(cut_a, step, ta, sidelobe_cells, "azimuth")
    irw_r, pslr_r, islr_r, _ = _cut_metrics(cut_r, step, tr, sidelobe_cells, "range")

    (az0, daz), (rg0, drg) = az_axis, rg_axis
    return PointTargetMetrics(
        irw_azimuth=float(irw_a * abs(daz)),
        irw_range=float(irw_r * abs(drg)),
        pslr_azimuth=float(pslr_a),
        pslr_range=float(pslr_r),
        islr_azimuth=float(islr_a),
        islr_range=float(islr_r),
        peak_azimuth=float(az0 + (pa - hw + ta) * daz),
        peak_range=float(rg0 + (pr - hw + tr) * drg),
        peak_value=peak_value,
        peak_db=float(20.0 * math.log10(abs(peak_value))) if peak_value != 0 else -math.inf,
    )


# --------------------------------------------------------------------------------------
# Image comparisons
# --------------------------------------------------------------------------------------


def nmse_db(test, reference) -> float:
    """Normalised mean-square error ``10 log10(Σ|a − b|² / Σ|b|²)`` [dB].

    Args:
        test: (...) complex array ``a`` or image-like (its ``.data`` is used).
        reference: (...) complex array ``b`` of the same shape, or image-like.

    Returns:
        NMSE [dB]; ``-inf`` for identical inputs.
    """
    a = _as_array(test, "test")
    b = _as_array(reference, "reference")
    if a.shape != b.shape:
        raise ValueError(f"test shape {a.shape} differs from reference shape {b.shape}")
    ref_energy = float(np.sum(np.abs(b) ** 2))
    if not ref_energy > 0.0:
        raise ValueError("reference has zero energy")
    err = float(np.sum(np.abs(a - b) ** 2))
    return 10.0 * math.log10(err / ref_energy) if err > 0.0 else -math.inf


def nmse_db_near(
    test_img, ref_img, *, azimuth: float, range: float, cells: int = 16
) -> float:
    """NMSE [dB] within a box around a position.

    The box is ``±cells`` samples (here one resolution cell = one sample of the image
    grid) around the reference-grid sample nearest to ``(azimuth, range)``, clipped at
    the image borders.

    Args:
        test_img: image-like, same shape and axes as ``ref_img``.
        ref_img: image-like reference.
        azimuth: box centre azimuth [m].
        range: box centre range [m].
        cells: box half-size [samples] (integer ≥ 0).

    Returns:
        NMSE [dB] over the ``(2·cells + 1)²`` box (fewer at borders).
    """
    a, az_t, rg_t = _unpack_image(test_img, "test_img")
    b, az_r, rg_r = _unpack_image(ref_img, "ref_img")
    if a.shape != b.shape:
        raise ValueError(f"test_img shape {a.shape} differs from ref_img shape {b.shape}")
    for name, t, r in (("azimuth", az_t, az_r), ("range", rg_t, rg_r)):
        tol = 1e-6 * abs(r[1])
        if abs(t[0] - r[0]) > tol or abs(t[1] - r[1]) > tol:
            raise ValueError(f"test_img.{name} axis differs from ref_img.{name} axis")
    cells = _check_int(cells, "cells", minimum=0)
    ca = round(_index_of(_check_float(azimuth, "azimuth"), az_r, b.shape[0], "azimuth"))
    cr = round(_index_of(_check_float(range, "range"), rg_r, b.shape[1], "range"))
    sa = slice(max(0, ca - cells), min(b.shape[0], ca + cells + 1))
    sr = slice(max(0, cr - cells), min(b.shape[1], cr + cells + 1))
    return nmse_db(a[sa, sr], b[sa, sr])


def phase_error_rms(test, reference, *, within_db: float = 20.0) -> float:
    """RMS phase difference [rad] over the bright part of the reference.

    ``sqrt(mean(angle(a · conj(b))²))`` (wrapped to (−π, π]) over the samples where
    ``|b| ≥ max|b| · 10^(−within_db/20)``.

    Args:
        test: (...) complex array ``a`` or image-like.
        reference: (...) complex array ``b`` of the same shape, or image-like.
        within_db: dynamic range below the reference maximum to include [dB] (≥ 0).

    Returns:
        RMS phase error [rad].
    """
    a = _as_array(test, "test")
    b = _as_array(reference, "reference")
    if a.shape != b.shape:
        raise ValueError(f"test shape {a.shape} differs from reference shape {b.shape}")
    within_db = _check_float(within_db, "within_db", nonnegative=True)
    mag = np.abs(b)
    peak = float(np.max(mag)) if mag.size else 0.0
    if not peak > 0.0:
        raise ValueError("reference is identically zero")
    mask = mag >= peak * 10.0 ** (-within_db / 20.0)
    phase = np.angle(a[mask] * np.conj(b[mask]))
    return float(np.sqrt(np.mean(phase**2)))


def azimuth_ambiguity_ratio(radar, processed_bandwidth=None, *, orders=64, samples=2001):
    """Azimuth-ambiguity-to-signal ratio (AASR, linear) of a radar and its pattern:

        AASR = Σ_{k≠0} ∫_{−B/2}^{B/2} |H(f + k·PRF)|² df / ∫_{−B/2}^{B/2} |H(f)|² df,

    ``H(f)`` the azimuth spectrum of a point target's echo at Doppler ``f`` from the
    centroid ``2v sin φ_d / λ``: the two-way pattern at the stationary point,
    ``W²(u*)``, ``u* = (L/λ)(T − t)/(1 + tT)``, ``t = ξ/√(k₀² − ξ²)``,
    ``ξ = k₀ sin φ_d + 2π f / v``, times the stationary-phase amplitude
    ``(k₀² − ξ²)^{−3/4}``. The exact model samples the echo at the PRF, so the energy at
    ``f + k·PRF`` folds onto ``f``: after azimuth compression over the band ``B`` it
    appears as ghosts displaced by ``k·PRF·λr/(2v)`` along track, with this energy
    relative to the target's.

    Args:
        radar: :class:`~sarjax.Radar` (its pattern, PRF, velocity, wavelength, squint).
        processed_bandwidth: B [Hz] (default: the PRF).
        orders: ambiguity orders ±1 … ±orders summed.
        samples: integration points per band.

    Returns:
        The AASR (linear; ``10 log10`` for dB).
    """
    import jax.numpy as jnp

    prf = float(radar.prf)
    band = prf if processed_bandwidth is None else float(processed_bandwidth)
    v = float(radar.velocity)
    k0 = float(radar.wavenumber)
    squint = float(np.asarray(radar.squint))
    ratio = float(radar.antenna_length) / float(radar.wavelength)
    f = np.linspace(-band / 2, band / 2, samples)

    def energy(shift):
        xi = k0 * math.sin(squint) + 2 * math.pi * (f + shift) / v
        inside = np.abs(xi) < k0
        kz2 = np.where(inside, k0**2 - xi**2, 1.0)
        t = xi / np.sqrt(kz2)
        u = ratio * (math.tan(squint) - t) / (1 + t * math.tan(squint))
        gain = np.asarray(radar.pattern(jnp.asarray(u)))
        spectrum = np.where(inside, np.abs(gain) ** 2 / kz2**1.5, 0.0)
        return float(np.trapezoid(spectrum, f))

    signal = energy(0.0)
    ghosts = sum(energy(k * prf) for k in range(-orders, orders + 1) if k)
    return ghosts / signal
