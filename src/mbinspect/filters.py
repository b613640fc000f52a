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
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .checks import check_points
from .errors import ParameterError
from .grid import near_rows

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
    Points in a voxel of ``0.65 r x 0.65 r x 0.4 r`` (diagonal under r) are all within
    ``r`` of each other, so a point whose voxel holds more than ``n + 1`` points, in either
    of two grids offset by half a voxel, is kept without a search (on a dense survey, all
    but a few per cent). Only the others ask a KD-tree, built on the soundings in the plan
    cells around them, for their ``n + 1`` nearest neighbours within ``r`` (not for all of
    them), which is the same test and much cheaper.
    """
    pts = check_points(points, minimum=0)
    _positive("radius", radius)
    if min_neighbors < 0:
        raise ParameterError(f"min_neighbors: {min_neighbors} must be >= 0")
    n = len(pts)
    if n == 0:
        return np.zeros(0, dtype=bool)
    b = 0.4 * radius
    a = math.sqrt((radius * radius - b * b) / 2.0) * (1.0 - 1e-9)  # 2a^2 + b^2 < r^2
    lo = [float(pts[:, k].min()) for k in range(3)]
    keep = np.zeros(n, dtype=bool)
    for shift in (0.0, 0.5):
        keep |= _voxel_count(pts, lo, (a, a, b), shift) > min_neighbors + 1
    todo = np.flatnonzero(~keep)
    if len(todo) == 0:
        return keep
    # the neighbours of a doubtful point lie in the 3 x 3 plan cells of side r around it
    cand = near_rows(pts, todo, radius)
    # an unbalanced tree builds twice as fast and answers these short queries as well
    tree = cKDTree(pts[cand], balanced_tree=False, compact_nodes=False)
    d, _ = tree.query(pts[todo], k=min_neighbors + 2, distance_upper_bound=radius, workers=workers)
    keep[todo] = np.isfinite(d[:, -1]) if d.ndim == 2 else np.isfinite(d)
    return keep


def _voxel_count(pts: np.ndarray, lo: list[float], size: tuple[float, float, float], shift: float
                 ) -> np.ndarray:
    """Number of points in each point's voxel (grid offset by ``shift`` voxels).

    Points outside the 0.1-99.9 % z range (water-column noise, tall structures) are given
    count 0, so that the grid stays small and dense; the caller tests them exactly.
    """
    idx = [((pts[:, k] - lo[k]) / size[k] + shift).astype(np.int64) for k in range(3)]  # >= 0
    z_lo, z_hi = np.quantile(idx[2], [0.001, 0.999]).astype(np.int64)
    inside = (idx[2] >= z_lo) & (idx[2] <= z_hi)
    dims = [int(idx[0].max()) + 1, int(idx[1].max()) + 1, int(z_hi - z_lo) + 1]
    key = (idx[0] * dims[1] + idx[1]) * dims[2] + np.clip(idx[2] - z_lo, 0, dims[2] - 1)
    del idx
    total = dims[0] * dims[1] * dims[2]
    if total <= max(8 * len(pts), 1 << 20):  # dense: one bincount, no sort
        counts = np.bincount(key[inside], minlength=total)[key]
    else:
        _, inverse, c = np.unique(key[inside], return_inverse=True, return_counts=True)
        counts = np.zeros(len(pts), dtype=np.int64)
        counts[inside] = c[inverse]
    counts[~inside] = 0
    return counts


def statistical_outlier(points: np.ndarray, *, k: int = 8, std_ratio: float = 2.5,
                        workers: int = -1) -> np.ndarray:
    """Keep points whose mean distance to their ``k`` nearest neighbours is not unusual.

    A point is noise when its mean k-NN distance exceeds the global mean by more than
    ``std_ratio`` standard deviations (as PCL's and Open3D's statistical filters do).

    Parameters
    ----------
    points : ndarray, shape (N, 3)
    k : int
        Neighbours.
    std_ratio : float
        Standard deviations above the mean that make noise.
    workers : int
        Threads of the neighbour search.

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
    d, _ = cKDTree(pts, balanced_tree=False, compact_nodes=False).query(pts, k=k + 1, workers=workers)
    mean_d = d[:, 1:].mean(axis=1)
    return mean_d <= mean_d.mean() + std_ratio * mean_d.std()
