"""The seabed as a grid of cell medians, sampled between cells: what two surveys of one
place are registered on and differenced."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..grid import cell_index

__all__ = ["Grid", "median_grid", "line_levels", "ping_levels"]


@dataclass(frozen=True, eq=False)
class Grid:
    """Cell medians of elevation: cell ``(i, j)`` (row ``j`` north, column ``i`` east) has
    its lower-left corner at ``(x0 + i * cell, y0 + j * cell)``; ``z`` is NaN where fewer
    than the wanted soundings fell, ``n`` counts them."""

    x0: float
    y0: float
    cell: float
    z: np.ndarray
    n: np.ndarray

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        """Every cell's centre (x, y), each shaped like ``z``."""
        ny, nx = self.z.shape
        return np.meshgrid(self.x0 + (np.arange(nx) + 0.5) * self.cell,
                           self.y0 + (np.arange(ny) + 0.5) * self.cell)

    def sample(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Elevation and its gradient (dz/dx, dz/dy) at ``x, y``: each bilinear between the
        four nearest cell centres, the gradient from central differences of the cells (a
        cell's own difference to the next would be the slope half a cell away, and a fit
        led by it would settle half a cell off); NaN where a cell needed is empty or outside.

        Examples
        --------
        >>> g = Grid(0.0, 0.0, 1.0, np.arange(16.0).reshape(4, 4), np.ones((4, 4)))
        >>> [float(v[0]) for v in g.sample(np.array([2.0]), np.array([2.0]))]
        [7.5, 1.0, 4.0]
        """
        gy, gx = np.gradient(self.z, self.cell)
        gx[:, [0, -1]] = np.nan
        gy[[0, -1], :] = np.nan
        return tuple(self._bilinear(v, x, y) for v in (self.z, gx, gy))  # type: ignore[return-value]

    def _bilinear(self, grid: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        ny, nx = grid.shape
        u = (np.asarray(x) - self.x0) / self.cell - 0.5
        v = (np.asarray(y) - self.y0) / self.cell - 0.5
        i, j = np.floor(u).astype(np.intp), np.floor(v).astype(np.intp)
        ok = (i >= 0) & (j >= 0) & (i < nx - 1) & (j < ny - 1)
        i, j = np.where(ok, i, 0), np.where(ok, j, 0)
        fu, fv = u - i, v - j
        z = ((grid[j, i] * (1 - fu) + grid[j, i + 1] * fu) * (1 - fv)
             + (grid[j + 1, i] * (1 - fu) + grid[j + 1, i + 1] * fu) * fv)
        return np.where(ok, z, np.nan)


def median_grid(points: np.ndarray, x0: float, y0: float, shape: tuple[int, int], cell: float, *,
                min_count: int = 3) -> Grid:
    """The median elevation of the soundings in each cell of a grid.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
    x0, y0 : float
        The grid's lower-left corner (m).
    shape : (ny, nx)
    cell : float
        Cell side (m).
    min_count : int
        Fewer soundings leave a cell empty (NaN).

    Returns
    -------
    Grid

    Examples
    --------
    >>> pts = np.array([[0.5, 0.5, 1.0], [0.4, 0.6, 3.0], [0.6, 0.5, 2.0], [1.5, 0.5, 9.0]])
    >>> median_grid(pts, 0.0, 0.0, (1, 2), 1.0).z.tolist()
    [[2.0, nan]]
    """
    ny, nx = shape
    z = np.full(shape, np.nan)
    n = np.zeros(shape, np.int64)
    if not len(points):
        return Grid(x0, y0, cell, z, n)
    i, j = cell_index(points, x0, y0, cell)
    inside = (i >= 0) & (j >= 0) & (i < nx) & (j < ny)
    flat = (j[inside].astype(np.int64) * nx + i[inside])
    cells, med, count, order = _key_medians(np.asarray(points[inside, 2], np.float64), flat)
    flat = flat[order]
    keep = count >= min_count
    z.ravel()[cells[keep]] = med[keep]
    n.ravel()[cells] = count
    return Grid(x0, y0, cell, _centred(z, points[inside], flat, order, cell, x0, y0), n)


def _centred(z: np.ndarray, points: np.ndarray, flat: np.ndarray, order: np.ndarray, cell: float,
             x0: float, y0: float) -> np.ndarray:
    """Each median moved to its cell's centre along the seabed's slope: a cell's soundings
    seldom centre on it (pings cross it at their own places), and on a slope the median of
    another survey's soundings would differ by as much as their centroids do, a bias of the
    plan registration the noise does not show."""
    ny, nx = z.shape
    size = ny * nx
    xs, ys = points[order, 0], points[order, 1]
    count = np.bincount(flat, minlength=size)
    with np.errstate(invalid="ignore", divide="ignore"):
        cx = np.bincount(flat, xs, minlength=size) / count
        cy = np.bincount(flat, ys, minlength=size) / count
    ix, iy = np.meshgrid(x0 + (np.arange(nx) + 0.5) * cell, y0 + (np.arange(ny) + 0.5) * cell)
    ox, oy = cx.reshape(z.shape) - ix, cy.reshape(z.shape) - iy
    gy, gx = np.gradient(z, cell) if min(z.shape) > 1 else (np.zeros_like(z), np.zeros_like(z))
    shift = gx * ox + gy * oy
    return np.where(np.isfinite(shift), z - shift, z)


def line_levels(points: np.ndarray, line: np.ndarray, cell: float = 1.0, *, iterations: int = 12
                ) -> np.ndarray:
    """Each line's vertical offset from the others where they overlap (m, per sounding),
    their sounding-weighted mean zero: subtracted, a survey's lines meet without the steps
    a tide or draft error leaves at their edges, steps a plan registration would otherwise
    lock onto. Lines that overlap no other keep no offset.

    Each line's offset is the median, over the cells it shares with other lines, of its
    cell median less the other lines' levelled cell medians; solved over and over, each
    time half way (a full step swings two lines' offsets back and forth).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> xy = rng.uniform(0, 20, (4000, 2))
    >>> ln = np.where(xy[:, 0] < 8, 0, np.where(xy[:, 0] > 12, 1, rng.integers(0, 2, 4000)))
    >>> z = 0.1 * xy[:, 1] + np.where(ln == 1, 0.05, 0.0)
    >>> off = line_levels(np.column_stack([xy, z]), ln)
    >>> bool(abs(off[ln == 1][0] - off[ln == 0][0] - 0.05) < 0.005)
    True
    """
    pts = np.asarray(points, np.float64)
    lines, li = np.unique(np.asarray(line), return_inverse=True)
    nl = len(lines)
    if nl < 2:
        return np.zeros(len(pts))
    x0, y0 = float(pts[:, 0].min()), float(pts[:, 1].min())
    i, j = cell_index(pts, x0, y0, cell)
    key = (j.astype(np.int64) * (int(i.max()) + 1) + i) * nl + li
    keys, med, count, _ = _key_medians(pts[:, 2], key)
    ok = count >= 3
    keys, med = keys[ok], med[ok]
    c, ln = keys // nl, keys % nl
    cells, ci = np.unique(c, return_inverse=True)
    off = np.zeros(nl)
    for _ in range(iterations):
        lev = med - off[ln]
        total, n = np.bincount(ci, lev), np.bincount(ci)
        shared = n[ci] >= 2
        others = (total[ci] - lev) / np.maximum(n[ci] - 1, 1)
        dev = med - others
        new = np.zeros(nl)
        for m in range(nl):
            d = dev[shared & (ln == m)]
            new[m] = float(np.median(d)) if len(d) >= 5 else 0.0
        weight = np.bincount(li, minlength=nl).astype(np.float64)
        off = (off + new) / 2
        off -= float(np.sum(off * weight) / weight.sum())
    return off[li]


def ping_levels(points: np.ndarray, line: np.ndarray, ping: np.ndarray, cell: float = 1.0, *,
                min_soundings: int = 10) -> np.ndarray:
    """Each ping's vertical offset from the other pings of its line (m, per sounding): the
    median of its soundings' heights over their cell's median in that line. A heave or
    GNSS height error moves a whole ping, a stripe across the swath that a plan
    registration reads as seabed texture (the simulator's per-ping 2 cm moved a jacket's
    plan registration by 3-5 cm); subtracted, each line keeps its own level, which
    :func:`line_levels` sets. Pings of fewer than ``min_soundings`` soundings keep none.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> ping = np.repeat(np.arange(200), 50)
    >>> xy = np.column_stack([ping * 0.1, rng.uniform(0, 10, len(ping))])
    >>> heave = rng.normal(0, 0.02, 200)
    >>> z = 0.05 * np.sin(xy[:, 1]) + heave[ping]
    >>> off = ping_levels(np.column_stack([xy, z]), np.zeros(len(z)), ping)
    >>> bool(np.std(off[::50] - (heave - heave.mean())) < 0.006)
    True
    """
    pts = np.asarray(points, np.float64)
    lines, li = np.unique(np.asarray(line), return_inverse=True)
    i, j = cell_index(pts, float(pts[:, 0].min()), float(pts[:, 1].min()), cell)
    cell_key = (j.astype(np.int64) * (int(i.max()) + 1) + i) * len(lines) + li
    med, count = _group_medians(pts[:, 2], cell_key)
    resid = pts[:, 2] - med
    pg = np.asarray(ping).astype(np.int64)
    pg -= int(pg.min())
    _, pk = np.unique(li.astype(np.int64) * (int(pg.max()) + 1) + pg, return_inverse=True)
    use = count >= 3
    off_use, n_use = _group_medians(resid[use], pk[use])
    off = np.zeros(int(pk.max()) + 1)
    n = np.zeros(len(off), np.int64)
    off[pk[use]], n[pk[use]] = off_use, n_use
    off = np.where(n >= min_soundings, off, 0.0)
    return off[pk]


def _group_medians(values: np.ndarray, key: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each value's group median and group size, per value (groups by ``key``)."""
    _, med, count, order = _key_medians(values, key)
    group = np.repeat(np.arange(len(med)), count)
    out_med, out_n = np.empty(len(values)), np.empty(len(values), np.int64)
    out_med[order], out_n[order] = med[group], count[group]
    return out_med, out_n


def _key_medians(values: np.ndarray, key: np.ndarray) -> tuple[np.ndarray, ...]:
    """The distinct keys, each one's median of ``values`` (the mean of the two middle ones
    where they are even in number) and count, and the order that sorts by key then value."""
    order = np.lexsort((values, key))
    v = values[order]
    keys, start, count = np.unique(key[order], return_index=True, return_counts=True)
    med = (v[start + (count - 1) // 2] + v[start + count // 2]) / 2 if len(v) else np.zeros(0)
    return keys, med, count, order
