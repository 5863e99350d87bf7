"""What the CPHD and CRSD writers share: the acquisition geometry of a sarjax run in ECF,
the parameters block."""

from __future__ import annotations

import contextlib
import dataclasses
import warnings

import numpy as np

from .._files import atomic_write as atomic_write  # re-exported from its former home
from ..constants import SPEED_OF_LIGHT
from ..motion import Motion
from ..radar import radar_attributes
from ._frame import GeoReference, LocalFrame

TRACKS = ("true", "nominal")


def require(module: str, extra: str = "io"):
    """Import an optional dependency or raise a one-line ImportError naming the extra."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        raise ImportError(
            f"{module} is needed for this export: pip install 'sarjax[{extra}]'"
        ) from None


@contextlib.contextmanager
def quiet_sarkit():
    """sarkit 1.8 reads its schema tables with the deprecated
    ``importlib.resources.read_text`` / ``open_text``: silence that warning (tests turn
    warnings into errors)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=r"(read|open)_text is deprecated",
                                category=DeprecationWarning)
        yield


@dataclasses.dataclass(frozen=True)
class Collection:
    """Per-pulse geometry of one sarjax acquisition, in sarjax's local frame and in ECF.

    Attributes:
        frame: the :class:`LocalFrame` (local ↔ ECF).
        tx_time: (pulse,) transmit times from the first pulse [s] (p / PRF).
        apc: (pulse, 3) antenna phase centre (local) [m]: the true or nominal track.
        velocity: (pulse, 3) its velocity (local) [m/s].
        srp: (pulse, 3) scene reference point of each pulse (local): the ground point at
            closest-approach range r₀ on the beam centre, (x'_p + r₀ tan φ_d, √(r₀² − H²),
            0) (abeam the pulse at broadside).
        srp_range: (pulse,) |apc − srp| [m].
        ground_reference: √(r₀² − H²) [m].
    """

    frame: LocalFrame
    tx_time: np.ndarray
    apc: np.ndarray
    velocity: np.ndarray
    srp: np.ndarray
    srp_range: np.ndarray
    ground_reference: float

    @property
    def apc_ecf(self):
        return self.frame.to_ecf(self.apc)

    @property
    def velocity_ecf(self):
        return self.frame.vector_to_ecf(self.velocity)

    @property
    def srp_ecf(self):
        return self.frame.to_ecf(self.srp)


def scalar(value, name: str) -> float:
    value = float(np.asarray(value))
    if not np.isfinite(value):
        raise ValueError(f"{name}={value} must be finite")
    return value


def collection(radar, raw, motion: Motion | None, track: str,
               reference: GeoReference) -> Collection:
    """Lay the acquisition of ``raw`` on the Earth (see :mod:`sarjax.export`)."""
    if track not in TRACKS:
        raise ValueError(f"track={track!r}; choose one of {TRACKS}")
    squint = scalar(radar.squint, "radar.squint")
    if not abs(squint) < np.pi / 2:
        raise ValueError(f"radar.squint={squint} rad must lie within (−π/2, π/2)")
    azimuth = np.asarray(raw.azimuth, dtype=float)
    n = azimuth.size
    if n < 2:
        raise ValueError(f"raw data has {n} pulse(s); at least 2 are needed")
    prf = scalar(radar.prf, "radar.prf")
    height = scalar(radar.height, "radar.height")
    r0 = scalar(radar.reference_range, "radar.reference_range")
    if r0 <= height:
        raise ValueError(f"radar.reference_range={r0} m must exceed radar.height={height} m")
    motion = Motion() if motion is None else motion
    dy, dz, _ = (np.asarray(v, dtype=float) for v in motion.resolve(n))
    if track == "nominal":
        dy, dz = np.zeros(n), np.zeros(n)
    tx_time = np.arange(n) / prf
    apc = np.stack([azimuth, dy, height + dz], axis=-1)
    velocity = np.stack([
        np.full(n, scalar(radar.velocity, "radar.velocity")),
        np.gradient(dy, tx_time), np.gradient(dz, tx_time)], axis=-1)
    y_ref = float(np.sqrt((r0 - height) * (r0 + height)))
    # each pulse's SRP: the ground point at closest-approach range r₀ on the beam centre,
    # x = x' + r₀ tan φ_d (the exact model's u = 0; abeam at broadside)
    srp = np.stack([azimuth + r0 * np.tan(squint), np.full(n, y_ref), np.zeros(n)], axis=-1)
    anchor = np.array([0.5 * (srp[0, 0] + srp[-1, 0]), y_ref, 0.0])
    frame = LocalFrame(reference, anchor)
    srp_range = np.linalg.norm(apc - srp, axis=-1)
    return Collection(frame, tx_time, apc, velocity, srp, srp_range, y_ref)


def parameters(radar, raw, track: str, extra: dict | None = None) -> dict[str, str]:
    """Every number of the run as text (for the files' parameter lists)."""
    out = {f"radar.{k}": str(v) for k, v in radar_attributes(radar).items()}
    out.update({
        "raw.method": raw.method or "",
        "raw.num_pulses": str(raw.data.shape[0]),
        "raw.num_range": str(raw.data.shape[1]),
        "raw.first_azimuth_m": repr(float(raw.azimuth[0])),
        "raw.near_range_m": repr(float(raw.range[0])),
        "track": track,
    })
    out.update({k: str(v) for k, v in (extra or {}).items()})
    return out


def receive_geometry(radar, geo: Collection, stop_and_go: bool):
    """The SRP's one-way-equivalent range c τ_srp / 2 (pulse,) [m] and the antenna's
    receive positions (pulse, 3) (local).

    Stop-and-go: ``|APC − SRP|`` and the transmit positions. Beyond stop-and-go the
    antenna moves on along x at v during the echo, its deviation held (the exact model's
    ``stop_and_go=False``): c τ = |APC − SRP| + |APC + (v τ, 0, 0) − SRP|, solved by
    fixed-point iteration (the map contracts by v/c per step; four steps reach float64).
    """
    if stop_and_go:
        return geo.srp_range, geo.apc
    velocity = float(radar.velocity)
    delay = two_way_delay(geo.srp_range)
    for _ in range(4):
        receive = geo.apc + np.outer(velocity * delay, [1.0, 0.0, 0.0])
        delay = (geo.srp_range + np.linalg.norm(receive - geo.srp, axis=-1)) / SPEED_OF_LIGHT
    receive = geo.apc + np.outer(velocity * delay, [1.0, 0.0, 0.0])
    return 0.5 * SPEED_OF_LIGHT * delay, receive


def two_way_delay(distance):
    """2 R / c [s]."""
    return 2 * np.asarray(distance, float) / SPEED_OF_LIGHT


def realization(raw, motion: Motion | None, index: int):
    """Realization ``index`` of a batched simulation: its raw data and its motion.

    A batch (``raw.data`` of shape (batch, azimuth, range), from a motion whose
    components are (batch, azimuth)) is exported one realization at a time, each an
    acquisition of its own: ``to_cphd(path, radar, *realization(raw, motion, b))``.

    Args:
        raw: :class:`~sarjax.RawData` with a leading batch axis.
        motion: the batched :class:`~sarjax.Motion` (components of shape (azimuth,) are
            shared by every realization) or None.
        index: the realization, 0 ≤ index < batch.

    Returns:
        ``(raw_b, motion_b)``: 2-D raw data and per-pulse motion.
    """
    data = np.asarray(raw.data)
    if data.ndim != 3:
        raise ValueError(f"raw.data of shape {data.shape} is not a batch (batch, azimuth, "
                         "range)")
    batch = data.shape[0]
    if not (isinstance(index, int | np.integer) and -batch <= index < batch):
        raise ValueError(f"index={index!r} is outside the batch of {batch} realizations")
    one = dataclasses.replace(raw, data=raw.data[index])
    if motion is None:
        return one, None
    # a (batch, azimuth) component is the realization's own; an (azimuth,) one is shared
    pick = lambda v: v if v is None or np.ndim(v) < 2 else np.asarray(v)[index]
    return one, Motion(horizontal=pick(motion.horizontal), vertical=pick(motion.vertical),
                       pointing=pick(motion.pointing))


def check_grid(radar, raw):
    """The raw grid must be the radar's (uniform pulses at v/PRF, samples at c/2f_s)."""
    data = np.asarray(raw.data)
    if data.ndim == 3:
        raise ValueError(f"raw.data holds a batch of {data.shape[0]} realizations "
                         f"{data.shape}: export one at a time, "
                         "sarjax.export.realization(raw, motion, b)")
    if data.ndim != 2 or not np.iscomplexobj(data):
        raise ValueError(f"raw.data must be 2-D complex (azimuth, range), got {data.shape}, "
                         f"{data.dtype}")
    if not np.all(np.isfinite(data)):
        raise ValueError("raw.data holds non-finite samples")
    for axis, name, step in ((raw.azimuth, "azimuth", radar.azimuth_spacing),
                             (raw.range, "range", radar.range_spacing)):
        axis = np.asarray(axis, float)
        step = float(step)
        if axis.size > 1 and not np.allclose(np.diff(axis), step, rtol=1e-9, atol=1e-9 * step):
            raise ValueError(f"raw.{name} spacing {np.diff(axis)[0]!r} m differs from the "
                             f"radar's {step!r} m")


def _centre_of_dwell(y, late, t_mid, per_metre):
    """COD time polynomial in IAC (x, y): ``t_mid + x·per_metre`` on the reference range,
    plus ``late`` (33,) [s] at the IAC ``y`` (33,) [m], fitted by a cubic in y: squinted,
    the beam centre crosses a point at closest-approach range r when the pulse is
    r tan φ_d behind it, ``−(r − r₀) tan φ_d / v`` later than at r₀."""
    if not np.any(late):  # broadside
        return np.array([[t_mid], [per_metre]])
    poly = np.zeros((2, 4))
    poly[0] = np.polynomial.polynomial.polyfit(y, late, 3)
    poly[0, 0] += t_mid
    poly[1, 0] = per_metre
    return poly


def scene_area(radar, raw, geo: Collection, reference: GeoReference,
               time_offset: float = 0.0) -> dict:
    """The image area (where a full integration time lies inside the track), its corners,
    the IAC axes, the dwell and centre-of-dwell polynomials and an image grid.

    IAC: uIAY horizontal, away from the track; uIAX = uIAY × up (along the track for
    side L, against it for side R); origin at the IARP. Dwell time: the integration time
    λr/(Lv cos² φ_d) (a cubic in IAC y), or half the track where the track is shorter
    than two integration times. COD time: the time the beam centre crosses the point,
    ``time_offset`` + x / v + r₀ / (c cos φ_d) from the middle of the track, squinted
    ``−(r − r₀) tan φ_d / v`` later (:func:`_centre_of_dwell`); the image area is narrowed
    by that spread so the whole dwell of every point lies inside the track.
    """
    wgs84 = require("sarkit.wgs84")
    height = float(radar.height)
    velocity = float(radar.velocity)
    # the window's slant range r' sees, on the beam centre, closest-approach range r' cos φ_d
    range_axis = np.asarray(raw.range, float) * np.cos(float(radar.squint))
    near, far = range_axis[0], range_axis[-1]
    if far <= height:
        raise ValueError(f"far range {far} m does not exceed radar.height={height} m: "
                         "the range window sees no ground")
    ground_near = max(near, height)  # samples before the nadir echo see no ground
    y_near = float(np.sqrt((ground_near - height) * (ground_near + height))) - (
        geo.ground_reference)
    y_far = float(np.sqrt((far - height) * (far + height))) - geo.ground_reference
    track_time = float(geo.tx_time[-1])
    y_fit = np.linspace(y_near, y_far, 33)
    slant = np.sqrt((geo.ground_reference + y_fit) ** 2 + height**2)
    squint = float(radar.squint)
    # the beam's footprint along x at closest-approach range r: λr / (L cos² φ_d)
    dwell = float(radar.wavelength) * slant / (
        float(radar.antenna_length) * velocity * np.cos(squint) ** 2)
    if dwell.max() <= 0.5 * track_time:
        dwell_poly = np.polynomial.polynomial.polyfit(y_fit, dwell, 3)
        dwell_max = float(np.polynomial.polynomial.polyval(y_fit, dwell_poly).max())
    else:
        dwell_poly = np.array([0.5 * track_time])
        dwell_max = 0.5 * track_time
    # squinted, the centre of dwell moves by −(r − r₀) tan φ_d / v across the range window
    late = -(slant - float(radar.reference_range)) * np.tan(squint) / velocity
    cod_shift = velocity * float(np.max(np.abs(late)))
    half_x = velocity * (0.5 * track_time - 0.5 * dwell_max - 2.0 / float(radar.prf)) - (
        cod_shift)
    if half_x <= 0.0:
        raise ValueError(
            f"the track ({track_time:.3g} s) is shorter than the dwell time ({dwell_max:.3g} s)"
            f" plus the squinted centre-of-dwell spread ({cod_shift / velocity:.3g} s): no "
            "image area has its whole aperture recorded; simulate more pulses")
    sign = 1.0 if reference.side_of_track == "L" else -1.0
    x1, x2, y1, y2 = -half_x, half_x, y_near, y_far
    iac_corners = np.array([[x1, y1], [x1, y2], [x2, y2], [x2, y1]])
    local_corners = np.stack([
        geo.frame.anchor[0] + sign * iac_corners[:, 0],
        geo.frame.anchor[1] + iac_corners[:, 1], np.zeros(4)], axis=-1)
    llh_corners = wgs84.cartesian_to_geodetic(geo.frame.to_ecf(local_corners))
    lon, lat = llh_corners[:, 1], llh_corners[:, 0]
    if np.sum(lon * np.roll(lat, -1) - np.roll(lon, -1) * lat) > 0:  # counter-clockwise
        llh_corners = llh_corners[::-1]
    u_iay = geo.frame.axes[1]
    t_mid = time_offset + 0.5 * track_time + float(radar.reference_range) / (
        SPEED_OF_LIGHT * np.cos(squint))
    line_spacing = float(radar.azimuth_spacing)
    sample_spacing = float(radar.range_spacing) * float(radar.reference_range) / (
        geo.ground_reference)
    return dict(
        x1=x1, x2=x2, y1=y1, y2=y2, line_spacing=line_spacing, sample_spacing=sample_spacing,
        num_lines=max(int(round((x2 - x1) / line_spacing)), 1),
        num_samples=max(int(round((y2 - y1) / sample_spacing)), 1),
        iarp_ecf=geo.frame.origin, iarp_llh=wgs84.cartesian_to_geodetic(geo.frame.origin),
        u_iax=np.cross(u_iay, geo.frame.up), u_iay=u_iay, llh_corners=llh_corners,
        cod_poly=_centre_of_dwell(y_fit, late, t_mid, sign / velocity),
        dwell_poly_2d=np.asarray(dwell_poly)[None, :],
        polygon=np.array([[x1, y1], [x1, y2], [x2, y2], [x2, y1]]),
    )
