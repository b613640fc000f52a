"""Stage 4a: the paper's centre method (mean of the top points within r + k_s).

A line sounds a top unevenly (denser where its beams meet the top more squarely, thinner
toward its shadowed rim), and a plain mean of soundings follows the density: 9 cm off on a
fully covered top of the real EM3000 line. With ``cell`` the mean is of area instead: each
sounding counts as the inverse of the soundings in its plan cell, so each covered cell
counts once (3 cm off on that top). Better still where the soundings reach the rim over
most of its round, :func:`rim_centre` fits the disc of the pile's radius to the edge of
the sounded top, which no unevenness inside it moves (2.2 cm off on that top; 0.3-2.5 cm
on the KMALL strip's tops sounded over 20-98 % of their area, where the area mean is
5-40 cm off).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import DataError
from ..fit import clustered_cov
from ..grid import cell_key
from .results import plan_sigma

__all__ = ["RIM_MIN_ARC_DEG", "RIM_MIN_VERTICES", "centre_method", "centre_summary", "rim_centre",
           "segment_bias", "top_coverage"]


def centre_method(top: np.ndarray, *, radius: float, ks: float = 0.1, start: np.ndarray | None = None,
                  max_iterations: int = 50, groups: np.ndarray | None = None, cell: float | None = None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The paper's centre method: mean of the top points within ``r + k_s``, iterated.

    Parameters
    ----------
    top : ndarray, shape (N, 3)
        The pile's top-face points (m).
    radius : float
        Pile radius r (m).
    ks : float
        The paper's k_s (m): points within r + k_s of the centre are averaged.
    start : ndarray (3,), optional
        Starting centre; default the mean of ``top``.
    max_iterations : int
        Most re-centring rounds.
    groups : ndarray (N,), optional
        Ping of each point, for a covariance that treats a ping's points as one cluster.
    cell : float, optional
        Plan cell (m) of the area mean: each point weighs the inverse of the points in its
        cell (cells on a lattice from (0, 0)); None: the paper's plain mean.

    Returns
    -------
    centre : ndarray, shape (3,)
    used : ndarray of bool
        The top points in the final mean.
    cov : ndarray, shape (2, 2)
        Covariance of the plan centre (m², cluster-robust by ``groups`` when given).

    Examples
    --------
    >>> a = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    >>> top = np.column_stack([0.6 * np.cos(a) + 5, 0.6 * np.sin(a) - 3, np.full(400, -16.0)])
    >>> c, used, cov = centre_method(top, radius=0.75)
    >>> np.round(c, 3).tolist()
    [5.0, -3.0, -16.0]

    A disc sounded four times as densely on one half: the plain mean follows the soundings,
    the area mean stays near the centre.

    >>> g = np.arange(-0.6, 0.61, 0.02)
    >>> xy = np.array([(x, y) for x in g for y in g if x * x + y * y <= 0.36])
    >>> dense = np.vstack([xy] + [xy[xy[:, 0] > 0] + 0.001 * k for k in range(1, 4)])
    >>> top = np.column_stack([dense, np.zeros(len(dense))])
    >>> plain, _, _ = centre_method(top, radius=0.6)
    >>> area, _, _ = centre_method(top, radius=0.6, cell=0.1)
    >>> round(float(plain[0]), 2), abs(round(float(area[0]), 2))
    (0.16, 0.0)
    """
    t = np.asarray(top, np.float64)
    if len(t) == 0:
        raise DataError("centre method: no top points")
    c = t.mean(axis=0) if start is None else np.asarray(start, np.float64)
    used = np.ones(len(t), dtype=bool)
    w = np.ones(len(t))
    for _ in range(max_iterations):
        used = np.hypot(*(t[:, :2] - c[:2]).T) <= radius + ks
        if not used.any():
            raise DataError(f"centre method: no top point within r + k_s = {radius + ks:.2f} m")
        w = _area_weights(t[used, :2], cell) if cell is not None else np.ones(int(used.sum()))
        new = (t[used] * w[:, None]).sum(axis=0) / w.sum()
        if np.hypot(*(new[:2] - c[:2])) < 1e-5:
            c = new
            break
        c = new
    dev = (t[used, :2] - c[:2]) * (w / w.mean())[:, None]
    n = int(used.sum())
    if groups is not None:
        cov = clustered_cov(dev, np.asarray(groups)[used])
    else:
        cov = np.cov(dev.T) / max(n, 1) if n > 1 else np.full((2, 2), np.nan)
    return c, used, cov


def _area_weights(xy: np.ndarray, cell: float) -> np.ndarray:
    """Each point's weight in an area mean: one over the points in its ``cell`` m square."""
    _, inv, count = np.unique(cell_key(xy, cell), return_inverse=True, return_counts=True)
    return 1.0 / count[inv]


def top_coverage(top: np.ndarray, centre: np.ndarray, radius: float, cell: float = 0.15) -> float:
    """Fraction of the top disc's cells (``cell`` m) that hold at least one top point.

    Parameters
    ----------
    top : ndarray, shape (N, 3)
        Top points (m).
    centre : ndarray, shape (2,) or (3,)
        Disc centre (m).
    radius : float
        Disc radius (m).
    cell : float
        Cell size (m).

    Returns
    -------
    float
        0 to 1.

    Examples
    --------
    >>> top_coverage(np.zeros((0, 3)), np.zeros(3), 0.75)
    0.0
    """
    g = np.arange(-radius + cell / 2, radius, cell)
    gx, gy = np.meshgrid(g, g)
    disc = np.hypot(gx, gy) <= radius - cell / 2
    if len(top) == 0 or not disc.any():
        return 0.0
    ij = np.floor((top[:, :2] - centre[:2] + radius) / cell).astype(np.int64)
    n = len(g)
    ok = (ij >= 0).all(axis=1) & (ij < n).all(axis=1)
    hit = np.zeros((n, n), dtype=bool)
    hit[ij[ok, 1], ij[ok, 0]] = True
    return float((hit & disc).sum() / disc.sum())


def segment_bias(top: np.ndarray, radius: float) -> float:
    """How far the mean of a partly seen top can lie from its centre (m): the offset of a
    circular segment of the disc with the area of the top points' convex hull.

    A top seen on one side only (one line along its edge) is a segment of the disc whose
    mean lies toward the seen side; scattered gaps between soundings leave the hull whole
    and add nothing (the disc is taken one sounding spacing narrower, as far as soundings
    reach). Used as a 1-sigma term of the centre method's covariance.

    Examples
    --------
    >>> a = np.linspace(0, 2 * np.pi, 400)
    >>> r = np.sqrt(np.linspace(0, 1, 400)) * 0.75
    >>> disc = np.column_stack([r * np.cos(a * 37), r * np.sin(a * 37)])
    >>> round(segment_bias(disc, 0.75), 3), round(segment_bias(disc[disc[:, 0] > 0], 0.75), 2)
    (0.0, 0.28)
    """
    from scipy.spatial import ConvexHull, QhullError, cKDTree

    xy = np.asarray(top, np.float64)[:, :2]
    try:
        area = ConvexHull(xy).volume if len(xy) >= 3 else 0.0
    except QhullError:  # collinear: a line across the top
        area = 0.0
    # soundings reach to within about their own spacing of the rim: a whole top seen by
    # soundings s apart has a hull of (r - s)^2 / r^2 of the disc
    spacing = float(np.median(cKDTree(xy).query(xy, k=2)[0][:, 1])) if len(xy) >= 2 else radius
    share = min(area / (math.pi * max(radius - spacing, 0.5 * radius) ** 2), 1.0)
    if share >= 1.0:
        return 0.0
    # a segment of half-angle t holds the share (t - sin t cos t) / pi of the disc, and its
    # centroid lies (2/3) r sin^3 t / (t - sin t cos t) from the centre
    t = np.linspace(1e-3, math.pi, 2000)
    held = (t - np.sin(t) * np.cos(t)) / math.pi
    half = float(np.interp(max(share, held[0]), held, t))
    return float(2 / 3 * radius * math.sin(half) ** 3 / (half - math.sin(half) * math.cos(half)))


def centre_summary(top: np.ndarray, *, radius: float, ks: float, start: np.ndarray | None,
                   groups: np.ndarray | None, cell: float | None = None) -> dict[str, Any]:
    """The centre method's answer as a summary: ``x, y, z`` (m), ``sigma_xy`` (m, plan
    1-sigma), ``cov`` (2 x 2, m²; the soundings' scatter and :func:`segment_bias` as a
    1-sigma in each direction), ``top_coverage`` (share of the disc seen) and
    ``segment_bias`` (m). With ``cell`` (the area mean), the plan centre is the rim's
    (:func:`rim_centre`, its own covariance, no segment bias) where the rim allows.

    Parameters are those of :func:`centre_method`.

    Parameters
    ----------
    top : ndarray, shape (N, 3)
        Top-face points (m).
    radius, ks : float
        Pile radius and the paper's k_s (m).
    start : ndarray (3,), optional
        Starting centre.
    groups : ndarray (N,), optional
        Ping of each point.
    cell : float, optional
        The area mean's cell (m); None: the plain mean.

    Returns
    -------
    dict
    """
    c, used, cov = centre_method(top, radius=radius, ks=ks, start=start, groups=groups, cell=cell)
    rim = rim_centre(top[used, :2], c[:2], radius) if cell is not None else None
    if rim is not None:
        c = np.r_[rim[0], c[2]]
        cov, bias = rim[1], 0.0
    else:
        bias = segment_bias(top[used], radius)
        cov = cov + bias**2 * np.eye(2)
    return {"x": float(c[0]), "y": float(c[1]), "z": float(c[2]),
            "sigma_xy": plan_sigma(cov), "cov": cov,
            "top_coverage": top_coverage(top[used], c, radius), "segment_bias": bias}


#: The rim is the top's edge where its soundings' hull meets the disc: a centre from it
#: needs this many hull vertices spread over :data:`RIM_MIN_ARC_DEG` of the disc's edge.
RIM_MIN_VERTICES = 6
RIM_MIN_ARC_DEG = 150.0

#: Scale (m) of the rim fit's robust loss: a hull vertex further than this from the rim
#: (one on a chord across an unsounded part) counts less and less.
RIM_LOSS_SCALE = 0.02


def rim_centre(xy: np.ndarray, start: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray] | None:
    """The centre of the disc of ``radius`` whose rim best follows the top soundings' hull.

    The vertices of the convex hull of a top's soundings lie on its rim (plus the noise),
    however unevenly the top is sounded inside; a chord across an unsounded part leaves
    vertices inside the disc, which a robust loss sets aside. None when the hull's vertices
    are too few or span less than :data:`RIM_MIN_ARC_DEG` around ``start``.

    Parameters
    ----------
    xy : ndarray, shape (N, 2)
        The top's soundings in plan (m).
    start : ndarray, shape (2,)
        A first centre (the area mean).
    radius : float
        The pile's radius (m).

    Returns
    -------
    (centre (2,), covariance (2, 2)) or None
        The covariance from the fit's residuals on the hull (m²).

    Examples
    --------
    A top sounded four times as densely on one half, and half a top: the rim keeps the
    centre where the soundings' mean does not.

    >>> g = np.arange(-0.5, 0.51, 0.02)
    >>> xy = np.array([(x, y) for x in g for y in g if x * x + y * y <= 0.25])
    >>> dense = np.vstack([xy] + [xy[xy[:, 0] > 0] + 0.001 * k for k in range(1, 4)])
    >>> c, cov = rim_centre(dense, dense.mean(axis=0), 0.5)
    >>> round(float(dense.mean(axis=0)[0]), 2), abs(round(float(c[0]), 2)), abs(round(float(c[1]), 2))
    (0.13, 0.0, 0.0)
    >>> half = xy[xy[:, 0] >= 0]
    >>> c, cov = rim_centre(half, half.mean(axis=0), 0.5)
    >>> round(float(half.mean(axis=0)[0]), 2), abs(round(float(c[0]), 2))
    (0.21, 0.01)
    >>> rim_centre(xy[np.hypot(xy[:, 0] - 0.4, xy[:, 1]) < 0.15], np.zeros(2), 0.5) is None
    True
    """
    from scipy.optimize import least_squares
    from scipy.spatial import ConvexHull, QhullError

    if len(xy) < RIM_MIN_VERTICES:
        return None
    try:
        v = xy[ConvexHull(xy).vertices]
    except QhullError:
        return None
    if len(v) < RIM_MIN_VERTICES:
        return None
    ang = np.sort(np.degrees(np.arctan2(*(v - start).T[::-1])))
    gaps = np.diff(np.r_[ang, ang[0] + 360.0])
    if 360.0 - gaps.max() < RIM_MIN_ARC_DEG:
        return None
    fit = least_squares(lambda c: np.hypot(*(v - c).T) - radius, np.asarray(start, float), loss="soft_l1",
                        f_scale=RIM_LOSS_SCALE)
    res = fit.fun
    s2 = max(float(np.median(np.abs(res))) * 1.4826, 1e-3) ** 2
    try:
        cov = s2 * np.linalg.inv(fit.jac.T @ fit.jac)
    except np.linalg.LinAlgError:
        return None
    return fit.x, cov
