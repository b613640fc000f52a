"""Soundings far from the rest of a survey (a navigation jump, a stray ping), found on the
occupied cells of a coarse plan grid so that memory follows the soundings, not their extent;
and groups of occupied cells.
"""

from __future__ import annotations

import numpy as np

from .grid import cell_key, unpack_cells

__all__ = ["stray_soundings", "stray_cells", "cell_groups", "duplicate_soundings", "deep_outliers",
           "STRAY_SHARE", "STRAY_OF_LARGEST"]


#: Share of the soundings a spatially separate group may hold and still be set aside as
#: stray, and its most against the largest group (thirty patches of a survey, each 3 % of
#: its soundings, are its data, not thirty navigation jumps).
STRAY_SHARE = 0.05
STRAY_OF_LARGEST = 0.1


def stray_soundings(points: np.ndarray, *, cell: float = 25.0, gap_cells: int = 4,
                    share: float = STRAY_SHARE) -> np.ndarray:
    """Soundings far from the rest of the survey: a navigation jump, a stray ping.

    The soundings are binned into ``cell`` m plan cells (only the occupied ones are kept,
    so memory follows the soundings, not their extent); occupied cells within
    ``gap_cells`` cells of each other form one group. Groups holding under ``share`` of
    the soundings and under :data:`STRAY_OF_LARGEST` of the largest group are stray.

    Parameters
    ----------
    points : ndarray, shape (N, 2 or 3)
    cell : float
        Cell size (m).
    gap_cells : int
        Groups closer than this many cells are one.
    share : float
        Largest share of the soundings a stray group may hold.

    Returns
    -------
    ndarray of bool, shape (N,)
        True for stray soundings.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> survey = rng.uniform(0, 100, (2000, 2))
    >>> jump = survey[:5] + 5000.0                    # one ping's soundings 5 km away
    >>> stray_soundings(np.vstack([survey, jump])).nonzero()[0].tolist()
    [2000, 2001, 2002, 2003, 2004]
    """
    xy = np.asarray(points, np.float64)[:, :2]
    if len(xy) == 0:
        return np.zeros(0, dtype=bool)
    # cells counted from (0, 0), not from the soundings' corner: a tile of a survey sees the
    # same cells as the whole survey; a chunk at a time, so that 10 M soundings cost no more
    # than their own arrays (one pass over all of them took 0.5 GB)
    spans = range(0, len(xy), STRAY_CHUNK)
    parts = [np.unique(cell_key(xy[s:s + STRAY_CHUNK], cell), return_counts=True) for s in spans]
    keys, inverse = np.unique(np.concatenate([k for k, _ in parts]), return_inverse=True)
    counts = np.bincount(inverse.ravel(), weights=np.concatenate([c for _, c in parts])).astype(np.int64)
    bad = keys[stray_cells(unpack_cells(keys), counts, gap_cells=gap_cells, share=share)]
    out = np.zeros(len(xy), dtype=bool)
    if len(bad):
        for s in spans:
            out[s:s + STRAY_CHUNK] = np.isin(cell_key(xy[s:s + STRAY_CHUNK], cell), bad)
    return out


#: Soundings :func:`stray_soundings` bins at a time.
STRAY_CHUNK = 1_000_000


def stray_cells(cells: np.ndarray, counts: np.ndarray, *, gap_cells: int = 4,
                share: float = STRAY_SHARE) -> np.ndarray:
    """Which occupied cells hold stray soundings (see :func:`stray_soundings`).

    Parameters
    ----------
    cells : ndarray of int, shape (M, 2)
        The occupied cells (column, row), each once.
    counts : ndarray of int, shape (M,)
        Soundings in each.
    gap_cells, share
        As :func:`stray_soundings`.

    Returns
    -------
    ndarray of bool, shape (M,)

    Examples
    --------
    >>> stray_cells(np.array([[0, 0], [1, 0], [200, 0]]), np.array([500, 500, 3])).tolist()
    [False, False, True]
    """
    if len(cells) <= 1:
        return np.zeros(len(cells), dtype=bool)
    n, group = cell_groups(cells, gap_cells)
    if n == 1:
        return np.zeros(len(cells), dtype=bool)
    size = np.bincount(group, weights=counts, minlength=n)
    stray_group = (size < share * float(np.sum(counts))) & (size < STRAY_OF_LARGEST * size.max())
    return stray_group[group]


def cell_groups(cells: np.ndarray, gap_cells: int) -> tuple[int, np.ndarray]:
    """Occupied cells within ``gap_cells`` cells of each other (centre to centre, plus half
    a cell), chained, as groups: their number and each cell's group (0, 1, ...).

    Examples
    --------
    >>> n, group = cell_groups(np.array([[0, 0], [3, 0], [20, 0]]), 4)
    >>> n, group.tolist()
    (2, [0, 0, 1])
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    if len(cells) <= 1:
        return len(cells), np.zeros(len(cells), dtype=np.int64)
    pairs = cKDTree(np.asarray(cells, np.float64)).query_pairs(gap_cells + 0.5, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(cells), len(cells)))
    n, group = connected_components(graph, directed=False)
    return int(n), group.astype(np.int64)


def duplicate_soundings(points: np.ndarray) -> np.ndarray:
    """Soundings that are exact copies of an earlier one (x, y and z to the bit): a file
    given twice, an export written twice. Counted twice, they would change a reef count and
    shrink every 1σ by √2.

    Parameters
    ----------
    points : ndarray, shape (N, 3)

    Returns
    -------
    ndarray of bool, shape (N,)
        True for every copy after the first.

    Examples
    --------
    >>> p = np.array([[1.0, 2.0, -3.0], [1.0, 2.0, -3.5], [1.0, 2.0, -3.0], [4.0, 2.0, -3.0]])
    >>> duplicate_soundings(p).tolist()
    [False, False, True, False]
    """
    pts = np.asarray(points, np.float64)
    out = np.zeros(len(pts), dtype=bool)
    if len(pts) < 2:
        return out
    # a 64-bit hash of each row's bits: only rows whose hashes meet can be copies; those
    # few are then compared exactly
    bits = np.ascontiguousarray(pts).view(np.uint64)
    mix = np.array([0x9E3779B97F4A7C15, 0xC2B2AE3D27D4EB4F, 0x165667B19E3779F9], dtype=np.uint64)
    h = bits[:, 0] * mix[0] ^ bits[:, 1] * mix[1] ^ bits[:, 2] * mix[2]
    ranked = np.sort(h)  # half an argsort's time: most surveys have no copy, and stop here
    if not (ranked[1:] == ranked[:-1]).any():
        return out
    # only the rows whose hash is shared (a sorted lookup, not a second sort of them all)
    shared = np.unique(ranked[1:][ranked[1:] == ranked[:-1]])
    rows = np.flatnonzero(shared[np.searchsorted(shared, h).clip(max=len(shared) - 1)] == h)
    order = rows[np.lexsort((rows, pts[rows, 2], pts[rows, 1], pts[rows, 0]))]
    same = (pts[order[1:]] == pts[order[:-1]]).all(axis=1)
    out[order[1:][same]] = True
    return out


def deep_outliers(z: np.ndarray) -> np.ndarray:
    """Soundings far deeper than any seabed of the survey: a corrupt record, a multiple, a
    range gate gone wrong (nothing stands hundreds of metres under a 10 m seabed).

    Deeper than the 1st percentile of the elevations by more than the largest of 10 m, half
    the median depth and three times the spread between the 1st and 99th percentiles. Objects
    stand above the seabed, so nothing above it is judged here.

    Examples
    --------
    >>> z = np.r_[np.full(999, -10.0), -650.0]
    >>> deep_outliers(z).nonzero()[0].tolist()
    [999]
    """
    z = np.asarray(z, np.float64)
    if len(z) < 100:
        return np.zeros(len(z), dtype=bool)
    low, mid, high = np.percentile(z, [1, 50, 99])
    return z < low - max(10.0, 0.5 * abs(float(mid)), 3.0 * float(high - low))
