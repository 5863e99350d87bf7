"""Placing sarjax's flat stripmap geometry on the WGS-84 Earth (for CPHD / CRSD files).

sarjax works in a local Cartesian frame: ``x`` along the nominal track [m], ``y`` the
horizontal ground range away from the track towards the scene [m], ``z`` up [m]; the
nominal antenna is at ``(x', 0, H)``, the actual one at ``(x', Δy, H + Δz)``, a scatterer
at ``(x, √(r² − (H − h)²), h)``. The files need Earth-centred, Earth-fixed (ECF)
coordinates: the flat frame is laid rigidly on the plane tangent to the ellipsoid at a
reference point, so every distance (hence every echo delay and phase) is kept exactly.
The reference surface is that tangent plane (the files declare it as ``Planar``), not the
curved ellipsoid.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt

import numpy as np

_WGS84_A = 6378137.0
_WGS84_F = 1 / 298.257223563
_WGS84_E2 = _WGS84_F * (2 - _WGS84_F)


def geodetic_to_ecf(latitude, longitude, height):
    """WGS-84 geodetic (deg, deg, m) → ECF (..., 3) [m]."""
    lat, lon = np.radians(latitude), np.radians(longitude)
    n = _WGS84_A / np.sqrt(1 - _WGS84_E2 * np.sin(lat) ** 2)
    return np.stack(
        [(n + height) * np.cos(lat) * np.cos(lon), (n + height) * np.cos(lat) * np.sin(lon),
         (n * (1 - _WGS84_E2) + height) * np.sin(lat)], axis=-1)


@dataclasses.dataclass(frozen=True)
class GeoReference:
    """Where and when the flat sarjax scene is placed on the Earth.

    Attributes:
        latitude, longitude: geodetic position [deg] of the image-area reference point
            (IARP): the ground point at the reference range r₀ abeam the middle pulse.
        height: its height above the WGS-84 ellipsoid [m].
        heading: direction of flight, clockwise from north [deg].
        side_of_track: ``"R"`` (scene right of the track) or ``"L"``.
        collection_start: UTC time of the first pulse (timezone-aware ``datetime``).
    """

    latitude: float = 52.0
    longitude: float = 5.0
    height: float = 0.0
    heading: float = 0.0
    side_of_track: str = "R"
    collection_start: _dt.datetime = _dt.datetime(2020, 1, 1, tzinfo=_dt.UTC)

    def __post_init__(self):
        if self.side_of_track not in ("L", "R"):
            raise ValueError(f"side_of_track={self.side_of_track!r}; choose 'L' or 'R'")
        if not -90 < self.latitude < 90:
            raise ValueError(f"latitude={self.latitude!r} must lie in (−90, 90) degrees")
        if self.collection_start.tzinfo is None:
            raise ValueError("collection_start must be timezone-aware (e.g. tzinfo=UTC)")


class LocalFrame:
    """Rigid map between sarjax's local frame and ECF.

    ``ecf = origin + (p − anchor) @ axes`` with ``axes`` the ECF unit vectors of local
    x (along track), y (away from the track, horizontal) and z (up: the ellipsoid normal
    at the reference point), and ``anchor`` the local coordinates of the reference point.
    For ``side_of_track="R"`` the local axes form a left-handed set in ECF (a mirror
    image); distances, hence the data, are unchanged.
    """

    def __init__(self, reference: GeoReference, anchor):
        self.reference = reference
        self.anchor = np.asarray(anchor, dtype=float)
        lat, lon = np.radians(reference.latitude), np.radians(reference.longitude)
        up = np.array([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])
        east = np.array([-np.sin(lon), np.cos(lon), 0.0])
        north = np.cross(up, east)
        heading = np.radians(reference.heading)
        along = np.cos(heading) * north + np.sin(heading) * east
        right = np.cross(along, up)
        away = right if reference.side_of_track == "R" else -right
        self.axes = np.stack([along, away, up])  # rows: local x, y, z in ECF
        self.origin = geodetic_to_ecf(reference.latitude, reference.longitude, reference.height)

    @property
    def up(self):
        return self.axes[2]

    def to_ecf(self, points):
        """(..., 3) local [m] → ECF [m]."""
        return self.origin + (np.asarray(points, float) - self.anchor) @ self.axes

    def to_local(self, ecf):
        """(..., 3) ECF [m] → local [m]."""
        return (np.asarray(ecf, float) - self.origin) @ self.axes.T + self.anchor

    def vector_to_ecf(self, vectors):
        """(..., 3) local velocity/direction → ECF."""
        return np.asarray(vectors, float) @ self.axes
