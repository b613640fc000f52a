"""The size of a single reef where a part lies (learnt from the parts around it) and the
diameter of a footprint's cells."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..geometry import convex_hull

__all__ = ["local_reef_area", "row_ends", "diameter", "AREA_RADIUS", "LEARN_PARTS"]


#: Fewest parts of at least ``min_area`` from which a single-reef area is learnt (fewer:
#: no part is split, unless ``reef_area`` is given).
LEARN_PARTS = 5

#: Single-reef areas are learnt from the parts within this many metres (a tiled survey reads
#: at least this far beyond each tile).
AREA_RADIUS = 22.0


def local_reef_area(parts: list[np.ndarray], areas: np.ndarray, nx: int, cell: float, overall: float,
                     radius: float = AREA_RADIUS, min_parts: int = 5, among: np.ndarray | None = None
                     ) -> np.ndarray:
    """Single-reef area near each part: the median area of the parts within ``radius`` m.

    A field may hold several kinds of reef in separate groups; a pair of small reefs that
    touch must be judged against its own kind. Only the parts flagged in ``among`` (all by
    default) count; fewer than ``min_parts`` of them around: the ``min_parts`` nearest;
    fewer than that in all: ``overall``.

    Parameters
    ----------
    parts : list of ndarray
        Each part's flat raster cells.
    areas : ndarray
        Their areas (m²).
    nx : int
        Raster columns.
    cell : float
        Cell size (m).
    overall : float
        The field's single-reef area (m²).
    radius : float
        Neighbourhood (m).
    min_parts : int
    among : ndarray of bool, optional

    Returns
    -------
    ndarray
        Single-reef area near each part (m²).
    """
    if not parts:
        return np.zeros(0)
    centres = np.array([[(p % nx).mean(), (p // nx).mean()] for p in parts]) * cell
    use = np.ones(len(parts), bool) if among is None else np.asarray(among, bool)
    if not use.any():
        return np.full(len(parts), overall)
    sel = np.flatnonzero(use)
    tree = cKDTree(centres[sel])
    near = tree.query_ball_point(centres, radius)
    out = np.full(len(parts), overall)
    for k, n in enumerate(near):
        if len(n) < min_parts and len(sel) >= min_parts:
            # fewer around: the nearest ``min_parts`` (not the whole cloud, so that a tile of
            # a survey learns what the whole survey learns)
            n = np.atleast_1d(tree.query(centres[k], k=min_parts)[1])
        if len(n) >= min_parts:
            out[k] = float(np.median(areas[sel[np.asarray(n, int)]]))
    return out


def row_ends(xy: np.ndarray) -> np.ndarray:
    """The first and last point of every row (equal y) of a point set: the same convex
    hull as all of them (every point lies between its row's ends), far fewer points.

    Parameters
    ----------
    xy : ndarray, shape (N, 2)

    Returns
    -------
    ndarray, shape (M, 2)

    Examples
    --------
    >>> row_ends(np.array([[0.0, 0], [1, 0], [2, 0], [0, 1]])).tolist()
    [[0.0, 0.0], [2.0, 0.0], [0.0, 1.0]]
    """
    order = np.lexsort((xy[:, 0], xy[:, 1]))
    y = xy[order, 1]
    new = y[1:] != y[:-1]
    return xy[order[np.r_[True, new] | np.r_[new, True]]]


def diameter(xy: np.ndarray) -> float:
    """Largest distance between two of the points (on their convex hull).

    Parameters
    ----------
    xy : ndarray, shape (N, 2)

    Returns
    -------
    float

    Examples
    --------
    >>> diameter(np.array([[0.0, 0], [3, 0], [3, 4], [1, 1]]))
    5.0
    """
    h = convex_hull(row_ends(xy))
    if len(h) < 2:
        return 0.0
    d = h[:, None, :] - h[None, :, :]
    return float(np.sqrt((d**2).sum(axis=2)).max())
