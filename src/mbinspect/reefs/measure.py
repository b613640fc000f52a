"""Stage 6: one reef measured from its raster cells and the soundings behind them."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ..geometry import convex_hull, min_area_rectangle
from ..noise import all_round, trimmed_lstsq
from ..seabed import GROUND_BAND
from .footprint import Raster
from .ground import Seabed
from .results import Reef
from .shape import weighted_percentile
from .split import row_ends

__all__ = ["measure_reef", "outline", "soundings_around", "own_soundings", "ring_seabed"]


def outline(cells_mask: np.ndarray, x0: float, y0: float, cell: float) -> np.ndarray:
    """The longest boundary of a cell mask as a polygon (K, 2) in map coordinates.

    Parameters
    ----------
    cells_mask : ndarray of bool, shape (ny, nx)
    x0, y0 : float
        Corner of the mask (m).
    cell : float
        Cell size (m).

    Returns
    -------
    ndarray, shape (K, 2)
    """
    import contourpy

    m = np.pad(cells_mask.astype(np.float64), 1)
    gen = contourpy.contour_generator(z=m, name="serial")
    lines = gen.lines(0.5)
    if not lines:
        return np.empty((0, 2))
    line = max(lines, key=lambda ln: len(ln))
    xy = (np.asarray(line) - 1.0 + 0.5) * cell
    return np.column_stack([x0 + xy[:, 0], y0 + xy[:, 1]])


def soundings_around(raster: Raster, cj: np.ndarray, ci: np.ndarray, margin: int) -> np.ndarray:
    """The soundings nearest to the raster cells in the bounding box of cells (cj, ci)
    widened by ``margin`` cells (indices, sorted).

    Parameters
    ----------
    raster : Raster
        The labelled footprint raster (:func:`split_reefs`).
    cj, ci : ndarray of int
        Rows and columns of the cells.
    margin : int

    Returns
    -------
    ndarray of int
    """
    idx = np.unique(raster.nearest[raster.window(cj, ci, margin)])
    return idx[idx >= 0]


def own_soundings(cells: np.ndarray, raster: Raster, is_reef: np.ndarray | None) -> np.ndarray:
    """The (reef, given ``is_reef``) soundings nearest to a reef's raster cells (indices, sorted).

    Parameters
    ----------
    cells : ndarray of int
        Flat raster cell indices.
    raster : Raster
        The labelled footprint raster (:func:`split_reefs`).
    is_reef : ndarray of bool, optional

    Returns
    -------
    ndarray of int
    """
    own = raster.nearest.ravel()[cells]
    own = np.unique(own[own >= 0])
    return own if is_reef is None else own[is_reef[own]]


def ring_seabed(points: np.ndarray, cj: np.ndarray, ci: np.ndarray, raster: Raster, seabed: Seabed,
                 is_reef: np.ndarray | None, x: float, y: float, margin: int = 6
                 ) -> Callable[[np.ndarray, np.ndarray], np.ndarray] | None:
    """The seabed under a reef from the ground soundings in a ring around it.

    A quadratic surface (it follows sand-wave curvature, which the grid's fill under a
    reef flattens) fitted by trimmed least squares to the non-reef soundings nearest to the
    raster cells within ``margin`` cells of the reef and within the ground band (0.3 m) of the seabed
    surface; None when the ring is too thin to hold one (then the grid is used).

    Parameters
    ----------
    points : ndarray, shape (N, 3)
    cj, ci : ndarray of int
        The reef's raster cells (rows, columns).
    raster : Raster
        The labelled footprint raster (:func:`split_reefs`).
    seabed : Seabed
    is_reef : ndarray of bool, optional
    x, y : float
        The reef's centre (m).
    margin : int
        Width of the ring (cells).

    Returns
    -------
    callable or None
        ``surface(x, y)`` -> elevation (m).
    """
    idx = soundings_around(raster, cj, ci, margin)
    if is_reef is not None:
        idx = idx[~is_reef[idx]]
    if len(idx) < 20:
        return None
    p = points[idx]
    p = p[np.abs(seabed.height_above(p)) <= GROUND_BAND]
    if len(p) < 20:
        return None
    u, v = p[:, 0] - x, p[:, 1] - y
    # the ring must surround the reef: soundings in at least 6 of 8 directions
    if not all_round(u, v):
        return None
    fit = trimmed_lstsq(np.column_stack([np.ones_like(u), u, v, u * u, u * v, v * v]), p[:, 2], 2)
    if fit is None:
        return None
    coef = fit

    def surface(qx: np.ndarray, qy: np.ndarray) -> np.ndarray:
        a, b = np.asarray(qx, np.float64) - x, np.asarray(qy, np.float64) - y
        return coef[0] + coef[1] * a + coef[2] * b + coef[3] * a * a + coef[4] * a * b + coef[5] * b * b

    return surface


def measure_reef(points: np.ndarray, cells: np.ndarray, raster: Raster, seabed: Seabed, *,
                 reef_id: int = 0, is_reef: np.ndarray | None = None, shape: bool = True,
                 sigma: np.ndarray | None = None) -> Reef:
    """Measure one reef from its raster cells and the soundings behind them.

    Centre: area centroid of the cells. Top: the median of the reef soundings within
    0.25 m below their 98th percentile (robust to noise). Height: top minus the seabed
    at the centre. The seabed under the reef is the mean of two estimates that fail in
    different ways: the seabed surface (whose fill under a reef flattens sand-wave
    curvature) and a quadratic fitted to the ground soundings in a ring around the reef
    (:func:`ring_seabed`, which bends when the ring is noisy); the surface alone where
    the ring is too thin. Over 10 seeds their mean kept the height error under 0.09 m
    both on sand waves and at double noise, where each alone reached 0.10 m. Area:
    cells x cell². Length, width, orientation: minimum-area rectangle. Volume: sum over
    cells of (nearest sounding's z - seabed) x cell².
    Envelope volume: length x width x height (the reef's "empty volume").

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        Soundings (m).
    cells : ndarray of int
        The reef's flat raster cell indices.
    raster : Raster
        The labelled footprint raster (:func:`split_reefs`).
    seabed : Seabed
    reef_id : int
    is_reef : ndarray of bool, optional
        The reef soundings (the top uses these only).
    shape : bool
        False leaves out the rectangle, the volumes and the outline (NaN, empty): what an
        object too small to be a reef is listed without.
    sigma : ndarray, shape (N,), optional
        Told the beam, each sounding's vertical 1σ: the seabed's noise with how far its
        cone may sound it high or low (:func:`~mbinspect.reefs.shape.cone_reach`). The
        top's percentile and median are then taken by inverse variance, so that outer
        beams sounding a flat top high (by up to twice that reach) do not lift it.

    Examples
    --------
    >>> from mbinspect.simulate import simulate
    >>> sim = simulate("reef-field", seed=1, groups="cross1", per_group=4, ping_spacing=0.8,
    ...                close_pairs=0, boulders=0, debris=0)
    >>> from mbinspect.reefs import fit_seabed, reef_points, split_reefs
    >>> seabed, _ = fit_seabed(sim.cloud.xyz)
    >>> is_reef, height = reef_points(sim.cloud.xyz, seabed)
    >>> parts, _, raster, _ = split_reefs(sim.cloud.xyz, is_reef, height=height)
    >>> reef = measure_reef(sim.cloud.xyz, parts[0], raster, seabed, is_reef=is_reef)
    >>> truth = min(sim.truth["reefs"], key=lambda t: (t["x"] - reef.x) ** 2 + (t["y"] - reef.y) ** 2)
    >>> bool(abs(reef.height - truth["height"]) < 0.1 and abs(reef.x - truth["x"]) < 0.3)
    True

    Returns
    -------
    Reef
    """
    ny, nx = raster.labels.shape
    cj, ci = np.divmod(cells, nx)
    c = raster.cell
    cx = raster.x0 + (ci + 0.5) * c
    cy = raster.y0 + (cj + 0.5) * c
    x, y = float(cx.mean()), float(cy.mean())
    near = raster.nearest.ravel()[cells]
    pidx = own_soundings(cells, raster, is_reef)
    z = points[pidx, 2] if len(pidx) else np.array([np.nan])
    if sigma is not None and len(pidx) >= 10 and np.isfinite(z).all():
        w = 1.0 / sigma[pidx] ** 2
        top = z >= weighted_percentile(z, w, 98) - 0.25
        z_top = weighted_percentile(z[top], w[top], 50)
    else:
        z_top = float(np.nanmedian(z[z >= np.nanpercentile(z, 98) - 0.25]))
    ring = ring_seabed(points, cj, ci, raster, seabed, is_reef, x, y)
    local: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
    if ring is not None:
        def local(qx: np.ndarray, qy: np.ndarray, _r=ring) -> np.ndarray:
            return 0.5 * (_r(qx, qy) + seabed.elevation(qx, qy))
    z_sea = float((local or seabed.elevation)(np.array([x]), np.array([y]))[0])
    height = z_top - z_sea
    if not shape:
        return Reef(reef_id, x, y, z_sea, z_top, height, float(len(cells) * c * c), math.nan, math.nan,
                    math.nan, math.nan, math.nan, int(len(pidx)))
    hull = convex_hull(row_ends(np.column_stack([cx, cy])))  # the outer cells decide the rectangle
    corners = np.concatenate([hull + [dx, dy] for dx in (-c / 2, c / 2) for dy in (-c / 2, c / 2)])
    rect = min_area_rectangle(corners)
    sea = local(cx, cy) if local is not None else seabed.elevation(cx, cy)
    zc = np.where(near >= 0, points[np.maximum(near, 0), 2], sea)
    volume = float(np.sum(np.maximum(zc - sea, 0.0)) * c * c)
    j0, j1, i0, i1 = cj.min(), cj.max() + 1, ci.min(), ci.max() + 1
    mask = np.zeros((j1 - j0, i1 - i0), dtype=bool)  # its own cells, not the raster's
    mask[cj - j0, ci - i0] = True
    edge = outline(mask, raster.x0 + i0 * c, raster.y0 + j0 * c, c)
    return Reef(reef_id, x, y, z_sea, z_top, height, float(len(cells) * c * c), rect.length,
                rect.width, rect.bearing_deg, volume, rect.length * rect.width * height,
                int(len(pidx)), outline=tuple(map(tuple, np.round(edge, 3).tolist())))
