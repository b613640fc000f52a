"""One reef's change between two surveys, each measure with its 95 % level of detection
(LoD): the bound a change must pass to be told from the two surveys' errors and the
registration's.

Positions come from the design fit (or the footprint) of each survey, known to
``position_sigma`` each; the top's settlement from the plane through its top in each
survey's levelled soundings (:mod:`.tops`; else from the least depths and their TVU), the
exposed height from those tops (else the least depths) over each survey's seabed round the
unit (a plane through the soundings just beyond its outline, :mod:`.tops`); the tilt
from each top plane's 1-sigma; scour from the registered difference map round the unit,
against the seabed just beyond ``scour_reach``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..geometry import points_in_polygon
from ..reefs.plan import bearing_sigma_of, position_sigma_of
from ..reefs.results import Reef
from ..scour import RING, clipped, grown, lone, ring_radii, scour_rings
from .grid import Grid
from .options import ChangeOptions
from .register import Registration
from .tops import Levels

__all__ = ["reef_change", "scour_of", "MapNoise", "CORRELATED_AREA", "Z95"]

#: The two-sided normal 95 % quantile, and the 95 % radius of a round 2-D normal in sigmas.
Z95, R95 = 1.959963984540054, 2.447746830680816

#: The scour measures and their levels of detection.
SCOUR_KEYS = ("scour_depth", "scour_depth_lod95", "scour_radius", "scour_radius_lod95", "scour_volume",
              "scour_volume_lod95")

#: The least area (m²) over which a difference map's errors are shared (a beam's footprint,
#: a ping's roll): cells within it are not independent.
CORRELATED_AREA = 1.0


@dataclass(frozen=True)
class MapNoise:
    """A difference map's noise: its cells' robust spread ``sigma`` (m) and the ``area``
    (m²) over which their errors are shared, both measured on the seabed away from the
    objects."""

    sigma: float
    area: float = CORRELATED_AREA
    scour_null95: float = 0.0


def null_scour(diff: Grid, noise: MapNoise, radius: float, *, reach: float, at_radius: bool = False
               ) -> tuple[float, int]:
    """The scour depth the map shows where nothing was dug: read as :func:`scour_of` reads
    it round centres on a lattice ``reach`` m apart over the map (each with a footprint of
    ``radius`` m left out, as a unit's is; farther apart on a large map, about 300 in
    all), at those whose surroundings are mostly mapped;
    the 95th percentile of those depths and how many centres gave it (0 and 0 below 20).
    It carries what the cells' spread does not: steps and stripes between lines, the
    registration's residual tilt, the swath edges, each many metres long.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> g = Grid(0.0, 0.0, 0.5, rng.normal(0, 0.01, (160, 160)), np.ones((160, 160), int))
    >>> q, n = null_scour(g, MapNoise(0.01), 1.0, reach=6.0)
    >>> n >= 20 and 0.0 < q < 0.01
    True
    """
    ny, nx = diff.z.shape
    x_min, y_min = diff.x0 + diff.cell / 2, diff.y0 + diff.cell / 2
    span_x, span_y = (nx - 1) * diff.cell, (ny - 1) * diff.cell
    step = max(reach, math.sqrt(span_x * span_y / 300.0))  # at most about 300 centres
    t = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    ring = radius * np.column_stack([np.sin(t), np.cos(t)])
    depths = []
    for cx in x_min + step / 2 + np.arange(max(int(span_x // step), 0)) * step:
        for cy in y_min + step / 2 + np.arange(max(int(span_y // step), 0)) * step:
            wx, wy, wz = _window(diff, (cx, cy), reach + 2.0)
            if np.isfinite(wz[np.hypot(wx - cx, wy - cy) <= reach + 2.0]).mean() < 0.6:
                continue
            d = scour_of(diff, noise, (cx, cy), [ring + (cx, cy)], reach=reach,
                         at_radius=at_radius)["scour_depth"]
            if math.isfinite(d):
                depths.append(max(d, 0.0))
    if len(depths) < 20:
        return 0.0, len(depths)
    return float(np.percentile(depths, 95)), len(depths)


def reef_change(b: Reef, a: Reef, a_xy: tuple[float, float], a_outline: np.ndarray, reg: Registration,
                opt: ChangeOptions, *, turn: float, diff: Grid | None, noise: MapNoise,
                tops: tuple[Levels, Levels] | None = None
                ) -> tuple[dict[str, Any], tuple[str, ...], tuple[str, ...]]:
    """A matched reef's change: the values (:data:`~mbinspect.change.results.MEASURES` with
    their ``_lod95``, and the levels read), the measures detected, and notes.

    ``a_xy`` and ``a_outline`` are the after reef's centre and outline carried into the
    before survey's frame; ``turn`` the design's symmetry (deg); ``diff`` the registered
    difference map (after minus before) and ``noise`` its noise; ``tops`` each survey's top
    level of the unit from its levelled soundings (:func:`~mbinspect.change.tops.top_level`),
    which its settlement is read from where both were read (else from the least depths), and
    the seabed round it (:func:`~mbinspect.change.tops.ground_level`), which its exposed
    height stands on.
    """
    v: dict[str, Any] = {"design": b.design or a.design}
    notes: list[str] = []
    # each survey's centre to its own 1-sigma (told the beam, with what its footprint leaves)
    cov = reg.plan_cov(*a_xy) + np.eye(2) * sum(position_sigma_of(r, opt.position_sigma)**2 for r in (b, a))
    dx, dy = a_xy[0] - b.x, a_xy[1] - b.y
    v.update(dx=dx, dx_lod95=Z95 * math.sqrt(cov[0, 0]), dy=dy, dy_lod95=Z95 * math.sqrt(cov[1, 1]),
             displacement=math.hypot(dx, dy), displacement_lod95=R95 * math.sqrt(np.trace(cov) / 2))
    if math.isfinite(b.design_bearing_deg) and math.isfinite(a.design_bearing_deg) and b.design == a.design:
        turned = a.design_bearing_deg - reg.rotation_deg - b.design_bearing_deg
        v["rotation_deg"] = (turned + turn / 2) % turn - turn / 2
        rs = reg.sigma_rotation_deg if math.isfinite(reg.sigma_rotation_deg) else 0.0
        sb, sa = (bearing_sigma_of(r, opt.bearing_sigma_deg) for r in (b, a))
        v["rotation_deg_lod95"] = Z95 * math.sqrt(sb**2 + sa**2 + rs**2)
    else:
        v["rotation_deg"] = v["rotation_deg_lod95"] = math.nan
        notes.append("rotation: no design fitted in both surveys" if b.design == a.design
                     else f"rotation: fitted as {b.design or 'no design'} before, "
                          f"{a.design or 'no design'} after")
    v.update(_levels(b, a, reg, notes, tops))
    v.update(_tilts(b, a, notes))
    if diff is not None:
        v.update(scour_of(diff, noise, a_xy, [np.asarray(b.outline), a_outline], reach=opt.scour_reach))
    else:
        v.update(dict.fromkeys(SCOUR_KEYS, math.nan))
        notes.append("scour: no difference map")
    detected = tuple(k for k in ("displacement", "rotation_deg", "settlement", "height_change",
                                 "tilt_change_deg", "scour_depth")
                     if math.isfinite(v.get(k, math.nan)) and math.isfinite(v.get(k + "_lod95", math.nan))
                     and abs(v[k]) > v[k + "_lod95"])
    if v["overturned_before"] is not None and v["overturned_after"] is not None \
            and v["overturned_before"] != v["overturned_after"]:
        detected += ("overturned",)
    return v, detected, tuple(notes)


def _levels(b: Reef, a: Reef, reg: Registration, notes: list[str],
            tops: tuple[Levels, Levels] | None = None) -> dict[str, Any]:
    """Settlement of the top (the top planes' highest points in the levelled soundings, else the
    least depths; registered) and the exposed heights."""
    lb, la = b.least or {}, a.least or {}
    db, da = _num(lb.get("least_depth")), _num(la.get("least_depth"))
    # each survey's own line levels are what the vertical registration measures: a survey of
    # one line (no level of its own) is compared by its least depths' noise
    tb, ta = (_num(d.get("least_depth_tvu95_relative", d.get("least_depth_tvu95"))) for d in (lb, la))
    out: dict[str, Any] = {}
    sz = reg.sigma_dz if math.isfinite(reg.sigma_dz) else math.nan
    unread = (math.nan, math.nan, "not read", math.nan, 0.0)
    (zb, sb, why_b, gb, pb), (za, sa, why_a, ga, pa) = tops or (unread, unread)
    if b.overturned or a.overturned:  # the plane through a unit on its side is a face, not its top
        zb = za = math.nan
        why_b = "the unit is overturned in one survey"
    out["top_level_before"], out["top_level_after"] = zb, za
    least_lod = math.sqrt(tb**2 + ta**2 + (Z95 * sz) ** 2)
    if math.isfinite(zb) and math.isfinite(za):
        out["settlement"] = zb - (za - reg.dz)
        # the planes alone bound it at about a third of the least depths' bound, and cover
        # 96 % of its errors; but six measures share a unit's 5 % of false calls, and that
        # bound alone spent 4-6 % of them: the least depths' bound is kept where it is wider
        out["settlement_lod95"] = max(Z95 * math.sqrt(sb**2 + sa**2 + sz**2), least_lod) \
            if math.isfinite(least_lod) else Z95 * math.sqrt(sb**2 + sa**2 + sz**2)
    elif math.isfinite(db) and math.isfinite(da):
        out["settlement"] = da + reg.dz - db
        out["settlement_lod95"] = least_lod
        if tops is not None:
            notes.append(f"settlement: from the least depths (top plane: {why_b or why_a})")
    else:  # no least depth: the tops as the pipeline read them, their bound unknown
        out["settlement"] = (b.z_top - (a.z_top - reg.dz))
        out["settlement_lod95"] = math.nan
    if not math.isfinite(out["settlement_lod95"]):
        notes.append("settlement: the least depths' TVU or the vertical registration is unknown")
    # exposed heights from the tops as the settlement reads them (a leaning top at its high
    # edge: a median top reads it low, by 8 cm RMS over tilted units), else the least depths
    # (the highest point the soundings support, as its bound is), over each survey's seabed
    # round the unit (else the pipeline's seabed under it, which bends into a scour pit round it)
    if not (math.isfinite(gb) and math.isfinite(ga)):
        gb, ga, pb, pa = b.z_seabed, a.z_seabed, 0.0, 0.0
    if math.isfinite(zb) and math.isfinite(za) and math.isfinite(gb) and math.isfinite(ga):
        hb, ha = zb - gb, za - ga
    else:
        hb, ha = _exposed(db, gb, b.height), _exposed(da, ga, a.height)
    out["height_before"], out["height_after"] = hb, ha
    out["height_change"] = ha - hb
    # the seabed round the unit read on a band whose place the outline sets: in a pit's wall
    # that place moves the level (classic sonar, scoured units: 68 % within the tops' bound alone)
    out["height_change_lod95"] = math.sqrt(tb**2 + ta**2 + (Z95 * pb) ** 2 + (Z95 * pa) ** 2)
    return out


def _exposed(depth: float, seabed: float, height: float) -> float:
    """A unit's exposed height: its least depth's top above ``seabed``, else the pipeline's
    ``height`` (a median top)."""
    return -depth - seabed if math.isfinite(depth) and math.isfinite(seabed) else height


def _tilts(b: Reef, a: Reef, notes: list[str]) -> dict[str, Any]:
    """The top plane's tilt in each survey and its change; how each unit rests."""
    out: dict[str, Any] = {"tilt_before": b.top_tilt_deg, "tilt_after": a.top_tilt_deg,
                           "overturned_before": b.overturned, "overturned_after": a.overturned}
    out["tilt_change_deg"] = a.top_tilt_deg - b.top_tilt_deg
    out["tilt_change_deg_lod95"] = Z95 * math.sqrt(b.top_tilt_sigma_deg**2 + a.top_tilt_sigma_deg**2)
    if b.overturned or a.overturned:  # the top plane of a unit on its side is a face, not its lean
        out["tilt_change_deg"] = out["tilt_change_deg_lod95"] = math.nan
        notes.append("tilt: a unit overturned in one survey has no comparable top")
    return out


def scour_of(diff: Grid, noise: MapNoise, centre: tuple[float, float], outlines: list[np.ndarray], *,
             reach: float, at_radius: bool = False) -> dict[str, float]:
    """Scour round one unit from the registered difference map: the lowering against the
    seabed 2 m beyond ``reach``, read by :func:`mbinspect.scour.scour_rings`, each with its
    level of detection from the map's ``noise`` (cells within its area sharing their
    errors). ``at_radius``: each ring read all round is read at its own radius
    (:func:`_ring_radii`), for a round object (a pile) whose pit is round it too."""
    x, y, z = _window(diff, centre, reach + 2.0)
    dist = np.hypot(x - centre[0], y - centre[1])
    near = dist <= reach + 2.0
    pts = np.column_stack([x[near], y[near]])
    inside = np.zeros(len(pts), bool)
    for poly in outlines:
        if len(poly) >= 3:
            inside |= points_in_polygon(pts, grown(poly))
    d, diffs = dist[near][~inside], z[near][~inside]
    ref_cells = (d > reach) & np.isfinite(diffs)
    nan = dict.fromkeys(SCOUR_KEYS, math.nan)
    if ref_cells.sum() < 8:
        return nan
    level = float(np.median(diffs[ref_cells]))
    area, sigma = diff.cell**2, noise.sigma
    share = max(area / max(noise.area, area), 1e-9)  # the independent share of a cell
    radii, areas = _ring_radii(diff, centre, outlines, reach) if at_radius else (None, None)
    odd = lone(z, sigma)[near][~inside]
    s = scour_rings(d, clipped(d, -(diffs - level), sigma, reach=reach, only=odd), area, reach=reach,
                    ring_radius=radii, ring_area=areas)
    if s.cells == 0:
        return nan
    ref_var = sigma**2 / max(ref_cells.sum() * share, 1.0)
    depth_lod = max(Z95 * math.sqrt(sigma**2 / max(s.deepest_cells * share, 1.0) + ref_var),
                    noise.scour_null95)
    vol_lod = Z95 * math.sqrt(s.cells * area**2 * sigma**2 / share + (s.cells * area) ** 2 * ref_var)
    found = s.depth > depth_lod
    return {"scour_depth": s.depth, "scour_depth_lod95": depth_lod,
            "scour_radius": s.radius if found else math.nan,
            "scour_radius_lod95": 2 * RING if found else math.nan,
            "scour_volume": s.volume, "scour_volume_lod95": vol_lod}


#: The share of a ring (outside the object) the map must read for the ring to be read at its radius.
ALL_ROUND = 0.9


def _ring_radii(diff: Grid, centre: tuple[float, float], outlines: list[np.ndarray], reach: float
                ) -> tuple[np.ndarray, np.ndarray]:
    """Each ring's mean radius over the area the map reads in it: outside the grown outlines,
    within a cell of a mapped cell (not the sliver between the object's outline and the first
    cell centres beyond it); NaN for a ring the map does not read all round (nine tenths of
    it): a neighbour's footprint, the swath's edge or a hole in the map leaves the ring's
    lowering no longer a matter of the distance alone, and it is read as its cells' mean.
    And each ring's area read (m²), on the same fine lattice."""
    grown_polys = [grown(poly) for poly in outlines if len(poly) >= 3]
    ny, nx = diff.z.shape
    mapped = np.isfinite(diff.z)

    def outside(pts: np.ndarray) -> np.ndarray:
        ok = np.ones(len(pts), bool)
        for poly in grown_polys:
            ok[ok] = ~points_in_polygon(pts[ok], poly)
        return ok

    def read(pts: np.ndarray) -> np.ndarray:
        i = np.floor((pts[:, 0] - diff.x0) / diff.cell).astype(np.int64)
        j = np.floor((pts[:, 1] - diff.y0) / diff.cell).astype(np.int64)
        near = np.zeros(len(pts), bool)
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                ii, jj = i + di, j + dj
                there = (ii >= 0) & (jj >= 0) & (ii < nx) & (jj < ny)
                there[there] = mapped[jj[there], ii[there]]
                near |= there
        return near & outside(pts)

    step = diff.cell / 5
    radii, n_read = ring_radii(centre, read, reach, step=step)
    _, n_all = ring_radii(centre, outside, reach, step=step)
    return np.where(n_read >= ALL_ROUND * np.maximum(n_all, 1), radii, np.nan), n_read * step**2


def _window(g: Grid, centre: tuple[float, float], r: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The centres (x, y) and values of the grid's cells within the square of half-side
    ``r`` round ``centre`` (and a cell beyond), each shaped alike."""
    ny, nx = g.z.shape

    def span(lo: float, hi: float, origin: float, n: int) -> tuple[int, int]:
        return (min(max(int((lo - origin) // g.cell) - 1, 0), n),
                min(max(int((hi - origin) // g.cell) + 2, 0), n))

    i0, i1 = span(centre[0] - r, centre[0] + r, g.x0, nx)
    j0, j1 = span(centre[1] - r, centre[1] + r, g.y0, ny)
    x, y = np.meshgrid(g.x0 + (np.arange(i0, i1) + 0.5) * g.cell, g.y0 + (np.arange(j0, j1) + 0.5) * g.cell)
    return x, y, g.z[j0:j1, i0:i1]


def _num(v: Any) -> float:
    return float(v) if isinstance(v, (int, float)) and v is not None else math.nan


def symmetry_turns(parameters: Mapping[str, Any]) -> dict[str, float]:
    """Design name -> the turn (deg) after which it looks the same, from a result's
    recorded designs."""
    return {d["name"]: 360.0 / max(int(d.get("symmetry") or 1), 1)
            for d in parameters.get("design") or [] if isinstance(d, dict) and "name" in d}
