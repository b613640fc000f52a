"""Stage 6b: only piles are piles. A measured candidate that cannot be a standing pile
(its top not above the seabed, leaning past ``max_tilt_deg``, or a radius far from the
prior), or that could only be given a centre from a handful of top points, from a small
part of a top with no side, or from a thin side and a few top points, is taken out of the
answer and listed with the reasons."""

from __future__ import annotations

import numpy as np

from .options import PileOptions
from .results import PileFit, RejectedPile

__all__ = ["MIN_SIDE", "MIN_TOP_SHARE", "RADIUS_RATIO", "rejected_record", "rejection_reasons"]

#: A fitted radius outside ``prior / RADIUS_RATIO`` to ``prior * RADIUS_RATIO`` is not this pile.
RADIUS_RATIO = 1.6

#: A candidate with fewer side points than MIN_SIDE (no side to fit) and less than
#: MIN_TOP_SHARE of a top disc covered cannot be told from any other raised object.
MIN_SIDE = 6
MIN_TOP_SHARE = 0.5


def rejection_reasons(pile: PileFit, top_height: float, options: PileOptions) -> list[str]:
    """Why ``pile`` cannot be a standing pile (empty when it can).

    Parameters
    ----------
    pile : PileFit
        A measured candidate.
    top_height : float
        Height (m) of its top above the seabed around it.
    options : PileOptions
        ``radius``, ``max_tilt_deg`` and ``min_top``.

    Returns
    -------
    list of str

    Examples
    --------
    >>> p = PileFit(1, 0.0, 0.0, -20.4, 0.75, 3.8, 0.0, "intersection", 9, 721, 35.0, 0.01, 0.03,
    ...             radius_fitted=0.31)
    >>> [r.split(":")[0].split(" (")[0] for r in rejection_reasons(p, -11.9, PileOptions(radius=0.75))]
    ['not measurable', 'top 11.9 m below the seabed around it', 'radius 0.31 m against the prior 0.75 m']
    """
    reasons = []
    if pile.method == "centre" and pile.n_top < options.min_top:
        reasons.append(f"not measurable: a centre from only {pile.n_top} top points (`min_top` "
                       f"{options.min_top}) and {pile.n_side} side points")
    elif pile.method != "centre" and pile.n_top < options.min_top and (
            pile.n_side < options.min_side or pile.side_coverage_deg < options.min_coverage_deg):
        reasons.append(f"not measurable: {pile.n_top} top points (`min_top` {options.min_top}) and a side "
                       f"too thin to hold the axis ({pile.n_side} points over "
                       f"{pile.side_coverage_deg:.0f} deg; `min_side` {options.min_side}, "
                       f"`min_coverage_deg` {options.min_coverage_deg:g})")
    elif (pile.n_side < MIN_SIDE and pile.top_coverage is not None
          and pile.top_coverage < MIN_TOP_SHARE):
        reasons.append(f"not measurable: {pile.n_side} side points and only "
                       f"{100 * pile.top_coverage:.0f} % of a top: nothing shows a pile")
    if not top_height > 0:
        reasons.append(f"top {-top_height:.1f} m below the seabed around it")
    if pile.tilt_deg is not None and pile.tilt_deg > options.max_tilt_deg:
        reasons.append(f"leans {pile.tilt_deg:.1f} deg, more than `max_tilt_deg` {options.max_tilt_deg:g}")
    r = pile.radius_fitted
    if r is not None and not (options.radius / RADIUS_RATIO <= r <= options.radius * RADIUS_RATIO):
        reasons.append(f"radius {r:.2f} m against the prior {options.radius:g} m")
    return reasons


def rejected_record(pile: PileFit, top_height: float, reasons: list[str]) -> RejectedPile:
    """What a result lists of a rejected candidate."""
    return RejectedPile(pile.x, pile.y, pile.z, float(np.round(top_height, 3)), pile.tilt_deg,
                        pile.radius_fitted, tuple(reasons))
