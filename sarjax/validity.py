"""Validity budgets of the approximate simulators (physics.md §7; seed 000 eq. 11–13, 35,
37, 40, 48).

Each approximation neglects a known term; its budget is the largest phase (or relative
amplitude) error that term can cause, in radians, over the scatterers and the pulses that
illuminate them (the pattern's main lobe, ``|x' − x| ≤ X``):

* ``epsilon_11 = (4π/λ) max|ϕ|``: the coupling ``ϕ = R − √(r² + (x' − x)²) − δr_xr`` of the
  deviation with the along-track offset (seed eq. 11). The moderate-deviation method
  corrects it to Taylor order n, leaving ``(α_max |δ − δ̄|)^{n+1}/(n+1)!`` plus the exact
  remainder beyond ``δ (r/R − 1)``.
* ``epsilon_12 = η_max max|ψ|``, ``η_max = (2π/λ)(Δf/f)``: the range-envelope shift of ψ
  (seed eq. 12). For the moderate-deviation method the migration error of the Doppler
  shift ``−k₀ ∂ψ/∂x'`` adds ``|x' − x| |∂ψ/∂x'|``; with its envelope correction the
  residual is the square of that over 2.
* ``epsilon_13 = (4π/λ) max|ψ(x', r) − ψ(x, r)|``: ψ moved onto the scene (seed eq. 13;
  small deviation only).
* ``epsilon_az``: the pointing expansion of order n leaves
  ``max|W²⁽ⁿ⁺¹⁾| / (n+1)! · (L max|δ_az| / λ)^{n+1}`` relative to the pattern peak
  (seed eq. 21, 37, 48); the seed's ``max|δ_az| L/λ`` is reported as ``pointing_ratio``.
* ``epsilon_motion`` (ideal 2-D only): ``(4π/λ) max|δr_xr|``, the whole deviation.

Thresholds are 0.1 rad for phases and 0.02 for the relative pattern error: chosen on the
calibration grid of ``tests/test_validity.py`` so that every case called valid is accurate
(focused NMSE ≤ −25 dB, IRW within 1 %, PSLR/ISLR within 0.3 dB of the exact model).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import jax
import jax.numpy as jnp
import numpy as np

from . import geometry
from .motion import Motion
from .scene import PointTargets, ReflectivityGrid

PHASE_THRESHOLD = 0.1  # [rad]
PATTERN_THRESHOLD = 0.02  # pattern-expansion error (0.046 at δ_m = 0.23 λ/L was inaccurate)

_APPROXIMATE = ("fourier_2d", "small_deviation", "moderate_deviation")
_ALIASES = {"algorithm_a": "small_deviation", "algorithm_b": "moderate_deviation"}


@dataclass(frozen=True)
class Budget:
    """One validity budget: ``value`` and ``threshold`` in radians (or relative)."""

    name: str
    value: float
    threshold: float
    meaning: str

    @property
    def ok(self) -> bool:
        """True when the budget holds (value ≤ threshold)."""
        return bool(self.value <= self.threshold)

    def __str__(self):
        verdict = "ok" if self.ok else "VIOLATED"
        return (f"{self.name:<15} {self.value:10.4g} ≤ {self.threshold:<8.3g} {verdict:<9} "
                f"{self.meaning}")


@dataclass(frozen=True)
class Validity:
    """Budgets of one method for one (radar, scene, motion)."""

    method: str
    budgets: tuple[Budget, ...] = field(default_factory=tuple)
    pointing_ratio: float = 0.0

    @property
    def valid(self) -> bool:
        """True when every budget holds."""
        return all(b.ok for b in self.budgets)

    def __getitem__(self, name) -> Budget:
        for b in self.budgets:
            if b.name == name:
                return b
        raise KeyError(name)

    def __str__(self):
        head = f"method {self.method}: {'VALID' if self.valid else 'NOT VALID'}"
        lines = [head] + [f"  {b}" for b in self.budgets]
        lines.append(f"  (max|δ_az| L/λ = {self.pointing_ratio:.4g})")
        return "\n".join(lines)


def _scene_samples(scene, max_points=1024):
    """(x, r, h) NumPy arrays of representative scatterers (all, or a lattice for grids)."""
    if isinstance(scene, PointTargets):
        x, r, h = (np.asarray(a, float) for a in (scene.azimuth, scene.range, scene.height))
        if x.size > max_points:
            idx = np.linspace(0, x.size - 1, max_points).astype(int)
            x, r, h = x[idx], r[idx], h[idx]
        return x, r, h
    if isinstance(scene, ReflectivityGrid):
        az, rg = np.asarray(scene.azimuth, float), np.asarray(scene.range, float)
        hh = np.asarray(scene.height, float)
        ia = np.unique(np.linspace(0, az.size - 1, min(az.size, 32)).astype(int))
        ir = np.unique(np.linspace(0, rg.size - 1, min(rg.size, 32)).astype(int))
        xx, rr = np.meshgrid(az[ia], rg[ir], indexing="ij")
        return xx.ravel(), rr.ravel(), hh[np.ix_(ia, ir)].ravel()
    raise ValueError(f"scene={type(scene).__name__} is not PointTargets or ReflectivityGrid")


def _pattern_remainder_coefficient(pattern, order):
    """max_u |W²⁽ⁿ⁺¹⁾(u)| / (n+1)! over the main lobe and first sidelobes."""
    f = pattern.__call__
    for _ in range(order + 1):
        f = jax.grad(f)
    u = jnp.linspace(-2.0, 2.0, 4001)
    return float(jnp.max(jnp.abs(jnp.vectorize(f)(u)))) / math.factorial(order + 1)


def _at_pulse(values, x, x_p, dx):
    """(scatterer,) per-(pulse, scatterer) ``values`` linearly interpolated at the pulse
    position ``x`` of each scatterer (pulses x_p spaced dx; edge values outside)."""
    n = x_p.size
    position = np.clip((x - x_p[0]) / dx, 0.0, n - 1.0)
    i0 = np.minimum(np.floor(position).astype(int), max(n - 2, 0))
    t = position - i0
    cols = np.arange(x.size)
    i1 = np.minimum(i0 + 1, n - 1)
    return values[i0, cols] * (1 - t) + values[i1, cols] * t


def _pointing_budget(radar, pointing, method, pointing_order):
    """(``epsilon_az`` budget, max|δ_az| L/λ) of the pointing expansion (seed eq. 21, 37)."""
    lam, L = float(radar.wavelength), float(radar.antenna_length)
    pointing_ratio = float(np.max(np.abs(pointing))) * L / lam
    order = 0 if method == "fourier_2d" else pointing_order
    coef = _pattern_remainder_coefficient(radar.pattern, order)
    peak = float(radar.pattern(jnp.asarray(0.0)))
    pattern_error = coef * pointing_ratio ** (order + 1) / peak
    return Budget("epsilon_az", pattern_error, PATTERN_THRESHOLD,
                  f"pointing expansion remainder, order {order} (seed eq. 21, 37)"), pointing_ratio


def validity(radar, scene, motion=None, *, method, num_pulses=None, azimuth_center=0.0,
             pointing_order=2, coupling_order=3, envelope_correction=True) -> Validity:
    """Validity budgets of ``method`` for this acquisition, without simulating.

    Args:
        radar: :class:`~sarjax.Radar`.
        scene: :class:`~sarjax.PointTargets` or :class:`~sarjax.ReflectivityGrid`.
        motion: :class:`~sarjax.Motion` (None = ideal).
        method: ``"fourier_2d"``, ``"small_deviation"`` / ``"algorithm_a"``,
            ``"moderate_deviation"`` / ``"algorithm_b"`` or ``"time_domain"`` (exact: no
            budgets).
        num_pulses: pulses (default ``radar.num_pulses``).
        azimuth_center: x' of the middle pulse [m].
        pointing_order: order of the pointing expansion the method will use.
        coupling_order, envelope_correction: moderate-deviation corrections in use.

    Returns:
        :class:`Validity` with each budget's value, threshold and verdict and ``.valid``.
    """
    method = _ALIASES.get(method, method)
    if method == "time_domain":
        return Validity(method, ())
    if method not in _APPROXIMATE:
        choices = _APPROXIMATE + ("time_domain",)
        raise ValueError(f"unknown method={method!r}; choose one of {choices}")
    motion = Motion() if motion is None else motion
    n = radar.num_pulses if num_pulses is None else num_pulses
    if float(np.asarray(radar.squint)) != 0.0:
        return _squinted_validity(radar, scene, motion, method, n, azimuth_center,
                                  pointing_order, coupling_order, envelope_correction)
    dx = float(radar.azimuth_spacing)
    x_p = azimuth_center + (np.arange(n) - (n - 1) / 2) * dx
    dy, dz, daz = (np.asarray(v, float) for v in motion.resolve(n))
    H = float(radar.height)
    lam = float(radar.wavelength)
    k0 = 4 * np.pi / lam
    eta_max = 2 * np.pi / lam * float(radar.bandwidth) / float(radar.carrier_frequency)
    L = float(radar.antenna_length)

    xs, rs, hs = _scene_samples(scene)
    # per (pulse, scatterer) within the main lobe |x' − x| ≤ X
    X = lam * rs / L
    along = x_p[:, None] - xs[None, :]
    lobe = np.abs(along) <= X[None, :]
    los = np.asarray(geometry.line_of_sight_deviation(dy[:, None], dz[:, None], rs[None, :],
                                                      hs[None, :], H))
    delta_r = np.asarray(geometry.reference_deviation(dy, dz, radar))
    psi = los - delta_r[:, None]
    nominal = np.sqrt(rs[None, :] ** 2 + along**2)
    offset = np.asarray(geometry.range_offset(along, rs[None, :], los))  # R − r
    phi = (rs[None, :] + offset) - nominal - los

    def lobe_max(a):
        return float(np.max(np.abs(np.where(lobe, a, 0.0)))) if lobe.any() else 0.0

    budgets = []
    if method == "fourier_2d":
        budgets.append(Budget("epsilon_motion", k0 * lobe_max(los), PHASE_THRESHOLD,
                              "(4π/λ) max|δr_xr|: the deviation is not modelled"))
    elif method == "small_deviation":
        budgets.append(Budget("epsilon_11", k0 * lobe_max(phi), PHASE_THRESHOLD,
                              "(4π/λ) max|ϕ| (seed eq. 11)"))
        budgets.append(Budget("epsilon_12", eta_max * lobe_max(psi), PHASE_THRESHOLD,
                              "η_max max|ψ| (seed eq. 12)"))
        # ψ(x, r): at the pulse above the scatterer
        diff = psi - _at_pulse(psi, xs, x_p, dx)[None, :]
        budgets.append(Budget("epsilon_13", k0 * lobe_max(diff), PHASE_THRESHOLD,
                              "(4π/λ) max|ψ(x', r) − ψ(x, r)| (seed eq. 13)"))
    else:  # moderate deviation
        if coupling_order:
            xi_max = np.pi / dx
            alpha_max = k0 - np.sqrt(k0**2 - xi_max**2)
            spread = lobe_max(los - np.mean(los, axis=0, keepdims=True))
            taylor = (alpha_max * spread) ** (coupling_order + 1) / math.factorial(
                coupling_order + 1)
            exact_rest = k0 * lobe_max(phi - los * (rs[None, :] / nominal - 1))
            value = taylor + exact_rest
            meaning = f"(4π/λ)|ϕ| after the order-{coupling_order} coupling correction"
        else:
            value = k0 * lobe_max(phi)
            meaning = "(4π/λ) max|ϕ| (seed eq. 11)"
        budgets.append(Budget("epsilon_11", value, PHASE_THRESHOLD, meaning))
        # envelope error: ψ itself plus the migration error of the Doppler shift −k₀∂ψ/∂x'
        slope = np.gradient(psi, dx, axis=0)
        e12 = eta_max * lobe_max(np.abs(psi) + np.abs(along * slope))
        if envelope_correction:
            budgets.append(Budget("epsilon_12", e12**2 / 2, PHASE_THRESHOLD,
                                  "(η_max max(|ψ| + |x'−x||∂ψ/∂x'|))²/2, after the envelope "
                                  "correction"))
        else:
            budgets.append(Budget("epsilon_12", e12, PHASE_THRESHOLD,
                                  "η_max max(|ψ| + |x'−x||∂ψ/∂x'|) (seed eq. 12)"))
    pointing_budget, pointing_ratio = _pointing_budget(radar, daz, method, pointing_order)
    budgets.append(pointing_budget)
    return Validity(method, tuple(budgets), pointing_ratio)


def _squinted_validity(radar, scene, motion, method, n, azimuth_center, pointing_order,
                       coupling_order, envelope_correction) -> Validity:
    """Budgets of the squinted Fourier simulators (``sarjax.simulators._squint``; seed 002
    eq. 10–11, 45–46, 50), evaluated like the broadside ones over the pulses within the
    squinted main lobe, ``|u| ≤ 1`` with ``u = (L/λ)(a/r + T)/(1 − aT/r)``.

    With ``c = r/R_n`` the cosine of the look direction, ``c_d = cos φ_d``, ``a = x' − x``:

    * small deviation: ``epsilon_11 = (4π/λ) max|R − R_n − c_d δr_xr|`` (the coupling, first
      order in the beam angle at squint); ``epsilon_12 = η_max max(|ψ|/c + |δr||1/c − 1/c_d|)``
      (the envelope of ψ and the per-pulse envelope slope taken at the centroid);
      ``epsilon_13 = (4π/λ) c_d max|ψ(x', r) − ψ(x_c, r)|``, ψ moved onto the scene at the
      beam-centre pulse ``x_c = x − r tan φ_d``.
    * moderate deviation: ``epsilon_11`` = the coupling left by the Taylor series of
      ``(√(k₀² − ξ²) − k₀ c_d) δr_xr`` over the PRF band about ξ_d, plus
      ``(4π/λ) max|R − R_n − δr_xr r/R_n|``; ``epsilon_12`` = the squared first-order
      envelope terms over 2 (``|ψ|/c`` and the migration ``c_d |a| |∂ψ/∂x'| / c²``, both
      corrected) plus the uncorrected ones: ``|δr||1/c − 1/c_d|`` and the migration of the
      coupling's Doppler shift, ``|a| |√(k₀² − ξ²) − k₀ c_d| |∂δr_xr/∂x'| / (k₀ c²)``.
    * fourier_2d: the squinted straight track (seed 002 eq. 49 without motion):
      ``epsilon_motion = (4π/λ) max|δr_xr|`` over the squinted lobe, as at broadside.
    """
    dx = float(radar.azimuth_spacing)
    x_p = azimuth_center + (np.arange(n) - (n - 1) / 2) * dx
    dy, dz, daz = (np.asarray(v, float) for v in motion.resolve(n))
    lam = float(radar.wavelength)
    k0 = 4 * np.pi / lam
    eta_max = 2 * np.pi / lam * float(radar.bandwidth) / float(radar.carrier_frequency)
    L = float(radar.antenna_length)
    squint = float(np.asarray(radar.squint))
    T, c_d = math.tan(squint), math.cos(squint)

    xs, rs, hs = _scene_samples(scene)
    along = x_p[:, None] - xs[None, :]
    u = L / lam * (along / rs[None, :] + T) / (1 - along * T / rs[None, :])
    lobe = np.abs(u) <= 1.0
    los = np.asarray(geometry.line_of_sight_deviation(
        dy[:, None], dz[:, None], rs[None, :], hs[None, :], float(radar.height)))
    delta_r = np.asarray(geometry.reference_deviation(dy, dz, radar))[:, None]
    psi = los - delta_r
    nominal = np.sqrt(rs[None, :] ** 2 + along**2)
    exact = rs[None, :] + np.asarray(geometry.range_offset(along, rs[None, :], los))
    cos_look = rs[None, :] / nominal

    def lobe_max(a):
        return float(np.max(np.abs(np.where(lobe, a, 0.0)))) if lobe.any() else 0.0

    budgets = []
    slope_mismatch = np.abs(delta_r) * np.abs(1 / cos_look - 1 / c_d)
    if method == "fourier_2d":
        budgets.append(Budget("epsilon_motion", k0 * lobe_max(los), PHASE_THRESHOLD,
                              "(4π/λ) max|δr_xr|: the deviation is not modelled"))
    elif method == "small_deviation":
        budgets.append(Budget("epsilon_11", k0 * lobe_max(exact - nominal - c_d * los),
                              PHASE_THRESHOLD, "(4π/λ) max|R − R_n − cos φ_d δr_xr|"))
        budgets.append(Budget("epsilon_12",
                              eta_max * lobe_max(np.abs(psi) / cos_look + slope_mismatch),
                              PHASE_THRESHOLD, "η_max max(|ψ|/c + |δr||1/c − 1/c_d|)"))
        psi_beam = _at_pulse(psi, xs - rs * T, x_p, dx)  # ψ at the beam-centre pulse
        budgets.append(Budget("epsilon_13", k0 * c_d * lobe_max(psi - psi_beam[None, :]),
                              PHASE_THRESHOLD,
                              "(4π/λ) cos φ_d max|ψ(x', r) − ψ(x_c, r)| (seed 002 eq. 10)"))
    else:  # moderate deviation
        xi_d = k0 * math.sin(squint)
        xi_band = xi_d + np.linspace(-np.pi / dx, np.pi / dx, 257)
        alpha_band = np.abs(np.sqrt(k0**2 - xi_band**2) - k0 * c_d)
        exact_rest = k0 * lobe_max(exact - nominal - los * cos_look)
        if coupling_order:
            spread = lobe_max(los - np.mean(los, axis=0, keepdims=True))
            value = (float(alpha_band.max()) * spread) ** (coupling_order + 1) / math.factorial(
                coupling_order + 1) + exact_rest
            meaning = f"coupling after its order-{coupling_order} correction"
        else:
            value = k0 * lobe_max(exact - nominal - c_d * los)
            meaning = "(4π/λ) max|R − R_n − cos φ_d δr_xr|"
        budgets.append(Budget("epsilon_11", value, PHASE_THRESHOLD, meaning))
        # stationary ξ of each (pulse, scatterer): ξ = −k₀ a/R_n
        alpha = np.abs(np.sqrt(k0**2 - (k0 * along / nominal) ** 2) - k0 * c_d)
        los_slope = np.gradient(los, dx, axis=0)
        psi_slope = np.gradient(psi, dx, axis=0)
        corrected = np.abs(psi) / cos_look + c_d * np.abs(along * psi_slope) / cos_look**2
        uncorrected = slope_mismatch + np.abs(along) * alpha * np.abs(los_slope) / (
            k0 * cos_look**2)
        if envelope_correction:
            value = (eta_max * lobe_max(corrected)) ** 2 / 2 + eta_max * lobe_max(uncorrected)
            meaning = "envelope terms after the first-order correction"
        else:
            value = eta_max * lobe_max(corrected + uncorrected)
            meaning = "η_max max(envelope terms) (seed 002 eq. 11)"
        budgets.append(Budget("epsilon_12", value, PHASE_THRESHOLD, meaning))
    pointing_budget, pointing_ratio = _pointing_budget(radar, daz, method, pointing_order)
    budgets.append(pointing_budget)
    return Validity(method, tuple(budgets), pointing_ratio)


FASTEST_FIRST = ("fourier_2d", "small_deviation", "moderate_deviation", "time_domain")


def choose_method(radar, scene, motion=None, **kwargs) -> tuple[str, dict]:
    """The fastest method whose budgets hold (``time_domain`` if none): (name, validities)."""
    report = {}
    for method in FASTEST_FIRST:
        report[method] = validity(radar, scene, motion, method=method, **kwargs)
        if report[method].valid:
            return method, report
    return "time_domain", report
