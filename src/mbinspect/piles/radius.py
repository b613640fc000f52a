"""Stage 5, after: one radius for the piles of a run, when the data reject the prior (issue 12).

The piles of a jacket are made to one design radius. Each pile measured by the
intersection method also gives the radius its side shows when fitted freely, with a
1-sigma that is cluster-robust by ping; a pile whose side is scanned over a narrow arc
gives a loose one. The weighted mean of those radii is far tighter than any one pile's,
so a prior that is off by a few centimetres is seen even where no single pile could show
it (``radius_mode="auto"`` frees a pile's radius only when its own side rejects the
prior). When the joint radius rejects the prior, every pile is measured again with it,
and the result says so; the prior stays in the parameters.

Either way the radius in use is known only so well: to the joint radius's 1-sigma when it
replaced the prior, and, when the prior stands, to that 1-sigma or as far as the joint
radius lies from the prior, whichever is larger. :func:`with_radius_sigma` carries that
into each centre's covariance through the way the centre moves with the radius (about a
centimetre per centimetre for a pile seen from one side, nothing for one seen all round).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from .results import PileMeasure, plan_sigma

__all__ = ["JointRadius", "MIN_PILES", "MIN_SHIFT", "joint_radius", "with_radius_sigma"]

#: Fewest piles whose free radii make a joint radius.
MIN_PILES = 2

#: The smallest difference from the prior (m) that can reject it, however tight the joint
#: radius (a millimetre or two is within what the free fits' small biases leave).
MIN_SHIFT = 0.005


@dataclass(frozen=True)
class JointRadius:
    """The piles' joint radius (m) and its 1-sigma, from how many piles, against the prior;
    ``spread`` is the chi-square per degree of freedom of the piles about it (a spread far
    above 1 says the piles do not share one radius: the sigma is widened by its root)."""

    radius: float
    sigma: float
    piles: int
    prior: float
    spread: float

    @property
    def rejects_prior(self) -> bool:
        """Whether the data reject the prior: off by more than 3 sigma and :data:`MIN_SHIFT`."""
        return abs(self.radius - self.prior) > max(3 * self.sigma, MIN_SHIFT)

    @property
    def note(self) -> str:
        return (f"radius prior {self.prior:.3f} m rejected by the data: the piles' joint radius "
                f"{self.radius:.3f} ± {self.sigma:.3f} m (1 sigma, {self.piles} piles) was used")

    def to_dict(self) -> dict[str, Any]:
        return {"radius": self.radius, "sigma": self.sigma, "piles": self.piles, "prior": self.prior,
                "spread": self.spread, "rejects_prior": self.rejects_prior}


def joint_radius(measures: Mapping[int, PileMeasure], prior: float, *, min_coverage_deg: float = 60.0
                 ) -> JointRadius | None:
    """The weighted mean of the piles' free radii (None from fewer than :data:`MIN_PILES`).

    Parameters
    ----------
    measures : mapping
        Pile id -> its measure; those by the intersection method, with a free radius and
        its 1-sigma and a side scanned over at least ``min_coverage_deg``, count.
    prior : float
        The prior radius (m).
    min_coverage_deg : float
        The narrowest side arc (deg) whose free radius counts.

    Examples
    --------
    >>> from mbinspect.piles import PileMeasure
    >>> ms = {i: PileMeasure(0, 0, 0, "intersection", np.eye(2), 0.0, 0.0, 50, 500, coverage=120.0,
    ...                      radius_fitted=r, radius_fitted_sigma=0.004)
    ...       for i, r in enumerate([0.748, 0.753])}
    >>> j = joint_radius(ms, 0.80)
    >>> round(j.radius, 4), round(j.sigma, 4), j.rejects_prior
    (0.7505, 0.0028, True)
    """
    r, s = [], []
    for m in measures.values():
        sig = m.radius_fitted_sigma
        if (m.method == "intersection" and m.radius_fitted is not None and m.coverage >= min_coverage_deg
                and math.isfinite(sig) and sig > 0):
            r.append(m.radius_fitted)
            s.append(sig)
    if len(r) < MIN_PILES:
        return None
    ra, w = np.asarray(r), 1.0 / np.asarray(s) ** 2
    mean = float((w * ra).sum() / w.sum())
    spread = float((w * (ra - mean) ** 2).sum() / (len(ra) - 1))
    sigma = math.sqrt(1.0 / float(w.sum())) * math.sqrt(max(1.0, spread))
    return JointRadius(mean, sigma, len(ra), float(prior), spread)


def with_radius_sigma(m: PileMeasure, sigma: float) -> PileMeasure:
    """``m`` with its plan covariance widened by a radius known to ``sigma`` (m): the
    centre's gradient with the radius held fixed, squared, times ``sigma`` squared. A pile
    seen from one side moves about a centimetre toward the sonar for each centimetre of
    radius too small; a pile seen all round does not move.

    Examples
    --------
    >>> from mbinspect.piles import PileMeasure
    >>> m = PileMeasure(0, 0, 0, "intersection", np.eye(2) * 1e-6, 0.001, 0.0, 50, 500,
    ...                 radius_gradient=(-1.0, 0.0))
    >>> round(with_radius_sigma(m, 0.02).sigma_xy, 4)
    0.0142
    """
    g = m.radius_gradient
    if g is None or not sigma > 0:
        return m
    cov = np.asarray(m.cov, float) + sigma**2 * np.outer(g, g)
    return replace(m, cov=cov, sigma_xy=plan_sigma(cov))
