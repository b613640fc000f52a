"""Stage 6: each measured pile judged: the reasons its data cannot support a centimetre
answer become flags on the reported pile."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .options import PileOptions
from .results import PileFit, PileMeasure

__all__ = ["PLAN_FLAG", "assess_pile", "other_method_piles", "plan_flag"]

#: How the flag of a plan 1-sigma over ``max_sigma`` begins (:func:`plan_flag`).
PLAN_FLAG = "plan uncertainty "


def plan_flag(sigma: float, max_sigma: float) -> str:
    """The flag of a plan 1-sigma (m) over ``max_sigma`` (m)."""
    return (f"{PLAN_FLAG}{1000 * sigma:.1f} mm (1 sigma) exceeds {1000 * max_sigma:.1f} mm: "
            "the data cannot support a centimetre answer")


def assess_pile(pid: int, m: PileMeasure, options: PileOptions) -> PileFit:
    """The reported pile with its flags: few top or side points, a narrow scanned arc, a
    plan 1-sigma above ``max_sigma``, a radius the points reject, a partly covered top.

    Parameters
    ----------
    pid : int
        The pile's id.
    m : PileMeasure
        The last iteration's measure.
    options : PileOptions
        ``min_top``, ``min_side``, ``min_coverage_deg``, ``max_sigma`` and ``radius``.

    Returns
    -------
    PileFit

    Examples
    --------
    >>> import numpy as np
    >>> m = PileMeasure(0.0, 0.0, -16.0, "centre", np.eye(2) * 1e-4, 0.01, 0.01, 5, 0)
    >>> assess_pile(1, m, PileOptions(radius=0.75)).flags[0]
    'few top points: 5 < 20'
    """
    o = options
    flags = list(m.flags)
    if m.n_top < o.min_top:
        flags.append(f"few top points: {m.n_top} < {o.min_top}")
    if m.method != "centre" and m.n_side < o.min_side:
        flags.append(f"few side points: {m.n_side} < {o.min_side}")
    if m.method != "centre" and m.coverage < o.min_coverage_deg:
        flags.append(f"side scanned over {m.coverage:.0f} deg < {o.min_coverage_deg:.0f} deg")
    if not (m.sigma_xy <= o.max_sigma):
        flags.append(plan_flag(m.sigma_xy, o.max_sigma))
    if m.radius_fitted is not None and abs(m.radius_fitted - o.radius) > max(0.03, 0.05 * o.radius):
        flags.append(f"the points show a radius of {m.radius_fitted:.3f} m, not the prior "
                     f"{o.radius:.3f} m")
    if m.method == "centre" and m.top_coverage is not None and m.top_coverage < 0.8:
        flags.append(f"top face only {100 * m.top_coverage:.0f} % covered: the centre "
                     "method's mean is biased toward the scanned part")
    return PileFit(
        id=pid, x=m.x, y=m.y, z=m.z, radius=m.radius_used if m.radius_used is not None else o.radius,
        tilt_deg=m.tilt_deg, tilt_azimuth_deg=m.tilt_azimuth_deg, method=m.method, n_top=m.n_top,
        n_side=m.n_side, side_coverage_deg=m.coverage, rms=m.rms, sigma_xy=m.sigma_xy,
        flags=tuple(flags), radius_fitted=m.radius_fitted, top_coverage=m.top_coverage,
        alternatives=m.alternatives, line_sigma_xy=m.line_sigma_xy,
        jackknife=m.jackknife, tilt_held=m.tilt_held)


def other_method_piles(piles: tuple[PileFit, ...], radius: float
                       ) -> tuple[tuple[PileFit, ...], dict[int, np.ndarray], tuple[PileFit, ...]]:
    """With both methods: the centre method's piles beside the intersection method's.

    Parameters
    ----------
    piles : tuple of PileFit
        The reported piles, each with both centres in ``alternatives``.
    radius : float
        The prior radius (m), the centre method's.

    Returns
    -------
    centre_piles : tuple of PileFit
        One per pile that has a centre-method answer.
    covariances : dict
        Pile id -> the centre method's plan covariance (2, 2).
    piles : tuple of PileFit
        The reported piles with the covariances left out of ``alternatives`` (not JSON).
    """
    alt = tuple(
        PileFit(id=p.id, x=c["x"], y=c["y"], z=c["z"], radius=radius, tilt_deg=None,
                tilt_azimuth_deg=None, method="centre", n_top=p.n_top, n_side=0,
                side_coverage_deg=0.0, rms=0.0, sigma_xy=c["sigma_xy"],
                top_coverage=c.get("top_coverage"), group=p.group)
        for p in piles if (c := p.alternatives.get("centre")) is not None)
    covs = {p.id: np.asarray(p.alternatives["centre"]["cov"]) for p in piles if "centre" in p.alternatives}
    stripped = tuple(replace(p, alternatives={k: {kk: vv for kk, vv in v.items() if kk != "cov"}
                                              for k, v in p.alternatives.items()}) for p in piles)
    return alt, covs, stripped
