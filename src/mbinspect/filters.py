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
from .neighbours import Cells, count_within

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
                   cells: Cells | None = None) -> np.ndarray:
    """The reef paper's radius filter: a point is noise if it has ``<= n`` neighbours within ``r``.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
    radius : float
        Search radius r (m); default 0.5.
    min_neighbors : int
        A point with ``min_neighbors`` or fewer other points within ``radius`` is noise
        (the paper's n); default 3.
    cells : Cells, optional
        An index of these very points (:class:`mbinspect.neighbours.Cells`, cells of any
        side), when the caller has one.

    Returns
    -------
    keep : ndarray of bool, shape (N,)

    Notes
    -----
    Each point counts the others within ``r`` in the plan cells of side ``r`` around it
    (:mod:`mbinspect.neighbours`), its own cell first, and stops at ``n + 1``: on a dense
    survey most points stop within their own cell. Distances are exact (a KD-tree's).
    """
    pts = check_points(points, minimum=0)
    _positive("radius", radius)
    if min_neighbors < 0:
        raise ParameterError(f"min_neighbors: {min_neighbors} must be >= 0")
    keep = np.zeros(len(pts), dtype=bool)
    if len(pts) == 0:
        return keep
    if cells is None:
        cells = Cells.build(pts, radius)
    # itself, and more than n others
    keep[cells.order] = count_within(cells, cells.xyz, radius, min_neighbors + 2) >= min_neighbors + 2
    return keep


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
