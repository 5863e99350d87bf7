"""Exact time-domain simulator — the reference model (physics.md §3, seed 000 eq. 19–20).

    h(x', r') = Σ_P γ_P · exp[−j 4πR/λ − j b (r' − R)²] · rect[(r' − R)/(cτ/2)]
                · W²((x' − x − δx)/X),     δx = (r + δr_xr) δ_az(x'),   X = λ r / L

with the exact 3-D slant range ``R`` from the actual antenna position. The kernel is
written for one pulse; :func:`_lift_over_pulses` maps it over pulses in chunks.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp

from .. import geometry
from ..scene import ReflectivityGrid
from ._base import AbstractSimulator

_TWO_PI = 2 * jnp.pi


def scatterer_phasors(radar, pulse, targets):
    """Per-scatterer quantities of one pulse (float64 geometry).

    Args:
        radar: the :class:`~sarjax.Radar`.
        pulse: tuple ``(x', Δy, Δz, δ_az)`` of scalars [m, m, m, rad].
        targets: tuple ``(x, r, h, γ)`` of (scatterer,) arrays.

    Returns:
        ``(range_offset, amplitude)``: ``R − r`` [m] and the complex weight
        ``γ W²(u) exp(−j 4πR/λ)``, each (scatterer,).
    """
    x_pulse, horizontal, vertical, pointing = pulse
    azimuth, slant_range, height, reflectivity = targets
    los = geometry.line_of_sight_deviation(
        horizontal, vertical, slant_range, height, radar.height
    )
    along_track = x_pulse - azimuth
    offset = geometry.range_offset(along_track, slant_range, los)  # R − r [m]
    footprint = radar.footprint(slant_range)  # X = λ r / L [m]
    u = (along_track - (slant_range + los) * pointing) / footprint
    k0 = radar.wavenumber
    # 4πR/λ mod 2π, formed from the exact decomposition R = r + (R − r) in float64.
    phase = jnp.mod(jnp.mod(k0 * slant_range, _TWO_PI) + k0 * offset, _TWO_PI)
    amplitude = reflectivity * radar.pattern(u) * jnp.exp(-1j * phase)
    return offset, amplitude


def pulse_echo(radar, pulse, targets, range_axis_offset, dtype):
    """Echo of one pulse from a set of scatterers: (range,) complex samples.

    Args:
        radar: the :class:`~sarjax.Radar`.
        pulse: ``(x', Δy, Δz, δ_az)`` scalars.
        targets: ``(x, r, h, γ)`` (scatterer,) arrays.
        range_axis_offset: ``(near_range, r'_k − near_range)``: a scalar [m] and a (range,)
            array [m] in the kernel's real dtype.
        dtype: complex dtype of the samples (complex64 or complex128).
    """
    near_range, sample_offsets = range_axis_offset
    real = jnp.finfo(dtype).dtype
    offset, amplitude = scatterer_phasors(radar, pulse, targets)
    # r' − R = (near − r − (R − r)) + (r'_k − near); the first term in float64.
    base = (near_range - targets[1] - offset).astype(real)
    delta = base[:, None] + sample_offsets[None, :]  # (scatterer, range)
    half = radar.pulse_half_length.astype(real)
    b = radar.chirp_rate.astype(real)
    phase = b * delta * delta
    inside = jnp.abs(delta) < half
    # cos/sin with the mask beats exp(1j·) on CPU (bit-identical)
    chirp = jax.lax.complex(jnp.where(inside, jnp.cos(phase), 0.0),
                            jnp.where(inside, -jnp.sin(phase), 0.0)).astype(dtype)
    weights = amplitude.astype(dtype)
    if weights.shape[0] <= 3:
        return jnp.sum(weights[:, None] * chirp, axis=0)
    return weights @ chirp  # a matrix–vector product: XLA's masked sum is slow for 4–32


def _chunked(targets, chunk):
    """Pad (scatterer,) arrays to a multiple of ``chunk`` (zero reflectivity) and reshape."""
    n = targets[0].shape[0]
    n_chunks = -(-n // chunk)
    pad = n_chunks * chunk - n
    padded = []
    for i, a in enumerate(targets):
        # padding repeats the first scatterer's geometry (always valid) with γ = 0
        fill = jnp.zeros((), a.dtype) if i == 3 else a[0]
        a = jnp.concatenate([a, jnp.full((pad,), fill, a.dtype)])
        padded.append(a.reshape(n_chunks, chunk))
    return tuple(padded)


def _lift_over_pulses(kernel, pulses, pulse_chunk):
    """The one place the one-pulse kernel is mapped over pulses (vmap within chunks)."""
    return jax.lax.map(kernel, pulses, batch_size=pulse_chunk)


class TimeDomain(AbstractSimulator):
    """Exact time-domain simulator (seed 000 "Algorithm C"), physics.md §3.

    Attributes:
        pulse_chunk: pulses evaluated together (vmapped); bounds memory. None = auto.
        scatterer_chunk: scatterers evaluated together per scan step. None = auto.
        memory_budget: bytes allowed for the kernel's intermediate arrays (auto chunks).
    """

    pulse_chunk: int | None = eqx.field(static=True, default=None)
    scatterer_chunk: int | None = eqx.field(static=True, default=None)
    memory_budget: int = eqx.field(static=True, default=256 * 2**20)

    def chunks(self, num_pulses, num_range, num_scatterers, dtype):
        """(pulse_chunk, scatterer_chunk) honouring the memory budget."""
        itemsize = jnp.dtype(dtype).itemsize
        per_cell = 4 * itemsize  # delta, chirp, product, mask temporaries
        # any scatterer chunk ≥ 48 costs the same CPU time, ≤ 32 about 4× more
        # (benchmarks/RESULTS.md sweep); few pulses per chunk bound the memory
        scat = self.scatterer_chunk or max(1, min(num_scatterers, 512))
        per_pulse = scat * num_range * per_cell
        pulse = self.pulse_chunk or max(
            1, min(num_pulses, self.memory_budget // per_pulse, max(1, 4096 // scat))
        )
        return int(pulse), int(scat)

    def __call__(self, radar, scene, motion, acquisition, dtype):
        if isinstance(scene, ReflectivityGrid):
            scene = scene.to_points()
        real = jnp.finfo(dtype).dtype
        x_pulse = acquisition.pulse_azimuths(radar)
        horizontal, vertical, pointing = motion.resolve(acquisition.num_pulses)
        pulses = (x_pulse, horizontal, vertical, pointing)
        targets = (scene.azimuth, scene.range, scene.height, scene.reflectivity)
        pulse_chunk, scat_chunk = self.chunks(
            acquisition.num_pulses, acquisition.num_range, scene.num_scatterers, dtype
        )
        chunked = _chunked(targets, scat_chunk)
        sample_offsets = (jnp.arange(acquisition.num_range) * radar.range_spacing).astype(real)
        axis = (acquisition.near_range, sample_offsets)

        def one_pulse(pulse):
            def accumulate(acc, chunk):
                return acc + pulse_echo(radar, pulse, chunk, axis, dtype), None

            init = jnp.zeros(acquisition.num_range, dtype)
            out, _ = jax.lax.scan(accumulate, init, chunked)
            return out

        return _lift_over_pulses(one_pulse, pulses, pulse_chunk)
