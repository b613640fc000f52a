"""The reef report: figures and the outputs of ``mbinspect reefs``."""

from __future__ import annotations

import html
import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..grid import bounds as plan_bounds
from .clearance import LEAST_COLS, clearance_section, placement_lines, placement_section, rest_section
from .gis import crs_label, crs_name, crs_of, heights_label
from .html import html_page, html_table, json_dumps, number, parameter_table, provenance_table, verdict_banner
from .maps import map_figure, map_furniture, mpl, plan_image, save_figure
from .writers import Outputs, figure_job, write_outputs

__all__ = ["reef_figures", "reef_figure_jobs", "reef_outputs", "write_reef_outputs", "reef_verdicts"]


_REEF_COLS = ["id", "x", "y", "z_seabed", "z_top", "height", "area", "length", "width",
              "orientation_deg", "volume", "envelope_volume", "n_points", "group"]


_DESIGN_COLS = ["design", "design_scale", "design_bearing_deg", "design_misfit", "buried_share"]


def _hillshade(z: np.ndarray, cell: float) -> np.ndarray:
    zz = np.where(np.isfinite(z), z, np.nanmedian(z))
    gy, gx = np.gradient(zz, cell)
    az, alt = math.radians(315.0), math.radians(45.0)
    slope = np.arctan(np.hypot(gx, gy))
    aspect = np.arctan2(-gx, gy)
    shade = np.sin(alt) * np.cos(slope) + np.cos(alt) * np.sin(slope) * np.cos(az - aspect)
    return np.where(np.isfinite(z), shade, np.nan)


def _inside(x: float, y: float, bounds: list[float] | None, margin: float = 10.0) -> bool:
    """Whether (x, y) lies within ``bounds`` (``[x0, y0, x1, y1]``) and ``margin`` m; any
    point without bounds."""
    return bounds is None or (bounds[0] - margin <= x <= bounds[2] + margin
                              and bounds[1] - margin <= y <= bounds[3] + margin)


def _draw_objects(ax: Any, result: Any, colours: dict[int, str], bounds: list[float] | None) -> None:
    """The reefs' outlines and numbers and the other objects on a map: one artist for all
    outlines and one for all others (a patch and a line each took 3 s of the five maps of a
    100-reef field); a zoomed map draws only what lies in it."""
    from matplotlib.collections import PolyCollection

    shown = [(i, r) for i, r in enumerate(result.reefs) if _inside(r.x, r.y, bounds)]
    outlines = [(np.asarray(r.outline), colours.get(i, "magenta")) for i, r in shown if r.outline]
    if outlines:
        ax.add_collection(PolyCollection([o for o, _ in outlines], closed=True, facecolors="none",
                                         edgecolors=[c for _, c in outlines], linewidths=0.9))
    if len(result.reefs) <= 400:
        for _, r in shown:
            ax.annotate(str(r.id), (r.x, r.y), fontsize=5 if bounds is None else 9, ha="center", va="center")
    others = np.array([(o.x, o.y) for o in result.others if _inside(o.x, o.y, bounds)]).reshape(-1, 2)
    if len(others):
        ax.plot(others[:, 0], others[:, 1], "x", color="orange", ms=4, ls="")


def _reef_map(result: Any, points: np.ndarray, path: Path, heading: str,
              bounds: list[float] | None = None) -> bytes:
    """One reef map: shaded relief, outlines coloured by the score, others, legend, furniture."""
    from matplotlib.lines import Line2D

    p = np.asarray(points, np.float64)
    span = float(np.subtract(*plan_bounds(p)[::-1]).max()) if bounds is None else max(bounds[2] - bounds[0],
                                                                          bounds[3] - bounds[1])
    cell = max(0.1 if bounds is not None else 0.2, span / 900.0)
    img, ext = plan_image(p, cell=cell, bounds=bounds)
    fig, ax, cax = map_figure(ext)
    shown = ax.imshow(img, origin="lower", extent=ext, cmap="gist_earth", interpolation="nearest", alpha=0.9)
    fig.colorbar(shown, cax=cax, label="elevation (m)")
    ax.imshow(_hillshade(img, cell), origin="lower", extent=ext, cmap="gray", alpha=0.35,
              interpolation="nearest")
    colours = {}
    ev = result.evaluation
    if ev is not None:
        matched = {i for i, _, _ in ev.matches}
        colours = {i: ("tab:green" if i in matched else "tab:red") for i in range(len(result.reefs))}
    _draw_objects(ax, result, colours, bounds)
    if ev is not None and result.reference_xy is not None:
        ref = np.asarray(result.reference_xy)
        miss = [j for j in ev.unmatched_references]
        if miss:
            ax.plot(ref[miss, 0], ref[miss, 1], "o", mfc="none", mec="blue", ms=8, label="FN (missed)")
    if result.region is not None and result.region.excluded.any():
        m = result.region
        ex = np.where(m.excluded.T, 1.0, np.nan)
        ax.imshow(ex, origin="lower", cmap="Reds", alpha=0.3, vmin=0, vmax=1.5,
                  extent=[m.x0, m.x0 + m.excluded.shape[0] * m.cell, m.y0,
                          m.y0 + m.excluded.shape[1] * m.cell])
    title = heading
    if ev is not None:
        title += f" (green TP {ev.tp}, red FP {ev.fp}, blue circles FN {ev.fn})"
    if result.region is not None and result.region.excluded.any():
        title += "; red wash: excluded terrain"
    ax.set_title(title, fontsize=10)
    ax.set_aspect("equal")
    ax.ticklabel_format(useOffset=False, style="plain")
    if bounds is not None:
        ax.set_xlim(bounds[0], bounds[2])
        ax.set_ylim(bounds[1], bounds[3])
    handles = [Line2D([], [], color="magenta" if ev is None else "tab:green", lw=1.5,
                      label="reef outline" if ev is None else "reef matched (TP)")]
    if ev is not None:
        handles += [Line2D([], [], color="tab:red", lw=1.5, label="reef not in the reference (FP)"),
                    Line2D([], [], marker="o", ls="", mfc="none", mec="blue", label="reference missed (FN)")]
    handles.append(Line2D([], [], marker="x", ls="", color="orange", label="other object"))
    ax.legend(handles=handles, loc="upper left", fontsize=8, framealpha=0.8)
    map_furniture(ax, crs_name=crs_name(crs_of(result)), origin=None)
    return save_figure(fig, path, tight=False)


def reef_figures(result: Any, points: np.ndarray, out: Path) -> dict[str, bytes]:
    """Reef figures: plan map, a map per group, profiles per group, height histogram.

    Parameters
    ----------
    result : ReefResult
    points : ndarray, shape (N, 3)
    out : Path
        Folder the PNGs are written to.

    Returns
    -------
    dict
        Name -> PNG bytes.
    """
    return {name: png for job in reef_figure_jobs(result, points, out) for name, png in job().items()}


def reef_figure_jobs(result: Any, points: np.ndarray, out: Path) -> list[Callable[[], dict[str, bytes]]]:
    """The reef figures as independent drawing jobs in report order, the slowest (the plan map)
    first: each draws one figure into ``out`` and returns {name: PNG bytes}
    (:attr:`~mbinspect.report.writers.Outputs.figures`)."""
    jobs = [figure_job("plan", _reef_map, result, points, out / "plan.png",
                       "Reefs: outlines on shaded relief")]
    if len(result.reefs) > 30:  # a readable map per group
        for g in list(result.groups)[:12]:
            members = [r for r in result.reefs if r.group == g["id"]]
            xy = np.array([v for r in members for v in (r.outline or ((r.x, r.y),))])
            lo, hi = xy.min(axis=0) - 4.0, xy.max(axis=0) + 4.0
            jobs.append(figure_job(f"groupmap{g['id']}", _reef_map, result, points,
                                   out / f"plan_group_{g['id']}.png",
                                   f"Group {g['id']}: {len(members)} reefs", [lo[0], lo[1], hi[0], hi[1]]))
    if result.reefs:
        jobs.append(figure_job("heights", _heights, result, out / "heights.png"))
    if result.groups:
        jobs.append(figure_job("groups", _profiles, result, list(result.groups)[:12], out / "groups.png"))
    return jobs


def _heights(result: Any, path: Path) -> bytes:
    """The histogram of the reefs' heights."""
    fig, ax = mpl().subplots(figsize=(6.5, 3.8))
    ax.hist([r.height for r in result.reefs], bins=20, color="tab:blue", edgecolor="white")
    ax.set_xlabel("reef height above the seabed (m)")
    ax.set_ylabel("reefs")
    ax.set_title(f"Heights of {len(result.reefs)} reefs")
    return save_figure(fig, path)


def _profiles(result: Any, groups: list[Mapping[str, Any]], path: Path) -> bytes:
    """Each group's reef heights against easting, a panel per group."""
    n = len(groups)
    cols = min(3, n)
    rows = int(math.ceil(n / cols))
    fig, axes = mpl().subplots(rows, cols, figsize=(5 * cols, 3.2 * rows), squeeze=False)
    for ax, g in zip(axes.ravel(), groups, strict=False):
        members = [r for r in result.reefs if r.group == g["id"]]
        xs = np.array([r.x for r in members])
        ax.bar(xs - xs.min(), [r.height for r in members], width=1.2, color="tab:gray")
        ax.set_title(f"group {g['id']}: {g['count']} reefs", fontsize=9)
        ax.set_xlabel("easting from the group's west edge (m)", fontsize=8)
        ax.set_ylabel("height (m)", fontsize=8)
    for ax in axes.ravel()[n:]:
        ax.axis("off")
    fig.suptitle("Profiles: reef heights across each group")
    fig.tight_layout()
    return save_figure(fig, path)


_GROUP_HEAD = {"id": "group", "count": "reefs", "x": "easting (m)", "y": "northing (m)",
               "area": "group area (m²)", "reef_area": "reef area (m²)", "mean_height": "mean height (m)"}
_REEF_HEAD = {"id": "reef", "group": "group", "x": "easting (m)", "y": "northing (m)",
              "z_seabed": "seabed (m)",
              "z_top": "top (m)", "height": "height (m)", "area": "area (m²)", "length": "length (m)",
              "width": "width (m)", "orientation_deg": "orientation (°)", "volume": "volume (m³)",
              "envelope_volume": "envelope (m³)", "n_points": "soundings"}
_DESIGN_HEAD = {"design": "design", "design_scale": "as built / design", "design_bearing_deg": "bearing (°)",
                "design_misfit": "misfit"}


def _reef_row(r: dict[str, Any]) -> dict[str, Any]:
    fmt = {"x": ".2f", "y": ".2f", "z_seabed": ".2f", "z_top": ".2f", "height": ".2f", "area": ".2f",
           "length": ".2f", "width": ".2f", "orientation_deg": ".0f", "volume": ".2f",
           "envelope_volume": ".1f",
           "design_scale": ".3f", "design_bearing_deg": ".0f", "design_misfit": ".2f"}
    out = {}
    for k, v in r.items():
        out[k] = f"{v:{fmt[k]}}" if k in fmt and isinstance(v, (int, float)) else v
    return out


def reef_verdicts(result: Any) -> list[tuple[str, str]]:
    """The reef report's first line: how many reefs, and against the reference how well.

    Parameters
    ----------
    result : ReefResult

    Returns
    -------
    list of (text, level)
    """
    n = len(result.reefs)
    ev = result.evaluation
    turned = [r.id for r in result.reefs if r.overturned]
    rest = [(f"Overturned (on a side or upside down): {len(turned)} unit{'s' * (len(turned) != 1)} "
             f"(reef {', '.join(map(str, turned))})", "fail")] if turned else []
    if ev is None:
        return [(f"Reefs: {n} found in {len(result.groups)} groups, {len(result.others)} other objects; no "
                 "reference to score against", "info")] + rest
    text = (f"Reefs: {n} found; against {ev.tp + ev.fn} reference reefs: TP {ev.tp}, FP {ev.fp}, FN {ev.fn}, "
            f"correctness {100 * ev.correctness:.1f} %, completeness {100 * ev.completeness:.1f} %"
            if n and ev.tp + ev.fn else f"Reefs: {n} found; TP {ev.tp}, FP {ev.fp}, FN {ev.fn}")
    level = "pass" if ev.fp == 0 and ev.fn == 0 else "undecided" if ev.tp else "fail"
    return [(text, level)]


def reef_outputs(result: Any, points: np.ndarray, *, title: str = "Artificial reefs") -> Outputs:
    """What the writers write of a reef result: ``reefs.json``, ``reefs.csv``, the GeoJSON
    (the footprints as polygons), the figures and ``report.html``.

    Parameters
    ----------
    result : ReefResult
    points : ndarray, shape (N, 3)
        The soundings, for the figures.
    title : str

    Returns
    -------
    Outputs
    """
    d = result.to_dict()
    cols = _REEF_COLS + (_DESIGN_COLS if result.parameters.get("design") else []) + LEAST_COLS
    # what a reef's row carries beyond these (its placement against a plan): columns too
    cols += [k for k in dict.fromkeys(k for r in d["reefs"] for k in r) if k not in cols
             and k not in ("outline", "sources") and not k.startswith("least_depth")]
    features = []
    for r in d["reefs"]:
        ring = r["outline"] + r["outline"][:1] if r["outline"] else []
        features.append({"type": "Feature",
                         "geometry": {"type": "Polygon", "coordinates": [ring]} if ring else None,
                         "properties": {c: r.get(c) for c in cols}})
    return Outputs("reefs", d, (("reefs.csv", d["reefs"], cols),), features, crs_of(result),
                   lambda out: reef_figure_jobs(result, points, out), _figure_file,
                   lambda images: html_page(title, _page(result, d, images), images),
                   (("placement", placement_lines(d)),) if "plan_missing" in d else ())


def write_reef_outputs(result: Any, points: np.ndarray, out: Path, *, figures: bool = True,
                       title: str = "Artificial reefs") -> list[str]:
    """Write every output of a reef result into ``out`` (:func:`reef_outputs`, :data:`WRITERS`).

    Parameters
    ----------
    result : ReefResult
    points : ndarray, shape (N, 3)
    out : Path
        The (staging) output folder.
    figures : bool
    title : str

    Returns
    -------
    list of str
        The files written.
    """
    return write_outputs(reef_outputs(result, points, title=title), out, figures=figures)


def _figure_file(name: str) -> str:
    return f"plan_group_{name[8:]}.png" if name.startswith("groupmap") else f"{name}.png"


def _page(result: Any, d: Mapping[str, Any], images: dict[str, bytes]) -> list[tuple[str, str]]:
    """The report's sections."""
    sections = [("Verdict", verdict_banner(reef_verdicts(result)))]
    if result.warnings:
        sections.append(("Warnings", "<ul>" + "".join(f"<li class='warn'>{html.escape(w)}</li>"
                                                      for w in result.warnings) + "</ul>"))
    summary: list[dict[str, Any]] = [
        {"item": "coordinates", "value": crs_label(result)},
        {"item": "heights", "value": heights_label(result)},
        {"item": "reefs", "value": len(d["reefs"])},
        {"item": "groups", "value": len(d["groups"])},
        {"item": "other objects (smaller than min_area)", "value": len(d["others"])},
        {"item": "seabed model", "value": d["seabed"].get("method")},
        {"item": "seabed residual RMS (m)", "value": number(d["seabed"].get("residual_rms"))}]
    sections.append(("Summary", html_table(summary, ["item", "value"])))
    if d["evaluation"] is not None:
        sections += _scoring_sections(d["evaluation"])
    if images:
        sections.append(("Plan map", "{img:plan}"))
        for n in images:
            if n.startswith("groupmap"):
                sections.append((f"Group {n[8:]}: plan", "{img:" + n + "}"))
    groups = [{"id": g["id"], "count": g["count"], "x": number(g["x"], ".2f"), "y": number(g["y"], ".2f"),
               "area": number(g["area"], ".0f"), "reef_area": number(g["reef_area"], ".1f"),
               "mean_height": number(g["mean_height"], ".2f")} for g in d["groups"]]
    sections.append(("Groups", html_table(groups, list(_GROUP_HEAD), list(_GROUP_HEAD.values()))))
    if "groups" in images:
        sections.append(("Profiles", "{img:groups}"))
    if "heights" in images:
        sections.append(("Heights", "{img:heights}"))
    head = {**_REEF_HEAD, **(_DESIGN_HEAD if result.parameters.get("design") else {})}
    rows = [_reef_row(r) for r in d["reefs"]]
    sections.append(("Reefs", html_table(rows, list(head), list(head.values()))))
    if d["others"]:
        sections.append(("Other objects", _others_table(d["others"])))
    if "plan_missing" in d:
        sections.append(placement_section(d))
    if d["reefs"]:
        sections.append(rest_section(d))
    sections.append(clearance_section([(f"reef {r['id']}", r) for r in d["reefs"]]
                                      + [(f"other at ({o['x']:.1f}, {o['y']:.1f})", o) for o in d["others"]
                                         if o["n_points"] > SPECK_SOUNDINGS], d["parameters"]))
    listing = json_dumps({"filters": d["filters"], "seabed": d["seabed"]})
    sections.append(("Filters and seabed", f"<pre>{html.escape(listing)}</pre>"))
    sections.append(("Input and software", provenance_table(d["parameters"])))
    sections.append(("Parameters", parameter_table(d["parameters"])))
    return sections


#: Other objects of this many soundings or fewer are specks (noise spikes): counted, not listed.
SPECK_SOUNDINGS = 2


def _others_table(others: Sequence[Mapping[str, Any]]) -> str:
    """The other objects with their reasons, specks of one or two soundings counted in one line."""
    specks = [o for o in others if o["n_points"] <= SPECK_SOUNDINGS]
    rows = [{"x": number(o["x"], ".2f"), "y": number(o["y"], ".2f"), "height": number(o["height"], ".2f"),
             "area": number(o["area"], ".2f"), "n_points": o["n_points"], "reason": o.get("reason", "")}
            for o in others if o["n_points"] > SPECK_SOUNDINGS]
    note = (f"<p>{len(specks)} specks of {SPECK_SOUNDINGS} soundings or fewer (noise spikes standing off the "
            "seabed) are counted here, not listed; reefs.json lists each.</p>") if specks else ""
    heads = ["easting (m)", "northing (m)", "height (m)", "area (m²)", "soundings", "why not a reef"]
    table = html_table(rows, ["x", "y", "height", "area", "n_points", "reason"], heads) if rows else ""
    return note + table


def _scoring_sections(ev: Mapping[str, Any]) -> list[tuple[str, str]]:
    """The scoring rule and the match table."""
    matches = [{"reference": m["reference"], "reef": m["reef"], "error": number(m["distance"], ".2f")}
               for m in ev["matches"]]
    matches += [{"reference": rid, "reef": "missed (FN)", "error": ""} for rid in ev["unmatched_references"]]
    matches += [{"reference": "none (FP)", "reef": rid, "error": ""} for rid in ev["unmatched_reefs"]]
    return [("Scoring rule", f"<p>{html.escape(ev['counting'])}; tolerance {ev['tolerance']} m.</p>"),
            ("Match table", html_table(matches, ["reference", "reef", "error"],
                                       ["reference", "reef", "position error (m)"]))]
