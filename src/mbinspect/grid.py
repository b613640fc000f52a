"""Plan-grid helpers shared by the stages: cell indices, per-cell percentiles, coverage.

A plan grid has square cells of ``cell`` m whose corner ``(x0, y0)`` is the grid's origin;
cell ``(i, j)`` spans ``x0 + i * cell .. x0 + (i + 1) * cell`` east and likewise north.
"""

from __future__ import annotations

import os

import numpy as np
from scipy import ndimage

from .cellsort import floor_cells, segment_percentile, sort_in_cells

__all__ = ["cell_index", "cell_segments", "cell_percentile", "grow", "fill_holes",
           "coverage", "sounding_spacing", "BYTES_PER_CELL", "extent_bytes", "pack_cells", "unpack_cells",
           "cell_key", "machine_memory", "patched_spacing", "PATCHED", "corner_cell_keys", "bounds"]


#: Cells by which a sounding on a cell edge is counted into the cell above it.
EDGE = 1e-6


def bounds(points: np.ndarray, dims: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """The lowest and highest of each of the first ``dims`` coordinates, column by column
    (a reduction over axis 0 of an (N, 3) array is ten times slower).

    Examples
    --------
    >>> lo, hi = bounds(np.array([[1.0, 5.0, 0.0], [3.0, 2.0, 9.0]]))
    >>> lo.tolist(), hi.tolist()
    ([1.0, 2.0], [3.0, 5.0])
    """
    p = np.asarray(points)
    return (np.array([p[:, k].min() for k in range(dims)], dtype=p.dtype),
            np.array([p[:, k].max() for k in range(dims)], dtype=p.dtype))


def cell_index(points: np.ndarray, x0: float, y0: float, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """Plan grid cell ``(i, j)`` of each point, for cells of ``cell`` m from ``(x0, y0)``.

    In one compiled pass (:func:`mbinspect.cellsort.floor_cells`).

    Parameters
    ----------
    points : ndarray, shape (N, 2 or more)
        Plan coordinates in the first two columns (m).
    x0, y0 : float
        The grid's corner (m).
    cell : float
        Cell size (m).

    Returns
    -------
    i, j : ndarray of int, shape (N,)
        Column (east) and row (north) of each point; negative or past the grid outside it.

    Examples
    --------
    >>> i, j = cell_index(np.array([[0.5, 2.5, 0.0], [-0.5, 0.0, 0.0]]), 0.0, 0.0, 1.0)
    >>> i.tolist(), j.tolist()
    ([0, -1], [2, 0])
    """
    inv = 1.0 / cell
    ox, oy = x0 * inv, y0 * inv
    if abs(ox - round(ox)) < 1e-6 and abs(oy - round(oy)) < 1e-6:
        # a corner on the lattice of whole cells from (0, 0): count from there, so that a
        # sounding on a cell edge (millimetre coordinates on a 0.1 m grid) falls in the same
        # cell whichever lattice corner a grid (of a tile, of the whole survey) starts from
        # (a millionth of a cell up: a sounding on an edge goes to the cell above it whatever
        # the rounding of x / cell, so that moving the survey by whole cells moves it too)
        return floor_cells(points, 0.0, 0.0, inv, EDGE, (int(round(ox)), int(round(oy))))
    return floor_cells(points, x0, y0, inv)


def cell_segments(key: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The elevations sorted by cell, then by z, to the millimetre, and each cell's first
    row (``starts``, cells ``0 .. key.max()`` and one more): cell ``c`` holds
    ``z[starts[c]:starts[c + 1]]``.

    A counting sort by cell, then each cell's few values sorted (much faster than an
    argsort); cells far more than soundings: packed into one integer and sorted by value.
    """
    # from a whole kilometre: the same millimetres (and the same halves rounded) in any
    # subset of the soundings, such as a tile of a survey
    if len(z) == 0:
        return np.zeros(1, np.int64), np.zeros(0)
    z0 = 1000.0 * float(np.floor(z.min() / 1000.0))
    zq = np.round((z - z0) * 1000.0).astype(np.int64)
    done = sort_in_cells(key, zq)
    if done is not None:
        starts, zq = done
    else:
        span = int(zq.max()) + 1
        ks, zq = np.divmod(np.sort(key * span + zq), span)
        starts = np.searchsorted(ks, np.arange(int(ks[-1]) + 2))
    return starts, z0 + zq / 1000.0


def cell_percentile(key: np.ndarray, z: np.ndarray, q: float, size: int) -> np.ndarray:
    """Per-cell ``q`` percentile of z (cells numbered 0..size-1); NaN where a cell is empty.

    Parameters
    ----------
    key : ndarray of int, shape (N,)
        Cell number of each sounding.
    z : ndarray, shape (N,)
        Elevations (m).
    q : float
        Percentile, 0 to 100.
    size : int
        Number of cells.

    Returns
    -------
    ndarray, shape (size,)

    Examples
    --------
    >>> cell_percentile(np.array([0, 0, 0, 2]), np.array([-3.0, -1.0, -2.0, -5.0]), 50.0, 3).tolist()
    [-2.0, nan, -5.0]
    """
    if len(key) == 0:
        return np.full(size, np.nan)
    starts, zs = cell_segments(key, z)
    return segment_percentile(np.pad(starts, (0, size + 1 - len(starts)), mode="edge"), zs, q)


def grow(mask: np.ndarray, r: int) -> np.ndarray:
    """Dilation by a (2r+1)-cell square, as two 1-D passes.

    Parameters
    ----------
    mask : ndarray of bool, shape (ny, nx)
    r : int
        Cells added on every side.

    Returns
    -------
    ndarray of bool, shape (ny, nx)

    Examples
    --------
    >>> m = np.zeros((5, 5), bool); m[2, 2] = True
    >>> int(grow(m, 1).sum())
    9
    """
    m = ndimage.maximum_filter1d(mask.view(np.uint8), 2 * r + 1, axis=0, mode="constant")
    return ndimage.maximum_filter1d(m, 2 * r + 1, axis=1, mode="constant").view(bool)


def fill_holes(mask: np.ndarray) -> np.ndarray:
    """``scipy.ndimage.binary_fill_holes`` with its default structure: the cells no
    4-connected path of empty cells links to the edge are set. One labelling of the empty
    cells, five times faster than SciPy's dilation from the edge on a sparse raster.

    Examples
    --------
    >>> m = np.zeros((5, 5), bool); m[1:4, 1:4] = True; m[2, 2] = False
    >>> int(fill_holes(m).sum()), bool((fill_holes(m) == ndimage.binary_fill_holes(m)).all())
    (9, True)
    """
    if mask.size == 0:
        return mask.copy()
    lab, n = ndimage.label(~mask)
    outside = np.zeros(n + 1, bool)
    outside[np.concatenate([lab[0], lab[-1], lab[:, 0], lab[:, -1]])] = True
    outside[0] = False  # the cells of ``mask`` themselves
    return ~outside[lab]


def coverage(points: np.ndarray, cell: float = 1.0) -> float:
    """Share of the 1 m cells of the points' bounding box that hold a sounding.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        Soundings (m).
    cell : float
        Cell size (m).

    Returns
    -------
    float
        0 to 1.

    Examples
    --------
    >>> coverage(np.array([[0.5, 0.5, 0.0], [2.5, 2.5, 0.0]]))
    0.2222222222222222
    """
    i, j = cell_index(points, float(points[:, 0].min()), float(points[:, 1].min()), cell)
    nx, ny = int(i.max()) + 1, int(j.max()) + 1
    key = i * ny + j
    if nx * ny <= 4 * len(key) + (1 << 16):  # a flag per cell: no sort
        flag = np.zeros(nx * ny, dtype=bool)
        flag[key] = True
        return float(np.count_nonzero(flag) / (float(nx) * float(ny)))
    # counted over the occupied cells only: memory follows the soundings, not their extent
    return float(len(np.unique(key)) / (float(nx) * float(ny)))


#: Peak bytes per cell of a seabed grid and the stages on it (its filters, the terrain's):
#: 2.44 GB for a 0.5 m grid of 30 M cells over a line 3 km across (benchmarks/RESULTS.md).
BYTES_PER_CELL = 80


def extent_bytes(points: np.ndarray, cell: float) -> float:
    """The memory (bytes) a seabed grid of ``cell`` m over the points' bounding box takes
    (:data:`BYTES_PER_CELL`): what follows the extent, not the soundings.

    Examples
    --------
    >>> round(extent_bytes(np.array([[0.0, 0.0, 0.0], [1000.0, 1000.0, 0.0]]), 0.5) / 1e9, 2)
    0.32
    """
    if not len(points):
        return 0.0
    lo, hi = bounds(points)
    span = (hi - lo) / cell + 1
    return float(span[0] * span[1] * BYTES_PER_CELL)


def pack_cells(i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Two cell indices as one int64 (each within ±2³⁰), ordered by ``i`` then ``j``.

    Examples
    --------
    >>> unpack_cells(pack_cells(np.array([-3, 2]), np.array([7, -1]))).tolist()
    [[-3, 7], [2, -1]]
    """
    return (np.asarray(i, np.int64) + (1 << 30)) * (1 << 31) + (np.asarray(j, np.int64) + (1 << 30))


def unpack_cells(key: np.ndarray) -> np.ndarray:
    """The (M, 2) cell indices of :func:`pack_cells` keys."""
    key = np.asarray(key, np.int64)
    return np.column_stack([key // (1 << 31) - (1 << 30), key % (1 << 31) - (1 << 30)])


def cell_key(xy: np.ndarray, cell: float) -> np.ndarray:
    """Each point's plan cell (from (0, 0)) as one :func:`pack_cells` key."""
    return pack_cells(np.floor(xy[:, 0] / cell), np.floor(xy[:, 1] / cell))


def sounding_spacing(points: np.ndarray, *, sample: int = 20_000, seed: int = 0, k: int = 1) -> float:
    """The typical plan distance between neighbouring soundings (m).

    The median distance from a seeded sample of soundings to their nearest other sounding,
    searched among all of them (a subsample's own neighbours would lie farther apart).

    Parameters
    ----------
    points : ndarray, shape (N, 2 or 3)
    sample : int
        Soundings measured.
    seed : int
    k : int
        Measure the distance to the k-th nearest other sounding (1: the nearest).

    Returns
    -------
    float
        NaN for fewer than ``k + 1`` soundings; 0 when most sit on top of each other.

    Examples
    --------
    >>> g = np.arange(0.0, 20.0, 0.5)
    >>> sounding_spacing(np.column_stack([np.repeat(g, 40), np.tile(g, 40)]))
    0.5
    """
    from scipy.spatial import cKDTree

    xy = np.asarray(points, np.float64)[:, :2]
    if len(xy) < k + 1:
        return float("nan")
    xy = xy - bounds(xy)[0]
    tree = cKDTree(xy, balanced_tree=False, compact_nodes=False)
    pick = xy if len(xy) <= sample else xy[np.random.default_rng(seed).choice(len(xy), sample, replace=False)]
    d, _ = tree.query(pick, k=k + 1, workers=-1)
    return float(np.median(d[:, k]))


def corner_cell_keys(xyz: np.ndarray, lo: np.ndarray, extent: np.ndarray, cell: float, pad: int = 0
                     ) -> tuple[np.ndarray, int]:
    """Each sounding's plan cell of ``cell`` metres from the corner ``lo`` (of an ``extent``)
    as one integer, and the cells per column (``pad`` empty cells around), with as few
    arrays of N made as can be (10 M soundings: two, where ``cell_index`` makes six)."""
    ny = int(extent[1] / cell) + 2 + 2 * pad
    keys = np.empty(len(xyz), np.int64)
    column = np.subtract(xyz[:, 0], lo[0])
    column *= 1.0 / cell
    np.floor(column, out=column)
    column += pad
    keys[:] = column
    keys *= ny
    np.subtract(xyz[:, 1], lo[1], out=column)
    column *= 1.0 / cell
    np.floor(column, out=column)
    column += pad
    keys += column.astype(np.int64)
    return keys, ny


#: Above this many soundings :func:`patched_spacing` measures in patches, not over all.
PATCHED = 1_000_000


def patched_spacing(points: np.ndarray, *, seed: int = 0, sample: int = 200_000) -> float:
    """:func:`sounding_spacing` for large surveys: the same median to the nearest other
    sounding, measured in 512 seeded patches of about 50 soundings.

    Up to :data:`PATCHED` soundings, :func:`sounding_spacing` (``sample`` of them among all).
    Above, each patch is searched with the eight around it, so a sounding's neighbour is found
    wherever it lies within a patch's width (a tree of all 10 M soundings took 2.8 s; this
    0.3 s); a spacing over half a patch's width falls back to the whole search.

    Examples
    --------
    >>> g = np.arange(0.0, 1200.0, 0.5)
    >>> grid = np.column_stack([np.repeat(g, 1000), np.tile(g[:1000], 2400)])
    >>> len(grid) > PATCHED, patched_spacing(grid)
    (True, 0.5)
    """
    from scipy.spatial import cKDTree

    xy = np.asarray(points)[:, :2]
    n = len(xy)
    if n <= PATCHED:
        return sounding_spacing(xy, sample=sample, seed=seed)
    lo, hi = bounds(xy)
    side = float(np.sqrt(max(hi[0] - lo[0], 1e-9) * max(hi[1] - lo[1], 1e-9) * 50 / n))
    keys, ny = corner_cell_keys(xy, lo, hi - lo, side, pad=1)
    chosen = keys[np.random.default_rng(seed).choice(n, 512, replace=False)]
    centres, times = np.unique(chosen, return_counts=True)
    steps = (np.arange(-1, 2)[:, None] * ny + np.arange(-1, 2)).ravel()
    wanted = np.zeros(int(keys.max()) + ny + 2, np.int8)  # a flag per patch: no sort of the keys
    wanted[(centres[:, None] + steps).ravel()] = 1
    wanted[centres] = 2
    flag = wanted[keys]
    near = np.flatnonzero(flag)
    inner = flag[near] == 2
    pts = xy[near] - lo
    d, _ = cKDTree(pts, balanced_tree=False, compact_nodes=False).query(pts[inner], k=2, workers=-1)
    # a patch is chosen as often as a sounding of it is: each weighs its times chosen, shared
    # among its soundings, so that the median is that of soundings drawn at random
    patch = np.searchsorted(centres, keys[near[inner]])
    weight = (times / np.bincount(patch, minlength=len(centres)).clip(1))[patch]
    order = np.argsort(d[:, 1])
    cum = np.cumsum(weight[order])
    spacing = float(d[order[np.searchsorted(cum, cum[-1] / 2)], 1])
    return spacing if spacing < side / 2 else sounding_spacing(xy, sample=sample, seed=seed)


def machine_memory() -> int:
    """The machine's physical memory in bytes."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):  # not POSIX: assume 8 GB
        return 8 << 30
