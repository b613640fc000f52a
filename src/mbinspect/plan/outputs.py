"""What ``mbinspect plan`` writes: ``plan.json`` (the result's ``to_dict()``), ``lines.csv``
(``line,x_start,y_start,x_end,y_end,heading,speed_kn``, what survey software imports),
``lines.geojson`` (WGS 84) and ``plan.geojson`` (the piles with the sides no beam reaches), ``plan.png`` (the
lines over the design, the unseen sides, the predicted 1-sigma of every spacing against the
target) and ``report.html``."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ..report.html import html_page, html_table, number, parameter_table, verdict_banner
from ..report.writers import Outputs, write_outputs
from .predict import SECTORS
from .reef_results import ReefPlanResult
from .results import PlanResult, Prediction

__all__ = ["write_plan_outputs", "LINE_COLUMNS", "line_rows", "line_features", "read_line_plan",
           "read_line_speed"]

#: ``lines.csv``'s columns.
LINE_COLUMNS = ("line", "x_start", "y_start", "x_end", "y_end", "heading", "speed_kn")


def line_rows(result: PlanResult | ReefPlanResult) -> list[dict[str, Any]]:
    """The chosen layout's lines, one row each, in the order sailed (heading in degrees, the
    speed to sail them at in knots)."""
    best = result.best
    if best is None:
        return []
    speed = result.speed_kn
    return [{"line": k + 1, "x_start": round(ln.start[0], 3), "y_start": round(ln.start[1], 3),
             "x_end": round(ln.end[0], 3), "y_end": round(ln.end[1], 3), "heading": round(ln.heading, 2),
             "speed_kn": round(speed, 2) if speed is not None else None}
            for k, ln in enumerate(best.layout.lines)]


def _plan_rows(path: str | Path) -> tuple[Path, list[dict[str, str]]]:
    """The rows of a ``lines.csv`` by column name.

    Raises
    ------
    FileAccessError
        No such file.
    """
    import csv

    from ..errors import FileAccessError

    p = Path(path)
    if not p.is_file():
        raise FileAccessError(f"{p}: no such file; expected a lines.csv written by 'mbinspect plan'")
    with open(p, newline="", encoding="utf-8-sig") as fh:
        return p, list(csv.DictReader(fh))


def _cell(p: Path, k: int, row: dict[str, str], column: str, expected: str, positive: bool = False) -> float:
    """The number in ``column`` of row ``row`` (line ``k`` of ``p``).

    Raises
    ------
    InputError
        Not a finite number (or not above 0 when ``positive``), the line and column named.
    """
    from ..errors import InputError

    try:
        v = float(row[column])
    except (TypeError, ValueError):
        v = math.nan
    if not math.isfinite(v) or (positive and v <= 0):
        raise InputError(f"{p}: line {k}, column {column}: {row[column]!r}; expected {expected}")
    return v


def read_line_plan(path: str | Path) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """The lines of a ``lines.csv`` (``x_start,y_start,x_end,y_end`` by name, other columns
    ignored), each ((x, y), (x, y)) from start to end.

    Raises
    ------
    FileAccessError
        No such file.
    InputError
        A column missing or a value not a finite number; the message names the line and column.
    """
    from ..errors import InputError

    p, rows = _plan_rows(path)
    need = ("x_start", "y_start", "x_end", "y_end")
    if not rows or any(c not in rows[0] for c in need):
        raise InputError(f"{p}: line 1: expected the columns {','.join(need)} (and line, heading)")
    out = []
    for k, row in enumerate(rows, start=2):
        x0, y0, x1, y1 = (_cell(p, k, row, c, "a number of metres") for c in need)
        out.append(((x0, y0), (x1, y1)))
    return out


def read_line_speed(path: str | Path) -> float | None:
    """The speed (m/s) a ``lines.csv`` asks its lines to be sailed at (its ``speed_kn``
    column; None without one).

    Raises
    ------
    FileAccessError
        No such file.
    InputError
        A speed that is not a positive number of knots, or lines asking different speeds.
    """
    from ..errors import InputError
    from .layouts import KNOT

    p, rows = _plan_rows(path)
    if not rows or "speed_kn" not in rows[0]:
        return None
    speeds = {_cell(p, k, row, "speed_kn", "a positive number of knots", positive=True)
              for k, row in enumerate(rows, start=2)}
    if len(speeds) > 1:
        raise InputError(f"{p}: column speed_kn: {', '.join(f'{v:g}' for v in sorted(speeds))}; expected "
                         "one speed for every line")
    return speeds.pop() * KNOT


def line_features(result: PlanResult | ReefPlanResult) -> list[dict[str, Any]]:
    """The chosen layout's lines as GeoJSON features (the design's CRS)."""
    return [{"type": "Feature", "geometry": {"type": "LineString", "coordinates": [
        [r["x_start"], r["y_start"]], [r["x_end"], r["y_end"]]]},
        "properties": {**r, "layout": result.chosen}} for r in line_rows(result)]


def _features(result: PlanResult) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    best = result.best
    unseen = dict(best.unseen) if best else {}
    levels = dict(best.tops) if best else {}
    piles = [{"type": "Feature", "geometry": {"type": "Point", "coordinates": [p.x, p.y]},
              "properties": {"id": p.id, "group": p.group, "top": p.top,
                             "unseen_sides": ";".join(unseen.get(p.id, ())),
                             "level_sigma": levels.get(p.id)}} for p in result.piles]
    return piles, line_features(result)


def write_plan_outputs(result: PlanResult, out: str | Path, *, crs: str | None = None,
                       figures: bool = True) -> list[str]:
    """Write a plan's files into ``out`` (a staging folder); the names written."""
    piles, lines = _features(result)
    outputs = Outputs("plan", result.to_dict(), tables=(("lines.csv", line_rows(result), LINE_COLUMNS),),
                      features=piles, layers=(("lines", lines),), crs=crs,
                      figures=(lambda folder: [lambda: _figures(result, folder)]) if figures else None,
                      page=lambda images: _page(result, images))
    return write_outputs(outputs, out, figures=figures)


def _figures(result: PlanResult, folder: Path) -> dict[str, bytes]:
    from ..report.maps import mpl, save_figure

    best = result.best
    if best is None:
        return {}
    plt = mpl()
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(13, 6), gridspec_kw={"width_ratios": [1.1, 1]},
                                 layout="constrained")
    x0 = min(p.x for p in result.piles)
    y0 = min(p.y for p in result.piles)
    seen: dict[tuple[float, float, float, float], int] = {}
    for k, ln in enumerate(best.layout.lines):
        (xa, ya), (xb, yb) = (ln.start[0] - x0, ln.start[1] - y0), (ln.end[0] - x0, ln.end[1] - y0)
        ax.plot([xa, xb], [ya, yb], color="tab:blue", lw=1.2)
        key = tuple(sorted([(round(xa, 1), round(ya, 1)), (round(xb, 1), round(yb, 1))]))
        twice = seen.setdefault(key, 0)  # type: ignore[arg-type]
        seen[key] += 1  # type: ignore[index]
        f = 0.35 + 0.3 * twice  # a line sailed both ways gets its second arrow further along
        ax.annotate("", xy=(xa + (f + 0.05) * (xb - xa), ya + (f + 0.05) * (yb - ya)),
                    xytext=(xa + f * (xb - xa), ya + f * (yb - ya)),
                    arrowprops={"arrowstyle": "-|>", "color": "tab:blue", "lw": 1.2})
        ax.text(xa + (1 - 0.05 * (twice + 1)) * (xb - xa) if twice else xa, ya + (1 - 0.05) * (yb - ya)
                if twice else ya, str(k + 1), color="tab:blue", fontsize=8)
    unseen = dict(best.unseen)
    radius = float(result.parameters.get("radius", 0.75))
    size = 2.5 * radius + 1.0  # drawn larger than the pile so that its sides show
    for p in result.piles:
        ax.add_patch(plt.Circle((p.x - x0, p.y - y0), size, fill=False, color="k"))
        for name in unseen.get(p.id, ()):
            b = math.radians(SECTORS.index(name) * 45.0)
            ax.plot(p.x - x0 + size * math.sin(b), p.y - y0 + size * math.cos(b), "o", color="tab:red", ms=5)
        ax.text(p.x - x0 + size, p.y - y0 + size, str(p.id), fontsize=9)
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.set_xlabel(f"m east of {x0:.1f}")
    ax.set_ylabel(f"m north of {y0:.1f}")
    ax.set_title(f"{best.layout.name}: {len(best.layout.lines)} lines, "
                 f"{best.time_on_site_s / 60:.0f} min on site\n"
                 "(red: a side no beam reaches; piles drawn enlarged)")
    labels = [f"{s.a}-{s.b}" for s in best.spacings]
    sig = [1000 * s.sigma if math.isfinite(s.sigma) else np.nan for s in best.spacings]
    bx.bar(np.arange(len(sig)), sig, color=["tab:green" if v <= 1000 * result.target_sigma else "tab:red"
                                           for v in sig])
    bx.axhline(1000 * result.target_sigma, color="k", ls="--",
               label=f"target {1000 * result.target_sigma:g} mm")
    bx.set_xticks(np.arange(len(sig)), labels, rotation=90 if len(sig) > 12 else 0, fontsize=8)
    bx.set_ylabel("predicted 1-sigma of the spacing (mm)")
    bx.set_title(f"Predicted from {best.surveys} simulated surveys")
    bx.legend(loc="lower right")
    return {"plan": save_figure(fig, folder / "plan.png")}


def _candidates(result: PlanResult) -> str:
    rows = [{"layout": p.layout.name + (" (chosen)" if p.layout.name == result.chosen else ""),
             "what": p.layout.description, "lines": len(p.layout.lines),
             "minutes": f"{p.time_on_site_s / 60:.1f}",
             "worst": number(1000 * p.worst_sigma, ".1f") if math.isfinite(p.worst_sigma) else "not measured",
             "meets": "yes" if p.meets_target else "no", "surveys": p.surveys,
             "unseen": sum(len(s) for _, s in p.unseen)} for p in result.predictions]
    return html_table(rows, ["layout", "what", "lines", "minutes", "worst", "meets", "surveys", "unseen"],
                      ["layout", "what it is", "lines", "time on site (min)", "worst spacing 1-sigma (mm)",
                       "meets the target", "simulated surveys", "pile sides no beam reaches"])


def _spacings(best: Prediction, target: float) -> str:
    rows = [{"pair": f"{s.a}-{s.b}", "design": s.design, "sigma": number(1000 * s.sigma, ".1f"),
             "reported": number(1000 * s.reported_sigma, ".1f"), "error": number(1000 * s.error_rms, ".1f"),
             "verdict": "meets" if best.upper(s.sigma) <= target else "misses"}
            for s in best.spacings]
    return html_table(rows, ["pair", "design", "sigma", "reported", "error", "verdict"],
                      ["spacing", "design (m)", "predicted 1-sigma (mm)", "1-sigma the runs reported (mm)",
                       "RMS error of the runs (mm)", f"against {1000 * target:g} mm at the upper bound"])


def _page(result: PlanResult, images: dict[str, bytes]) -> str:
    best = result.best
    banner = []
    if best is not None:
        banner.append((f"{best.layout.name}: {best.layout.description}; {len(best.layout.lines)} lines, "
                       f"{best.time_on_site_s / 60:.0f} min on site; every spacing predicted within "
                       f"{1000 * best.worst_sigma:.1f} mm (1-sigma; {1000 * best.worst_upper:.1f} mm at the "
                       f"upper bound of an estimate from {best.surveys} surveys) against a target of "
                       f"{1000 * result.target_sigma:g} mm", "pass" if best.meets_target else "fail"))
    banner += [(w, "undecided") for w in result.warnings]
    sections = [("Plan", verdict_banner(banner))]
    if "plan" in images:
        sections.append(("The lines over the design", "{img:plan}"))
    if best is not None:
        sections.append(("Predicted spacings", _spacings(best, result.target_sigma)))
        levels = [{"pile": i, "sigma": number(1000 * s, ".1f"),
                   "unseen": ", ".join(dict(best.unseen).get(i, ())) or "none"} for i, s in best.tops]
        sections.append(("Pile tops and sides", html_table(levels, ["pile", "sigma", "unseen"], [
            "pile", "top level 1-sigma (mm)", "sides no beam reaches"])))
    sections.append(("Every layout tried, fastest first", _candidates(result)))
    sections.append(("Options", parameter_table(result.parameters)))
    return html_page("mbinspect: survey plan", sections, images)
