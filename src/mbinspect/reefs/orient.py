"""How each reef unit rests: the tilt of its top plane, and whether it stands upright or lies
on its side or upside down (the design compared with the soundings in every orientation the
design allows).

A unit dropped badly lies on its side or upside down; one that landed on a rock or on the
edge of a scour hole leans. The top plane is fitted to the unit's highest soundings (the
cells of its upper surface that one plane holds, then every sounding within the noise of
it; :mod:`mbinspect.reefs.tilt`). The orientation: the design's upper surface in each
orientation that looks different from above
(:func:`mbinspect.design_solids.distinct_orientations`) placed over the soundings at the
best bearing and position, the cells' highest soundings against the design's surface at
the same soundings (mean absolute difference); a unit is called overturned only when another
orientation beats upright by :data:`OVERTURNED_MARGIN` of the height and
:data:`OVERTURNED_SHARE` of the cells where the two differ side with it (told the beam, the
margin is at most :data:`OVERTURNED_SEPARATION` of how far the two surfaces lie apart). A design that looks
alike every way (a solid cube) cannot tell: ``overturned`` is then None.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..design_solids import distinct_orientations, sample, surface_map
from ..reef_designs import ReefDesign
from .results import Reef
from .tilt import CELL, cells_of, tilt_of, top_plane

__all__ = ["Rest", "rest_of", "with_rest", "overturned_unit",
           "OVERTURNED_MARGIN", "OVERTURNED_SHARE", "OVERTURNED_FIT",
           "OVERTURNED_SEPARATION", "UNTOLD_SHARE", "UNTOLD"]

#: How much better (a share of the design's height, mean absolute) an orientation other
#: than upright must fit before a unit is called overturned ...
OVERTURNED_MARGIN = 0.05

#: ... and the share of the cells where the two differ (by a quarter of the height) whose
#: soundings must lie nearer the overturned one (measured: ``benchmarks/study_rest.py``).
OVERTURNED_SHARE = 0.6

#: Told the beam, the margin is also met by this share of how far the two orientations'
#: surfaces, each spread by the cone (:func:`~mbinspect.design_solids.surface_map`), lie
#: apart: spread by 0.1 m, an upright double cross's top bars are the width of its lower
#: ones, and an upside-down unit in the real R2Sonic XTF beat upright by 0.30-0.36 of that
#: (0.09-0.10 m, under the margin's 0.10 m) where no upright unit in ``study_rest.py`` or
#: ``study_change.py`` through 1° cones came above 0.04.
OVERTURNED_SEPARATION = 0.2

#: Told the beam, a unit not called overturned is left undecided when at least this share
#: of the cells where upright and the best other orientation differ side with the other: a
#: double cross upside down through 1° cones at 17-23 m (its 0.8 m top bars spread 0.16-0.23 m,
#: an upright one's 0.6 m bars as much) had 50-69 % of those cells on its side and was read
#: upright; of 60 upright ones none came above 47 % (``study_rest.py``'s cross2-beam-told).
UNTOLD_SHARE = 0.5

#: The words a ``resting_note`` holds when the beam left a unit undecided (the command line
#: lists those units).
UNTOLD = "cannot be told apart through the beam"

#: Fewest cells where upright and overturned differ for the orientation to be told.
_MIN_DIFFER = 8

#: The steepest top (degrees) taken for a lean and levelled before the orientations are
#: compared; a steeper one is a face of a unit on its side, not a lean.
_LEVEL_MAX = 20.0



@dataclass(frozen=True)
class Rest:
    """How one unit rests.

    Attributes
    ----------
    design : str
        The design compared ("" when none was).
    resting : str
        The orientation that fits best ("upright", "upside down", "on its side", ...).
    overturned : bool or None
        None when the design looks alike every way, or no design was compared.
    misfit, upright_misfit, turned_misfit : float
        Mean absolute difference (m) of the cells' highest soundings from the design's
        upper surface, in the best orientation, upright, and the best other than upright.
    x, y, bearing_deg : float
        The design's centre and bearing in the best orientation.
    top_tilt_deg, top_tilt_sigma_deg : float
        The top plane's tilt from level and its 1-sigma; NaN when the top is too small.
    note : str
        Why something could not be said.
    """

    design: str = ""
    resting: str = ""
    overturned: bool | None = None
    misfit: float = math.nan
    upright_misfit: float = math.nan
    turned_misfit: float = math.nan
    x: float = math.nan
    y: float = math.nan
    bearing_deg: float = math.nan
    top_tilt_deg: float = math.nan
    top_tilt_sigma_deg: float = math.nan
    note: str = ""
    turned_share: float = math.nan
    n_differ: int = 0


class _Window:
    """The soundings around one unit, their cells and their heights with the unit's top
    plane taken out (so that a leaning unit is compared level)."""

    def __init__(self, xy: np.ndarray, h: np.ndarray, bloom: float = 0.0) -> None:
        self.xy = xy
        self.bloom = bloom
        self.order, self.starts = cells_of(xy, CELL)
        self.heights = h
        self.measured = np.maximum.reduceat(h[self.order], self.starts)

    def surface(self, design: ReefDesign, orientation: str, x: float | np.ndarray, y: float | np.ndarray,
                bearing: float | np.ndarray, scale: float, tall: float) -> np.ndarray:
        """The design's surface over each cell (its highest at the cell's soundings), sunk or
        lifted (a unit on a rock or its own edge) as far as fits the soundings (up to 30 %
        of its height); NaN off the design. Given K poses (arrays), (K, cells)."""
        d = np.maximum.reduceat(sample(design, orientation, self.xy[self.order], x, y, bearing, scale,
                                       bloom=self.bloom), self.starts, axis=-1)
        m = self.measured
        on = d > 0
        both = on & (m > 0.1 * tall)
        if d.ndim > 1:  # each pose's median over its cells in common (none: no sink)
            v = np.sort(np.where(both, d - m, np.inf), axis=-1)
            k = both.sum(axis=-1)
            rows = np.arange(len(v))
            lo, hi = v[rows, np.maximum(k - 1, 0) // 2], v[rows, np.maximum(k, 1) // 2 - (k == 0)]
            gap = np.where(k > 0, (lo + hi) / 2, 0.0)[:, None]
        else:
            gap = np.asarray(np.median(d[both] - m[both]) if both.any() else 0.0)
        sink = np.clip(np.nan_to_num(gap), -0.3 * tall, 0.3 * tall)
        return np.where(on, np.maximum(d - sink, 0.0), np.nan)

    def misfit(self, design: ReefDesign, orientation: str, x: float | np.ndarray, y: float | np.ndarray,
               bearing: float | np.ndarray, scale: float, tall: float) -> np.ndarray:
        """Mean absolute difference (m) of the cells' highest soundings from the design's
        surface (:meth:`surface`), over the cells either stands in; one per pose."""
        d = np.atleast_2d(self.surface(design, orientation, np.atleast_1d(x), np.atleast_1d(y),
                                       np.atleast_1d(bearing), scale, tall))
        m = self.measured
        used = np.isfinite(d) | (m > 0.2 * tall)
        e = np.where(used, np.abs(m - np.nan_to_num(d)), 0.0).sum(axis=1)
        n = used.sum(axis=1)
        return np.where(n > 0, e / np.maximum(n, 1), np.inf)

    def separation(self, a: np.ndarray, b: np.ndarray, tall: float) -> float:
        """Mean absolute difference (m) of two surfaces (:meth:`surface`) over the cells
        either stands in or the soundings rise in (those :meth:`misfit` counts)."""
        used = np.isfinite(a) | np.isfinite(b) | (self.measured > 0.2 * tall)
        return float(np.abs(np.nan_to_num(a) - np.nan_to_num(b))[used].mean()) if used.any() else 0.0

    def preference(self, a: np.ndarray, b: np.ndarray, tall: float) -> tuple[float, int]:
        """Of the cells where two surfaces (:meth:`surface`) differ by more than a quarter
        of the height, the share whose soundings lie nearer ``b``, and how many there are."""
        a, b = np.nan_to_num(a), np.nan_to_num(b)
        differ = np.abs(a - b) > 0.25 * tall
        if not differ.any():
            return math.nan, 0
        m = self.measured[differ]
        return float(np.mean(np.abs(m - b[differ]) < np.abs(m - a[differ]))), int(differ.sum())


def _best_pose(win: _Window, design: ReefDesign, orientation: str, x: float, y: float, scale: float,
               bearings: np.ndarray) -> tuple[float, float, float, float]:
    """The bearing and position of least misfit: a coarse sweep of ``bearings``, then finer
    turns and shifts about the best. Returns misfit, x, y, bearing."""
    tall = design.height * scale
    bearings = np.asarray(bearings, np.float64)
    ones = np.ones(len(bearings))
    m = win.misfit(design, orientation, x * ones, y * ones, bearings, scale, tall)
    k = int(np.argmin(m))
    best = (float(m[k]), x, y, float(bearings[k]))
    for step_b, step_xy in ((2.0, 0.15), (1.0, 0.05)):
        _, bx, by, bb = best
        turns = bb + step_b * np.array([-2.0, -1.0, 1.0, 2.0])
        m = win.misfit(design, orientation, bx + 0 * turns, by + 0 * turns, turns, scale, tall)
        k = int(np.argmin(m))
        best = min(best, (float(m[k]), bx, by, float(turns[k])))
        _, bx, by, bb = best
        dx, dy = (a.ravel() for a in np.meshgrid([-step_xy, 0.0, step_xy], [-step_xy, 0.0, step_xy]))
        moved = (dx != 0) | (dy != 0)
        xs, ys = bx + dx[moved], by + dy[moved]
        m = win.misfit(design, orientation, xs, ys, bb + 0 * xs, scale, tall)
        k = int(np.argmin(m))
        best = min(best, (float(m[k]), float(xs[k]), float(ys[k]), bb))
    return best


def rest_of(xyz: np.ndarray, h: np.ndarray, own: np.ndarray, designs: Sequence[ReefDesign], *,
            noise: float, ping: np.ndarray | None = None, design: str = "",
            pose: tuple[float, float, float, float] | None = None, bloom: float = 0.0) -> Rest:
    """How one unit rests: its top's tilt and its best orientation.

    Parameters
    ----------
    xyz : ndarray, shape (N, 3)
        The soundings around the unit (its own and the seabed about it), m.
    h : ndarray, shape (N,)
        Their heights above the seabed (m).
    own : ndarray of bool, shape (N,)
        The unit's own soundings.
    designs : sequence of ReefDesign
        The designs it may be; ``design`` names the one an upright fit chose (only that
        one is then compared).
    noise : float
        The soundings' vertical 1-sigma (m).
    ping : ndarray of int, shape (N,), optional
    pose : (x, y, bearing_deg, scale), optional
        The upright fit's pose: the upright comparison starts there.
    bloom : float, optional
        Told the beam, its cone's radius where the unit was heard (m): each orientation's
        surface is compared as that beam hears it (:func:`~mbinspect.design_solids.surface_map`),
        its tops spread by it. Through 1° cones the thin design's surfaces took a double-layer
        cross upright, its top bars spread, for one upside down (22 of 853 upright units).

    Returns
    -------
    Rest
    """
    xy = xyz[:, :2]
    pts = xyz[own]  # the top's tilt from level, whatever the seabed does
    coef, cov, note = top_plane(pts, noise, None if ping is None else ping[own])
    tilt, tilt_sigma = tilt_of(coef, cov) if not note else (math.nan, math.nan)
    level = h.copy()
    if not note and tilt <= _LEVEL_MAX:  # a lean taken out of the unit's own heights
        mx, my = pts[:, :2].mean(axis=0)
        level[own] -= coef[1] * (xy[own, 0] - mx) + coef[2] * (xy[own, 1] - my)
    chosen = [d for d in designs if d.name == design] if design else list(designs)
    if not chosen:
        return Rest(top_tilt_deg=tilt, top_tilt_sigma_deg=tilt_sigma, note=note)
    win = _Window(xy, level, bloom)
    weight = np.maximum(h[own], 0.0)
    centre = ((xy[own] * weight[:, None]).sum(axis=0) / max(weight.sum(), 1e-12) if own.any()
              else xy.mean(axis=0))
    results = []
    for d in chosen:
        scale = pose[3] if pose is not None and d.name == design else 1.0
        for way in distinct_orientations(d):
            if way == "upright" and pose is not None and d.name == design:
                fit = _best_pose(win, d, way, pose[0], pose[1], scale,
                                 np.array([pose[2] - 4.0, pose[2], pose[2] + 4.0]))
            else:
                sym = d.symmetry if way in ("upright", "upside down") else 2
                fit = _best_pose(win, d, way, float(centre[0]), float(centre[1]), scale,
                                 np.arange(0.0, 360.0 / sym, 6.0))
            results.append((fit, d, way, scale))
    rest = _decide(win, results)
    return replace(rest, top_tilt_deg=tilt, top_tilt_sigma_deg=tilt_sigma, note=note or rest.note)


_Fit = tuple[tuple[float, float, float, float], ReefDesign, str, float]


def _decide(win: _Window, results: list[_Fit]) -> Rest:
    """Upright or overturned, from each design's and orientation's best fit (misfit, x, y,
    bearing), design, orientation and scale: the best upright fit of any design against the
    best other orientation of any design (:data:`OVERTURNED_MARGIN`,
    :data:`OVERTURNED_SHARE`), so that one design upright is never taken for another
    overturned."""
    best = min(results, key=lambda r: r[0][0])
    up = min((r for r in results if r[2] == "upright"), key=lambda r: r[0][0], default=None)
    down = min((r for r in results if r[2] != "upright"), key=lambda r: r[0][0], default=None)
    upright = math.inf if up is None else up[0][0]
    turned = math.inf if down is None else down[0][0]
    share, n_differ, note = math.nan, 0, ""
    overturned: bool | None = None
    if up is None or down is None:
        note = f"the {best[1].name} design looks alike every way up: its orientation cannot be told"
    else:
        tall = max(up[1].height * up[3], down[1].height * down[3])
        upper = win.surface(up[1], "upright", *up[0][1:], up[3], tall)
        other = win.surface(down[1], down[2], *down[0][1:], down[3], tall)
        share, n_differ = win.preference(upper, other, tall)
        margin = OVERTURNED_MARGIN * down[1].height * down[3]
        if win.bloom > 0:  # spread by the beam, the two surfaces lie nearer each other
            margin = min(margin, OVERTURNED_SEPARATION * win.separation(upper, other, tall))
        if n_differ < _MIN_DIFFER:
            note = (f"{n_differ} cells where upright and {down[2]} differ (fewer than {_MIN_DIFFER}): "
                    "its orientation cannot be told")
        else:
            overturned = bool(upright - turned >= margin and share >= OVERTURNED_SHARE)
            if not overturned and win.bloom > 0 and share >= UNTOLD_SHARE:
                overturned = None  # the soundings do not side with upright
                note = (f"upright and {down[2]} {UNTOLD}: {share:.0%} of the "
                        f"{n_differ} cells where they differ side with {down[2]}")
    chosen = up if overturned is False else down if overturned else best
    assert chosen is not None
    (m, x, y, b), resting = chosen[0], chosen[2] if overturned is not None else ""
    if win.bloom > 0:  # how well it fits: as the beam hears it, or as its soundings show once the
        # bloom beyond its footprint is off (the chain's own unbloom), whichever holds better
        thin = _best_pose(_Window(win.xy, win.heights), chosen[1], chosen[2], x, y, chosen[3],
                          np.array([b - 4.0, b, b + 4.0]))
        m = min(m, thin[0])
    return Rest(chosen[1].name, resting, overturned, m, upright, turned, x, y, b % 360.0, note=note,
                turned_share=share, n_differ=n_differ)


#: Largest misfit (a share of the orientation's own height, mean absolute) at which a unit
#: no upright design fits is still taken for an overturned one of its design.
OVERTURNED_FIT = 0.25


def with_rest(reef: Reef, rows: np.ndarray, own: np.ndarray, points: np.ndarray, height: np.ndarray,
              designs: Sequence[ReefDesign], *, noise: float, ping: np.ndarray | None = None,
              pose: tuple[float, float, float, float] | None = None, cone: np.ndarray | None = None) -> Reef:
    """``reef`` with how it rests (:func:`rest_of`): its top's tilt, and with designs its
    best orientation and whether it is overturned.

    Parameters
    ----------
    reef : Reef
        Its ``design`` (when an upright fit chose one) limits the comparison to that design.
    rows : ndarray of int
        The soundings around it (rows of ``points``), its own among them.
    own : ndarray of int
        Its own soundings.
    points, height : ndarray
        All soundings (N, 3) and their heights above the seabed (N,).
    designs : sequence of ReefDesign
    noise : float
        The soundings' vertical 1-sigma (m).
    ping : ndarray of int, shape (N,), optional
    pose : (x, y, bearing_deg, scale), optional
        The upright fit's design origin, bearing and scale.
    cone : ndarray, shape (N,), optional
        Told the beam, each sounding's cone's radius (m); the unit's own soundings' median is
        its ``bloom`` (:func:`rest_of`).
    """
    rows = np.union1d(rows, own)
    mine = np.isin(rows, own)
    bloom = float(np.median(cone[own])) if cone is not None and len(own) else 0.0
    rest = rest_of(points[rows], height[rows], mine, designs, noise=noise,
                   ping=None if ping is None else ping[rows], design=reef.design, pose=pose, bloom=bloom)
    return replace(reef, top_tilt_deg=rest.top_tilt_deg, top_tilt_sigma_deg=rest.top_tilt_sigma_deg,
                   resting=rest.resting, overturned=rest.overturned, resting_misfit=rest.misfit,
                   resting_note=rest.note,
                   design=reef.design or (rest.design if rest.overturned else ""))


def overturned_unit(reef: Reef, designs: Sequence[ReefDesign]) -> bool:
    """Whether a unit that no upright design fits is one of them overturned
    (:data:`OVERTURNED_FIT`)."""
    d = next((d for d in designs if d.name == reef.design), None)
    if d is None or not reef.overturned:
        return False
    tall = max(float(surface_map(d, reef.resting)[0].max()), d.height)
    return bool(reef.resting_misfit <= OVERTURNED_FIT * tall)
