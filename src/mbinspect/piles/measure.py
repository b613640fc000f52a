"""Stage 5: one pile measured from its current top and side points, and those points
pruned to the fitted models between iterations (the paper's step 5)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import DataError
from ..fit import fit_cylinder
from .centre import centre_summary
from .intersect import intersection_method, side_coverage
from .options import PileOptions
from .results import PileMeasure, PileSegment, plan_sigma
from .weights import side_sigma

__all__ = ["measure_pile", "prune"]


def measure_pile(seg: PileSegment, top_m: np.ndarray, side_m: np.ndarray, side_normals: np.ndarray, *,
                 options: PileOptions, seed: int, previous: PileMeasure | None = None,
                 gradient: bool = True) -> PileMeasure:
    """One pile's top centre from its current top and side points.

    The method is ``options.method``; the intersection method falls back to the centre
    method, with a flag saying why, when the side has fewer than 6 points or no cylinder
    fits; a top with fewer than 3 soundings is no reason to (the axis is read where the
    side's soundings end, :func:`~mbinspect.piles.intersect.intersection_method`). With
    ``method="both"`` both centres are kept in ``alternatives``.

    Parameters
    ----------
    seg : PileSegment
        The pile's points and its initial top and side masks.
    top_m, side_m : ndarray of bool
        The top and side points in use (masks over ``seg.points``).
    side_normals : ndarray, shape (side_m.sum(), 3)
        Normals of the side points in use.
    options : PileOptions
    seed : int
        Seed of this pile's MSAC.
    previous : PileMeasure, optional
        The previous iteration's measure: its centre and cylinder are the starts.
    gradient : bool
        Find how the centre moves with the radius (``radius_gradient``); a jackknife's
        delete-one measures, which need only the centre, skip it.

    Examples
    --------
    >>> from mbinspect.piles import PileOptions, PileSegment
    >>> rng = np.random.default_rng(1)
    >>> a, z = rng.uniform(0, 2 * np.pi, 800), rng.uniform(-19, -16.3, 800)
    >>> side = np.column_stack([0.75 * np.cos(a), 0.75 * np.sin(a), z])
    >>> r, t = 0.6 * np.sqrt(rng.uniform(0, 1, 300)), rng.uniform(0, 2 * np.pi, 300)
    >>> top = np.column_stack([r * np.cos(t), r * np.sin(t), np.full(300, -16.0)])
    >>> seg = PileSegment(np.vstack([side, top]), np.r_[np.zeros(800, bool), np.ones(300, bool)],
    ...                   np.r_[np.ones(800, bool), np.zeros(300, bool)])
    >>> nrm = np.column_stack([np.cos(a), np.sin(a), np.zeros(800)])
    >>> m = measure_pile(seg, seg.top, seg.side, nrm, options=PileOptions(radius=0.75), seed=1)
    >>> m.method, round(m.x, 3) + 0.0, round(m.y, 3) + 0.0, round(m.z, 3)
    ('intersection', 0.0, 0.0, -16.0)

    Returns
    -------
    PileMeasure

    Raises
    ------
    DataError
        Neither top nor side points enough to measure the pile.
    """
    top, side = seg.points[top_m], seg.points[side_m]
    gtop = None if seg.ping is None else seg.ping[top_m]
    method = options.method
    flags: list[str] = []
    alternatives: dict[str, dict[str, Any]] = {}
    centre = None
    if method in ("centre", "both") or len(side) < 6:
        if len(top) == 0:
            raise DataError(f"pile at ({seg.points[:, 0].mean():.2f}, {seg.points[:, 1].mean():.2f}): "
                            "no top points and too few side points to measure it")
        start = None if previous is None else previous.centre
        centre = centre_summary(top, radius=options.radius, ks=options.ks, start=start, groups=gtop,
                                cell=_area_cell(options))
        alternatives["centre"] = centre
    found = None
    if method in ("intersection", "both") and len(side) >= 6:
        try:
            found = _by_intersection(seg, top, side, side_m, side_normals, options, seed, previous, gradient)
        except DataError as exc:
            flags.append(f"intersection method failed ({exc}); centre method used")
        else:
            alternatives["intersection"] = {"x": found.x, "y": found.y, "z": found.z,
                                            "sigma_xy": found.sigma_xy}
    if found is None:
        if centre is None:
            centre = centre_summary(top, radius=options.radius, ks=options.ks, start=None, groups=gtop,
                                    cell=_area_cell(options))
        dz = top[:, 2] - centre["z"]
        if method != "centre" and not flags:
            flags.append(f"only {len(side)} side points: centre method used")
        found = PileMeasure(centre["x"], centre["y"], centre["z"], "centre", centre["cov"],
                            centre["sigma_xy"], float(np.sqrt(np.mean(dz**2))), int(len(top)),
                            int(len(side)), coverage=0.0, top_coverage=centre["top_coverage"])
    return PileMeasure(**{**found.__dict__, "flags": tuple(flags) + found.flags,
                          "alternatives": alternatives if method == "both" else {}})


#: The area mean's cell, as a share of the radius (0.1 m for a 0.5 m pile).
AREA_CELL_SHARE = 0.2


def _area_cell(options: PileOptions) -> float | None:
    """The centre method's area-mean cell (m); None (the paper's plain mean) with the
    paper's segmentation."""
    return None if options.segmentation == "paper" else AREA_CELL_SHARE * options.radius


def _by_intersection(seg: PileSegment, top: np.ndarray, side: np.ndarray, side_m: np.ndarray,
                     side_normals: np.ndarray, options: PileOptions, seed: int,
                     previous: PileMeasure | None, gradient: bool = True) -> PileMeasure:
    """The intersection method's measure of one pile (raises DataError when it cannot)."""
    gside = None if seg.ping is None else seg.ping[side_m]
    cyl, plane, centre, s_in, t_in, cov, notes, held = intersection_method(
        side, side_normals, top, radius=options.radius, threshold=options.threshold,
        max_tilt_deg=options.max_tilt_deg, seed=seed, groups=gside,
        start=previous.cylinder if previous is not None else None, radius_mode=options.radius_mode,
        side_sigma=side_sigma(seg, side_m, previous, options.weights), axis_mode=options.axis_mode)
    r_res = cyl.residuals(side[s_in])
    r_free: float | None = None
    r_sigma = math.nan
    try:
        free, fcov = fit_cylinder(side[s_in], cyl, radius=None, z_ref=float(centre[2]),
                                  f_scale=options.threshold / 3,
                                  groups=None if gside is None else gside[s_in], random_effects=False)
        r_free = free.radius
        r_sigma = math.sqrt(float(fcov[4, 4])) if fcov.shape[0] > 4 and fcov[4, 4] >= 0 else math.nan
    except (ValueError, np.linalg.LinAlgError):  # no free radius from this side (DataError included)
        pass
    sig = plan_sigma(cov)
    grad = None if not gradient or options.radius_mode == "free" or cyl.radius != options.radius else \
        _radius_gradient(side[s_in], cyl, plane, centre, held, gside[s_in] if gside is not None else None)
    return PileMeasure(float(centre[0]), float(centre[1]), float(centre[2]), "intersection", cov[:2, :2],
                       sig, float(np.sqrt(np.mean(r_res**2))), int(t_in.sum()), int(s_in.sum()),
                       coverage=side_coverage(cyl, side[s_in]), top_coverage=None,
                       tilt_deg=cyl.tilt_deg, tilt_azimuth_deg=cyl.tilt_bearing_deg, cylinder=cyl,
                       plane=plane, radius_fitted=r_free, radius_used=cyl.radius, flags=tuple(notes),
                       radius_fitted_sigma=r_sigma, tilt_held=held, radius_gradient=grad)


#: The step (m) of the radius for :func:`_radius_gradient`.
RADIUS_STEP = 0.01


def _radius_gradient(side: np.ndarray, cyl: Any, plane: Any, centre: np.ndarray, plumb: bool,
                     groups: np.ndarray | None) -> tuple[float, float] | None:
    """How far the plan centre moves per metre of the fixed radius: the side's cylinder
    refitted :data:`RADIUS_STEP` wider, its axis met with the same top plane."""
    from ..fit import Cylinder

    try:
        wider, _ = fit_cylinder(side, Cylinder(cyl.point, cyl.axis, cyl.radius + RADIUS_STEP),
                                radius=cyl.radius + RADIUS_STEP, z_ref=float(centre[2]), groups=groups,
                                plumb=plumb, random_effects=False)
        base, _ = fit_cylinder(side, cyl, radius=cyl.radius, z_ref=float(centre[2]), groups=groups,
                               plumb=plumb, random_effects=False)
    except (ValueError, np.linalg.LinAlgError):  # the side does not hold a refit (DataError included)
        return None
    a, b = wider.intersect(plane), base.intersect(plane)
    if a is None or b is None:
        return None
    g = (np.asarray(a)[:2] - np.asarray(b)[:2]) / RADIUS_STEP
    return float(g[0]), float(g[1])


def prune(seg: PileSegment, fit: PileMeasure, *, radius: float, ks: float, threshold: float
          ) -> tuple[np.ndarray, np.ndarray]:
    """The top and side points that agree with a pile's fitted models (the paper's step 5).

    Side points within a band of the cylinder that follows the noise (3 robust sigmas, at
    least ``threshold``: a fixed band would truncate noisy data, shrink its spread and hide
    its errors); top points within ``r + k_s`` of the axis and ``threshold`` of the top
    plane; with the centre method, top points within ``r + k_s`` of the centre. A mask
    that would keep too few points (6 side, 3 top) stays the segment's initial one.

    Parameters
    ----------
    seg : PileSegment
    fit : PileMeasure
        This iteration's measure.
    radius, ks, threshold : float
        Prior radius, the paper's k_s and the inlier distance (m).

    Examples
    --------
    >>> from mbinspect.piles import PileMeasure, PileSegment
    >>> pts = np.array([[0.0, 0, -16], [0.3, 0, -16], [0.2, 0.1, -16], [3.0, 0, -16]])
    >>> seg = PileSegment(pts, np.ones(4, bool), np.zeros(4, bool))
    >>> fit = PileMeasure(0.0, 0.0, -16.0, "centre", np.eye(2), 0.0, 0.0, 4, 0)
    >>> top, side = prune(seg, fit, radius=0.75, ks=0.1, threshold=0.06)
    >>> top.tolist()
    [True, True, True, False]

    Returns
    -------
    top, side : ndarray of bool
        Masks over ``seg.points``.
    """
    cyl, plane = fit.cylinder, fit.plane
    new_side = seg.side.copy()
    new_top = seg.top.copy()
    if cyl is not None:
        r = np.abs(cyl.residuals(seg.points))
        near = seg.side & (r <= 5 * threshold)
        band = max(threshold, 3.0 * 1.4826 * float(np.median(r[near]))) if near.sum() > 10 else threshold
        sel = seg.side & (r <= band)
        if sel.sum() >= 6:
            new_side = sel
        axis_d = np.abs(cyl.residuals(seg.points) + cyl.radius)
        tsel = seg.top & (axis_d <= radius + ks)
        if plane is not None:
            tsel &= np.abs(plane.residuals(seg.points)) <= threshold
        if tsel.sum() >= 3:
            new_top = tsel
    else:
        c = np.array([fit.x, fit.y])
        tsel = seg.top & (np.hypot(*(seg.points[:, :2] - c).T) <= radius + ks)
        if tsel.sum() >= 3:
            new_top = tsel
    return new_top, new_side
