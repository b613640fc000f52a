"""Stage 1: steep or rough terrain, where reefs cannot be told from the seabed, found from
the robust local seabed (the paper cut the uneven near-shore area away by hand)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import ndimage

from ..checks import check_points, positive, within
from ..grid import cell_index, coverage, fill_holes
from ..neighbours import Cells, count_within
from ..seabed import GridSurface, grid_seabed

__all__ = ["TerrainMask", "rough_terrain", "Ground", "screen_terrain"]


@dataclass(frozen=True, eq=False)
class TerrainMask:
    """Cells of a coarse grid judged too steep or rough for reef extraction."""

    x0: float
    y0: float
    cell: float
    excluded: np.ndarray  # (nx, ny) bool
    slope_deg: np.ndarray
    roughness: np.ndarray
    max_slope_deg: float
    max_roughness: float

    def contains(self, points: np.ndarray) -> np.ndarray:
        """True for points that fall in an excluded cell."""
        p = np.asarray(points, np.float64)
        i, j = cell_index(p, self.x0, self.y0, self.cell)
        nx, ny = self.excluded.shape
        # a point just past the grid's edge belongs to the edge cell
        return self.excluded[np.clip(i, 0, nx - 1), np.clip(j, 0, ny - 1)]

    @property
    def excluded_area(self) -> float:
        return float(self.excluded.sum()) * self.cell**2

    def to_dict(self) -> dict[str, Any]:
        return {"excluded_area": self.excluded_area, "cell": self.cell,
                "max_slope_deg": self.max_slope_deg, "max_roughness": self.max_roughness,
                "excluded_cells": int(self.excluded.sum())}


#: The soundings whose spread about the seabed counts as its roughness: within 0.5 m below
#: it and up to this far above it. Not 0.5 m: the tops of reefs sunk 0.5-0.6 m stand 0.3-0.5 m
#: proud, and a group of them counted as rough ground (10-28 reefs of a group excluded in the
#: buried and rocky studies); 0.4 m still excludes the simulator's rough shores.
BAND_TOP = 0.4


def rough_terrain(points: np.ndarray, *, cell: float = 2.0, max_slope_deg: float = 15.0,
                  max_roughness: float = 0.2, min_area: float = 100.0, margin: int = 2,
                  surface: GridSurface | None = None, height: np.ndarray | None = None,
                  skirt: float = 0.0) -> TerrainMask:
    """Steep or rough terrain: cells where the seabed itself is too steep or too rough.

    Both are measured on the robust local seabed surface (which sees through reefs, so a
    reef group is not "rough"): slope from the surface averaged over ``cell`` m; roughness
    the larger of the RMS of the surface about its 2 m Gaussian smoothing and the RMS of
    the soundings from 0.5 m below the surface to :data:`BAND_TOP` above it (rock relief
    narrower than the opening), leaving out those within ``skirt`` m in plan of a sounding
    above that band (an object's flanks as a wide beam draws them). Patches are
    closed and filled, those smaller than ``min_area`` m² are kept (a lone steep cell is a
    sand-wave lee, not a shore), and the rest widened by ``margin`` cells. ``height`` may
    give the points' heights above ``surface`` when the caller has them.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        Soundings (m).
    cell : float
        Judging cell (m).
    max_slope_deg : float
        Steeper is excluded (deg).
    max_roughness : float
        Rougher (RMS, m) is excluded.
    min_area : float
        Smaller patches are kept (m²).
    margin : int
        Cells added around each patch.
    surface : GridSurface, optional
        The robust local seabed, when computed already.
    height : ndarray (N,), optional
        Heights above ``surface``.
    skirt : float
        Plan reach (m) of a wide beam's bloom round anything standing above the band: the
        mixed echoes there are the object's, not rough ground (0: thin beams, none).

    Examples
    --------
    >>> from mbinspect.simulate import simulate
    >>> sim = simulate("reef-field", seed=1, groups="cross1", per_group=4, ping_spacing=0.8,
    ...                close_pairs=0, boulders=0, debris=0)
    >>> rough_terrain(sim.cloud.xyz).excluded_area  # a reef group is not rough terrain
    0.0

    Returns
    -------
    TerrainMask
    """
    pts = check_points(points, minimum=10)
    within("max_slope_deg", max_slope_deg, 0.0, 90.0, open_lo=True, open_hi=True, unit="deg")
    positive("max_roughness", max_roughness)
    fine = surface if surface is not None else grid_seabed(pts, cell=0.5, window=6.0)
    f = max(1, int(round(cell / fine.cell)))
    px, py = (-fine.z.shape[0]) % f, (-fine.z.shape[1]) % f  # pad to whole coarse cells
    z = np.pad(fine.z, ((0, px), (0, py)), mode="edge")
    obs = np.pad(fine.observed, ((0, px), (0, py)))
    nx, ny = z.shape
    coarse = z.reshape(nx // f, f, ny // f, f).mean(axis=(1, 3))
    seen = obs.reshape(nx // f, f, ny // f, f).any(axis=(1, 3))
    step = fine.cell * f
    if min(coarse.shape) >= 2:
        gx, gy = np.gradient(coarse, step)
        slope = np.degrees(np.arctan(np.hypot(gx, gy)))
    else:  # a strip narrower than two judging cells: no slope can be measured across it
        slope = np.zeros_like(coarse)
    detail = z - ndimage.gaussian_filter(z, 2.0 / fine.cell, mode="nearest")
    rough = np.sqrt((detail**2).reshape(nx // f, f, ny // f, f).mean(axis=(1, 3)))
    # rocks narrower than the opening window vanish from the surface: measure the soundings
    # too, near it (reef tops stand higher and drop out, rock relief does not)
    h = fine.height_above(pts) if height is None or surface is None else height
    near = (h >= -0.5) & (h <= BAND_TOP)
    if skirt > 0:
        near &= ~_skirts(pts, h, near, skirt)
    ci, cj = (v[near] for v in cell_index(pts, fine.x0, fine.y0, step))  # no copy of the rows
    ok = (ci >= 0) & (ci < nx // f) & (cj >= 0) & (cj < ny // f)
    key = ci[ok] * (ny // f) + cj[ok]
    cnt = np.bincount(key, minlength=(nx // f) * (ny // f))
    ss = np.bincount(key, weights=h[near][ok] ** 2, minlength=(nx // f) * (ny // f))
    point_rough = np.sqrt(ss / np.maximum(cnt, 1)).reshape(nx // f, ny // f)
    rough = np.maximum(rough, np.where(cnt.reshape(nx // f, ny // f) >= 5, point_rough, 0.0))
    bad = ((slope > max_slope_deg) | (rough > max_roughness)) & seen
    # one patch of rough ground has gentler cells inside and at its rim: close, fill, widen
    bad = ndimage.binary_closing(np.pad(bad, 3), structure=np.ones((5, 5), bool))[3:-3, 3:-3]
    bad = fill_holes(bad)
    lab, k = ndimage.label(bad)
    if k:
        sizes = ndimage.sum(bad, lab, index=np.arange(1, k + 1)) * step * step
        bad = np.isin(lab, 1 + np.flatnonzero(sizes >= min_area))
    if margin > 0 and bad.any():
        bad = ndimage.binary_dilation(bad, structure=np.ones((3, 3), bool), iterations=margin)
    return TerrainMask(fine.x0, fine.y0, step, bad, slope, rough, max_slope_deg, max_roughness)


def _skirts(pts: np.ndarray, h: np.ndarray, near: np.ndarray, skirt: float) -> np.ndarray:
    """The soundings of ``near`` within ``skirt`` m in plan of a sounding standing above
    :data:`BAND_TOP`."""
    tall = h > BAND_TOP
    out = np.zeros(len(pts), bool)
    if tall.any() and near.any():
        cells = Cells.build(np.compress(tall, pts[:, :2], axis=0), skirt)
        rows = np.flatnonzero(near)
        out[rows] = count_within(cells, pts[rows, :2], skirt, 1) > 0
    return out


@dataclass(frozen=True, eq=False)
class Ground:
    """The soundings left for the seabed after the terrain screen, and what it found.

    Attributes
    ----------
    points : ndarray, shape (M, 3)
        Soundings outside the excluded terrain (m).
    height : ndarray (M,) or None
        Their heights above ``grid``, when it was computed.
    grid : GridSurface or None
        The robust local seabed of all the soundings (reused by the seabed stage).
    region : TerrainMask or None
        The terrain judged too steep or rough.
    coverage : float
        Share of the 1 m cells of the extent holding a sounding.
    report : dict or None
        What the exclusion removed (``filters["rough_terrain"]``).
    warnings : tuple of str
    """

    points: np.ndarray
    height: np.ndarray | None
    grid: GridSurface | None
    region: TerrainMask | None
    coverage: float
    report: dict[str, Any] | None
    warnings: tuple[str, ...]
    kept: np.ndarray | None = None  # which input points ``points`` holds (None: all)


def screen_terrain(points: np.ndarray, *, local: bool, seabed: str, exclude_rough: bool,
                   max_slope_deg: float, max_roughness: float, seabed_cell: float,
                   seabed_window: float, skirt: float = 0.0) -> Ground:
    """The soundings on which reefs can be told from the seabed.

    Without a seabed in the cloud (under a quarter of the extent covered) terrain is not
    judged, and a warning says so. ``local`` (our method) computes the robust local
    seabed once for both this stage and the seabed stage (when ``seabed`` is ``auto`` or
    ``grid``) and, with ``exclude_rough``, excludes :func:`rough_terrain`.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        Soundings after the radius filter (m).
    local, seabed, exclude_rough, max_slope_deg, max_roughness, seabed_cell, seabed_window
        As :class:`~mbinspect.reefs.ReefOptions` (``local``: the method is ``"local"``).
    skirt : float
        As :func:`rough_terrain` (m).

    Examples
    --------
    >>> from mbinspect.simulate import simulate
    >>> sim = simulate("reef-field", seed=1, groups="cross1", per_group=4, ping_spacing=0.8,
    ...                close_pairs=0, boulders=0, debris=0)
    >>> ground = screen_terrain(sim.cloud.xyz, local=True, seabed="auto", exclude_rough=True,
    ...                         max_slope_deg=15.0, max_roughness=0.2, seabed_cell=0.5, seabed_window=6.0)
    >>> len(ground.points) == len(sim.cloud), ground.region.excluded_area, ground.coverage > 0.9
    (True, 0.0, True)

    Returns
    -------
    Ground
    """
    cover = coverage(points) if len(points) else 0.0
    warnings = []
    if cover < 0.25:
        warnings.append(f"the soundings cover only {100 * cover:.0f} % of their extent (1 m cells): "
                        "is there a seabed in this cloud, or only the objects on it?")
        exclude_rough = False  # terrain cannot be judged without a seabed
    grid: GridSurface | None = None
    height: np.ndarray | None = None
    if local and seabed in ("auto", "grid") and len(points) >= 3:
        grid = grid_seabed(points, cell=seabed_cell, window=seabed_window)
        height = grid.height_above(points)
    kept, region, report, mask = points, None, None, None
    if exclude_rough and local:
        region = rough_terrain(points, max_slope_deg=max_slope_deg, max_roughness=max_roughness,
                               surface=grid, height=height, skirt=skirt)
        out = region.contains(points)
        report = {"n_removed": int(out.sum()), **region.to_dict()}
        if out.any():
            kept, mask = np.compress(~out, points, axis=0), ~out
            height = height[~out] if height is not None else None
    return Ground(kept, height, grid, region, cover, report, tuple(warnings), mask)
