"""The shape of a reef candidate: how rounded, how much a dome, how thick, and each survey
line's level around it (strips a few centimetres apart put a flat top at two heights).

Measures only; :mod:`mbinspect.reefs.reject` turns them into reasons.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..grid import bounds
from ..neighbours import Cells
from ..seabed import GROUND_BAND
from .footprint import Raster

__all__ = ["rounded_shape", "dome_shape", "beam_weights", "cone_reach", "cone_radius", "weighted_percentile",
           "ground_soundings", "GroundSoundings", "line_levels", "thickness", "cell_soundings",
           "PLATEAU_DEPTH", "TOP_SHARE", "DOME_BASE", "DOME_PLATEAU", "LEVEL_MARGIN", "LEVEL_MIN"]


#: Share of a candidate's height counted as its top (``rounded_plateau``), and the share of
#: its soundings, highest first, whose spread is its top's (``rounded_spread``).
PLATEAU_DEPTH = 0.15
TOP_SHARE = 0.3


def rounded_shape(height: np.ndarray, weight: np.ndarray | None = None) -> tuple[float, float]:
    """How rounded a candidate is, from the heights of its surface (one per footprint cell,
    or per sounding) above one level; given ``weight`` (each height's, :func:`beam_weights`),
    every share and percentile is taken by weight.

    Returns
    -------
    spread : float
        The 10th to 90th percentile of its highest :data:`TOP_SHARE` surface, as a share of
        its top (the 95th percentile): a reef's flat top holds it to the noise, a rock's
        dome spreads it.
    plateau : float
        The share of its surface within :data:`PLATEAU_DEPTH` of its top below it: most of a
        reef's, little of a rock's.

    Examples
    --------
    >>> r = np.sqrt(np.random.default_rng(0).uniform(0, 1, 2000))  # even over a disc
    >>> [round(v, 2) for v in rounded_shape(np.sqrt(1 - r**2))]  # a dome
    [0.14, 0.31]
    >>> [round(v, 2) for v in rounded_shape(np.r_[np.full(900, 1.0), np.linspace(0.2, 1, 100)])]  # a box
    [0.0, 0.92]
    """
    h = np.asarray(height, np.float64)
    if len(h) < 10:
        return math.nan, math.nan
    if weight is not None:
        w = np.asarray(weight, np.float64)
        top = weighted_percentile(h, w, 95)
        sel = h >= weighted_percentile(h, w, 100 * (1 - TOP_SHARE))
        high, wh = h[sel], w[sel]
        spread = (weighted_percentile(high, wh, 90) - weighted_percentile(high, wh, 10)) / top
        return spread, float(np.sum(w[h >= (1 - PLATEAU_DEPTH) * top]) / np.sum(w))
    top = float(np.percentile(h, 95))
    high = h[h >= np.percentile(h, 100 * (1 - TOP_SHARE))]
    spread = float(np.percentile(high, 90) - np.percentile(high, 10)) / top
    return spread, float(np.mean(h >= (1 - PLATEAU_DEPTH) * top))


def weighted_percentile(values: np.ndarray, weight: np.ndarray, q: float) -> float:
    """The ``q``-th percentile of ``values`` counted by ``weight`` (each value standing at
    the middle of its weight; equal weights give NumPy's ``"hazen"`` percentile).

    >>> round(weighted_percentile(np.array([0.0, 1.0, 5.0]), np.array([1.0, 1.0, 0.01]), 50), 3)
    0.505
    """
    order = np.argsort(values, kind="stable")
    v, w = values[order], weight[order]
    at = (np.cumsum(w) - w / 2) / np.sum(w)
    return float(np.interp(q / 100, at, v))


def cone_reach(points: np.ndarray, origins: np.ndarray, beam_width_deg: float) -> np.ndarray:
    """How far (m) a beam of ``beam_width_deg`` may sound each of ``points`` above or below
    the surface it heard.

    A detection places the echo on the beam's axis at the range it heard; an echo from the
    cone's edge at that range stands higher or lower than the axis by up to the plan
    distance from the transducer (``origins``) times the tangent of half the beam: 0.15 m
    at 45° and 17 m for a 1° beam, under 1 cm at nadir. So an outer beam over a reef's flat
    top can sound it that much high. Unknown transducers (NaN) count as at nadir.
    """
    reach = np.hypot(*(points[:, :2] - origins[:, :2]).T) * math.tan(math.radians(beam_width_deg) / 2)
    return np.nan_to_num(reach, nan=0.0)


def cone_radius(points: np.ndarray, origins: np.ndarray, beam_width_deg: float) -> np.ndarray:
    """The radius (m) of a beam of ``beam_width_deg`` where it heard each of ``points``: the
    range from its transducer (``origins``) times the tangent of half the beam (0.16 m at
    18 m for 1°). Unknown transducers (NaN) give 0.

    >>> cone_radius(np.array([[0.0, 0.0, -18.0]]), np.zeros((1, 3)), 1.0).round(3)
    array([0.157])
    """
    rng = np.linalg.norm(points - origins, axis=1) * math.tan(math.radians(beam_width_deg) / 2)
    return np.nan_to_num(rng, nan=0.0)


def beam_weights(reach: np.ndarray, height: float) -> np.ndarray:
    """Each sounding's weight in the shape of a top ``height`` m tall, from its cone's
    :func:`cone_reach`: whole while the cone cannot move it by more than half the plateau's
    depth (:data:`PLATEAU_DEPTH`), then falling as the square of the reach beyond that. A
    sounding whose cone reaches farther cannot show whether a top is flat.

    >>> beam_weights(np.array([0.0, 0.08, 0.24]), 1.1).round(2)
    array([1.  , 0.52, 0.11])
    """
    scale = PLATEAU_DEPTH * max(height, 0.0) / 2
    return scale**2 / np.maximum(scale**2 + reach**2, 1e-12)


#: Share of a candidate's height above which its soundings are its upper part (:func:`dome_shape`),
#: and the most of its surface a dome holds near its top (``plateau`` of :func:`rounded_shape`;
#: rocks of the rocky field 0.14-0.52): a box's flat top holds most of it (solid 2 m cubes,
#: 0.80-0.97), though its rim falls like a dome's.
DOME_BASE = 0.3
DOME_PLATEAU = 0.6


def dome_shape(xy: np.ndarray, z: np.ndarray, across: float, weight: np.ndarray | None = None
               ) -> tuple[float, float]:
    """How much a candidate is a dome: a quadratic surface fitted to its upper soundings
    (above :data:`DOME_BASE` of its top, the 95th percentile of ``z``).

    Parameters
    ----------
    xy : ndarray, shape (N, 2)
        Plan positions (m).
    z : ndarray, shape (N,)
        Heights (m) above the seabed.
    across : float
        The width (m) of its thickest part (:func:`thickness`).
    weight : ndarray, shape (N,), optional
        Each sounding's weight (:func:`beam_weights`): its top and fit taken by weight.

    Returns
    -------
    misfit : float
        The fit's RMS residual as a share of its top: a rock's dome is within the noise of
        one, a stepped or hollow reef is not.
    drop : float
        How far the surface falls across half of ``across`` along its most curved direction,
        as a share of its top: most of a dome's height, nothing for a flat top. NaN both
        with fewer than 10 upper soundings.

    Examples
    --------
    >>> g = np.stack(np.meshgrid(np.linspace(-1, 1, 21), np.linspace(-1, 1, 21)), -1).reshape(-1, 2)
    >>> disc = g[np.hypot(*g.T) < 1]
    >>> dome = np.sqrt(1 - np.sum(disc**2, axis=1))
    >>> [round(v, 2) for v in dome_shape(disc, dome, 2.0)]
    [0.03, 0.75]
    >>> [abs(round(v, 2)) for v in dome_shape(disc, np.ones(len(disc)), 2.0)]  # a flat top
    [0.0, 0.0]
    """
    top = float(np.percentile(z, 95)) if weight is None else weighted_percentile(z, weight, 95)
    up = z >= DOME_BASE * top
    if up.sum() < 10 or top <= 0:
        return math.nan, math.nan
    p = xy[up] - xy[up].mean(axis=0)
    design = np.column_stack([np.ones(len(p)), p, p**2, p[:, 0] * p[:, 1]])
    w = np.ones(len(p)) if weight is None else weight[up]  # ones: the plain fit, to the bit
    root = np.sqrt(w)
    coef, *_ = np.linalg.lstsq(design * root[:, None], z[up] * root, rcond=None)
    misfit = float(np.sqrt(np.sum(w * (z[up] - design @ coef) ** 2) / np.sum(w))) / top
    hessian = np.array([[2 * coef[3], coef[5]], [coef[5], 2 * coef[4]]])
    curvature = -float(np.linalg.eigvalsh(hessian).min())  # the most downward, 1/m
    return misfit, curvature / 2 * (across / 2) ** 2 / top


#: Margin (m) around a candidate whose seabed soundings give each line's level, and the
#: least of them a line needs there for its level to be taken (else none is removed).
LEVEL_MARGIN = 2.0
LEVEL_MIN = 10


@dataclass(frozen=True, eq=False)
class GroundSoundings:
    """The seabed soundings (not reef points, within the ground band) in plan cells of
    :data:`LEVEL_MARGIN` m (``cells``), with each one's ``line`` and ``height`` above the
    seabed in the cells' order: those around a candidate are a few runs of them."""

    cells: Cells
    line: np.ndarray
    height: np.ndarray

    def within(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The lines and heights of the soundings with ``lo[0] <= x < hi[0]`` and
        ``lo[1] <= y <= hi[1]``."""
        c = self.cells
        if len(c.xyz) == 0:
            return self.line[:0], self.height[:0]
        (i0, i1), (j0, j1) = ((max(0, math.floor((a - o) / c.side)), min(n - 1, math.floor((b - o) / c.side)))
                              for a, b, o, n in ((lo[0], hi[0], c.x0, c.nx), (lo[1], hi[1], c.y0, c.ny)))
        runs = [c.run(j * c.nx + i0, j * c.nx + i1) for j in range(j0, j1 + 1)] if i0 <= i1 else []
        rows = np.concatenate([np.arange(a, b) for a, b in runs]) if runs else np.zeros(0, np.int64)
        x, y = c.xyz[rows, 0], c.xyz[rows, 1]
        take = rows[(x >= lo[0]) & (x < hi[0]) & (y >= lo[1]) & (y <= hi[1])]
        return self.line[take], self.height[take]


def ground_soundings(points: np.ndarray, is_reef: np.ndarray, height: np.ndarray, line: np.ndarray
                     ) -> GroundSoundings:
    """The seabed soundings (not reef points, within the ground band), in plan cells."""
    rows = np.flatnonzero(~is_reef & (np.abs(height) <= GROUND_BAND))
    cells = Cells.build(points[rows, :2], LEVEL_MARGIN)
    rows = rows[cells.order]
    return GroundSoundings(cells, line[rows], height[rows])


def line_levels(xy: np.ndarray, line: np.ndarray, ground: GroundSoundings,
                margin: float = LEVEL_MARGIN) -> np.ndarray:
    """Each sounding's line's level: the median height above the seabed of that line's
    seabed soundings within ``margin`` (m) of the soundings' extent (``ground`` as
    :func:`ground_soundings` gives). Strips that disagree by a few centimetres put a reef's
    flat top at two heights, which spread like a dome's; a line with fewer than
    :data:`LEVEL_MIN` seabed soundings there keeps its height.

    Examples
    --------
    >>> gx = np.repeat(np.arange(10.0), 4)
    >>> pts = np.column_stack([gx, np.zeros(40), np.zeros(40)])
    >>> ground = ground_soundings(pts, np.zeros(40, bool), np.tile([0.05, 0.05, -0.05, -0.05], 10),
    ...                           np.tile([1, 1, 2, 2], 10))
    >>> line_levels(np.array([[4.0, 0.5], [5.0, 0.5]]), np.array([1, 2]), ground).tolist()
    [0.05, -0.05]
    """
    lo, hi = bounds(xy)
    lines, h = ground.within(lo - margin, hi + margin)
    level = np.zeros(len(line))
    for k in np.unique(line):
        own = h[lines == k]
        if len(own) >= LEVEL_MIN:
            level[line == k] = np.median(own)
    return level


def thickness(cells: np.ndarray, raster: Raster) -> float:
    """The width (m) of a footprint's thickest part: the diameter of the largest disc its
    cells hold: about 1.4 arm widths at a cross's crossing, not its span; a rock's own width.

    Examples
    --------
    >>> from mbinspect.reefs.footprint import Raster
    >>> lab = np.zeros((40, 40), int)
    >>> lab[15:25, :] = lab[:, 15:25] = 1  # a cross of 0.1 m cells, arms 1 m wide, 4 m long
    >>> r = Raster(0.0, 0.0, 0.1, lab, np.full(lab.shape, -1))
    >>> round(thickness(np.flatnonzero(lab.ravel() == 1), r), 1)
    1.4
    """
    from scipy.ndimage import distance_transform_edt

    ny, nx = raster.labels.shape
    iy, ix = np.divmod(np.asarray(cells, np.int64), nx)
    mask = np.zeros((iy.max() - iy.min() + 3, ix.max() - ix.min() + 3), bool)
    mask[iy - iy.min() + 1, ix - ix.min() + 1] = True
    return float(2.0 * distance_transform_edt(mask).max() * raster.cell)


def cell_soundings(cells: np.ndarray, raster: Raster) -> np.ndarray:
    """The nearest sounding of each of a footprint's cells that has one (rows of the raster's
    soundings).

    Parameters
    ----------
    cells : ndarray of int
        Flat raster cells of a footprint.
    raster : Raster

    Returns
    -------
    ndarray of int
    """
    idx = raster.nearest.ravel()[cells]
    return idx[idx >= 0]
