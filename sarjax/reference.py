"""Analytic expectations for point-target responses (NumPy only).

The impulse response (IRF) of a focused point target along one image axis is the
inverse Fourier transform of its (possibly weighted) spectral support. With a
spectrum of bandwidth ``B`` [cycles/m] and weighting ``w(ν)`` on ``ν ∈ [−½, ½]``
(ν = f/B, normalised frequency), the IRF in the normalised coordinate ``u = B·x`` is

    h(u) = ∫_{−½}^{½} w(ν) exp(j 2π ν u) dν,

which is ``sinc(u) = sin(πu)/(πu)`` for ``w ≡ 1``. Everything here is expressed in
``u`` (units of ``1/B``) and then converted with the bandwidth.

The metric conventions are exactly those of :func:`sarjax.metrics.point_target_metrics`:

* IRW: width of the power ``|h|²`` at half its peak (−3 dB), ``0.8859/B`` for a sinc.
* PSLR: highest power outside the first nulls (first local minima of ``|h|²`` on each
  side of the peak) and within the sidelobe window (below), relative to the peak [dB].
* ISLR: energy outside the first nulls but within ``±sidelobe_cells × IRW`` of the peak,
  over the energy between the first nulls [dB]. The window is measured in resolution
  cells, one cell being the IRW itself. For a sinc and 10 cells this is ≈ −10.2 dB
  (−9.68 dB if the sidelobes are integrated to infinity, see ``islr_infinite_db``).

All expectations are computed numerically (root bracketing, golden-section search and
composite Gauss–Legendre quadrature), so the same code serves unweighted and weighted
(Hamming, Taylor, any cosine-series or user-supplied) spectra.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable

import numpy as np

from sarjax.constants import SPEED_OF_LIGHT

__all__ = [
    "CosineWeighting",
    "IRFExpectation",
    "hamming_weighting",
    "irf_expectation",
    "numerical_irf",
    "range_irw_theory",
    "sinc_image",
    "sinc_irf_expectation",
    "taylor_weighting",
    "weighted_irf_expectation",
]


# --------------------------------------------------------------------------------------
# Spectral weightings
# --------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class CosineWeighting:
    """Spectral weighting written as a cosine series on the normalised band.

    ``w(ν) = Σ_m a_m cos(2π m ν)`` for ``|ν| ≤ ½`` and 0 outside, with ``ν = f/B``.
    Its IRF has the closed form (see :meth:`irf`)

        h(u) = a_0 sinc(u) + Σ_{m≥1} (a_m/2) [sinc(u − m) + sinc(u + m)].

    Attributes:
        coefficients: (n_terms,) the ``a_m``, ``a_0`` first (dimensionless).
        name: label used in reprs and reports.
    """

    coefficients: tuple[float, ...]
    name: str = "cosine"

    def __post_init__(self):
        coeffs = tuple(float(c) for c in self.coefficients)
        if len(coeffs) == 0 or not all(math.isfinite(c) for c in coeffs):
            raise ValueError(f"coefficients must be a non-empty finite sequence, got {coeffs}")
        object.__setattr__(self, "coefficients", coeffs)

    def __call__(self, nu):
        """Weighting ``w(ν)``.

        Args:
            nu: (...) normalised frequency ``f/B`` (dimensionless).

        Returns:
            (...) float weights, 0 outside ``|ν| ≤ ½``.
        """
        nu = np.asarray(nu, dtype=float)
        w = np.zeros_like(nu)
        for m, a in enumerate(self.coefficients):
            w = w + a * np.cos(2.0 * np.pi * m * nu)
        return np.where(np.abs(nu) <= 0.5, w, 0.0)

    def irf(self, u):
        """Closed-form IRF ``h(u)`` (real, not normalised: ``h(0) = a_0``).

        Args:
            u: (...) position in units of ``1/B`` (dimensionless).

        Returns:
            (...) float amplitude.
        """
        u = np.asarray(u, dtype=float)
        h = self.coefficients[0] * np.sinc(u)
        for m, a in enumerate(self.coefficients[1:], start=1):
            h = h + 0.5 * a * (np.sinc(u - m) + np.sinc(u + m))
        return h


def hamming_weighting(alpha: float = 0.54) -> CosineWeighting:
    """Generalised Hamming weighting ``w(ν) = α + (1 − α) cos(2πν)``.

    Args:
        alpha: pedestal coefficient (0.54 = Hamming, 0.5 = Hann).

    Returns:
        The :class:`CosineWeighting`.
    """
    alpha = float(alpha)
    if not (0.0 < alpha <= 1.0):
        raise ValueError(f"alpha must be in (0, 1], got {alpha}")
    return CosineWeighting((alpha, 1.0 - alpha), name=f"hamming({alpha:g})")


def taylor_weighting(nbar: int = 4, sll_db: float = -35.0) -> CosineWeighting:
    """Taylor weighting with ``nbar − 1`` cosine terms (standard SAR formulation).

    ``w(ν) = 1 + 2 Σ_{m=1}^{n̄−1} F_m cos(2π m ν)`` with the usual Taylor coefficients
    ``F_m`` for a design sidelobe level ``sll_db``.

    Args:
        nbar: number of nearly constant-level sidelobes ``n̄`` (≥ 1).
        sll_db: design peak sidelobe level [dB], negative (e.g. −35).

    Returns:
        The :class:`CosineWeighting`.
    """
    if int(nbar) != nbar or nbar < 1:
        raise ValueError(f"nbar must be an integer >= 1, got {nbar}")
    nbar = int(nbar)
    sll_db = float(sll_db)
    if not (math.isfinite(sll_db) and sll_db < 0.0):
        raise ValueError(f"sll_db must be a finite negative level in dB, got {sll_db}")
    a = math.acosh(10.0 ** (-sll_db / 20.0)) / math.pi
    sigma2 = nbar**2 / (a**2 + (nbar - 0.5) ** 2)
    coeffs = [1.0]
    for m in range(1, nbar):
        num = (-1.0) ** (m + 1)
        for n in range(1, nbar):
            num *= 1.0 - (m**2 / sigma2) / (a**2 + (n - 0.5) ** 2)
        den = 2.0
        for n in range(1, nbar):
            if n != m:
                den *= 1.0 - m**2 / n**2
        coeffs.append(2.0 * num / den)
    return CosineWeighting(tuple(coeffs), name=f"taylor(nbar={nbar}, sll={sll_db:g} dB)")


def _resolve_weighting(weighting) -> Callable | None:
    """``None``/"rect" → None, "hamming"/"taylor" → defaults, callables unchanged."""
    if weighting is None:
        return None
    if isinstance(weighting, str):
        key = weighting.lower()
        if key in ("rect", "rectangular", "none", "uniform"):
            return None
        if key == "hamming":
            return hamming_weighting()
        if key == "taylor":
            return taylor_weighting()
        raise ValueError(f"unknown weighting name {weighting!r} (rect, hamming, taylor)")
    if callable(weighting):
        return weighting
    raise ValueError(f"weighting must be None, a name or a callable, got {weighting!r}")


# --------------------------------------------------------------------------------------
# Numerical IRF of an arbitrary weighting
# --------------------------------------------------------------------------------------


@functools.lru_cache(maxsize=16)
def _gauss_legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    x, w = np.polynomial.legendre.leggauss(n)
    return x, w


def numerical_irf(weighting: Callable, *, nodes: int = 512) -> Callable[[np.ndarray], np.ndarray]:
    """IRF of a spectral weighting by numerical Fourier integration.

    Evaluates ``h(u) = ∫_{−½}^{½} w(ν) exp(j2πνu) dν`` with ``nodes``-point
    Gauss–Legendre quadrature, which is exact to rounding for ``|u| ≲ nodes/4``
    (the integrand is smooth on the closed band).

    Args:
        weighting: callable ``w(ν)``, vectorised over a 1-D array of ``ν ∈ [−½, ½]``.
        nodes: number of quadrature nodes.

    Returns:
        Callable mapping (...) ``u`` [units of 1/B] to (...) complex ``h(u)``.
    """
    x, wq = _gauss_legendre(int(nodes))
    nu = 0.5 * x
    weights = 0.5 * wq * np.asarray(weighting(nu), dtype=complex)
    if weights.shape != nu.shape or not np.all(np.isfinite(weights)):
        raise ValueError("weighting must return finite values with the shape of its input")
    limit = nodes / 4.0

    def irf(u):
        u = np.asarray(u, dtype=float)
        if u.size and np.max(np.abs(u)) > limit:
            raise ValueError(
                f"|u| up to {np.max(np.abs(u)):g} exceeds the quadrature limit {limit:g}"
            )
        phase = np.exp(2j * np.pi * np.multiply.outer(u, nu))
        return phase @ weights

    return irf


# --------------------------------------------------------------------------------------
# Expectations
# --------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class IRFExpectation:
    """Analytic point-target quality figures of a 1-D IRF.

    Attributes:
        irw_factor: −3 dB width of ``|h|²`` times the bandwidth (0.8859 for a sinc).
        pslr_db: peak sidelobe ratio [dB] (−13.26 for a sinc).
        islr_db: integrated sidelobe ratio [dB], sidelobes within
            ``±sidelobe_cells × IRW`` (module convention).
        islr_infinite_db: ISLR with the sidelobes integrated to infinity [dB]
            (−9.68 for a sinc), from Parseval's theorem.
        first_null: distance from the peak to the first null, times the bandwidth
            (1.0 for a sinc); the mean of the two sides.
        sidelobe_cells: half-width of the sidelobe window, in IRWs.
    """

    irw_factor: float
    pslr_db: float
    islr_db: float
    islr_infinite_db: float
    first_null: float
    sidelobe_cells: float

    def irw(self, bandwidth: float) -> float:
        """IRW [m] for a bandwidth [cycles/m]."""
        return self.irw_factor / float(bandwidth)


def _bisect(f: Callable[[float], float], a: float, b: float, iterations: int = 80) -> float:
    fa = f(a)
    for _ in range(iterations):
        m = 0.5 * (a + b)
        fm = f(m)
        if (fm > 0.0) == (fa > 0.0):
            a, fa = m, fm
        else:
            b = m
    return 0.5 * (a + b)


def _golden_min(f: Callable[[float], float], a: float, b: float, iterations: int = 90) -> float:
    g = (math.sqrt(5.0) - 1.0) / 2.0
    c, d = b - g * (b - a), a + g * (b - a)
    fc, fd = f(c), f(d)
    for _ in range(iterations):
        if fc < fd:
            b, d, fd = d, c, fc
            c = b - g * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + g * (b - a)
            fd = f(d)
    return 0.5 * (a + b)


def _integrate(f: Callable[[np.ndarray], np.ndarray], a: float, b: float) -> float:
    """∫_a^b f by composite 32-point Gauss–Legendre on ≤ 0.25-wide panels."""
    if b <= a:
        return 0.0
    n_panels = max(1, math.ceil((b - a) / 0.25))
    edges = np.linspace(a, b, n_panels + 1)
    x, w = _gauss_legendre(32)
    half = 0.5 * np.diff(edges)
    mid = 0.5 * (edges[1:] + edges[:-1])
    pts = mid[:, None] + half[:, None] * x[None, :]
    return float(np.sum(half[:, None] * w[None, :] * f(pts)))


def irf_expectation(
    irf: Callable[[np.ndarray], np.ndarray],
    *,
    total_energy: float | None = None,
    sidelobe_cells: float = 10.0,
    step: float = 1e-2,
) -> IRFExpectation:
    """Quality figures of an IRF given as a function of ``u = B·x``.

    The peak is searched near ``u = 0``; the half-power points are bracketed on a grid
    of ``step`` and bisected; the first nulls are the first local minima of ``|h|²`` on
    each side (golden-section refined); sidelobe maxima are golden-section refined;
    energies use composite Gauss–Legendre quadrature.

    Args:
        irf: vectorised callable, (...) ``u`` → (...) real or complex amplitude.
        total_energy: ``∫|h|² du`` over the whole line (Parseval), used for
            ``islr_infinite_db``; NaN is reported when omitted.
        sidelobe_cells: sidelobe window half-width in IRWs (> 0).
        step: search grid step in ``u``.

    Returns:
        The :class:`IRFExpectation`.
    """
    sidelobe_cells = float(sidelobe_cells)
    if not (math.isfinite(sidelobe_cells) and sidelobe_cells > 0.0):
        raise ValueError(f"sidelobe_cells must be finite and > 0, got {sidelobe_cells}")

    def power(u):
        return np.abs(np.asarray(irf(np.asarray(u, dtype=float)))) ** 2

    def p1(u: float) -> float:
        return float(power(np.array([u]))[0])

    # Peak: grid maximum near the origin, then golden section.
    grid = np.arange(-0.5, 0.5 + step / 2, step)
    g0 = grid[int(np.argmax(power(grid)))]
    u_pk = _golden_min(lambda u: -p1(u), g0 - step, g0 + step)
    p_pk = p1(u_pk)
    if not (p_pk > 0.0 and math.isfinite(p_pk)):
        raise ValueError(f"IRF peak power must be finite and > 0, got {p_pk}")

    def side(sign: float) -> tuple[float, float]:
        """(half-power distance, first-null distance) on one side of the peak."""
        d = np.arange(0.0, 20.0, step)
        p = power(u_pk + sign * d)
        below = np.nonzero(p < 0.5 * p_pk)[0]
        if below.size == 0:
            raise ValueError("IRF never drops to half power within 20/B of its peak")
        i = int(below[0])
        half = _bisect(lambda x: p1(u_pk + sign * x) - 0.5 * p_pk, d[i - 1], d[i])
        rising = np.nonzero(np.diff(p[i:]) > 0.0)[0]
        if rising.size == 0:
            raise ValueError("IRF has no null within 20/B of its peak")
        j = i + int(rising[0])  # first grid local minimum
        null = _golden_min(lambda x: p1(u_pk + sign * x), d[j] - step, d[j] + step)
        return half, null

    half_r, null_r = side(+1.0)
    half_l, null_l = side(-1.0)
    irw = half_r + half_l
    window = sidelobe_cells * irw
    if window <= max(null_r, null_l):
        raise ValueError(
            f"sidelobe window ±{window:.4g}/B (sidelobe_cells={sidelobe_cells}) does not "
            "reach beyond the first nulls"
        )

    # PSLR: refined local maxima of |h|² between the nulls and the window edges.
    best = 0.0
    for sign, null in ((+1.0, null_r), (-1.0, null_l)):
        d = np.arange(null, window + step / 2, step)
        d[-1] = min(d[-1], window)
        p = power(u_pk + sign * d)
        best = max(best, float(p[0]), float(p[-1]))
        interior = np.nonzero((p[1:-1] >= p[:-2]) & (p[1:-1] >= p[2:]))[0] + 1
        for k in interior:
            x = _golden_min(lambda x, s=sign: -p1(u_pk + s * x), d[k - 1], d[k + 1])
            best = max(best, p1(u_pk + sign * x))
    pslr = 10.0 * math.log10(best / p_pk)

    main = _integrate(power, u_pk - null_l, u_pk + null_r)
    sides = _integrate(power, u_pk - window, u_pk - null_l) + _integrate(
        power, u_pk + null_r, u_pk + window
    )
    islr = 10.0 * math.log10(sides / main)
    if total_energy is None:
        islr_inf = float("nan")
    else:
        islr_inf = 10.0 * math.log10((float(total_energy) - main) / main)
    return IRFExpectation(
        irw_factor=float(irw),
        pslr_db=float(pslr),
        islr_db=float(islr),
        islr_infinite_db=float(islr_inf),
        first_null=float(0.5 * (null_r + null_l)),
        sidelobe_cells=sidelobe_cells,
    )


@functools.lru_cache(maxsize=64)
def sinc_irf_expectation(*, sidelobe_cells: float = 10.0) -> IRFExpectation:
    """Expectation for an unweighted spectrum (``h = sinc``).

    IRW factor 0.8859 (root of ``sinc²(u) = ½``), PSLR −13.26 dB, ISLR ≈ −10.2 dB for
    10 cells (−9.68 dB to infinity), first nulls at ``±1/B``.

    Args:
        sidelobe_cells: sidelobe window half-width in IRWs (module convention).

    Returns:
        The :class:`IRFExpectation` (cached).
    """
    return irf_expectation(np.sinc, total_energy=1.0, sidelobe_cells=float(sidelobe_cells))


def weighted_irf_expectation(
    weighting, *, sidelobe_cells: float = 10.0, nodes: int = 512
) -> IRFExpectation:
    """Expectation for a weighted spectrum, from a numerical Fourier integral.

    The IRF is obtained with :func:`numerical_irf` (Gauss–Legendre over the band, no
    closed form used), and the total energy from Parseval, ``∫ w(ν)² dν``.

    Args:
        weighting: ``"hamming"``, ``"taylor"``, ``"rect"``/None, a
            :class:`CosineWeighting` or any callable ``w(ν)`` on ``ν ∈ [−½, ½]``.
        sidelobe_cells: sidelobe window half-width in IRWs.
        nodes: quadrature nodes of the transform.

    Returns:
        The :class:`IRFExpectation`.
    """
    w = _resolve_weighting(weighting)
    if w is None:
        return sinc_irf_expectation(sidelobe_cells=sidelobe_cells)
    x, wq = _gauss_legendre(int(nodes))
    total = float(np.sum(0.5 * wq * np.abs(np.asarray(w(0.5 * x), dtype=complex)) ** 2))
    return irf_expectation(
        numerical_irf(w, nodes=nodes), total_energy=total, sidelobe_cells=sidelobe_cells
    )


def range_irw_theory(bandwidth: float) -> float:
    """Theoretical slant-range IRW of an unweighted chirp, ``0.8859 · c / (2 Δf)`` [m].

    Args:
        bandwidth: transmitted (processed) bandwidth Δf [Hz].

    Returns:
        IRW [m].
    """
    bandwidth = float(bandwidth)
    if not (math.isfinite(bandwidth) and bandwidth > 0.0):
        raise ValueError(f"bandwidth must be finite and > 0, got {bandwidth}")
    return sinc_irf_expectation().irw_factor * SPEED_OF_LIGHT / (2.0 * bandwidth)


# --------------------------------------------------------------------------------------
# Analytic images
# --------------------------------------------------------------------------------------


def _axis_irf(axis, x0, bandwidth, weighting, centre_frequency, name):
    axis = np.asarray(axis, dtype=float)
    if axis.ndim != 1 or axis.size == 0:
        raise ValueError(f"{name} axis must be a non-empty 1-D array, got shape {axis.shape}")
    bandwidth = float(bandwidth)
    if not (math.isfinite(bandwidth) and bandwidth > 0.0):
        raise ValueError(f"{name}_bandwidth must be finite and > 0, got {bandwidth}")
    x0 = float(x0)
    fc = float(centre_frequency)
    if not (math.isfinite(x0) and math.isfinite(fc)):
        raise ValueError(f"{name}0 and {name}_centre_frequency must be finite, got {x0}, {fc}")
    w = _resolve_weighting(weighting)
    u = bandwidth * (axis - x0)
    if w is None:
        h = np.sinc(u).astype(complex)
    else:
        if hasattr(w, "irf"):
            irf = w.irf
        else:
            irf = numerical_irf(w, nodes=max(512, 8 * math.ceil(float(np.max(np.abs(u))))))
        h = np.asarray(irf(u), dtype=complex) / complex(irf(np.zeros(1))[0])
    return h * np.exp(2j * np.pi * fc * (axis - x0))


def sinc_image(
    azimuth_axis,
    range_axis,
    *,
    azimuth0: float,
    range0: float,
    azimuth_bandwidth: float,
    range_bandwidth: float,
    azimuth_weighting=None,
    range_weighting=None,
    azimuth_centre_frequency: float = 0.0,
    range_centre_frequency: float = 0.0,
    amplitude: complex = 1.0,
) -> np.ndarray:
    """Analytic separable point-target IRF sampled on given axes.

    ``I(x, r) = A · h_a(B_a (x − x0)) e^{j2π f_a (x − x0)}
    · h_r(B_r (r − r0)) e^{j2π f_r (r − r0)}``
    with ``h = sinc`` for unweighted axes (weighted IRFs normalised to ``h(0) = 1``).
    The spectrum along each axis occupies ``[f_c − B/2, f_c + B/2]`` [cycles/m].

    Args:
        azimuth_axis: (n_azimuth,) azimuth coordinates [m].
        range_axis: (n_range,) range coordinates [m].
        azimuth0: target azimuth [m].
        range0: target range [m].
        azimuth_bandwidth: azimuth spatial bandwidth B_a [cycles/m] (IRW ≈ 0.886/B_a).
        range_bandwidth: range spatial bandwidth B_r [cycles/m] (= 2Δf/c).
        azimuth_weighting: None/"rect", "hamming", "taylor", a :class:`CosineWeighting`
            or a callable ``w(ν)`` on ``ν ∈ [−½, ½]``.
        range_weighting: same for range.
        azimuth_centre_frequency: azimuth spectral centre f_a [cycles/m] (Doppler
            centroid over velocity); 0 centres the spectrum.
        range_centre_frequency: range spectral centre f_r [cycles/m].
        amplitude: complex peak value A.

    Returns:
        (n_azimuth, n_range) complex128 image.
    """
    ha = _axis_irf(
        azimuth_axis, azimuth0, azimuth_bandwidth, azimuth_weighting,
        azimuth_centre_frequency, "azimuth",
    )
    hr = _axis_irf(
        range_axis, range0, range_bandwidth, range_weighting, range_centre_frequency, "range"
    )
    return complex(amplitude) * np.outer(ha, hr)

