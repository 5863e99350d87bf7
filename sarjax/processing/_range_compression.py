"""Matched-filter range compression (physics.md §11)."""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp

from .._numerics.interpolation import next_fast_len


def chirp_replica(radar, offsets):
    """Transmitted chirp in range coordinates, centred on 0 (seed 000 eq. 19):
    ``exp(−j b o²) rect(o / (cτ/2))`` at offsets ``o`` [m]."""
    inside = jnp.abs(offsets) < radar.pulse_half_length
    return jnp.where(inside, jnp.exp(-1j * radar.chirp_rate * offsets**2), 0.0)


def range_fft_length(radar, num_range: int) -> int:
    """FFT length that holds ``num_range`` samples plus one chirp without wrap-around.

    Needs concrete radar values (call it outside ``jit``); inside a trace it falls back to
    ``2 · num_range``, which suffices whenever the chirp is shorter than the window.
    """
    try:
        chirp = int(float(radar.chirp_samples)) + 2
    except jax.errors.ConcretizationTypeError:
        chirp = num_range
    return next_fast_len(num_range + chirp)


@eqx.filter_jit  # n_fft static: one program per length
def matched_filter(radar, n_fft: int):
    """(n_fft,) range matched filter ``conj(FFT(replica)) / N_tp`` on the circular offset
    grid ``o_k = k · c/(2 f_s)``, k = −n/2 … n/2 − 1 (scaled so a unit echo peaks at ≈ 1)."""
    k = jnp.fft.fftfreq(n_fft) * n_fft
    replica = chirp_replica(radar, k * radar.range_spacing)
    norm = jnp.maximum(jnp.sum(jnp.abs(replica) ** 2), 1.0)
    return jnp.conj(jnp.fft.fft(replica)) / norm


def range_compress(radar, data, *, n_fft: int | None = None, keep_spectrum: bool = False,
                   lags: int = 0):
    """Range-compress raw data by matched filtering.

    Args:
        radar: the :class:`~sarjax.Radar`.
        data: (azimuth, range) raw samples.
        n_fft: range FFT length (static; default :func:`range_fft_length`).
        keep_spectrum: return the (azimuth, n_fft) range spectrum instead of samples.
        lags: samples (static) of the correlation kept beyond each end of the window
            (:func:`sarjax.processing._focus.recorded_lags`): the transform is linear over
            the window and a chirp (:func:`range_fft_length`), so the lags before the first
            sample are the end of its output, those after the last follow it.

    Returns:
        (azimuth, range + 2 lags) range-compressed samples on the r' grid extended by
        ``lags`` samples at each end (an echo centred on R peaks at r' = R), or the
        spectrum.
    """
    n_range = data.shape[-1]
    n_fft = n_fft or range_fft_length(radar, n_range)
    if n_range + 2 * lags > n_fft:
        raise ValueError(f"lags={lags} beyond the window's {n_range} samples do not fit in "
                         f"a range transform of n_fft={n_fft}")
    spectrum = jnp.fft.fft(data, n=n_fft, axis=-1) * jnp.expand_dims(
        matched_filter(radar, n_fft), tuple(range(data.ndim - 1))
    )
    if keep_spectrum:
        return spectrum
    compressed = jnp.fft.ifft(spectrum, axis=-1)
    if not lags:
        return compressed[..., :n_range]
    return jnp.concatenate([compressed[..., n_fft - lags:], compressed[..., :n_range + lags]],
                           axis=-1)
