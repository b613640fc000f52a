"""The registration's plan shift refined on the objects that kept their place.

A smooth seabed barely holds a plan shift (the reef field's, 4 cm of roughness at 2 m: 3-5 cm
1-sigma), where the objects on it are sharp marks: each matched pair's apparent move, after the
seabed's registration, is what is left of the shift plus that unit's own move and its centres'
noise. Most units do not move between two surveys. The units whose moves agree (within three
robust spreads of their median, iterated) are taken as unmoved when they are at least
:data:`MIN_TIES` and a majority of the matched; their mean move is an estimate of the residual
shift independent of the seabed's (their centres' noise, not the seabed's texture), and the two
are combined by their variances. Their shift's 1-sigma is their scatter over their number
with what they share in one survey (:data:`SHARED`).

A shift shared by most units is the survey's only when the seabed allows it: the objects'
estimate is used only within :data:`AGREE` combined sigmas of the seabed's, else the seabed's
stands and the note says the units moved together. A common move of the units smaller than
that is taken as the survey's: the seabed cannot tell the two apart.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .register import IDENTITY, Registration

__all__ = ["tie_to_objects", "MIN_TIES", "PILE_TIES", "AGREE"]

#: Fewest unmoved objects that refine a registration.
MIN_TIES = 5

#: Fewest unmoved piles that refine it: three of a jacket's four, whose top centres agree to
#: millimetres where reefs' centres scatter by centimetres.
PILE_TIES = 3

#: The objects' shift is used within this many combined sigmas of the seabed's.
AGREE = 3.0

#: Rounds of the robust selection of the unmoved objects.
ROUNDS = 3

#: A floor (m) on the robust spread of the moves: centres quoted to the millimetre can agree
#: better than their objects are placed.
FLOOR = 0.005

#: What the objects' centres in one survey share (m, 1-sigma per axis), which their number does
#: not average: the survey's lines, motion and beam place every unit alike. Measured (issue
#: 29's study, 10 pairs of reef-field surveys): the shift's error 4 mm RMS per axis where the
#: units' scatter said 3 mm (80 % within 2 sigma), and 7-12 mm on the classic sonar where it
#: said 1-2 mm (70 %).
SHARED = 0.01


def _unmoved(moves: np.ndarray, noise: float, least: int, floor: float) -> np.ndarray:
    """Which moves (n, 2) agree: within three robust spreads of their median in both axes,
    the spread never over ``noise`` (where most units moved, theirs would take them all)."""
    keep = np.ones(len(moves), bool)
    for _ in range(ROUNDS):
        centre = np.median(moves[keep], axis=0)
        spread = np.clip(1.4826 * np.median(np.abs(moves[keep] - centre), axis=0), floor, noise)
        now = np.all(np.abs(moves - centre) <= 3.0 * spread, axis=1)
        if now.sum() < least or (now == keep).all():
            return now
        keep = now
    return keep


def tie_to_objects(reg: Registration, before_xy: np.ndarray, after_xy: np.ndarray,
                   pairs: list[tuple[int, int]], *, noise: float = 0.07, least: int = MIN_TIES,
                   floor: float = FLOOR) -> Registration:
    """``reg`` with its plan shift refined on the matched objects that did not move.

    Parameters
    ----------
    reg : Registration
        The seabed's registration (left as it is when it is :data:`~.register.IDENTITY`:
        with no seabed to check them, the objects' common move cannot be told from the
        survey's).
    before_xy, after_xy : ndarray, shape (n, 2)
        Object positions, the after survey's carried into the before frame by ``reg``.
    pairs : list of (i, j)
        The matched objects (:func:`~mbinspect.change.match.match_objects`).
    noise : float
        The most an unmoved object's apparent move may scatter (m, 1-sigma per axis: both
        surveys' centres); the robust spread of the moves is capped at it.
    least : int
        Fewest unmoved objects that refine the shift (and a majority of the matched).
    floor : float
        The least robust spread of the moves (m): a few objects' median deviation can fall
        far below their centres' noise, which ``floor`` then stands for.

    Returns
    -------
    Registration
        With ``dx``, ``dy``, their sigmas and covariance from both estimates, ``ties`` the
        objects used, and the note saying so (or why the objects were not used).

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> b = rng.uniform(0, 100, (20, 2))
    >>> a = b + [0.04, -0.03] + rng.normal(0, 0.02, (20, 2))
    >>> a[:3] += 1.0  # three units moved a metre
    >>> cov = np.diag([0.04**2, 0.04**2, 0.001**2, 0.0])
    >>> seabed = Registration(0.1, 0.2, 0.0, 0.0, 0.04, 0.04, 0.001, math.nan, (50.0, 50.0),
    ...                       1e4, 10000, 0.02, 20, "", cov)
    >>> tied = tie_to_objects(seabed, b, a, [(k, k) for k in range(20)])
    >>> tied.ties, round(tied.dx, 2), round(tied.dy, 2), round(tied.sigma_dx, 3)
    (17, 0.13, 0.17, 0.01)
    """
    if reg is IDENTITY or not (math.isfinite(reg.sigma_dx) and math.isfinite(reg.sigma_dy)) or not pairs:
        return reg
    i, j = np.array(pairs).T
    moves = np.asarray(after_xy, np.float64)[j] - np.asarray(before_xy, np.float64)[i]
    floor = max(floor, FLOOR)
    keep = _unmoved(moves, noise, least, floor)
    n = int(keep.sum())
    if n < least or 2 * n <= len(pairs):
        return dataclasses.replace(reg, note=_joined(reg.note, f"{n} of {len(pairs)} matched objects kept "
                                                     "together: too few to refine the plan shift on"))
    shift = moves[keep].mean(axis=0)
    sigma = np.hypot(np.maximum(moves[keep].std(axis=0, ddof=1), floor) / math.sqrt(n), SHARED)
    seabed = np.array([reg.sigma_dx, reg.sigma_dy])
    if np.any(np.abs(shift) > AGREE * np.hypot(seabed, sigma)):
        return dataclasses.replace(reg, note=_joined(
            reg.note, f"{n} of {len(pairs)} matched objects moved together by ({shift[0]:+.3f}, "
            f"{shift[1]:+.3f}) m against the seabed, more than its {AGREE:g} sigma: taken as their "
            "own move, the plan shift is the seabed's"))
    w = sigma**2 / (seabed**2 + sigma**2)  # the seabed estimate's weight
    cov = np.array(reg.cov, np.float64, copy=True)
    for k in (0, 1):
        cov[k, :] *= w[k]
        cov[:, k] *= w[k]
    combined = np.sqrt(w) * seabed  # 1/s^2 = 1/seabed^2 + 1/sigma^2
    cov[0, 0], cov[1, 1] = combined**2
    return dataclasses.replace(
        reg, dx=float(reg.dx + (1 - w[0]) * shift[0]), dy=float(reg.dy + (1 - w[1]) * shift[1]),
        sigma_dx=float(combined[0]), sigma_dy=float(combined[1]), cov=cov, ties=n,
        note=_joined(reg.note, f"plan shift refined on {n} of {len(pairs)} matched objects that kept their "
                               f"place (their mean move after the seabed's registration ({shift[0]:+.3f}, "
                               f"{shift[1]:+.3f}) m ± ({sigma[0]:.3f}, {sigma[1]:.3f}))"))


def _joined(note: str, more: str) -> str:
    return f"{note}; {more}" if note else more
