"""The reef report: figures and the outputs of ``mbinspect reefs``."""

from __future__ import annotations

import html
import math
from pathlib import Path
from typing import Any

import numpy as np

from ..outputs import atomic_path
from .gis import crs_label, crs_of, write_gis
from .html import html_page, html_table, json_dumps
from .maps import mpl, plan_image, save_figure

__all__ = ["reef_figures", "write_reef_outputs"]


_REEF_COLS = ["id", "x", "y", "z_seabed", "z_top", "height", "area", "length", "width",
              "orientation_deg", "volume", "envelope_volume", "n_points", "group"]


_DESIGN_COLS = ["design", "design_scale", "design_bearing_deg", "design_misfit"]


def _hillshade(z: np.ndarray, cell: float) -> np.ndarray:
    zz = np.where(np.isfinite(z), z, np.nanmedian(z))
    gy, gx = np.gradient(zz, cell)
    az, alt = math.radians(315.0), math.radians(45.0)
    slope = np.arctan(np.hypot(gx, gy))
    aspect = np.arctan2(-gx, gy)
    shade = np.sin(alt) * np.cos(slope) + np.cos(alt) * np.sin(slope) * np.cos(az - aspect)
    return np.where(np.isfinite(z), shade, np.nan)


def reef_figures(result: Any, points: np.ndarray, out: Path) -> dict[str, bytes]:
    """Reef figures: plan map, profiles per group, height histogram. Returns name -> PNG.

    Parameters
    ----------
    result : ReefResult
    points : ndarray, shape (N, 3)
    out : Path
        Folder the PNGs are written to.

    Returns
    -------
    dict
    """
    from matplotlib.patches import Polygon as MplPolygon

    plt = mpl()
    images: dict[str, bytes] = {}
    p = np.asarray(points, np.float64)
    span = float(np.ptp(p[:, :2], axis=0).max())
    cell = max(0.2, span / 900.0)
    img, ext = plan_image(p, cell=cell)
    fig, ax = plt.subplots(figsize=(10, 8.5))
    ax.imshow(img, origin="lower", extent=ext, cmap="gist_earth", interpolation="nearest", alpha=0.9)
    ax.imshow(_hillshade(img, cell), origin="lower", extent=ext, cmap="gray", alpha=0.35,
              interpolation="nearest")
    colours = {}
    ev = result.evaluation
    if ev is not None:
        matched = {i for i, _, _ in ev.matches}
        colours = {i: ("tab:green" if i in matched else "tab:red") for i in range(len(result.reefs))}
    for i, r in enumerate(result.reefs):
        if r.outline:
            ax.add_patch(MplPolygon(np.asarray(r.outline), closed=True, fill=False, lw=0.9,
                                    ec=colours.get(i, "magenta")))
        if len(result.reefs) <= 400:
            ax.annotate(str(r.id), (r.x, r.y), fontsize=5, ha="center", va="center")
    for o in result.others:
        ax.plot(o["x"], o["y"], "x", color="orange", ms=4)
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
    title = "Reefs: outlines on shaded relief"
    if ev is not None:
        title += f" (green TP {ev.tp}, red FP {ev.fp}, blue circles FN {ev.fn})"
    if result.region is not None and result.region.excluded.any():
        title += "; red wash: excluded terrain"
    ax.set_title(title, fontsize=10)
    ax.set_xlabel("easting (m)")
    ax.set_ylabel("northing (m)")
    ax.set_aspect("equal")
    ax.ticklabel_format(useOffset=False, style="plain")
    images["plan"] = save_figure(fig, out / "plan.png")
    if result.reefs:
        fig, ax = plt.subplots(figsize=(6.5, 3.8))
        ax.hist([r.height for r in result.reefs], bins=20, color="tab:blue", edgecolor="white")
        ax.set_xlabel("reef height above the seabed (m)")
        ax.set_ylabel("reefs")
        ax.set_title(f"Heights of {len(result.reefs)} reefs")
        images["heights"] = save_figure(fig, out / "heights.png")
    groups = list(result.groups)[:12]
    if groups:
        n = len(groups)
        cols = min(3, n)
        rows = int(math.ceil(n / cols))
        fig, axes = plt.subplots(rows, cols, figsize=(5 * cols, 3.2 * rows), squeeze=False)
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
        images["groups"] = save_figure(fig, out / "groups.png")
    return images


def write_reef_outputs(result: Any, points: np.ndarray, out: Path, *, figures: bool = True,
                       title: str = "Artificial reefs") -> list[str]:
    """Write ``reefs.json``, ``reefs.csv``, ``reefs.geojson``, figures and ``report.html``.

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

    from ..outputs import write_json, write_table

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    d = result.to_dict()
    write_json(d, out / "reefs.json")
    cols = _REEF_COLS + (_DESIGN_COLS if result.parameters.get("design") else [])
    write_table(d["reefs"], out / "reefs.csv", cols)
    features = []
    for r in d["reefs"]:
        ring = r["outline"] + r["outline"][:1] if r["outline"] else []
        features.append({"type": "Feature",
                         "geometry": {"type": "Polygon", "coordinates": [ring]} if ring else None,
                         "properties": {c: r[c] for c in cols}})
    written = ["reefs.json", "reefs.csv", *write_gis(features, crs_of(result), out, "reefs")]
    images = reef_figures(result, points, out) if figures else {}
    written += [f"{n}.png" for n in images]
    ev = d["evaluation"]
    sections = []
    if result.warnings:
        sections.append(("Warnings", "<ul>" + "".join(f"<li class='warn'>{html.escape(w)}</li>"
                                                      for w in result.warnings) + "</ul>"))
    summary: list[dict[str, Any]] = [{"item": "coordinates", "value": crs_label(result)},
               {"item": "reefs", "value": len(d["reefs"])},
               {"item": "groups", "value": len(d["groups"])},
               {"item": "other objects (< min area)", "value": len(d["others"])},
               {"item": "seabed model", "value": d["seabed"].get("method")},
               {"item": "seabed residual RMS (m)", "value": d["seabed"].get("residual_rms")}]
    if ev is not None:
        summary += [{"item": k, "value": ev[k]} for k in ("tp", "fp", "fn", "correctness",
                                                          "completeness", "f1")]
    sections.append(("Summary", html_table(summary, ["item", "value"])))
    if ev is not None:
        sections.append(("Scoring rule", f"<p>{html.escape(ev['counting'])}; tolerance "
                                         f"{ev['tolerance']} m.</p>"))
    if images:
        sections.append(("Plan map", "{img:plan}"))
    sections.append(("Groups", html_table(d["groups"], ["id", "count", "x", "y", "area",
                                                        "reef_area", "mean_height"])))
    if "groups" in images:
        sections.append(("Profiles", "{img:groups}"))
    if "heights" in images:
        sections.append(("Heights", "{img:heights}"))
    sections.append(("Reefs", html_table(d["reefs"], cols)))
    if d["others"]:
        sections.append(("Other objects", html_table(d["others"], ["x", "y", "height", "area",
                                                                   "n_points"])))
    listing = json_dumps({"filters": d["filters"], "seabed": d["seabed"], "parameters": d["parameters"]})
    sections.append(("Filters and parameters", f"<pre>{html.escape(listing)}</pre>"))
    with atomic_path(out / "report.html") as tmp:
        tmp.write_text(html_page(title, sections, images), encoding="utf-8")
    written.append("report.html")
    return written
