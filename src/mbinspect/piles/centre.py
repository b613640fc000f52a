"""Stage 4a: the paper's centre method (mean of the top points within r + k_s).

A line sounds a top unevenly (denser where its beams meet the top more squarely, thinner
toward its shadowed rim), and a plain mean of soundings follows the density: 9 cm off on a
fully covered top of the real EM3000 line. With ``cell`` the mean is of area instead: each
sounding counts as the inverse of the soundings in its plan cell, so each covered cell
counts once (3 cm off on that top).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import DataError
from ..grid import cell_key

__all__ = ["centre_method", "top_coverage", "centre_summary", "segment_bias"]


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
        _, inv = np.unique(np.asarray(groups)[used], return_inverse=True)
        g = np.zeros((inv.max() + 1, 2))
        np.add.at(g, inv, dev)
        cov = g.T @ g / max(n, 1) ** 2
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
    ``segment_bias`` (m).

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
    bias = segment_bias(top[used], radius)
    cov = cov + bias**2 * np.eye(2)
    return {"x": float(c[0]), "y": float(c[1]), "z": float(c[2]),
            "sigma_xy": math.sqrt(max(float(np.trace(cov)) / 2, 0.0)), "cov": cov,
            "top_coverage": top_coverage(top[used], c, radius), "segment_bias": bias}
