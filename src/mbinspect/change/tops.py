"""A reef's top level read again from its survey's levelled soundings, for its settlement.

Each survey's own result gives a reef's least depth: its shoalest reliable sounding, taken
before the comparison levels each ping against the others of its line. A ping's heave or
roll error then moves the least depth as a whole, and an extreme sounding is a noisy
statistic. Two surveys of one field differ by 3.1 cm RMS in their least depths where the
units did not move (the study of issue 29, two seeds); the plane through each unit's top
(:func:`~mbinspect.reefs.tilt.top_plane`), fitted to the levelled soundings in its footprint
and read at its highest sounded point, differs by 1.9 cm. A top whose slope is within three
times its 1-sigma of level is read at the soundings' centre instead (the highest point of a
level plane is wherever its noise tilts it, a few millimetres high), its 1-sigma taking the
slope it may still have over the top's reach.

The level's 1-sigma is the plane's at that point (pings and patches of the top as clusters)
with what a tilted top adds: its highest edge is sounded to about one sounding spacing, so
the edge's level is known to the slope times that spacing.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..geometry import points_in_polygon
from ..noise import all_round, robust_sigma, trimmed_lstsq
from ..reefs.results import Reef
from ..reefs.tilt import top_plane
from ..scour import grown
from .grid import _group_medians

__all__ = ["top_level", "TopLevel", "by_x", "sounding_noise", "reef_tops", "ground_level", "ground_sigma",
           "ground_round", "Levels", "ROUND_BAND"]

#: The vertical noise (m) below which no top's soundings are taken to agree (a plane's
#: tolerance is three of it).
MIN_NOISE = 0.01

#: A top whose slope is within this many of its 1-sigma of level is read at its centre.
LEVEL = 3.0

#: The noise taken where the soundings are too sparse to measure theirs (no cell of four).
DEFAULT_NOISE = 0.02


TopLevel = tuple[float, float, str]

#: A unit's top level, its 1-sigma, why it was not read, the seabed round it (m, up) and what
#: that seabed owes to where its band stands (:func:`ground_sigma`, m).
Levels = tuple[float, float, str, float, float]

#: The band round a unit (m beyond its footprint's outline) whose soundings give the seabed
#: its exposed height stands on: outside most of the wall's bloom, and the seabed the
#: simulator's truth takes round a unit (0.3 m beyond its outline) at its middle.
ROUND_BAND = (0.15, 0.45)
#: The soundings of that band more than this (m) above the unit's seabed under it (as its
#: survey measured it) are not the seabed round it.
ROUND_ABOVE = 0.2
#: Told the beam, the band stands this share of the unit's beam footprint farther out: the
#: outline has its bloom taken off, and a cone over the band's inner edge still hears the
#: unit's wall (through 1° cones the seabed round cross1 units read 2.3 cm high, and the
#: exposed heights 2.2-2.6 cm 1-sigma against 1.3-1.5 cm with thin rays; 0.5: 0.3 cm, 1.9 cm).
BAND_BEAM = 0.5
#: Where the band was moved out, a seabed rising away from the unit by more than this (m a
#: metre) is a scour pit's wall: its level is carried back along that slope to where the band
#: would have stood (else the scoured units' exposed heights read 6.4 cm RMS against 3.6).
PIT_SLOPE = 0.1


#: Soundings the noise is read on, at most (every k-th).
NOISE_SAMPLE = 400_000


def sounding_noise(points: np.ndarray, cell: float = 0.5) -> float:
    """The soundings' vertical 1-sigma: the robust spread about their cell's median (cells of
    ``cell`` m holding four soundings or more), on at most :data:`NOISE_SAMPLE` of them.

    >>> rng = np.random.default_rng(2)
    >>> pts = np.column_stack([rng.uniform(0, 20, (50_000, 2)), rng.normal(-8.0, 0.03, 50_000)])
    >>> round(sounding_noise(pts), 2)
    0.03
    """
    pts = points[:: max(1, len(points) // NOISE_SAMPLE)]
    key = np.floor(pts[:, :2] / cell).astype(np.int64) @ np.array([1_000_003, 1], np.int64)
    med, n = _group_medians(pts[:, 2], key)
    full = n >= 4
    # a cell's own median takes part of each sounding's spread about it: restored as for a
    # mean's (n - 1) / n, which is close for four soundings or more
    return float(robust_sigma((pts[full, 2] - med[full]) * np.sqrt(n[full] / (n[full] - 1))))


def by_x(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The soundings' order by x and their x in that order: each footprint's soundings are
    then found without a pass over all of them."""
    order = np.argsort(points[:, 0], kind="stable")
    return order, points[order, 0]


def top_level(points: np.ndarray, reef: Reef, *, ping: np.ndarray | None = None, noise: float = 0.02,
              index: tuple[np.ndarray, np.ndarray] | None = None) -> TopLevel:
    """A unit's top level (m, up), its 1-sigma and why it could not be read ("" when read).

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        The survey's levelled soundings.
    reef : Reef
        The unit as its survey found it: its footprint ``outline``, its seabed and height
        (the soundings above half its height are its top's).
    ping : ndarray of int, shape (N,), optional
        Each sounding's ping (pings are clusters of the plane's 1-sigma).
    noise : float
        The soundings' vertical 1-sigma (m).
    index : (ndarray, ndarray), optional
        :func:`by_x` of ``points`` (made here when not given).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> xy = rng.uniform(-1, 1, (600, 2))
    >>> pts = np.column_stack([xy, -10.0 + rng.normal(0, 0.01, 600)])
    >>> square = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
    >>> reef = Reef(1, 0.0, 0.0, -11.0, -10.0, 1.0, 4.0, 2.0, 2.0, 0.0, 4.0, 4.0, 600, outline=square)
    >>> z, sigma, why = top_level(pts, reef)
    >>> round(z, 2), sigma < 0.005, why
    (-10.0, True, '')
    """
    poly = np.asarray(reef.outline, np.float64).reshape(-1, 2)
    if len(poly) < 3 or not (math.isfinite(reef.z_seabed) and math.isfinite(reef.height)):
        return math.nan, math.nan, "no footprint"
    idx = _in_box(points, poly, index)
    idx = idx[points_in_polygon(points[idx], poly)]
    idx = idx[points[idx, 2] > reef.z_seabed + 0.5 * reef.height]
    pts = points[idx]
    noise = max(noise, MIN_NOISE) if math.isfinite(noise) else DEFAULT_NOISE  # too sparse to measure it
    coef, cov, why = top_plane(pts, noise, None if ping is None else np.asarray(ping)[idx])
    if why:
        return math.nan, math.nan, why
    slope = math.hypot(coef[1], coef[2])
    slope_sigma = math.sqrt(max(float(cov[1, 1] + cov[2, 2]), 0.0) / 2)
    g = np.column_stack([np.ones(len(pts)), pts[:, :2] - pts[:, :2].mean(axis=0)])
    on = np.abs(pts[:, 2] - g @ coef) <= max(3.0 * noise, 0.04)
    g = g[on]
    if slope <= LEVEL * slope_sigma:  # a level top: its level where the plane is best known, the
        # slope it may still have over the top's reach in its 1-sigma
        reach = float(np.hypot(g[:, 1], g[:, 2]).max()) if len(g) else 0.0
        return float(coef[0]), math.sqrt(max(float(cov[0, 0]), 0.0) + (slope * reach) ** 2), ""
    level = g @ coef
    k = int(np.argmax(level))
    spacing = math.sqrt(max(float(reef.area), 0.0) / max(len(pts), 1))
    sigma = math.sqrt(max(float(g[k] @ cov @ g[k]), 0.0) + (slope * spacing) ** 2)
    return float(level[k]), sigma, ""


def ground_level(points: np.ndarray, reef: Reef, *, index: tuple[np.ndarray, np.ndarray] | None = None
                 ) -> float:
    """The seabed round a unit, at its centre (m, up): a plane through the soundings in the
    :data:`ROUND_BAND` round its footprint (told the beam, :data:`BAND_BEAM` of its
    ``beam_footprint`` farther out) no more than :data:`ROUND_ABOVE` above its seabed
    under it, trimmed of what stands off the plane; NaN when fewer than 20 soundings, or
    soundings in fewer than 6 of 8 directions round it, remain. Where the band was moved out
    and rises away from the unit by more than :data:`PIT_SLOPE`, the level is carried back
    down that slope by as much.

    A plane, not a curved surface: round a scour pit the band lies in the pit, and a curved
    surface carried under the unit would bend on down into the pit's bowl there (by 10 cm
    over the scoured units of ``study_change.py``).

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> xy = rng.uniform(-3, 3, (20_000, 2))
    >>> z = np.where(np.abs(xy).max(axis=1) <= 1.0, -9.0, -11.0 + 0.05 * xy[:, 0])
    >>> square = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
    >>> reef = Reef(1, 0.0, 0.0, -11.0, -9.0, 2.0, 4.0, 2.0, 2.0, 0.0, 4.0, 4.0, 600, outline=square)
    >>> round(ground_level(np.column_stack([xy, z]), reef), 3)
    -11.0
    """
    return ground_round(points, reef, index=index)[0]


#: How far (m) the band's middle may stand from where the seabed round a unit is meant (0.3 m
#: beyond its true outline): half the band's width, over which an outline's bloom moves it.
BAND_PLACE = 0.15


def ground_sigma(points: np.ndarray, reef: Reef, *, index: tuple[np.ndarray, np.ndarray] | None = None
                 ) -> float:
    """What the seabed round a unit (:func:`ground_level`) owes to where its band stands
    (m, 1-sigma): the seabed's slope away from the unit across the band's soundings (a scour
    pit's wall: 0.4 m a metre in a pit 0.9 m deep and 3.6 m wide) times :data:`BAND_PLACE`.
    Zero on a level seabed, where the band's soundings span too little distance from the
    unit to show a slope (under 0.2 m), or where no seabed round the unit is read.

    Examples
    --------
    >>> rng = np.random.default_rng(2)
    >>> xy = rng.uniform(-3, 3, (20_000, 2))
    >>> r = np.hypot(*xy.T)
    >>> z = np.where(np.abs(xy).max(axis=1) <= 1.0, -9.0, -11.5 + 0.3 * r)  # a pit's wall round it
    >>> square = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
    >>> reef = Reef(1, 0.0, 0.0, -11.0, -9.0, 2.0, 4.0, 2.0, 2.0, 0.0, 4.0, 4.0, 600, outline=square)
    >>> round(ground_sigma(np.column_stack([xy, z]), reef), 3)
    0.045
    """
    return ground_round(points, reef, index=index)[1]


def ground_round(points: np.ndarray, reef: Reef, *, index: tuple[np.ndarray, np.ndarray] | None = None
                 ) -> tuple[float, float]:
    """:func:`ground_level` and :func:`ground_sigma` from one reading of the band's soundings."""
    poly = np.asarray(reef.outline, np.float64).reshape(-1, 2)
    if len(poly) < 3:
        return math.nan, 0.0
    out = BAND_BEAM * reef.beam_footprint if math.isfinite(reef.beam_footprint) else 0.0
    inner, outer = grown(poly, ROUND_BAND[0] + out), grown(poly, ROUND_BAND[1] + out)
    idx = _in_box(points, outer, index)
    idx = idx[points_in_polygon(points[idx], outer) & ~points_in_polygon(points[idx], inner)]
    # the seabed, not the unit: a radial band cuts a concave footprint's arms, a leaning or
    # overturned unit reaches past its outline, and a neighbour may stand in the band
    if math.isfinite(reef.z_seabed):
        idx = idx[points[idx, 2] <= reef.z_seabed + ROUND_ABOVE]
    if len(idx) < 20:
        return math.nan, 0.0
    u, v, z = points[idx, 0] - reef.x, points[idx, 1] - reef.y, points[idx, 2]
    if not all_round(u, v):
        return math.nan, 0.0
    one = np.ones_like(u)
    coef = trimmed_lstsq(np.column_stack([one, u, v]), z, 3)  # a neighbour's wall or a stray: off
    if coef is None:
        return math.nan, 0.0
    r = np.hypot(u, v)
    wall = None if np.ptp(r) < 0.2 else trimmed_lstsq(np.column_stack([one, u, v, r - r.mean()]), z, 3)
    if wall is None:
        return float(coef[0]), 0.0
    slope = float(wall[3])
    return float(coef[0]) - (slope * out if slope > PIT_SLOPE else 0.0), abs(slope) * BAND_PLACE


def _in_box(points: np.ndarray, poly: np.ndarray, index: tuple[np.ndarray, np.ndarray] | None
            ) -> np.ndarray:
    """The rows of ``points`` in the plan box round ``poly`` (``index``: :func:`by_x` of them)."""
    order, xs = index if index is not None else by_x(points)
    idx = order[int(np.searchsorted(xs, poly[:, 0].min(), side="left")):
                int(np.searchsorted(xs, poly[:, 0].max(), side="right"))]
    return idx[(points[idx, 1] >= poly[:, 1].min()) & (points[idx, 1] <= poly[:, 1].max())]


def reef_tops(reefs: tuple[Reef, ...] | list[Reef], points: np.ndarray, fields: Mapping[str, Any] | None
              ) -> list[Levels]:
    """Every unit's :func:`top_level` in one survey's levelled soundings, with the seabed
    round it (:func:`ground_level`)."""
    if not len(reefs):
        return []
    ping = None if not fields or "ping" not in fields else np.asarray(fields["ping"])
    noise, index = sounding_noise(points), by_x(points)
    return [(*top_level(points, r, ping=ping, noise=noise, index=index),
             *ground_round(points, r, index=index)) for r in reefs]
