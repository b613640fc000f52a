"""Stage 5, last: the errors a line shares, from the lines' disagreement (issue 12).

The model covariance of a pile centre counts each sounding's noise as independent, so
averaging hundreds of soundings makes it tiny. Real errors shared by all the soundings of
one survey line (its height offset, its sound-speed "smile", a roll bias) do not average
out: a pile seen by five lines carries five such errors. When a pile's soundings come from
at least three lines, it is measured again without each line in turn, and the spread of
those centres (the delete-one jackknife) is added to its covariance.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..errors import DataError
from .measure import measure_pile
from .options import PileOptions
from .results import PileMeasure, PileSegment

__all__ = ["line_jackknife", "MIN_LINES"]

#: Fewest lines whose soundings a pile must hold for the jackknife.
MIN_LINES = 3


def line_jackknife(seg: PileSegment, top_m: np.ndarray, side_m: np.ndarray, normals: np.ndarray,
                   fit: PileMeasure, options: PileOptions, seed: int) -> PileMeasure:
    """``fit`` with the covariance of its centre widened by the line-wise jackknife.

    Parameters
    ----------
    seg : PileSegment
        With ``line`` per point (otherwise ``fit`` is returned as it is).
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
        from it; ``line_sigma_xy`` the jackknife part alone (NaN when not computed).

    Examples
    --------
    >>> from mbinspect.simulate import simulate
    >>> from mbinspect.piles import locate_piles
    >>> sim = simulate("jacket", seed=2, ping_spacing=0.3)
    >>> res = locate_piles(sim.cloud, count=4, radius=0.75)
    >>> all(p.line_sigma_xy > 0 for p in res.piles)
    True
    """
    if seg.line is None:
        return fit
    used = top_m | side_m
    lines = np.unique(seg.line[used])
    if len(lines) < MIN_LINES:
        return fit
    centres = []
    for ln in lines:
        keep = seg.line != ln
        try:
            m = measure_pile(seg, top_m & keep, side_m & keep, normals[keep[side_m]], options=options,
                             seed=seed, previous=fit)
        except DataError:
            continue
        centres.append((m.x, m.y))
    if len(centres) < MIN_LINES:
        return fit
    c = np.asarray(centres)
    d = c - c.mean(axis=0)
    jack = (len(c) - 1) / len(c) * (d.T @ d)
    cov = np.asarray(fit.cov)[:2, :2] + jack
    return replace(fit, cov=cov, sigma_xy=math.sqrt(max(float(cov[0, 0] + cov[1, 1]) / 2, 0.0)),
                   line_sigma_xy=math.sqrt(max(float(jack[0, 0] + jack[1, 1]) / 2, 0.0)))
