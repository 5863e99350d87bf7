"""The focusing entry point."""

from __future__ import annotations

import math
import warnings

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import _memory, _validate, geometry
from .._data import Image, RawData
from .._numerics.interpolation import next_fast_len
from ..motion import Motion
from . import _motion_compensation as moco
from ._backprojection import backprojection
from ._exact_backprojection import backprojection_exact
from ._omega_k import (
    azimuth_aperture,
    band_edge_walk,
    kappa_oversampling,
    omega_k,
    range_spread,
    range_transform_length,
    squint_image_offsets,
)
from ._range_compression import range_compress, range_fft_length

_COMPENSATION = (None, "none", "first_order", "second_order")

# ω-k's squint budget [deg]: against the exact back-projection of the same time-domain
# raw data (airborne preset, 1024 × 256, point targets at three places in the window,
# both azimuth weightings) the image agrees to −38 dB or better at every squint measured,
# 0–70° either side (tests/test_focusing.py draws squints, places and weightings);
# beyond, unmeasured
OMEGA_K_MAX_SQUINT_DEG = 70.0


def _transform_padding(num_pulses, aperture):
    """The azimuth padding of at least ``aperture`` pulses that ω-k's transform takes:
    ``next_fast_len(num_pulses + aperture) − num_pulses``. The padding is a static
    argument whose one use is that transform length, so apertures that give one length
    (a sweep over antenna length or carrier: 1528 and 1527 pulses on a 512-pulse
    window) share one compiled program instead of tracing and compiling another."""
    return next_fast_len(num_pulses + aperture) - num_pulses


@eqx.filter_jit
def _focus_omega_k(radar, data, azimuth, range_, motion, order, n_fft, equalize, offsets,
                   oversampling=1, padding=0, spread=0, lags=0):
    """ω-k of the window's compressed lines with ``lags`` samples beyond each end (static;
    ``range_`` the extended axis), the image cropped back to the window's columns."""
    num_pulses = data.shape[0]
    compressed = range_compress(radar, data, n_fft=n_fft, lags=lags)
    if order in ("first_order", "second_order"):
        dy, dz, _ = motion.resolve(num_pulses)
        compressed = moco.first_order(radar, compressed, dy, dz, range_)
        if order == "second_order":
            compressed = moco.second_order(radar, compressed, dy, dz, range_)
    image = omega_k(radar, compressed, azimuth, range_, equalize_pattern=equalize,
                    offsets=offsets, kappa_oversampling=oversampling,
                    azimuth_padding=padding, range_spread=spread)
    return image[:, lags:image.shape[1] - lags]


@eqx.filter_jit
def _focus_backprojection(radar, data, azimuth, range_, motion, image_azimuth, image_range,
                          upsample, n_fft, lags=0):
    dy, dz, _ = motion.resolve(data.shape[0])
    compressed = range_compress(radar, data, n_fft=n_fft, lags=lags)
    return backprojection(
        radar, compressed, azimuth, range_, dy, dz, image_azimuth, image_range,
        upsample=upsample,
    )


@eqx.filter_jit
def _focus_exact_backprojection(radar, data, azimuth, range_, motion, image_azimuth,
                                image_range, upsample, n_fft, stop_and_go, weighting,
                                acquisition_doppler, lags=0):
    dy, dz, _ = motion.resolve(data.shape[0])
    return backprojection_exact(
        radar, data, azimuth, range_, dy, dz, image_azimuth, image_range,
        stop_and_go=stop_and_go, azimuth_weighting=weighting, upsample=upsample, n_fft=n_fft,
        acquisition_doppler=acquisition_doppler, lags=lags,
    )


def recorded_lags(radar, range_axis) -> int:
    """Range lags (samples, static, from concrete values) that the matched filter of a window
    still reaches beyond each of its ends and that the focusers read: half a chirp + 1, at
    most the larger of ``max(2 n, 256)`` (n the window's samples) and the range walk
    :func:`~._omega_k.band_edge_walk` + 64 samples. A target whose echo the window records
    in part correlates with the recorded part at lags outside the window; the focusers keep
    them (range compression returns them: its transform already holds the window and a
    chirp) so that an image equals the 2-D matched filter of the recorded samples up to the
    window's edge. Cropped to the window instead, the compressed line of a target near an
    end stopped short: its interpolation then rang across the whole line, and the pulses
    whose echo had migrated past the end were lost, 6–23 dB from the matched filter for a
    target at the edge (airborne preset, 512 × 128, 0–20° of squint; 0.5 % of the peak with
    the lags, ``tests/test_focusing.py``).

    A window that records a small part of a long chirp needs fewer than half a chirp: an
    image sample of the window reads its compressed lines no farther out than the range
    walk over the PRF band, so lags beyond it only lengthen the transforms (the high-speed
    preset's 28 800-sample chirp would take a 128-sample window's ω-k transforms to 29 000
    samples). Lags that stop short of the walk lose the pulses whose echo walks past
    them: on that preset at 5° of squint (walk 1 824 samples) a cap of 256 lags left both
    focusers −14 dB from the matched filter, a centred target included; with the walk,
    −75 dB (ω-k) and −150 dB (exact back-projection) from the same filter with 4 096 lags.
    """
    range_axis = np.asarray(range_axis, float)
    num_range = range_axis.size
    half_chirp = int(math.ceil(float(radar.chirp_samples) / 2)) + 1
    reach = max(2 * num_range, 256, band_edge_walk(radar, range_axis) + _WALK_MARGIN)
    return min(half_chirp, reach)


_WALK_MARGIN = 64  # samples: the upsampled line's and the interpolation's own spread


def _lag_axis(radar, range_axis, lags):
    """(range + 2 lags,) the window's range axis extended by ``lags`` samples at each end."""
    steps = jnp.arange(1, lags + 1) * radar.range_spacing
    return jnp.concatenate([range_axis[0] - steps[::-1], range_axis, range_axis[-1] + steps])


def range_compressed(radar, raw: RawData) -> RawData:
    """Matched-filter range compression of raw data (same grid; physics.md §11)."""
    n_fft = range_fft_length(radar, raw.data.shape[-1])
    return RawData(
        data=range_compress(radar, raw.data, n_fft=n_fft), azimuth=raw.azimuth, range=raw.range,
        azimuth_period=raw.azimuth_period,
    )


def focus(
    radar,
    raw: RawData,
    *,
    method: str = "omega_k",
    motion: Motion | None = None,
    motion_compensation: str | None = "second_order",
    azimuth=None,
    range=None,
    upsample: int = 8,
    azimuth_weighting: str = "uniform",
    stop_and_go: bool = True,
    acquisition_doppler: bool = False,
    memory_limit=None,
    strict: bool = False,
    circular_azimuth: bool | None = None,
) -> Image:
    """Focus raw data into a complex image (physics.md §11).

    Args:
        radar: the :class:`~sarjax.Radar` that acquired ``raw``.
        raw: :class:`~sarjax.RawData`.
        method: ``"omega_k"`` (wavenumber domain, straight track, any squint, with motion
            compensation when ``motion`` is given; squinted, the image's grid lies
            ``R_c sin φ_d`` ahead of the pulses and ``R_c (1 − cos φ_d)`` nearer than the
            samples, R_c the window's mid slant range, each rounded to whole sample
            spacings), ``"backprojection"`` (any known trajectory) or
            ``"exact_backprojection"`` (any known trajectory, squint, the simulator's echo
            range with or without stop-and-go, azimuth weighting about the Doppler
            centroid; see :func:`sarjax.processing.backprojection_exact`).
        motion: the platform motion to compensate (ω-k) or the actual track
            (back-projection). None = nominal straight track.
        motion_compensation: for ω-k with ``motion``: ``"first_order"`` (δr(x')),
            ``"second_order"`` (δr(x') and ψ(x', r)) or None.
        azimuth: back-projection output azimuths x [m] (default: the pulse positions).
        range: back-projection output slant ranges r [m] (default: the range samples).
        upsample: back-projection range upsampling before linear interpolation.
        azimuth_weighting: ω-k only: ``"uniform"`` (default) equalises the two-way
            pattern over the PRF band, with a floor of 0.05 where the pattern vanishes at
            the band edges, as the seeds' point-target tables do (airborne set: IRW ≈
            0.255 m = 1.15 v/PRF, PSLR ≈ −13.4 dB; seed 000 Table 3 reports 0.23 m);
            ``"antenna"`` keeps the natural sinc² weighting of the azimuth spectrum
            (IRW ≈ 0.39 m, sidelobes below −35 dB). Also for ``"exact_backprojection"``.
        stop_and_go: ``"exact_backprojection"`` only: the echo-range model (False: seed 004
            eq. 3, for high-speed platforms).
        acquisition_doppler: ``"exact_backprojection"`` only: ``azimuth``/``range`` are
            Acquisition-Doppler coordinates (beam-centre crossing azimuth, range along the
            beam centre; seed 002 eq. 1) instead of closest-approach ones.
        memory_limit: bound on the estimated peak memory, bytes or e.g. ``"2GiB"``
            (default: ``$SARJAX_MEMORY_LIMIT``, else half the available memory; see
            :mod:`sarjax._memory`). Focusing is not chunked further: over the limit it
            raises :class:`sarjax._memory.MemoryLimitError` (a MemoryError and ValueError)
            stating the estimate and the limit.
        strict: raise, rather than warn (:class:`sarjax.FocusWarning`), where the method
            is outside its measured budget (ω-k beyond 70° of squint, or its motion
            compensation past ``moco_aperture_phase``).
        circular_azimuth: ω-k only: the raw data is periodic along track, as a
            Fourier-domain simulation whose fixed ``azimuth_padding`` let echoes wrap
            makes it (``azimuth_padding=0``: the seeds' circular setup): the azimuth
            correlation is then taken circularly over the period
            (:attr:`~sarjax.RawData.azimuth_period`, or the pulses' fast transform
            length where the data do not say): where the data hold the whole period
            (``azimuth_padding=0``) the consistent inverse, each echo wrapped in from the
            far end focused with the rest of its aperture. A longer period's pulses beyond
            the window are not in the data and no focusing recovers them (512 pulses,
            period 768 or 1024: circular and padded both −3 dB from the image of the
            whole period; circular 0–0.5 dB nearer). False:
            the pulses are padded by the full-band aperture
            (:func:`~sarjax.processing._omega_k.azimuth_aperture`) so that nothing wraps,
            which on recorded (not periodic) data is right. Default None: circular where
            ``raw.azimuth_period`` says the data are periodic. Back-projection of
            periodic data warns (:class:`sarjax.FocusWarning`): it places each wrapped
            echo where its pulse was.

    Returns:
        :class:`~sarjax.Image` on (x, r); a target at (x, r) focuses there with phase
        ``exp(−j4πr/λ)``.
    """
    motion = Motion() if motion is None else motion
    _validate.check_focus(radar, raw, motion)
    if not isinstance(strict, (bool, np.bool_)):
        raise ValueError(f"strict={strict!r} must be True or False")
    if motion_compensation not in _COMPENSATION:
        raise ValueError(
            f"motion_compensation={motion_compensation!r}; choose one of {_COMPENSATION}"
        )
    if azimuth_weighting not in ("antenna", "uniform"):
        raise ValueError(f"azimuth_weighting={azimuth_weighting!r}; choose 'antenna' or 'uniform'")
    azimuth_weighting = str(azimuth_weighting)  # a NumPy string too (a static argument)
    if circular_azimuth is not None and not isinstance(circular_azimuth, (bool, np.bool_)):
        raise ValueError(f"circular_azimuth={circular_azimuth!r} must be True, False or None")
    if circular_azimuth and method != "omega_k":
        raise ValueError(f"circular_azimuth=True is an omega_k option; method={method!r} "
                         "back-projects each pulse where it was")
    data = jnp.asarray(raw.data)
    if data.ndim != 2:
        raise ValueError(f"raw.data has shape {data.shape}; expected (azimuth, range)")
    period = int(getattr(raw, "azimuth_period", 0))
    if circular_azimuth is None:
        circular_azimuth = method == "omega_k" and period > 0
    if period and method != "omega_k":
        message = (f"focus(method={method!r}): raw.azimuth_period = {period} pulses: the "
                   "data are periodic along track (echoes wrapped in from the window's "
                   "other end) and back-projection places each where its pulse was; use "
                   "method='omega_k', which correlates circularly over the period")
        if strict:
            raise ValueError(message)
        warnings.warn(message, _validate.FocusWarning, stacklevel=2)
    if method == "omega_k":  # its budgets first: beyond them its sizes can be large
        order = None if motion.is_ideal else (motion_compensation or "none")
        _check_omega_k(radar, motion, order, data.shape[0], strict)
    if method in ("omega_k", "backprojection", "exact_backprojection"):
        image_shape = (data.shape[0] if azimuth is None else int(jnp.size(azimuth)),
                       data.shape[1] if range is None else int(jnp.size(range)))
        window_range = jnp.asarray(raw.range)
        lags = recorded_lags(radar, window_range)
        lag_range = _lag_axis(radar, window_range, lags)
        n_fft = range_fft_length(radar, data.shape[1])
        omega_k_sizes = ((max(period - data.shape[0], 0) if circular_azimuth
                          else _transform_padding(data.shape[0],
                                                  azimuth_aperture(radar, lag_range)),
                          kappa_oversampling(radar),
                          range_spread(radar, lag_range))
                         if method == "omega_k" else (0, 1, 0))
        n_lagged = data.shape[1] + 2 * lags  # the compressed lines
        estimate = _memory.focus_estimate(method, data.shape[0], n_lagged, n_fft,
                                          image_shape=image_shape, upsample=upsample,
                                          azimuth_padding=omega_k_sizes[0],
                                          kappa_oversampling=omega_k_sizes[1],
                                          range_transform=range_transform_length(
                                              n_lagged, omega_k_sizes[2]))
        limit = _memory.memory_limit(memory_limit)
        if estimate.total > limit:
            _memory.refuse(f"focus(method={method!r})", estimate, limit, chunked=False)
    if method == "omega_k":
        offsets = squint_image_offsets(radar, window_range)
        image = _focus_omega_k(radar, data, raw.azimuth, lag_range, motion, order, n_fft,
                               azimuth_weighting == "uniform", offsets, omega_k_sizes[1],
                               omega_k_sizes[0], omega_k_sizes[2], lags)
        return Image(data=image,
                     azimuth=raw.azimuth + offsets[0], range=window_range + offsets[1])
    if method == "backprojection":
        image_azimuth = (raw.azimuth if azimuth is None
                         else jnp.atleast_1d(jnp.asarray(azimuth, float)))
        image_range = raw.range if range is None else jnp.atleast_1d(jnp.asarray(range, float))
        image = _focus_backprojection(
            radar, data, raw.azimuth, lag_range, motion, image_azimuth, image_range, upsample,
            n_fft, lags
        )
        return Image(data=image, azimuth=image_azimuth, range=image_range)
    if method == "exact_backprojection":
        image_azimuth = (raw.azimuth if azimuth is None
                         else jnp.atleast_1d(jnp.asarray(azimuth, float)))
        image_range = raw.range if range is None else jnp.atleast_1d(jnp.asarray(range, float))
        image = _focus_exact_backprojection(
            radar, data, raw.azimuth, lag_range, motion, image_azimuth, image_range, upsample,
            n_fft, bool(stop_and_go), azimuth_weighting, bool(acquisition_doppler), lags,
        )
        return Image(data=image, azimuth=image_azimuth, range=image_range)
    raise ValueError(
        f"unknown focus method={method!r}; choose 'omega_k', 'backprojection' or "
        "'exact_backprojection'"
    )


def moco_aperture_phase(radar, motion, num_pulses):
    """Budget ``moco_aperture_phase`` [rad] of ω-k's motion compensation: the phase MoCo
    leaves across the processed aperture. MoCo moves each pulse's echo by the deviation
    along the beam centre, cos φ_d δ(x'); a target seen at θ = φ_d + Δθ moves by cos θ δ,
    so over the PRF band's half-span Δθ ≤ θ_a = λ / (4 Δx cos φ_d) the residual is
    ``k₀ max|δ| (|sin φ_d| θ_a + cos φ_d θ_a²/6)`` (δ the first-order deviation δr(x');
    the linear term at its edge value, a shift of the response, the quadratic one, a
    defocus, at about its rms over the band). Calibrated against the exact
    back-projection on the actual track (512 × 128, smooth Δy, Δz, uniform weighting):
    squinted (0.5–30 cm rms, 0–40°, 40 draws) 0.23 rad or less gave −34 dB or better,
    0.26 rad −25.9 and −32.2 dB, 0.29 rad −26.8 dB, 0.48–1.9 rad −11 to −29 dB, 3.2 rad
    −8 dB; broadside (0.3–5 m rms) 0.07–0.16 rad −30 to −43 dB, 0.29–0.32 rad −24 and
    −28 dB, 0.73–0.80 rad −16 and −20 dB. None where traced."""
    dy, dz, _ = motion.resolve(num_pulses)
    try:
        deviation = np.asarray(geometry.reference_deviation(dy, dz, radar))
        squint = float(radar.squint)
        wavelength, spacing = float(radar.wavelength), float(radar.azimuth_spacing)
    except (TypeError, jax.errors.TracerArrayConversionError):
        return None
    half_span = wavelength / (4 * spacing * math.cos(squint))
    k0 = 4 * math.pi / wavelength
    return k0 * float(np.max(np.abs(deviation))) * (
        abs(math.sin(squint)) * half_span + math.cos(squint) * half_span**2 / 6)


MOCO_APERTURE_PHASE_THRESHOLD = 0.2  # [rad], moco_aperture_phase's calibration above


def _check_omega_k(radar, motion, order, num_pulses, strict):
    """Warn (or raise, ``strict``) where ω-k is beyond a measured budget: its squint, and
    with motion compensation ``moco_aperture_phase``."""
    broken = []
    try:
        squint = abs(math.degrees(float(radar.squint)))
    except TypeError:  # traced: the budget cannot be checked here
        squint = None
    if squint is not None and squint > OMEGA_K_MAX_SQUINT_DEG:
        broken.append(f"squint budget broken: |squint| = {squint:.1f}° > "
                      f"{OMEGA_K_MAX_SQUINT_DEG:g}° (up to which its image was measured within "
                      "-38 dB of the exact back-projection)")
    if order in ("first_order", "second_order"):
        value = moco_aperture_phase(radar, motion, num_pulses)
        if value is not None and value > MOCO_APERTURE_PHASE_THRESHOLD:
            broken.append(f"moco_aperture_phase = {value:.3g} rad > "
                          f"{MOCO_APERTURE_PHASE_THRESHOLD:g} rad (the phase the motion "
                          "compensation leaves across the aperture: deviation × squint)")
    if broken:
        message = ("focus(method='omega_k'): " + "; ".join(broken)
                   + "; use method='exact_backprojection' (the actual track as motion)")
        if strict:
            raise ValueError(message)
        warnings.warn(message, _validate.FocusWarning, stacklevel=3)
