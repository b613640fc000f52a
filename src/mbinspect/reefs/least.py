"""Each reef's and each other object's least depth (:mod:`mbinspect.least_depth`), with the
disagreement of the lines that sounded it as the height's systematic part."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TypeVar

import numpy as np

from ..least_depth import least_depth
from .reject import Context
from .shape import line_levels

__all__ = ["with_least_depth"]

T = TypeVar("T")


def with_least_depth(obj: T, rows: np.ndarray, context: Context, min_clearance: float | None,
                     noise: float | None = None) -> T:
    """``obj`` (a :class:`~mbinspect.reefs.Reef` or an ``OtherObject``) with its least depth
    from its soundings ``rows`` (of ``context.points``).

    The lines' levels around it (:func:`~mbinspect.reefs.shape.line_levels`, their
    spread) are the height's systematic 1-sigma; one line, or no line field, leaves it
    unknown (the TVU then is, and the least depth says why). ``noise`` is the soundings'
    vertical 1-sigma (m; the seabed's spread about its fitted surface), else measured on
    the object.
    """
    pts = context.points[rows]
    ping = None if context.ping is None else context.ping[rows]
    lift = None if context.reach is None else context.reach[rows]
    ld = least_depth(pts, ping=ping, level_sigma=_level_sigma(pts, rows, context), noise=noise, lift=lift)
    return replace(obj, least=ld.fields(min_clearance))  # type: ignore[type-var]


def _level_sigma(pts: np.ndarray, rows: np.ndarray, context: Context) -> float:
    """The spread (m, 1-sigma) of the levels of the lines around the soundings; NaN with one
    line or none known."""
    if context.line is None or context.ground is None:
        return math.nan
    lines = np.asarray(context.line)[rows]
    if len(np.unique(lines)) < 2:
        return math.nan
    levels = line_levels(pts[:, :2], lines, context.ground)
    per_line = np.array([levels[lines == k][0] for k in np.unique(lines)])
    return float(per_line.std(ddof=1))
