"""The least depth of an object: the shoalest depth its soundings support, with its 95 %
vertical and horizontal uncertainties (TVU, THU) as IHO S-44 states them, the S-44 order
those meet, and a clearance verdict.

Not the single shoalest sounding: a flier must not make an object shoaler. A sounding
counts only when another ping confirms it (a sounding of another ping within a few sounding
spacings in plan, or 1.5 times the distance to that ping's nearest sounding where the pings
there lie farther apart, and within the noise in height), which keeps the one or two
soundings of a real mast (every ping that passes over it sees it) and drops a flier (no
other ping does).
The least depth is the median of the upper surface around the confirmed shoalest sounding
(the soundings within reach down to twice the noise band below it): on a flat top, the top;
on a peak, within its soundings' spread, which the TVU carries.

Examples
--------
>>> rng = np.random.default_rng(1)
>>> xy = rng.uniform(0, 2, (400, 2))
>>> z = -10.0 + rng.normal(0, 0.01, 400)
>>> z[7] = -9.3  # a flier
>>> ld = least_depth(np.column_stack([xy, z]), ping=np.arange(400) // 20)
>>> abs(ld.z + 10.0) < 0.02, ld.fliers
(True, 1)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from .noise import robust_sigma

__all__ = ["LeastDepth", "least_depth", "s44_order", "clearance", "S44_ORDERS", "least_of"]

#: IHO S-44 (6th edition, 2020) orders, strictest first: TVU = sqrt(a² + (b·depth)²) and
#: THU = c + d·depth, at 95 %.
S44_ORDERS: tuple[tuple[str, float, float, float, float], ...] = (
    ("exclusive", 0.15, 0.0075, 1.0, 0.0),
    ("special", 0.25, 0.0075, 2.0, 0.0),
    ("1a", 0.5, 0.013, 5.0, 0.05),
    ("2", 1.0, 0.023, 20.0, 0.10),
)

#: The upper surface around a confirmed sounding: this many times the confirming reach.
SURFACE_REACH = 3.0

#: How many of the shoalest soundings are tried before giving up on a confirmed one.
CANDIDATES = 200


@dataclass(frozen=True)
class LeastDepth:
    """An object's least depth.

    Attributes
    ----------
    z : float
        Its elevation (m, up; NaN: none).
    x, y : float
        Where it is (m).
    tvu95, thu95 : float
        Its 95 % vertical and horizontal uncertainties (m).
    n : int
        The soundings it rests on.
    fliers : int
        Shoaler soundings no other ping confirms (left out).
    order : str or None
        The strictest S-44 order its TVU and THU meet at its depth.
    note : str
        Why it is wanting, or "".
    tvu95_relative : float
        Its 95 % vertical uncertainty against its own survey's seabed: the TVU without the
        level of its line, which a comparison of two registered surveys measures (NaN: as
        ``tvu95``).
    """

    z: float
    x: float
    y: float
    tvu95: float
    thu95: float
    n: int
    fliers: int = 0
    order: str | None = None
    note: str = ""
    tvu95_relative: float = math.nan

    @property
    def depth(self) -> float:
        """Positive down below the heights' reference (m)."""
        return -self.z

    def fields(self, min_clearance: float | None = None) -> dict[str, Any]:
        """The flat ``least_depth*`` keys an object's JSON row carries: ``least_depth``
        (positive down), ``least_depth_tvu95``, ``least_depth_x``, ``least_depth_y``,
        ``least_depth_thu95``, ``least_depth_order``, ``least_depth_n``,
        ``least_depth_fliers``, ``least_depth_note``, and with ``min_clearance`` (m)
        ``least_depth_clearance`` (:func:`clearance`)."""
        out: dict[str, Any] = {
            "least_depth": self.depth, "least_depth_tvu95": self.tvu95, "least_depth_x": self.x,
            "least_depth_y": self.y, "least_depth_thu95": self.thu95, "least_depth_order": self.order,
            "least_depth_n": self.n, "least_depth_fliers": self.fliers, "least_depth_note": self.note,
            "least_depth_tvu95_relative": self.tvu95 if math.isfinite(self.tvu95) else self.tvu95_relative}
        if min_clearance is not None:
            out["least_depth_clearance"] = clearance(self.depth, self.tvu95, min_clearance) \
                if math.isfinite(self.z) else "undecided"
        return out


def s44_order(depth: float, tvu95: float, thu95: float) -> str | None:
    """The strictest S-44 order whose TVU and THU at ``depth`` (m) the uncertainties meet.

    Examples
    --------
    >>> s44_order(20.0, 0.2, 0.5), s44_order(20.0, 0.28, 0.5), s44_order(20.0, 3.0, 1.0)
    ('exclusive', 'special', None)
    """
    if not (math.isfinite(tvu95) and math.isfinite(thu95)):
        return None
    for name, a, b, c, d in S44_ORDERS:
        if tvu95 <= math.hypot(a, b * depth) and thu95 <= c + d * depth:
            return name
    return None


def clearance(depth: float, tvu95: float, minimum: float) -> str:
    """``pass`` when the least depth is at least ``minimum`` (m) even at its shoal bound,
    ``fail`` when it is less even at its deep bound, else ``undecided`` (at 95 %).

    Examples
    --------
    >>> clearance(12.0, 0.1, 11.5), clearance(11.0, 0.1, 11.5), clearance(11.45, 0.1, 11.5)
    ('pass', 'fail', 'undecided')
    """
    if not math.isfinite(tvu95):  # a depth whose uncertainty is unknown never passes
        return "fail" if depth < minimum else "undecided"
    if depth - tvu95 >= minimum:
        return "pass"
    if depth + tvu95 < minimum:
        return "fail"
    return "undecided"


def least_depth(points: np.ndarray, *, ping: np.ndarray | None = None, level_sigma: float = 0.0,
                spacing: float | None = None, noise: float | None = None,
                position_sigma: float = 0.0, lift: np.ndarray | None = None) -> LeastDepth:
    """The least depth of an object's soundings.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        The object's soundings (m, z up).
    ping : ndarray (N,), optional
        Each sounding's ping: a sounding is confirmed only by another ping's (without: by
        any other sounding).
    level_sigma : float
        The 1-sigma (m) of the height of the line the soundings came from against the
        survey's reference (the lines' disagreement; NaN: unknown, then so is the TVU).
    spacing : float, optional
        The soundings' plan spacing (m); default: the median distance to the nearest.
    noise : float, optional
        The soundings' vertical noise (m, 1-sigma); default: measured on the object's
        upper surface.
    position_sigma : float
        The soundings' horizontal position 1-sigma (m) the THU adds.
    lift : ndarray (N,), optional
        Told the beam, how far each sounding's cone may have sounded it high (m,
        :func:`~mbinspect.reefs.shape.cone_reach`): a sounding confirmed only by the wider
        search (:func:`_reach_at`) must not have been lifted beyond the noise.

    Returns
    -------
    LeastDepth
    """
    pts = np.asarray(points, np.float64)
    ping = None if ping is None else np.asarray(ping)
    if len(pts) < 2:
        return LeastDepth(math.nan, math.nan, math.nan, math.nan, math.nan, len(pts),
                          note="fewer than two soundings")
    tree = cKDTree(pts[:, :2])
    if spacing is None:
        d, _ = tree.query(pts[:, :2], k=2)
        spacing = float(np.median(d[:, 1]))
    # far enough to meet the next ping's soundings (pings lie further apart than beams)
    reach = max(2.5 * spacing, 1.5 * _ping_gap(pts, tree, ping), 0.1)
    sigma = noise if noise is not None else _surface_noise(pts, tree, reach)
    tol = max(3.0 * sigma, 0.02)
    order = np.argsort(-pts[:, 2], kind="stable")
    fliers = 0
    for c in order[:CANDIDATES]:
        near_reach = reach if ping is None else _reach_at(pts, tree, ping, int(c), reach)
        around = np.asarray(tree.query_ball_point(pts[c, :2], near_reach), np.int64)
        near = around[np.abs(pts[around, 2] - pts[c, 2]) <= tol]
        others = near[near != c] if ping is None else near[ping[near] != ping[c]]
        if len(others):
            # the upper surface there: every sounding within a wider reach, down to twice the
            # noise band (a narrow top's few soundings would keep the shoalest's noise)
            wide = np.asarray(tree.query_ball_point(pts[c, :2], max(SURFACE_REACH * near_reach, 0.5)),
                              np.int64)
            dz = pts[wide, 2] - pts[c, 2]
            surface = wide[(dz >= -2 * tol) & (dz <= tol)]  # the fliers over it left out
            # confirmed only beyond the usual reach: the wider search agrees by chance more
            # often, so soundings of WIDE_PINGS pings must stand within the noise of it
            widened = float(np.hypot(*(pts[others, :2] - pts[c, :2]).T).min()) > reach
            level = wide[np.abs(dz) <= tol]
            if not widened or (ping is not None and len(np.unique(ping[level])) >= WIDE_PINGS
                               and (lift is None or lift[c] <= tol)):
                return _estimate(pts[surface], sigma, level_sigma, spacing, position_sigma, fliers)
        fliers += 1
    top = pts[order[0]]
    return LeastDepth(float(top[2]), float(top[0]), float(top[1]), math.nan, math.nan, 1, 0,
                      note=f"no sounding among the {min(len(pts), CANDIDATES)} shoalest confirmed by another "
                           "ping: the shoalest taken, its uncertainty unknown")


#: Soundings searched round a candidate for the nearest of another ping.
NEAREST_OTHER = 64
#: Pings whose soundings must stand within the noise of a candidate confirmed only beyond
#: the object's usual reach (:func:`_reach_at`), within the upper surface's reach: through 1°
#: cones, cone-raised soundings 0.3 m over a double cross's top, on two pings 0.4 m apart,
#: confirmed each other, and the least depth read 0.18-0.31 m shoal; the real top of a unit on
#: its side held four pings' soundings. Told the beam, such a candidate's cone must also not
#: have lifted it beyond the noise (``lift``): with pings 0.25 m apart three pings' cones
#: heard the same raised edge, 0.2-0.28 m over the top.
WIDE_PINGS = 3


def _reach_at(pts: np.ndarray, tree: cKDTree, ping: np.ndarray, c: int, reach: float) -> float:
    """The reach (m) within which another ping confirms the candidate ``c``: ``reach``, or
    1.5 times the plan distance to the nearest sounding of another ping where that stands
    farther (the median gap between pings is that of the whole object, where two lines' pings
    interleave; over a narrow top only one line's pings may pass, 0.33 m apart where the
    median gap was 0.2 m, and every top sounding was left out as a flier: a double cross on
    its side read 0.5 m deep through 1° cones)."""
    gap = float(_nearest_other(pts, tree, ping, np.array([c]), NEAREST_OTHER)[0])
    return max(reach, 1.5 * gap) if math.isfinite(gap) else reach


def _nearest_other(pts: np.ndarray, tree: cKDTree, ping: np.ndarray, rows: np.ndarray, k: int) -> np.ndarray:
    """Each of ``rows``' plan distance to the nearest sounding of another ping among its
    ``k`` nearest (NaN: none there)."""
    d, idx = tree.query(pts[rows, :2], k=min(len(pts), k))
    d, idx = d.reshape(len(rows), -1), idx.reshape(len(rows), -1)
    other = ping[idx] != ping[rows, None]
    return np.where(other.any(axis=1), d[np.arange(len(rows)), other.argmax(axis=1)], np.nan)


def _ping_gap(pts: np.ndarray, tree: cKDTree, ping: np.ndarray | None) -> float:
    """The median plan distance from a sounding to the nearest of another ping (0 without
    pings)."""
    if ping is None:
        return 0.0
    rows = np.linspace(0, len(pts) - 1, min(len(pts), 100)).astype(np.int64)
    first = _nearest_other(pts, tree, np.asarray(ping), rows, 24)
    return float(np.nanmedian(first)) if np.isfinite(first).any() else 0.0


def _surface_noise(pts: np.ndarray, tree: cKDTree, reach: float) -> float:
    """The soundings' spread about the upper surface: each of the shoalest third's height
    against the median of its neighbours within ``reach``."""
    top = np.argsort(-pts[:, 2])[: max(3, len(pts) // 3)]
    dev = []
    for i in top[:300]:
        near = tree.query_ball_point(pts[i, :2], reach)
        if len(near) >= 4:
            dev.append(pts[i, 2] - float(np.median(pts[near, 2])))
    return robust_sigma(np.asarray(dev)) if len(dev) >= 5 else 0.05


def _estimate(s: np.ndarray, sigma: float, level_sigma: float, spacing: float, position_sigma: float,
              fliers: int) -> LeastDepth:
    """The least depth from the confirmed shoalest sounding and those that confirm it."""
    z = float(np.median(s[:, 2]))
    spread = float(s[:, 2].std())
    # the median's noise, where the true top lies within their spread, the line's level
    var_rel = 1.57 * sigma**2 / len(s) + (spread / 2) ** 2
    var_z = var_rel + level_sigma**2
    tvu = 1.96 * math.sqrt(var_z) if math.isfinite(var_z) else math.nan
    # the least depth may lie anywhere between soundings: a sampling of ``spacing``
    thu = 1.96 * math.sqrt(spacing**2 / 6 + position_sigma**2 + float(s[:, :2].var(axis=0).sum()) / len(s))
    x, y = (float(v) for v in s[:, :2].mean(axis=0))
    note = "" if math.isfinite(tvu) else "the height of its line against the others is unknown (one line)"
    return LeastDepth(z, x, y, tvu, thu, len(s), fliers, s44_order(-z, tvu, thu), note,
                      1.96 * math.sqrt(var_rel) if math.isfinite(var_rel) else math.nan)


def least_of(d: dict[str, Any]) -> dict[str, Any]:
    """The ``least_depth*`` keys of a JSON row (NaN where JSON holds null)."""
    numbers = ("least_depth", "least_depth_tvu95", "least_depth_thu95", "least_depth_x", "least_depth_y",
               "least_depth_tvu95_relative")
    return {k: (math.nan if v is None and k in numbers else v)
            for k, v in d.items() if k.startswith("least_depth")}
