"""Reference parameter sets of physics.md §12.

Each preset takes keyword overrides of any :class:`~sarjax.Radar` field, e.g.
``airborne_xband(squint=np.deg2rad(4), num_pulses=512)``.
"""

from __future__ import annotations

import jax
import numpy as np

from ._names import unknown_names
from .constants import SPEED_OF_LIGHT
from .radar import Radar

__all__ = ["airborne_xband", "spaceborne_cband", "spaceborne_cband_extended", "highspeed_xband"]


def _build(defaults: dict, overrides: dict) -> Radar:
    unknown = set(overrides) - set(Radar.__dataclass_fields__)
    if unknown:
        raise ValueError(unknown_names("radar parameter(s)", unknown, Radar.__dataclass_fields__))
    for name, value in overrides.items():
        if name == "pattern" or isinstance(value, jax.core.Tracer):
            continue
        try:
            np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"{name}={value!r} is not a number") from None
    return Radar(**{**defaults, **overrides})


def airborne_xband(**overrides) -> Radar:
    """X-band airborne system of seed 000 Table 2 (also seed 002 Tables 1, 3).

    λ = 3.14 cm, H = 4000 m, r₀ = 5140 m, v = 100 m/s, PRF = 400 Hz (0.25 m pulse spacing),
    f_s = 50 MHz (≈ 3 m range samples), Δf = 45 MHz, τ = 5 µs, L = 1 m. The default grid is
    the point-target raw size 1941 × 830 with range sample 415 at r₀.
    """
    sampling_rate = 50e6
    defaults = dict(
        carrier_frequency=SPEED_OF_LIGHT / 0.0314,
        bandwidth=45e6,
        chirp_duration=5e-6,
        sampling_rate=sampling_rate,
        prf=400.0,
        velocity=100.0,
        height=4000.0,
        antenna_length=1.0,
        reference_range=5140.0,
        near_range=5140.0 - 415 * SPEED_OF_LIGHT / (2 * sampling_rate),
        squint=0.0,
        num_pulses=1941,
        num_range=830,
    )
    return _build(defaults, overrides)


def spaceborne_cband(**overrides) -> Radar:
    """C-band spaceborne system of seed 003 (Appendix A listing, Tables 1 and 3).

    f = 5.33 GHz, f_s = 19.2 MHz, PRF = 300 Hz, 2 s of data (600 pulses), τ = 21.6 µs,
    Δf = 16 MHz, near range 799 km, v = 750 m/s (as in the listing), L = 1 m. The seed's
    flat geometry gives no height: H = 692 km (look angle ≈ 30° at 800 km) is assumed.
    The default range window (882 samples at f_s) holds every echo of a scene
    799.0–799.4 km (the listing's ``X0 = 200`` m about 799.2 km): the chirp is centred on
    the echo delay here (physics.md §1), so the window starts cτ/4 before 799 km.
    (The listing's ``dt = 1/(2 f_s)`` samples range at twice f_s; f_s is used here.)
    Note that with v = 750 m/s and L = 1 m the Doppler band 2v/L = 1.5 kHz exceeds the PRF.
    """
    defaults = dict(
        carrier_frequency=5.33e9,
        bandwidth=16e6,
        chirp_duration=21.6e-6,
        sampling_rate=19.2e6,
        prf=300.0,
        velocity=750.0,
        height=692e3,
        antenna_length=1.0,
        reference_range=799.2e3,
        near_range=799e3 - SPEED_OF_LIGHT * 21.6e-6 / 4,
        squint=0.0,
        num_pulses=600,
        num_range=882,
    )
    return _build(defaults, overrides)


def spaceborne_cband_extended(**overrides) -> Radar:
    """C-band spaceborne system of seed 003 Table 1, extended-scene column (1171 × 747).

    f = 5.33 GHz, f_s = 19.2 MHz, PRF = 1174 Hz, 1 s of data, τ = 21.6 µs, Δf = 16.2 MHz,
    near range 799 km, v = 855 m/s; L = 1 m as in the listing (Appendix A). Assumed, as in
    :func:`spaceborne_cband`: H = 692 km. The default grid is the seed's 1171 pulses × 747
    range samples (0.73 m × 7.8 m), the range window starting at 799 km.
    """
    sampling_rate = 19.2e6
    num_range = 747
    near_range = 799e3
    defaults = dict(
        carrier_frequency=5.33e9,
        bandwidth=16.2e6,
        chirp_duration=21.6e-6,
        sampling_rate=sampling_rate,
        prf=1174.0,
        velocity=855.0,
        height=692e3,
        antenna_length=1.0,
        reference_range=near_range + (num_range // 2) * SPEED_OF_LIGHT / (2 * sampling_rate),
        near_range=near_range,
        squint=0.0,
        num_pulses=1171,
        num_range=num_range,
    )
    return _build(defaults, overrides)


def highspeed_xband(**overrides) -> Radar:
    """High-speed spaceborne X-band system of seed 004 Table 1.

    f = 9.6 GHz, r_ref = 800 km, Δf = 600 MHz, v = 7500 m/s, PRF = 5000 Hz, τ = 40 µs,
    azimuth beamwidth 0.005 rad (L = λ / 0.005 ≈ 6.25 m), squint 0 (30° via ``squint=``).
    Not given by the seed, assumed here: f_s = 720 MHz (1.2 Δf) and H = 693 km.
    The default grid (2048 × 32768) covers one chirp (28 800 samples) and the aperture.
    """
    carrier_frequency = 9.6e9
    sampling_rate = 720e6
    num_range = 32768
    defaults = dict(
        carrier_frequency=carrier_frequency,
        bandwidth=600e6,
        chirp_duration=40e-6,
        sampling_rate=sampling_rate,
        prf=5000.0,
        velocity=7500.0,
        height=693e3,
        antenna_length=SPEED_OF_LIGHT / carrier_frequency / 0.005,
        reference_range=800e3,
        near_range=800e3 - (num_range // 2) * SPEED_OF_LIGHT / (2 * sampling_rate),
        squint=0.0,
        num_pulses=2048,
        num_range=num_range,
    )
    return _build(defaults, overrides)
