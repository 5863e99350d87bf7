"""The grid a Fourier-domain simulation runs on, from the scene (physics.md §3, §4a):
the Doppler bands to synthesise (azimuth ambiguities), every scatterer's echo support,
the azimuth extent and crop, the range FFT length, and the scatterers left out. The one
place these are decided (:func:`work_grid`).

The synthesis is circular in both axes; what it must hold is what reaches the window.
A scatterer's echo at pulse x' has the pattern argument ``u(x' − x)``; the exact model
records it at the window's pulses only, and samples the pattern at the PRF, so the echo
energy at Doppler beyond ±PRF/2 folds back into the band (the azimuth ambiguities). The
engine synthesises the principal band ``ξ_d ± π/Δx`` and, for the scenes that need them,
alias bands ``ξ_d + 2πk/Δx ± π/Δx`` (:func:`azimuth_support`); the grid then holds each
scatterer's echo over those bands (:func:`work_grid`).
"""

from __future__ import annotations

import functools
import math
from types import SimpleNamespace
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import antenna
from .._numerics.interpolation import next_fast_len
from ._base import is_traced
from ._budgets import coincident_power
from ._moving_target import spectrum_terms


def within_support(scene, included):
    """The scene with the scatterers outside the grid's support (``WorkGrid.included``)
    set to zero reflectivity."""
    return eqx.tree_at(lambda s: s.reflectivity, scene, scene.reflectivity * included)



@functools.lru_cache(maxsize=64)
def _pattern_energy_table(pattern):
    """(u, cumulative energy fraction of |W²(u)|² from −∞ to u) on u ∈ [−64, 64]."""
    u = np.linspace(-64.0, 64.0, 2**17 + 1)
    with jax.ensure_compile_time_eval():  # one compiled program, not one per operation
        energy = np.abs(np.asarray(antenna.evaluate(pattern, jnp.asarray(u)))) ** 2
    cumulative = np.cumsum(energy)
    return u, cumulative / cumulative[-1]


def pattern_energy_table(pattern):
    """(u, cumulative energy fraction) of the two-way pattern's echo energy ``|W²(u)|²``."""
    try:
        return _pattern_energy_table(pattern)
    except TypeError:  # a pattern with array fields is not hashable
        return _pattern_energy_table.__wrapped__(pattern)


@functools.lru_cache(maxsize=64)
def _pattern_curvature_table(pattern):
    """(u, ∫ |W²″|² from −∞ to u over ∫ |W²|² over all u) on the grid of
    :func:`pattern_energy_table`."""
    u = np.linspace(-64.0, 64.0, 2**17 + 1)
    with jax.ensure_compile_time_eval():
        energy = np.abs(np.asarray(antenna.evaluate(pattern, jnp.asarray(u)))) ** 2
        curvature = np.abs(np.asarray(antenna.evaluate_derivative(pattern, 2,
                                                                  jnp.asarray(u)))) ** 2
    return u, np.cumsum(curvature) / np.sum(energy)


def pattern_curvature_table(pattern):
    """(u, cumulative ``∫|W²″(u)|² du`` relative to the echo energy ``∫|W²(u)|² du``)."""
    try:
        return _pattern_curvature_table(pattern)
    except TypeError:  # a pattern with array fields is not hashable
        return _pattern_curvature_table.__wrapped__(pattern)


def amplitude_coefficient(radar, slant_range):
    """``c = (du/dx')² / (2 ∂²φ/∂x'²) = (L/λ)² cos φ_d / (2 k₀ r)`` at the beam centre: the
    stationary-phase synthesis's relative amplitude error is ``c |W²″(u)| / W²(u)`` (the
    first correction of the stationary-phase expansion, the pattern's curvature against the
    azimuth chirp's; the squint's ``u″`` term, ``2 tan φ_d W²′/((L/λ) W²″)`` of it, is
    left out)."""
    ratio = float(radar.antenna_length) / float(radar.wavelength)
    squint = float(np.asarray(radar.squint))
    return ratio**2 * math.cos(squint) / (2 * float(radar.wavenumber) * slant_range)


class AzimuthSupport(NamedTuple):
    """What the engine synthesises in azimuth for a scene (eager, NumPy).

    Attributes:
        bands: Doppler alias bands ±1 … ±bands synthesised beside the principal one.
        left_out: the echo energy the window records that the synthesised bands miss,
            and the energy their cut rings into it (:func:`_ringing`), over the energy
            it records (scatterers weighted by ``|γ|²``): the azimuth ambiguities not
            modelled, and the echoes of scatterers left out.
        look: (φ_lo, φ_hi) [rad], the look angles the bands span (``ξ = k₀ sin φ``,
            ``a = x' − x = −r tan φ``).
        sidelobes: the share of the recorded echo energy the window sees through the
            pattern's sidelobes only (``|u| > 1``).
        synthesised: the echo energy the synthesis makes (each scatterer's echo over the
            look angles of the bands and its whole chirp) over the energy the window
            records, ≥ 1 up to the bands' losses: the synthesis works on the whole echo
            and crops the window out of it, so its rounding scales with this ratio.
        hold: (left, right) [m], per scatterer, how far the grid must reach beyond the
            window's ends for the bands' cut to ring no more than a quarter of the
            tolerance into it from its periodic images (None: the Fresnel margin).
        amplitude: the stationary-phase synthesis's amplitude error energy over the
            recorded echo energy, ``Σ |γ|² ∫ (c W²″)² / Σ |γ|² ∫ (W²)²`` over the pattern
            arguments each scatterer's echo is recorded at (``c``:
            :func:`amplitude_coefficient`).
    """

    bands: int
    left_out: float
    look: tuple[float, float]
    sidelobes: float = 0.0
    synthesised: float = 1.0
    hold: tuple | None = None
    amplitude: float = 0.0


def _pattern_u(radar, along, slant_range):
    """The exact model's pattern argument ``u = (L/λ)(a/r + T)/(1 − aT/r)`` (nominal
    pointing) of pulses at ``a = x' − x`` from a scatterer at range r."""
    t = math.tan(float(np.asarray(radar.squint)))
    ratio = float(radar.antenna_length) / float(radar.wavelength)
    with np.errstate(divide="ignore", invalid="ignore"):
        return ratio * (along / slant_range + t) / (1 - along * t / slant_range)


def band_look_angles(radar, bands):
    """(φ_lo, φ_hi) [rad]: the look angles ``ξ = k₀ sin φ`` of the principal Doppler band
    ``ξ_d ± π/Δx`` and ``bands`` alias bands on each side."""
    edge = np.clip(_band_wavenumbers(radar, bands) / float(radar.wavenumber), -1, 1)
    limit = math.pi / 2 - 1e-3
    lo, hi = np.clip(np.arcsin(edge), -limit, limit)
    return float(lo), float(hi)


def azimuth_support(radar, scene, acquisition, tolerance, bands=None, max_bands=4):
    """The Doppler bands an echo must be synthesised over (physics.md §3: the exact model
    samples the pattern at the PRF, so echo energy at Doppler beyond ±PRF/2 folds back:
    azimuth ambiguities), from the scene: :class:`AzimuthSupport`.

    A scatterer's echo at pulse ``x'`` has the pattern argument ``u(a)``, ``a = x' − x``;
    over the window it spans ``[u(w₀ − x), u(w₁ − x)]``, and records the energy
    ``∫|W²(u)|² du`` there. The bands cover look angles ``φ`` (``ξ = k₀ sin φ``, at the
    stationary point ``a = −r tan φ``), i.e. ``u ∈ [u(−r tan φ_hi), u(−r tan φ_lo)]``;
    the energy outside that, over every scatterer (weighted by ``|γ|²``), relative to
    all the window records, is ``left_out``. ``bands=None``: the fewest (at most
    ``max_bands``) with ``left_out ≤ tolerance``.

    A moving scatterer (``v_r``, ``v_a``) is seen at ``a' = a (1 − v_a/v)`` from range
    ``r + v_r a/v`` (the exact model's geometry), and its echo's Doppler moves with it:
    the bands cover the pattern arguments of its own stationary points at their edges
    (``_moving_target.spectrum_terms``; ``v_r`` shifts the echo by ``−2v_r/λ``, at 100 m/s
    and X band 6.8 m/s is a whole PRF band of 400 Hz), less ``FRESNEL_ZONES`` Fresnel
    zones at each edge: moved by the velocity, an edge can fall in the main lobe, and
    the cut rings there (a target whose recorded echo ended 2 zones from an edge:
    −15.9 dB against the exact model).

    The cut also rings into the window from beyond it (:func:`_ringing`, added to
    ``left_out``): a band edge in the main lobe 79 m past a window that records the
    sidelobes (15 m/s in range, −30 m/s along track, 10° squint) gave −13.2 dB with no
    energy counted missing; predicted −13.9 dB. ``hold`` keeps the cut's images on the
    circular grid as far away (a quarter of the tolerance).
    """
    key = (radar, scene, acquisition.num_pulses, float(acquisition.azimuth_center),
           tolerance, bands, max_bands)
    return _kept(_LAST_SUPPORT, key, 2, lambda: _azimuth_support(
        radar, scene, acquisition, tolerance, bands, max_bands))


class _RecordedGeometry:
    """The part of a scene's azimuth analysis that does not depend on its reflectivity
    (eager, NumPy): where each scatterer's echo is recorded and what the synthesised
    bands miss of it, per scatterer. :func:`_azimuth_support` and
    :func:`band_edge_spill` weight these by ``|γ|²``; a new reflectivity on the same
    cells (a Monte Carlo over speckle) reuses them (:func:`_recorded_geometry`).

    Attributes:
        window: the window's first and last pulse [m].
        x, r: the scene's cells (:func:`_scene_cells`), broadcastable to ``shape``.
        moving: the velocities (:func:`_velocities`), or None.
        arguments: the pattern arguments at the window's first and last pulses (as the
            exact model sees a moving scatterer), or None for traced scatterers (judged
            by the whole echo, equally weighted).
        fractions: the energy fractions below them, lower first.
    """

    def __init__(self, radar, scene, acquisition):
        u_grid, cumulative = pattern_energy_table(radar.pattern)
        self.radar, self.acquisition = radar, acquisition
        self.u_grid, self.cumulative = u_grid, cumulative
        # F(u): the energy fraction below u, monotone, so that the energy over
        # [max(u_a, c), min(u_b, d)] is min(F(u_b), F(d)) − max(F(u_a), F(c)): the
        # scatterers' F(u_a), F(u_b) are interpolated once, the bands' edges per range only
        self.energy_below = lambda u: np.interp(u, u_grid, cumulative)
        dx = float(radar.azimuth_spacing)
        n = acquisition.num_pulses
        w0 = float(acquisition.azimuth_center) - (n - 1) / 2 * dx
        w1 = w0 + (n - 1) * dx
        self.window, self.width = (w0, w1), w1 - w0 + dx
        self.x, self.r = _scene_cells(scene, (w0, w1))
        self.shape = np.broadcast_shapes(np.shape(self.x), np.shape(self.r))
        self.traced = is_traced((scene.azimuth, scene.reflectivity))
        self.moving = None if self.traced else _velocities(scene, self.shape)
        self._bands, self._holds, self._cuts, self._grids = {}, {}, None, {}

    @functools.cached_property
    def arguments(self):
        if self.traced:
            return None
        return tuple(np.nan_to_num(_pattern_u(self.radar, *_seen_from(
            self.radar, end - self.x, self.r, self.moving)), nan=fill)
            for end, fill in ((self.window[0], -np.inf), (self.window[1], np.inf)))

    @functools.cached_property
    def fractions(self):
        if self.traced:
            return np.zeros(self.shape), np.ones(self.shape)
        f_a, f_b = (self.energy_below(u) for u in self.arguments)
        return np.minimum(f_a, f_b), np.maximum(f_a, f_b)

    @functools.cached_property
    def per_scatterer(self):
        """The energy fraction of each scatterer's echo the window records."""
        f_a, f_b = self.fractions
        return np.clip(f_b - f_a, 0.0, None)

    def grid_cells(self, key, compute):
        """``compute()`` (:func:`_grid_cells`), kept for the same ``key`` (its arrays
        read-only: every call's grid shares them)."""
        if key not in self._grids:
            cells = compute()
            for value in vars(cells).values():
                if isinstance(value, np.ndarray):
                    value.flags.writeable = False
            self._grids[key] = cells
        return self._grids[key]

    def weight(self, scene):
        """(shape) ``|γ|²`` of the scene's scatterers (ones where traced)."""
        if self.traced:
            return np.ones(self.shape)
        return np.abs(np.broadcast_to(np.asarray(scene.reflectivity), self.shape)) ** 2

    def seen(self, lo, hi):
        """The energy fraction each scatterer's window records within ``F ∈ [lo, hi]``."""
        f_a, f_b = self.fractions
        return np.clip(np.minimum(f_b, hi) - np.maximum(f_a, lo), 0.0, None)

    @functools.cached_property
    def curvature(self):
        """(c², |ΔG|), shape each: the stationary-phase amplitude error's coefficient
        (:func:`amplitude_coefficient`) squared and the pattern curvature's energy over
        the recorded pattern arguments."""
        u_table, curvature = pattern_curvature_table(self.radar.pattern)
        if self.arguments is None:
            g_span = np.full(self.shape, curvature[-1])
        else:
            g_a, g_b = (np.interp(v, u_table, curvature) for v in self.arguments)
            g_span = np.abs(g_b - g_a)
        coefficient = amplitude_coefficient(self.radar, np.broadcast_to(self.r, self.shape))
        return coefficient**2, g_span

    @functools.cached_property
    def main_lobe(self):
        """The energy fraction each window records within the main lobe (|u| ≤ 1)."""
        return self.seen(self.energy_below(-1.0), self.energy_below(1.0))

    @functools.cached_property
    def chirp_share(self):
        """:func:`_chirp_share` of each scatterer."""
        return _chirp_share(self.radar, self.acquisition, self.x, self.r, self.window,
                            self.moving)

    def band_edges(self, k):
        """F(u) at the two edges of bands ±k for each scatterer, lower first."""
        radar, r, moving = self.radar, self.r, self.moving
        phi_lo, phi_hi = band_look_angles(radar, k)
        edges = [self.energy_below(_pattern_u(radar, -r * math.tan(phi), r))
                 for phi in (phi_hi, phi_lo)]
        if moving is not None:
            # the band's cut rings over a few Fresnel zones about its edge (moved by the
            # velocity, an edge may fall in the main lobe): not counted as covered
            u = np.sort(np.stack(_moving_edges(radar, _band_wavenumbers(radar, k), moving)),
                        axis=0)
            ringing = (fresnel_margin(radar, r) / r
                       * float(radar.antenna_length) / float(radar.wavelength)
                       / math.cos(float(np.asarray(radar.squint))) ** 2)
            own = (self.energy_below(u[0] + ringing),
                   self.energy_below(np.maximum(u[1] - ringing, u[0] + ringing)))
            lower, upper = np.minimum(*edges), np.maximum(*edges)
            return np.where(moving[2], own[0], lower), np.where(moving[2], own[1], upper)
        return np.minimum(*edges), np.maximum(*edges)

    @functools.cached_property
    def _density_table(self):
        return np.gradient(self.cumulative, self.u_grid)  # |W²(u)|² / ∫|W²|² du

    def _density(self, u):
        """``|W²(u)|² / ∫|W²|² du``."""
        return np.interp(np.nan_to_num(u, nan=np.inf), self.u_grid, self._density_table,
                         left=0.0, right=0.0)

    @functools.cached_property
    def _slope(self):
        u_a, u_b = self.arguments
        return np.abs(u_b - u_a) / self.width  # |du/dx'| over the window

    def _band_cuts(self, k):
        """:func:`_band_cuts` for bands ±k (the last one asked for is kept until its
        hold is formed)."""
        cuts = self._cuts  # read once: a call in another thread may replace it
        if cuts is None or cuts[0] != k:
            cuts = (k, _band_cuts(self.radar, self.x, self.r, self.moving, k))
            self._cuts = cuts
        return cuts[1]

    def bands(self, k):
        """(missed, in_bands) for bands ±k, shape each: the energy fraction of each
        scatterer's recorded echo the bands miss, with what their cut rings into the
        window (:func:`_ringing`: from the cut's own pulse, and on the circular grid from
        its images, which the grid holds far enough away); and the fraction between the
        bands' edges."""
        if k not in self._bands:
            lower, upper = self.band_edges(k)
            covered = self.seen(lower, upper)
            if self.traced:
                ringing = 0.0  # judged by the whole echo
            else:
                x_e, u_e, zone2 = self._band_cuts(k)
                w0, w1 = self.window
                gap = np.maximum(w0 - x_e, x_e - w1)
                ringing = np.sum(_ringing(gap, self.width, u_e, zone2, self._density,
                                          self._slope), axis=0)
            self._bands[k] = (self.per_scatterer - covered + ringing,
                              np.clip(upper - lower, 0.0, None))
        return self._bands[k]

    def hold_terms(self, k):
        """(x_e, first, terms) for bands ±k: each cut's pulse (2, shape) (the scatterer's
        own where it has none), whether the lower-ξ cut comes first along track, and
        :func:`_image_distance`'s ``terms`` of each cut (2, shape)."""
        if k not in self._holds:
            x_e, u_e, zone2 = self._band_cuts(k)
            with np.errstate(divide="ignore", invalid="ignore"):
                terms = self._density(u_e) * zone2 * self.width * self._slope
            # the image of the left cut falls right of the window, and the other way round
            x_e = np.where(np.isfinite(x_e), x_e, self.x)
            # the two cuts in order along track (a select of two: an argsort along an axis
            # of two was a quarter of a 404 352-cell grid's support analysis)
            self._holds[k] = (x_e, x_e[0] <= x_e[1], terms)
            self._cuts = None
        return self._holds[k]


GEOMETRY_CELLS = 1 << 20  # the largest scene whose recorded geometry is kept between calls
# (about 20 float64 arrays of its cells: 170 MB at this size)
_LAST_GEOMETRY = [None]  # ((the inputs, their values), _RecordedGeometry) of the last scene


def _recorded_geometry(radar, scene, acquisition):
    """The scene's :class:`_RecordedGeometry`; the last one is kept for the next call on
    the same radar (by identity), window and cells (by value: a new reflectivity on the
    same grid reuses it) up to ``GEOMETRY_CELLS`` cells."""
    if is_traced((scene.azimuth, scene.range, scene.reflectivity,
                  getattr(scene, "velocity_range", None),
                  getattr(scene, "velocity_azimuth", None))):
        return _RecordedGeometry(radar, scene, acquisition)
    values = tuple(None if v is None else np.array(v) for v in (
        scene.azimuth, scene.range, getattr(scene, "velocity_range", None),
        getattr(scene, "velocity_azimuth", None)))
    key = (radar, type(scene), np.shape(scene.reflectivity), acquisition.num_pulses,
           acquisition.num_range, float(acquisition.azimuth_center),
           float(acquisition.near_range))
    last = _LAST_GEOMETRY[0]
    if last is not None and last[0][0] is radar and last[0][1:] == key[1:] and all(
            (a is None and b is None) or (a is not None and b is not None
                                          and a.shape == b.shape and a.dtype == b.dtype
                                          and np.array_equal(a, b))
            for a, b in zip(last[1], values, strict=True)):
        return last[2]
    geometry = _RecordedGeometry(radar, scene, acquisition)
    if math.prod(geometry.shape) <= GEOMETRY_CELLS:
        _LAST_GEOMETRY[0] = (key, values, geometry)
    return geometry


def _azimuth_support(radar, scene, acquisition, tolerance, bands, max_bands):
    geometry = _recorded_geometry(radar, scene, acquisition)
    weight = geometry.weight(scene)
    weighted = weight * geometry.per_scatterer
    recorded = float(np.sum(weighted))
    # the stationary-phase amplitude error over the same pattern arguments
    coefficient2, g_span = geometry.curvature
    amplitude = (float(np.sum(weight * coefficient2 * g_span)) / recorded
                 if recorded > 0 else 0.0)
    main_lobe = float(np.sum(weight * geometry.main_lobe))
    sidelobes = 1.0 - main_lobe / recorded if recorded > 0 else 0.0

    def left_out(k):
        missed = float(np.sum(weight * geometry.bands(k)[0]))
        return missed / recorded if recorded > 0 else 0.0

    if bands is None:
        bands = 0
        while left_out(bands) > tolerance and bands < max_bands:
            bands += 1
    in_bands = geometry.bands(bands)[1]
    in_window = weighted * geometry.chirp_share
    window_energy = float(np.sum(in_window))
    synthesised = (float(np.sum(weight * in_bands)) / window_energy if window_energy > 0
                   else 1.0)
    hold = None
    if not geometry.traced and recorded > 0:
        # each cut's images at least this far from the window: a quarter of the
        # tolerance over the scene, shared by the scatterers by weight
        budget = 0.25 * tolerance * recorded / max(float(np.sum(weight)), 1e-300)
        x_e, first, terms = geometry.hold_terms(int(bands))
        reach = _image_distance(budget, geometry.width, terms)
        hold = (np.where(first, x_e[0] - reach[0], x_e[1] - reach[1]),
                np.where(first, x_e[1] + reach[1], x_e[0] + reach[0]))
    return AzimuthSupport(int(bands), left_out(bands), band_look_angles(radar, bands),
                          max(sidelobes, 0.0), max(synthesised, 1.0), hold, amplitude)


def band_edge_spill(radar, scene, acquisition, bands, spread):
    """The share of the recorded echo energy within ``spread`` [rad/m] of an edge between
    two synthesised Doppler bands (principal and ``bands`` alias bands on each side): a
    factor a band's echo takes on its pulses (Algorithm B's per-line motion phase, whose
    Doppler spread is ``spread``) moves that energy across the edge, where the band's
    transform wraps it to its other edge.

    Each scatterer's recorded energy ``∫|W²(u)|² du`` over the pattern arguments of the
    window (:class:`_RecordedGeometry`), weighted by ``|γ|²``,
    counted within ``ξ_e ± spread`` of each inner edge ``ξ_e`` (``ξ = k₀ sin φ``,
    ``a = −r tan φ``)."""
    if bands < 1 or not spread > 0:
        return 0.0
    geometry = _recorded_geometry(radar, scene, acquisition)
    energy_below = geometry.energy_below
    weight = geometry.weight(scene)
    r = np.broadcast_to(geometry.r, geometry.shape)
    f_a, f_b = geometry.fractions
    recorded = float(np.sum(weight * (f_b - f_a)))
    if recorded <= 0:
        return 0.0
    k0 = float(radar.wavenumber)
    spilled = 0.0
    for inner in range(bands):  # the edges between bands ±inner and ±(inner + 1)
        for edge in _band_wavenumbers(radar, inner):
            phi = np.arcsin(np.clip((edge + np.array([-spread, spread])) / k0, -1, 1))
            lo, hi = (energy_below(_pattern_u(radar, -r * math.tan(p), r)) for p in phi)
            lo, hi = np.minimum(lo, hi), np.maximum(lo, hi)
            spilled += float(np.sum(weight * np.clip(np.minimum(f_b, hi)
                                                     - np.maximum(f_a, lo), 0.0, None)))
    return spilled / recorded


def _band_cuts(radar, x, r, moving, bands):
    """Where the synthesised bands' edges ``ξ_e`` cut each scatterer's echo:
    ``(x_e, u_e, ℓ²)``, each (2, …) (the lower ξ edge first): the pulse of the edge's
    stationary point [m] (``x − r tan φ_e``, or a moving scatterer's own,
    ``_moving_offsets``), the pattern argument there, and the squared Fresnel length
    ``ℓ² = 2π / |dξ/dx'|`` [m²] of the echo's azimuth chirp there (``λr/(2 cos³φ_e)`` for a
    still scatterer). An edge beyond a moving scatterer's Doppler horizon gives NaN."""
    xi = _band_wavenumbers(radar, bands)
    k0 = float(radar.wavenumber)
    phi = np.arcsin(np.clip(xi / k0, -1 + 1e-9, 1 - 1e-9)).reshape((2,) + (1,) * np.ndim(r))
    offset = -r * np.tan(phi)
    u = _pattern_u(radar, offset, r)
    zone2 = 2 * np.pi * r / (k0 * np.cos(phi) ** 3)
    if moving is not None:
        which = moving[2]
        horizon = beyond_horizon(radar, moving, xi, np.ndim(r))
        with np.errstate(divide="ignore", invalid="ignore"):
            step = 1e-4 * k0
            derivative = (_moving_offsets(radar, r, moving, xi + step)
                          - _moving_offsets(radar, r, moving, xi - step)) / (2 * step)
            own = (np.where(horizon, np.nan, _moving_offsets(radar, r, moving, xi)),
                   np.stack(_moving_edges(radar, xi, moving)),
                   2 * np.pi * np.abs(derivative))
        offset, u, zone2 = (np.where(which, o, np.broadcast_to(s, o.shape))
                            for o, s in zip(own, (offset, u, zone2), strict=True))
    return x + offset, u, zone2


def beyond_horizon(radar, moving, xi, ndim):
    """(2, …) whether each band edge ``xi`` (2,) lies beyond a moving scatterer's Doppler
    horizon, ``|ξ| v/k₀ ≥ v_eq`` (``v_eq² = v_r² + (v − v_a)²``, ``_high_speed``'s module
    docstring): there its echo has no stationary point. ``ndim``: the scatterers' ndim."""
    v_r, v_a, _ = moving
    v = float(radar.velocity)
    edge_speed = np.abs(np.asarray(xi)).reshape((2,) + (1,) * ndim) * v / float(
        radar.wavenumber)
    return edge_speed >= np.hypot(v_r, v - v_a)


def _ringing(gap, width, u, zone2, density, slope):
    """The energy a band cut at pattern argument ``u`` rings into a window of ``width``
    [m] whose nearest pulse is ``gap`` [m] from the cut's pulse (``gap < 0``: the cut is
    recorded), in the units of ``left_out`` (fractions of ``∫|W²(u)|² du``).

    A spectrum cut at ``ξ_e`` leaves at a pulse ``x`` away from the cut's stationary
    pulse ``x_e`` the end-point term of the inverse transform, ``|e(x)| = |W²(u_e)| ℓ /
    (2π |x − x_e|)``, at the edge's Doppler at every pulse: over the window's pulses
    ``|W²(u_e)|² ℓ² (1/d_near − 1/d_far) / (4π² Δx)``. With the window's recorded energy
    in the same units (``|dx'/du|`` the window's), the fraction is ``density(u_e) ℓ²
    (1/d_near − 1/d_far) |du/dx'| / (4π²)``; a recorded cut rings over about a Fresnel
    length each side, ``2/ℓ``."""
    with np.errstate(divide="ignore", invalid="ignore"):
        zone = np.sqrt(zone2)
        near = np.maximum(gap, 0.5 * zone)
        spread = np.where(gap > 0, 1 / near - 1 / (near + width), 2 / zone)
        energy = density(u) * zone2 * spread * slope / (4 * np.pi**2)
    return np.nan_to_num(energy, nan=0.0, posinf=0.0)


def _image_distance(budget, width, terms):
    """The distance [m] from the window at which a band cut's periodic image (the grid is
    circular) rings no more than ``budget`` into it (:func:`_ringing` solved for the gap:
    ``d (d + width) = density ℓ² width |du/dx'| / (4π² budget)``; ``terms``: the
    numerator, ``density(u) ℓ² width |du/dx'|``)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        q = terms / (4 * np.pi**2 * budget)
        d = 0.5 * (np.sqrt(width**2 + 4 * q) - width)
    return np.nan_to_num(d, nan=0.0, posinf=0.0)


def _velocities(scene, shape):
    """``(v_r, v_a, moving)`` of a scene with moving scatterers, broadcast to ``shape``
    (``moving``: the scatterers whose velocity is not zero), else None."""
    if not hasattr(scene, "velocity_range") or is_traced(
            (scene.velocity_range, scene.velocity_azimuth)):
        return None
    v_r = np.broadcast_to(np.asarray(scene.velocity_range, float), shape)
    v_a = np.broadcast_to(np.asarray(scene.velocity_azimuth, float), shape)
    moving = (v_r != 0) | (v_a != 0)
    return (v_r, v_a, moving) if moving.any() else None


def _seen_rates(radar, moving):
    """``(c, b) = (v_r/v, 1 − v_a/v)``: a scatterer at ``a = x' − x`` from the pulse is seen
    at offset ``b a`` and range ``r + c a`` (still: ``(0, 1)``)."""
    if moving is None:
        return 0.0, 1.0
    v = float(radar.velocity)
    return moving[0] / v, 1 - moving[1] / v


def _seen_from(radar, along, r, moving):
    """``(a', r')`` at which the exact model sees a scatterer ``along = x' − x`` from the
    pulse: ``(a (1 − v_a/v), r + v_r a/v)`` when it moves."""
    if moving is None:
        return along, r
    c, b = _seen_rates(radar, moving)
    return along * b, r + c * along


def _band_wavenumbers(radar, bands):
    """(2,) the azimuth wavenumbers [rad/m] of the edges of the principal band and
    ``bands`` alias bands on each side (``band_look_angles``' ξ)."""
    dx = float(radar.azimuth_spacing)
    k0 = float(radar.wavenumber)
    xi_d = k0 * math.sin(float(np.asarray(radar.squint)))
    return xi_d + np.array([-1.0, 1.0]) * (2 * bands + 1) * math.pi / dx


def _moving_edges(radar, xi, moving):
    """The pattern arguments of a moving scatterer's stationary points at the band-edge
    wavenumbers ``xi`` (2,), at the carrier: two arrays of the scatterers' shape."""
    v_r, v_a, _ = moving
    with jax.ensure_compile_time_eval():
        u = [np.asarray(spectrum_terms(radar, edge, radar.wavenumber, v_r, v_a)[2])
             for edge in xi]
    return u


def _moving_offsets(radar, r, moving, xi):
    """(2, …) the along-track offsets ``x' − x`` [m] of a moving scatterer's stationary
    points at the band-edge wavenumbers ``xi``: from the pattern argument there, the
    look tangent ``τ = (w − T)/(1 + wT)`` (``w = uλ/L``, ``T = tan φ_d``) is
    ``(v − v_a) s / (r + v_r s)`` at the transmit time s, so ``x' − x = v s =
    v r τ / (v − v_a − v_r τ)``."""
    v_r, v_a, _ = moving
    v = float(radar.velocity)
    tan = math.tan(float(np.asarray(radar.squint)))
    w = np.stack(_moving_edges(radar, xi, moving)) * (
        float(radar.wavelength) / float(radar.antenna_length))
    tau = (w - tan) / (1 + w * tan)
    return v * r * tau / (v - v_a - v_r * tau)


def _chirp_share(radar, acquisition, x, r, window, moving=None):
    """The share of each scatterer's chirp ``R ± cτ/4`` the range window holds, R its
    slant range at the recorded pulse nearest its beam centre ``x' = x − r tan φ_d``; a
    moving one (``moving``, :func:`_velocities`) where it is at each pulse, at offset
    ``b s`` and range ``r + c s`` (``s = x' − x``, ``c = v_r/v``, ``b = 1 − v_a/v``), on
    the beam centre at ``s = −r tan φ_d/(b + c tan φ_d)``."""
    w0, w1 = window
    tan = math.tan(float(np.asarray(radar.squint)))
    c, b = _seen_rates(radar, moving)
    with np.errstate(divide="ignore", invalid="ignore"):  # b + c tan φ_d → 0: no crossing
        crossing = np.nan_to_num(x - r * tan / (b + c * tan))
    offset = np.clip(crossing, w0, w1) - x
    slant = np.hypot(*_seen_from(radar, offset, r, moving))
    half = float(radar.pulse_half_length)
    near = float(acquisition.near_range)
    far = near + (acquisition.num_range - 1) * float(radar.range_spacing)
    overlap = np.minimum(slant + half, far) - np.maximum(slant - half, near)
    return np.clip(overlap / (2 * half), 0.0, 1.0)


def _kept(slot, key, held, compute):
    """``compute()``, or the value kept in ``slot`` (a one-item list) for the same key: a
    call's plan and budgets ask for the same support and grid. The first ``held`` items of
    the key are compared by identity (the inputs are held, so that their identities cannot
    be reused), the others by value. Key and value are kept as one item: a call in
    another thread never sees one call's key with another's value."""
    last = slot[0]
    if last is not None and len(last[0]) == len(key) and all(
            a is b if i < held else a == b
            for i, (a, b) in enumerate(zip(last[0], key, strict=True))):
        return last[1]
    value = compute()
    slot[0] = (key, value)
    return value


_LAST_SUPPORT = [None]  # ((the inputs, AzimuthSupport),) of the last support decided


OFFSET_LIMIT = 4.0  # a moving target's band-edge offset held, over a still target's
FRESNEL_ZONES = 6.0  # margin of an echo's azimuth support beyond its band's edges


def fresnel_margin(radar, r):
    """``FRESNEL_ZONES`` Fresnel zones ``√(λr/2)`` [m] at range r: where a band's cut
    rings about its edge."""
    return FRESNEL_ZONES * np.sqrt(float(radar.wavelength) * r / 2)
AZIMUTH_TOLERANCE = 10 ** -3.5  # echo energy left out of the azimuth support (default)


def motion_margin(motion) -> float:
    """The largest line-of-sight deviation a motion can cause, ``max|Δy| + max|Δz|`` [m]
    (0 for none, or for traced values)."""
    total = 0.0
    for values in (getattr(motion, "horizontal", None), getattr(motion, "vertical", None)):
        if values is not None and not isinstance(values, jax.core.Tracer):
            total += float(np.max(np.abs(np.asarray(values)), initial=0.0))
    return total


_LAST = [None]  # ((the inputs, (support, grid)),) of the last grid decided


def band_grid(radar, scene, motion, acquisition, azimuth_padding, support, **rules):
    """(support, grid): :func:`work_grid` for the look angles of ``support``
    (:func:`azimuth_support`) and the motion's largest deviation. A call's plan and
    budgets ask for the same grid: the last one is kept (the inputs held, so that their
    identities cannot be reused)."""
    margin = motion_margin(motion)
    key = (radar, scene, margin, acquisition.num_pulses, acquisition.num_range,
           float(acquisition.near_range), float(acquisition.azimuth_center),
           azimuth_padding, support, tuple(sorted(rules.items())))
    return _kept(_LAST, key, 2, lambda: (support, work_grid(
        radar, scene, acquisition, azimuth_padding, support=support, motion_margin=margin,
        **rules)))


class WorkGrid(NamedTuple):
    """The padded grid a Fourier-domain simulation runs on (eager, NumPy).

    Attributes:
        lead: pulses synthesised before the first acquired pulse (the crop offset); as
            many after it, up to ``n_x``'s rounding, but for a scene with moving
            scatterers (high_speed), whose two sides are sized apart.
        n_x, n_r: azimuth and range FFT lengths.
        included: bool, broadcast to the scene (``(n_s,)`` or ``(n_az, n_lines)``): the
            scatterers whose echo reaches the window (within the support); the others
            add less than the tolerance there and are left out (else they would wrap in).
        extent: the azimuth span the scene needs over what one scatterer in the window
            needs (the window and one echo support): how far the scene reaches beyond.
        wrapped: fraction of the included scatterers whose support the azimuth grid does
            not hold (a fixed ``azimuth_padding`` smaller than the scene needs).
        wrapped_energy: the echo energy that grid wraps into the window, over the energy
            the window records (:func:`_wrapped_energy`; 0 where nothing wraps).
    """

    lead: int
    n_x: int
    n_r: int
    included: np.ndarray
    extent: float
    wrapped: float
    wrapped_energy: float = 0.0


def data_period(simulator, radar, scene, motion, acquisition) -> int:
    """Pulses over which a Fourier-domain simulation's data repeat: the grid's ``n_x``
    where a fixed ``azimuth_padding`` let echoes wrap (``grid.wrapped``), else 0 (every
    echo held: the data are those of a recorded window; the default padding always
    holds them, so its grid is not asked for)."""
    if simulator.azimuth_padding is None:
        return 0
    grid = simulator.grid(radar, scene, motion, acquisition)[1]
    return int(grid.n_x) if grid.wrapped > 0 else 0


def _scene_cells(scene, window=None):
    """(x, r) broadcastable NumPy arrays of the scene's scatterers. Traced azimuths (a
    gradient with respect to them) are taken at the window's ends ``window = (w₀, w₁)``,
    the farthest an in-window scatterer can be (traced ranges cannot size a grid)."""
    if is_traced(scene.range):
        raise ValueError("the Fourier-domain simulators size their grid from the scatterers' "
                         "ranges: scene.range must be concrete (not differentiated)")
    r = np.asarray(scene.range, float)
    if is_traced(scene.azimuth):
        if window is None:
            raise ValueError("scene.azimuth is traced")
        return np.asarray(window, float)[:, None], np.array([r.min(), r.max()])[None, :]
    x = np.asarray(scene.azimuth, float)
    if np.ndim(scene.reflectivity) == 2 and x.ndim == 1 and r.ndim == 1 and (
            np.shape(scene.reflectivity) == (x.size, r.size)):
        return x[:, None], r[None, :]
    return x, r


def _grid_cells(radar, scene, acquisition, bands, look, motion_margin):
    """The per-cell part of :func:`work_grid` that does not depend on the reflectivity,
    for the bands ±``bands`` (look angles ``look``) and a largest line-of-sight deviation
    ``motion_margin`` [m]: each scatterer's azimuth support ``[lo, hi]`` [m] and the
    period that holds it (``span``), whether it reaches the window (``kept``,
    ``included``), the range the window needs for it (``need_r`` [m], over the kept),
    and for moving ones (``moving``, :func:`_velocities`) the band edges held no farther
    than ``OFFSET_LIMIT`` allows (``too_far``)."""
    dx, dr = float(radar.azimuth_spacing), float(radar.range_spacing)
    n, n_range = acquisition.num_pulses, acquisition.num_range
    x_first = float(acquisition.azimuth_center) - (n - 1) / 2 * dx
    w0, w1 = x_first, x_first + (n - 1) * dx
    x, r = np.broadcast_arrays(*_scene_cells(scene, (w0, w1)))
    near = float(acquisition.near_range)
    far = near + (n_range - 1) * dr
    # azimuth support of each scatterer [m], with FRESNEL_ZONES Fresnel zones √(λr/2) on
    # each side: where the pattern is still high at the band's edge (a PRF below the
    # Doppler band) the spectrum's cut rings over a few zones
    fresnel = fresnel_margin(radar, r)
    lo = x - r * math.tan(look[1]) - fresnel
    hi = x - r * math.tan(look[0]) + fresnel
    moving = None if is_traced(scene.azimuth) else _velocities(scene, x.shape)
    if moving is not None:  # their own stationary points at the bands' edges
        edges = _band_wavenumbers(radar, bands)
        a_edges = _moving_offsets(radar, r, moving, edges)
        # a band edge beyond a target's Doppler horizon (beyond_horizon) has no
        # stationary point (its offset diverges): there the echo is held no farther
        # than a still target's, over 1 − |v_a|/v; an edge before the horizon is held
        # where it is, up to OFFSET_LIMIT times that (beyond, the grid does not hold
        # the echo: ``wrapped``). The cells nearer the horizon, whose stationary pulses
        # lie beyond the grid, high_speed leaves out (``_high_speed._direct_sum``)
        # rather than wrapping them into the window
        bound = (r * max(abs(math.tan(look[0])), abs(math.tan(look[1])))
                 / np.maximum(1 - np.abs(moving[1]) / float(radar.velocity), 1e-3))
        beyond = beyond_horizon(radar, moving, edges, x.ndim) | ~np.isfinite(a_edges)
        too_far = np.any(~beyond & (np.abs(a_edges) > OFFSET_LIMIT * bound), axis=0)
        a_edges = np.where(beyond, np.clip(np.nan_to_num(a_edges), -bound, bound),
                           np.clip(a_edges, -OFFSET_LIMIT * bound, OFFSET_LIMIT * bound))
        # its Fresnel zone in pulses is a still target's times v / v_eq (the echo's range
        # R ≈ r + (v_eq/v)² (x' − x)²/(2r)): 1.43× at 30 m/s along track, where the cut's
        # ringing outgrew a grid sized on a still target's zones (−24.9 dB, no warning)
        speed = float(radar.velocity)
        slower = np.maximum(1.0, speed / np.maximum(np.hypot(moving[0], speed - moving[1]),
                                                    1e-3 * speed))
        lo = np.where(moving[2], x + np.min(a_edges, axis=0) - fresnel * slower, lo)
        hi = np.where(moving[2], x + np.max(a_edges, axis=0) + fresnel * slower, hi)
    reaches = (hi >= w0 - dx) & (lo <= w1 + dx)
    # range support over the window's pulses a = x' − x ∈ [a₀, a₁] within the azimuth
    # support: R(a)² = (r + c a)² + (b a)², a moving scatterer where it is at each pulse
    # (c = v_r/v, b = 1 − v_a/v; still: c = 0, b = 1), least at a* = −r c/(c² + b²)
    # clipped to the interval, most at an end. (Its non-stop-and-go delay moves the echo
    # by (v_eq²|a|/v + r|v_r|)/c: 0.2 m at 7.5 km/s, within the two samples' margin.)
    a_ends = np.stack([np.clip(lo - x, w0 - x, w1 - x), np.clip(hi - x, w0 - x, w1 - x)])
    c, b = _seen_rates(radar, moving)
    vertex = np.clip(-r * c / (c**2 + b**2), a_ends[0], a_ends[1])
    reach = float(radar.pulse_half_length) + motion_margin + 2 * dr
    rho0 = np.hypot(*_seen_from(radar, vertex, r, moving)) - reach
    rho1 = np.max(np.hypot(*_seen_from(radar, a_ends, r, moving)), axis=0) + reach
    kept = reaches & (rho1 >= near) & (rho0 <= far)
    included = kept
    if is_traced(scene.azimuth):  # sized for scatterers anywhere in the window: all kept
        kept = np.ones(x.shape, bool)
        included = np.ones(np.shape(scene.reflectivity), bool)
    span = np.maximum(w1 - lo, hi - w0)  # the period that holds each echo's support
    need_r = np.max(np.where(kept, np.maximum(far - rho0, rho1 - near), 0.0), initial=0.0)
    return SimpleNamespace(x=x, r=r, lo=lo, hi=hi, moving=moving,
                           too_far=too_far if moving is not None else None, kept=kept,
                           included=included, need_r=need_r, span=span)


def work_grid(radar, scene, acquisition, azimuth_padding=None, *, support=None,
              motion_margin=0.0, doppler_limited=False, curvature=False, migration=False):
    """The padded grid of a Fourier-domain simulator (:class:`WorkGrid`; eager, on
    concrete values): the one place the azimuth extent, the crop and the range FFT length
    are decided.

    The synthesis is circular in both axes: a scatterer's echo, synthesised over its
    support ``[lo, hi]`` (pulses, or range samples), comes back shifted by whole periods
    ``P``. It stays out of the window ``[w₀, w₁]`` when ``P > max(w₁ − lo, hi − w₀)``; the
    grid takes the largest such P over the scatterers whose support reaches the window,
    so its cost grows with the scene's extent, not with a worst case. Scatterers whose
    support misses the window are left out (``included``): within the support's tolerance
    they add nothing there, and they would otherwise wrap in.

    * Azimuth support: the look angles of the synthesised Doppler bands
      (:func:`azimuth_support`; ``a = x' − x = −r tan φ``; ``support=None``: the
      principal band). A number
      ``azimuth_padding`` [footprints] instead pads the window by that many squinted
      footprints ``λ r_max / (L cos² φ_d)`` on each side (with ``doppler_limited``, no more
      than where the echo's Doppler leaves the PRF band), whatever the scene; ``wrapped``
      says which scatterers that grid does not hold.
    * Range support: the echo's range over the window's pulses within its azimuth support,
      ± the chirp ``cτ/4``, ``motion_margin`` (the largest line-of-sight deviation) and
      two samples; at least the window, the chirp (+2 samples) and the range walk of an
      echo over the window's pulses ``span |sin φ_d|`` (with ``curvature`` also its
      range curvature ``span²/(8 r_min)``, with ``migration`` the range migration at the
      edge of the synthesised bands ``r_max (1/√(1 − ξ_max²/k₀²) − 1)``,
      ``ξ_max = (2 bands + 1) π/Δx``). The range transform replicates the echo along
      range at each pulse, so the pulses the grid pads the window with need no room:
      they are cropped away.
    """
    dx, dr = float(radar.azimuth_spacing), float(radar.range_spacing)
    squint = float(np.asarray(radar.squint))
    n, n_range = acquisition.num_pulses, acquisition.num_range
    x_first = float(acquisition.azimuth_center) - (n - 1) / 2 * dx
    w0, w1 = x_first, x_first + (n - 1) * dx
    k0 = float(radar.wavenumber)
    bands = 0 if support is None else support.bands
    xi_max = (2 * bands + 1) * math.pi / dx  # the synthesised bands' edge
    look = band_look_angles(radar, 0) if support is None else support.look
    compute = functools.partial(_grid_cells, radar, scene, acquisition, bands, look,
                                motion_margin)
    # the same for a new reflectivity on the same cells: kept with their geometry (a
    # traced scene's geometry is its own, made afresh)
    cells = _recorded_geometry(radar, scene, acquisition).grid_cells(
        (bands, tuple(float(v) for v in look), float(motion_margin)), compute)
    x, r, lo, hi, moving, too_far, kept, included, need_r, span = (
        cells.x, cells.r, cells.lo, cells.hi, cells.moving, cells.too_far, cells.kept,
        cells.included, cells.need_r, cells.span)
    r_max, r_min = float(np.max(r)), float(np.min(r))
    if support is not None and support.hold is not None:
        # and keeps the images of its bands' cut from ringing into the window
        span = np.maximum(span, np.maximum(w1 - support.hold[0], support.hold[1] - w0))
    coarse = lambda pulses: -(-pulses // 128) * 128  # noqa: E731  (new target positions
    # rarely recompile)
    if azimuth_padding is None:
        need = np.max(np.where(kept, span, 0.0), initial=0.0)
        pad = coarse(max(0, math.ceil((need / dx + 1 - n) / 2)))
        lead = trail = pad
        if moving is not None and (kept & moving[2]).any():
            # high_speed leaves out a moving scatterer's cells whose stationary pulse lies
            # off the grid [x₀, x₀ + P) (its echo near the Doppler horizon): the grid holds
            # such a scatterer's support itself, on each side, not by wrapping it past the
            # window. A support held by wrapping only was cut where the grid ends, inside
            # the echo, and the cut rang into the window (30 m/s along track, seen 125 m
            # past the window's end: −25.0 dB against the exact model, no warning). The
            # sides are sized apart: a moving target is often seen far to one side
            held = kept & moving[2]
            sides = [coarse(max(0, math.ceil(float(np.max(np.where(held, d, 0.0))) / dx)))
                     for d in (w0 - lo, hi - w1)]
            total = max(2 * pad, sum(sides))
            lead = max(sides[0], min(pad, total - sides[1]))
            trail = total - lead
    else:
        extent = float(radar.footprint(r_max)) / math.cos(squint) ** 2
        if doppler_limited:
            extent = min(extent, r_max * xi_max / math.sqrt(max(k0**2 - xi_max**2, 1e-12)))
        pad = coarse(math.ceil(azimuth_padding * extent / dx))
        lead = trail = pad
    n_x = next_fast_len(n + lead + trail)
    period = n_x * dx
    holds = span < period
    if moving is not None:
        # each side of the grid, not only the period: high_speed leaves out the cells
        # beyond its ends
        beyond = (w0 - lo > lead * dx) | (hi - w1 > (n_x - n - lead) * dx)
        holds &= ~((too_far | beyond) & moving[2])
    wrapped = float(np.mean(~holds[kept])) if kept.any() else 0.0
    wrapped_energy = 0.0
    if azimuth_padding is not None and kept.any() and wrapped > 0:
        unheld_moving = (np.zeros(x.shape, bool) if moving is None
                         else ~holds & moving[2].astype(bool))
        wrapped_energy = _wrapped_energy(radar, scene, x, r, look, (w0, w1), period,
                                         kept, unheld_moving)
    # range: the scene's need, at least the fixed rule over the window's pulses (the
    # padded pulses need no room: docstring). Sized on the padded span (n_x Δx), a
    # squinted scene held far along track took 1728 samples where it needs 540
    span = n * dx
    walk = span * abs(math.sin(squint))
    if curvature:
        walk += span**2 / (8 * r_min)
    if migration:
        walk += r_max * (1 / math.sqrt(max(1 - (xi_max / k0) ** 2, 1e-6)) - 1)
    chirp = int(float(radar.chirp_samples)) + 2
    fixed = n_range + chirp + int(walk / dr)
    n_r = next_fast_len(max(fixed, math.ceil(need_r / dr) + 2))
    # the scene's need over what one scatterer in the window needs
    own = n * dx + r_max * (math.tan(look[1]) - math.tan(look[0]))
    return WorkGrid(lead, n_x, n_r, included, float(need) / own if azimuth_padding is None
                    else n_x * dx / own, wrapped, wrapped_energy)


WRAP_IMAGES = 3  # the grid's periodic images whose wrapped echo is counted one by one


def _wrapped_energy(radar, scene, x, r, look, window, period, kept, unheld_moving):
    """The echo energy a circular azimuth grid of ``period`` [m] wraps into the window
    ``(w₀, w₁)``, over the energy the window records (scatterers weighted by ``|γ|²``):
    the raw NMSE of a fixed ``azimuth_padding`` too small for the scene.

    A still scatterer's synthesised echo spans the look angles of the bands,
    ``x' − x ∈ [−r tan φ_hi, −r tan φ_lo]``; the part at ``x' ∈ [w₀, w₁] + kP``, k ≠ 0,
    lands in the window, with the energy ``|F(u(b)) − F(u(a))|`` of its pattern
    arguments (:func:`pattern_energy_table`), counted for ``|k| ≤ WRAP_IMAGES``, and
    beyond them the echo's whole remaining energy (an upper bound). The cut's ringing
    beyond the bands is not counted (measured ≤ −42 dB where nothing else wraps); a
    moving scatterer whose echo the grid does not hold counts as wholly wrapped (its
    recorded energy). Traced azimuths or reflectivities: 1."""
    if is_traced((scene.azimuth, scene.reflectivity)):
        return 1.0  # not computable: as if the whole echo wrapped (the grid did not hold it)
    w0, w1 = window
    u_grid, cumulative = pattern_energy_table(radar.pattern)

    def energy(a, b):  # of the echo over the pulses [a, b] (a ≤ b)
        fa, fb = (np.interp(np.nan_to_num(_pattern_u(radar, v - x, r)), u_grid, cumulative)
                  for v in (a, b))
        return np.abs(fb - fa)

    lo, hi = x - r * math.tan(look[1]), x - r * math.tan(look[0])
    recorded = energy(np.clip(w0, lo, hi), np.clip(w1, lo, hi))
    wrapped = np.zeros_like(recorded)
    for k in range(1, WRAP_IMAGES + 1):
        for shift in (-k * period, k * period):
            a, b = np.maximum(lo, w0 + shift), np.minimum(hi, w1 + shift)
            wrapped += np.where(b > a, energy(np.minimum(a, b), b), 0.0)
    reach = WRAP_IMAGES * period  # beyond: all of it, an upper bound
    wrapped += energy(lo, np.clip(w0 - reach, lo, hi)) + energy(np.clip(w1 + reach, lo, hi), hi)
    wrapped = np.where(unheld_moving, np.maximum(wrapped, recorded), wrapped)
    gamma = np.broadcast_to(np.asarray(scene.reflectivity), x.shape)
    weight = coincident_power(scene, gamma) * kept
    total = float(np.sum(weight * recorded))
    return float(np.sum(weight * wrapped)) / total if total > 0 else 0.0
