"""Outlier filters: each returns a boolean mask of the points to keep.

Examples
--------
>>> import numpy as np
>>> from mbinspect.filters import radius_outlier
>>> g = np.stack(np.meshgrid(np.arange(20.0), np.arange(20.0)), -1).reshape(-1, 2) * 0.2
>>> pts = np.column_stack([g, np.zeros(len(g))])
>>> pts = np.vstack([pts, [[10.0, 10.0, 5.0]]])          # one lone point
>>> keep = radius_outlier(pts, radius=0.5, min_neighbors=3)
>>> bool(keep[:-1].all()), bool(keep[-1])
(True, False)
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .errors import ParameterError
from .io import check_points

__all__ = ["radius_outlier", "statistical_outlier", "FilterReport"]


@dataclass(frozen=True)
class FilterReport:
    """How many points a filter saw and removed, with its parameters."""

    name: str
    n_in: int
    n_removed: int
    parameters: dict[str, float]

    def to_dict(self) -> dict[str, object]:
        return {"name": self.name, "n_in": self.n_in, "n_removed": self.n_removed,
                "parameters": self.parameters}


def _positive(name: str, value: float) -> None:
    if not (value > 0 and math.isfinite(value)):
        raise ParameterError(f"{name}: {value} must be a positive number")


def radius_outlier(points: np.ndarray, *, radius: float = 0.5, min_neighbors: int = 3,
                   workers: int = -1) -> np.ndarray:
    """The reef paper's radius filter: a point is noise if it has ``<= n`` neighbours within ``r``.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
    radius : float
        Search radius r (m); default 0.5.
    min_neighbors : int
        A point with ``min_neighbors`` or fewer other points within ``radius`` is noise
        (the paper's n); default 3.
    workers : int
        Threads for the KD-tree queries (-1 = all cores).

    Returns
    -------
    keep : ndarray of bool, shape (N,)

    Notes
    -----
    Points in a voxel of side ``r / sqrt(3)`` are all within ``r`` of each other, so a
    voxel holding more than ``n + 1`` points keeps them all without a search; the others
    ask the KD-tree only for their ``n + 1`` nearest neighbours within ``r`` (not for all of
    them), which is the same test and much cheaper.
    """
    pts = check_points(points, minimum=0)
    _positive("radius", radius)
    if min_neighbors < 0:
        raise ParameterError(f"min_neighbors: {min_neighbors} must be >= 0")
    n = len(pts)
    if n == 0:
        return np.zeros(0, dtype=bool)
    inv = math.sqrt(3.0) / radius  # voxels of side r / sqrt(3)
    lo = [float(pts[:, a].min()) for a in range(3)]
    ijk = [((pts[:, a] - lo[a]) * inv).astype(np.int64) for a in range(3)]  # >= 0: truncation floors
    dims = [int(c.max()) + 1 for c in ijk]
    key = (ijk[0] * dims[1] + ijk[1]) * dims[2] + ijk[2]
    del ijk
    size = dims[0] * dims[1] * dims[2]
    if size <= max(8 * n, 1 << 20):  # a dense voxel grid: counting is one bincount, no sort
        keep = np.bincount(key, minlength=size)[key] > min_neighbors + 1
    else:
        _, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
        keep = counts[inverse] > min_neighbors + 1
    todo = np.flatnonzero(~keep)
    if len(todo):
        keep[todo] = _has_neighbours(pts, todo, radius, min_neighbors + 1, workers)
    return keep


def _has_neighbours(pts: np.ndarray, todo: np.ndarray, radius: float, k: int, workers: int
                    ) -> np.ndarray:
    """Whether each point ``pts[todo]`` has at least ``k`` other points within ``radius``.

    The doubtful points are cut into strips along x, one per worker; each strip builds a
    KD-tree on the points within ``radius`` of it and runs in its own thread (the tree
    build and queries release the GIL).
    """
    n_workers = (os.cpu_count() or 1) if workers < 1 else workers
    strips = n_workers if len(pts) >= 200_000 else 1

    def strip(rows: np.ndarray, cand: np.ndarray | None) -> np.ndarray:
        base = pts if cand is None else pts[cand]
        # an unbalanced tree builds twice as fast and answers these short queries as well
        tree = cKDTree(base, balanced_tree=False, compact_nodes=False)
        d, _ = tree.query(pts[rows], k=k + 1, distance_upper_bound=radius,
                          workers=1 if strips > 1 else workers)
        return np.isfinite(d[:, -1]) if d.ndim == 2 else np.isfinite(d)

    if strips == 1:
        return strip(todo, None)
    x = pts[:, 0]
    edges = np.quantile(x[todo], np.linspace(0.0, 1.0, strips + 1))
    edges[-1] = np.inf
    jobs = []
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        sel = (x[todo] >= a) & (x[todo] < b)
        jobs.append((todo[sel], np.flatnonzero((x >= a - radius) & (x <= b + radius)), sel))
    out = np.zeros(len(todo), dtype=bool)
    with ThreadPoolExecutor(strips) as pool:
        for (_, _, sel), res in zip(jobs, pool.map(lambda j: strip(j[0], j[1]), jobs), strict=True):
            out[sel] = res
    return out


def statistical_outlier(points: np.ndarray, *, k: int = 8, std_ratio: float = 2.5,
                        workers: int = -1) -> np.ndarray:
    """Keep points whose mean distance to their ``k`` nearest neighbours is not unusual.

    A point is noise when its mean k-NN distance exceeds the global mean by more than
    ``std_ratio`` standard deviations (as PCL's and Open3D's statistical filters do).

    Returns
    -------
    keep : ndarray of bool, shape (N,)
    """
    pts = check_points(points, minimum=0)
    if k < 1:
        raise ParameterError(f"k: {k} must be >= 1")
    _positive("std_ratio", std_ratio)
    if len(pts) <= k:
        return np.ones(len(pts), dtype=bool)
    d, _ = cKDTree(pts).query(pts, k=k + 1, workers=workers)
    mean_d = d[:, 1:].mean(axis=1)
    return mean_d <= mean_d.mean() + std_ratio * mean_d.std()
