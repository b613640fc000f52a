"""Stage 5a: the plan footprint of the reef points: a fine raster whose cells take the
label of their nearest sounding, kept out of acoustic shadows, gaps between pings bridged."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy import ndimage

from ..grid import bounds, cell_index, fill_holes, grow
from ..neighbours import Cells, kth_distance, nearest_within

__all__ = ["Raster", "nearest_label_raster", "label_parts", "TIE"]

#: Distances (m) this close to a threshold, or to each other, are equal: millimetre
#: coordinates put soundings exactly on a threshold, where rounding in one frame or
#: another (a tile's, the whole survey's) would decide otherwise.
TIE = 1e-9


@dataclass(frozen=True, eq=False)
class Raster:
    x0: float
    y0: float
    cell: float
    labels: np.ndarray  # (ny, nx) int: 0 background, 1..K parts
    nearest: np.ndarray  # (ny, nx) int: index of the nearest sounding (-1 none)
    bloom: np.ndarray | None = None  # (ny, nx) bool: cells a beam's bloom was taken off (told the beam)

    def centres(self, cells: np.ndarray) -> np.ndarray:
        """The plan centres (M, 2) of flat cell indices ``cells`` (m)."""
        cj, ci = np.divmod(np.asarray(cells), self.labels.shape[1])
        return np.column_stack([self.x0 + (ci + 0.5) * self.cell, self.y0 + (cj + 0.5) * self.cell])

    def window(self, cj: np.ndarray, ci: np.ndarray, margin: int) -> tuple[slice, slice]:
        """The rows and columns of the bounding box of cells (cj, ci) widened by ``margin``
        cells, within the raster."""
        ny, nx = self.labels.shape
        return (slice(max(int(cj.min()) - margin, 0), min(int(cj.max()) + margin + 1, ny)),
                slice(max(int(ci.min()) - margin, 0), min(int(ci.max()) + margin + 1, nx)))

    def in_bloom(self, points: np.ndarray) -> np.ndarray:
        """Whether each of ``points`` stands in a cell the bloom was taken off (all False
        when no bloom was, or outside the raster)."""
        out = np.zeros(len(points), bool)
        if self.bloom is None:
            return out
        ny, nx = self.bloom.shape
        ci, cj = cell_index(points, self.x0, self.y0, self.cell)
        ok = (ci >= 0) & (ci < nx) & (cj >= 0) & (cj < ny)
        out[ok] = self.bloom[cj[ok], ci[ok]]
        return out


def nearest_label_raster(points: np.ndarray, is_reef: np.ndarray, *, cell: float, reach: float,
                         own: float, bridge: float, height: np.ndarray | None = None,
                         wall: float = 0.0, seed: int = 0) -> tuple[np.ndarray, np.ndarray, float, float]:
    """The footprint raster: cells near reef points, each labelled by its nearest sounding.

    See :func:`~mbinspect.reefs.split_reefs` for what each rule is for.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        Soundings (m).
    is_reef : ndarray of bool, shape (N,)
        The reef soundings.
    cell : float
        Raster cell (m).
    reach : float
        Only cells within this distance (m) of a reef sounding are labelled.
    own, bridge : float
        In sounding spacings: a reef cell lies within ``own`` of a reef sounding; gaps
        inside a reef are closed over ``bridge``.
    height : ndarray (N,), optional
        Heights above the seabed, for side-wall soundings.
    wall : float
        A reef sounding below ``wall`` times the highest reef sounding within 0.4 m is on a
        side wall (0: no wall rule).
    seed : int
        Seed of the sample on which the typical sounding spacing is measured.

    Returns
    -------
    reef : ndarray of bool, shape (ny, nx)
        The footprint raster.
    nearest : ndarray of int, shape (ny, nx)
        Index of each cell's nearest sounding (-1: none within ``reach``).
    x0, y0 : float
        The raster's corner (m).

    Examples
    --------
    >>> g = np.arange(0.0, 10.0, 0.25)
    >>> xy = np.column_stack([np.repeat(g, len(g)), np.tile(g, len(g))])
    >>> z = np.where((np.abs(xy[:, 0] - 5) < 1) & (np.abs(xy[:, 1] - 5) < 1), -16.0, -17.0)
    >>> pts = np.column_stack([xy, z])
    >>> reef, nearest, x0, y0 = nearest_label_raster(pts, z > -16.5, cell=0.1, reach=0.6, own=1.5,
    ...                                              bridge=3.5)
    >>> # 7 x 7 reef soundings 0.25 m apart: a 1.75 m square halfway to the seabed soundings
    >>> bool(abs(float(reef.sum()) * 0.01 - 1.75**2) < 0.2)
    True
    """
    rp = points[is_reef, :2]
    # whole cells from (0, 0), as in any tile, and room for the whole ring of soundings
    # around the candidates (``wide``): a raster that cut it would see fewer of them
    pad = 2 * reach + 3 * cell
    rlo, rhi = bounds(rp)
    lo = np.floor((rlo - pad) / cell) * cell
    hi = rhi + pad
    nx = int(math.ceil((hi[0] - lo[0]) / cell))
    ny = int(math.ceil((hi[1] - lo[1]) / cell))
    # only cells within ``reach`` of a reef point are candidates
    occ = np.zeros((ny, nx), dtype=bool)
    oi, oj = cell_index(rp, lo[0], lo[1], cell)
    occ[np.clip(oj, 0, ny - 1), np.clip(oi, 0, nx - 1)] = True
    r = max(1, int(math.ceil(reach / cell)))
    occ = grow(occ, r)
    cj, ci = np.nonzero(occ)
    centres = np.column_stack([lo[0] + (ci + 0.5) * cell, lo[1] + (cj + 0.5) * cell])
    # the soundings that can be nearest to a candidate cell lie within ``reach`` of one
    wide = grow(occ, r + 1)
    idx = np.concatenate([s + _in_cells(points[s:s + CHUNK], wide, lo, cell)
                          for s in range(0, len(points), CHUNK)])
    # cells holding a few soundings each: the nearest one is a ring or two away
    density = len(idx) / max(float(wide.sum()) * cell * cell, 1e-12)
    pxy = points[idx, :2]
    near = Cells.build(pxy - lo, min(max(math.sqrt(3.0 / density), cell), reach))
    # own and bridge are in units of the soundings' typical spacing (median distance to the
    # nearest other sounding), measured around each connected candidate region on its own:
    # a region's answer does not depend on what else the cloud (or the tile) holds
    comp, n_comp = ndimage.label(occ, structure=np.ones((3, 3), bool))
    spacing = _region_spacing(pxy, near, comp, n_comp, lo, cell)
    own_c, bridge_c = own * spacing, bridge * spacing
    # each cell's nearest sounding; among soundings equally near (to TIE: millimetre
    # coordinates make such ties, and several soundings share a plan position) the first
    # in the cloud, so that the answer depends on neither the search nor the frame
    d, k = nearest_within(near, centres - lo, reach + TIE, TIE)
    nearest = np.full((ny, nx), -1, dtype=np.int64)
    ok = np.isfinite(d)
    nearest[cj[ok], ci[ok]] = idx[k[ok]]
    reef = np.zeros((ny, nx), dtype=bool)
    reef[cj[ok], ci[ok]] = is_reef[idx[k[ok]]]
    # acoustic shadows behind a reef hold no seabed sounding, so "nearest is a reef point"
    # alone would spread the reef into its shadow: a reef cell must also lie within
    # ``own`` m of a reef sounding; enclosed gaps between pings are filled back
    close = np.zeros((ny, nx), dtype=bool)
    close[cj[ok], ci[ok]] = d[ok] <= own_c[comp[cj[ok], ci[ok]]] + TIE
    if height is not None and wall > 0:
        rows = np.flatnonzero(ok)
        _wall_rule(points, is_reef, height, wall, _Cells(cj, ci, centres, rows, idx[k[rows]]),
                   _Raster(lo, cell, comp, r), close)
    closed = _bridged(reef & close, comp, bridge_c, cell)
    filled = fill_holes(closed & reef) & reef
    return filled, nearest, float(lo[0]), float(lo[1])


def _bridged(core: np.ndarray, comp: np.ndarray, bridge: np.ndarray, cell: float) -> np.ndarray:
    """The gaps between pings inside each candidate region closed over its ``bridge`` (m);
    closing does not grow outer edges."""
    closed = np.zeros_like(core)
    disks: dict[int, np.ndarray] = {}
    for c, box in enumerate(ndimage.find_objects(comp), start=1):
        if box is None:
            continue
        mine = comp[box] == c
        sub = core[box] & mine
        if not sub.any():  # nothing to close
            continue
        rc = max(1, int(round(bridge[c] / cell)))
        if rc not in disks:
            yy, xx = np.mgrid[-rc:rc + 1, -rc:rc + 1]
            disks[rc] = xx * xx + yy * yy <= rc * rc
        done = ndimage.binary_closing(np.pad(sub, rc + 1), structure=disks[rc])
        closed[box] |= done[rc + 1:-rc - 1, rc + 1:-rc - 1] & mine
    return closed


#: Soundings whose raster cells are found at a time (all of 10 M at once took 0.5 GB).
CHUNK = 1_000_000


def _in_cells(points: np.ndarray, mask: np.ndarray, lo: np.ndarray, cell: float) -> np.ndarray:
    """The rows of ``points`` that fall in a True cell of ``mask`` (rows y, columns x, corner
    ``lo``)."""
    ny, nx = mask.shape
    pi, pj = cell_index(points, lo[0], lo[1], cell)
    idx = np.flatnonzero((pi >= 0) & (pi < nx) & (pj >= 0) & (pj < ny))
    return idx[mask[pj[idx], pi[idx]]]


class _Cells(NamedTuple):
    """The candidate cells (rows ``cj``, columns ``ci``, ``centres`` in m) and, for those
    with a sounding within reach (``rows`` of them), that nearest sounding (``src``)."""

    cj: np.ndarray
    ci: np.ndarray
    centres: np.ndarray
    rows: np.ndarray
    src: np.ndarray


class _Raster(NamedTuple):
    """The footprint raster: its corner ``lo`` (m), ``cell`` (m), the candidate regions'
    labels ``comp`` and the reach in cells ``r``."""

    lo: np.ndarray
    cell: float
    comp: np.ndarray
    r: int


def _wall_rule(points: np.ndarray, is_reef: np.ndarray, height: np.ndarray, wall: float, cells: _Cells,
               raster: _Raster, close: np.ndarray) -> None:
    """A sounding on a reef's side wall marks the edge itself: of the cells nearest to it,
    only those on the reef's side of it (up the height gradient) are reef (``close`` is
    set in place).

    The highest reef sounding per cell, its local maximum and its smoothed gradient are
    computed in a window around each candidate region, padded beyond what the filters
    reach and cut at the raster's edge as the raster itself is: the same values as over
    the whole raster, in memory that follows the reefs, not the tile."""
    lo, cell, comp, r = raster
    cj, ci, centres, rows, src = cells
    ny, nx = comp.shape
    ri = np.flatnonzero(is_reef)
    ri_i, ri_j = cell_index(points[ri], lo[0], lo[1], cell)
    ri_i, ri_j = np.clip(ri_i, 0, nx - 1), np.clip(ri_j, 0, ny - 1)
    w = max(1, int(round(0.4 / cell)))
    si, sj = cell_index(points[src], lo[0], lo[1], cell)
    si, sj = np.clip(si, 0, nx - 1), np.clip(sj, 0, ny - 1)
    label = comp[cj[rows], ci[rows]]
    order = np.argsort(label, kind="stable")
    bounds = np.searchsorted(label[order], np.arange(comp.max() + 2))
    # the Gaussian's truncation (4 sigma = 8 cells), one cell of gradient, the maximum's
    # half-width, and the reach from a candidate cell to its nearest sounding
    pad = r + 2 + 8 + 1 + w
    by_row = np.argsort(ri_j, kind="stable")  # the reef soundings of a window's rows: a slice
    row_start = np.searchsorted(ri_j[by_row], np.arange(ny + 1))
    for c, box in enumerate(ndimage.find_objects(comp), start=1):
        if box is None or bounds[c + 1] == bounds[c]:
            continue
        mine = order[bounds[c]:bounds[c + 1]]
        y0, y1 = max(0, box[0].start - pad), min(ny, box[0].stop + pad)
        x0, x1 = max(0, box[1].start - pad), min(nx, box[1].stop + pad)
        inside = by_row[row_start[y0]:row_start[y1]]
        inside = inside[(ri_i[inside] >= x0) & (ri_i[inside] < x1)]
        hmax = np.zeros((y1 - y0, x1 - x0))
        np.maximum.at(hmax, (ri_j[inside] - y0, ri_i[inside] - x0), height[ri[inside]])
        s_src, a, b = src[mine], sj[mine] - y0, si[mine] - x0
        on_wall = is_reef[s_src]
        on_wall[on_wall] = height[s_src[on_wall]] < wall * _window_max(hmax, a[on_wall], b[on_wall], w)
        if not on_wall.any():
            continue
        s_src, a, b, hit = s_src[on_wall], a[on_wall], b[on_wall], rows[mine][on_wall]
        # the smoothed gradient over the wall cells and the Gaussian's reach (8 cells) and one
        # more around them, no farther: the same values as over the whole window
        wy0, wx0 = max(0, int(a.min()) - 10), max(0, int(b.min()) - 10)
        gy, gx = np.gradient(ndimage.gaussian_filter(hmax[wy0:a.max() + 11, wx0:b.max() + 11], 2.0))
        g = np.column_stack([gx[a - wy0, b - wx0], gy[a - wy0, b - wx0]])
        # on the reef's side: the cell centre's offset along the gradient, to TIE (a centre
        # square to the gradient from its sounding is on the edge in any frame)
        inward = ((centres[hit] - points[s_src, :2]) * g).sum(axis=1) >= -TIE * np.hypot(*g.T)
        close[cj[hit], ci[hit]] = inward


def _window_max(grid: np.ndarray, a: np.ndarray, b: np.ndarray, w: int) -> np.ndarray:
    """The largest value of ``grid`` within ``w`` cells of each cell (``a``, ``b``), the window
    cut at the grid's edge: ``scipy.ndimage.maximum_filter(grid, 2 * w + 1)`` at those cells
    alone (its mirrored edge adds no new value to a maximum)."""
    if len(a) == 0:
        return np.zeros(0)
    ny, nx = grid.shape
    off = np.arange(-w, w + 1)
    rows = np.clip(a[:, None] + off, 0, ny - 1)[:, :, None]
    cols = np.clip(b[:, None] + off, 0, nx - 1)[:, None, :]
    return grid[rows, cols].reshape(len(a), -1).max(axis=1)


#: Side (m) of the plan blocks over which the sounding spacing around reef candidates is
#: counted, and how many blocks each way a candidate region looks (5 to 10 m).
SPACING_BLOCK = 5.0
SPACING_REACH = 1
#: Millimetre bins of that count (spacings beyond 1 m count as 1 m).
SPACING_BINS = 1000


def _region_spacing(xy: np.ndarray, near: Cells, comp: np.ndarray, n: int, lo: np.ndarray, cell: float
                    ) -> np.ndarray:
    """The median distance to the nearest other sounding, over the soundings near reef
    points (``xy``, indexed by ``near`` less ``lo``) within :data:`SPACING_REACH` blocks of
    :data:`SPACING_BLOCK` m of each candidate region (index 1..n of ``comp``; 0 gets
    ``cell``), to the millimetre. (:data:`SPACING_REACH` blocks: up to 10 m.)

    Blocks lie on a lattice from (0, 0) and distances are counted in millimetre bins with a
    summed-area table, so that a region's spacing is exact, deterministic and the same in
    any tile of a survey whose buffer holds its neighbourhood."""
    out = np.full(n + 1, cell)
    if len(xy) < 2 or n == 0:
        return out
    # the blocks the soundings span (cell_index is monotonic: the corners' blocks bound them all)
    (bi0, bi1), (bj0, bj1) = (v.tolist() for v in cell_index(np.array(bounds(xy)), 0.0, 0.0, SPACING_BLOCK))
    nbx, nby = bi1 - bi0 + 1, bj1 - bj0 + 1
    hist = np.zeros((nbx + 1) * (nby + 1) * SPACING_BINS, np.int64)
    for s in range(0, len(xy), CHUNK):  # near every sounding of a noisy 10 M field: 0.5 GB at once
        # in the index's order (its memory in turn): the counts do not depend on it
        part = near.order[s:s + CHUNK]
        dn = kth_distance(near, near.xyz[s:s + CHUNK], 2)
        mm = np.minimum(np.round(dn * 1000.0).astype(np.int64), SPACING_BINS - 1)
        bi, bj = cell_index(xy[part], 0.0, 0.0, SPACING_BLOCK)
        flat = ((bi - bi0 + 1) * (nby + 1) + (bj - bj0 + 1)) * SPACING_BINS + mm
        hist += np.bincount(flat, minlength=len(hist))
    hist = hist.astype(np.int32).reshape(nbx + 1, nby + 1, SPACING_BINS)
    table = hist.cumsum(axis=0, dtype=np.int32).cumsum(axis=1, dtype=np.int32)
    ny, nx = comp.shape
    cj, ci = np.nonzero(comp)
    labels = comp[cj, ci]
    cx = lo[0] + (np.bincount(labels, ci, n + 1)[1:] / np.maximum(np.bincount(labels, None, n + 1)[1:], 1)
                  + 0.5) * cell
    cy = lo[1] + (np.bincount(labels, cj, n + 1)[1:] / np.maximum(np.bincount(labels, None, n + 1)[1:], 1)
                  + 0.5) * cell
    gi, gj = cell_index(np.column_stack([cx, cy]), 0.0, 0.0, SPACING_BLOCK)
    a0 = np.clip(gi - bi0 - SPACING_REACH, 0, nbx)
    a1 = np.clip(gi - bi0 + SPACING_REACH + 1, 0, nbx)
    b0 = np.clip(gj - bj0 - SPACING_REACH, 0, nby)
    b1 = np.clip(gj - bj0 + SPACING_REACH + 1, 0, nby)
    # a few hundred regions at a time: the (regions, bins) counts of a noisy 10 M field's
    # thousands of specks took 0.3 GB at once
    for s in range(0, n, 256):
        t = slice(s, s + 256)
        counts = table[a1[t], b1[t]] - table[a0[t], b1[t]] - table[a1[t], b0[t]] + table[a0[t], b0[t]]
        total = counts.sum(axis=1)
        half = np.argmax(counts.cumsum(axis=1) >= (total[:, None] + 1) // 2, axis=1)
        ok = total >= 2
        out[1:][t][ok] = half[ok] / 1000.0
    return out


def label_parts(reef_mask: np.ndarray, *, cell: float, link: float
                ) -> tuple[list[np.ndarray], tuple[int, int]]:
    """The connected parts of a footprint raster, parts closer than ``2 * link`` m joined.

    The thin walls of a hollow reef break up between pings, so parts that near are one
    candidate; each part's cells stay its own undilated cells.

    Parameters
    ----------
    reef_mask : ndarray of bool, shape (ny, nx)
        The footprint raster.
    cell : float
        Raster cell (m).
    link : float
        Half the gap (m) across which parts are joined.

    Returns
    -------
    parts : list of ndarray
        Flat cell indices of each part, in label order.
    shape : (ny, nx)

    Examples
    --------
    >>> m = np.zeros((5, 14), bool); m[1:4, 1:4] = True; m[1:4, 5:8] = True; m[1:4, 11:13] = True
    >>> parts, _ = label_parts(m, cell=0.1, link=0.1)
    >>> [len(p) for p in parts]
    [18, 6]
    """
    rl = max(1, int(round(link / cell)))
    yy, xx = np.mgrid[-rl:rl + 1, -rl:rl + 1]
    joined = ndimage.binary_dilation(reef_mask, structure=xx * xx + yy * yy <= rl * rl)
    lab, k = ndimage.label(joined, structure=np.ones((3, 3), bool))
    lab = np.where(reef_mask, lab, 0)
    ny, nx = lab.shape
    cells = np.flatnonzero(lab)  # the reef cells, in raster order within each part
    order = cells[np.argsort(lab.ravel()[cells], kind="stable")]
    bounds = np.searchsorted(lab.ravel()[order], np.arange(1, k + 2))
    return [order[bounds[i]:bounds[i + 1]] for i in range(k)], (ny, nx)
