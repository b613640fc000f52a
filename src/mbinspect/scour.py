"""Scour round an object, read the same way from a true pit and from a difference map:
how far the seabed went down (the lowering) in rings round the object's centre, outside
its footprint.

``scour_depth`` is the deepest ring's mean lowering; ``scour_radius`` the distance from the
centre at which the rings' mean falls to half of it, going out from the deepest ring;
``scour_volume`` the lowering summed over the cells out to ``reach``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["RING", "REACH", "FOOT_MARGIN", "Scour", "scour_rings", "ring_radii", "grown", "pit_lowering",
           "pit_scour", "clipped", "lone", "CLIP"]

#: The rings' width (m).
RING = 0.5

#: How far from an object's centre its scour is looked for (m), by default; the seabed
#: 2 m beyond is taken as undisturbed.
REACH = 6.0

#: The footprint left out of the rings grows by this much (m): the rim where the beams of
#: two surveys sailed otherwise see the unit's edge, its shadow and its blur differently.
FOOT_MARGIN = 0.75

#: A ring's cells whose distances from the centre spread less than this (m, RMS) give it no
#: slope of their own (:func:`_at_radius`).
FLAT_SPREAD = 0.02

#: Least area (m²) a ring's cells must cover to count: an area, not a count of cells, so
#: that a true pit read on a fine lattice and a difference map on a coarse one leave out the
#: same slivers at the footprint's edge.
MIN_RING_AREA = 1.0

#: A lone cell of a map (this many map sigmas beyond its neighbours, :func:`lone`) whose
#: lowering stands farther than this many robust sigmas from its ring's median is brought
#: back to that bound before the rings' means are taken (:func:`clipped`).
CLIP = 3.0


@dataclass(frozen=True)
class Scour:
    """The scour of :func:`scour_rings` (m, m, m³), the deepest ring's cells (how many
    independent cells its mean is worth: fewer than it holds once that mean is read at the
    ring's own radius), and the number of cells summed into the volume."""

    depth: float
    radius: float
    volume: float
    deepest_cells: float
    cells: int


def scour_rings(dist: np.ndarray, lowering: np.ndarray, cell_area: float, *, reach: float,
                ring_radius: np.ndarray | None = None, ring_area: np.ndarray | None = None) -> Scour:
    """Scour from the cells round one object.

    Parameters
    ----------
    dist : ndarray
        Each cell's distance from the object's centre (m); cells inside the footprint
        (grown by :data:`FOOT_MARGIN`, :func:`grown`) already left out.
    lowering : ndarray
        How far the seabed went down in each cell (m, positive down; NaN: unknown).
    cell_area : float
        One cell's area (m²).
    reach : float
        Cells farther out are not read (m).
    ring_radius : ndarray, optional
        Each ring's mean distance from the centre over its area (m; NaN: unknown), as
        :func:`ring_radii` gives it. Given, each ring's mean is the lowering at that
        distance, from a straight line through its cells' lowering against their distances:
        a lattice of coarse cells puts its centres in a ring unevenly (round a pile standing
        on a cell corner, 0.06 m farther out than the ring's area on average), and a pit's
        flank falls by centimetres over that.
    ring_area : ndarray, optional
        Each ring's area outside the footprint that the map reads (m², from a fine lattice, as
        :func:`ring_radii` counts it). Given, a ring counts when that area reaches
        :data:`MIN_RING_AREA`, not its cells' count times ``cell_area``: a sliver of ring
        between the grown footprint and the next ring holds 2 to 8 coarse cells by where the
        lattice falls, and a true pit read on a fine lattice always counts it.

    Returns
    -------
    Scour

    Examples
    --------
    >>> d = np.repeat(np.arange(0.25, 5.0, 0.5), 8)
    >>> low = np.clip(1.0 - d / 2.0, 0.0, None)
    >>> s = scour_rings(d, low, 0.25, reach=5.0)
    >>> round(s.depth, 3), s.radius
    (0.875, 1.0)
    """
    use = np.isfinite(lowering) & (dist <= reach)
    d, low = dist[use], lowering[use]
    if not len(d):
        return Scour(0.0, 0.0, 0.0, 0, 0)
    k = np.floor(d / RING).astype(np.int64)
    n = np.bincount(k)
    mean = np.bincount(k, weights=low) / np.maximum(n, 1)
    worth = n.astype(np.float64)
    if ring_radius is not None:
        mean, worth = _at_radius(k, d, low, mean, n, ring_radius)
    area = n * cell_area
    if ring_area is not None:
        area = np.zeros(len(n))
        m = min(len(n), len(ring_area))
        area[:m] = np.where(n[:m] > 0, np.nan_to_num(np.asarray(ring_area, np.float64)[:m]), 0.0)
    mean = np.where(area >= MIN_RING_AREA - 1e-9, mean, np.nan)
    if not np.isfinite(mean).any():
        return Scour(0.0, 0.0, 0.0, 0, 0)
    deepest = int(np.nanargmax(mean))
    depth = float(mean[deepest])
    radius = (len(mean)) * RING
    for j in range(deepest + 1, len(mean)):
        if np.isfinite(mean[j]) and mean[j] < depth / 2:
            radius = j * RING
            break
    return Scour(depth, float(radius), float(low.sum() * cell_area), float(worth[deepest]), int(len(low)))


def clipped(dist: np.ndarray, lowering: np.ndarray, floor: float, *, reach: float,
            only: np.ndarray | None = None) -> np.ndarray:
    """Each cell's lowering held within :data:`CLIP` robust sigmas (the ring's own, from its
    median absolute deviation, at least ``floor``) of its ring's median; given ``only``, those
    cells alone (:func:`lone`: the others stand with their neighbours).

    A difference map's cell at an object's edge may hold one sounding that one survey's
    beam heard on the object's flank or in its shadow: a ring of four such cells has its
    mean moved by centimetres by that one (through 1° cones, 24 of 441 unchanged reefs
    called scoured). A true pit's ring spreads by its slope across the ring's width, which
    the ring's own spread carries, and a pit reaching into part of a ring (a neighbour's,
    or one scoured deeper downstream) lowers whole patches of cells together, which
    ``only`` leaves as they are.

    Examples
    --------
    >>> d = np.array([0.1, 0.2, 0.3, 0.4, 0.6, 0.7])
    >>> clipped(d, np.array([0.0, 0.01, -0.01, 0.3, 0.2, 0.2]), 0.01, reach=2.0).round(3).tolist()
    [0.0, 0.01, -0.01, 0.049, 0.2, 0.2]
    """
    out = np.array(lowering, np.float64)
    use = np.isfinite(out) & (dist <= reach)
    k = np.floor(dist / RING).astype(np.int64)
    for ring in np.unique(k[use]):
        m = use & (k == ring)
        v = out[m]
        med = float(np.median(v))
        s = max(1.4826 * float(np.median(np.abs(v - med))), floor)
        held = np.clip(v, med - CLIP * s, med + CLIP * s)
        out[m] = held if only is None else np.where(only[m], held, v)
    return out


def lone(z: np.ndarray, sigma: float) -> np.ndarray:
    """The cells of a map (2-D, NaN: unknown) that stand more than :data:`CLIP` ``sigma``
    beyond all their known neighbours but one (of the eight, at least three known), up or
    down: a cell or a pair on its own, not part of a patch that went down or up together
    (nor a pit's floor, which curves up on every side by less).

    Examples
    --------
    >>> z = np.zeros((7, 7)); z[2, 2] = 0.2; z[5:, :] = 0.2  # a spike, and a band that went up
    >>> np.argwhere(lone(z, 0.01)).tolist()
    [[2, 2]]
    """
    ny, nx = z.shape
    p = np.pad(np.asarray(z, np.float64), 1, constant_values=np.nan)
    around = np.stack([p[1 + dj: 1 + dj + ny, 1 + di: 1 + di + nx]
                       for dj in (-1, 0, 1) for di in (-1, 0, 1) if di or dj])
    known = np.isfinite(around).sum(axis=0)
    low = np.sort(np.where(np.isfinite(around), around, np.inf), axis=0)  # ascending, unknown last
    high = np.sort(np.where(np.isfinite(around), around, -np.inf), axis=0)  # unknown first
    with np.errstate(invalid="ignore"):
        below = z < low[1] - CLIP * sigma  # under all but the lowest neighbour
        above = z > high[-2] + CLIP * sigma
    return (known >= 3) & (below | above)


def _at_radius(k: np.ndarray, d: np.ndarray, low: np.ndarray, mean: np.ndarray, n: np.ndarray,
               ring_radius: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each ring's mean carried along its cells' own slope (lowering against distance) to
    the ring's mean radius, and what it is worth in cells (the slope's own error counted).
    A ring whose cells stand at one distance (a sliver round a pile on a lattice's axis of
    symmetry) takes its slope from its cells and the next ring's together."""
    size = len(n)
    with np.errstate(invalid="ignore", divide="ignore"):
        centre = np.bincount(k, weights=d, minlength=size) / n
        off = d - centre[k]
        sxx = np.bincount(k, weights=off * off, minlength=size)
        slope = np.bincount(k, weights=off * (low - mean[k]), minlength=size) / sxx
        flat = ~(sxx > n * FLAT_SPREAD**2)
        count = n
        if flat.any():
            s_n, s_d, s_l, s_dd, s_dl = (np.convolve(np.bincount(k, weights=w, minlength=size), [1, 1])[1:]
                                         for w in (None, d, low, d * d, d * low))
            s_xx = s_dd - s_d**2 / s_n
            slope = np.where(flat, (s_dl - s_d * s_l / s_n) / s_xx, slope)
            sxx = np.where(flat, s_xx, sxx)
            count = np.where(flat, s_n, n)
    target = np.full(size, np.nan)
    m = min(size, len(ring_radius))
    target[:m] = np.asarray(ring_radius, np.float64)[:m]
    move = target - centre
    ok = np.isfinite(move) & np.isfinite(slope) & (count >= 3) & (sxx > 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        worth = np.where(ok, 1.0 / (1.0 / np.maximum(n, 1) + move**2 / sxx), n.astype(np.float64))
    return np.where(ok, mean + slope * move, mean), worth


def ring_radii(centre: tuple[float, float], inside: Callable[[np.ndarray], np.ndarray], reach: float,
               step: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """Each ring's mean distance from ``centre`` over its area (m), rings of :data:`RING` out
    to ``reach``: the mean over a ``step`` lattice of the points ``inside`` keeps (a mask of
    the points, shape (M, 2), that lie in the area read), NaN for a ring it leaves empty; and
    how many lattice points each ring holds.

    Examples
    --------
    >>> r, n = ring_radii((0.0, 0.0), lambda p: np.hypot(*p.T) >= 1.5, 2.0, step=0.01)
    >>> [round(float(v), 2) for v in r[3:]], int(n[3])
    ([1.76], 54988)
    """
    r = np.arange(step / 2, reach, step)
    gx, gy = np.meshgrid(np.concatenate([-r[::-1], r]), np.concatenate([-r[::-1], r]))
    dist = np.hypot(gx, gy).ravel()
    keep = dist < reach
    pts = np.column_stack([gx.ravel()[keep] + centre[0], gy.ravel()[keep] + centre[1]])
    dist = dist[keep]
    use = inside(pts)
    k = np.floor(dist[use] / RING).astype(np.int64)
    size = int(math.ceil(reach / RING))
    n = np.bincount(k, minlength=size)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.bincount(k, weights=dist[use], minlength=size) / n, n


def grown(poly: np.ndarray, by: float = FOOT_MARGIN) -> np.ndarray:
    """A polygon pushed out from its centre by about ``by`` m.

    Examples
    --------
    >>> grown(np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]]), 1.0).tolist()
    [[2.0, 0.0], [0.0, 2.0], [-2.0, 0.0], [0.0, -2.0]]
    """
    c = poly.mean(axis=0)
    r = np.hypot(*(poly - c).T)
    return c + (poly - c) * ((r + by) / np.maximum(r, 1e-9))[:, None]


def pit_lowering(pits: Sequence[tuple[float, float, float, float]], x: np.ndarray, y: np.ndarray
                 ) -> np.ndarray:
    """How far the pits ``(x, y, depth, radius)`` lower the seabed at ``x, y`` (m, down): each
    a cosine bell ``depth`` m deep at its centre and ``radius`` m wide, the simulator's pits.

    Examples
    --------
    >>> pit_lowering([(0.0, 0.0, 0.6, 4.0)], np.array([0.0, 2.0, 5.0]), np.zeros(3)).tolist()
    [0.6, 0.3, 0.0]
    """
    low = np.zeros(np.broadcast(x, y).shape)
    for px, py, depth, radius in pits:
        r = np.hypot(x - px, y - py)
        low += np.where(r < radius, depth * (1 + np.cos(np.pi * r / radius)) / 2, 0.0)
    return low


def pit_scour(pits: Sequence[tuple[float, float, float, float]], outline: np.ndarray,
              centre: tuple[float, float], *, reach: float = REACH, cell: float = 0.1,
              others: Sequence[np.ndarray] = ()) -> dict[str, float]:
    """The scour true pits leave round an object, read as a difference map is read: every
    pit ``(x, y, depth, radius)`` a cosine bell ``depth`` m deep and ``radius`` m wide (a
    neighbour's pit lowers this object's rings too), on a ``cell`` lattice outside the
    object's ``outline`` (and the ``others``' outlines, as the map leaves every object out)
    grown by :data:`FOOT_MARGIN`, against the lowering 2 m beyond
    ``reach`` (as :func:`mbinspect.change.measure.scour_of` takes the seabed there as
    undisturbed): ``scour_depth``, ``scour_radius`` (m) and ``scour_volume`` (m³); zeros
    without a pit.

    Examples
    --------
    >>> t = np.linspace(0, 2 * np.pi, 48, endpoint=False)
    >>> ring = np.column_stack([0.75 * np.sin(t), 0.75 * np.cos(t)])
    >>> round(pit_scour([(0.0, 0.0, 0.6, 4.0)], ring, (0.0, 0.0))["scour_depth"], 3)
    0.354
    >>> pit_scour([(20.0, 0.0, 0.6, 4.0)], ring, (0.0, 0.0))["scour_depth"]
    0.0
    >>> round(pit_scour([(5.0, 0.0, 0.6, 4.0)], ring, (0.0, 0.0))["scour_depth"], 3)  # a neighbour's
    0.078
    """
    zero = {"scour_depth": 0.0, "scour_radius": 0.0, "scour_volume": 0.0}
    near = [p for p in pits if p[2] > 0 and math.hypot(p[0] - centre[0], p[1] - centre[1]) < reach + 2 + p[3]]
    if not near:
        return zero
    from .geometry import points_in_polygon

    r = np.arange(cell / 2, reach + 2.0, cell)
    gx, gy = np.meshgrid(np.concatenate([-r[::-1], r]), np.concatenate([-r[::-1], r]))
    dist = np.hypot(gx, gy).ravel()
    pts = np.column_stack([gx.ravel() + centre[0], gy.ravel() + centre[1]])
    low = pit_lowering(near, pts[:, 0], pts[:, 1])
    outside = ~points_in_polygon(pts, grown(np.asarray(outline))) & (dist <= reach + 2.0)
    for poly in others:  # the map leaves every object out, not only this one
        poly = np.asarray(poly)
        if len(poly) >= 3 and float(np.hypot(*(poly - centre).T).min()) < reach + 3:
            outside &= ~points_in_polygon(pts, grown(poly))
    level = float(np.median(low[outside & (dist > reach)]))
    s = scour_rings(dist[outside], low[outside] - level, cell * cell, reach=reach)
    if s.depth <= 0:
        return zero
    return {"scour_depth": s.depth, "scour_radius": s.radius, "scour_volume": s.volume}
