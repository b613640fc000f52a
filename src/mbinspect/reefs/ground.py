"""Stage 3: the seabed under every sounding, the paper's RANSAC plane where one plane fits,
a robust local grid surface where it does not."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..checks import check_points, one_of
from ..options import CHOICES
from ..seabed import GROUND_BAND, GridSurface, PlaneSeabed, grid_seabed, ransac_plane

__all__ = ["Seabed", "fit_seabed"]

#: A seabed surface: ``elevation(x, y)`` and ``height_above(points)``.
Seabed = GridSurface | PlaneSeabed


def fit_seabed(points: np.ndarray, *, mode: str = "auto", threshold: float = 0.5,
               confidence: float = 0.99, cell: float = 0.5, window: float = 6.0,
               max_plane_dev: float = 0.08, sample: int = 100_000, seed: int = 0,
               grid: GridSurface | None = None, grid_height: np.ndarray | None = None
               ) -> tuple[Seabed, dict[str, Any]]:
    """The seabed under every point.

    Parameters
    ----------
    mode : {"auto", "plane", "grid"}
        ``plane`` is the paper's RANSAC plane; ``grid`` the robust local surface; ``auto``
        the plane when it fits (its 99th-percentile departure from the local surface is
        within ``max_plane_dev`` m), else the grid.
    threshold, confidence : float
        The paper's distance threshold D (0.5 m) and q (0.99).
    cell, window : float
        Grid cell and opening window (m); the window must exceed a reef's footprint.
    max_plane_dev : float
        Largest departure (m) of the plane from the local surface for ``auto`` to keep it.
    sample : int
        RANSAC runs on at most this many points (seeded), then scores all.
    grid : GridSurface, optional
        A local surface already computed from (a superset of) these points, reused.
    grid_height : ndarray (N,), optional
        The points' heights above ``grid``, when the caller has them.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> xy = rng.uniform(0, 30, (5000, 2))
    >>> pts = np.column_stack([xy, -17.0 + 0.02 * xy[:, 0] + rng.normal(0, 0.02, 5000)])
    >>> seabed, info = fit_seabed(pts)
    >>> info["method"], round(float(seabed.elevation(np.array([10.0]), np.array([5.0]))[0]), 2)
    ('plane', -16.8)

    Returns
    -------
    seabed, info : the surface (``elevation``, ``height_above``) and a JSON-ready summary,
        including the RMS of the ground soundings about the chosen surface.
    """
    one_of("seabed", mode, CHOICES["seabed"])
    pts = check_points(points, minimum=10)
    info: dict[str, Any] = {}
    plane = None
    if mode in ("auto", "plane"):
        rng = np.random.default_rng(seed)
        sub = pts if len(pts) <= sample else pts[rng.choice(len(pts), sample, replace=False)]
        plane = ransac_plane(sub, threshold=threshold, confidence=confidence, seed=seed)
        h = plane.height_above(pts)
        ground = np.abs(h) <= GROUND_BAND
        rms = float(np.sqrt(np.mean(h[ground] ** 2))) if ground.any() else math.inf
        info["plane"] = {**plane.to_dict(), "ground_rms": rms,
                         "inlier_ratio_all": float(np.mean(np.abs(h) <= threshold))}
        if mode == "plane":
            info.update(method="plane", residual_rms=rms)
            return plane, info
    if grid is None:
        grid = grid_seabed(pts, cell=cell, window=window)
    if plane is not None:
        # does one plane fit? compare it with the robust local surface wherever there is data
        gx, gy = np.nonzero(grid.observed)
        cx, cy = grid.x0 + (gx + 0.5) * grid.cell, grid.y0 + (gy + 0.5) * grid.cell
        dev = float(np.percentile(np.abs(plane.elevation(cx, cy) - grid.z[gx, gy]), 99))
        info["plane"]["deviation_p99"] = dev
        if dev <= max_plane_dev:
            info.update(method="plane", residual_rms=info["plane"]["ground_rms"])
            return plane, info
    h = grid.height_above(pts) if grid_height is None else grid_height
    ground = np.abs(h) <= GROUND_BAND
    rms = float(np.sqrt(np.mean(h[ground] ** 2))) if ground.any() else math.inf
    info.update(method="grid", residual_rms=rms, grid=grid.to_dict())
    if plane is not None:
        info["why"] = (f"the plane departs from the local seabed by {info['plane']['deviation_p99']:.2f} m "
                       f"(99th percentile) > {max_plane_dev} m: slope changes, sand waves or relief")
    return grid, info
