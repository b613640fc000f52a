"""Neighbours of soundings from square plan cells, searched in compiled loops.

One :class:`Cells` index (the soundings sorted into plan cells by a counting sort, their
coordinates copied in that order) answers the questions the stages ask of every sounding:
how many others lie within a radius (:func:`count_within`), how far the k-th nearest lies
(:func:`kth_distance`) and which is nearest (:func:`nearest_within`), in 3-D or in plan.
A search visits the rings of cells around a point until no farther cell can change its
answer, so the answers are exact and equal to a KD-tree's, to the bit: a distance is the
square root of the same sum of squares. Searches of many points are split among
:func:`threads`. (Sorting within cells is :mod:`mbinspect.cellsort`'s.)

Why compiled (numba): a KD-tree over a dense 3.7 M-sounding field takes 0.7 s to build
and the stages built several; the counting sort and the ring searches take a fraction of
that, and no NumPy or SciPy call searches cells ring by ring (``benchmarks/RESULTS.md``).

Examples
--------
>>> pts = np.array([[0.0, 0, 0], [0.3, 0, 0], [0.0, 0.4, 0], [5.0, 5.0, 0]])
>>> cells = Cells.build(pts, 0.5)
>>> count_within(cells, pts, np.full(4, 0.5), 10).tolist()  # itself included
[3, 2, 2, 1]
>>> kth_distance(cells, pts, 2).round(3).tolist()  # the nearest other
[0.3, 0.3, 0.4, 6.794]
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import numba
import numpy as np

from .cellsort import DENSE_CELLS_PER_POINT

__all__ = ["Cells", "count_within", "kth_distance", "nearest_within", "threads"]

@dataclass(frozen=True, eq=False)
class Cells:
    """Soundings sorted into square plan cells of ``side`` m from ``(x0, y0)``.

    ``order`` holds the rows of the soundings cell by cell, ``xyz`` their coordinates in
    that order; the soundings of cell key ``k`` (``j * nx + i``) are
    ``starts[p]:starts[p + 1]`` of them, ``p`` being ``k`` itself (``dense``) or the
    position of ``k`` in ``keys``.
    """

    side: float
    x0: float
    y0: float
    nx: int
    ny: int
    dense: bool
    keys: np.ndarray
    starts: np.ndarray
    order: np.ndarray
    xyz: np.ndarray

    @classmethod
    def build(cls, points: np.ndarray, side: float) -> Cells:
        """The index of ``points`` ((N, 2) or (N, 3), m) over cells of ``side`` m."""
        pts = np.ascontiguousarray(points, dtype=np.float64)
        if len(pts) == 0:
            empty = np.zeros(0, np.int64)
            return cls(side, 0.0, 0.0, 1, 1, True, empty, np.zeros(2, np.int64), empty, pts)
        x0, y0 = float(pts[:, 0].min()), float(pts[:, 1].min())
        nx = int((float(pts[:, 0].max()) - x0) / side) + 1
        ny = int((float(pts[:, 1].max()) - y0) / side) + 1
        if nx * ny <= DENSE_CELLS_PER_POINT * len(pts) + (1 << 16):
            starts, order, xyz = _counting_sort(pts, x0, y0, side, nx, ny)
            return cls(side, x0, y0, nx, ny, True, np.zeros(0, np.int64), starts, order, xyz)
        key = ((pts[:, 1] - y0) / side).astype(np.int64) * nx + ((pts[:, 0] - x0) / side).astype(np.int64)
        order = np.argsort(key, kind="stable")
        keys, first = np.unique(key[order], return_index=True)
        starts = np.append(first, len(pts)).astype(np.int64)
        xyz = np.column_stack([pts[:, c][order] for c in range(pts.shape[1])])
        return cls(side, x0, y0, nx, ny, False, keys, starts, order, xyz)

    def run(self, first: int, last: int) -> tuple[int, int]:
        """The sorted rows of the cells with keys ``first`` to ``last`` (one row of
        cells, from column ``first % nx`` to ``last % nx``), as ``(start, end)``."""
        if self.dense:
            return int(self.starts[first]), int(self.starts[last + 1])
        a, b = np.searchsorted(self.keys, [first, last + 1])
        return int(self.starts[a]), int(self.starts[b])

    def _args(self, plan: bool) -> tuple:
        dims = 2 if plan else self.xyz.shape[1]
        # the cells' edges are known to within the rounding of coordinates this large: a
        # search reaches this much farther, so that no tie at a bound is missed
        tol = 1e-12 * (abs(self.x0) + abs(self.y0) + (self.nx + self.ny) * self.side) + 1e-9 * self.side
        return (dims, self.xyz, self.starts, self.keys, self.dense, self.nx, self.ny, self.x0, self.y0,
                self.side, tol)


def count_within(cells: Cells, at: np.ndarray, radius: np.ndarray | float, cap: int, *, strict: bool = True,
                 plan: bool = False) -> np.ndarray:
    """How many soundings of ``cells`` (the point itself too, when it is one) lie within
    ``radius[q]`` m of each point ``at[q]``, counted up to ``cap``.

    ``strict``: distances under the radius (a KD-tree's ``distance_upper_bound``); else
    distances at most the radius. Distances are in plan with ``plan`` or when the index
    has two coordinates, else in 3-D. An infinite radius counts every sounding.
    """
    q = np.ascontiguousarray(at, dtype=np.float64)
    r = np.ascontiguousarray(np.broadcast_to(radius, (len(q),)), dtype=np.float64)
    if len(q) == 0 or len(cells.xyz) == 0:
        return np.zeros(len(q), np.int64)
    if _few(cells, q):
        dims = 2 if plan else cells.xyz.shape[1]
        with np.errstate(invalid="ignore"):
            return np.concatenate([np.minimum(np.count_nonzero(
                d2 < (r[a:b, None] ** 2) if strict else np.sqrt(d2) <= r[a:b, None], axis=1), int(cap))
                for a, b, d2 in _pair_distances(cells, q, dims)])
    args = cells._args(plan)
    return _split(lambda a, b: _count_within(q[a:b], r[a:b], int(cap), bool(strict), *args), len(q))


def kth_distance(cells: Cells, at: np.ndarray, k: int, *, plan: bool = False) -> np.ndarray:
    """The distance (m) from each point ``at[q]`` to its ``k``-th nearest sounding of
    ``cells`` (the point itself counts, at 0, when it is one), in plan with ``plan``;
    inf where fewer than ``k``."""
    q = np.ascontiguousarray(at, dtype=np.float64)
    if len(q) == 0 or len(cells.xyz) < k or k < 1:
        return np.full(len(q), math.inf)
    if _few(cells, q):
        dims = 2 if plan else cells.xyz.shape[1]
        return np.concatenate([np.sqrt(np.partition(d2, k - 1, axis=1)[:, k - 1])
                               for _, _, d2 in _pair_distances(cells, q, dims)])
    args = cells._args(plan)
    return _split(lambda a, b: _kth_distance(q[a:b], int(k), *args), len(q))


#: Pairs of points and soundings a search of a sparse index takes all at once: in a tile
#: of a deep survey, a few soundings tens of metres apart over cells sized for shallow
#: water, a ring search visits every empty cell between them.
FEW_PAIRS = 1 << 20


def _few(cells: Cells, q: np.ndarray) -> bool:
    """Whether every pair is cheaper than the rings: an index mostly of empty cells, few pairs."""
    return not cells.dense and len(q) * len(cells.xyz) <= FEW_PAIRS


def _pair_distances(cells: Cells, q: np.ndarray, dims: int) -> Iterator[tuple[int, int, np.ndarray]]:
    """``(a, b, d2)``: the squared distances (summed as the ring searches sum them) of the
    points ``a:b`` to every sounding, in blocks of queries."""
    step = max(1, (1 << 16) // max(len(cells.xyz), 1))
    for a in range(0, len(q), step):
        b = min(a + step, len(q))
        d2 = np.zeros((b - a, len(cells.xyz)))
        for c in range(dims):
            u = cells.xyz[None, :, c] - q[a:b, c, None]
            d2 += u * u
        yield a, b, d2


def nearest_within(cells: Cells, at: np.ndarray, reach: float, tie: float = 0.0, *, plan: bool = False
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Each point's nearest sounding of ``cells`` nearer than ``reach`` m: its distance (inf
    when none) and its row in the points the index was built on (-1 when none).

    Among soundings within ``tie`` m of the nearest distance, the first row: the answer
    depends on the soundings alone, not on how they are searched.
    """
    q = np.ascontiguousarray(at, dtype=np.float64)
    if len(q) == 0 or len(cells.xyz) == 0:
        return np.full(len(q), math.inf), np.full(len(q), -1, np.int64)
    args = cells._args(plan)
    return _split(lambda a, b: _nearest_within(q[a:b], float(reach), float(tie), cells.order, *args), len(q))


#: Fewest points a search splits among threads.
SPLIT_FROM = 50_000


def threads() -> int:
    """Threads a search runs on: the cores this process may use, or ``OMP_NUM_THREADS``
    when set (Dask's workers set it to their own thread count)."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        cores = os.cpu_count() or 1
    try:
        return max(1, min(cores, int(os.environ.get("OMP_NUM_THREADS", cores))))
    except ValueError:
        return cores


def _split(search: Callable[[int, int], Any], n: int) -> Any:
    """``search(a, b)`` over the points ``a:b``, the points split evenly among
    :func:`threads` (the compiled searches release the GIL); results joined in order."""
    parts = threads() if n >= SPLIT_FROM else 1
    if parts == 1:
        return search(0, n)
    edges = np.linspace(0, n, parts + 1).astype(int)
    with ThreadPoolExecutor(parts) as pool:
        done = list(pool.map(search, edges[:-1], edges[1:]))
    if isinstance(done[0], tuple):
        return tuple(np.concatenate(col) for col in zip(*done, strict=True))
    return np.concatenate(done)


@numba.njit(cache=True, nogil=True)
def _counting_sort(pts, x0, y0, side, nx, ny):
    """Cell starts (cells + 1), the rows in cell order (stable) and their coordinates."""
    n = len(pts)
    key = np.empty(n, np.int64)
    starts = np.zeros(nx * ny + 1, np.int64)
    for row in range(n):
        # the same cell as ``((x - x0) / side).astype(int)`` gives (all >= 0), the maxima
        # clipped into the last cell as rounding may put them one beyond
        i = min(int((pts[row, 0] - x0) / side), nx - 1)
        j = min(int((pts[row, 1] - y0) / side), ny - 1)
        key[row] = j * nx + i
        starts[key[row] + 1] += 1
    for c in range(nx * ny):
        starts[c + 1] += starts[c]
    fill = starts[:-1].copy()
    order = np.empty(n, np.int64)
    xyz = np.empty_like(pts)
    for row in range(n):
        p = fill[key[row]]
        fill[key[row]] += 1
        order[p] = row
        for c in range(pts.shape[1]):
            xyz[p, c] = pts[row, c]
    return starts, order, xyz


@numba.njit(cache=True, nogil=True, inline="always")
def _dist2(xyz, b, q, a, dims):
    """Squared distance of sorted sounding ``b`` from point ``a``, summed in a KD-tree's order."""
    d2 = 0.0
    for c in range(dims):
        u = xyz[b, c] - q[a, c]
        d2 += u * u
    return d2


@numba.njit(cache=True, nogil=True, inline="always")
def _span(key: int, starts: np.ndarray, keys: np.ndarray, dense: bool) -> tuple[int, int]:
    """The first and past-last sorted rows of cell ``key`` (empty when unoccupied)."""
    if dense:
        return starts[key], starts[key + 1]
    p = np.searchsorted(keys, key)
    if p < len(keys) and keys[p] == key:
        return starts[p], starts[p + 1]
    return 0, 0


@numba.njit(cache=True, nogil=True, inline="always")
def _count_cell(q, a, ra, r2, strict, s, e, xyz, dims, n, cap):
    """``n`` plus the soundings ``s:e`` within reach of point ``a``, stopping at ``cap``."""
    for b in range(s, e):
        d2 = _dist2(xyz, b, q, a, dims)
        if (d2 < r2) if strict else (math.sqrt(d2) <= ra):
            n += 1
            if n >= cap:
                break
    return n


@numba.njit(cache=True, nogil=True)
def _count_within(q, r, cap, strict, dims, xyz, starts, keys, dense, nx, ny, x0, y0, side, tol):
    out = np.zeros(len(q), np.int64)
    for a in range(len(q)):
        ra = r[a]
        ci = int(math.floor((q[a, 0] - x0) / side))
        cj = int(math.floor((q[a, 1] - y0) / side))
        reach = nx + ny if not math.isfinite(ra) else int(math.ceil((ra + tol) / side))
        r2 = ra * ra
        n = 0
        if 0 <= ci < nx and 0 <= cj < ny:  # its own cell first: most stop there
            s, e = _span(cj * nx + ci, starts, keys, dense)
            n = _count_cell(q, a, ra, r2, strict, s, e, xyz, dims, n, cap)
        i0, i1 = max(ci - reach, 0), min(ci + reach, nx - 1)
        j0, j1 = max(cj - reach, 0), min(cj + reach, ny - 1)
        for j in range(j0, j1 + 1):
            if n >= cap:
                break
            for i in range(i0, i1 + 1):
                if n >= cap:
                    break
                if i == ci and j == cj:
                    continue
                s, e = _span(j * nx + i, starts, keys, dense)
                n = _count_cell(q, a, ra, r2, strict, s, e, xyz, dims, n, cap)
        out[a] = n
    return out


@numba.njit(cache=True, nogil=True)
def _kth_distance(q, k, dims, xyz, starts, keys, dense, nx, ny, x0, y0, side, tol):
    out = np.full(len(q), np.inf)
    best = np.empty(k)
    spans = np.empty((8 * (nx + ny) + 1, 2), np.int64)  # the cells of any ring
    for a in range(len(q)):
        fx = (q[a, 0] - x0) / side
        fy = (q[a, 1] - y0) / side
        ci = int(math.floor(fx))
        cj = int(math.floor(fy))
        # the point's distance (in cells) to the edges of its own cell: the rings beyond
        # ring R lie at least R plus the least of these away
        edge = min(fx - ci, ci + 1 - fx, fy - cj, cj + 1 - fy)
        found = 0
        ring = 0
        while True:
            m = _ring_rows(ci, cj, ring, starts, keys, dense, nx, ny, spans)
            for t in range(m):
                for b in range(spans[t, 0], spans[t, 1]):
                    d2 = _dist2(xyz, b, q, a, dims)
                    if found < k:
                        found += 1
                        p = found - 1
                    elif d2 < best[k - 1]:
                        p = k - 1
                    else:
                        continue
                    while p > 0 and best[p - 1] > d2:  # insertion into the sorted k best
                        best[p] = best[p - 1]
                        p -= 1
                    best[p] = d2
            # every sounding beyond this ring lies farther than this in plan
            limit = (ring + max(edge, 0.0)) * side - tol
            if found == k and limit > 0 and best[k - 1] <= limit * limit:
                break
            if ci - ring <= 0 and cj - ring <= 0 and ci + ring >= nx - 1 and cj + ring >= ny - 1:
                break
            ring += 1
        if found == k:
            out[a] = math.sqrt(best[k - 1])
    return out


@numba.njit(cache=True, nogil=True)
def _ring_rows(ci, cj, ring, starts, keys, dense, nx, ny, out):
    """The sorted rows ``(start, end)`` of the occupied cells of ring ``ring`` around cell
    ``(ci, cj)``, written to ``out``; their number."""
    m = 0
    for j in range(cj - ring, cj + ring + 1):
        if j < 0 or j >= ny:
            continue
        step = 1 if (j == cj - ring or j == cj + ring) else 2 * ring
        i = ci - ring
        while i <= ci + ring:
            if 0 <= i < nx:
                s, e = _span(j * nx + i, starts, keys, dense)
                if e > s:
                    out[m, 0] = s
                    out[m, 1] = e
                    m += 1
            i += step
    return m


@numba.njit(cache=True, nogil=True)
def _nearest_within(q, reach, tie, order, dims, xyz, starts, keys, dense, nx, ny, x0, y0, side, tol):
    out_d = np.full(len(q), np.inf)
    out_row = np.full(len(q), -1, np.int64)
    last = int(math.ceil((reach + tie + tol) / side))  # rings beyond lie out of reach
    spans = np.empty((8 * (last + 1) + 1, 2), np.int64)
    for a in range(len(q)):
        fx = (q[a, 0] - x0) / side
        fy = (q[a, 1] - y0) / side
        ci = int(math.floor(fx))
        cj = int(math.floor(fy))
        edge = max(min(fx - ci, ci + 1 - fx, fy - cj, cj + 1 - fy), 0.0)
        best = np.inf
        ring = 0
        while ring <= last:
            m = _ring_rows(ci, cj, ring, starts, keys, dense, nx, ny, spans)
            for t in range(m):
                for b in range(spans[t, 0], spans[t, 1]):
                    d2 = _dist2(xyz, b, q, a, dims)
                    best = min(best, d2)
            # every sounding within ``tie`` of the nearest has been seen
            if best < np.inf and math.sqrt(best) + tie <= (ring + edge) * side - tol:
                break
            ring += 1
        dmin = math.sqrt(best)
        if not dmin < reach:
            continue
        row = -1
        for r in range(min(ring, last) + 1):
            m = _ring_rows(ci, cj, r, starts, keys, dense, nx, ny, spans)
            for t in range(m):
                for b in range(spans[t, 0], spans[t, 1]):
                    d2 = _dist2(xyz, b, q, a, dims)
                    d = math.sqrt(d2)
                    tied = d == dmin or d - dmin < tie
                    if d < reach and tied and (row < 0 or order[b] < row):
                        row = order[b]
        out_d[a] = dmin
        out_row[a] = row
    return out_d, out_row
