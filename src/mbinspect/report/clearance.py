"""The least depths of a result's objects as a report table and CSV columns (both pipelines)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from .html import html_table

__all__ = ["LEAST_COLS", "clearance_section"]

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
