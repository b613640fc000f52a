"""Stage 1: the points that stand well above a robust local seabed, and the backscatter
threshold between structure and seabed."""

from __future__ import annotations

import numpy as np

from ..checks import check_points, positive
from ..errors import NotEnoughPointsError
from ..filters import radius_outlier
from ..noise import backscatter_anomaly, robust_sigma
from ..seabed import GridSurface, grid_seabed
from ..segment import otsu_threshold

__all__ = ["BASE_SPREADS", "RING_RADII", "SEPARATION", "elevated_points", "intensity_threshold", "pile_base",
           "pile_thresholds"]


def elevated_points(points: np.ndarray, *, min_height: float = 1.0, seabed_cell: float = 1.0,
                    seabed_window: float = 5.0, noise_radius: float = 1.0,
                    noise_neighbors: int = 3) -> tuple[np.ndarray, GridSurface, np.ndarray]:
    """Points standing more than ``min_height`` m above a robust local seabed.

    Lone returns among them (water-column noise, spikes) are dropped by the radius filter
    (``<= noise_neighbors`` others within ``noise_radius`` m).

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        Soundings (m), z up.
    min_height : float
        Height above the seabed (m) a pile point exceeds.
    seabed_cell, seabed_window : float
        Seabed grid cell and grey-opening window (m); the window must exceed a pile's
        diameter.
    noise_radius : float
        Radius of the lone-return filter (m).
    noise_neighbors : int
        A point with at most this many neighbours within ``noise_radius`` is dropped.

    Returns
    -------
    mask : ndarray of bool, shape (N,)
    seabed : GridSurface
    height : ndarray, shape (N,)
        Height of every point above the seabed (m).

    Examples
    --------
    >>> from mbinspect.simulate import simulate
    >>> sim = simulate("jacket", seed=2, ping_spacing=0.5)
    >>> mask, seabed, height = elevated_points(sim.cloud.xyz)
    >>> bool(sim.labels[mask].tolist().count(1) > 0.95 * mask.sum())  # pile soundings
    True
    """
    pts = check_points(points, minimum=10)
    positive("min_height", min_height)
    seabed = grid_seabed(pts, cell=seabed_cell, window=seabed_window, percentile=10.0)
    height = seabed.height_above(pts)
    mask = height > min_height
    idx = np.flatnonzero(mask)
    if len(idx):
        mask[idx] = radius_outlier(pts[idx], radius=noise_radius, min_neighbors=noise_neighbors)
    return mask, seabed, height


#: A found pile's soundings reach down to this many robust spreads of the seabed's own
#: heights above its median (and at least :data:`BASE_MIN` m): the part of the side below
#: ``min_height`` that no seabed sounding reaches.
BASE_SPREADS = 6.0
BASE_MIN = 0.3


def pile_base(points: np.ndarray, height: np.ndarray, candidates: np.ndarray, labels: np.ndarray, *,
              radius: float, min_height: float, ground: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Each found pile's soundings below ``min_height``, down to a floor the seabed's noise sets.

    A pile 2 m proud keeps only its upper metre above a 1 m ``min_height``: too short a side
    for its axis when its top is not sounded. Once the piles are found, the soundings
    between the floor and ``min_height`` that lie within half a radius (in plan) of a
    pile's own soundings join that pile. The floor is the seabed soundings' median height
    plus :data:`BASE_SPREADS` robust spreads (at least :data:`BASE_MIN` m, at most
    ``min_height``), so it follows the noise of the depth.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
    height : ndarray, shape (N,)
        Height of every sounding above the seabed (m).
    candidates : ndarray of int
        Rows of the soundings that ``labels`` label (pile label or -1).
    labels : ndarray of int
    radius, min_height : float
        Pile radius and the candidates' height above the seabed (m).
    ground : ndarray of bool, shape (N,)
        The seabed's soundings (within the ground band).

    Returns
    -------
    candidates, labels : ndarray
        With the base soundings added.
    floor : float
        The floor used (m above the seabed).

    Examples
    --------
    >>> a = np.linspace(0, np.pi, 60)
    >>> z = np.repeat(np.arange(0.05, 2.0, 0.1), 60)
    >>> side = np.column_stack([0.5 * np.tile(np.cos(a), 20), 0.5 * np.tile(np.sin(a), 20), z])
    >>> bed = np.column_stack([np.linspace(3, 9, 200), np.zeros(200), np.tile([-0.02, 0.0, 0.02, 0.01], 50)])
    >>> pts = np.vstack([side, bed])
    >>> h = pts[:, 2]
    >>> cand = np.flatnonzero(h > 1.0)
    >>> c, lab, floor = pile_base(pts, h, cand, np.zeros(len(cand), int), radius=0.5, min_height=1.0,
    ...                           ground=np.abs(h) < 0.2)
    >>> len(cand), len(c), floor
    (600, 1020, 0.3)
    """
    h_ground = height[ground]
    floor = BASE_MIN
    if len(h_ground) >= 20:
        floor = max(BASE_MIN, float(np.median(h_ground)) + BASE_SPREADS * robust_sigma(h_ground))
    low = np.flatnonzero((height > floor) & (height <= min_height))
    mine = labels >= 0
    if floor >= min_height or not len(low) or not mine.any():
        return candidates, labels, min(floor, min_height)
    from scipy.spatial import cKDTree

    # the candidates stand above min_height, so none of them is among these
    d, j = cKDTree(points[candidates[mine], :2]).query(points[low, :2], distance_upper_bound=radius / 2)
    keep = np.isfinite(d)
    return np.r_[candidates, low[keep]], np.r_[labels, labels[mine][j[keep]]], floor


#: Backscatter separates structure from seabed only when their medians lie this many
#: pooled robust spreads apart; otherwise the segmentation is geometry alone.
SEPARATION = 2.0


def intensity_threshold(cloud_int: np.ndarray | None, elevated: np.ndarray, near_seabed: np.ndarray
                        ) -> float | None:
    """An Otsu backscatter threshold between structure and seabed, when there are two classes.

    Parameters
    ----------
    cloud_int : ndarray, shape (N,), or None
        Backscatter of every point (any unit; best normalised by beam angle,
        :func:`~mbinspect.noise.backscatter_anomaly`).
    elevated, near_seabed : ndarray of bool, shape (N,)
        The points of the structure, and those within the ground band of the seabed.

    Returns
    -------
    float or None
        None unless both classes have 20 points, the structure's median lies above the
        threshold and the seabed's below it, and the medians lie :data:`SEPARATION` pooled
        robust spreads apart (a structure that returns what the seabed returns at the same
        angle cannot be told from it by backscatter).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> bs = np.r_[rng.normal(-10, 4, 300), rng.normal(-30, 4, 300)]
    >>> pile = np.arange(600) < 300
    >>> bool(-22 < intensity_threshold(bs, pile, ~pile) < -18)
    True
    >>> intensity_threshold(np.r_[rng.normal(-10, 4, 300), rng.normal(-13, 4, 300)], pile, ~pile) is None
    True
    """
    if cloud_int is None or elevated.sum() < 20 or near_seabed.sum() < 20:
        return None
    up, down = cloud_int[elevated], cloud_int[near_seabed]
    up, down = up[np.isfinite(up)], down[np.isfinite(down)]
    if len(up) < 20 or len(down) < 20:
        return None
    try:
        thr = otsu_threshold(np.r_[up, down])
    except NotEnoughPointsError:  # one value only: no threshold
        return None
    # only a split between two clear classes is a threshold: structure brighter than seabed
    mu, md = np.median(up), np.median(down)
    spread = np.hypot(robust_sigma(up), robust_sigma(down)) / np.sqrt(2.0)
    if mu <= thr or md >= thr or mu - md < SEPARATION * spread:
        return None
    return thr


#: Seabed soundings within this many pile radii (plus 2 m) of a pile's centroid are its
#: seabed for :func:`pile_thresholds`.
RING_RADII = 6.0


def pile_thresholds(cloud_int: np.ndarray | None, points: np.ndarray, candidates: np.ndarray,
                    labels: np.ndarray, near_seabed: np.ndarray, radius: float, *,
                    beam_angle: np.ndarray | None = None, line: np.ndarray | None = None
                    ) -> tuple[dict[int, float | None], np.ndarray | None]:
    """Each pile's own backscatter threshold (:func:`intensity_threshold`) between its
    soundings and the seabed around it (within :data:`RING_RADII` radii plus 2 m), on
    backscatter normalised by beam angle against that seabed where angles are known.

    A threshold from each pile's own surroundings follows the backscatter where the pile
    stands (gains differ between lines and along a swath) and does not depend on what
    else the cloud holds: a pile in one tile of a survey gets the threshold it gets in the
    whole survey. Normalising by the seabed's response at each beam angle (and line) keeps
    the angular fall of raw backscatter from passing for a difference of material.

    Parameters
    ----------
    cloud_int : ndarray (N,) or None
        Backscatter of every sounding.
    points : ndarray, shape (N, 3)
    candidates : ndarray of int
        Rows of the soundings that ``labels`` label.
    labels : ndarray of int
        Pile label of each candidate (-1: none); pile id = label + 1.
    near_seabed : ndarray of bool, shape (N,)
    radius : float
        Pile radius (m).
    beam_angle, line : ndarray (N,), optional
        Beam angle (deg) and survey line of every sounding.

    Returns
    -------
    thresholds : dict
        Pile id -> threshold or None.
    values : ndarray, shape (len(candidates),), or None
        The backscatter of each candidate that its pile's threshold applies to
        (normalised where angles are known).
    """
    out: dict[int, float | None] = {}
    ids = [int(c) for c in np.unique(labels) if c >= 0]
    if cloud_int is None or not ids:
        return {c + 1: None for c in ids}, None
    cloud_int = np.asarray(cloud_int, float)
    values = cloud_int[candidates].copy()
    ground = np.flatnonzero(near_seabed)
    # only the seabed within reach of a candidate; each pile's ring by plan distance from
    # it (a tree over that seabed cost more than the few rings it answered)
    reach = RING_RADII * radius + 2.0
    lo, hi = points[candidates, :2].min(axis=0) - reach, points[candidates, :2].max(axis=0) + reach
    gxy = points[ground, :2]
    inside = np.all((gxy >= lo) & (gxy <= hi), axis=1)
    ground, gxy = ground[inside], gxy[inside]
    for c in ids:
        mine = labels == c
        own = candidates[mine]
        off = gxy - points[own, :2].mean(axis=0)
        near = ground[np.einsum("ij,ij->i", off, off) <= reach * reach]
        rows = np.r_[own, near]
        is_own = np.arange(len(rows)) < len(own)
        inten = cloud_int[rows]
        if beam_angle is not None:
            anom = backscatter_anomaly(inten, np.asarray(beam_angle)[rows], ~is_own,
                                       line=None if line is None else np.asarray(line)[rows])
            if anom is not None:
                inten = anom
        values[mine] = inten[is_own]
        out[c + 1] = intensity_threshold(inten, is_own, ~is_own)
    return out, values
