"""Stage 8: each jacket's prefabricated frame fitted to the measured centres, with a verdict."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy.optimize import least_squares

from .design import Design
from .pairs import Level
from .results import FrameFit, PileFit

__all__ = ["fit_frames", "decide", "leg_shims"]

#: Two-sided 95 % factor.
Z95 = 1.96


def decide(miss: float, sigma: float, tolerance: float) -> str:
    """``pass``, ``fail`` or ``undecided`` at 95 % for a miss (m) with its 1-sigma (m).

    Parameters
    ----------
    miss : float
        The deviation from the design (absolute value taken).
    sigma : float
        Its 1-sigma; NaN counts as unknown (never ``pass``).
    tolerance : float

    Returns
    -------
    str

    Examples
    --------
    >>> decide(0.01, 0.005, 0.05), decide(0.045, 0.005, 0.05), decide(0.09, 0.005, 0.05)
    ('pass', 'undecided', 'fail')
    """
    s = sigma if math.isfinite(sigma) else math.inf
    if abs(miss) + Z95 * s <= tolerance:
        return "pass"
    if abs(miss) - Z95 * (sigma if math.isfinite(sigma) else 0.0) > tolerance:
        return "fail"
    return "undecided"


def _fit_one(design_xy: np.ndarray, measured: np.ndarray, covs: Sequence[np.ndarray]
             ) -> tuple[float, np.ndarray, np.ndarray]:
    """Rotation (rad) and shift of the template onto the centres, weighted, and each residual."""
    origin = design_xy.mean(axis=0)
    d = design_xy - origin
    # both sides centred, so the solver's tolerances act on millimetres wherever either frame lies
    centre = measured.mean(axis=0)
    m_local = measured - centre
    whiten = [np.linalg.cholesky(np.linalg.inv(c + np.eye(2) * 1e-8)).T for c in covs]

    def residual(q: np.ndarray) -> np.ndarray:
        c, s = math.cos(q[0]), math.sin(q[0])
        placed = d @ np.array([[c, s], [-s, c]]) + q[1:]
        return np.concatenate([w @ (m - p) for w, m, p in zip(whiten, m_local, placed, strict=True)])

    q = least_squares(residual, np.zeros(3), xtol=1e-12, ftol=1e-12).x
    c, s = math.cos(q[0]), math.sin(q[0])
    placed = d @ np.array([[c, s], [-s, c]]) + q[1:]
    return float(q[0]), q[1:] + centre - origin, m_local - placed


def fit_frames(piles: Sequence[PileFit], covs: dict[int, np.ndarray], design: Design | None, *,
               tolerance: float, shims: dict[int, tuple[float, float]] | None = None
               ) -> tuple[FrameFit, ...]:
    """Per group of at least three piles with design positions, the frame fit and its verdict.

    Parameters
    ----------
    piles : sequence of PileFit
        With their design ids and groups.
    covs : dict
        Pile id -> plan covariance of its centre (2, 2), m².
    design : Design, optional
        Positions are needed; none: no frame is fitted.
    tolerance : float
        How far a pile may miss the fitted frame (m).
    shims : dict, optional
        Pile id -> the packing (m) and its 1-sigma its leg needs under a level frame
        (:func:`~mbinspect.piles.level.leg_shims`), given in each row as ``shim`` and
        ``shim_sigma``.

    Returns
    -------
    tuple of FrameFit

    Examples
    --------
    >>> from mbinspect.piles import PileFit
    >>> d = Design(positions={1: (0, 0), 2: (14, 0), 3: (0, 14), 4: (14, 14)})
    >>> ps = [PileFit(i, x + 0.3, y - 0.2, -8.0, 0.6, None, None, "centre", 50, 0, 0.0, 0.0, 0.001)
    ...       for i, (x, y) in d.positions.items()]
    >>> f, = fit_frames(ps, {i: np.eye(2) * 1e-6 for i in d.positions}, d, tolerance=0.05)
    >>> round(f.shift_x, 3), round(f.shift_y, 3), f.verdict
    (0.3, -0.2, 'pass')
    """
    if design is None or not design.positions:
        return ()
    out = []
    for g in sorted({p.group for p in piles}):
        members = [p for p in piles if p.group == g and p.id in design.positions]
        if len(members) < 3:
            continue
        dxy = np.array([design.positions[p.id] for p in members], np.float64)
        mxy = np.array([[p.x, p.y] for p in members])
        cv = [np.asarray(covs.get(p.id, np.eye(2) * 1e-4))[:2, :2] for p in members]
        cv = [c if np.isfinite(c).all() else np.eye(2) * 1e-2 for c in cv]
        angle, shift, res = _fit_one(dxy, mxy, cv)
        # a residual's spread: its centre's plan sigma, widened by the 4 fitted of 2K numbers
        widen = math.sqrt(len(members) * 2 / max(len(members) * 2 - 3, 1))
        rows, verdicts = [], []
        for p, r, c in zip(members, res, cv, strict=True):
            miss = float(np.hypot(*r))
            sigma = widen * math.sqrt(max(float(np.trace(c)) / 2, 0.0))
            verdict = decide(miss, sigma, tolerance)
            verdicts.append(verdict)
            row = {"id": p.id, "dx": float(r[0]), "dy": float(r[1]), "miss": miss, "sigma": sigma,
                   "miss_95": miss + Z95 * sigma, "verdict": verdict}
            if shims and p.id in shims:
                row["shim"], row["shim_sigma"] = shims[p.id]
            rows.append(row)
        overall = "fail" if "fail" in verdicts else ("undecided" if "undecided" in verdicts else "pass")
        out.append(FrameFit(g, math.degrees(angle), float(shift[0]), float(shift[1]), tuple(rows), tolerance,
                            overall))
    return tuple(out)


def leg_shims(piles: Sequence[PileFit], levels: Sequence[Level]) -> dict[int, tuple[float, float]]:
    """The packing (m) each pile needs under a level frame resting on its jacket's highest
    sounded top, with its 1-sigma (from the pair's level difference; NaN where a top was
    not sounded).

    Examples
    --------
    >>> from mbinspect.piles.results import PileFit
    >>> p = [PileFit(i, 0.0, 0.0, z, 0.75, None, None, "intersection", 50, 50, 360, 0.01, 0.002, top_z=z)
    ...      for i, z in ((1, -16.0), (2, -16.03))]
    >>> shim, sigma = leg_shims(p, [Level(1, 1, 2, -0.03, 0.004)])[2]
    >>> round(shim, 6), sigma
    (0.03, 0.004)
    """
    by_pair = {(lv.a, lv.b): lv for lv in levels}
    out: dict[int, tuple[float, float]] = {}
    for g in sorted({p.group for p in piles}):
        members = [p for p in piles if p.group == g and p.top_z is not None]
        sounded = [p for p in members if not p.top_z_lower_bound] or members
        if not sounded:
            continue
        high = max(sounded, key=lambda p: float(p.top_z))  # type: ignore[arg-type]
        for p in members:
            pair = by_pair.get((high.id, p.id)) or by_pair.get((p.id, high.id))
            sigma = 0.0 if p.id == high.id else math.nan if pair is None or pair.lower_bound else pair.sigma
            out[p.id] = (float(high.top_z) - float(p.top_z), sigma)  # type: ignore[arg-type]
    return out
