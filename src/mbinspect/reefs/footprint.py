"""Stage 5a: the plan footprint of the reef points: a fine raster whose cells take the
label of their nearest sounding, kept out of acoustic shadows, gaps between pings bridged."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from ..grid import cell_index, grow

__all__ = ["Raster", "nearest_label_raster", "label_parts"]


@dataclass(frozen=True, eq=False)
class Raster:
    x0: float
    y0: float
    cell: float
    labels: np.ndarray  # (ny, nx) int: 0 background, 1..K parts
    nearest: np.ndarray  # (ny, nx) int: index of the nearest sounding (-1 none)


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
    lo = rp.min(axis=0) - reach
    hi = rp.max(axis=0) + reach
    nx = int(math.ceil((hi[0] - lo[0]) / cell))
    ny = int(math.ceil((hi[1] - lo[1]) / cell))
    # only cells within ``reach`` of a reef point are candidates
    occ = np.zeros((ny, nx), dtype=bool)
    ij = np.floor((rp - lo) / cell).astype(np.int64)
    occ[np.clip(ij[:, 1], 0, ny - 1), np.clip(ij[:, 0], 0, nx - 1)] = True
    r = max(1, int(math.ceil(reach / cell)))
    occ = grow(occ, r)
    cj, ci = np.nonzero(occ)
    centres = np.column_stack([lo[0] + (ci + 0.5) * cell, lo[1] + (cj + 0.5) * cell])
    # the soundings that can be nearest to a candidate cell lie within ``reach`` of one
    wide = grow(occ, r + 1)
    pi, pj = cell_index(points, lo[0], lo[1], cell)
    idx = np.flatnonzero((pi >= 0) & (pi < nx) & (pj >= 0) & (pj < ny))
    idx = idx[wide[pj[idx], pi[idx]]]
    tree = cKDTree(points[idx, :2] - lo, balanced_tree=False, compact_nodes=False)
    # own and bridge are in units of the soundings' typical spacing here (median distance
    # to the nearest other sounding, from a seeded sample)
    sample = idx[np.random.default_rng(seed).permutation(len(idx))[:20_000]]
    dn, _ = tree.query(points[sample, :2] - lo, k=2)
    spacing = float(np.median(dn[:, 1])) if len(sample) > 1 else cell
    own, bridge = own * spacing, bridge * spacing
    d, k = tree.query(centres - lo, k=1, distance_upper_bound=reach, workers=-1)
    nearest = np.full((ny, nx), -1, dtype=np.int64)
    ok = np.isfinite(d)
    nearest[cj[ok], ci[ok]] = idx[k[ok]]
    reef = np.zeros((ny, nx), dtype=bool)
    reef[cj[ok], ci[ok]] = is_reef[idx[k[ok]]]
    # acoustic shadows behind a reef hold no seabed sounding, so "nearest is a reef point"
    # alone would spread the reef into its shadow: a reef cell must also lie within
    # ``own`` m of a reef sounding; enclosed gaps between pings are filled back
    close = np.zeros((ny, nx), dtype=bool)
    close[cj[ok], ci[ok]] = d[ok] <= own
    if height is not None and wall > 0:
        # a sounding on a reef's side wall marks the edge itself: of the cells nearest to
        # it, only those on the reef's side of it (up the height gradient) are reef
        hmax = np.zeros((ny, nx))
        ri = np.flatnonzero(is_reef)
        ri_i, ri_j = cell_index(points[ri], lo[0], lo[1], cell)
        np.maximum.at(hmax, (np.clip(ri_j, 0, ny - 1), np.clip(ri_i, 0, nx - 1)), height[ri])
        w = max(1, int(round(0.4 / cell)))
        local = ndimage.maximum_filter(hmax, size=2 * w + 1)
        smooth = ndimage.gaussian_filter(hmax, 2.0)
        gy, gx = np.gradient(smooth)
        rows = np.flatnonzero(ok)
        src = idx[k[rows]]
        si, sj = cell_index(points[src], lo[0], lo[1], cell)
        si, sj = np.clip(si, 0, nx - 1), np.clip(sj, 0, ny - 1)
        on_wall = is_reef[src] & (height[src] < wall * local[sj, si])
        g = np.column_stack([gx[sj, si], gy[sj, si]])
        inward = ((centres[rows] - points[src, :2]) * g).sum(axis=1) >= 0
        close[cj[rows[on_wall]], ci[rows[on_wall]]] = inward[on_wall]
    core = reef & close
    # bridge the gaps between pings inside a reef; closing does not grow outer edges
    rc = max(1, int(round(bridge / cell)))
    yy, xx = np.mgrid[-rc:rc + 1, -rc:rc + 1]
    disk = xx * xx + yy * yy <= rc * rc
    closed = ndimage.binary_closing(np.pad(core, rc + 1), structure=disk)[rc + 1:-rc - 1, rc + 1:-rc - 1]
    filled = ndimage.binary_fill_holes(closed & reef) & reef
    return filled, nearest, float(lo[0]), float(lo[1])


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
    flat = lab.ravel()
    order = np.argsort(flat, kind="stable")
    bounds = np.searchsorted(flat[order], np.arange(1, k + 2))
    return [order[bounds[i]:bounds[i + 1]] for i in range(k)], (ny, nx)
