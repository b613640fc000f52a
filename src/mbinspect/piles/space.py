"""Stage 7: every pile-to-pile spacing with its 1-sigma, against the design."""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np

from .design import Design
from .frame import decide
from .results import PileFit, Spacing

__all__ = ["spacings"]


def spacings(piles: Sequence[PileFit], covs: dict[int, np.ndarray], design: Design | None,
             tolerance: float, *, method: str, all_pairs: bool = True) -> tuple[Spacing, ...]:
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
    all_pairs : bool
        Every pair; else only pairs within a group (jacket). A cross-group pair has group 0.

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
    >>> s.verdict
    'pass'
    """
    out = []
    for a, b in itertools.combinations(sorted(piles, key=lambda p: (p.group, p.id)), 2):
        if a.group != b.group and not all_pairs:
            continue
        d = np.array([b.x - a.x, b.y - a.y])
        dist = float(np.hypot(*d))
        u = d / max(dist, 1e-12)
        ca, cb = np.asarray(covs.get(a.id)), np.asarray(covs.get(b.id))
        var = float(u @ ca[:2, :2] @ u + u @ cb[:2, :2] @ u) if ca.ndim == 2 and cb.ndim == 2 else math.nan
        sigma = math.sqrt(var) if var >= 0 else math.nan
        ref = design.spacing(a.id, b.id) if design is not None else None
        dev = None if ref is None else dist - ref
        verdict = None if dev is None else decide(dev, sigma, tolerance)
        passed = None if verdict in (None, "undecided") else verdict == "pass"
        out.append(Spacing(a.id, b.id, dist, sigma, ref, dev, passed, method, verdict,
                           a.group if a.group == b.group else 0))
    return tuple(out)
