"""What every sonar reader returns, and how soundings become a projected point cloud."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..crs import ScaleError, project_lonlat, utm_crs
from ..errors import InputError, InputWarning

__all__ = ["Soundings", "to_cloud", "utm_crs", "offsets_to_geographic", "project_lonlat", "Datagrams"]

# WGS 84
_A = 6378137.0
_F = 1 / 298.257223563
_E2 = _F * (2 - _F)


@dataclass(frozen=True, eq=False)
class Soundings:
    """Soundings as a sonar file gives them, before any projection.

    Attributes
    ----------
    lat, lon : ndarray, shape (N,)
        Geographic position of each sounding (degrees, WGS 84).
    z : ndarray, shape (N,)
        Elevation (m, up) relative to the format's level (see :mod:`mbinspect.sonar`).
    fields : dict of ndarray (N,)
        ``ping``, ``beam``, ``beam_angle`` (deg from vertical, + starboard), ``intensity``
        (backscatter, dB as stored), ``time`` (s since 1970, UTC), ``valid`` and, where
        the file has them, ``sigma_h`` and ``sigma_v`` (m).
    meta : dict
        ``format``, ``source``, ``sonar`` and what else the file says (version, level).
    """

    lat: np.ndarray
    lon: np.ndarray
    z: np.ndarray
    fields: dict[str, np.ndarray] = field(default_factory=dict)
    meta: dict[str, Any] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.z)

    def subset(self, mask: np.ndarray) -> Soundings:
        """The soundings where ``mask`` is True."""
        return Soundings(self.lat[mask], self.lon[mask], self.z[mask],
                         {k: v[mask] for k, v in self.fields.items()}, dict(self.meta))


def offsets_to_geographic(lat: np.ndarray, lon: np.ndarray, heading_deg: np.ndarray, along: np.ndarray,
                          across: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions of soundings from their ping's position and along/across-track offsets.

    The offsets (m; along positive forward, across positive to starboard) are turned by
    the heading (deg clockwise from true north) into north and east metres, and those into
    degrees with the ellipsoid's meridian and prime-vertical radii at the ping.

    Parameters
    ----------
    lat, lon, heading_deg : ndarray, shape (N,)
        Each sounding's ping position (deg) and heading (deg).
    along, across : ndarray, shape (N,)
        Offsets (m).

    Returns
    -------
    lat, lon : ndarray, shape (N,)

    Examples
    --------
    >>> la, lo = offsets_to_geographic(np.array([0.0]), np.array([0.0]), np.array([90.0]),
    ...                                np.array([0.0]), np.array([1000.0]))
    >>> round(float(la[0]) * 110574, 1), round(float(lo[0]), 6)  # 1 km south of the equator
    (-1000.0, 0.0)
    """
    h = np.radians(heading_deg)
    north = along * np.cos(h) - across * np.sin(h)
    east = along * np.sin(h) + across * np.cos(h)
    phi = np.radians(lat)
    s2 = np.sin(phi) ** 2
    rn = _A / np.sqrt(1 - _E2 * s2)  # prime vertical
    rm = rn * (1 - _E2) / (1 - _E2 * s2)  # meridian
    return lat + np.degrees(north / rm), lon + np.degrees(east / (rn * np.cos(phi)))


def to_cloud(soundings: Soundings, *, crs: str | None = None, keep_rejected: bool = False) -> Any:
    """Soundings projected to ``crs`` (default: the UTM zone of their mean position).

    Parameters
    ----------
    soundings : Soundings
    crs : str, optional
        Any CRS pyproj accepts (``"EPSG:32631"``); it must be projected, in metres.
    keep_rejected : bool
        Keep the soundings the file flags as rejected (their ``valid`` field says which).

    Returns
    -------
    PointCloud
        x east, y north (m, in ``crs``), z elevation; the fields (with ``line`` 0: the
        file), and ``crs`` set.

    Raises
    ------
    InputError
        No sounding with a position.
    ParameterError
        A ``crs`` pyproj does not know or that is not projected in metres.
    """
    from ..cloud import PointCloud

    valid = soundings.fields["valid"].astype(bool)
    extra = soundings.fields.get("extra_detection")
    if not keep_rejected and extra is not None and (extra & ~valid).any():
        warnings.warn(f"{soundings.meta.get('source')}: {int((extra & ~valid).sum()):,} extra detections "
                      "(water-column targets the sonar reports beside the seabed) left out with the "
                      f"{int((~valid & ~extra).sum()):,} soundings it rejected (`keep_rejected` keeps them)",
                      InputWarning, stacklevel=4)
    s = soundings if keep_rejected else soundings.subset(valid)
    ok = np.isfinite(s.lat) & np.isfinite(s.lon) & np.isfinite(s.z)
    if not ok.any():
        raise InputError(f"{s.meta.get('source')}: no sounding with a position")
    s = s.subset(ok) if not ok.all() else s
    try:
        x, y, wkt, name = project_lonlat(s.lon, s.lat, crs)
    except ScaleError as exc:
        if crs is not None:
            raise
        raise InputError(f"{s.meta.get('source')}: {exc}") from None
    meta = {**s.meta, "crs_name": name, "lines": 1}
    fields = {**s.fields, "line": np.zeros(len(s), np.int32)} if "line" not in s.fields else dict(s.fields)
    return PointCloud(np.column_stack([x, y, s.z]), fields, source=s.meta.get("source"),
                      crs=wkt, z_convention="elevation", meta=meta)


class Datagrams:
    """A file's bytes and a cursor, for readers that walk records (one error grammar)."""

    def __init__(self, path: str, data: bytes) -> None:
        self.path = path
        self.data = data

    def fail(self, what: str, offset: int | None = None) -> InputError:
        """The error for a bad record at byte ``offset`` (None: the file as a whole)."""
        where = f"{self.path}, byte {offset}" if offset is not None else self.path
        return InputError(f"{where}: {what}")
