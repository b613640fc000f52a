"""The ground floor's point cloud: :class:`PointCloud`, the name of its CRS, a pipeline's
checked input and the sources (files, pings) behind a set of its soundings.

Examples
--------
>>> import numpy as np
>>> cloud = PointCloud(np.array([[0.0, 0.0, -20.0], [1.0, 0.0, -20.5]]), {"ping": np.array([1, 2])})
>>> len(cloud), cloud.subset(np.array([False, True])).fields["ping"].tolist()
(2, [2])
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from .checks import check_points
from .errors import InputError, NotEnoughPointsError, ParameterError
from .geometry import crop_mask
from .grid import bounds
from .strays import deep_outliers, duplicate_soundings, stray_soundings

__all__ = ["PointCloud", "crs_name", "pipeline_input", "sources", "ping_ranges"]


def crs_name(crs: str | None, *, epsg: bool = True) -> str | None:
    """The name of a CRS (WKT or any pyproj input), with its EPSG code unless ``epsg`` is
    False; None for None; the text's first 40 characters for a CRS pyproj cannot read.

    Examples
    --------
    >>> crs_name("EPSG:32631"), crs_name("EPSG:32631", epsg=False), crs_name(None)
    ('WGS 84 / UTM zone 31N (EPSG:32631)', 'WGS 84 / UTM zone 31N', None)
    """
    if crs is None:
        return None
    try:
        from pyproj import CRS

        c = CRS.from_user_input(crs)
    except Exception:
        return crs[:40]
    code = c.to_epsg() if epsg else None
    return str(c.name) + (f" (EPSG:{code})" if code else "")


@dataclass(frozen=True, eq=False)
class PointCloud:
    """Soundings with optional per-point fields and metadata.

    Parameters
    ----------
    xyz : ndarray, shape (N, 3)
        Coordinates in metres: x east, y north, z elevation (up).
    fields : mapping of str to ndarray, shape (N,)
        Per-point attributes: ``intensity`` (backscatter), ``beam_angle`` (degrees),
        ``line``, ``ping``, ``classification`` and any other.
    source : str, optional
        The file the points came from.
    crs : str, optional
        Coordinate reference system when the file says it (WKT or EPSG code).
    z_convention : str
        How z was stored in the source: ``"elevation"`` (up) or ``"depth"``
        (positive down, flipped on reading). ``xyz`` is always elevation.
    meta : mapping
        What else the source says: format, sonar, version, vertical level, the CRS's name.
    """

    xyz: np.ndarray
    fields: Mapping[str, np.ndarray] = field(default_factory=dict)
    source: str | None = None
    crs: str | None = None
    z_convention: str = "elevation"
    meta: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        xyz = np.ascontiguousarray(self.xyz, dtype=np.float64)
        if xyz.ndim != 2 or xyz.shape[1] != 3:
            raise ParameterError(f"xyz: expected shape (N, 3), got {xyz.shape}")
        n = xyz.shape[0]
        fields = {}
        for name, values in self.fields.items():
            arr = np.asarray(values)
            if arr.shape != (n,):
                raise ParameterError(
                    f"field {name!r}: expected shape ({n},), got {arr.shape}"
                )
            fields[name] = arr
        object.__setattr__(self, "xyz", xyz)
        object.__setattr__(self, "fields", fields)

    def __len__(self) -> int:
        return int(self.xyz.shape[0])

    @property
    def intensity(self) -> np.ndarray | None:
        """Backscatter intensity per point, or None when the file has none."""
        return self.fields.get("intensity")

    def subset(self, index: np.ndarray) -> PointCloud:
        """The cloud restricted to a boolean mask or an index array."""
        return replace(
            self,
            xyz=self.xyz[index],
            fields={k: v[index] for k, v in self.fields.items()},
        )

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Minimum and maximum corner, each shape (3,)."""
        if len(self) == 0:
            raise NotEnoughPointsError("the cloud has no points")
        return bounds(self.xyz, 3)


def pipeline_input(data: PointCloud | np.ndarray, *, crop: Any = None, minimum: int = 10
                   ) -> tuple[PointCloud, np.ndarray, list[str]]:
    """A pipeline's input as a cloud and its checked ``(N, 3)`` points, cropped, without
    stray soundings far from the rest (:func:`mbinspect.strays.stray_soundings`: a navigation
    jump would otherwise make every grid as large as the distance jumped).

    Parameters
    ----------
    data : PointCloud or ndarray, shape (N, 3)
    crop : box or polygon, optional
        See :func:`mbinspect.geometry.crop_mask`.
    minimum : int
        Fewest points the pipeline can work with.

    Returns
    -------
    cloud : PointCloud
    points : ndarray, shape (N, 3)
    notes : list of str
        What was left out and why (stray soundings), for the result's warnings.

    Raises
    ------
    InputError
        The cloud's z is in doubt (``meta["z_doubt"]``, see :func:`read`).
    NotEnoughPointsError
        Fewer than ``minimum`` points (after the crop).
    """
    cloud = data if isinstance(data, PointCloud) else PointCloud(check_points(data))
    if cloud.meta.get("z_doubt"):
        raise InputError(cloud.meta["z_doubt"])
    if crop is not None:
        cloud = cloud.subset(crop_mask(cloud.xyz, crop))
    pts = check_points(cloud.xyz, minimum=minimum, name="points")
    notes: list[str] = []
    copies = duplicate_soundings(pts)
    if copies.sum() > max(10, 1e-4 * len(pts)):  # more than soundings that meet by chance at mm
        notes.append(f"{int(copies.sum()):,} soundings are exact copies of others (a file given twice, an "
                     "export written twice?) and were counted once")
    if copies.any():
        cloud = cloud.subset(~copies)
        pts = check_points(cloud.xyz, minimum=minimum, name="points")
    deep = deep_outliers(pts[:, 2])
    if deep.any():
        where = f" (pings {', '.join(map(str, np.unique(cloud.fields['ping'][deep])[:5]))})" \
            if "ping" in cloud.fields else ""
        low, median, n = float(pts[deep, 2].min()), float(np.median(pts[:, 2])), int(deep.sum())
        notes.append(f"{n:,} sounding{'s' * (n > 1)}{where} far below the seabed of the survey, down to "
                     f"{low:.1f} m (median {median:.1f} m): corrupt records or multiples? Kept; check them")
    if cloud.meta.get("strays_removed"):  # a tile of a survey: done once for the whole survey
        return cloud, pts, notes
    stray = stray_soundings(pts)
    if stray.any():
        rest = pts[~stray, :2]
        far = float(np.hypot(*(np.median(pts[stray, :2], axis=0) - np.median(rest, axis=0))))
        pings = ""
        if "ping" in cloud.fields:
            p = cloud.fields["ping"][stray]
            pings = f", pings {int(p.min())}–{int(p.max())}"
        notes.append(f"{int(stray.sum()):,} soundings{pings} lie {far / 1000:.1f} km from the rest of the "
                     "survey (a navigation jump?) and were left out")
        cloud = cloud.subset(~stray)
        pts = check_points(cloud.xyz, minimum=minimum, name="points")
    return cloud, pts, notes


def ping_ranges(pings: np.ndarray) -> list[list[int]]:
    """Runs of consecutive ping numbers, each ``[first, last]``.

    Examples
    --------
    >>> ping_ranges(np.array([7, 3, 4, 5, 7, 9, 10]))
    [[3, 5], [7, 7], [9, 10]]
    """
    u = np.unique(np.asarray(pings, np.int64))
    if len(u) == 0:
        return []
    breaks = np.flatnonzero(np.diff(u) > 1)
    starts = np.concatenate([[0], breaks + 1])
    ends = np.concatenate([breaks, [len(u) - 1]])
    return [[int(u[a]), int(u[b])] for a, b in zip(starts, ends, strict=True)]


def sources(index: np.ndarray, fields: Mapping[str, np.ndarray], files: Sequence[str]
            ) -> tuple[dict[str, Any], ...]:
    """The files and ping ranges of the soundings ``index`` of a cloud.

    Parameters
    ----------
    index : ndarray of int
        The object's soundings (rows of the cloud).
    fields : mapping
        The cloud's fields: ``file`` (index into ``files``; absent: every sounding is from
        ``files[0]``) and ``ping`` (absent: no ranges).
    files : sequence of str
        The survey's files.

    Returns
    -------
    tuple of dict
        ``{"file", "pings" ([[first, last], ...] or None), "soundings"}`` per file, in
        file order.

    Examples
    --------
    >>> f = {"file": np.array([0, 0, 1, 1]), "ping": np.array([4, 5, 1, 9])}
    >>> sources(np.array([0, 1, 3]), f, ["a.laz", "b.laz"])[1]
    {'file': 'b.laz', 'pings': [[9, 9]], 'soundings': 1}
    """
    index = np.asarray(index, np.int64)
    file_of = fields.get("file")
    which = np.zeros(len(index), np.int64) if file_of is None else np.asarray(file_of)[index].astype(np.int64)
    ping = fields.get("ping")
    out = []
    for f in np.unique(which):
        rows = index[which == f]
        out.append({"file": str(files[int(f)]) if int(f) < len(files) else str(int(f)),
                    "pings": None if ping is None else ping_ranges(np.asarray(ping)[rows]),
                    "soundings": len(rows)})
    return tuple(out)
