"""Time-domain back-projection for any known trajectory (physics.md §11).

    I(x, r) = Σ_p  s_c(x'_p, R_p(x, r)) · exp(+j 4π R_p(x, r)/λ)

with ``s_c`` the range-compressed pulse (upsampled, then linearly interpolated) and
``R_p`` the exact range from the actual antenna position of pulse p to the pixel at
(x, r, h = 0). The output carries the phase ``exp(−j 4π r/λ)`` of the target, like ω-k.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from .. import geometry
from .._numerics.interpolation import linear_interpolate, next_fast_len

_TWO_PI = 2 * jnp.pi


def _upsample_lines(lines, factor: int):
    """FFT-upsample (pulse, range) lines by ``factor`` (zeros inserted at Nyquist)."""
    n = lines.shape[-1]
    n_pad = next_fast_len(n + 32)
    spec = jnp.fft.fft(lines, n=n_pad, axis=-1)
    half = n_pad // 2
    up = jnp.zeros(lines.shape[:-1] + (n_pad * factor,), spec.dtype)
    up = up.at[..., :half].set(spec[..., :half])
    up = up.at[..., -(n_pad - half):].set(spec[..., half:])
    return jnp.fft.ifft(up, axis=-1) * factor


def backprojection(
    radar, compressed, azimuth_axis, range_axis, horizontal, vertical, image_azimuth,
    image_range, *, upsample: int = 8, pulse_chunk: int = 16,
):
    """Back-project range-compressed data onto an (x, r) image grid.

    Args:
        radar: the :class:`~sarjax.Radar`.
        compressed: (azimuth, range) range-compressed data.
        azimuth_axis: (azimuth,) pulse positions x' [m].
        range_axis: (range,) r' [m], uniform.
        horizontal, vertical: (azimuth,) actual track deviations Δy, Δz [m].
        image_azimuth: (n_x,) output azimuths x [m].
        image_range: (n_r,) output closest-approach slant ranges r [m] (pixels at h = 0).
        upsample: range upsampling factor before linear interpolation.
        pulse_chunk: pulses processed together.

    Returns:
        (n_x, n_r) complex image.
    """
    n_pulses = compressed.shape[0]
    near = range_axis[0]
    step = radar.range_spacing / upsample
    k0 = radar.wavenumber
    xx = image_azimuth[:, None]
    rr = image_range[None, :]
    carrier = jnp.mod(k0 * rr, _TWO_PI)

    def one_pulse(args):
        line, x_pulse, dy, dz = args
        line_up = _upsample_lines(line[None, :], upsample)[0]
        los = geometry.line_of_sight_deviation(dy, dz, rr, 0.0, radar.height)
        offset = geometry.range_offset(x_pulse - xx, rr, los)  # R − r
        position = (rr + offset - near) / step
        sample = linear_interpolate(line_up, position)
        return sample * jnp.exp(1j * (carrier + k0 * offset))

    chunk = min(pulse_chunk, n_pulses)
    n_chunks = -(-n_pulses // chunk)
    pad = n_chunks * chunk - n_pulses

    def prep(a):
        return jnp.pad(a, [(0, pad)] + [(0, 0)] * (a.ndim - 1)).reshape(
            (n_chunks, chunk) + a.shape[1:]
        )

    stacked = (prep(compressed), prep(azimuth_axis), prep(horizontal), prep(vertical))

    def body(image, block):
        contributions = jax.vmap(one_pulse)(block)
        return image + jnp.sum(contributions, axis=0), None

    init = jnp.zeros((image_azimuth.shape[0], image_range.shape[0]), compressed.dtype)
    image, _ = jax.lax.scan(body, init, stacked)
    return image * jnp.exp(-1j * carrier) / n_pulses
