"""Acceptance tables: the least depths of a result's objects (both pipelines) and the reefs'
placement against their plan, as report tables, CSV columns and GeoJSON lines."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from .html import html_table

__all__ = ["LEAST_COLS", "clearance_section", "placement_section", "placement_lines"]

#: The least depth's columns in a pipeline's CSV.
LEAST_COLS = ["least_depth", "least_depth_tvu95", "least_depth_x", "least_depth_y", "least_depth_thu95",
              "least_depth_order", "least_depth_clearance", "least_depth_note"]

_HEAD = {"object": "object", "depth": "least depth (m)", "tvu": "TVU 95 % (m)", "x": "easting (m)",
         "y": "northing (m)", "thu": "THU 95 % (m)", "order": "S-44 order met",
         "clearance": "clearance at 95 %", "note": "note"}


def _m(v: Any, form: str = ".2f") -> str:
    return "" if v is None or (isinstance(v, float) and not math.isfinite(v)) else format(v, form)


def clearance_section(rows: Sequence[tuple[str, Mapping[str, Any]]], parameters: Mapping[str, Any]
                      ) -> tuple[str, str]:
    """The least depth table: one row per (label, JSON row) that has a least depth, with the
    vertical reference and the clearance asked for in its heading."""
    table = [{"object": label, "depth": _m(r.get("least_depth")), "tvu": _m(r.get("least_depth_tvu95")),
              "x": _m(r.get("least_depth_x")), "y": _m(r.get("least_depth_y")),
              "thu": _m(r.get("least_depth_thu95")), "order": r.get("least_depth_order") or "none",
              "clearance": r.get("least_depth_clearance") or "", "note": r.get("least_depth_note") or ""}
             for label, r in rows if "least_depth" in r]
    ref = (parameters.get("vertical_reference") or {}).get("text") or "heights as the files give them"
    need = parameters.get("min_clearance")
    heading = "Least depths (positive down; " + ref + (f"; clearance {need:g} m" if need else "") + ")"
    return heading, html_table(table, list(_HEAD), list(_HEAD.values()))


_PLACE_HEAD = {"reef": "reef", "unit": "planned unit", "offset": "offset (m)", "sigma": "1σ (m)",
               "dx": "east (m)", "dy": "north (m)", "bearing": "bearing error (°)",
               "verdict": "placed at 95 %", "note": "note", "permit": "in the permit area"}


def placement_section(d: Mapping[str, Any]) -> tuple[str, str]:
    """The reefs against their plan: one row per reef, then the units not found."""
    rows = [{"reef": r["id"], "unit": r.get("plan_id") or "not in the plan",
             "offset": _m(r.get("plan_offset")), "sigma": _m(r.get("plan_offset_sigma"), ".3f"),
             "dx": _m(r.get("plan_dx")), "dy": _m(r.get("plan_dy")),
             "bearing": _m(r.get("bearing_error_deg"), "+.1f"), "verdict": r.get("placement") or "",
             "note": r.get("placement_note") or "",
             "permit": {True: "yes", False: "NO", None: ""}[r.get("in_permit")]}
            for r in d["reefs"]]
    rows += [{"reef": "not found", "unit": m["id"], "offset": "", "sigma": "", "dx": "", "dy": "",
              "bearing": "", "verdict": "missing", "note": "", "permit": ""}
             for m in d.get("plan_missing") or []]
    tol = d["parameters"].get("placement_tolerance")
    return (f"Placement against the plan (tolerance {tol:g} m)" if tol else "Placement against the plan",
            html_table(rows, list(_PLACE_HEAD), list(_PLACE_HEAD.values())))


def placement_lines(d: Mapping[str, Any]) -> list[dict[str, Any]]:
    """GeoJSON lines from each planned unit's place to the reef found there."""
    out = []
    for r in d["reefs"]:
        if r.get("plan_id") is None:
            continue
        start = [r["x"] - r["plan_dx"], r["y"] - r["plan_dy"]]
        keys = ("plan_id", "plan_offset", "placement", "placement_note", "bearing_error_deg", "in_permit")
        props = {k: r.get(k) for k in keys}
        out.append({"type": "Feature",
                    "geometry": {"type": "LineString", "coordinates": [start, [r["x"], r["y"]]]},
                    "properties": {"reef": r["id"], **props}})
    return out


_REST_HEAD = {"reef": "reef", "design": "design", "resting": "resting", "overturned": "overturned",
              "tilt": "top tilt (°)", "sigma": "1σ (°)", "misfit": "misfit (m)", "note": "note"}


def rest_section(d: Mapping[str, Any]) -> tuple[str, str]:
    """How each reef unit rests: its top's tilt with its 1-sigma, and upright or overturned
    (the overturned first)."""
    reefs = sorted(d["reefs"], key=lambda r: (r.get("overturned") is not True, r["id"]))
    rows = [{"reef": r["id"], "design": r.get("design") or "", "resting": r.get("resting") or "",
             "overturned": {True: "YES", False: "no", None: ""}[r.get("overturned")],
             "tilt": _m(r.get("top_tilt_deg"), ".1f"), "sigma": _m(r.get("top_tilt_sigma_deg"), ".1f"),
             "misfit": _m(r.get("resting_misfit"), ".2f"), "note": r.get("resting_note") or ""}
            for r in reefs]
    n = sum(r.get("overturned") is True for r in reefs)
    head = f"How the units rest ({n} overturned)" if n else "How the units rest"
    return head, html_table(rows, list(_REST_HEAD), list(_REST_HEAD.values()))
