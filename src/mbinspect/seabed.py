"""The seabed: the reef paper's RANSAC plane and a robust local grid surface.

Both give the elevation of the seabed under any point, so that a structure's points
are those standing well above it (``height_above``).

Examples
--------
>>> import numpy as np
>>> from mbinspect.seabed import grid_seabed
>>> rng = np.random.default_rng(0)
>>> xy = rng.uniform(0, 40, (20000, 2))
>>> z = -20 + 0.05 * xy[:, 0] + rng.normal(0, 0.02, len(xy))
>>> on_box = (np.abs(xy - 20) < 1).all(axis=1)
>>> z[on_box] += 3.0                               # a 2 m wide object 3 m tall
>>> surf = grid_seabed(np.column_stack([xy, z]), cell=1.0, window=5.0)
>>> abs(float(surf.elevation(20.0, 20.0)) - (-19.0)) < 0.05
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import ndimage

from .cellsort import segment_percentile
from .checks import check_points
from .errors import NotEnoughPointsError, ParameterError
from .fit import Plane, msac, ransac_trials
from .grid import cell_index, cell_segments

__all__ = ["GridSurface", "grid_seabed", "PlaneSeabed", "ransac_plane"]


@dataclass(frozen=True, eq=False)
class GridSurface:
    """A seabed elevation grid with bilinear interpolation.

    ``z[i, j]`` is the elevation at ``x0 + (i + 0.5) * cell, y0 + (j + 0.5) * cell``.
    Cells without data are filled from the nearest cell with data; ``observed`` says which
    cells had soundings.
    """

    x0: float
    y0: float
    cell: float
    z: np.ndarray
    observed: np.ndarray
    window: float
    percentile: float
    method: str = field(default="grid")

    def elevation(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        """Seabed elevation at ``x, y`` (bilinear; clamped at the grid edge)."""
        x = np.asarray(x, np.float64)
        y = np.asarray(y, np.float64)
        nx, ny = self.z.shape
        u = np.clip((x - self.x0) / self.cell - 0.5, 0, nx - 1)
        v = np.clip((y - self.y0) / self.cell - 0.5, 0, ny - 1)
        out = ndimage.map_coordinates(self.z, [u.ravel(), v.ravel()], order=1, mode="nearest",
                                      prefilter=False)
        return out.reshape(np.shape(u))

    def height_above(self, points: np.ndarray) -> np.ndarray:
        """Height of each point above the seabed under it (m)."""
        p = np.asarray(points, np.float64)
        return p[:, 2] - self.elevation(p[:, 0], p[:, 1])

    def to_dict(self) -> dict[str, Any]:
        return {"method": self.method, "cell": self.cell, "window": self.window,
                "percentile": self.percentile, "shape": list(self.z.shape),
                "z_min": float(self.z.min()), "z_max": float(self.z.max())}


#: Soundings within this height (m) of a seabed surface are ground: the band in which a
#: seabed's residual is measured, ring soundings are taken and a pile's foot is judged.
GROUND_BAND = 0.3


def grid_seabed(points: np.ndarray, *, cell: float = 1.0, window: float = 5.0,
                percentile: float = 10.0, ground_band: float = GROUND_BAND,
                low_cut: float = 1.0) -> GridSurface:
    """A robust local seabed surface that ignores structures narrower than ``window``.

    Per ``cell`` the ``percentile`` of z (spikes far below the cell median ignored); a
    3 x 3 median removes lone spikes; a grey opening (erosion then dilation) over
    ``window`` m removes whatever stands on the seabed and is narrower than the window
    (piles, reefs, boulders) while keeping slopes and sand waves longer than it; empty
    cells take their nearest neighbour's value.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
    cell : float
        Grid cell (m); default 1.0.
    window : float
        Width (m) of the widest object to see through; default 5.0. Use more than the
        largest pile diameter or reef footprint.
    percentile : float
        Per-cell z percentile, 0-100; default 10 (the seabed is the low part).
    ground_band : float
        Soundings within this distance (m) of the opened surface are ground; default 0.3.
    low_cut : float
        Soundings more than this (m) below their cell's median are ignored (multipath
        spikes); default 1.0.
    """
    pts = check_points(points, minimum=3)
    for name, v in (("cell", cell), ("window", window)):
        if not (v > 0 and math.isfinite(v)):
            raise ParameterError(f"{name}: {v} must be a positive number")
    if not 0 <= percentile <= 100:
        raise ParameterError(f"percentile: {percentile} must be within 0..100")
    # the corner on a 10 m lattice of whole cells: a tile of a survey gets the very cells
    # (and coarser cells of a few fine ones) that the whole survey gets
    unit = cell * max(1, round(10.0 / cell))
    lo = np.floor(np.array([pts[:, 0].min(), pts[:, 1].min()]) / unit) * unit
    ci, cj = cell_index(pts, lo[0], lo[1], cell)
    nx, ny = int(ci.max()) + 1, int(cj.max()) + 1
    key = ci * ny + cj
    # multipath spikes lie metres below the seabed: in a sparse cell the low percentile
    # would pick one, so only points at most ``low_cut`` below the cell median count
    starts, zs = cell_segments(key, pts[:, 2])
    starts = np.pad(starts, (0, nx * ny + 1 - len(starts)), mode="edge")  # every cell
    median = segment_percentile(starts, zs, 50.0)
    grid = segment_percentile(starts, zs, percentile, median, below=low_cut).reshape(nx, ny)
    observed = np.isfinite(grid)
    filled = _fill_nearest(grid)
    filled = ndimage.median_filter(filled, size=3, mode="nearest")
    w = max(3, int(math.ceil(window / cell)) | 1)
    opened = ndimage.grey_opening(filled, size=(w, w), mode="nearest")
    # the opening shaves crests and the low percentile sits under the noise: re-estimate
    # each cell from the soundings close to the opened surface (the ground), by median
    # (the opened surface at each sounding's own cell: bilinear is not needed for a band,
    # and the soundings stay sorted by cell and z)
    med = segment_percentile(starts, zs, 50.0, opened, band=ground_band).reshape(nx, ny)
    # cells without ground (under a structure) take a Gaussian-weighted mean of the ground
    # cells around them (normalized convolution), not the opened surface, which sits low
    # on slopes and sand-wave flanks; far from any ground the opened surface stays
    has = np.isfinite(med)
    sigma = window / (4.0 * cell)
    num = ndimage.gaussian_filter(np.where(has, med, 0.0), sigma, mode="nearest")
    den = ndimage.gaussian_filter(has.astype(np.float64), sigma, mode="nearest")
    around = np.where(den > 0.05, num / np.maximum(den, 1e-12), opened)
    refined = np.where(has, med, around)
    refined = ndimage.median_filter(refined, size=3, mode="nearest")
    return GridSurface(float(lo[0]), float(lo[1]), cell, refined, observed, window, percentile)


def _fill_nearest(grid: np.ndarray) -> np.ndarray:
    missing = ~np.isfinite(grid)
    if not missing.any():
        return grid
    if missing.all():
        raise NotEnoughPointsError("grid_seabed: no cell has data")
    idx = ndimage.distance_transform_edt(missing, return_distances=False, return_indices=True)
    return grid[tuple(idx)]


@dataclass(frozen=True, eq=False)
class PlaneSeabed:
    """The reef paper's seabed: one RANSAC plane, its inliers and the trial bookkeeping."""

    plane: Plane
    inliers: np.ndarray
    inlier_ratio: float
    trials: int
    trials_needed: int
    threshold: float
    rms: float
    method: str = "plane"

    def elevation(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        return self.plane.z_at(np.asarray(x, np.float64), np.asarray(y, np.float64))

    def height_above(self, points: np.ndarray) -> np.ndarray:
        p = np.asarray(points, np.float64)
        return p[:, 2] - self.elevation(p[:, 0], p[:, 1])

    def to_dict(self) -> dict[str, Any]:
        return {"method": self.method, "plane": self.plane.to_dict(),
                "inlier_ratio": self.inlier_ratio, "trials": self.trials,
                "trials_needed": self.trials_needed, "threshold": self.threshold,
                "rms": self.rms}


def ransac_plane(points: np.ndarray, *, threshold: float = 0.5, confidence: float = 0.99,
                 max_trials: int = 1000, loss: str = "ransac", seed: int = 0) -> PlaneSeabed:
    """The reef paper's seabed plane: RANSAC with N = ln(1-q)/ln(1-P^K), P learnt.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
    threshold : float
        Distance threshold D (m); default 0.5 as in the paper.
    confidence : float
        q, the wanted probability of drawing one all-inlier sample; default 0.99.
    max_trials : int
        Upper bound on N.
    loss : {"ransac", "msac"}
        Count inliers (the paper) or score them (MSAC).
    seed : int
    """
    pts = check_points(points, minimum=3)
    if not threshold > 0:
        raise ParameterError(f"threshold: {threshold} must be positive")
    if not 0 < confidence < 1:
        raise ParameterError(f"confidence: {confidence} must be within (0, 1)")
    shift = pts.mean(axis=0)
    local = pts - shift
    res = msac(local, Plane.from_sample, lambda m, p: m.residuals(p), 3, threshold,
               loss=loss, max_trials=max_trials, confidence=confidence, seed=seed,
               refine=lambda rows, _m: Plane.fit(rows))
    if res.model is None:
        raise NotEnoughPointsError("ransac_plane: no plane could be fitted (degenerate points)")
    model, inliers = res.model, res.inliers
    for _ in range(3):  # final least-squares polish on the inliers (counting alone tilts it)
        polished = Plane.fit(local[inliers])
        if polished is None:
            break
        model, inliers = polished, np.abs(polished.residuals(local)) <= threshold
    ratio = float(inliers.sum()) / len(local)
    plane = Plane(model.point + shift, model.normal)
    r = plane.residuals(pts[inliers])
    return PlaneSeabed(plane, inliers, ratio, res.trials,
                       ransac_trials(ratio, 3, confidence), threshold,
                       float(np.sqrt(np.mean(r * r))) if len(r) else math.nan)
