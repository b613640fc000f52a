"""Stage 1: the points that stand well above a robust local seabed, and the backscatter
threshold between structure and seabed."""

from __future__ import annotations

import numpy as np

from ..checks import check_points, positive
from ..filters import radius_outlier
from ..noise import backscatter_anomaly, robust_sigma
from ..seabed import GridSurface, grid_seabed
from ..segment import otsu_threshold

__all__ = ["RING_RADII", "SEPARATION", "elevated_points", "intensity_threshold", "pile_thresholds"]


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
    except Exception:
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
    from scipy.spatial import cKDTree

    cloud_int = np.asarray(cloud_int, float)
    values = cloud_int[candidates].copy()
    ground = np.flatnonzero(near_seabed)
    tree = cKDTree(points[ground, :2]) if len(ground) else None
    for c in ids:
        mine = labels == c
        own = candidates[mine]
        near = ground[tree.query_ball_point(points[own, :2].mean(axis=0), RING_RADII * radius + 2.0)] \
            if tree is not None else np.zeros(0, np.int64)
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
