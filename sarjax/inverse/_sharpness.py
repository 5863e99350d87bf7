"""A differentiable azimuth focuser and the image-sharpness objectives of autofocus.

The autofocus estimators work on the range-compressed data ``s(x', r')`` (the matched
filter of :func:`sarjax.processing.range_compress`), kept in a (range, azimuth) layout so
that every FFT runs along the last axis. A target at (x, r) has, in range bin r, the
azimuth history ``a W²(u) exp[−j k₀ R(x')]`` with ``k₀ = 4π/λ`` and
``R = √((r + δr_xr(x', r))² + (x' − x)²)`` (physics.md §2–3); a trajectory deviation adds
the line-of-sight phase ``−k₀ δr_xr(x', r)``.

Focusing with a trial motion (Δy, Δz) is

    I(x, r) = F⁻¹_ξ { F_x'{ s(x', r) · exp[+j k₀ δr_xr(x', r)] } · exp[+j(√(k₀² − ξ²) − k₀) r] }

the phase compensation of the motion at every (x', r) followed by the azimuth matched
filter of the straight track at range r (the ω-k reference function at η = 0, physics.md
§4). The range migration (≤ (X/2)²/(2r) ≈ 0.6 m on the airborne set, a fifth of a range
cell) is not corrected: it only tapers a target's azimuth amplitude, not its phase. Both
steps are unitary along azimuth (the data are zero-padded so that nothing wraps), so the
image energy ``E = Σ|I|²`` does not depend on the motion and the sharpness objectives
below are normalised by a constant.

Objectives (to minimise):

* entropy ``S = −Σ p log p``, ``p = |I|²/E`` (Kragh & Kharbouch; Wang & Liu);
* contrast ``−log(Σ |I|⁴ / E²)`` (power-law sharpness, Fienup & Miller 2003, exponent 2).

Speckle of fully developed, spatially white clutter is a circular Gaussian field: a phase
error only permutes it into another such field, so neither objective sees defocus there.
The information comes from point scatterers and from edges of the backscatter (see
``docs/autofocus.md``).
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import geometry
from .._numerics.interpolation import next_fast_len
from ..processing._range_compression import range_compress, range_fft_length

OBJECTIVES = ("entropy", "contrast")
MIN_LOOK_ANGLE = np.deg2rad(5.0)  # nearer range bins have no scene [rad]


class AzimuthFocuser(eqx.Module):
    """Range-compressed data and the azimuth matched filters of the straight track.

    Attributes:
        radar: the :class:`~sarjax.Radar`.
        compressed: (range, n_fft) range-compressed data, transposed, zero-padded in
            azimuth (the pulses are the first ``num_pulses`` columns).
        azimuth: (num_pulses,) pulse positions x' [m].
        range: (range,) slant ranges r of the kept range bins [m].
        filters: (range, n_fft) ``exp[+j(√(k₀² − ξ²) − k₀) r]`` on the azimuth
            wavenumbers ξ of the padded grid.
        energy: E = Σ|I|² (float; independent of the motion).
    """

    radar: object
    compressed: jnp.ndarray
    azimuth: jnp.ndarray
    range: jnp.ndarray
    filters: jnp.ndarray
    energy: jnp.ndarray

    @property
    def num_pulses(self) -> int:
        return int(self.azimuth.shape[0])

    def line_of_sight_phase(self, horizontal, vertical, range_index=None):
        """(range, pulse) two-way phase k₀ δr_xr(x', r) [rad] of a deviation (Δy, Δz), each
        (pulse,) [m], at the kept range bins (or at ``range_index`` of them)."""
        r = self.range if range_index is None else self.range[range_index]
        los = geometry.line_of_sight_deviation(horizontal[None, :], vertical[None, :],
                                               r[:, None], 0.0, self.radar.height)
        return self.radar.wavenumber * los

    def image(self, phase, range_index=None):
        """(range, n_fft) image after compensating the phase ``phase`` [rad].

        Args:
            phase: (range, pulse) or (pulse,) phase to remove: the data are multiplied by
                ``exp(+j phase)``.
            range_index: optional (k,) indices of the range bins to focus.
        """
        return jnp.fft.ifft(self.spectrum(phase, range_index), axis=-1)

    def spectrum(self, phase, range_index=None):
        """(range, n_fft) azimuth spectrum of :meth:`image` (the compensated data's
        transform times the matched filters), same arguments."""
        data = self.compressed if range_index is None else self.compressed[range_index]
        filters = self.filters if range_index is None else self.filters[range_index]
        n_fft = data.shape[-1]
        phase = jnp.broadcast_to(phase, data.shape[:-1] + (self.num_pulses,))
        pad = n_fft - self.num_pulses
        rotation = jnp.pad(jnp.exp(1j * phase).astype(data.dtype), ((0, 0), (0, pad)))
        return jnp.fft.fft(data * rotation, axis=-1) * filters

    def unfocus(self, image, range_index):
        """Inverse of the azimuth matched filter: (k, n_fft) image rows of the bins
        ``range_index`` back to their range-compressed azimuth histories."""
        spectrum = jnp.fft.fft(image, axis=-1) * jnp.conj(self.filters[range_index])
        return jnp.fft.ifft(spectrum, axis=-1)


def make_focuser(radar, raw, *, min_look_angle=MIN_LOOK_ANGLE, dtype=jnp.complex64,
                 range_stride: int = 1) -> AzimuthFocuser:
    """Range-compress ``raw`` and build the :class:`AzimuthFocuser` (outside jit).

    Keeps the range bins with a ground position at look angle ≥ ``min_look_angle``
    (``r cos ϑ = H``; nearer bins have no scene) and every ``range_stride``-th of them.
    The azimuth padding holds one footprint at the far range, so that no target wraps.
    """
    data = jnp.asarray(raw.data)
    n_fft_range = range_fft_length(radar, data.shape[-1])
    compressed = np.asarray(_compress(radar, data, n_fft_range))
    r_axis = np.asarray(raw.range, float)
    height = float(radar.height)
    keep = np.flatnonzero(r_axis * np.cos(min_look_angle) >= height)[::range_stride]
    if keep.size < 2:
        raise ValueError(
            f"raw.range {r_axis[0]:.0f}…{r_axis[-1]:.0f} m has fewer than 2 range bins with "
            f"a look angle ≥ {np.degrees(min_look_angle):.1f}° at H = {height:.0f} m"
        )
    ranges = r_axis[keep]
    x = np.asarray(raw.azimuth, float)
    spacing = float(radar.azimuth_spacing)
    footprint = float(radar.footprint(ranges.max()))
    n_fft = next_fast_len(x.size + int(np.ceil(footprint / spacing)) + 8)
    k0 = float(radar.wavenumber)
    xi = 2 * np.pi * np.fft.fftfreq(n_fft, spacing)
    # (√(k₀² − ξ²) − k₀) r written as −ξ² r / (√(k₀² − ξ²) + k₀) (no cancellation)
    filters = np.exp(-1j * (xi[None, :] ** 2 / (np.sqrt(k0**2 - xi**2) + k0)[None, :])
                     * ranges[:, None])
    block = compressed[:, keep].T
    padded = np.zeros((keep.size, n_fft), np.complex128)
    padded[:, : x.size] = block
    energy = float(np.sum(np.abs(block) ** 2))
    return AzimuthFocuser(
        radar=radar, compressed=jnp.asarray(padded, dtype), azimuth=jnp.asarray(x),
        range=jnp.asarray(ranges), filters=jnp.asarray(filters, dtype),
        energy=jnp.asarray(energy),
    )


@eqx.filter_jit
def _compress(radar, data, n_fft):
    return range_compress(radar, data, n_fft=n_fft)


def entropy(image, energy):
    """Image entropy ``−Σ p log p``, ``p = |I|²/E`` (dimensionless, ≥ 0)."""
    p = (jnp.real(image) ** 2 + jnp.imag(image) ** 2) / energy
    return -jnp.sum(p * jnp.log(p + 1e-30))


def contrast(image, energy):
    """Power-law sharpness ``Σ|I|⁴ / E²`` (dimensionless; larger is sharper)."""
    p = (jnp.real(image) ** 2 + jnp.imag(image) ** 2) / energy
    return jnp.sum(p**2)


def sharpness_loss(image, energy, objective: str):
    """The quantity minimised: the entropy, or minus the logarithm of the contrast (the
    same optimum, on a scale the optimiser's tolerances suit)."""
    if objective == "entropy":
        return entropy(image, energy)
    if objective == "contrast":
        return -jnp.log(contrast(image, energy))
    raise ValueError(f"objective={objective!r}; choose one of {OBJECTIVES}")


def image_entropy(image) -> float:
    """Entropy of a complex image (NumPy; the metric reported beside the objectives)."""
    p = np.abs(np.asarray(image)) ** 2
    p = p / p.sum()
    return float(-np.sum(p * np.log(p + 1e-300)))


def image_contrast(image) -> float:
    """Intensity contrast std(|I|²)/mean(|I|²) of a complex image (NumPy)."""
    p = np.abs(np.asarray(image)) ** 2
    return float(p.std() / p.mean())


def value_and_grad(fn):
    """``jax.value_and_grad`` of a scalar loss, jitted once (equinox filter)."""
    return eqx.filter_jit(jax.value_and_grad(fn))
