"""What ``mbinspect plan`` writes for a reef plan: ``plan.json`` (the result's ``to_dict()``),
``lines.csv``, ``lines.geojson``, ``plan.geojson`` (the units with the soundings each is
predicted to get), ``plan.png`` (the lines over the units, the fewest soundings on each against
the target) and ``report.html``."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ..report.html import html_page, html_table, number, parameter_table, verdict_banner
from ..report.writers import Outputs, figure_job, write_outputs
from .outputs import LINE_COLUMNS, line_features, line_rows
from .reef_results import ReefPlanResult

__all__ = ["write_reef_plan_outputs"]


def _units(result: ReefPlanResult) -> list[dict[str, Any]]:
    best = result.best
    pred = {u.id: u for u in best.units} if best else {}
    return [{"type": "Feature", "geometry": {"type": "Point", "coordinates": [u.x, u.y]},
             "properties": {"id": u.id, "kind": u.kind, "bearing_deg": u.bearing_deg,
                            "found": pred[u.id].found if u.id in pred else None,
                            "min_soundings": pred[u.id].min_soundings if u.id in pred else None,
                            "mean_soundings": pred[u.id].mean_soundings if u.id in pred else None}}
            for u in result.units]


def write_reef_plan_outputs(result: ReefPlanResult, out: str | Path, *, crs: str | None = None,
                            figures: bool = True) -> list[str]:
    """Write a reef plan's files into ``out`` (a staging folder); the names written."""
    folder = Path(out)

    def jobs(f: Path) -> list[Any]:
        return [figure_job("plan", _figure, result, f / "plan.png")]

    outputs = Outputs("plan", result.to_dict(), tables=(("lines.csv", line_rows(result), LINE_COLUMNS),),
                      features=_units(result), layers=(("lines", line_features(result)),), crs=crs,
                      figures=jobs if figures else None, page=lambda images: _page(result, images))
    return write_outputs(outputs, folder, figures=figures)


def _figure(result: ReefPlanResult, path: Path) -> bytes:
    from ..report.maps import mpl, save_figure

    best = result.best
    plt = mpl()
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(13, 6), gridspec_kw={"width_ratios": [1.1, 1]},
                                 layout="constrained")
    x0 = min(u.x for u in result.units)
    y0 = min(u.y for u in result.units)
    half = float(result.parameters.get("swath_width_m", 0.0)) / 2
    if best is not None:
        for k, ln in enumerate(best.layout.lines):
            a, b = np.subtract(ln.start, (x0, y0)), np.subtract(ln.end, (x0, y0))
            d = (b - a) / max(float(np.hypot(*(b - a))), 1e-9)
            side = half * np.array([d[1], -d[0]])
            band = np.array([a + side, b + side, b - side, a - side])
            ax.fill(band[:, 0], band[:, 1], color="tab:blue", alpha=0.08, lw=0)
            ax.plot([a[0], b[0]], [a[1], b[1]], color="tab:blue", lw=1.2)
            ax.annotate("", xy=a + 0.55 * (b - a), xytext=a + 0.45 * (b - a),
                        arrowprops={"arrowstyle": "-|>", "color": "tab:blue"})
            ax.text(a[0], a[1], str(k + 1), color="tab:blue", fontsize=8)
    for u in result.units:
        ax.add_patch(plt.Circle((u.x - x0, u.y - y0), u.reach, fill=False, color="k"))
        ax.text(u.x - x0 + u.reach, u.y - y0 + u.reach, u.id, fontsize=8)
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.set_xlabel(f"m east of {x0:.1f}")
    ax.set_ylabel(f"m north of {y0:.1f}")
    if best is not None:
        n = len(best.layout.lines)
        ax.set_title(f"{best.layout.name}: {n} line{'s' if n > 1 else ''}, "
                     f"{best.time_on_site_s / 60:.0f} min on site\n(shaded: each line's swath on the seabed; "
                     "circles: each unit's reach)", fontsize=10)
        counts = [u.min_soundings for u in best.units]
        bx.bar(np.arange(len(counts)), counts,
               color=["tab:green" if c >= result.min_soundings and u.found == 1.0 else "tab:red"
                      for c, u in zip(counts, best.units, strict=True)])
        bx.axhline(result.min_soundings, color="k", ls="--", label=f"target {result.min_soundings}")
        bx.set_xticks(np.arange(len(counts)), [u.id for u in best.units],
                      rotation=90 if len(counts) > 12 else 0, fontsize=8)
        bx.set_ylabel("fewest soundings on the unit in a simulated survey")
        bx.set_title(f"Predicted from {best.surveys} simulated surveys")
        bx.legend(loc="lower right")
    return save_figure(fig, path)


def _mm(v: float) -> str:
    return number(1000 * v, ".0f") if math.isfinite(v) else "-"


def _page(result: ReefPlanResult, images: dict[str, bytes]) -> str:
    best = result.best
    banner = []
    if best is not None:
        cubes = "" if best.cubes_detected is None else \
            f"; {100 * best.cubes_detected:.0f} % of the S-44 {result.s44_order} cubes detected"
        banner.append((f"{best.layout.name}: {best.layout.description}; "
                       f"{best.time_on_site_s / 60:.0f} min on site; {100 * best.found:.0f} % of the units "
                       "found, the fewest soundings on one "
                       f"{best.min_soundings} against {result.min_soundings}{cubes}",
                       "pass" if best.meets_target else "fail"))
    banner += [(w, "undecided") for w in result.warnings]
    sections = [("Plan", verdict_banner(banner))]
    if "plan" in images:
        sections.append(("The lines over the units", "{img:plan}"))
    if best is not None:
        rows = [{"id": u.id, "found": f"{100 * u.found:.0f} %", "min": u.min_soundings,
                 "mean": number(u.mean_soundings, ".0f"), "height": _mm(u.height_error_rms),
                 "centre": _mm(u.centre_error_rms)} for u in best.units]
        sections.append(("Each unit", html_table(rows, ["id", "found", "min", "mean", "height", "centre"], [
            "unit", "found in its place", "fewest soundings", "mean soundings", "height error RMS (mm)",
            "centre error RMS (mm)"])))
    rows = [{"layout": p.layout.name + (" (chosen)" if p.layout.name == result.chosen else ""),
             "what": p.layout.description, "minutes": f"{p.time_on_site_s / 60:.1f}",
             "found": f"{100 * p.found:.0f} %", "min": p.min_soundings,
             "cubes": "-" if p.cubes_detected is None else f"{100 * p.cubes_detected:.0f} %",
             "height": _mm(p.height_sigma), "centre": _mm(p.centre_sigma),
             "meets": "yes" if p.meets_target else "no"} for p in result.predictions]
    sections.append(("Every layout tried, fastest first", html_table(
        rows, ["layout", "what", "minutes", "found", "min", "cubes", "height", "centre", "meets"],
        ["layout", "what it is", "time on site (min)", "units found", "fewest soundings on a unit",
         "cubes detected", "height 1-sigma (mm)", "centre 1-sigma (mm)", "meets the targets"])))
    sections.append(("Options", parameter_table(result.parameters)))
    return html_page("mbinspect: survey plan over a reef plan", sections, images)
