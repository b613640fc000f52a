"""Reefs against their deployment plan: each found reef matched to its planned unit, its
offset and bearing error with their 1-sigma and a verdict at 95 %, inside or outside the
permit area; the planned units not found.

A plan is a CSV ``id,x,y[,bearing_deg][,kind][,group]`` in the survey's CRS. Units are
matched one to one (the assignment of least total distance, :func:`place_reefs`), each
within half the distance to its nearest planned neighbour (at least ``MIN_REACH``): a reef
that landed two metres off is still its unit, two reefs that swapped places are not taken
for each other's. A reef's centre is known to ``position_sigma`` (the studies measure 2.5
cm RMS with a design fit, 4 cm without; the positioning adds), its bearing to
``bearing_sigma_deg``; a design's symmetry (a cross looks the same every 90°: its
``symmetry`` 4) folds the bearing error into half that turn either way.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..checks import csv_rows
from ..errors import InputError
from ..geometry import crop_mask
from .results import Reef, ReefResult

__all__ = ["ReefPlan", "read_plan", "read_permit", "permit_in", "place_reefs", "bearing_sigma_of",
           "position_sigma_of", "BEAM_BEARING", "BEAM_POSITION"]

#: The least reach (m) of a planned unit for its reef.
MIN_REACH = 1.0



@dataclass(frozen=True)
class ReefPlan:
    """Planned units: ``rows`` of ``{"id", "x", "y", "bearing_deg" (or None), "kind", "group"}``."""

    rows: tuple[dict[str, Any], ...]
    source: str = ""
    permit: np.ndarray | None = field(default=None, repr=False)
    permit_source: str = ""


def read_plan(path: str | Path) -> ReefPlan:
    """Read a reef plan CSV (``id,x,y[,bearing_deg][,kind][,group]``; a header is required,
    ``#`` lines are skipped).

    Raises
    ------
    FileAccessError
        No such file.
    InputError
        A bad row: the message names the line and column.
    """
    p = Path(path)
    head, rows = csv_rows(p, "plan file", "a reef plan CSV: a header id,x,y and a row per unit")
    if not {"id", "x", "y"} <= set(head):
        raise InputError(f"{p}, line {rows[0][0]}: header {rows[0][1]}; expected columns id,x,y"
                         "[,bearing_deg][,kind][,group]")
    out, seen = [], set()
    for lineno, cells in rows[1:]:
        if len(cells) < len(head):
            raise InputError(f"{p}, line {lineno}: {len(cells)} values, expected {len(head)}")
        row: dict[str, Any] = {"id": cells[head.index("id")], "kind": None, "group": None,
                               "bearing_deg": None}
        for name in ("x", "y", "bearing_deg"):
            if name in head:
                row[name] = _number(p, lineno, head, cells, name)
        for name in ("kind", "group"):
            if name in head and cells[head.index(name)]:
                row[name] = cells[head.index(name)]
        if row["id"] in seen:
            raise InputError(f"{p}, line {lineno}: unit id {row['id']!r} appears twice")
        seen.add(row["id"])
        out.append(row)
    if not out:
        raise InputError(f"{p}: the plan has a header but no units")
    return ReefPlan(tuple(out), str(p))


def _number(p: Path, lineno: int, head: list[str], cells: list[str], name: str) -> float | None:
    col = head.index(name)
    text = cells[col]
    if name == "bearing_deg" and text == "":
        return None
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not math.isfinite(v):
        raise InputError(f"{p}, line {lineno}, column {col + 1} ({name}): {text!r} is not a number")
    return v


def read_permit(spec: str) -> tuple[np.ndarray, str | None, str]:
    """The permit area as given: its ring, the CRS it names (GeoJSON: WGS 84 unless it names
    another; WKT: None, the survey's or lon/lat, :func:`permit_in`), and where it came from.
    Read before a run, so that a bad polygon stops it before it starts.

    Raises
    ------
    InputError
        Not a polygon of at least three vertices.
    """
    is_file = Path(spec).is_file()
    text = Path(spec).read_text(encoding="utf-8") if is_file else spec
    where = spec if is_file else "--permit-area"
    if text.lstrip().startswith("{"):
        try:
            obj = json.loads(text)
        except json.JSONDecodeError as exc:
            raise InputError(f"{where}: not JSON ({exc.msg}, line {exc.lineno}); expected GeoJSON") from None
        ring, src_crs = _geojson_ring(obj, where)
    else:
        ring, src_crs = _wkt_ring(text, where), None
    if ring.ndim != 2 or ring.shape[0] < 3 or ring.shape[1] < 2 or not np.isfinite(ring).all():
        raise InputError(f"{where}: {len(ring)} vertices; expected a polygon of at least three x y pairs")
    return ring[:, :2], src_crs, where


def permit_in(permit: tuple[np.ndarray, str | None, str], crs: str | None, survey_xy: np.ndarray
              ) -> tuple[np.ndarray, str]:
    """The permit area (:func:`read_permit`) in the survey's CRS, and a note of how: a
    polygon without a CRS is in the survey's, unless every vertex is a longitude and
    latitude while the survey's coordinates are not (then WGS 84, said in the note).

    Raises
    ------
    InputError
        Degrees or a named CRS with a survey that has no CRS to put them in.
    """
    ring, src_crs, where = permit
    if src_crs is None:
        lonlat = bool(np.all(np.abs(ring[:, 0]) <= 180) and np.all(np.abs(ring[:, 1]) <= 90))
        src_crs = "EPSG:4326" if lonlat and np.abs(survey_xy).max() > 1000 else None
    if src_crs is None:
        return ring, f"{where} in the survey's CRS"
    if crs is None:
        raise InputError(f"{where}: the permit area is in {src_crs} but the survey has no CRS to put it in; "
                         "expected --crs or a polygon in the survey's coordinates")
    from pyproj import Transformer

    tr = Transformer.from_crs(src_crs, crs, always_xy=True)
    x, y = tr.transform(ring[:, 0], ring[:, 1])
    return np.column_stack([x, y]), f"{where} in {src_crs}, put in the survey's CRS"


def _geojson_ring(obj: Any, where: str) -> tuple[np.ndarray, str | None]:
    if not isinstance(obj, dict):
        raise InputError(f"{where}: a JSON {type(obj).__name__}; expected a GeoJSON object")
    crs = ((obj.get("crs") or {}).get("properties") or {}).get("name") or "EPSG:4326"
    geom = obj
    if obj.get("type") == "FeatureCollection" and obj.get("features"):
        geom = obj["features"][0]
    if geom.get("type") == "Feature":
        geom = geom.get("geometry") or {}
    coords = geom.get("coordinates")
    if geom.get("type") == "MultiPolygon" and coords:
        coords = coords[0]
    if geom.get("type") not in ("Polygon", "MultiPolygon") or not coords:
        kind = geom.get("type") or "no GeoJSON geometry"
        raise InputError(f"{where}: {kind}; expected a GeoJSON Polygon (or a Feature holding one)")
    try:
        return np.asarray(coords[0], np.float64), crs
    except (TypeError, ValueError):
        raise InputError(f"{where}: the polygon's coordinates are not x y pairs") from None


def _wkt_ring(text: str, where: str) -> np.ndarray:
    t = text.strip()
    if not t.upper().startswith("POLYGON") or "(" not in t:
        raise InputError(f"{where}: {t[:40]!r}; expected a GeoJSON file or WKT POLYGON ((x y, ...))")
    first = t[t.index("(") :].strip("() \n").split(")")[0].strip("( ")
    try:
        pairs = [[float(v) for v in pair.split()] for pair in first.split(",")]
    except ValueError:
        raise InputError(f"{where}: {first[:60]!r} is not a list of x y pairs") from None
    if any(len(xy) < 2 for xy in pairs):
        raise InputError(f"{where}: {first[:60]!r} is not a list of x y pairs")
    return np.array([xy[:2] for xy in pairs])


def place_reefs(result: ReefResult, plan: ReefPlan, *, tolerance: float, position_sigma: float,
                bearing_sigma_deg: float) -> ReefResult:
    """The result with each reef matched to its planned unit (``plan`` on the reef: its
    ``plan_id``, ``plan_dx``, ``plan_dy``, ``plan_offset``, ``plan_offset_sigma``,
    ``bearing_error_deg`` and its sigma, ``placement`` pass/fail/undecided at 95 % against
    ``tolerance``, ``in_permit``) and the units not found in ``plan_missing``."""
    units = list(plan.rows)
    pxy = np.array([[u["x"], u["y"]] for u in units], np.float64)
    reefs = list(result.reefs)
    rxy = np.array([[r.x, r.y] for r in reefs], np.float64).reshape(-1, 2)
    reach = _reach(pxy)
    pairs = _assign(rxy, pxy, reach)
    inside = None if plan.permit is None or not reefs else crop_mask(np.c_[rxy, np.zeros(len(rxy))],
                                                                      plan.permit)
    # the turn after which each design looks the same (a cross every 90 deg)
    turns = {d["name"]: 360.0 / max(int(d.get("symmetry") or 1), 1)
             for d in result.parameters.get("design") or [] if isinstance(d, dict)}
    out = []
    for k, r in enumerate(reefs):
        u = pairs.get(k)
        fields: dict[str, Any] = {"plan_id": None if u is None else units[u]["id"]}
        if u is not None:
            fields.update(_offsets(r, units[u], tolerance, position_sigma, bearing_sigma_deg,
                                   turns.get(r.design, 360.0)))
            fields.update(_kind_check(r, units[u], set(turns)))
        if inside is not None:
            fields["in_permit"] = bool(inside[k])
        out.append(replace(r, plan=fields))
    found = set(pairs.values())
    missing = tuple({"id": units[i]["id"], "x": units[i]["x"], "y": units[i]["y"]}
                    for i in range(len(units)) if i not in found)
    params = {**result.parameters, "plan": {"file": plan.source, "units": len(units)},
              **({"permit_area": plan.permit_source} if plan.permit is not None else {})}
    return replace(result, reefs=tuple(out), plan_missing=missing, parameters=params)


def _reach(pxy: np.ndarray) -> np.ndarray:
    """Each planned unit's reach: half the distance to its nearest planned neighbour (a reef
    further off is nearer another unit's place than its own could tell)."""
    if len(pxy) < 2:
        return np.full(len(pxy), 10.0 * MIN_REACH)
    d = np.hypot(*(pxy[:, None, :] - pxy[None, :, :]).transpose(2, 0, 1))
    np.fill_diagonal(d, np.inf)
    return np.maximum(d.min(axis=1) / 2, MIN_REACH)


def _assign(rxy: np.ndarray, pxy: np.ndarray, reach: np.ndarray) -> dict[int, int]:
    """Reef index -> unit index: the one-to-one assignment of least total distance among
    pairs within each unit's reach."""
    if not len(rxy) or not len(pxy):
        return {}
    d = np.hypot(*(rxy[:, None, :] - pxy[None, :, :]).transpose(2, 0, 1))
    big = 1e6
    cost = np.where(d <= reach[None, :], d, big)
    rows, cols = linear_sum_assignment(cost)
    return {int(i): int(j) for i, j in zip(rows, cols, strict=True) if cost[i, j] < big}


def _offsets(r: Reef, unit: dict[str, Any], tolerance: float, sigma: float, bearing_sigma: float,
             turn: float) -> dict[str, Any]:
    """A matched reef's offset from its unit and its bearing error, each with its 1-sigma,
    and the placement verdict at 95 %."""
    dx, dy = r.x - float(unit["x"]), r.y - float(unit["y"])
    off = math.hypot(dx, dy)
    sigma = position_sigma_of(r, sigma)
    out: dict[str, Any] = {"plan_dx": dx, "plan_dy": dy, "plan_offset": off, "plan_offset_sigma": sigma,
                           "placement": _decide(off, sigma, tolerance)}
    planned = unit.get("bearing_deg")
    if planned is not None and math.isfinite(r.design_bearing_deg):
        err = (r.design_bearing_deg - float(planned) + turn / 2) % turn - turn / 2
        out.update(bearing_error_deg=err, bearing_error_sigma_deg=bearing_sigma_of(r, bearing_sigma))
    return out


#: The centre's error the beam leaves, per metre of the footprint's width: calibrated on the
#: simulator (`benchmarks/study_acceptance.py`, 2° cones told the beam; checked at 1° and 0.5°).
BEAM_POSITION = 0.06


def position_sigma_of(r: Reef, floor: float) -> float:
    """A reef centre's 1-sigma (m) along its offset from the plan: ``floor`` (the thin-ray
    figure and the positioning's, as a user states it) and, told the beam, the footprint's
    width times :data:`BEAM_POSITION`.

    >>> from mbinspect.reefs.results import Reef
    >>> r = Reef(1, 0, 0, -20, -18, 2, 5, 3.0, 3.0, 0, 1, 1, 100, beam_footprint=0.8)
    >>> round(position_sigma_of(r, 0.05), 3), position_sigma_of(replace(r, beam_footprint=math.nan), 0.05)
    (0.069, 0.05)
    """
    if not math.isfinite(r.beam_footprint):
        return floor
    return math.hypot(floor, BEAM_POSITION * r.beam_footprint)


#: The bearing error the beam leaves, in radians per unit of the footprint's width over the
#: unit's length (the edges the bearing hangs on stand off by a share of the footprint; the
#: error is a bias of the fit, not its noise, so no per-reef covariance shows it):
#: calibrated on the simulator (`benchmarks/study_acceptance.py`, 1° cones told the beam).
BEAM_BEARING = 0.2


def bearing_sigma_of(r: Reef, floor: float) -> float:
    """A fitted design's bearing 1-sigma (deg): ``floor`` (the thin-ray figure a user states),
    and told the beam, the footprint's share of the unit's length times :data:`BEAM_BEARING`.

    >>> from mbinspect.reefs.results import Reef
    >>> r = Reef(1, 0, 0, -20, -18, 2, 5, 3.0, 3.0, 0, 1, 1, 100, beam_footprint=0.6)
    >>> round(bearing_sigma_of(r, 1.0), 2), bearing_sigma_of(replace(r, beam_footprint=math.nan), 1.0)
    (2.5, 1.0)
    """
    if not (math.isfinite(r.beam_footprint) and r.length > 0):
        return floor
    return math.hypot(floor, math.degrees(BEAM_BEARING * r.beam_footprint / r.length))


def _kind_check(r: Reef, unit: dict[str, Any], designs: set[str]) -> dict[str, Any]:
    """A unit of a kind among the run's designs that its reef is not fitted as (another
    design, or none) is not placed: its verdict is ``undecided``, and ``placement_note`` says
    why (on a sparse survey such reefs are fragments or merged objects, their centres metres
    off). Nothing when the plan gives no kind, or one the run was not given."""
    kind = unit.get("kind")
    if not kind or kind not in designs or r.design == kind:
        return {}
    return {"placement": "undecided",
            "placement_note": f"fitted as {r.design or 'no design'}, planned {kind}: not placed"}


def _decide(miss: float, sigma: float, tolerance: float) -> str:
    """``pass`` when the miss is within the tolerance at its far 95 % bound, ``fail`` when
    beyond it at its near bound, else ``undecided``."""
    if miss + 1.96 * sigma <= tolerance:
        return "pass"
    if miss - 1.96 * sigma > tolerance:
        return "fail"
    return "undecided"
