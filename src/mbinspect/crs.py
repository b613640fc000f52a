"""Coordinates in metres, never guessed: a cloud whose CRS is geographic or in feet is
projected (pyproj) to a projected metre CRS, the one asked for or the UTM zone of the data,
and a CRS that contradicts the coordinates is refused.

Every conversion says what it did in one note naming both CRSs; heights in feet (a vertical
CRS in feet, or a horizontal one in feet with no vertical CRS: the LAS habit) are converted
too, and the note says which rule set the vertical unit.

Examples
--------
>>> import numpy as np
>>> from mbinspect.cloud import PointCloud
>>> ft = PointCloud(np.array([[1_500_000.0, 500_000.0, -30.0], [1_500_010.0, 500_000.0, -31.0]]),
...                 crs="EPSG:2263")                         # New York Long Island, US feet
>>> out, notes = to_metres(ft)
>>> # 10 US feet apart (3.048 m on the ground; UTM's grid scale makes it 3.049), 30 ft deep
>>> round(float(np.hypot(*(out.xyz[1, :2] - out.xyz[0, :2]))), 3), round(float(out.xyz[0, 2]), 3)
(3.049, -9.144)
>>> notes[0][:60]
'coordinates in NAD83 / New York Long Island (ftUS) (US surve'
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from .cloud import PointCloud
from .errors import InputError, ParameterError

__all__ = ["utm_crs", "projected_metres", "project_lonlat", "to_metres", "looks_geographic",
           "MAX_SCALE_ERROR", "ScaleError"]

#: The largest scale error (|k - 1|) of a target CRS over the data: a UTM zone's own reaches
#: 1:1000 at its edge (its centre is 1:2500 short), a wrong zone many times more (a line at
#: 81° W put in zone 31 doubles every distance).
MAX_SCALE_ERROR = 1e-3


class ScaleError(ParameterError):
    """A CRS that distorts distances over the data beyond :data:`MAX_SCALE_ERROR`: where
    the data lie (``utm``, their own UTM zone) and by how much (``ratio``, N of 1:N)."""

    def __init__(self, message: str, *, ratio: float, utm: str, name: str) -> None:
        super().__init__(message, option="crs")
        self.ratio, self.utm, self.name = ratio, utm, name


def utm_crs(lat: float, lon: float) -> str:
    """The EPSG code of the UTM zone (WGS 84) holding a position, as ``"EPSG:326NN"``.

    Parameters
    ----------
    lat, lon : float
        Degrees.

    Returns
    -------
    str

    Examples
    --------
    >>> utm_crs(51.37, 3.14), utm_crs(-33.9, 151.2)
    ('EPSG:32631', 'EPSG:32756')
    """
    zone = int(math.floor((lon + 180.0) / 6.0)) % 60 + 1
    return f"EPSG:{32600 + zone if lat >= 0 else 32700 + zone}"


def projected_metres(target: str) -> Any:
    """``target`` as a pyproj CRS, refused unless it is a projected CRS in metres.

    Parameters
    ----------
    target : str
        EPSG code, WKT, PROJ string.

    Returns
    -------
    pyproj.CRS

    Examples
    --------
    >>> projected_metres("EPSG:4326")
    Traceback (most recent call last):
    ...
    mbinspect.errors.ParameterError: crs: 'EPSG:4326' (WGS 84) is geographic; expected a projected CRS...
    """
    from pyproj import CRS
    from pyproj.exceptions import CRSError

    try:
        out = CRS.from_user_input(target)
    except CRSError:
        raise ParameterError(f"crs: {target!r}; expected a CRS such as EPSG:32631", option="crs") from None
    horizontal = _horizontal(out)
    if horizontal.is_geographic:
        raise ParameterError(f"crs: {target!r} ({out.name}) is geographic; expected a projected CRS in "
                             "metres", option="crs")
    if not horizontal.is_projected or _unit_factor(horizontal) != 1.0:
        raise ParameterError(f"crs: {target!r} ({out.name}) is not in metres; expected a projected CRS in "
                             "metres", option="crs")
    return out


def project_lonlat(lon: np.ndarray, lat: np.ndarray, crs: str | None = None
                   ) -> tuple[np.ndarray, np.ndarray, str, str]:
    """Longitudes and latitudes (WGS 84) projected to ``crs`` (default: their UTM zone).

    Parameters
    ----------
    lon, lat : ndarray
        Degrees.
    crs : str, optional
        A projected CRS in metres.

    Returns
    -------
    x, y : ndarray
        Metres.
    wkt, name : str
        The CRS used.

    Examples
    --------
    >>> x, y, wkt, name = project_lonlat(np.array([3.0]), np.array([51.0]))
    >>> name, round(float(x[0])), round(float(y[0]))
    ('WGS 84 / UTM zone 31N', 500000, 5649825)
    """
    from pyproj import Transformer

    target = crs or utm_crs(float(np.median(lat)), float(np.median(lon)))
    out = projected_metres(target)
    try:
        _check_scale(out, lon, lat, target)
    except ScaleError as exc:
        if crs is not None:
            raise
        span = max(float(np.ptp(lon)), float(np.ptp(lat)))
        raise ScaleError(f"positions spread over {span:,.2f} degrees, more than one projection holds to "
                         "1:1000 (a corrupt position or navigation jump?); expected one survey's extent, or "
                         "`crs` for a survey this wide", ratio=exc.ratio, utm=exc.utm,
                         name=exc.name) from None
    x, y = Transformer.from_crs("EPSG:4326", out, always_xy=True).transform(lon, lat)
    return np.asarray(x), np.asarray(y), out.to_wkt(), out.name


def looks_geographic(xy: np.ndarray) -> bool:
    """Longitude and latitude: every x within ±180 and y within ±90, spanning under a degree
    (a survey's extent), not all one point.

    Parameters
    ----------
    xy : ndarray, shape (N, 2 or 3)

    Returns
    -------
    bool

    Examples
    --------
    >>> looks_geographic(np.array([[-122.38, 37.757], [-122.379, 37.758], [-122.3785, 37.7575]]))
    True
    >>> looks_geographic(np.array([[554845.0, 4179000.0], [554846.0, 4179001.0], [554847.0, 4179000.5]]))
    False
    """
    xy = np.asarray(xy, np.float64)
    if len(xy) < 3:
        return False
    x, y = xy[:, 0], xy[:, 1]
    return bool(np.abs(x).max() <= 180 and np.abs(y).max() <= 90 and np.ptp(x) < 1 and np.ptp(y) < 1
                and (np.ptp(x) > 0 or np.ptp(y) > 0))


def to_metres(cloud: PointCloud, target: str | None = None) -> tuple[PointCloud, list[str]]:
    """The cloud in a projected metre CRS, and a note for every conversion.

    The cloud's own CRS (what the file declares) is the source; ``target`` (``--crs``) the
    CRS wanted. A cloud without a CRS takes ``target`` as the CRS of its coordinates. A
    geographic or foot-based source is projected to ``target`` or to the UTM zone of the
    data; a metre source is reprojected only when ``target`` differs.

    Parameters
    ----------
    cloud : PointCloud
    target : str, optional
        A projected CRS in metres.

    Returns
    -------
    PointCloud
        Metres; its ``crs`` the CRS used.
    notes : list of str

    Raises
    ------
    ParameterError
        A target that is not a projected metre CRS, or whose scale error over the data
        exceeds :data:`MAX_SCALE_ERROR`.
    InputError
        A geographic CRS over coordinates that cannot be degrees.
    """
    from pyproj import CRS

    if cloud.crs is None:
        if target is None:
            return cloud, []
        given = _parsed(target)
        h = _horizontal(given)
        if h.is_geographic and not looks_geographic(cloud.xyz):
            x, y = cloud.xyz[0, :2]
            raise ParameterError(f"crs: {target!r} ({given.name}) is geographic, but the coordinates of "
                                 f"{cloud.source} (x = {x:,.3f}, y = {y:,.3f}) are not longitude and "
                                 "latitude; expected the CRS the coordinates are in", option="crs")
        if h.is_geographic or (h.is_projected and _unit_factor(h) != 1.0):
            return _transformed(cloud, given, h, None)
        projected_metres(target)
        return replace(cloud, crs=given.to_wkt()), []
    source = CRS.from_user_input(cloud.crs)
    horizontal = _horizontal(source)
    factor = _unit_factor(horizontal)
    wanted = projected_metres(target) if target is not None else None
    if horizontal.is_projected and factor == 1.0 and (wanted is None or wanted.equals(source)
                                                      or wanted.equals(horizontal)):
        z_factor, z_rule = _vertical_factor(source, horizontal)
        if z_factor == 1.0:
            return cloud, []
        # metres in plan, heights in feet (a COPC in NAD83 / Oregon LCC + NAVD88 height (ftUS))
        xyz = cloud.xyz.copy()
        xyz[:, 2] *= z_factor
        note = (f"heights in {source.name} converted from {z_rule} to metres (× {z_factor:.10g}); "
                f"the plan CRS {horizontal.name} kept")
        meta = {**cloud.meta, "source_crs": source.to_wkt()}
        return replace(cloud, xyz=xyz, crs=horizontal.to_wkt(), meta=meta), \
            [f"{cloud.source}: {note}" if cloud.source else note]
    if horizontal.is_geographic and not looks_geographic(cloud.xyz):
        x, y = cloud.xyz[0, :2]
        raise InputError(f"{cloud.source}: the file's CRS {source.name} is geographic, but its coordinates "
                         f"(x = {x:,.3f}, y = {y:,.3f}) are not longitude and latitude; expected degrees, "
                         "or a file whose CRS matches its coordinates")
    return _transformed(cloud, source, horizontal, wanted)


def _transformed(cloud: PointCloud, source: Any, horizontal: Any, wanted: Any
                 ) -> tuple[PointCloud, list[str]]:
    """The cloud projected from ``source`` to ``wanted`` (or the data's UTM zone)."""
    from pyproj import CRS, Transformer

    to_lonlat = Transformer.from_crs(horizontal, "EPSG:4326", always_xy=True)
    lon, lat = to_lonlat.transform(cloud.xyz[:, 0], cloud.xyz[:, 1])
    lon, lat = np.asarray(lon), np.asarray(lat)
    if wanted is None:
        wanted = CRS.from_user_input(utm_crs(float(np.median(lat)), float(np.median(lon))))
    _check_scale(wanted, lon, lat, wanted.to_string())
    x, y = Transformer.from_crs("EPSG:4326", wanted, always_xy=True).transform(lon, lat)
    z_factor, z_rule = _vertical_factor(source, horizontal)
    xyz = np.column_stack([x, y, cloud.xyz[:, 2] * z_factor])
    note = f"coordinates in {source.name} ({_unit_name(horizontal)}) projected to {wanted.name} (metres)"
    if z_factor != 1.0:
        note += f"; heights converted from {z_rule} to metres (× {z_factor:.10g})"
    return replace(cloud, xyz=xyz, crs=wanted.to_wkt(),
                   meta={**cloud.meta, "source_crs": source.to_wkt()}), [f"{cloud.source}: {note}"
                                                                          if cloud.source else note]


def _horizontal(crs: Any) -> Any:
    """The horizontal part of a compound CRS (the CRS itself otherwise)."""
    if crs.is_compound:
        for sub in crs.sub_crs_list:
            if sub.is_projected or sub.is_geographic:
                return sub
    return crs


def _unit_factor(crs: Any) -> float:
    """Metres per unit of a CRS's first axis (1 for metres; NaN for degrees)."""
    axis = crs.axis_info[0] if crs.axis_info else None
    if axis is None:
        return 1.0
    return float(axis.unit_conversion_factor) if crs.is_projected else math.nan


def _unit_name(crs: Any) -> str:
    if crs.is_geographic:
        return "degrees"
    name = crs.axis_info[0].unit_name if crs.axis_info else "metre"
    return {"US survey foot": "US survey feet", "foot": "international feet"}.get(name, name)


def _vertical_factor(source: Any, horizontal: Any) -> tuple[float, str]:
    """Metres per unit of z, and what says so: the vertical CRS's unit, or (none declared)
    the horizontal unit of a projected CRS in feet, as LAS files in feet write heights."""
    if source.is_compound:
        for sub in source.sub_crs_list:
            if sub.is_vertical and sub.axis_info:
                unit = sub.axis_info[0]
                return float(unit.conversion_factor if hasattr(unit, "conversion_factor")
                             else unit.unit_conversion_factor), f"the vertical CRS's {unit.unit_name}"
    if horizontal.is_projected:
        f = _unit_factor(horizontal)
        if f != 1.0:
            return f, f"{_unit_name(horizontal)} (no vertical CRS: taken in the horizontal unit)"
    return 1.0, "metres"


def _check_scale(crs: Any, lon: np.ndarray, lat: np.ndarray, given: str) -> None:
    """Refuse a CRS whose scale error over the data exceeds :data:`MAX_SCALE_ERROR`."""
    from pyproj import Proj

    pick = np.unique(np.r_[np.argmin(lon), np.argmax(lon), np.argmin(lat), np.argmax(lat)])
    factors = Proj(crs).get_factors(lon[pick], lat[pick], errcheck=False)
    k = np.r_[np.asarray(factors.meridional_scale), np.asarray(factors.parallel_scale)]
    worst = float(np.nanmax(np.abs(k - 1.0))) if np.isfinite(k).any() else math.inf
    if not worst <= MAX_SCALE_ERROR:
        utm = utm_crs(float(np.median(lat)), float(np.median(lon)))
        shown = repr(given) if len(given) < 40 else "the survey's CRS"
        ratio = 1 / worst if math.isfinite(worst) else 0.0
        how = f"1:{ratio:,.0f}" if ratio >= 2 else "a factor of two or more"
        raise ScaleError(f"crs: {shown} ({crs.name}) distorts distances over these data by {how}; expected "
                         f"a projected CRS for where the data lie ({utm} here)", ratio=ratio, utm=utm,
                         name=crs.name)


def _parsed(text: str) -> Any:
    from pyproj import CRS
    from pyproj.exceptions import CRSError

    try:
        return CRS.from_user_input(text)
    except CRSError:
        raise ParameterError(f"crs: {text!r}; expected a CRS such as EPSG:32631", option="crs") from None
