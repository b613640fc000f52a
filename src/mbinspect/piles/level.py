"""Stage 9: each pile top's level with its own 1-sigma, the level differences within a jacket,
and the shim each leg of a frame set on the tops needs.

A top's soundings are read line by line (:func:`top_lines`: each line's mean height over the
fitted top plane, and how well that mean is known from its pings). Lines disagree in height
by centimetres (tide, draft, heave, refraction), the same for every pile a line crosses, so
the levels of all piles are fitted together (:func:`adjust_levels`): each (pile, line) mean is
the pile's level plus the line's offset plus an interaction whose spread the fit estimates
from the surplus cells. The level differences within a jacket are then free of the line
offsets; an absolute level keeps their unknown mean (the survey's own vertical reference),
whose spread the fitted offsets show, and a top read from one line alone cannot show it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy.special import stdtrit

from ..fit import clustered_cov
from ..least_depth import LeastDepth, s44_order
from .frame import decide
from .pairs import Level
from .results import PileFit, PileMeasure, PileSegment

__all__ = ["Level", "Levels", "top_lines", "adjust_levels", "pile_levels", "pile_least_depth"]

#: Top soundings within this share of the radius from the axis (the beams that straddle the
#: edge read a blend of top and water).
EDGE_SHARE = 0.8


def top_lines(seg: PileSegment, fit: PileMeasure, *, radius: float, threshold: float
              ) -> tuple[dict[str, Any], ...]:
    """Each line's mean height (m) of a pile's top soundings over its fitted top plane.

    The plane passes through the reported centre, so a line's ``offset`` is what it says
    the centre's elevation ``fit.z`` should move by. Soundings within :data:`EDGE_SHARE` of
    the radius from the axis, within 3 robust sigmas (at least ``threshold / 2``) of the
    plane; ``sigma`` is the mean's 1-sigma with the pings as clusters (a ping's soundings
    share its heave and roll) or the beams (:data:`BEAM_BIN_DEG`; a beam keeps its bias from
    ping to ping) or patches of the top (:data:`PATCH_SHARE`; errors that follow the place),
    whichever is largest.

    Parameters
    ----------
    seg : PileSegment
    fit : PileMeasure
        The pile's last measure (its plane and axis, or its centre).
    radius, threshold : float
        Prior radius and the fits' inlier distance (m).

    Returns
    -------
    tuple of dict
        ``{"line", "offset", "n", "sigma"}`` per line with at least two soundings; empty
        when the top was not sounded.

    Examples
    --------
    >>> from mbinspect.piles import PileMeasure, PileSegment
    >>> rng = np.random.default_rng(0)
    >>> xy = rng.uniform(-0.4, 0.4, (200, 2))
    >>> line = np.repeat([1, 2], 100)
    >>> z = -16.0 + np.where(line == 1, 0.02, -0.02) + rng.normal(0, 0.003, 200)
    >>> seg = PileSegment(np.column_stack([xy, z]), np.ones(200, bool), np.zeros(200, bool),
    ...                   ping=np.arange(200), line=line)
    >>> fit = PileMeasure(0.0, 0.0, -16.0, "centre", np.eye(2), 0.0, 0.0, 200, 0)
    >>> [round(r["offset"], 2) for r in top_lines(seg, fit, radius=0.75, threshold=0.06)]
    [0.02, -0.02]
    """
    if fit.n_top < 3 or any(f.startswith("top not sounded") for f in fit.flags):
        return ()
    pts = seg.points[seg.top]
    if fit.cylinder is not None:
        off_axis = fit.cylinder.residuals(pts) + fit.cylinder.radius
        r = fit.cylinder.radius
    else:
        off_axis = np.hypot(pts[:, 0] - fit.x, pts[:, 1] - fit.y)
        r = radius
    n = fit.plane.normal if fit.plane is not None else np.array([0.0, 0.0, 1.0])
    # the height over the plane through the centre, along the vertical
    height = pts[:, 2] - fit.z + (n[0] * (pts[:, 0] - fit.x) + n[1] * (pts[:, 1] - fit.y)) / n[2]
    use = off_axis <= EDGE_SHARE * r
    if use.sum() < 3:
        return ()
    h = height[use]
    med = float(np.median(h))
    band = max(threshold / 2, 3.0 * 1.4826 * float(np.median(np.abs(h - med))))
    keep = np.flatnonzero(use)[np.abs(h - med) <= band]
    lines = np.zeros(len(pts), np.int64) if seg.line is None else np.asarray(seg.line)[seg.top]
    pings = np.arange(len(pts)) if seg.ping is None else np.asarray(seg.ping)[seg.top]
    beams = None if seg.beam_angle is None else np.round(np.asarray(seg.beam_angle)[seg.top] / BEAM_BIN_DEG)
    # patches of the top: errors that follow the place (the seabed texture an injected top
    # carries, a slow roll or refraction) are shared by neighbours whatever ping or beam
    cell = PATCH_SHARE * r
    cells = np.floor((pts[:, 0] - fit.x) / cell) * 1e4 + np.floor((pts[:, 1] - fit.y) / cell)
    out = []
    for ln in np.unique(lines[keep]):
        rows = keep[lines[keep] == ln]
        if len(rows) < 2:
            continue
        v = height[rows]
        var = max(_cluster_var(v, pings[rows]), _cluster_var(v, beams[rows]) if beams is not None else 0.0,
                  _cluster_var(v, cells[rows]))
        out.append({"line": int(ln), "offset": float(v.mean()), "n": len(rows), "sigma": math.sqrt(var)})
    return tuple(out)


#: The side of the patches of a top (a share of the radius) whose soundings may share an error.
PATCH_SHARE = 0.3

#: The beam angles (deg) that count as one beam for the errors a beam keeps from ping to
#: ping (its calibration, its refraction): a top of a metre at 20 m spans 3 such bins.
BEAM_BIN_DEG = 1.0


def _cluster_var(values: np.ndarray, groups: np.ndarray) -> float:
    """The variance of the mean of ``values`` with ``groups`` as clusters (the soundings'
    own spread over their count when there are fewer than three clusters)."""
    plain = float(values.var(ddof=1) / len(values))
    g = len(np.unique(groups))
    if g < 3:
        return plain
    return max(plain, g / (g - 1) * float(clustered_cov(values - values.mean(), groups)[0, 0]))


@dataclass(frozen=True)
class Levels:
    """Every pile's top level fitted with the lines' offsets (:func:`adjust_levels`).

    Attributes
    ----------
    top_z : dict
        Pile id -> top elevation (m), line offsets removed.
    sigma : dict
        Pile id -> its 1-sigma (m), the survey's vertical reference included (NaN: unknown).
    relative : dict
        (a, b) -> the 1-sigma (m) of ``top_z[b] - top_z[a]`` (line offsets cancel).
    lower_bound : frozenset
        Piles whose top no beam reached: ``top_z`` is where the side's soundings end.
    notes : tuple of str
        Why a level's sigma is unknown or wide.
    line_offsets : dict
        Line -> its fitted offset (m), the lines' mean being zero.
    """

    top_z: dict[int, float]
    sigma: dict[int, float]
    relative: dict[tuple[int, int], float]
    lower_bound: frozenset[int] = frozenset()
    notes: tuple[str, ...] = ()
    line_offsets: dict[int, float] = field(default_factory=dict)


def adjust_levels(piles: Sequence[PileFit]) -> Levels:
    """The top levels of every pile, fitted together with the offsets of the lines that
    sounded them (the lines' mean offset held at zero), each with its 1-sigma.

    Piles and lines that share no sounding are fitted apart (each such set has its own
    reference). A cell's variance is its pings' spread plus the interaction the surplus
    cells show (the chi-square equal to its degrees of freedom); the absolute 1-sigma adds
    the variance of the mean of the line offsets, from their spread. Both are known from
    few degrees of freedom, so each 1-sigma is widened by Student's 97.5 % quantile over
    the normal's: 1.96 sigma stays a 95 % bound.

    Parameters
    ----------
    piles : sequence of PileFit
        With ``top_lines`` (:func:`top_lines`).

    Returns
    -------
    Levels

    Examples
    --------
    >>> from mbinspect.piles.results import PileFit
    >>> def pile(i, z, rows):
    ...     return PileFit(i, 0.0, 0.0, z, 0.75, None, None, "intersection", 50, 50, 360, 0.01, 0.002,
    ...                    top_lines=tuple({"line": ln, "offset": o, "n": 50, "sigma": 0.002}
    ...                                    for ln, o in rows))
    >>> lv = adjust_levels([pile(1, -16.0, [(1, 0.03), (2, -0.03)]),
    ...                     pile(2, -16.1, [(1, 0.031), (2, -0.029)])])
    >>> round(lv.top_z[1], 3), round(lv.top_z[2], 3), round(lv.top_z[2] - lv.top_z[1], 3)
    (-16.0, -16.099, -0.099)
    """
    tops, sig, rel = {p.id: p.z for p in piles}, {p.id: math.nan for p in piles}, {}
    lower = frozenset(p.id for p in piles if not p.top_lines)
    notes: list[str] = []
    offsets: dict[int, float] = {}
    for comp in _components([p for p in piles if p.top_lines]):
        fitted = _fit_component(comp)
        tops.update(fitted[0])
        sig.update(fitted[1])
        rel.update(fitted[2])
        offsets.update(fitted[3])
        notes += fitted[4]
    if lower:
        notes.append(f"pile{'s' if len(lower) > 1 else ''} {', '.join(map(str, sorted(lower)))}: top not "
                     "sounded, its level is where the side's soundings end (a lower bound)")
    return Levels(tops, sig, rel, lower, tuple(notes), offsets)


def _components(piles: list[PileFit]) -> list[list[PileFit]]:
    """The piles split into sets joined by the lines they share."""
    parent = {p.id: p.id for p in piles}

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    by_line: dict[int, int] = {}
    for p in piles:
        for row in p.top_lines:
            first = by_line.setdefault(int(row["line"]), p.id)
            parent[root(p.id)] = root(first)
    comps: dict[int, list[PileFit]] = {}
    for p in piles:
        comps.setdefault(root(p.id), []).append(p)
    return list(comps.values())


def _fit_component(piles: list[PileFit]) -> tuple[dict[int, float], dict[int, float],
                                                   dict[tuple[int, int], float], dict[int, float], list[str]]:
    """One joined set's levels, absolute sigmas, relative sigmas, line offsets and notes."""
    ids = [p.id for p in piles]
    lines = sorted({int(r["line"]) for p in piles for r in p.top_lines})
    n_p, n_l = len(ids), len(lines)
    cells = [(i, lines.index(int(r["line"])), float(r["offset"]), float(r["sigma"]))
             for i, p in enumerate(piles) for r in p.top_lines]
    x = np.zeros((len(cells), n_p + n_l - 1))
    for k, (i, ln, _, _) in enumerate(cells):
        x[k, i] = 1.0
        if ln < n_l - 1:
            x[k, n_p + ln] = 1.0
        else:  # the last line's offset is minus the others' sum: the lines' mean offset is zero
            x[k, n_p:] = -1.0
    y = np.array([c[2] for c in cells])
    v = np.array([c[3] for c in cells]) ** 2
    v = np.where(np.isfinite(v) & (v > 0), v, np.nanmax(np.r_[v, 1e-6]))
    dof = len(cells) - x.shape[1]
    tau2 = _interaction(x, y, v, dof)
    w = 1.0 / (v + tau2)
    # the interaction is known from few surplus cells: the 95 % bound is Student's, not the
    # normal's, and the 1-sigma is widened to carry it (a 1.96-sigma bound stays 95 %)
    widen = float(stdtrit(dof, 0.975)) / 1.96 if dof > 0 else 1.0
    cov = np.linalg.pinv(x.T @ (x * w[:, None])) * widen**2
    beta = cov @ (x.T @ (w * y)) / widen**2
    delta = np.r_[beta[n_p:], -beta[n_p:].sum()] if n_l > 1 else np.zeros(1)
    notes = []
    if n_l > 1:
        datum = float(np.sum(delta**2) / (n_l - 1) / n_l) * (float(stdtrit(n_l - 1, 0.975)) / 1.96)**2
    else:
        datum = math.nan
        notes.append(f"pile{'s' if n_p > 1 else ''} {', '.join(map(str, ids))}: top sounded by one line, "
                     "whose vertical offset and biases between beams the data cannot show; the levels' "
                     "1-sigmas, and their differences', are unknown")
    top = {pid: piles[i].z + float(beta[i]) for i, pid in enumerate(ids)}
    sig = {pid: math.sqrt(float(cov[i, i]) + datum) for i, pid in enumerate(ids)}
    # one line alone cannot show the biases it keeps between beam angles and places (a
    # smile, refraction, a patch of seabed texture): its tops' differences get no sigma
    rel = {(a, b): math.sqrt(max(float(cov[i, i] + cov[k, k] - 2 * cov[i, k]), 0.0)) if n_l > 1 else math.nan
           for i, a in enumerate(ids) for k, b in enumerate(ids) if i != k}
    return top, sig, rel, dict(zip(lines, map(float, delta), strict=True)), notes


def _interaction(x: np.ndarray, y: np.ndarray, v: np.ndarray, dof: int) -> float:
    """The variance each (pile, line) cell adds beyond its pings' spread: the value that makes
    the weighted chi-square equal its degrees of freedom (zero when it is already below)."""
    if dof <= 0:
        return 0.0

    def chi2(t2: float) -> float:
        w = 1.0 / (v + t2)
        a = x.T @ (x * w[:, None])
        beta = np.linalg.lstsq(a, x.T @ (w * y), rcond=None)[0]
        return float(np.sum(w * (y - x @ beta) ** 2))

    if chi2(0.0) <= dof:
        return 0.0
    lo, hi = 0.0, float(np.var(y)) + float(v.max())
    for _ in range(50):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if chi2(mid) > dof else (lo, mid)
    return hi


def pile_levels(piles: Sequence[PileFit], tops: dict[int, float], *, tolerance: float,
                min_clearance: float | None = None
                ) -> tuple[tuple[PileFit, ...], tuple[Level, ...], tuple[str, ...]]:
    """Every pile given its fitted level (:func:`adjust_levels`), compared with its design
    top when known, and every pair within a jacket's level difference.

    Parameters
    ----------
    piles : sequence of PileFit
        Numbered as reported, with ``top_lines`` and their groups.
    tops : dict
        Pile id -> design top elevation (m), from the design's ``top`` column.
    tolerance : float
        How far a top (or a level difference) may miss the design (m), decided at 95 %.
    min_clearance : float, optional
        The least depth (m below the stated datum) each top must keep.

    Returns
    -------
    piles, levels, notes
    """
    lv = adjust_levels(piles)
    out = []
    for p in piles:
        z, s = lv.top_z[p.id], lv.sigma[p.id]
        design = tops.get(p.id)
        dev = None if design is None else z - design
        verdict = None if dev is None else _verdict(dev, s, tolerance, p.id in lv.lower_bound)
        lifted = _with_level(p, z, s, p.id in lv.lower_bound, design, dev, verdict)
        out.append(replace(lifted, least=pile_least_depth(lifted, min_clearance)))
    pairs = []
    for i, a in enumerate(out):
        for b in out[i + 1:]:
            if a.group != b.group:
                continue
            sig = lv.relative.get((a.id, b.id), math.sqrt(a.top_z_sigma**2 + b.top_z_sigma**2))
            diff = lv.top_z[b.id] - lv.top_z[a.id]
            design = None if a.top_design is None or b.top_design is None else b.top_design - a.top_design
            dev = None if design is None else diff - design
            bound = a.top_z_lower_bound or b.top_z_lower_bound
            pairs.append(Level(a.group, a.id, b.id, diff, sig, design, dev,
                               None if dev is None else "undecided" if bound else decide(dev, sig, tolerance),
                               bound))
    return tuple(out), tuple(pairs), lv.notes


def pile_least_depth(p: PileFit, min_clearance: float | None = None) -> dict[str, Any]:
    """A pile top's least depth (the ``least_depth*`` keys,
    :meth:`~mbinspect.least_depth.LeastDepth.fields`): the top's high edge, its level plus
    the radius times the tilt's tangent, toward the tilt's bearing; its TVU from the level's
    1-sigma, its THU from the centre's. A top no beam reached stands at least that high:
    its least depth is at most that deep (a note says so, and its clearance never passes).
    """
    tilt = math.radians(p.tilt_deg or 0.0)
    rise = p.radius * math.tan(tilt)
    bearing = math.radians(p.tilt_azimuth_deg or 0.0)
    edge = p.radius if tilt > 0 else 0.0
    x, y = p.x + edge * math.sin(bearing), p.y + edge * math.cos(bearing)
    z = float(p.top_z if p.top_z is not None else p.z) + rise
    tvu = 1.96 * p.top_z_sigma if not p.top_z_lower_bound else math.nan
    thu = 1.96 * p.sigma_xy
    note = "top not sounded: the least depth is at most this" if p.top_z_lower_bound else \
        "" if math.isfinite(tvu) else "the level's 1-sigma is unknown (one line)"
    ld = LeastDepth(z, x, y, tvu, thu, p.n_top, 0, s44_order(-z, tvu, thu), note)
    return ld.fields(min_clearance)


def _verdict(deviation: float, sigma: float, tolerance: float, lower_bound: bool) -> str:
    """A top's verdict at 95 %; a top not sounded stands at least this high, so it fails
    only when already too high, and passes never."""
    if lower_bound:
        return "fail" if deviation > tolerance else "undecided"
    return decide(deviation, sigma, tolerance)


def _with_level(p: PileFit, z: float, s: float, lower: bool, design: float | None, dev: float | None,
                verdict: str | None) -> PileFit:
    """The pile with its level and its comparison with the design top."""
    return replace(p, top_z=z, top_z_sigma=s, top_z_lower_bound=lower, top_design=design,
                   top_deviation=dev, top_verdict=verdict)
