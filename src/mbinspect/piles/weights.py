"""Stage 5, within: each side sounding's noise, the weight of the cylinder fit (issue 12).

A sounding's error on a pile's side grows with its beam angle (range noise with range,
pointing noise as 1/cos of the angle), and the far, grazing beams are the noisiest. With
``weights="angle"`` the noise is measured on the pile's own side: the robust spread of the
previous round's cylinder residuals in bins of beam angle; each point is then weighed by
its bin's. The pile's own soundings say it, so a pile in one tile of a survey is weighed as
in the whole survey. With ``weights="file"`` the file's own horizontal uncertainty of each
sounding (KMALL, GSF) is used instead; the real files' figures put it 1.5 to 5 times
under the spread measured on their seabed (``benchmarks/RESULTS.md``), so it only ranks the
soundings. Either way the fit's covariance is a sandwich of the weighted residuals, right
whether the weights are or not.
"""

from __future__ import annotations

import numpy as np

from ..noise import robust_sigma
from .results import PileMeasure, PileSegment

__all__ = ["ANGLE_STEP_DEG", "MIN_BIN", "WEIGHT_RANGE", "angle_noise", "side_sigma"]

#: Width (deg) of the beam-angle bins of a pile's side noise.
ANGLE_STEP_DEG = 10.0

#: Fewest residuals a bin needs for its own spread; a thinner bin takes the whole side's.
MIN_BIN = 30

#: A bin's spread is kept within this factor of the whole side's (either way), so that a
#: few lucky bins cannot take over the fit.
WEIGHT_RANGE = 2.0


def angle_noise(residuals: np.ndarray, beam_angle: np.ndarray) -> np.ndarray:
    """Each point's noise (m): the robust spread of the residuals of its beam-angle bin.

    Parameters
    ----------
    residuals : ndarray (N,)
        The points' distances from the fitted surface (m).
    beam_angle : ndarray (N,)
        Their beam angles (deg, either side).

    Returns
    -------
    ndarray (N,)
        Per point, its bin's spread, within :data:`WEIGHT_RANGE` of the whole set's; the
        whole set's for points in bins under :data:`MIN_BIN`.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> ang = np.r_[np.full(4000, 15.0), np.full(4000, 55.0)]
    >>> res = np.r_[rng.normal(0, 0.01, 4000), rng.normal(0, 0.02, 4000)]
    >>> s = angle_noise(res, ang)
    >>> bool(0.0095 < s[0] < 0.0105), bool(0.019 < s[-1] < 0.021)
    (True, True)
    """
    r = np.asarray(residuals, np.float64)
    whole = robust_sigma(r)
    out = np.full(len(r), whole)
    if not whole > 0:
        return out
    key = (np.abs(np.asarray(beam_angle, np.float64)) // ANGLE_STEP_DEG).astype(np.int64)
    for k in np.unique(key):
        m = key == k
        if m.sum() >= MIN_BIN:
            out[m] = np.clip(robust_sigma(r[m]), whole / WEIGHT_RANGE, whole * WEIGHT_RANGE)
    return out


def side_sigma(seg: PileSegment, side_m: np.ndarray, previous: PileMeasure | None, mode: str
               ) -> np.ndarray | None:
    """The noise (m) of each side point in use, for the cylinder fit's weights; None where
    the mode, the fields or the first round leave the points unweighted.

    Parameters
    ----------
    seg : PileSegment
        With ``beam_angle`` (mode "angle") or ``sigma_h`` (mode "file").
    side_m : ndarray of bool
        The side points in use (a mask over ``seg.points``).
    previous : PileMeasure or None
        The previous round's measure: its cylinder's residuals measure the noise.
    mode : {"angle", "file", "none"}
    """
    if mode == "file" and seg.sigma_h is not None:
        s = np.asarray(seg.sigma_h, np.float64)[side_m]
        good = np.isfinite(s) & (s > 0)
        if good.all() and len(s):
            return np.clip(s, np.median(s) / WEIGHT_RANGE, np.median(s) * WEIGHT_RANGE)
        return None
    if mode != "angle" or seg.beam_angle is None or previous is None or previous.cylinder is None:
        return None
    side = seg.points[side_m]
    if len(side) < MIN_BIN:
        return None
    return angle_noise(previous.cylinder.residuals(side), np.asarray(seg.beam_angle)[side_m])
