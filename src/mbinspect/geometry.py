"""Plane geometry on polygons and point sets: hulls, areas, rectangles, distances.

Angles that a user reads are *bearings*: degrees clockwise from grid north (+y),
as surveyors give them. Polygons are ``(K, 2)`` arrays of vertices, counter-clockwise,
not closed (the last vertex is not a repeat of the first).

Examples
--------
>>> import numpy as np
>>> from mbinspect.geometry import polygon_area, min_area_rectangle
>>> square = np.array([[0, 0], [2, 0], [2, 2], [0, 2]], float)
>>> polygon_area(square)
4.0
>>> rect = min_area_rectangle(square)
>>> round(rect.length, 6), round(rect.width, 6)
(2.0, 2.0)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "ray_cylinder",
    "bearing_to_vector",
    "vector_to_bearing",
    "convex_hull",
    "tilted_section",
    "polygon_area",
    "polygon_centroid",
    "Rectangle",
    "min_area_rectangle",
    "rectangle_corners",
    "polygon_distance",
    "points_in_polygon",
    "crop_mask",
]


def bearing_to_vector(bearing_deg: float) -> np.ndarray:
    """Unit vector (east, north) of a bearing in degrees clockwise from north.

    Parameters
    ----------
    bearing_deg : float
        Degrees clockwise from grid north.

    Returns
    -------
    ndarray, shape (2,)

    Examples
    --------
    >>> np.round(bearing_to_vector(90.0), 6).tolist()
    [1.0, 0.0]
    """
    b = math.radians(bearing_deg)
    return np.array([math.sin(b), math.cos(b)])


def vector_to_bearing(v: np.ndarray, *, axial: bool = False) -> float:
    """Bearing in degrees clockwise from north of vector ``(east, north)``.

    With ``axial=True`` the result is folded into [0, 180) (an axis has no sense).

    Parameters
    ----------
    v : ndarray, shape (2,)
        (east, north).
    axial : bool
        Fold into [0, 180).

    Returns
    -------
    float
        Degrees clockwise from grid north, in [0, 360) or [0, 180).
    """
    b = math.degrees(math.atan2(float(v[0]), float(v[1]))) % 360.0
    return b % 180.0 if axial else b


def convex_hull(points: np.ndarray) -> np.ndarray:
    """Convex hull of 2-D points, counter-clockwise, shape (K, 2) (Qhull; fewer than three
    distinct or collinear points are returned as they are).

    Parameters
    ----------
    points : ndarray, shape (N, 2)

    Returns
    -------
    ndarray, shape (K, 2)
    """
    from scipy.spatial import ConvexHull, QhullError

    pts = np.asarray(points, dtype=np.float64)[:, :2]
    if len(pts) < 50:  # few points may be all duplicates or collinear: settle them exactly
        pts = np.unique(pts, axis=0)
    if len(pts) < 3:
        return pts
    try:
        hull = ConvexHull(pts)
    except QhullError:
        return pts
    return pts[hull.vertices]  # Qhull gives 2-D hull vertices counter-clockwise


def tilted_section(centre: tuple[float, float], radius: float, tilt_deg: float, bearing_deg: float,
                   points: int = 24) -> np.ndarray:
    """A cylinder's horizontal section round ``centre``: an ellipse, ``radius`` stretched by
    1/cos(tilt) toward the bearing its axis leans to, shape (points, 2).

    >>> (tilted_section((0.0, 0.0), 1.0, 60.0, 90.0, points=4).round(3) + 0.0).tolist()
    [[2.0, 0.0], [0.0, -1.0], [-2.0, 0.0], [0.0, 1.0]]
    """
    t, (ux, uy) = np.linspace(0, 2 * math.pi, points, endpoint=False), bearing_to_vector(bearing_deg)
    along, across = radius / math.cos(math.radians(tilt_deg)) * np.cos(t), radius * np.sin(t)
    return np.column_stack([centre[0] + along * ux + across * uy, centre[1] + along * uy - across * ux])


def polygon_area(poly: np.ndarray) -> float:
    """Area of a simple polygon (shoelace); positive for counter-clockwise.

    Parameters
    ----------
    poly : ndarray, shape (K, 2)
        Vertices in order (m).

    Returns
    -------
    float
        Signed area (m²).
    """
    p = np.asarray(poly, dtype=np.float64)
    if len(p) < 3:
        return 0.0
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def polygon_centroid(poly: np.ndarray) -> np.ndarray:
    """Area centroid of a simple polygon, shape (2,).

    Parameters
    ----------
    poly : ndarray, shape (K, 2)
        Vertices in order (m).

    Returns
    -------
    ndarray, shape (2,)
    """
    p = np.asarray(poly, dtype=np.float64)
    a = polygon_area(p)
    if abs(a) < 1e-12:
        return p.mean(axis=0)
    x, y = p[:, 0], p[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    return np.array([np.sum((x + xn) * cross), np.sum((y + yn) * cross)]) / (6.0 * a)


@dataclass(frozen=True)
class Rectangle:
    """An oriented rectangle: centre, side lengths and the bearing of its long side."""

    cx: float
    cy: float
    length: float
    width: float
    bearing_deg: float

    @property
    def area(self) -> float:
        return self.length * self.width


def rectangle_corners(
    cx: float, cy: float, length: float, width: float, bearing_deg: float
) -> np.ndarray:
    """The four corners (counter-clockwise) of an oriented rectangle, shape (4, 2).

    Parameters
    ----------
    cx, cy : float
        Centre (m).
    length, width : float
        Sides along and across the bearing (m).
    bearing_deg : float
        Direction of the length (deg clockwise from grid north).

    Returns
    -------
    ndarray, shape (4, 2)
    """
    u = bearing_to_vector(bearing_deg) * (length / 2.0)
    w = np.array([u[1], -u[0]]) * (width / max(length, 1e-300))
    c = np.array([cx, cy])
    corners = np.array([c - u - w, c + u - w, c + u + w, c - u + w])
    if polygon_area(corners) < 0:
        corners = corners[::-1]
    return corners


def min_area_rectangle(points: np.ndarray) -> Rectangle:
    """Minimum-area enclosing rectangle of 2-D points (rotating calipers on the hull).

    Parameters
    ----------
    points : ndarray, shape (N, 2)

    Returns
    -------
    Rectangle
        Centre, length >= width (m) and the bearing of the length (deg, axial).
    """
    hull = convex_hull(points)
    if len(hull) < 3:
        pts = np.asarray(points, dtype=np.float64)[:, :2]
        c = pts.mean(axis=0)
        if len(pts) < 2:
            return Rectangle(float(c[0]), float(c[1]), 0.0, 0.0, 0.0)
        d = pts.max(axis=0) - pts.min(axis=0)
        length = float(np.hypot(*d))
        return Rectangle(float(c[0]), float(c[1]), length, 0.0, vector_to_bearing(d, axial=True))
    edges = np.roll(hull, -1, axis=0) - hull
    angles = np.unique(np.mod(np.arctan2(edges[:, 1], edges[:, 0]), np.pi / 2))
    # every edge direction at once: projections (angles, hull points) on both axes
    ca, sa = np.cos(angles), np.sin(angles)
    u = np.outer(ca, hull[:, 0]) + np.outer(sa, hull[:, 1])
    v = np.outer(-sa, hull[:, 0]) + np.outer(ca, hull[:, 1])
    umin, umax, vmin, vmax = u.min(axis=1), u.max(axis=1), v.min(axis=1), v.max(axis=1)
    areas = (umax - umin) * (vmax - vmin)
    k = int(np.flatnonzero(areas <= areas.min() + 1e-12)[0])  # the first of equal minima
    ang, u0, u1, v0, v1 = float(angles[k]), umin[k], umax[k], vmin[k], vmax[k]
    c, s = math.cos(ang), math.sin(ang)
    du, dv = u1 - u0, v1 - v0
    centre = np.array([c, s]) * (u0 + u1) / 2 + np.array([-s, c]) * (v0 + v1) / 2
    if du >= dv:
        axis, length, width = np.array([c, s]), du, dv
    else:
        axis, length, width = np.array([-s, c]), dv, du
    return Rectangle(
        float(centre[0]), float(centre[1]), float(length), float(width),
        vector_to_bearing(axis, axial=True),
    )


def _segments_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance of each point in ``p`` (M, 2) to each segment a[k]-b[k]: shape (M, K)."""
    ab = b - a
    ap = p[:, None, :] - a[None, :, :]
    denom = np.maximum(np.einsum("kj,kj->k", ab, ab), 1e-300)
    t = np.clip(np.einsum("mkj,kj->mk", ap, ab) / denom, 0.0, 1.0)
    closest = a[None] + t[..., None] * ab[None]
    return np.linalg.norm(p[:, None, :] - closest, axis=2)


def _convex_overlap(p: np.ndarray, q: np.ndarray) -> bool:
    for poly in (p, q):
        edges = np.roll(poly, -1, axis=0) - poly
        normals = np.column_stack([-edges[:, 1], edges[:, 0]])
        pp, qq = p @ normals.T, q @ normals.T
        if np.any((pp.max(axis=0) < qq.min(axis=0)) | (qq.max(axis=0) < pp.min(axis=0))):
            return False
    return True


def polygon_distance(p: np.ndarray, q: np.ndarray) -> float:
    """Smallest distance between two convex polygons; 0 when they touch or overlap.

    Parameters
    ----------
    p, q : ndarray, shape (K, 2)
        Convex polygons (m).

    Returns
    -------
    float
        Distance (m).
    """
    p = np.asarray(p, dtype=np.float64)
    q = np.asarray(q, dtype=np.float64)
    if _convex_overlap(p, q):
        return 0.0
    d1 = _segments_distance(p, q, np.roll(q, -1, axis=0)).min()
    d2 = _segments_distance(q, p, np.roll(p, -1, axis=0)).min()
    return float(min(d1, d2))


def points_in_polygon(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Boolean mask of the 2-D points inside a simple polygon (even-odd rule).

    Parameters
    ----------
    points : ndarray, shape (N, 2 or more)
    poly : ndarray, shape (K, 2)

    Returns
    -------
    ndarray of bool, shape (N,)
    """
    pts = np.asarray(points, dtype=np.float64)[:, :2]
    poly = np.asarray(poly, dtype=np.float64)
    x, y = pts[:, 0], pts[:, 1]
    inside = np.zeros(len(pts), dtype=bool)
    xj, yj = poly[-1]
    for xi, yi in poly:
        crosses = (yi > y) != (yj > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            xc = (xj - xi) * (y - yi) / (yj - yi) + xi
        inside ^= crosses & (x < xc)
        xj, yj = xi, yi
    return inside


def crop_mask(xyz: np.ndarray, crop: Any) -> np.ndarray:
    """Points inside a box or a polygon.

    Parameters
    ----------
    xyz : ndarray, shape (N, 2 or 3)
        Points (m).
    crop : (xmin, ymin, xmax, ymax) or sequence of (x, y) vertices (at least 3)
        A flat sequence of 6 or more numbers is read as polygon vertices.

    Returns
    -------
    ndarray of bool, shape (N,)

    Examples
    --------
    >>> pts = np.array([[0.5, 0.5, 0.0], [2.0, 2.0, 0.0]])
    >>> crop_mask(pts, (0, 0, 1, 1)).tolist(), crop_mask(pts, [(0, 0), (3, 0), (0, 3)]).tolist()
    ([True, False], [True, False])
    """
    from .options import crop_value

    value = crop_value("crop", crop)
    if len(value) == 4 and not isinstance(value[0], tuple):
        xmin, ymin, xmax, ymax = value
        return (xyz[:, 0] >= xmin) & (xyz[:, 0] <= xmax) & (xyz[:, 1] >= ymin) & (xyz[:, 1] <= ymax)
    return points_in_polygon(xyz[:, :2], np.asarray(value, np.float64))


def ray_cylinder(top: np.ndarray, axis: np.ndarray, radius: float, length: float, o: np.ndarray,
                 d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where rays first meet a closed-top cylinder (a pile): its side or its top disc.

    Parameters
    ----------
    top : ndarray, shape (3,)
        The top disc's centre.
    axis : ndarray, shape (3,)
        Unit axis, pointing up out of the top.
    radius, length : float
        The cylinder's radius and its length below the top (m).
    o, d : ndarray, shape (N, 3)
        Ray origins and unit directions.

    Returns
    -------
    t : ndarray, shape (N,)
        Ray parameter of the first hit (inf: a miss).
    normal : ndarray, shape (N, 3)
        Outward surface normal there.

    Examples
    --------
    >>> o = np.array([[0.0, 0.0, 10.0], [-5.0, 0.0, -1.0]])
    >>> d = np.array([[0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])
    >>> t, n = ray_cylinder(np.zeros(3), np.array([0.0, 0.0, 1.0]), 1.0, 5.0, o, d)
    >>> t.tolist(), n[1].tolist()
    ([10.0, 4.0], [-1.0, 0.0, 0.0])
    """
    a = np.asarray(axis, float)
    w = o - np.asarray(top, float)
    wa, da = w @ a, d @ a
    wp = w - wa[:, None] * a
    dp = d - da[:, None] * a
    qa = np.einsum("ij,ij->i", dp, dp)
    qb = 2 * np.einsum("ij,ij->i", wp, dp)
    qc = np.einsum("ij,ij->i", wp, wp) - radius**2
    disc = qb * qb - 4 * qa * qc
    with np.errstate(invalid="ignore", divide="ignore"):
        ts = (-qb - np.sqrt(disc)) / (2 * qa)
        tc = -wa / da
    s = wa + ts * da
    side_ok = (disc >= 0) & (ts > 0) & (s <= 0) & (s >= -length)
    rc = wp + tc[:, None] * dp
    cap_ok = (da < 0) & (tc > 0) & (np.einsum("ij,ij->i", rc, rc) <= radius**2)
    t = np.where(side_ok, ts, np.inf)
    t = np.where(cap_ok & (tc < t), tc, t)
    use_cap = cap_ok & (tc <= t)
    radial = (wp + ts[:, None] * dp) / radius
    return t, np.where(use_cap[:, None], a[None, :], radial)
