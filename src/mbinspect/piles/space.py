"""Stage 7: every pile-to-pile spacing with its 1-sigma, against the design."""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np

from .design import Design
from .results import PileFit, Spacing

__all__ = ["spacings"]


def spacings(piles: Sequence[PileFit], covs: dict[int, np.ndarray], design: Design | None,
             tolerance: float, *, method: str) -> tuple[Spacing, ...]:
    """The plan distance of every pair of piles, its 1-sigma, and the design's verdict.

    The 1-sigma is the two centres' plan covariances projected on the line between them.

    Parameters
    ----------
    piles : sequence of PileFit
    covs : dict
        Pile id -> plan covariance (2, 2) (m²).
    design : Design, optional
        Design distances to compare with.
    tolerance : float
        Largest deviation from the design that passes (m).
    method : str
        The centre method the spacings come from (recorded on each).

    Returns
    -------
    tuple of Spacing
        Pairs (a, b) with a < b, in id order.

    Examples
    --------
    >>> a = PileFit(1, 0.0, 0.0, -16.0, 0.75, None, None, "centre", 50, 0, 0.0, 0.0, 0.001)
    >>> b = PileFit(2, 22.01, 0.0, -16.0, 0.75, None, None, "centre", 50, 0, 0.0, 0.0, 0.001)
    >>> s, = spacings([a, b], {1: np.eye(2) * 1e-6, 2: np.eye(2) * 1e-6},
    ...               Design(positions={1: (0, 0), 2: (22, 0)}), 0.05, method="centre")
    >>> round(s.distance, 3), round(s.deviation, 3), s.passed
    (22.01, 0.01, True)
    """
    out = []
    for a, b in itertools.combinations(sorted(piles, key=lambda p: p.id), 2):
        d = np.array([b.x - a.x, b.y - a.y])
        dist = float(np.hypot(*d))
        u = d / max(dist, 1e-12)
        ca, cb = np.asarray(covs.get(a.id)), np.asarray(covs.get(b.id))
        var = float(u @ ca[:2, :2] @ u + u @ cb[:2, :2] @ u) if ca.ndim == 2 and cb.ndim == 2 else math.nan
        sigma = math.sqrt(var) if var >= 0 else math.nan
        ref = design.spacing(a.id, b.id) if design is not None else None
        dev = None if ref is None else dist - ref
        out.append(Spacing(a.id, b.id, dist, sigma, ref, dev,
                           None if dev is None else bool(abs(dev) <= tolerance), method))
    return tuple(out)
