"""What ``mbinspect change`` writes: ``change.json`` (the result's ``to_dict()``),
``change.csv``, ``change.geojson`` (each unit's displacement as a line from where it was to
where it is, removed and new units as points), the registered difference map as a PNG with
its colour bar, and ``report.html``: what changed, where, and how sure."""

from __future__ import annotations

import html
import math
from pathlib import Path
from typing import Any

import numpy as np

from ..report.html import html_page, html_table, number, verdict_banner
from ..report.writers import Outputs, write_outputs
from .results import MEASURES, ChangeResult, ObjectChange

__all__ = ["write_change_outputs", "CSV_COLUMNS", "change_rows"]

#: The CSV's columns, in order.
CSV_COLUMNS = (["id_before", "id_after", "status", "x_before", "y_before", "x_after", "y_after", "design"]
               + [c for m, _, _ in MEASURES for c in (m, f"{m}_lod95")]
               + ["height_before", "height_after", "tilt_before", "tilt_after", "overturned_before",
                  "overturned_after", "detected", "notes"])


def change_rows(result: ChangeResult) -> list[dict[str, Any]]:
    """One flat row per object (lists joined by ``;``)."""
    out = []
    for o in result.objects:
        d = o.to_dict()
        d["detected"] = ";".join(d["detected"]) or ("no detectable change" if o.status == "unchanged" else "")
        d["notes"] = "; ".join(d["notes"])
        out.append({c: d.get(c) for c in CSV_COLUMNS})
    return out


def _features(result: ChangeResult) -> list[dict[str, Any]]:
    feats = []
    for o in result.objects:
        props = {k: v for k, v in o.to_dict().items() if not isinstance(v, list)}
        props["detected"] = ";".join(o.detected)
        if o.status == "removed":
            geom = {"type": "Point", "coordinates": [o.x_before, o.y_before]}
        elif o.status == "new":
            geom = {"type": "Point", "coordinates": [o.x_after, o.y_after]}
        else:
            geom = {"type": "LineString", "coordinates": [[o.x_before, o.y_before], [o.x_after, o.y_after]]}
        feats.append({"type": "Feature", "properties": props, "geometry": geom})
    return feats


def write_change_outputs(result: ChangeResult, out: str | Path, *, crs: str | None = None,
                         figures: bool = True) -> list[str]:
    """Write a comparison's files into ``out`` (a staging folder); the names written."""
    outputs = Outputs("change", result.to_dict(), tables=(("change.csv", change_rows(result), CSV_COLUMNS),),
                      features=_features(result), crs=crs,
                      figures=(lambda folder: [lambda: _figures(result, folder)]) if figures else None,
                      page=lambda images: _page(result, images))
    return write_outputs(outputs, out, figures=figures)


def _figures(result: ChangeResult, folder: Path) -> dict[str, bytes]:
    """The difference map (after minus before, registered) with the displacement arrows."""
    from ..report.maps import mpl, save_figure

    diff = result.difference
    if diff is None:
        return {}
    plt = mpl()
    fig, ax = plt.subplots(figsize=(8, 7))
    ny, nx = diff.z.shape
    x0, y0 = diff.x0, diff.y0
    lim = max(float(np.nanpercentile(np.abs(diff.z), 99)) if np.isfinite(diff.z).any() else 0.1, 0.05)
    im = ax.imshow(diff.z, origin="lower", cmap="RdBu", vmin=-lim, vmax=lim,
                   extent=(0, nx * diff.cell, 0, ny * diff.cell), interpolation="nearest")
    bar = fig.colorbar(im, ax=ax, shrink=0.8)
    bar.set_label("after − before, registered (m; red: the seabed went down)")
    moved = [math.hypot(o.x_after - o.x_before, o.y_after - o.y_before) for o in result.objects
             if o.status in ("unchanged", "changed")]
    # arrows drawn longer than the moves (a move of centimetres would not show), said in the title
    scale = float(np.clip(3.0 / max(max(moved, default=1.0), 1e-3), 1.0, 20.0)) // 1
    for o in result.objects:
        if o.status in ("unchanged", "changed"):
            colour = "k" if o.status == "changed" else "0.5"
            tip = (o.x_before - x0 + scale * (o.x_after - o.x_before),
                   o.y_before - y0 + scale * (o.y_after - o.y_before))
            ax.annotate("", xy=tip, xytext=(o.x_before - x0, o.y_before - y0),
                        arrowprops={"arrowstyle": "->", "color": colour, "lw": 1.2})
            ax.plot(o.x_before - x0, o.y_before - y0, "o", ms=3, color=colour)
        else:
            x, y = (o.x_before, o.y_before) if o.status == "removed" else (o.x_after, o.y_after)
            ax.plot(x - x0, y - y0, "x" if o.status == "removed" else "+", ms=9, mew=2,
                    color="m" if o.status == "removed" else "g")
    ax.set_aspect("equal")
    ax.set_xlabel(f"m east of {x0:.1f}")
    ax.set_ylabel(f"m north of {y0:.1f}")
    ax.set_title("Seabed difference and unit movements" + (f" (arrows × {scale:.0f})" if scale > 1 else "")
                 + "; x removed, + new; black: changed")
    return {"difference": save_figure(fig, folder / "difference.png")}


def _page(result: ChangeResult, images: dict[str, bytes]) -> str:
    c = result.counts()
    reg = result.registration
    lines = [(f"{c['changed']} units changed, {c['unchanged']} with no detectable change, {c['removed']} "
              f"removed, {c['new']} new", "info")]
    lines += [(w, "undecided") for w in result.warnings]
    sections = [("Summary", verdict_banner(lines)),
                ("Registration (after minus before)", _registration(reg))]
    if "difference" in images:
        sections.append(("Difference map", "{img:difference}"))
    changed = [o for o in result.objects if o.status == "changed"]
    sections.append(("What changed, and how sure", _changes(changed) if changed
                     else "<p>No unit changed beyond its level of detection.</p>"))
    gone = [o for o in result.objects if o.status in ("removed", "new")]
    if gone:
        sections.append(("Removed and new units", html_table(
            [o.to_dict() for o in gone],
            ["status", "id_before", "id_after", "x_before", "y_before", "x_after", "y_after"], digits=2)))
    quiet = [o for o in result.objects if o.status == "unchanged"]
    if quiet:
        names = ", ".join(f"reef {o.id_before}" for o in quiet)
        sections.append(("No detectable change",
                         f"<p>{names}: every measure within its 95 % level of detection.</p>"))
    return html_page("mbinspect: change between two surveys", sections, images)


def _registration(reg: Any) -> str:
    rows = [{"quantity": "plan shift east (dx)", "value": number(reg.dx), "sigma": number(reg.sigma_dx)},
            {"quantity": "plan shift north (dy)", "value": number(reg.dy), "sigma": number(reg.sigma_dy)},
            {"quantity": "vertical offset (dz)", "value": number(reg.dz), "sigma": number(reg.sigma_dz)},
            {"quantity": "rotation (deg, clockwise)", "value": number(reg.rotation_deg, ".4f"),
             "sigma": number(reg.sigma_rotation_deg, ".4f")}]
    note = f"<p>{html.escape(reg.note)}</p>" if reg.note else ""
    return (html_table(rows, ["quantity", "value", "sigma"], ["", "value (m)", "1-sigma"]) + note
            + f"<p>From {reg.cells:,} cells ({reg.area:,.0f} m²) of seabed away from the objects; residual "
              f"spread {number(reg.residual_rms)} m; covariance over {reg.blocks} parts of the seabed"
            + (f"; the plan shift refined on {reg.ties} objects that kept their place" if reg.ties else "")
            + ".</p>")


def _changes(objs: list[ObjectChange]) -> str:
    rows = []
    for o in objs:
        row: dict[str, Any] = {"reef": f"{o.id_before} → {o.id_after}"}
        for m, _unit, _ in MEASURES:
            if m in ("dx", "dy"):
                continue
            v, lod = o.values.get(m), o.values.get(f"{m}_lod95")
            if v is None or not math.isfinite(v):
                row[m] = "–"
            elif lod is not None and math.isfinite(lod) and abs(v) <= lod:
                row[m] = "no detectable change"
            else:
                row[m] = f"{v:.2f} ± {number(lod, '.2f')}"
        row["how it rests"] = _rest(o.values)
        rows.append(row)
    cols = ["reef"] + [m for m, _, _ in MEASURES if m not in ("dx", "dy")] + ["how it rests"]
    heads = ["reef (before → after)"] + [f"{m} ({u})" for m, u, _ in MEASURES if m not in ("dx", "dy")] + [
        "how it rests"]
    return html_table(rows, cols, heads) + ("<p>Each change is given with its 95 % level of detection; a "
                                            "change inside it is no detectable change.</p>")


def _rest(v: dict[str, Any]) -> str:
    b, a = v.get("overturned_before"), v.get("overturned_after")
    word = {True: "overturned", False: "upright", None: "undecided"}
    return word[b] if b == a else f"{word[b]} → {word[a]}"
