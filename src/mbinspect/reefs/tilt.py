"""The plane through a reef unit's top: its tilt from level and that tilt's 1-sigma.

A unit that landed on a rock or on the edge of a scour hole leans. The top's cells
(0.25 m) each give their highest sounding; the plane that holds the most of those (within
3 × the noise, at most 40° from level) is refitted to every sounding within the noise of
it. Its 1-sigma is the largest of three readings of the soundings' spread about it: as
independent, pings as clusters (a ping's roll or heave moves all its soundings) and
patches of the top as clusters, with few clusters corrected and widened by Student's
quantile so that 2 sigma still holds 95 %; and, since a tilt is the length of
a slope vector, its 1-sigma is set so that 2 sigma holds 95 % of that vector's error
(:func:`tilt_of`).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import stdtrit

from ..fit.robust import clustered_cov
from ..noise import robust_sigma

__all__ = ["top_plane", "top_tilt", "tilt_of", "cells_of"]

#: Patches of a top (m) whose soundings' errors are taken as one cluster in its tilt's 1-sigma.
_PATCH = 0.5

#: The radius (in standard deviations) holding 95 % of a 2-D normal error: sqrt(chi2(2)_95).
VECTOR_95 = 2.447746830680816

#: Upper-surface cell (m): a sounding's neighbourhood on the top.
CELL = 0.25


def cells_of(xy: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """Soundings sorted by their cell: the order and the start of each cell's run."""
    key = np.floor(xy / cell).astype(np.int64)
    flat = key[:, 0] * 1_000_003 + key[:, 1]
    order = np.argsort(flat, kind="stable")
    starts = np.flatnonzero(np.r_[True, np.diff(flat[order]) != 0])
    return order, starts


def top_plane(pts: np.ndarray, noise: float, ping: np.ndarray | None = None
              ) -> tuple[np.ndarray, np.ndarray, str]:
    """The plane through a unit's top, ``z = c0 + c1 (x - mx) + c2 (y - my)`` about the
    soundings' mean (mx, my): its coefficients (3,), their covariance (3, 3) and, when
    the top holds no plane, NaNs and why (see :func:`top_tilt`)."""
    nan = np.full(3, math.nan)
    if len(pts) < 12:
        return nan, np.full((3, 3), math.nan), "too few soundings for a top plane"
    p = pts - np.array([*pts[:, :2].mean(axis=0), 0.0])
    order, starts = cells_of(p[:, :2], CELL)
    cell = np.repeat(np.arange(len(starts)), np.diff(np.r_[starts, len(order)]))
    by_height = order[np.lexsort((p[order, 2], cell))]  # within each cell, lowest first
    top = by_height[np.r_[starts[1:], len(order)] - 1]  # each cell's highest sounding
    u = p[top]
    tol = max(3.0 * noise, 0.04)
    best, best_n = None, 0
    high = np.flatnonzero(u[:, 2] >= np.median(u[:, 2]))
    if len(high) >= 3:  # 150 planes through three high cells, all at once
        rng = np.random.default_rng(0)
        tri = u[high[np.argpartition(rng.random((150, len(high))), 2, axis=1)[:, :3]]]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        steep = np.abs(n[:, 2]) < math.cos(math.radians(40)) * np.maximum(np.linalg.norm(n, axis=1), 1e-12)
        ok = ~steep & (np.abs(n[:, 2]) > 1e-9)
        if ok.any():
            tri, n = tri[ok], n[ok] / n[ok, 2:3]  # each plane z = a0z - n0 (x - a0x) - n1 (y - a0y)
            a0 = tri[:, 0]
            res = u[None, :, 2] - (a0[:, 2:3] - n[:, 0:1] * (u[None, :, 0] - a0[:, 0:1])
                                   - n[:, 1:2] * (u[None, :, 1] - a0[:, 1:2]))
            inl = (np.abs(res) <= tol).sum(axis=1)
            k = int(np.argmax(inl))
            best, best_n = (a0[k], n[k]), int(inl[k])
    if best is None or best_n < 6:
        return nan, np.full((3, 3), math.nan), "the top holds no plane"
    a0, n = best
    keep = np.abs(p[:, 2] - (a0[2] - n[0] * (p[:, 0] - a0[0]) - n[1] * (p[:, 1] - a0[1]))) <= tol
    x_all = np.column_stack([np.ones(len(p)), p[:, 0], p[:, 1]])
    for _ in range(3):
        if keep.sum() < 6 or min(np.ptp(p[keep, 0]), np.ptp(p[keep, 1])) < 0.3:
            return nan, np.full((3, 3), math.nan), "the top is too small for its tilt"
        coef, *_ = np.linalg.lstsq(x_all[keep], p[keep, 2], rcond=None)
        r_all = p[:, 2] - x_all @ coef
        keep = np.abs(r_all) <= max(3.0 * robust_sigma(r_all[keep]), tol / 2)
    x, r = x_all[keep], r_all[keep]
    xtx_inv = np.linalg.inv(x.T @ x)
    dev = (x @ xtx_inv) * r[:, None] * len(x)
    # the larger of: pings as clusters (a ping's roll or heave moves all its soundings),
    # patches of the top as clusters (errors that follow the beam and the place), and
    # the soundings as independent
    covs = [xtx_inv * float(np.sum(r**2)) / max(len(x) - 3, 1)]
    patch = np.floor(p[keep, :2] / _PATCH).astype(np.int64) @ np.array([1_000_003, 1])
    for groups, least in ((patch, 4), (np.zeros(0) if ping is None else ping[keep], 8)):
        g = len(np.unique(groups))
        if g >= least:  # with the few-cluster correction (CR1) and Student's quantile for
            # g - 1 degrees of freedom, so that 2 sigma still holds 95 %
            widen = (float(stdtrit(g - 1, 0.975)) / 1.96) ** 2
            covs.append(clustered_cov(dev, groups) * g / (g - 1) * (len(x) - 1) / max(len(x) - 3, 1) * widen)
    cov = max(covs, key=lambda c: float(c[1, 1] + c[2, 2]))
    return coef, cov, ""


def top_tilt(pts: np.ndarray, noise: float, ping: np.ndarray | None = None
             ) -> tuple[float, float, str]:
    """The tilt (degrees from level) of the plane through a unit's top and its 1-sigma.

    The top's cells (0.25 m) each give their highest sounding; the plane that holds the
    most of those (within 3 × ``noise``, at most 40° from level) is refitted to every
    sounding within the noise of it.

    Parameters
    ----------
    pts : ndarray, shape (N, 3)
        The unit's soundings.
    noise : float
        The soundings' vertical 1-sigma (m).
    ping : ndarray of int, shape (N,), optional
        Each sounding's ping: the 1-sigma counts pings as clusters.

    Returns
    -------
    tilt_deg, sigma_deg : float
        NaN when the top holds no plane.
    note : str
        Why not.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> xy = rng.uniform(-1, 1, (400, 2))
    >>> z = 2.0 + 0.1 * xy[:, 0] + rng.normal(0, 0.01, 400)
    >>> t, s, _ = top_tilt(np.column_stack([xy, z]), 0.01)
    >>> round(t, 1), s < 0.5
    (5.7, True)
    """
    coef, cov, note = top_plane(pts, noise, ping)
    return (math.nan, math.nan, note) if note else (*tilt_of(coef, cov), "")


def tilt_of(coef: np.ndarray, cov: np.ndarray) -> tuple[float, float]:
    """A plane's tilt from level and its 1-sigma (degrees), from :func:`top_plane`'s
    coefficients and covariance.

    The tilt is the length of the slope vector, and near level that length is biased up
    (noise only lengthens it): the 1-sigma is :data:`VECTOR_95` / 2 times the slope
    vector's larger standard deviation, so that 2 sigma holds 95 % of the vector's own
    error, which bounds the length's error at any tilt.
    """
    g = float(np.hypot(coef[1], coef[2]))
    largest = float(np.sqrt(max(np.linalg.eigvalsh(cov[1:, 1:]).max(), 0.0)))
    return math.degrees(math.atan(g)), math.degrees(largest * VECTOR_95 / 2 / (1.0 + g * g))
