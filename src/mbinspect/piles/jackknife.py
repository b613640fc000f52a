"""Stage 5, last: the errors a line shares, from the lines' disagreement (issue 12).

The model covariance of a pile centre counts each sounding's noise as independent, so
averaging hundreds of soundings makes it tiny. Real errors shared by all the soundings of
one survey line (its height offset, its sound-speed "smile", a roll bias) do not average
out: a pile seen by five lines carries five such errors. When a pile's soundings come from
at least three lines, it is measured again without each line in turn, and the spread of
those centres (the delete-one jackknife) is added to its covariance.

A pile seen by one or two lines (a native sonar file is one line) is measured again
without each of :data:`PING_BLOCKS` blocks of successive pings instead: errors shared by
neighbouring pings (a roll or heave that lasts, a refraction that drifts) and a narrow
scanned arc that leaves the centre loosely held both show in the blocks' disagreement,
where the model covariance, which takes pings as independent, would be too small.

Errors that every ping shares at the same beam angle (a refraction or roll bias, or, in a
real survey, seabed relief met at the same place across the swath by ping after ping) do not
show between blocks of pings. So a pile seen by one or two lines is also measured again
without each of :data:`SECTORS` sectors of beam angle (equal shares of its soundings), and
that jackknife's covariance is added too. Seen by three lines or more, the lines meet the
pile at different angles and their disagreement already holds such errors.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..errors import DataError
from .measure import measure_pile
from .options import PileOptions
from .results import PileMeasure, PileSegment, plan_sigma

__all__ = ["line_jackknife", "MIN_LINES", "PING_BLOCKS", "SECTORS"]

#: Fewest lines whose soundings a pile must hold for the jackknife over lines (and fewest
#: blocks or lines left measurable for either jackknife).
MIN_LINES = 3

#: Blocks of successive pings of the jackknife of a pile seen by fewer than MIN_LINES lines.
PING_BLOCKS = 5

#: Sectors of beam angle of the second jackknife of such a pile.
SECTORS = 5


def jackknife_units(seg: PileSegment, used: np.ndarray) -> tuple[np.ndarray | None, str]:
    """Each point's jackknife unit: its line when the used points span :data:`MIN_LINES`
    lines, else its block of successive pings (lines first, then ping numbers, in
    :data:`PING_BLOCKS` blocks of as many pings); (None, "") when neither is known.

    Examples
    --------
    >>> seg = PileSegment(np.zeros((10, 3)), np.ones(10, bool), np.zeros(10, bool),
    ...                   ping=np.arange(10) // 2)
    >>> units, kind = jackknife_units(seg, np.ones(10, bool))
    >>> units.tolist(), kind
    ([0, 0, 1, 1, 2, 2, 3, 3, 4, 4], 'ping blocks')
    """
    if seg.line is not None and len(np.unique(seg.line[used])) >= MIN_LINES:
        return np.asarray(seg.line), "lines"
    if seg.ping is None:
        return None, ""
    line = np.zeros(len(seg.ping), np.int64) if seg.line is None else np.asarray(seg.line, np.int64)
    _, key = np.unique(np.column_stack([line, np.asarray(seg.ping, np.int64)]), axis=0, return_inverse=True)
    key = key.ravel()
    seen = np.unique(key[used])  # sorted by line, then ping
    if len(seen) < MIN_LINES:
        return None, ""
    block = np.full(key.max() + 1, -1, np.int64)
    block[seen] = np.arange(len(seen)) * min(PING_BLOCKS, len(seen)) // len(seen)
    return block[key], "ping blocks"


def line_jackknife(seg: PileSegment, top_m: np.ndarray, side_m: np.ndarray, normals: np.ndarray,
                   fit: PileMeasure, options: PileOptions, seed: int) -> PileMeasure:
    """``fit`` with the covariance of its centre widened by the jackknife over lines (or over
    blocks of successive pings, :func:`jackknife_units`).

    Parameters
    ----------
    seg : PileSegment
        With ``line`` or ``ping`` per point (otherwise ``fit`` is returned as it is).
    top_m, side_m : ndarray of bool
        The points the fit used.
    normals : ndarray, shape (side_m.sum(), 3)
        Their side normals.
    fit : PileMeasure
        The pile measured on all of them.
    options : PileOptions
    seed : int

    Returns
    -------
    PileMeasure
        ``cov`` = model covariance + jackknife covariance of the plan centre, ``sigma_xy``
        from it; ``line_sigma_xy`` the jackknife part alone (NaN when not computed) and
        ``jackknife`` its units ("lines" or "ping blocks").

    Examples
    --------
    >>> from mbinspect.simulate import simulate
    >>> from mbinspect.piles import locate_piles
    >>> sim = simulate("jacket", seed=2, ping_spacing=0.3)
    >>> res = locate_piles(sim.cloud, count=4, radius=0.75)
    >>> all(p.line_sigma_xy > 0 for p in res.piles)
    True
    """
    used = top_m | side_m
    units, kind = jackknife_units(seg, used)
    if units is None:
        return fit
    found = _delete_one(seg, top_m, side_m, normals, fit, options, seed, units)
    if found is None:
        return fit
    jack, jack_r = found
    sectors = sector_units(seg, used) if kind == "ping blocks" else None
    if sectors is not None:
        by_angle = _delete_one(seg, top_m, side_m, normals, fit, options, seed, sectors)
        if by_angle is not None:
            jack, jack_r = jack + by_angle[0], jack_r + by_angle[1]
            kind = "ping blocks and beam-angle sectors"
    cov = np.asarray(fit.cov)[:2, :2] + jack
    # the free radius is shaken by the same shared errors as the centre
    r_sigma = math.sqrt(fit.radius_fitted_sigma**2 + jack_r) if math.isfinite(jack_r) \
        else fit.radius_fitted_sigma
    return replace(fit, cov=cov, sigma_xy=plan_sigma(cov), line_sigma_xy=plan_sigma(jack), jackknife=kind,
                   radius_fitted_sigma=r_sigma)


def sector_units(seg: PileSegment, used: np.ndarray) -> np.ndarray | None:
    """Each point's sector of beam angle: :data:`SECTORS` sectors holding equal shares of the
    used points (by the angle's size and side); None without beam angles or with too few
    distinct angles.

    Examples
    --------
    >>> seg = PileSegment(np.zeros((10, 3)), np.ones(10, bool), np.zeros(10, bool),
    ...                   beam_angle=np.linspace(20, 40, 10))
    >>> sector_units(seg, np.ones(10, bool)).tolist()
    [0, 0, 1, 1, 2, 2, 3, 3, 4, 4]
    """
    if seg.beam_angle is None:
        return None
    ang = np.asarray(seg.beam_angle, np.float64)
    if len(np.unique(ang[used])) < SECTORS:
        return None
    rank = np.searchsorted(np.sort(ang[used]), ang, side="right") - 1
    return np.clip(rank * SECTORS // int(used.sum()), 0, SECTORS - 1)


def _delete_one(seg: PileSegment, top_m: np.ndarray, side_m: np.ndarray, normals: np.ndarray,
                fit: PileMeasure, options: PileOptions, seed: int, units: np.ndarray
                ) -> tuple[np.ndarray, float] | None:
    """The delete-one jackknife covariance (2, 2) of the plan centre over ``units`` and the
    variance of the free radius (NaN where it was not fitted in every case); None when fewer
    than :data:`MIN_LINES` of them leave a measurable pile."""
    used = top_m | side_m
    centres, radii = [], []
    for ln in np.unique(units[used]):
        keep = units != ln
        try:
            m = measure_pile(seg, top_m & keep, side_m & keep, normals[keep[side_m]], options=options,
                             seed=seed, previous=fit, gradient=False)
        except DataError:
            continue
        centres.append((m.x, m.y))
        radii.append(math.nan if m.radius_fitted is None else m.radius_fitted)
    if len(centres) < MIN_LINES:
        return None
    c = np.asarray(centres)
    d = c - c.mean(axis=0)
    k = (len(c) - 1) / len(c)
    r = np.asarray(radii)
    return k * (d.T @ d), k * float(np.sum((r - r.mean()) ** 2))
