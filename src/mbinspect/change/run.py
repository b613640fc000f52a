"""Stage list of :func:`compare_surveys`: grid both surveys' soundings, register them on the
seabed away from the objects, carry the after survey's objects into the before survey's
frame, match them one to one, difference the seabed, and measure each object's change
(reefs: :mod:`.measure`; piles: :mod:`.piles`)."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from ..errors import InputError
from ..grid import bounds
from ..piles.results import PileResult
from ..reefs.results import Reef, ReefResult
from ..version import __version__
from .grid import Grid, line_levels, median_grid, ping_levels
from .match import match_objects
from .measure import CORRELATED_AREA, MapNoise, null_scour, reef_change, symmetry_turns
from .options import ChangeOptions
from .piles import exposed_height, pile_change, pile_footprint, pile_outline
from .register import IDENTITY, Registration, register
from .results import ChangeResult, ObjectChange
from .tie import PILE_TIES, tie_to_objects
from .tops import Levels, reef_tops

__all__ = ["compare_surveys"]


Result = ReefResult | PileResult


def compare_surveys(before: Result, after: Result, before_points: np.ndarray,
                    after_points: np.ndarray, *, options: ChangeOptions | None = None,
                    before_fields: Mapping[str, Any] | None = None,
                    after_fields: Mapping[str, Any] | None = None,
                    progress: Callable[[float], None] | None = None,
                    **given: Any) -> ChangeResult:
    """Two surveys of one reef field, or of one jacket's piles, compared object by object.

    Parameters
    ----------
    before, after : ReefResult or PileResult
        Each survey's reefs (:func:`~mbinspect.reefs.extract_reefs`) or piles
        (:func:`~mbinspect.piles.locate_piles`), or either read back; both of one kind.
    before_points, after_points : ndarray, shape (N, 3)
        Each survey's soundings, on the vertical reference its result records.
    before_fields, after_fields : mapping, optional
        Each survey's per-sounding fields (a :class:`~mbinspect.cloud.PointCloud`'s):
        with ``ping``, each ping is levelled against the others of its line
        (:func:`~mbinspect.change.grid.ping_levels`), with ``line``, the lines against each
        other (:func:`~mbinspect.change.grid.line_levels`); with ``beam_angle``, the outer beams
        are left out of the registration (``inner_angle_deg``).
    options : ChangeOptions, optional
    progress : callable, optional
        Called with the fraction done.
    **given
        Options by name (instead of ``options``).

    Returns
    -------
    ChangeResult

    Raises
    ------
    InputError
        Results in different coordinate systems, or soundings that do not overlap.
    """
    opt = options or ChangeOptions(**given)
    report = progress or (lambda f: None)
    kind = "piles" if isinstance(before, PileResult) else "reefs"
    if isinstance(after, PileResult) != (kind == "piles"):
        raise InputError(f"the before survey's result holds {kind}, the after survey's "
                         f"{'piles' if kind == 'reefs' else 'reefs'}; expected two of one kind")
    warnings = _compatible(before, after)
    b_pts, a_pts = np.asarray(before_points, np.float64), np.asarray(after_points, np.float64)
    lo_b, hi_b = bounds(b_pts)
    lo_a, hi_a = bounds(a_pts)
    lo, hi = np.maximum(lo_b, lo_a), np.minimum(hi_b, hi_a)
    if np.any(hi - lo < 4 * opt.cell):
        raise InputError(f"the surveys do not overlap: before spans {_span(lo_b, hi_b)}, "
                         f"after {_span(lo_a, hi_a)}")
    inner = opt.inner_angle_deg
    (b_pts, b_in), (a_pts, a_in) = (_prepared(b_pts, before_fields, opt.level_lines, inner),
                                    _prepared(a_pts, after_fields, opt.level_lines, inner))
    warnings += _unlevelled(before_fields, after_fields, opt.level_lines)
    spots = _spots(before) + _spots(after)
    reg, beams = _registered(b_pts, a_pts, (b_in, a_in), spots, lo, hi, opt)
    if opt.tie_objects:
        reg = _tied(reg, before, after, opt)
    report(0.6)
    if reg is IDENTITY:
        warnings.append(reg.note)
    db, da = _grids(b_pts, a_pts, lo, hi, opt.scour_cell, min_count=1)
    diff, diff_sigma = _difference(db, da, reg, _away(db, spots, opt.exclude_buffer))
    diff = _without_objects(diff, before, after, reg, (db, da))
    noise = MapNoise(diff_sigma, _shared_area(diff, diff_sigma))
    null95, null_n = null_scour(diff, noise, _typical_radius(before), reach=opt.scour_reach,
                                at_radius=isinstance(before, PileResult))
    noise = MapNoise(noise.sigma, noise.area, null95)
    if isinstance(before, PileResult) and isinstance(after, PileResult):
        objects = _piles(before, after, reg, opt, diff, noise, (db, da))
    elif isinstance(before, ReefResult) and isinstance(after, ReefResult):
        tops = (reef_tops(before.reefs, b_pts, before_fields), reef_tops(after.reefs, a_pts, after_fields))
        objects = _objects(before, after, reg, opt, diff, noise, tops)
    report(1.0)
    params = {**opt.to_dict(), "registration_beams": beams, "before": _record(before),
              "after": _record(after),
              "difference_sigma": diff_sigma, "difference_shared_area": noise.area,
              "scour_null95": null95, "scour_null_centres": null_n,
              "software": f"mbinspect {__version__}"}
    return ChangeResult(kind, reg, tuple(objects), params, tuple(warnings), diff)


def _prepared(pts: np.ndarray, fields: Mapping[str, Any] | None, level: bool, inner_deg: float
              ) -> tuple[np.ndarray, np.ndarray]:
    """The soundings with their pings and lines levelled (when known and ``level``), and which of
    them the registration reads: those within ``inner_deg`` of nadir where beam angles are
    known and they leave at least half the soundings, else all."""
    fields = fields or {}
    line = np.asarray(fields["line"]) if "line" in fields else np.zeros(len(pts), np.int8)
    if level and "ping" in fields:
        pts = pts.copy()
        pts[:, 2] -= ping_levels(pts, line, np.asarray(fields["ping"]))
    if level and len(np.unique(line)) > 1:
        pts = pts.copy()
        pts[:, 2] -= line_levels(pts, line)
    inner = np.ones(len(pts), bool)
    if "beam_angle" in fields:
        near = np.abs(np.asarray(fields["beam_angle"], np.float64)) <= inner_deg
        if near.sum() >= len(pts) / 2:
            inner = near
    return pts, inner


def _registered(b_pts: np.ndarray, a_pts: np.ndarray, inner: tuple[np.ndarray, np.ndarray], spots: list[Any],
                lo: np.ndarray, hi: np.ndarray, opt: ChangeOptions) -> tuple[Registration, str]:
    """The registration on the inner beams, or on every beam where the inner ones alone
    leave the plan shift half again as uncertain (a sonar whose beams crowd its swath's
    edges, a small survey), and which beams it read."""
    def on(b: np.ndarray, a: np.ndarray) -> Registration:
        gb, ga = _grids(b, a, lo, hi, opt.cell)
        return register(gb, ga, _away(gb, spots, opt.exclude_buffer), rotation=opt.rotation)

    b_in, a_in = inner
    reg = on(b_pts[b_in], a_pts[a_in])
    if b_in.all() and a_in.all():
        return reg, "all"
    every = on(b_pts, a_pts)
    plan = [max(r.sigma_dx, r.sigma_dy) for r in (reg, every)]
    if every is not IDENTITY and (reg is IDENTITY or not plan[0] <= 1.5 * plan[1]):
        return every, "all"
    return reg, f"within {opt.inner_angle_deg:g} deg of nadir"


def _positions(r: Result) -> np.ndarray:
    """The plan positions (n, 2) of a result's reefs or piles."""
    items = r.piles if isinstance(r, PileResult) else r.reefs
    return np.array([[o.x, o.y] for o in items], np.float64).reshape(-1, 2)


def _tied(reg: Registration, before: Result, after: Result, opt: ChangeOptions) -> Registration:
    """The registration's plan shift refined on the matched objects that kept their place
    (:func:`~mbinspect.change.tie.tie_to_objects`)."""
    bxy, axy = _positions(before), _positions(after)
    carried = np.column_stack(reg.to_before(axy[:, 0], axy[:, 1])).reshape(-1, 2)
    pairs = match_objects(bxy, carried, max_move=opt.max_move)
    noise = math.sqrt(2) * opt.position_sigma
    if not (isinstance(before, PileResult) and isinstance(after, PileResult)):
        return tie_to_objects(reg, bxy, carried, pairs, noise=noise)
    # a jacket's top centres: three of four tie it, their moves' spread no less than their 1-sigma
    sig = [p.sigma_xy for p in (*before.piles, *after.piles) if math.isfinite(p.sigma_xy)]
    floor = math.sqrt(2) * float(np.median(sig)) if sig else opt.position_sigma
    return tie_to_objects(reg, bxy, carried, pairs, noise=noise, least=PILE_TIES, floor=min(floor, noise))


def _unlevelled(before: Mapping[str, Any] | None, after: Mapping[str, Any] | None, level: bool) -> list[str]:
    """A warning for each survey whose lines could not be levelled: its soundings carry no line."""
    if not level:
        return []
    return [f"the {which} survey's soundings carry no line (an ASCII export, say): its lines were not "
            "levelled against each other, and a step between them can pass for a plan shift on a smooth "
            "seabed; a format that keeps lines (LAS/LAZ, the sonars' own) avoids it"
            for which, f in (("before", before), ("after", after))
            if f is None or "line" not in f]


def _span(lo: np.ndarray, hi: np.ndarray) -> str:
    return f"x {lo[0]:.1f}..{hi[0]:.1f}, y {lo[1]:.1f}..{hi[1]:.1f}"


def _compatible(before: Result, after: Result) -> list[str]:
    """Refuse results in different CRSs; warn of different vertical references."""
    crs = [r.parameters.get("input", {}).get("crs") for r in (before, after)]
    if crs[0] and crs[1] and crs[0] != crs[1]:
        from ..cloud import crs_name

        raise InputError(f"the surveys are in different coordinate systems: before {crs_name(crs[0])}, after "
                         f"{crs_name(crs[1])}; expected one (read both with the same --crs)")
    refs = [(r.parameters.get("vertical_reference") or {}).get("text") for r in (before, after)]
    if refs[0] != refs[1]:
        return [f"the surveys' vertical references differ (before: {refs[0] or 'as the files give them'}; "
                f"after: {refs[1] or 'as the files give them'}): the registration's dz takes up the "
                "difference"]
    return []


def _record(r: Result) -> dict[str, Any]:
    """What the comparison read of one result."""
    n = {"piles": len(r.piles)} if isinstance(r, PileResult) else {"reefs": len(r.reefs)}
    return {"source": r.parameters.get("input", {}).get("source"), **n,
            "vertical_reference": r.parameters.get("vertical_reference")}


def _grids(b: np.ndarray, a: np.ndarray, lo: np.ndarray, hi: np.ndarray, cell: float, min_count: int = 3
           ) -> tuple[Grid, Grid]:
    """Both surveys' cell medians on one lattice over their shared extent."""
    x0, y0 = math.floor(lo[0] / cell) * cell, math.floor(lo[1] / cell) * cell
    shape = (int((hi[1] - y0) / cell) + 1, int((hi[0] - x0) / cell) + 1)
    return (median_grid(b, x0, y0, shape, cell, min_count=min_count),
            median_grid(a, x0, y0, shape, cell, min_count=min_count))


def _spots(r: Result) -> list[tuple[float, float, float]]:
    """Every object of a result as (x, y, its reach from its centre)."""
    if isinstance(r, PileResult):
        return [(p.x, p.y, p.radius) for p in r.piles]
    return [(f.x, f.y, _reach(f)) for f in r.reefs] + [(o.x, o.y, math.sqrt(max(o.area, 0.0) / math.pi))
                                                      for o in r.others]


def _away(g: Grid, spots: list[tuple[float, float, float]], buffer: float) -> np.ndarray:
    """The cells farther than ``buffer`` from every object (its reach from its centre)."""
    x, y = g.centres()
    ok = np.ones(g.z.shape, bool)
    for ox, oy, reach in spots:
        r = reach + buffer
        i0, i1 = int((ox - r - g.x0) / g.cell), int((ox + r - g.x0) / g.cell) + 1
        j0, j1 = int((oy - r - g.y0) / g.cell), int((oy + r - g.y0) / g.cell) + 1
        i0, j0 = max(i0, 0), max(j0, 0)
        if i1 <= i0 or j1 <= j0:
            continue
        sub = np.hypot(x[j0:j1, i0:i1] - ox, y[j0:j1, i0:i1] - oy) <= r
        ok[j0:j1, i0:i1] &= ~sub
    return ok


def _reach(r: Reef) -> float:
    if len(r.outline):
        xy = np.asarray(r.outline)
        return float(np.hypot(xy[:, 0] - r.x, xy[:, 1] - r.y).max())
    return max(r.length, r.width) / 2


def _difference(b: Grid, a: Grid, reg: Registration, usable: np.ndarray) -> tuple[Grid, float]:
    """After minus before, the after survey carried onto the before survey's cells; and the
    robust spread of its cells on the shared seabed away from the objects (m)."""
    x, y = b.centres()
    th = math.radians(-reg.rotation_deg)
    rx, ry = x - reg.centre[0], y - reg.centre[1]
    za, _, _ = a.sample(x + reg.dx + th * -ry, y + reg.dy + th * rx)
    d = za - reg.dz - b.z
    cells = d[usable & np.isfinite(d)]
    sigma = 1.4826 * float(np.median(np.abs(cells - np.median(cells)))) if len(cells) > 8 else math.nan
    return Grid(b.x0, b.y0, b.cell, d, b.n), sigma


def _outlines(r: Result, seabed: Grid | None = None) -> list[np.ndarray]:
    """Every object's outline (a pile's plan cover from top to ``seabed``, or its top
    circle without one; a reef's footprint), the others' as circles of their area."""
    if isinstance(r, PileResult):
        if seabed is None:
            return [pile_outline(p) for p in r.piles]
        return [pile_footprint(p, exposed_height(p, seabed))[0] for p in r.piles]
    t = np.linspace(0, 2 * math.pi, 16, endpoint=False)
    return [np.asarray(f.outline) for f in r.reefs if len(f.outline) >= 3] + [
        np.column_stack([o.x + math.sqrt(max(o.area, 0.01) / math.pi) * np.sin(t),
                         o.y + math.sqrt(max(o.area, 0.01) / math.pi) * np.cos(t)]) for o in r.others]


def _typical_radius(r: Result) -> float:
    """The median radius of a result's objects (a reef's of its footprint's area), 1 m if none."""
    if isinstance(r, PileResult):
        radii = [p.radius for p in r.piles]
    else:
        radii = [math.sqrt(max(f.area, 0.01) / math.pi) for f in r.reefs]
    return float(np.median(radii)) if radii else 1.0


def _without_objects(diff: Grid, before: Result, after: Result, reg: Registration,
                     seabeds: tuple[Grid, Grid]) -> Grid:
    """The difference map with every object of either survey left out (its footprint grown
    by :data:`mbinspect.scour.FOOT_MARGIN`; the after survey's carried into the before
    frame): what is left is the seabed."""
    from ..geometry import points_in_polygon
    from ..scour import FOOT_MARGIN, grown

    x, y = diff.centres()
    z = diff.z.copy()
    polys = _outlines(before, seabeds[0]) + [np.column_stack(reg.to_before(o[:, 0], o[:, 1]))
                                             for o in _outlines(after, seabeds[1])]
    for poly in polys:
        lo, hi = poly.min(axis=0) - FOOT_MARGIN - diff.cell, poly.max(axis=0) + FOOT_MARGIN + diff.cell
        box = (x >= lo[0]) & (x <= hi[0]) & (y >= lo[1]) & (y <= hi[1])
        if box.any():
            inside = points_in_polygon(np.column_stack([x[box], y[box]]), grown(poly))
            z.ravel()[np.flatnonzero(box.ravel())[inside]] = np.nan
    return Grid(diff.x0, diff.y0, diff.cell, z, diff.n)


def _objects(before: ReefResult, after: ReefResult, reg: Registration, opt: ChangeOptions, diff: Grid,
             noise: MapNoise, tops: tuple[list[Levels], list[Levels]]) -> list[ObjectChange]:
    """Every reef of either survey with its change, before ids first (``tops``: each survey's
    units' top levels, :func:`~mbinspect.change.tops.reef_tops`)."""
    bxy = _positions(before)
    ax, ay = reg.to_before(np.array([r.x for r in after.reefs]), np.array([r.y for r in after.reefs]))
    axy = np.column_stack([ax, ay]).reshape(-1, 2)
    pairs = dict(match_objects(bxy, axy, max_move=opt.max_move))
    turns = {**symmetry_turns(after.parameters), **symmetry_turns(before.parameters)}
    out = []
    for i, rb in enumerate(before.reefs):
        j = pairs.get(i)
        if j is None:
            out.append(ObjectChange(rb.id, None, "removed", rb.x, rb.y))
            continue
        ra = after.reefs[j]
        outline = np.asarray(ra.outline).reshape(-1, 2)
        if len(outline):
            outline = np.column_stack(reg.to_before(outline[:, 0], outline[:, 1]))
        values, detected, notes = reef_change(rb, ra, (float(ax[j]), float(ay[j])), outline, reg, opt,
                                              turn=turns.get(rb.design, 360.0), diff=diff,
                                              noise=noise, tops=(tops[0][i], tops[1][j]))
        out.append(ObjectChange(rb.id, ra.id, "changed" if detected else "unchanged", rb.x, rb.y,
                                float(ax[j]), float(ay[j]), values, detected, notes))
    matched = set(pairs.values())
    out += [ObjectChange(None, ra.id, "new", x_after=float(ax[j]), y_after=float(ay[j]),
                         values={"height_after": ra.height, "design": ra.design})
            for j, ra in enumerate(after.reefs) if j not in matched]
    return out


def _piles(before: PileResult, after: PileResult, reg: Registration, opt: ChangeOptions, diff: Grid,
           noise: MapNoise, seabeds: tuple[Grid, Grid]) -> list[ObjectChange]:
    """Every pile of either survey with its change, before ids first: matched by their feet
    (where each axis meets the seabed), about which a pile leans anew, not by their tops (a
    pile 6 m proud leaning 4° more at another bearing moves its top 3 m)."""
    h_b = [exposed_height(p, seabeds[0]) for p in before.piles]
    h_a = [exposed_height(p, seabeds[1]) for p in after.piles]
    feet_b, feet_a = (np.array([pile_footprint(p, h)[1] for p, h in zip(r.piles, hs, strict=True)],
                               np.float64).reshape(-1, 2) for r, hs in ((before, h_b), (after, h_a)))
    fx, fy = reg.to_before(feet_a[:, 0], feet_a[:, 1])
    pairs = dict(match_objects(feet_b, np.column_stack([fx, fy]).reshape(-1, 2), max_move=opt.max_move))
    ax, ay = reg.to_before(np.array([p.x for p in after.piles]), np.array([p.y for p in after.piles]))
    out = []
    for i, pb in enumerate(before.piles):
        j = pairs.get(i)
        if j is None:
            out.append(ObjectChange(pb.id, None, "removed", pb.x, pb.y))
            continue
        pa = after.piles[j]
        heights = (h_b[i], h_a[j])
        values, detected, notes = pile_change(pb, pa, (float(ax[j]), float(ay[j])), reg, opt, diff=diff,
                                              noise=noise, heights=heights)
        out.append(ObjectChange(pb.id, pa.id, "changed" if detected else "unchanged", pb.x, pb.y,
                                float(ax[j]), float(ay[j]), values, detected, notes))
    matched = set(pairs.values())
    out += [ObjectChange(None, pa.id, "new", x_after=float(ax[j]), y_after=float(ay[j]))
            for j, pa in enumerate(after.piles) if j not in matched]
    return out


def _shared_area(diff: Grid, sigma: float) -> float:
    """The area (m²) over which the difference map's errors are shared, measured on its
    seabed: for blocks 1, 2 and 4 m wide, the block area times the variance of the blocks'
    means over the cells' variance (independent cells would give one cell's area); the
    largest, and never below :data:`~.measure.CORRELATED_AREA`."""
    if not (math.isfinite(sigma) and sigma > 0):
        return CORRELATED_AREA
    best = CORRELATED_AREA
    ny, nx = diff.z.shape
    for side in (1.0, 2.0, 4.0):
        b = max(int(round(side / diff.cell)), 1)
        if ny < 2 * b or nx < 2 * b:
            continue
        z = diff.z[: ny // b * b, : nx // b * b].reshape(ny // b, b, nx // b, b)
        have = np.isfinite(z).sum(axis=(1, 3))
        means = np.where(np.isfinite(z), z, 0.0).sum(axis=(1, 3)) / np.maximum(have, 1)
        full = means[have >= 0.75 * b * b]
        if len(full) < 20:
            continue
        spread = 1.4826 * float(np.median(np.abs(full - np.median(full))))
        best = max(best, (b * diff.cell) ** 2 * spread**2 / sigma**2)
    return best
