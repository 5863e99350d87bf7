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
            the reference range r₀ abeam the pulse, (x'_p, √(r₀² − H²), 0).
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
    if scalar(radar.squint, "radar.squint") != 0.0:
        raise ValueError(f"radar.squint={float(radar.squint)} ≠ 0: only broadside data export")
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
    srp = np.stack([azimuth, np.full(n, y_ref), np.zeros(n)], axis=-1)
    anchor = np.array([0.5 * (azimuth[0] + azimuth[-1]), y_ref, 0.0])
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


def two_way_delay(distance):
    """2 R / c [s]."""
    return 2 * np.asarray(distance, float) / SPEED_OF_LIGHT


def check_grid(radar, raw):
    """The raw grid must be the radar's (uniform pulses at v/PRF, samples at c/2f_s)."""
    data = np.asarray(raw.data)
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


def scene_area(radar, raw, geo: Collection, reference: GeoReference,
               time_offset: float = 0.0) -> dict:
    """The image area (where a full integration time lies inside the track), its corners,
    the IAC axes, the dwell and centre-of-dwell polynomials and an image grid.

    IAC: uIAY horizontal, away from the track; uIAX = uIAY × up (along the track for
    side L, against it for side R); origin at the IARP. Dwell time: the integration time
    λr/(Lv) (a cubic in IAC y), or half the track where the track is shorter than two
    integration times. COD time: the time the pulse abeam the point is at its SRP,
    ``time_offset`` + x / v + r₀ / c from the middle of the track.
    """
    wgs84 = require("sarkit.wgs84")
    height = float(radar.height)
    velocity = float(radar.velocity)
    range_axis = np.asarray(raw.range, float)
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
    dwell = float(radar.wavelength) * slant / (float(radar.antenna_length) * velocity)
    if dwell.max() <= 0.5 * track_time:
        dwell_poly = np.polynomial.polynomial.polyfit(y_fit, dwell, 3)
        dwell_max = float(np.polynomial.polynomial.polyval(y_fit, dwell_poly).max())
    else:
        dwell_poly = np.array([0.5 * track_time])
        dwell_max = 0.5 * track_time
    half_x = velocity * (0.5 * track_time - 0.5 * dwell_max - 2.0 / float(radar.prf))
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
    t_mid = time_offset + 0.5 * track_time + float(radar.reference_range) / SPEED_OF_LIGHT
    line_spacing = float(radar.azimuth_spacing)
    sample_spacing = float(radar.range_spacing) * float(radar.reference_range) / (
        geo.ground_reference)
    return dict(
        x1=x1, x2=x2, y1=y1, y2=y2, line_spacing=line_spacing, sample_spacing=sample_spacing,
        num_lines=max(int(round((x2 - x1) / line_spacing)), 1),
        num_samples=max(int(round((y2 - y1) / sample_spacing)), 1),
        iarp_ecf=geo.frame.origin, iarp_llh=wgs84.cartesian_to_geodetic(geo.frame.origin),
        u_iax=np.cross(u_iay, geo.frame.up), u_iay=u_iay, llh_corners=llh_corners,
        cod_poly=np.array([[t_mid], [sign / velocity]]),
        dwell_poly_2d=np.asarray(dwell_poly)[None, :],
        polygon=np.array([[x1, y1], [x1, y2], [x2, y2], [x2, y1]]),
    )
