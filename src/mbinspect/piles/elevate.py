"""Stage 1: the points that stand well above a robust local seabed, and the backscatter
threshold between structure and seabed."""

from __future__ import annotations

import numpy as np

from ..checks import check_points, positive
from ..filters import radius_outlier
from ..seabed import GridSurface, grid_seabed
from ..segment import otsu_threshold

__all__ = ["elevated_points", "intensity_threshold"]


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


def intensity_threshold(cloud_int: np.ndarray | None, elevated: np.ndarray, near_seabed: np.ndarray
                        ) -> float | None:
    """An Otsu backscatter threshold between structure and seabed, when there are two classes.

    Parameters
    ----------
    cloud_int : ndarray, shape (N,), or None
        Backscatter of every point (any unit).
    elevated, near_seabed : ndarray of bool, shape (N,)
        The points of the structure, and those within the ground band of the seabed.

    Returns
    -------
    float or None
        None unless both classes have 20 points and the structure's median lies above
        the threshold and the seabed's below it.
    """
    if cloud_int is None or elevated.sum() < 20 or near_seabed.sum() < 20:
        return None
    both = np.r_[cloud_int[elevated], cloud_int[near_seabed]]
    try:
        thr = otsu_threshold(both)
    except Exception:
        return None
    # only a split between two clear classes is a threshold: structure brighter than seabed
    if np.median(cloud_int[elevated]) <= thr or np.median(cloud_int[near_seabed]) >= thr:
        return None
    return thr


#: Seabed soundings within this many pile radii (plus 2 m) of a pile's centroid are its
#: seabed for :func:`pile_thresholds`.
RING_RADII = 6.0


def pile_thresholds(cloud_int: np.ndarray | None, points: np.ndarray, candidates: np.ndarray,
                    labels: np.ndarray, near_seabed: np.ndarray, radius: float
                    ) -> dict[int, float | None]:
    """Each pile's own Otsu backscatter threshold (:func:`intensity_threshold`) between its
    soundings and the seabed around it (within :data:`RING_RADII` radii plus 2 m).

    A threshold from each pile's own surroundings follows the backscatter where the pile
    stands (gains differ between lines and along a swath) and does not depend on what
    else the cloud holds: a pile in one tile of a survey gets the threshold it gets in the
    whole survey.

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

    Returns
    -------
    dict
        Pile id -> threshold or None.
    """
    out: dict[int, float | None] = {}
    ids = [int(c) for c in np.unique(labels) if c >= 0]
    if cloud_int is None or not ids:
        return {c + 1: None for c in ids}
    from scipy.spatial import cKDTree

    ground = np.flatnonzero(near_seabed)
    tree = cKDTree(points[ground, :2]) if len(ground) else None
    for c in ids:
        own = candidates[labels == c]
        mask = np.zeros(len(points), bool)
        mask[own] = True
        near = np.zeros(len(points), bool)
        if tree is not None:
            centre = points[own, :2].mean(axis=0)
            near[ground[tree.query_ball_point(centre, RING_RADII * radius + 2.0)]] = True
        out[c + 1] = intensity_threshold(cloud_int, mask, near)
    return out
