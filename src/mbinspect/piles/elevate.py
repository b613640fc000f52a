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
