"""Plan cells and the values in them, in compiled loops: each sounding's cell in one pass
(:func:`floor_cells`), values sorted by cell then by value with a counting sort
(:func:`sort_in_cells`), and per-cell percentiles over runs of those sorted values
(:func:`segment_percentile`), with no mask of them made.

Why compiled (numba): NumPy makes six arrays of N to find the cells and sorts all the
soundings as one array to group them; these take one pass each (``benchmarks/RESULTS.md``).

Examples
--------
>>> starts, v = sort_in_cells(np.array([2, 0, 2, 2]), np.array([7, 5, 3, 9]))
>>> starts.tolist(), v.tolist()
([0, 1, 1, 4], [5, 3, 7, 9])
>>> segment_percentile(starts, v.astype(float), 50.0).tolist()
[5.0, nan, 7.0]
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["floor_cells", "sort_in_cells", "segment_percentile", "DENSE_CELLS_PER_POINT"]

#: A dense table of cell starts is used while the grid has at most this many cells per
#: sounding (beyond it, the occupied cells are sorted or searched otherwise).
DENSE_CELLS_PER_POINT = 4


def floor_cells(points: np.ndarray, x0: float, y0: float, inv: float, edge: float = 0.0,
                offset: tuple[int, int] = (0, 0)) -> tuple[np.ndarray, np.ndarray]:
    """``floor((x - x0) * inv + edge) - offset[0]`` and likewise for y, as int64, in one
    pass (NumPy makes six arrays of N for it): the plan cells of
    :func:`mbinspect.grid.cell_index`."""
    p = np.asarray(points)
    if p.dtype != np.float64:
        p = p.astype(np.float64)
    i = np.empty(len(p), np.int64)
    j = np.empty(len(p), np.int64)
    if len(p):
        _floor_cells(p, float(x0), float(y0), float(inv), float(edge), int(offset[0]), int(offset[1]), i, j)
    return i, j


@numba.njit(cache=True, nogil=True)
def _floor_cells(p, x0, y0, inv, edge, ox, oy, i, j):
    for r in range(len(p)):
        i[r] = math.floor((p[r, 0] - x0) * inv + edge) - ox
        j[r] = math.floor((p[r, 1] - y0) * inv + edge) - oy


def sort_in_cells(key: np.ndarray, value: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Integer ``value`` sorted by cell ``key`` (0 or more), then by value: each cell's
    first row (``starts``, one more than the cells) and the sorted values. A counting sort
    by cell and a small sort within each, several times faster than sorting them packed
    into one integer. None when the cells outnumber the values
    :data:`DENSE_CELLS_PER_POINT` times (the caller sorts them itself)."""
    n_cells = int(key.max()) + 1 if len(key) else 0
    if n_cells > DENSE_CELLS_PER_POINT * len(key) + (1 << 16):
        return None
    return _sort_in_cells(np.ascontiguousarray(key, np.int64), np.ascontiguousarray(value, np.int64), n_cells)


def segment_percentile(starts: np.ndarray, values: np.ndarray, q: float, ref: np.ndarray | None = None,
                       below: float = math.inf, band: float = math.nan) -> np.ndarray:
    """The ``q`` percentile of each cell's sorted ``values`` (``starts``: each cell's first
    row), the value ``floor(q / 100 * (n - 1))`` places up; NaN where a cell has none.

    Only values at least ``ref[c] - below`` count, or with ``band``, only those within
    ``band`` of ``ref[c]`` (``abs(v - ref) <= band``): a run of the sorted values either
    way, so no mask of them is made.
    """
    n = len(starts) - 1
    r = np.zeros(n) if ref is None else np.ascontiguousarray(ref, np.float64).ravel()
    return _segment_percentile(starts, np.ascontiguousarray(values, np.float64), float(q), r, float(below),
                               float(band))


@numba.njit(cache=True, nogil=True)
def _segment_percentile(starts, values, q, ref, below, band):
    out = np.full(len(starts) - 1, np.nan)
    use_band = not math.isnan(band)
    for c in range(len(starts) - 1):
        first, count = -1, 0
        for t in range(starts[c], starts[c + 1]):
            v = values[t]
            ok = abs(v - ref[c]) <= band if use_band else v >= ref[c] - below
            if ok:
                if first < 0:
                    first = t
                count += 1
        if count:
            out[c] = values[first + math.floor(q / 100.0 * (count - 1))]
    return out


@numba.njit(cache=True, nogil=True)
def _sort_in_cells(key, value, n_cells):
    starts = np.zeros(n_cells + 1, np.int64)
    for k in key:
        starts[k + 1] += 1
    for c in range(n_cells):
        starts[c + 1] += starts[c]
    fill = starts[:-1].copy()
    vs = np.empty(len(key), np.int64)
    for row in range(len(key)):
        p = fill[key[row]]
        fill[key[row]] += 1
        vs[p] = value[row]
    for c in range(n_cells):
        a, b = starts[c], starts[c + 1]
        if b - a > 32:
            vs[a:b] = np.sort(vs[a:b])
        else:  # a few values: sorted in place
            for t in range(a + 1, b):
                v = vs[t]
                u = t
                while u > a and vs[u - 1] > v:
                    vs[u] = vs[u - 1]
                    u -= 1
                vs[u] = v
    return starts, vs
