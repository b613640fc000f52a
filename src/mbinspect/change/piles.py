"""One pile's change between two surveys, each measure with its 95 % level of detection:
the top centre's displacement (from each survey's plan 1-sigma and the registration's), the
top's settlement (each top level's 1-sigma and the vertical registration's), the lean's
change (from the top's displacement over the pile's exposed height) and the scour round it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..geometry import bearing_to_vector, convex_hull, tilted_section
from ..piles.results import PileFit
from .grid import Grid
from .measure import R95, SCOUR_KEYS, Z95, MapNoise, scour_of
from .options import ChangeOptions
from .register import Registration

__all__ = ["pile_change", "pile_outline", "exposed_height"]


def pile_outline(p: PileFit, points: int = 24) -> np.ndarray:
    """The pile's circle at its top as a polygon, shape (points, 2)."""
    t = np.linspace(0, 2 * math.pi, points, endpoint=False)
    return np.column_stack([p.x + p.radius * np.sin(t), p.y + p.radius * np.cos(t)])


def pile_footprint(p: PileFit, height: float, points: int = 24) -> tuple[np.ndarray, tuple[float, float]]:
    """What a pile covers in plan, from its top down to the seabed ``height`` m below the
    top (the hull of its top circle and its section at the seabed, an ellipse along its
    lean), and its foot: where its axis meets the seabed. A plumb pile, an unknown lean or
    height: the top circle and its centre.

    Examples
    --------
    >>> from mbinspect.piles.results import PileFit
    >>> p = PileFit(1, 0.0, 0.0, -5.0, 0.5, 10.0, 90.0, "x", 10, 100, 360.0, 0.01, 0.005)
    >>> poly, foot = pile_footprint(p, 10.0)
    >>> round(foot[0], 2), round(abs(foot[1]), 2), round(float(poly[:, 0].min()), 2)
    (-1.76, 0.0, -2.27)
    """
    top = pile_outline(p, points)
    if p.tilt_deg is None or p.tilt_azimuth_deg is None or not math.isfinite(height) or p.tilt_deg < 0.5:
        return top, (p.x, p.y)
    t = math.radians(p.tilt_deg)
    u = bearing_to_vector(p.tilt_azimuth_deg)
    foot = (float(p.x - height * math.tan(t) * u[0]), float(p.y - height * math.tan(t) * u[1]))
    section = tilted_section(foot, p.radius, p.tilt_deg, p.tilt_azimuth_deg, points)
    return convex_hull(np.vstack([top, section])), foot


def exposed_height(p: PileFit, seabed: Grid, xy: tuple[float, float] | None = None) -> float:
    """The top's height above the seabed round the pile: the median of the grid's cells
    between 1.5 and 3 radii plus 1 m from the centre (NaN: no seabed there)."""
    x, y = seabed.centres()
    cx, cy = xy if xy is not None else (p.x, p.y)
    d = np.hypot(x - cx, y - cy)
    ring = (d >= 1.5 * p.radius + 0.5) & (d <= 3 * p.radius + 1.0) & np.isfinite(seabed.z)
    top = p.top_z if p.top_z is not None else p.z
    return float(top - np.median(seabed.z[ring])) if ring.sum() >= 3 else math.nan


def pile_change(b: PileFit, a: PileFit, a_xy: tuple[float, float], reg: Registration, opt: ChangeOptions, *,
                diff: Grid | None, noise: MapNoise, heights: tuple[float, float]
                ) -> tuple[dict[str, Any], tuple[str, ...], tuple[str, ...]]:
    """A matched pile's change: the values (the pile measures of
    :data:`~mbinspect.change.results.MEASURES` with their ``_lod95``, the levels read), the
    measures detected, and notes. ``a_xy`` is the after pile's top centre in the before
    survey's frame, ``heights`` each survey's exposed height of the pile (m)."""
    notes: list[str] = []
    sb, sa = (p.sigma_xy if math.isfinite(p.sigma_xy) else opt.position_sigma for p in (b, a))
    cov = reg.plan_cov(*a_xy) + np.eye(2) * (sb**2 + sa**2)
    dx, dy = a_xy[0] - b.x, a_xy[1] - b.y
    v: dict[str, Any] = {
        "design": None, "dx": dx, "dx_lod95": Z95 * math.sqrt(cov[0, 0]), "dy": dy,
        "dy_lod95": Z95 * math.sqrt(cov[1, 1]), "displacement": math.hypot(dx, dy),
        "displacement_lod95": R95 * math.sqrt(np.trace(cov) / 2),
        "rotation_deg": math.nan, "rotation_deg_lod95": math.nan,
        "height_before": heights[0], "height_after": heights[1],
        "tilt_before": b.tilt_deg, "tilt_after": a.tilt_deg,
        "overturned_before": None, "overturned_after": None}
    v.update(_settlement(b, a, reg, notes))
    v["height_change"] = heights[1] - heights[0]
    v["height_change_lod95"] = v["settlement_lod95"]
    v.update(_lean(b, a, cov, heights, notes))
    if diff is not None:
        (fb, _), (fa, foot) = pile_footprint(b, heights[0]), pile_footprint(a, heights[1])
        move = np.subtract(a_xy, (a.x, a.y))
        v.update(scour_of(diff, noise, (foot[0] + move[0], foot[1] + move[1]), [fb, fa + move],
                          reach=opt.scour_reach, at_radius=True))
    else:
        v.update(dict.fromkeys(SCOUR_KEYS, math.nan))
        notes.append("scour: no difference map")
    detected = tuple(k for k in ("displacement", "settlement", "tilt_change_deg", "scour_depth")
                     if math.isfinite(v.get(k, math.nan)) and math.isfinite(v.get(k + "_lod95", math.nan))
                     and abs(v[k]) > v[k + "_lod95"])
    return v, detected, tuple(notes)


def _level(p: PileFit, notes: list[str]) -> tuple[float, float]:
    """The top's level and its 1-sigma relative to its own survey: the fitted top level
    where the lines' offsets gave it one; else, read by one line alone, that line's mean's
    own 1-sigma from its pings (its offset is then the survey's, which the vertical
    registration takes); else the least depth's relative TVU, else the top face's own noise
    (soundings without lines or pings: said in a note)."""
    z = p.top_z if p.top_z is not None else p.z
    if p.top_z_lower_bound:
        return z, math.nan
    if p.top_z is not None and math.isfinite(p.top_z_sigma):
        return z, p.top_z_sigma
    if len(p.top_lines) == 1 and float(p.top_lines[0].get("sigma", math.nan)) > 0:
        return z, float(p.top_lines[0]["sigma"])
    rel = p.least.get("least_depth_tvu95_relative")
    if isinstance(rel, (int, float)) and math.isfinite(rel):
        return z, rel / Z95
    if p.n_top >= 3 and math.isfinite(p.rms):
        notes.append(f"settlement: pile {p.id}'s top level has its top face's noise alone for its 1-sigma "
                     "(no lines or pings in its soundings: an offset between lines is not in the bound)")
        return z, p.rms / math.sqrt(p.n_top)
    return z, math.nan


def _settlement(b: PileFit, a: PileFit, reg: Registration, notes: list[str]) -> dict[str, float]:
    (zb, sb), (za, sa) = _level(b, notes), _level(a, notes)
    sz = reg.sigma_dz if math.isfinite(reg.sigma_dz) else math.nan
    lod = Z95 * math.sqrt(sb**2 + sa**2 + sz**2)
    if not math.isfinite(lod):
        notes.append("settlement: a top's level has no 1-sigma (no beam reached it, or the vertical "
                     "registration failed)")
    return {"settlement": zb - (za - reg.dz), "settlement_lod95": lod}


def _lean(b: PileFit, a: PileFit, cov: np.ndarray, heights: tuple[float, float], notes: list[str]
          ) -> dict[str, float]:
    """The lean's change, and its bound: a pile leaning anew about its foot moves its top
    by the exposed height times the change of the lean's sine, so the top's displacement
    bound over that height bounds the lean (the wall's own fit is no surer than the top
    centre it is anchored to)."""
    if b.tilt_deg is None or a.tilt_deg is None:
        notes.append("tilt: not fitted in both surveys")
        return {"tilt_change_deg": math.nan, "tilt_change_deg_lod95": math.nan}
    h = np.nanmean(heights)
    if not (math.isfinite(h) and h > 0.2):
        notes.append("tilt: the pile's exposed height is unknown")
        return {"tilt_change_deg": a.tilt_deg - b.tilt_deg, "tilt_change_deg_lod95": math.nan}
    lod = math.degrees(math.atan(R95 * math.sqrt(np.trace(cov) / 2) / h))
    return {"tilt_change_deg": a.tilt_deg - b.tilt_deg, "tilt_change_deg_lod95": lod}
