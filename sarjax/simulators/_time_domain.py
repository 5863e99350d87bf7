"""Exact time-domain simulator — the reference model (physics.md §3, §8, §10; seed 000
eq. 19–20, seed 002 eq. 32, seed 004 eq. 1–5).

    h(x', r') = Σ_P γ_P · exp[−j 4πρ/λ − j b (r' − ρ)²] · rect[(r' − ρ)/(cτ/2)] · W²(u)

``ρ = c τ_d / 2`` is the echo's one-way range. With the stop-and-go approximation
(default) ``ρ = R(t)``, the exact 3-D range from the actual antenna position at the
transmit time ``t = x'/v`` to the scatterer at that time. Without it (``stop_and_go=False``)
the two-way delay solves seed 004 eq. 3, ``c τ_d = R(t) + R(t + τ_d)`` (the antenna moves
on during the echo; the deviation of the pulse is held), by fixed-point iteration — the
map contracts by ``|dR/dt|/c`` ≲ 3·10⁻⁵ per step, so three steps reach float64 precision;
for a straight track the solution is seed 004 eq. 4.

Moving scatterers (seed 004 eq. 1): ``x`` and ``r`` are the azimuth and the slant range
of closest approach at the time ``τ₀ = x/v`` the antenna passes the scatterer's azimuth;
the scatterer moves along track at ``v_a`` and along its line of sight from the nominal
track (look angle ϑ held) at ``v_r``: at time ``t``, azimuth ``x + v_a (t − τ₀)`` and
range ``r + v_r (t − τ₀)``.

Pattern (squint φ_d, pointing error δ_az): the two-way pattern of the angle between the
line of sight and the beam, ``u = −(L/λ) tan(φ − φ_d)`` with ``tan φ = (x_P − x_A)/r``,
written with ``a = x_A − x_P`` and ``T = tan φ_d`` as

    u = (a + r T − (r + δr_xr) δ_az) / (X (1 − a T / r)),    X = λ r / L,

which is ``(x' − x − δx)/X`` at broadside (seed 000 eq. 20). The beam centre crosses a
scatterer at ``x' = x − r tan φ_d`` (φ_d > 0 looks forward), where the Doppler centroid is
``2 v sin φ_d / λ`` (azimuth wavenumber ``ξ_d = (4π/λ) sin φ_d``). Without stop-and-go the
pattern is taken at the middle of the echo, ``t + τ_d/2``.

The kernel is written for one pulse; :func:`_lift_over_pulses` maps it over pulses in
chunks. Per pulse the geometry, pattern and carrier phase of each scatterer are formed in
float64; the chirp ``exp(−j b (r'_k − ρ)²)`` is not evaluated sample by sample but
factored (:func:`pulse_blocks`): with the samples as blocks ``k = n_lo a + c`` it is a
fixed per-sample factor times one phasor per (scatterer, block) and one per (scatterer,
offset in a block), all from float64 phases, so that the sum over scatterers is a
masked product of two small tables (a loop for a few scatterers, a complex matrix product
for many). complex64 evaluates those phasors from phases reduced in float64, so its error
is the rounding of the tables (≈ 1e-7 relative), not of a float32 range. With
``stop_and_go=True``, a broadside radar and static scatterers the broadside
stop-and-go program runs unchanged (same bits); the general kernel gives the same values
there up to rounding (every added term is an exact zero).
"""

from __future__ import annotations

import dataclasses
import math
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import geometry
from .._numerics.phasor import unit_phasor, wrap_phase
from ..constants import SPEED_OF_LIGHT
from ..scene import ReflectivityGrid
from ._base import AbstractExactSimulator, AbstractPlan, Cost

NON_STOP_AND_GO_ITERATIONS = 3
_LOOPED_SCATTERERS = 32  # scatterers (per chunk) summed by a loop (16–48: same cost as the product)


def _concrete(value):
    return None if isinstance(value, jax.core.Tracer) else np.asarray(value)


def _line_of_sight_deviation(horizontal, vertical, slant_range, moved_range, height,
                             platform_height):
    """δr_xr [m] of a scatterer moved along its nominal line of sight to ``moved_range``.

    As :func:`sarjax.geometry.line_of_sight_deviation`, with the scatterer's cross-track
    position (y_P, H − h) scaled by ``moved_range / slant_range`` (the same operations,
    so an unmoved scatterer gives the same bits).
    """
    scale = moved_range / slant_range
    drop = (platform_height - height) * scale
    y = geometry.ground_range(slant_range, height, platform_height) * scale
    q = horizontal * (horizontal - 2 * y) + vertical * (vertical + 2 * drop)
    return q / (jnp.sqrt(moved_range**2 + q) + moved_range)


def relative_geometry(radar, pulse, targets, elapsed):
    """Antenna–scatterer geometry ``elapsed`` seconds after the transmission of a pulse.

    Args:
        radar: the :class:`~sarjax.Radar`.
        pulse: ``(x', Δy, Δz, δ_az)`` scalars [m, m, m, rad] (x' at transmission).
        targets: ``(x, r, h, γ, v_r, v_a)`` (scatterer,) arrays [m, m, m, –, m/s, m/s].
        elapsed: time after transmission [s], scalar or (scatterer,).

    Returns:
        ``(along, moved_range, los, offset)``, each (scatterer,) [m]: the along-track offset
        antenna − scatterer, the scatterer's nominal slant range ``r + v_r (t − τ₀)``, its
        line-of-sight deviation δr_xr, and ``R − r`` (exact 3-D range minus the
        closest-approach range ``r``).
    """
    x_pulse, horizontal, vertical, _ = pulse
    azimuth, slant_range, height, _, velocity_range, velocity_azimuth = targets
    along_track = x_pulse - azimuth
    since_crossing = along_track / radar.velocity + elapsed  # t − τ₀ [s]
    along = along_track + radar.velocity * elapsed - velocity_azimuth * since_crossing
    moved = velocity_range * since_crossing  # [m]
    moved_range = slant_range + moved
    los = _line_of_sight_deviation(
        horizontal, vertical, slant_range, moved_range, height, radar.height
    )
    offset = geometry.range_offset(along, moved_range, los) + moved  # R − r
    return along, moved_range, los, offset


def echo_range_offset(radar, pulse, targets, stop_and_go=True):
    """One-way echo range ``ρ = c τ_d / 2`` of each scatterer minus ``r`` [m].

    Args:
        radar, pulse, targets: as :func:`relative_geometry`.
        stop_and_go: True: ``ρ = R(t)``; False: seed 004 eq. 3 solved by fixed-point
            iteration, ``ρ = (R(t) + R(t + 2ρ/c)) / 2``.

    Returns:
        ``(offset, pattern_geometry)``: ``ρ − r`` (scatterer,) [m] and the
        ``(along, moved_range, los)`` at which the pattern is evaluated (transmit time,
        or the middle of the echo).
    """
    along, moved_range, los, offset = relative_geometry(radar, pulse, targets, 0.0)
    if stop_and_go:
        return offset, (along, moved_range, los)
    slant_range = targets[1]
    echo = offset
    for _ in range(NON_STOP_AND_GO_ITERATIONS):
        delay = 2 * (slant_range + echo) / SPEED_OF_LIGHT  # τ_d [s]
        echo = 0.5 * (offset + relative_geometry(radar, pulse, targets, delay)[3])
    middle = (slant_range + echo) / SPEED_OF_LIGHT  # τ_d / 2 [s]
    along_m, range_m, los_m, _ = relative_geometry(radar, pulse, targets, middle)
    return echo, (along_m, range_m, los_m)


def pattern_argument(radar, pointing, along, slant_range, los):
    """u = (a + r T − (r + δr_xr) δ_az) / (X (1 − a T / r)), T = tan φ_d (see module doc).

    Args:
        radar: the :class:`~sarjax.Radar`.
        pointing: δ_az [rad].
        along: a = x_A − x_P [m]; slant_range: r [m]; los: δr_xr [m].
    """
    t = jnp.tan(radar.squint)
    footprint = radar.footprint(slant_range)  # X = λ r / L [m]
    numerator = along + slant_range * t - (slant_range + los) * pointing
    return numerator / (footprint * (1 - along * t / slant_range))


def _broadside_static_phasors(radar, pulse, targets):
    """:func:`scatterer_phasors` for a broadside radar, static scatterers and stop-and-go
    (``targets`` = ``(x, r, h, γ)``): the same values, in the operations (and so the
    compiled program and its bits) of the broadside model."""
    x_pulse, horizontal, vertical, pointing = pulse
    azimuth, slant_range, height, reflectivity = targets
    los = geometry.line_of_sight_deviation(
        horizontal, vertical, slant_range, height, radar.height
    )
    along_track = x_pulse - azimuth
    offset = geometry.range_offset(along_track, slant_range, los)  # R − r [m]
    u = (along_track - (slant_range + los) * pointing) / radar.footprint(slant_range)
    k0 = radar.wavenumber
    phase = wrap_phase(k0 * slant_range) + k0 * offset
    amplitude = reflectivity * radar.pattern(u) * unit_phasor(-phase)
    return offset, amplitude


def scatterer_phasors(radar, pulse, targets, stop_and_go=True):
    """Per-scatterer quantities of one pulse (float64 geometry).

    Args:
        radar: the :class:`~sarjax.Radar`.
        pulse: tuple ``(x', Δy, Δz, δ_az)`` of scalars [m, m, m, rad].
        targets: tuple ``(x, r, h, γ, v_r, v_a)`` of (scatterer,) arrays, or ``(x, r, h, γ)``
            for the broadside static stop-and-go model.
        stop_and_go: see :func:`echo_range_offset`.

    Returns:
        ``(range_offset, amplitude)``: ``ρ − r`` [m] and the complex weight
        ``γ W²(u) exp(−j 4πρ/λ)``, each (scatterer,).
    """
    if len(targets) == 4:
        return _broadside_static_phasors(radar, pulse, targets)
    slant_range, reflectivity = targets[1], targets[3]
    offset, (along, moved_range, los) = echo_range_offset(radar, pulse, targets, stop_and_go)
    u = pattern_argument(radar, pulse[3], along, moved_range, los)
    k0 = radar.wavenumber
    # 4πρ/λ, formed from the exact decomposition ρ = r + (ρ − r) in float64 (k₀ r reduced
    # to [−π, π]; unit_phasor reduces the rest)
    phase = wrap_phase(k0 * slant_range) + k0 * offset
    amplitude = reflectivity * radar.pattern(u) * unit_phasor(-phase)
    return offset, amplitude


def range_blocks(num_range):
    """(n_hi, n_lo): the range samples k = n_lo·a + c as an (n_hi, n_lo) block array,
    n_lo ≈ √num_range rounded up to a multiple of 8 (the tables of one scatterer hold
    n_hi + n_lo phasors)."""
    n_lo = max(8, 8 * math.ceil(math.sqrt(num_range) / 8))
    return -(-num_range // n_lo), n_lo


def sample_chirp(radar, num_range, dtype):
    """(range,) ``Q_k = exp(−j b Δr² k²)``: the scatterer-independent factor of the chirp
    at sample k (float64 phase, then ``dtype``)."""
    k = jnp.arange(num_range, dtype=jnp.float64)
    q = radar.chirp_rate * radar.range_spacing**2
    return unit_phasor(-(q * k * k)).astype(dtype)


def pulse_extent(radar, base, num_range):
    """(first, last) int32 sample indices of each scatterer's pulse, ``|r'_k − ρ| < cτ/4``.

    ``base = r'_0 − ρ`` [m] (float64); the decision is the float64 test
    ``|base + k Δr| < cτ/4`` itself (the closed-form bound, corrected by one sample where
    its rounding lands on the other side of an edge). Clipped to the window; an echo
    outside it has ``first > last``.
    """
    dr, half = radar.range_spacing, radar.pulse_half_length

    def inside(k):
        return jnp.abs(base + k * dr) < half

    f0 = jnp.floor((-half - base) / dr) + 1
    first = jnp.where(inside(f0 - 1), f0 - 1, jnp.where(inside(f0), f0, f0 + 1))
    l0 = jnp.ceil((half - base) / dr) - 1
    last = jnp.where(inside(l0 + 1), l0 + 1, jnp.where(inside(l0), l0, l0 - 1))
    first = jnp.clip(first, 0, num_range).astype(jnp.int32)
    last = jnp.clip(last, -1, num_range - 1).astype(jnp.int32)
    return first, last


def pulse_blocks(radar, pulse, targets, near_range, blocks, dtype, stop_and_go=True):
    """Echo of one pulse from a set of scatterers, without the sample factor ``Q_k``:
    an (n_hi, n_lo) block array, sample k = n_lo·a + c (see :func:`range_blocks`).

    With ``β = r'_0 − ρ`` the chirp phase at sample k is
    ``b (β + k Δr)² = b β² + 2 b β Δr k + b Δr² k²``. The last term is ``Q_k``
    (:func:`sample_chirp`); the first two factor over the blocks,
    ``γ W² e^{−j4πρ/λ} e^{−j(b β² + 2bβΔr n_lo a)} · e^{−j 2bβΔr c}``: per scatterer
    n_hi + n_lo phasors from float64 phases instead of one per sample. The pulse's
    rect over k is the sum of three products of a mask over a and a mask over c
    (the blocks strictly inside, the first block, the last block), so that the sum over
    scatterers is one complex matrix product of (3 N_P, n_hi) by (3 N_P, n_lo).

    Args:
        radar: the :class:`~sarjax.Radar`.
        pulse: ``(x', Δy, Δz, δ_az)`` scalars.
        targets: ``(x, r, h, γ, v_r, v_a)`` (scatterer,) arrays (or ``(x, r, h, γ)``, see
            :func:`scatterer_phasors`).
        near_range: r'_0 [m].
        blocks: ``(n_hi, n_lo)``.
        dtype: complex dtype of the tables and the product (complex64 or complex128).
        stop_and_go: see :func:`echo_range_offset`.
    """
    n_hi, n_lo = blocks
    offset, amplitude = scatterer_phasors(radar, pulse, targets, stop_and_go)
    base = near_range - targets[1] - offset  # β = r'_0 − ρ [m], float64
    first, last = pulse_extent(radar, base, n_hi * n_lo)
    b, dr = radar.chirp_rate, radar.range_spacing
    slope = 2 * b * dr * base  # [rad / sample]
    # both tables from one evaluation of float64 phases
    a = jnp.arange(n_hi)[None, :]
    c = jnp.arange(n_lo)[None, :]
    phases = jnp.concatenate([
        (b * base * base)[:, None] + slope[:, None] * (n_lo * a.astype(jnp.float64)),
        slope[:, None] * c.astype(jnp.float64),
    ], axis=1)
    real = jnp.finfo(dtype).dtype
    if real != jnp.float64:
        # reduced to [−π, π] in float64, then the phasor in the kernel's precision
        phases = wrap_phase(phases)
    tables = unit_phasor(-phases.astype(real))
    outer = amplitude[:, None].astype(dtype) * tables[:, :n_hi]
    inner = tables[:, n_hi:]
    if outer.shape[0] <= _LOOPED_SCATTERERS:
        # a few scatterers: a loop over them, each step one fused pass of masked
        # multiply-adds over the blocks (a batched matrix product of this size costs 2–5×
        # more on the CPU); the loop's operands keep the tables from being recomputed
        # inside that pass
        k = n_lo * a.T + c  # (n_hi, n_lo) sample index

        def add(i, out):
            inside = (k >= first[i]) & (k <= last[i])
            return out + jnp.where(inside, outer[i][:, None] * inner[i][None, :], 0)

        return jax.lax.fori_loop(0, outer.shape[0], add, jnp.zeros((n_hi, n_lo), dtype))
    a_first, c_first = (first // n_lo)[:, None], (first % n_lo)[:, None]
    a_last, c_last = (last // n_lo)[:, None], (last % n_lo)[:, None]
    valid = first[:, None] <= last[:, None]
    spans = a_last > a_first
    left = jnp.concatenate([
        jnp.where((a > a_first) & (a < a_last) & valid, outer, 0),  # whole blocks
        jnp.where((a == a_first) & valid, outer, 0),  # the first block (and the last)
        jnp.where((a == a_last) & spans & valid, outer, 0),  # the last block
    ])
    right = jnp.concatenate([
        inner,
        jnp.where((c >= c_first) & ((c <= c_last) | spans), inner, 0),
        jnp.where(c <= c_last, inner, 0),
    ])
    return jax.lax.dot_general(left, right, (((0,), (0,)), ((), ())))


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


def _divides(total, most):
    """The largest chunk in (most / 2, most] that divides ``total``, else ``most``: whole
    chunks only spare the copy that joins a remainder to them (~35 % of the 9-point
    4096 × 2048 case)."""
    for size in range(most, most // 2, -1):
        if total % size == 0:
            return size
    return most


class TimeDomainPlan(AbstractPlan):
    """Whether the general kernel (squint, moving scatterers, non-stop-and-go) runs:
    False for a broadside radar, static scatterers and stop-and-go, which runs the
    broadside program unchanged."""

    general: bool = eqx.field(static=True)


def needs_general_kernel(radar, scene, stop_and_go) -> bool:
    """Whether the exact model needs its general kernel for these inputs (traced
    values: yes)."""
    general = not stop_and_go
    squint = _concrete(radar.squint)
    general = general or squint is None or bool(squint != 0)
    if not isinstance(scene, ReflectivityGrid):
        for v in (scene.velocity_range, scene.velocity_azimuth):
            c = _concrete(v)
            general = general or c is None or bool(np.any(c != 0))
    return general


class TimeDomain(AbstractExactSimulator):
    """Exact time-domain simulator (seed 000 "Algorithm C"), physics.md §3, §8, §10:
    squint, moving scatterers and (``stop_and_go=False``) the non-stop-and-go delay.

    Attributes:
        stop_and_go: True (default): the echo range is the range at the transmit time;
            False: the two-way delay of seed 004 eq. 3 (see the module docstring).
        pulse_chunk: pulses evaluated together (vmapped); bounds memory. None = auto.
        scatterer_chunk: scatterers evaluated together per scan step. None = auto.
        memory_budget: bytes allowed for the kernel's intermediate arrays (auto chunks).
    """

    names: ClassVar[tuple[str, ...]] = ("time_domain",)
    physics: ClassVar[str] = "physics.md §3, §8, §10 (seed 000 eq. 19–20; seed 004 eq. 1–5)"
    compile_time: ClassVar[float] = 0.5

    stop_and_go: bool = eqx.field(static=True, default=True)
    pulse_chunk: int | None = eqx.field(static=True, default=None)
    scatterer_chunk: int | None = eqx.field(static=True, default=None)
    memory_budget: int = eqx.field(static=True, default=256 * 2**20)

    def prepare(self, radar, scene, acquisition, motion=None) -> TimeDomainPlan:
        """Decide (eagerly) whether the general kernel is needed."""
        return TimeDomainPlan(needs_general_kernel(radar, scene, self.stop_and_go))

    def memory(self, plan, radar, scene, acquisition, dtype) -> int:
        """Per pulse chunk the per-scatterer tables of :func:`pulse_blocks` (float64
        phases, the phasors and the three masked copies of each), the scatterers'
        geometry, the block accumulators and the pulses' samples; the padded scatterer
        arrays."""
        n_r, n_s = acquisition.num_range, scene.num_scatterers
        pulse, scat = self.chunks(acquisition.num_pulses, n_r, n_s, dtype)
        item = np.dtype(dtype).itemsize
        padded = (-(-n_s // scat)) * scat * 6 * 8
        n = acquisition.num_pulses
        # pulses left over after the whole chunks are evaluated apart and the two parts
        # joined: one more output-sized array
        joined = n * n_r * item if n % pulse else 0
        return int(pulse * self._per_pulse(n_r, scat, item) + padded + joined)

    @staticmethod
    def _per_pulse(num_range, scat, item):
        """Workspace bytes of one pulse with ``scat`` scatterers at a time."""
        n_hi, n_lo = range_blocks(num_range)
        looped = scat <= _LOOPED_SCATTERERS
        copies = 1 if looped else 3
        tables = scat * (n_hi + n_lo) * (8 + 16 + copies * item)
        blocks = (2 if looped else 3) * n_hi * n_lo * item + 2 * num_range * item
        # with a margin of a half over XLA's measured temporaries
        return int(1.5 * (tables + scat * 24 * 8 + blocks))

    def smaller_chunks(self, plan, acquisition, scene, dtype):
        """Fewer pulses at a time first (the scatterer chunk sets the speed), then fewer
        scatterers."""
        n, n_r, n_s = acquisition.num_pulses, acquisition.num_range, scene.num_scatterers
        pulse, scat = self.chunks(n, n_r, n_s, dtype)
        while pulse > 1:
            pulse //= 2
            yield dataclasses.replace(self, pulse_chunk=pulse, scatterer_chunk=scat)
        while scat > 1:
            scat //= 2
            yield dataclasses.replace(self, pulse_chunk=1, scatterer_chunk=scat)

    def cost(self, plan, radar, scene, acquisition, dtype) -> Cost:
        """≈ 200 M (complex128) / 400 M (complex64) scatterer·sample per second (the
        factored chirp; benchmarks/RESULTS.md: 3 points and a 64 × 64 grid on the
        1941 × 830 grid measured 240–460 M/s), compile ≈ 0.5 s."""
        rate = 400e6 if np.dtype(dtype) == np.complex64 else 200e6
        work = acquisition.num_pulses * acquisition.num_range * scene.num_scatterers
        return Cost(compile=self.compile_time, steady=work / rate)

    def chunks(self, num_pulses, num_range, num_scatterers, dtype):
        """(pulse_chunk, scatterer_chunk) honouring the memory budget."""
        item = jnp.dtype(dtype).itemsize
        # _LOOPED_SCATTERERS at a time (the loop over them; a scan over such chunks), as
        # many pulses as keep the loop's block accumulators within ~1 MB (cache: 2-3×
        # faster than 8 MB and more). This beats the matrix product of larger chunks even
        # for 4096 scatterers (0.6 against 1.4 CPU-s for 256 pulses of the 64 × 64 grid);
        # a larger scatterer_chunk takes the product, one pulse at a time (unbatched: a
        # batched product of these sizes runs ~2× slower on the CPU)
        scat = self.scatterer_chunk or max(1, min(num_scatterers, _LOOPED_SCATTERERS))
        looped = scat <= _LOOPED_SCATTERERS
        per_pulse = self._per_pulse(num_range, scat, item)
        n_hi, n_lo = range_blocks(num_range)
        most = max(1, 2**20 // (n_hi * n_lo * item)) if looped else 1
        pulse = self.pulse_chunk or _divides(
            num_pulses, max(1, min(num_pulses, self.memory_budget // per_pulse, most)))
        return int(pulse), int(scat)

    def simulate(self, plan, radar, scene, motion, acquisition, dtype):
        if isinstance(scene, ReflectivityGrid):
            scene = scene.to_points()
        x_pulse = acquisition.pulse_azimuths(radar)
        horizontal, vertical, pointing = motion.resolve(acquisition.num_pulses)
        pulses = (x_pulse, horizontal, vertical, pointing)
        targets = (scene.azimuth, scene.range, scene.height, scene.reflectivity)
        if plan.general:
            targets = targets + (scene.velocity_range, scene.velocity_azimuth)
        pulse_chunk, scat_chunk = self.chunks(
            acquisition.num_pulses, acquisition.num_range, scene.num_scatterers, dtype
        )
        chunked = _chunked(targets, scat_chunk)
        n_range = acquisition.num_range
        blocks = range_blocks(n_range)
        chirp = sample_chirp(radar, n_range, dtype)
        near = acquisition.near_range

        def one_pulse(pulse):
            def accumulate(acc, chunk):
                return acc + pulse_blocks(radar, pulse, chunk, near, blocks, dtype,
                                          self.stop_and_go), None

            init = jnp.zeros(blocks, dtype)
            out, _ = jax.lax.scan(accumulate, init, chunked)
            return out.reshape(-1)[:n_range] * chirp

        return _lift_over_pulses(one_pulse, pulses, pulse_chunk)
