"""The exact model at Fourier speed: one non-uniform FFT per pulse (physics.md §3).

Per pulse x', the sampled echo of scatterers at one-way echo ranges ρ_P (exact 3-D
geometry with the pulse's deviation; the same ``ρ``, pattern and carrier phase as
:class:`~sarjax.simulators.TimeDomain`) has the DFT over its range samples

    D(η_k) = (1/Δr) Σ_m C(η_k + 2πm/Δr) F(η_k + 2πm/Δr),
    F(η) = Σ_P a_P e^{−jη (ρ_P − r'_0)},    a_P = γ_P W²(u_P) e^{−j 4πρ_P/λ},

with C the chirp's continuous spectrum (Fresnel integrals, see
:func:`sarjax.simulators._fourier_engine.chirp_spectrum`) and m the range aliases of the sampled
hard-edged chirp (Poisson summation). ``F`` on the (2M + 1)·n_r wavenumbers of the
bands m = −M … M is a type-1 non-uniform FFT: each scatterer is spread onto a 2×
oversampled periodic grid with an "exponential of semicircle" kernel
``φ(z) = exp(β(√(1 − z²) − 1))`` of ``w`` cells (evaluated as a polynomial in the
fractional offset), the grid is FFT'd and divided by the kernel's transform. The bands
are folded onto the sampled band and one inverse FFT gives the pulse's samples.

Cost per pulse ``O(w N_P + n_r log n_r)`` instead of the direct ``O(N_P N_r)``; the
kernel width follows ``tolerance`` (``w = ⌈log₁₀(1/tolerance)⌉ + 1``: relative error
≈ tolerance). ``engine="direct"`` evaluates ``F`` as the plain sum (the reference with
the same band limit). The model differs from the direct time-domain simulator only by
the chirp spectrum's tails beyond the 2M + 1 bands (``range_bands=M``): they are what
the sampled hard-edged pulse aliases, and they fall off as 1/η².

Scatterers whose echo does not reach the range window contribute nothing (as in the
time domain): they are masked, so that the periodic FFT cannot wrap them in.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import geometry
from .._numerics import native as _native
from .._numerics.es_kernel import kernel_transform, kernel_width, spreading_kernel
from .._numerics.interpolation import next_fast_len
from .._numerics.phasor import reduced_phasor, unit_phasor, wrap_phase
from ..scene import ReflectivityGrid
from ._base import AbstractExactSimulator, AbstractPlan, Cost
from ._fourier_engine import chirp_spectrum
from ._time_domain import echo_range_offset, needs_general_kernel, pattern_argument

_TWO_PI = 2 * np.pi


# --------------------------------------------------------------------------------------
# spreading kernel
# --------------------------------------------------------------------------------------


def _spread_xla(points, amplitude, width, grid, coefficients, reach):
    """(grid,) Σ_P a_P ψ(l − t_P) on a periodic grid of ``grid`` cells (the JAX
    formulation: the reference of the native kernel, its derivatives and its fallback).

    Args:
        points: (n,) grid positions t_P [cells] (float64), within ``[−reach, grid + reach]``
            for every non-zero amplitude (others are clamped).
        amplitude: (n,) complex a_P.
        reach: cells a point may lie outside [0, grid) (static).

    The taps are added one at a time in a loop: its operands (positions, amplitudes) are
    then computed once, not once per tap as a fused ``amplitude[:, None] * taps`` would;
    an extended grid with the wrap folded afterwards avoids a modulo per tap. On a CPU
    the scatter adds complex values; elsewhere (pairs of real values) it adds each real
    and imaginary part on its own: XLA's GPU scatter-add of complex64 values took 1.9 ms
    for 404 352 × 5 updates on an H200, of (n, 2) float32 pairs 0.22 ms, and complex128
    0.35 against 0.31 ms (on the CPU pairs took twice as long: 5.9 against 2.6 ms).
    """
    return jax.lax.platform_dependent(
        points, amplitude,
        cpu=functools.partial(_spread_taps, width=width, grid=grid,
                              coefficients=coefficients, reach=reach, pairs=False),
        default=functools.partial(_spread_taps, width=width, grid=grid,
                                  coefficients=coefficients, reach=reach, pairs=True))


def _spread_taps(points, amplitude, *, width, grid, coefficients, reach, pairs):
    """:func:`_spread_xla`, the scatter over complex values or (``pairs``) real pairs."""
    low = int(math.ceil(reach)) + width
    start = jnp.ceil(points - width / 2)
    real = jnp.finfo(amplitude.dtype).dtype  # the tap weights in the amplitude's precision
    f = (start - (points - width / 2)).astype(real)  # [0, 1)
    first = jnp.clip(start, -low, grid + low).astype(jnp.int32) + low
    table = jnp.asarray(coefficients, real)
    # the values added: complex, or (n, 2) real and imaginary parts
    values = jnp.stack([jnp.real(amplitude), jnp.imag(amplitude)], -1) if pairs else amplitude

    length = grid + 2 * low + 1  # cells a tap's window spans: first ∈ [0, grid + 2 low]

    def add_tap(i, extended):
        c = table[:, i]
        tap = jnp.full_like(f, c[-1])
        for k in range(table.shape[0] - 2, -1, -1):
            tap = tap * f + c[k]
        # tap i added at ``first`` into the grid's window from cell i (a slice of the
        # small grid): the scatterers' indices are not formed again per tap
        window = jax.lax.dynamic_slice_in_dim(extended, i, length)
        update = values * (tap[:, None] if pairs else tap.astype(amplitude.dtype))
        window = window.at[first].add(update, mode="promise_in_bounds")
        return jax.lax.dynamic_update_slice_in_dim(extended, window, i, 0)

    extended = jnp.zeros((grid + 2 * low + width, *values.shape[1:]), values.dtype)
    extended = jax.lax.fori_loop(0, width, add_tap, extended)
    if pairs:
        extended = jax.lax.complex(extended[:, 0], extended[:, 1])
    # extended cell j is grid cell j − low: folded onto the periodic grid (any G, w)
    cell = np.mod(np.arange(extended.shape[0]) - low, grid)
    return jnp.zeros(grid, amplitude.dtype).at[cell].add(extended)


def _spread(points, amplitude, width, grid, coefficients, reach, native):
    """:func:`_spread_xla`'s sum; with ``native`` (static) by the native CPU kernel
    (:mod:`sarjax._numerics.native`) where the program runs on a CPU, its derivatives
    (any order, forward and reverse) those of :func:`_spread_xla`."""
    xla = functools.partial(_spread_xla, width=width, grid=grid,
                            coefficients=coefficients, reach=reach)
    if not native:
        return xla(points, amplitude)
    real = jnp.finfo(amplitude.dtype).dtype
    call = jax.ffi.ffi_call(_native.TARGETS[np.dtype(amplitude.dtype)],
                            jax.ShapeDtypeStruct((grid,), amplitude.dtype),
                            vmap_method="sequential")
    low = int(math.ceil(reach)) + width

    @jax.custom_jvp
    def spread(points, amplitude):
        return jax.lax.platform_dependent(
            points, amplitude,
            cpu=lambda p, a: call(p, a, jnp.asarray(coefficients, real),
                                  grid=np.int64(grid), low=np.int64(low)),
            default=xla)

    @spread.defjvp
    def _(primals, tangents):
        return spread(*primals), jax.jvp(xla, primals, tangents)[1]

    return spread(points, amplitude)


# --------------------------------------------------------------------------------------
# the simulator
# --------------------------------------------------------------------------------------


class NUFFTPlan(AbstractPlan):
    """Static sizes of the NUFFT exact model: the range FFT length, whether the general
    (squint, moving, non-stop-and-go) geometry runs, and whether the spreading runs in
    the native CPU kernel (:mod:`sarjax._numerics.native`: decided here, so that a
    program with the kernel's call is keyed apart from one without)."""

    range_fft_size: int = eqx.field(static=True)
    general: bool = eqx.field(static=True)
    native: bool = eqx.field(static=True, default=False)


class TimeDomainNUFFT(AbstractExactSimulator):
    """Exact time-domain model, one non-uniform FFT per pulse (module docstring).

    ``method="time_domain_nufft"``. Same geometry, pattern, carrier phase, squint, moving
    scatterers and ``stop_and_go`` as ``method="time_domain"``; the chirp is represented
    by its spectrum over ``2 range_bands + 1`` bands of width f_s (the direct time-domain
    simulator samples the hard-edged chirp, whose spectrum never ends): the two agree to
    the energy of the chirp spectrum outside those bands (−36 dB for the airborne set
    with ``range_bands=1``, −44 dB with 2 at the chirp ends; the echo interiors agree far
    better). ``method="time_domain"`` is unchanged (it stays the exact judge).

    Attributes:
        tolerance: relative accuracy of the non-uniform FFT (kernel width).
        range_bands: chirp-spectrum bands M on each side of the sampled band.
        engine: ``"nufft"`` or ``"direct"`` (plain sum over scatterers: the reference
            with the same band limit, O(N_P · (2M + 1) n_r) per pulse).
        stop_and_go: as :class:`~sarjax.simulators.TimeDomain`.
        pulse_chunk: pulses evaluated together (vmapped; default 1: XLA's scatter-add is
            ~4× slower batched); larger chunks are bounded by ``memory_budget``.
        memory_budget: bytes for the per-chunk intermediates.
        loops: independent pulse loops (they may run concurrently on several cores).
    """

    names: ClassVar[tuple[str, ...]] = ("time_domain_nufft",)
    physics: ClassVar[str] = "physics.md §3, §8, §10 (the exact model by a type-1 NUFFT)"
    compile_time: ClassVar[float] = 2.0

    tolerance: float = eqx.field(static=True, default=1e-4)
    range_bands: int = eqx.field(static=True, default=2)
    engine: str = eqx.field(static=True, default="nufft")
    stop_and_go: bool = eqx.field(static=True, default=True)
    pulse_chunk: int = eqx.field(static=True, default=1)
    memory_budget: int = eqx.field(static=True, default=512 * 2**20)
    loops: int = eqx.field(static=True, default=2)

    def prepare(self, radar, scene, acquisition, motion=None) -> NUFFTPlan:
        """Check the options; fix the range FFT size and the model branch."""
        kernel_width(self.tolerance)
        if self.engine not in ("nufft", "direct"):
            raise ValueError(f"engine={self.engine!r} must be 'nufft' or 'direct'")
        if not (isinstance(self.range_bands, int) and 0 <= self.range_bands <= 8):
            raise ValueError(f"range_bands={self.range_bands!r} must be an integer in 0…8")
        n_r = next_fast_len(acquisition.num_range + int(float(radar.chirp_samples)) + 2)
        return NUFFTPlan(n_r, needs_general_kernel(radar, scene, self.stop_and_go),
                         self.engine == "nufft" and _native.available())

    def sizes(self, plan):
        """(n_r, bands Q/n_r, grid G, kernel width w) of one pulse's transform."""
        n_r = plan.range_fft_size
        bands = 2 * self.range_bands + 1
        width = kernel_width(self.tolerance)
        grid = next_fast_len(2 * bands * n_r)
        return n_r, bands, grid, width

    def chunk(self, plan, num_pulses, num_scatterers, dtype):
        """``pulse_chunk``, reduced to fit ``memory_budget`` (about 12 float64 per
        scatterer plus the w spread values, and the grid, per pulse)."""
        n_r, bands, grid, width = self.sizes(plan)
        itemsize = jnp.dtype(dtype).itemsize
        per_pulse = num_scatterers * (12 * 8 + 2 * width * (8 + itemsize)) + 4 * grid * 16
        if self.engine == "direct":
            per_pulse += num_scatterers * bands * n_r * 16
        fit = self.memory_budget // max(per_pulse, 1)
        return int(max(1, min(num_pulses, self.pulse_chunk, fit)))

    def memory(self, plan, radar, scene, acquisition, dtype) -> int:
        """≈ 20 oversampled-grid-sized tables (chirp spectrum, deconvolution, indices),
        and per pulse in flight (``loops`` concurrent loops of ``chunk()`` pulses) the
        extended grid and a tap's window of it (≈ 2 grids each) and the scatterers'
        geometry and spread values; ``engine="direct"`` adds its
        (scatterer, band · n_r) phasor table per pulse of a chunk (fitted to XLA's memory
        analysis, with a margin)."""
        n_r, bands, grid, width = self.sizes(plan)
        n, n_s = acquisition.num_pulses, scene.num_scatterers
        item = np.dtype(dtype).itemsize
        chunk = self.chunk(plan, n, n_s, dtype)
        in_flight = max(1, min(self.loops, n)) * chunk
        per_pulse = 4 * grid * item + n_s * (6 * 8 + width * item)
        workspace = 20 * grid * 16 + in_flight * per_pulse
        if self.engine == "direct":
            workspace += 1.2 * chunk * n_s * bands * n_r * 16
        return int(workspace)

    def smaller_chunks(self, plan, acquisition, scene, dtype):
        """Fewer pulses at a time, then one loop."""
        pulse = self.chunk(plan, acquisition.num_pulses, scene.num_scatterers, dtype)
        while pulse > 1:
            pulse //= 2
            yield dataclasses.replace(self, pulse_chunk=pulse)
        if self.loops > 1:
            yield dataclasses.replace(self, pulse_chunk=1, loops=1)

    def cost(self, plan, radar, scene, acquisition, dtype) -> Cost:
        """Per pulse: one FFT of the oversampled grid (≈ 8 ns per element and log₂ of its
        size) and the geometry and spreading of each scatterer: with the spreading's JAX
        formulation ≈ 9 ns in complex128, 7.2 ns in complex64, so that the 972 × 416 grid
        scene, 972 pulses, costs the 4.2 / 3.5 s ``bench_nufft`` measured in one block of
        pulses; with the native kernel two thirds of that (``bench_nufft``, one run:
        complex64 1.97 s against 2.95 s, complex128 2.51 s); compile ≈ 2 s."""
        _, _, grid, _ = self.sizes(plan)
        per_scatterer = 7.2e-9 if np.dtype(dtype) == np.complex64 else 9e-9
        if plan.native:
            per_scatterer *= 2 / 3
        per_pulse = (scene.num_scatterers * per_scatterer
                     + 8e-9 * grid * np.log2(max(grid, 2)))
        return Cost(compile=self.compile_time, steady=acquisition.num_pulses * per_pulse)

    def simulate(self, plan, radar, scene, motion, acquisition, dtype):
        if isinstance(scene, ReflectivityGrid):
            scene = scene.to_points()
        n_range = acquisition.num_range
        n_r, bands, grid, width = self.sizes(plan)
        modes = bands * n_r
        coefficients, _ = spreading_kernel(width, grid / modes)
        deconvolve = jnp.asarray(1.0 / kernel_transform(width, grid / modes, grid, modes))
        # mode q (FFT order of the Q = bands·n_r modes) sits at grid frequency q mod G
        q = np.fft.fftfreq(modes, 1.0 / modes).astype(np.int64)
        grid_index = jnp.asarray(np.mod(q, grid))
        dr = radar.range_spacing
        eta = jnp.asarray(q) * (_TWO_PI / n_r) / dr  # η_q [rad/m]
        chirp = chirp_spectrum(radar, eta) / dr  # (Q,) C(η_q)/Δr
        transfer = (chirp * deconvolve).astype(dtype)
        near = acquisition.near_range
        k0 = radar.wavenumber
        carrier = wrap_phase(k0 * scene.range)  # k₀ r reduced to [−π, π], once per scatterer
        window = (n_range - 1) * dr
        half = radar.pulse_half_length
        real = jnp.finfo(dtype).dtype
        # a visible echo centre lies in (−cτ/4, window + cτ/4), and n_r Δr exceeds the
        # window by more than cτ/2: its cell is within (−G/2, G)
        reach = grid / 2

        targets = (scene.azimuth, scene.range, scene.height, scene.reflectivity,
                   scene.velocity_range, scene.velocity_azimuth)
        # per scatterer, formed once for every pulse: the cross-track position, the
        # pattern's scale 1/X (a product per pulse, not a division), the range from the
        # window's start and the reflectivity in the output's precision
        ground = geometry.ground_range(scene.range, scene.height, radar.height)
        drop = radar.height - scene.height
        inverse_footprint = 1 / radar.footprint(scene.range)
        from_near = scene.range - near
        reflectivity = scene.reflectivity.astype(dtype)
        x_pulse = acquisition.pulse_azimuths(radar)
        horizontal, vertical, pointing = motion.resolve(acquisition.num_pulses)

        def echo_geometry(pulse):
            """(ρ − r'_0 [m], a_P) of every scatterer for one pulse."""
            if plan.general:
                offset, (along, moved, los) = echo_range_offset(
                    radar, pulse, targets, self.stop_and_go)
                u = pattern_argument(radar, pulse[3], along, moved, los)
            else:
                x_p, dy, dz, daz = pulse
                los = geometry.line_of_sight_deviation_across(dy, dz, scene.range, ground,
                                                              drop)
                along = x_p - scene.azimuth
                offset = geometry.range_offset(along, scene.range, los)
                u = (along - (scene.range + los) * daz) * inverse_footprint
            position = from_near + offset  # ρ − r'_0
            visible = (position > -half) & (position < window + half)
            # the pattern and the phasor in the output's precision: the phase is formed
            # and reduced in float64 (reduced_phasor), the pattern's argument rounded
            # only after the float64 geometry (complex64: −130 dB from complex128)
            gain = jnp.where(visible, radar.pattern(u.astype(real)), 0.0)
            amplitude = (reflectivity * gain.astype(real)
                         * reduced_phasor(-(carrier + k0 * offset), dtype))
            return position, amplitude

        def one_pulse(pulse):
            position, amplitude = echo_geometry(pulse)
            if self.engine == "direct":
                phase = -jnp.outer(eta, position)  # (Q, n)
                spectrum = (unit_phasor(phase.astype(real)) @ amplitude) * chirp.astype(dtype)
            else:
                cells = position * (grid / (n_r * dr))  # t = G θ / 2π, θ = Δη (ρ − r'_0)
                spread = _spread(cells, amplitude, width, grid, coefficients, reach,
                                 plan.native)
                spectrum = jnp.fft.fft(spread)[grid_index] * transfer
            folded = spectrum.reshape(bands, n_r).sum(axis=0)  # Σ_m over the bands
            return jnp.fft.ifft(folded)[:n_range]

        pulses = (x_pulse, horizontal, vertical, pointing)
        chunk = self.chunk(plan, acquisition.num_pulses, scene.num_scatterers, dtype)
        return map_pulses(one_pulse, pulses, chunk, self.loops).astype(dtype)


def map_pulses(kernel, pulses, chunk, loops):
    """The one place the one-pulse kernel is mapped over pulses: ``loops`` independent
    sequential loops over contiguous pulse ranges (they can run concurrently), each
    evaluating ``chunk`` pulses together (vmapped). XLA's scatter-add runs ~4× faster
    unbatched, so ``chunk=1`` is the default."""
    n = pulses[0].shape[0]
    per_loop = -(-n // max(1, loops))
    parts = []
    for start in range(0, n, per_loop):
        part = tuple(p[start:start + per_loop] for p in pulses)
        size = min(per_loop, n - start)
        parts.append(jax.lax.map(kernel, part, batch_size=chunk if chunk > 1 else None)
                     if size > 1 else kernel(tuple(p[0] for p in part))[None])
    return parts[0] if len(parts) == 1 else jnp.concatenate(parts, axis=0)
