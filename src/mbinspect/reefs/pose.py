"""Fitting a reef design's pose (position, bearing) and as-built size to one reef's soundings.

Where the user names the designs, each reef found by :func:`mbinspect.reefs.extract_reefs`
is also fitted by the design that explains its soundings best: position, bearing and an
as-built size factor (one scale on every dimension, free, so the footprint area is measured,
not copied from the design).

The fit classifies the soundings near the reef: a reef sounding must fall inside the plan
footprint of the boxes that reach its height, a seabed sounding (or another reef's) outside
every box, and a sounding on a side wall (its height near no box top) on the edge. Each costs
its squared distance on the wrong side, capped; nothing pulls a sounding on its right side, so
an edge facing an acoustic shadow does not drift outward (a symmetric soft cost did: +4 %
area on 0.55 m pings). A free-form outline is limited by the soundings near each edge; a
design shares its few parameters over every edge, which is what brings the footprint area
within a few percent on a survey whose pings are as far apart as a reef arm is wide.

Examples
--------
>>> import numpy as np
>>> from mbinspect.reef_designs import BUILTIN_DESIGNS
>>> d = BUILTIN_DESIGNS["cross1"]
>>> g = np.mgrid[-2:2:0.1, -2:2:0.1].reshape(2, -1).T + 0.05
>>> inside = d.signed_distance(g, 0.3, -0.2, 20.0, 1.0) < 0
>>> f = fit_design(g, inside, ~inside, d, x0=0.0, y0=0.0)
>>> bool(abs(f.x - 0.3) < 0.05 and abs(f.y + 0.2) < 0.05 and abs(f.scale - 1) < 0.05)
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from ..errors import ParameterError
from ..outputs import to_jsonable
from ..reef_designs import Grow, ReefDesign, box_distances, rotate

__all__ = ["DesignFit", "fit_design", "SCALE_BOUNDS", "scale_at_bound"]


#: How far (m) a sounding near the fitted edge may stand on its wrong side before it counts
#: against the fit (:attr:`DesignFit.misfit`).
MISFIT_TOLERANCE = 0.1
#: Soundings this near (m) a fitted design's edge are those its misfit counts, with the reef's
#: own soundings beyond it.
EDGE_BAND = 0.5

#: Told the beam, the share of a sounding's bloom (its reach past the edge it faces) added to
#: :data:`MISFIT_TOLERANCE`: where a wide beam's echo stops standing on the reef varies by about
#: that much from ping to ping (with the fixed tolerance alone, 28 of 100 reefs of the 1° reef field
#: (seed 1) were refused their design, against 11 before the design was fitted as heard).
BLOOM_TOLERANCE = 0.5

#: The as-built size factor a design fit may take (smallest, largest).
SCALE_BOUNDS: tuple[float, float] = (0.6, 1.6)

#: A fitted size factor within this ratio of a bound is taken as held by it: the soundings
#: wanted a size outside the range, so the fit explains another kind of object.
BOUND_MARGIN = 1.03


def scale_at_bound(scale: float, bounds: tuple[float, float] = SCALE_BOUNDS) -> bool:
    """Whether a fitted size factor sits at (within 3 % of) a bound of the fit.

    Parameters
    ----------
    scale : float
        The fitted as-built size factor.
    bounds : (float, float)
        The fit's bounds.

    Returns
    -------
    bool

    Examples
    --------
    >>> scale_at_bound(1.0), scale_at_bound(0.61), scale_at_bound(1.58)
    (False, True, True)
    """
    return not bounds[0] * BOUND_MARGIN < scale < bounds[1] / BOUND_MARGIN


@dataclass(frozen=True)
class DesignFit:
    """A design fitted to one reef: pose, as-built size factor and how well it fits.

    ``x, y`` are the fitted footprint's centroid; ``area`` the design's footprint area
    times ``scale``²; ``misfit`` the share of the soundings within 0.5 m of the fitted edge,
    and of the reef's own beyond it, that lie more than 0.1 m on its wrong side (reef
    outside, seabed inside); ``n_edge`` how many were counted; ``origin``
    the design frame's origin at the fitted pose (for :meth:`ReefDesign.signed_distance`).
    """

    design: str
    x: float
    y: float
    bearing_deg: float
    scale: float
    area: float
    misfit: float
    n_edge: int
    loss: float
    outline: np.ndarray = field(repr=False, compare=False)
    origin: tuple[float, float] = field(default=(math.nan, math.nan), repr=False, compare=False)

    @property
    def pose(self) -> tuple[float, float, float, float]:
        """The design frame's origin, bearing and scale: (x, y, bearing_deg, scale)."""
        return (*self.origin, self.bearing_deg, self.scale)

    def to_dict(self) -> dict[str, Any]:
        return to_jsonable({k: getattr(self, k) for k in ("design", "x", "y", "bearing_deg", "scale",
                                                           "area", "misfit", "n_edge")})


def _roles(design: ReefDesign, inside: np.ndarray, height: np.ndarray | None, band: float
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Which boxes each sounding is judged against (N, B), which lie on a side wall, and
    which lie higher than the design reaches.

    A reef sounding at height h lies on a box that reaches above h - ``band``; one whose
    height is within ``band`` of no box top lies on a side wall, so on the footprint's
    edge at that height. A seabed sounding must lie outside the boxes standing on the
    base (the seabed under an overhanging upper box can be seen).
    """
    tops = np.array([b.dz + b.height for b in design.boxes])
    n = len(inside)
    use = np.ones((n, len(tops)), dtype=bool)
    wall = np.zeros(n, dtype=bool)
    above = np.zeros(n, dtype=bool)
    if height is not None:
        h = np.asarray(height, np.float64)[inside]
        q = tops[None, :] >= h[:, None] - band
        above[inside] = ~q.any(axis=1)
        q[~q.any(axis=1)] = True  # above the design's top: judged against every box
        use[inside] = q
        wall[inside] = (np.abs(h[:, None] - tops[None, :]) > band).all(axis=1) & (h < tops.max())
    return use, wall, above


def fit_design(xy: np.ndarray, inside: np.ndarray, outside: np.ndarray, design: ReefDesign, *,
               x0: float, y0: float, height: np.ndarray | None = None, sigma: float = 0.03,
               cap: float = 0.12, band: float = 0.25, size_prior: float = 0.1,
               scale_range: tuple[float, float] = SCALE_BOUNDS, grow: Grow | None = None) -> DesignFit:
    """Fit a design's pose (x, y, bearing) and size factor to the soundings around a reef.

    Costs, each ``(distance / sigma)²`` up to ``(cap / sigma)²``: a reef sounding outside
    the footprint of the boxes that reach its height, a seabed sounding inside any box,
    and a reef sounding on a side wall (its height within ``band`` of no box top, heights
    taken relative to the reef's own top set on the design's) away from that footprint's
    edge either way. Nothing pulls a sounding that is on its right side, so an edge facing
    an acoustic shadow (reef soundings and no seabed beyond) does not drift outward;
    side-wall soundings pin the edges they were measured on. The bearing is scanned over
    one symmetry period; from the best start (and the best one 20 degrees or more from
    it) Levenberg-Marquardt runs twice, with four times the tolerance and cap first.

    Parameters
    ----------
    xy : ndarray (N, 2)
        Plan positions of the soundings near the reef (m).
    inside, outside : ndarray of bool (N,)
        Reef soundings, and seabed soundings; others are ignored.
    design : ReefDesign
    x0, y0 : float
        Starting position (the free-form centroid).
    height : ndarray (N,), optional
        Height of each sounding above the seabed (m); without it every reef sounding is
        only required inside the footprint.
    sigma, cap, band : float
        Edge tolerance, largest cost of one sounding (m), and the tolerance (m) on box-top
        heights (settlement into the seabed, noise).
    size_prior : float
        Prior 1-sigma of the log size factor around 1: it only decides where the soundings
        leave the size free (no side wall seen, pings far apart); wherever they fix it,
        they win.
    scale_range : (float, float)
        Bounds of the size factor.
    grow : Grow, optional
        How far (m) a wide beam's bloom moves each side of the footprint out for each
        sounding, by the side's outward normal (:func:`~mbinspect.reef_designs.box_distances`):
        the soundings are then those as heard, bloom and all, and the design is fitted as the
        beam drew it.

    Returns
    -------
    DesignFit
    """
    p = np.asarray(xy, np.float64)
    inside = np.asarray(inside, bool)
    sel = inside | np.asarray(outside, bool)
    if sel.sum() < 10 or not inside.any():
        raise ParameterError(f"design {design.name!r}: too few soundings to fit ({int(sel.sum())})")
    if height is not None:
        # heights relative to the reef's own top, set on the design's: a reef sunk into the
        # sediment, or a seabed estimate a little off under it, moves every height alike
        h = np.asarray(height, np.float64)
        h_in = h[inside]
        hi = np.percentile(h_in, 98)
        height = h - (float(np.median(h_in[h_in >= hi - 0.25])) - design.height)
    use, wall, above = _roles(design, inside, height, band)
    c = np.array([x0, y0])
    problem = _Pose(design, p[sel] - c, inside[sel], use[sel], wall[sel], above[sel],  # near the origin
                    sigma, cap, size_prior, math.log(scale_range[0]), math.log(scale_range[1]),
                    None if grow is None else grow.subset(np.flatnonzero(sel)))
    period = 360.0 / design.symmetry
    best = None
    for b in _bearing_starts(problem, period):
        r = problem.solve(b)
        if best is None or r.cost < best.cost:
            best = r
    assert best is not None
    x, y, bearing, ls = best.x
    scale = math.exp(ls)
    d = problem.distances(best.x)
    edge = np.abs(d) <= EDGE_BAND
    ins = problem.inside
    tol = MISFIT_TOLERANCE
    if grow is not None:  # where the bloom ends is uncertain by a part of its reach
        bloom = np.maximum(replace(problem, grow=None).distances(best.x) - d, 0.0)
        tol = MISFIT_TOLERANCE + BLOOM_TOLERANCE * bloom
    wrong = (np.where(problem.wall, np.abs(d) > tol, np.where(ins, d > tol, d < -tol)) | problem.above) & edge
    # the reef's own soundings beyond the edge's band are wrong too: a ridge 9 m long is no
    # cross 3 m wide, however well the cross's edges sit among its soundings
    far = ins & (d > EDGE_BAND)
    wrong, edge = wrong | far, edge | far
    centroid = rotate(design.centroid * scale, bearing) + np.array([x, y]) + c
    return DesignFit(design.name, float(centroid[0]), float(centroid[1]), float(bearing % period),
                     scale, design.area * scale * scale, float(wrong.sum() / max(edge.sum(), 1)),
                     int(edge.sum()), float(2 * best.cost),
                     design.outline(float(x + c[0]), float(y + c[1]), float(bearing), scale),
                     (float(x + c[0]), float(y + c[1])))


@dataclass(frozen=True)
class _Pose:
    """The least-squares problem of one design's pose (x, y, bearing, log scale) on the
    soundings near a reef (plan positions ``p`` relative to the start)."""

    design: ReefDesign
    p: np.ndarray
    inside: np.ndarray
    use: np.ndarray
    wall: np.ndarray
    above: np.ndarray
    sigma: float
    cap: float
    size_prior: float
    lo: float
    hi: float
    grow: Grow | None = None

    def distances(self, v: np.ndarray) -> np.ndarray:
        scale = math.exp(min(max(v[3], self.lo), self.hi))
        db, _ = box_distances(self.design, self.p, v[0], v[1], v[2], scale, grow=self.grow)
        return np.where(self.use, db, np.inf).min(axis=1)

    def wrong_side(self, d: np.ndarray) -> np.ndarray:
        return np.where(self.wall, np.abs(d),
                        np.where(self.inside, np.maximum(d, 0.0), np.maximum(-d, 0.0)))

    def residual(self, v: np.ndarray, sigma: float, cap: float) -> np.ndarray:
        r = np.where(self.above, cap, np.minimum(self.wrong_side(self.distances(v)), cap)) / sigma
        return np.append(r, v[3] / self.size_prior)

    def jacobian(self, v: np.ndarray, sigma: float, cap: float) -> np.ndarray:
        ls = min(max(v[3], self.lo), self.hi)
        db, g = box_distances(self.design, self.p, v[0], v[1], v[2], math.exp(ls), grad=True,
                              grow=self.grow)
        assert g is not None
        if ls != v[3]:
            g[..., 3] = 0.0
        k = np.where(self.use, db, np.inf).argmin(axis=1)
        rows = np.arange(len(self.p))
        d, gd = db[rows, k], g[rows, k]
        w = self.wrong_side(d)
        sign = np.where(self.wall, np.sign(d),
                        np.where(self.inside, (d > 0).astype(float), -(d < 0).astype(float)))
        live = ~self.above & (w < cap)
        prior = np.array([[0.0, 0.0, 0.0, 1.0 / self.size_prior]])
        return np.vstack([gd * (np.where(live, sign, 0.0) / sigma)[:, None], prior])

    def start(self, bearing: float) -> np.ndarray:
        """The pose with the design's centroid at the start and the given bearing."""
        return np.array([*rotate(-self.design.centroid, bearing), bearing, 0.0])

    def solve(self, bearing: float) -> Any:
        """Levenberg-Marquardt from a bearing: coarse to fine, a wide tolerance first smooths
        away the local minima that thin arms make, then the edge tolerance proper."""
        start = self.start(bearing)
        # the first trust region scales with the start: a start of round-off, not of zero,
        # would make it vanish
        start[np.abs(start) < 1e-9] = 0.0
        for s_k, c_k in ((4 * self.sigma, 4 * self.cap), (self.sigma, self.cap)):
            r = least_squares(self.residual, start, method="lm", jac=self.jacobian, args=(s_k, c_k),
                              x_scale=np.array([0.05, 0.05, 2.0, 0.02]), xtol=1e-4, max_nfev=60)
            r.x[3] = min(max(r.x[3], self.lo), self.hi)
            start = r.x
        return r


def _bearing_starts(problem: _Pose, period: float) -> list[float]:
    """The bearing from a scan over one symmetry period: the best, and the best one at
    least 20 degrees from it when it costs little more."""
    step = period / 12
    scan = np.arange(0.0, period, step)
    costs = np.array([float(np.sum(problem.residual(problem.start(b), problem.sigma, problem.cap) ** 2))
                      for b in scan])
    order = np.argsort(costs)
    starts = [order[0]]
    far = [k for k in order[1:] if min((scan[k] - scan[order[0]]) % period,
                                       (scan[order[0]] - scan[k]) % period) >= 20.0]
    if far and costs[far[0]] <= 1.5 * costs[order[0]] + 5.0:
        starts.append(far[0])
    return [float(scan[k]) for k in starts]
