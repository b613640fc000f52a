"""Segmentation helpers: normals, clusters, the elevation window, Otsu thresholds.

Examples
--------
>>> import numpy as np
>>> from mbinspect.segment import elevation_window
>>> z = np.r_[np.full(50, -16.0), np.linspace(-21, -16.2, 50)]
>>> lo, hi, n = elevation_window(z, window=0.1, step=0.01)
>>> bool(lo <= -16.0 <= hi), n >= 50
(True, True)
"""

from __future__ import annotations

import numpy as np
from scipy.cluster.vq import kmeans2, vq
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from .errors import NotEnoughPointsError, ParameterError

__all__ = ["normals", "kmeans", "components", "elevation_window", "otsu_threshold"]


def normals(points: np.ndarray, *, k: int = 16, workers: int = -1) -> tuple[np.ndarray, np.ndarray]:
    """Unit normals by PCA over the ``k`` nearest neighbours, oriented up (n_z >= 0).

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        Points (m).
    k : int
        Neighbours per point.
    workers : int
        Threads of the neighbour search (-1: all cores).

    Returns
    -------
    normals : ndarray, shape (N, 3)
    planarity : ndarray, shape (N,)
        ``(l2 - l3) / l1`` of the eigenvalues l1 >= l2 >= l3: near 1 for a clean
        surface patch, near 0 where the neighbours lie on a line (one ping's beams
        across a sparse survey) and the normal is not defined.
    """
    pts = np.asarray(points, np.float64)
    n = len(pts)
    if n < 3:
        raise NotEnoughPointsError(f"normals: {n} points, at least 3 needed")
    kk = min(k, n)
    centre = pts.mean(axis=0)
    local = pts - centre
    _, idx = cKDTree(local).query(local, k=kk, workers=workers)
    nb = local[idx]  # (N, k, 3)
    nb = nb - nb.mean(axis=1, keepdims=True)
    cov = np.einsum("nki,nkj->nij", nb, nb) / kk
    w, v = np.linalg.eigh(cov)
    nrm = v[:, :, 0]
    nrm = np.where(nrm[:, 2:3] < 0, -nrm, nrm)
    planarity = (w[:, 1] - w[:, 0]) / np.maximum(w[:, 2], 1e-300)
    return nrm, planarity


def kmeans(points: np.ndarray, k: int, *, seed: int | list[int] = 0, n_init: int = 10
           ) -> tuple[np.ndarray, np.ndarray]:
    """K-means with k-means++ seeding, best of ``n_init`` seeded runs.

    Parameters
    ----------
    points : ndarray, shape (N, D)
    k : int
        Clusters.
    seed : int
    n_init : int
        Seeded restarts; the one of least inertia wins.

    Returns
    -------
    labels : ndarray of int, shape (N,)
    centres : ndarray, shape (k, D)
    """
    pts = np.asarray(points, np.float64)
    if k < 1:
        raise ParameterError(f"k: {k} must be >= 1")
    if len(pts) < k:
        raise NotEnoughPointsError(f"kmeans: {len(pts)} points for {k} clusters")
    shift = pts.mean(axis=0)
    local = pts - shift
    rng = np.random.default_rng(seed)
    best = None
    for _ in range(n_init):
        centres, _ = kmeans2(local, k, minit="++", seed=rng, iter=1)
        labels, centres = _lloyd(local, centres)
        inertia = float(((local - centres[labels]) ** 2).sum())
        if best is None or inertia < best[0]:
            best = (inertia, labels, centres)
    assert best is not None
    return best[1], best[2] + shift


def _lloyd(pts: np.ndarray, centres: np.ndarray, max_iter: int = 100) -> tuple[np.ndarray, np.ndarray]:
    """Lloyd iterations from ``centres`` until no label changes (an empty cluster stays put)."""
    k = len(centres)
    centres = centres.copy()
    labels = np.full(len(pts), -1)
    for _ in range(max_iter):
        new, _ = vq(pts, centres)
        if np.array_equal(new, labels):
            break
        labels = new
        counts = np.bincount(labels, minlength=k)
        sums = np.stack([np.bincount(labels, weights=pts[:, d], minlength=k) for d in range(pts.shape[1])],
                        axis=1)
        full = counts > 0
        centres[full] = sums[full] / counts[full, None]
    return labels, centres


def components(points: np.ndarray, *, eps: float, min_points: int = 1) -> np.ndarray:
    """Connected components of points closer than ``eps`` (single linkage).

    Returns labels 0..K-1 ordered by decreasing size; components smaller than
    ``min_points`` get -1.

    Parameters
    ----------
    points : ndarray, shape (N, D)
        Points (m).
    eps : float
        Linking distance (m).
    min_points : int
        Smaller components are labelled -1.

    Returns
    -------
    ndarray of int, shape (N,)

    Examples
    --------
    >>> components(np.array([[0.0, 0], [0.3, 0], [5, 5]]), eps=0.5).tolist()
    [0, 0, 1]
    """
    pts = np.asarray(points, np.float64)
    n = len(pts)
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    local = pts - pts.mean(axis=0)
    pairs = _delaunay_links(local, eps) if pts.shape[1] == 2 else None
    if pairs is None:
        pairs = cKDTree(local).query_pairs(eps, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, lab = connected_components(graph, directed=False)
    sizes = np.bincount(lab)
    order = np.argsort(-sizes, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    out = rank[lab]
    out[sizes[lab] < min_points] = -1
    return out


def _delaunay_links(xy: np.ndarray, eps: float) -> np.ndarray | None:
    """The edges of the plan Delaunay triangulation no longer than ``eps``: they join the same
    points as every pair within ``eps`` (the Euclidean minimum spanning tree is a subgraph of
    the triangulation, and its path between two points within ``eps`` has no longer edge),
    without listing the millions of pairs a dense pile wall holds. None where the
    triangulation does not hold every point (too few, all on a line)."""
    from scipy.spatial import Delaunay, QhullError

    if len(xy) < 4:
        return None
    try:
        tri = Delaunay(xy)
    except (QhullError, ValueError):
        return None
    s = tri.simplices
    edges = np.concatenate([s[:, [0, 1]], s[:, [1, 2]], s[:, [0, 2]]])
    if len(tri.coplanar):  # points Qhull left out (copies of a vertex): joined to their vertex
        edges = np.vstack([edges, tri.coplanar[:, [0, 2]]])
    gap = xy[edges[:, 0]] - xy[edges[:, 1]]
    length = np.hypot(gap[:, 0], gap[:, 1])
    if len(tri.coplanar) and (length[-len(tri.coplanar):] > eps).any():
        return None  # one left out farther than eps from its vertex: its own neighbours unknown
    return edges[length <= eps]


def elevation_window(z: np.ndarray, *, window: float = 0.1, step: float = 0.01
                     ) -> tuple[float, float, int]:
    """The pile paper's top-face search: slide a ``window`` m z-interval by ``step`` m.

    Returns the interval ``(lo, hi)`` holding the most points and that count.

    Parameters
    ----------
    z : ndarray, shape (N,)
        Elevations (m).
    window, step : float
        Window height and step (m).

    Returns
    -------
    lo, hi : float
        The window (m).
    count : int
        Points in it.
    """
    if window <= 0 or step <= 0:
        raise ParameterError(f"window {window} and step {step} must be positive")
    zs = np.sort(np.asarray(z, np.float64))
    if len(zs) == 0:
        raise NotEnoughPointsError("elevation_window: no points")
    starts = np.arange(zs[0] - window, zs[-1] + step, step)
    counts = np.searchsorted(zs, starts + window, side="right") - np.searchsorted(zs, starts)
    i = int(np.argmax(counts[::-1]))  # ties: the highest window (the top is on top)
    i = len(counts) - 1 - i
    return float(starts[i]), float(starts[i] + window), int(counts[i])


def otsu_threshold(values: np.ndarray, *, bins: int = 256) -> float:
    """Otsu's threshold: the split that maximises the between-class variance.

    Parameters
    ----------
    values : ndarray, shape (N,)
    bins : int
        Histogram bins.

    Returns
    -------
    float

    Examples
    --------
    >>> v = np.r_[np.full(50, 10.0), np.full(50, 30.0)]
    >>> 10 < otsu_threshold(v) < 30
    True
    """
    v = np.asarray(values, np.float64)
    v = v[np.isfinite(v)]
    if len(v) < 2 or v.min() == v.max():
        raise NotEnoughPointsError("otsu_threshold: needs at least two distinct values")
    hist, edges = np.histogram(v, bins=bins)
    mids = (edges[:-1] + edges[1:]) / 2
    w0 = np.cumsum(hist)
    w1 = w0[-1] - w0
    m0 = np.cumsum(hist * mids) / np.maximum(w0, 1)
    m1 = (np.sum(hist * mids) - np.cumsum(hist * mids)) / np.maximum(w1, 1)
    between = w0 * w1 * (m0 - m1) ** 2
    return float(edges[int(np.argmax(between[:-1])) + 1])
