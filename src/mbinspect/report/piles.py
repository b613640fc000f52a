"""The pile report: figures, the spacing table, and the outputs of ``mbinspect piles``."""

from __future__ import annotations

import html
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .clearance import LEAST_COLS, clearance_section
from .gis import crs_label, crs_name, crs_of, heights_label
from .html import html_page, html_table, parameter_table, provenance_table, verdict_banner
from .maps import map_furniture, mpl, plan_image, save_figure
from .pile_tables import (
    LEVEL_COLS,
    PILE_COLS,
    PILE_HEAD,
    SPACING_COLS,
    SPACING_HEAD,
    frame_section,
    level_section,
    pile_row,
    pile_verdicts,
    spacing_row,
    spacing_table,
)
from .writers import Outputs, figure_job, write_outputs

__all__ = ["pile_figures", "pile_figure_jobs", "spacing_table", "pile_outputs", "write_pile_outputs",
           "pile_verdicts"]


def _plan(result: Any, points: np.ndarray, piles: list[Any], spacings: list[Any], path: Path, title: str
          ) -> bytes:
    """One plan map: soundings, the piles' fitted tops, the spacings with their deviation."""
    plt = mpl()
    xy = np.array([[p.x, p.y] for p in piles])
    pad = 8.0
    lo, hi = xy.min(axis=0) - pad, xy.max(axis=0) + pad
    img, ext = plan_image(points, cell=0.2, bounds=[lo[0], lo[1], hi[0], hi[1]])
    fig, ax = plt.subplots(figsize=(8.5, 7.5))
    ref = xy.mean(axis=0)
    extent = [ext[0] - ref[0], ext[1] - ref[0], ext[2] - ref[1], ext[3] - ref[1]]
    im = ax.imshow(img, origin="lower", extent=extent, cmap="viridis", interpolation="nearest")
    fig.colorbar(im, ax=ax, label="elevation (m)", shrink=0.8)
    by_id = {p.id: p for p in piles}
    placed: list[np.ndarray] = []
    room = 0.06 * float(max(hi - lo))
    for s in spacings:
        a, b = by_id[s.a], by_id[s.b]
        ax.plot([a.x - ref[0], b.x - ref[0]], [a.y - ref[1], b.y - ref[1]], "w-", lw=0.8, alpha=0.8)
        label = f"{s.distance:.3f} m"
        if s.deviation is not None:
            label += f"\n{1000 * s.deviation:+.0f} mm"
        # a label where no other lies: the middle, else a third of the way along (diagonals)
        ends = np.array([[a.x, a.y], [b.x, b.y]]) - ref
        for frac in (0.5, 0.3, 0.7, 0.2, 0.8):
            at = ends[0] + frac * (ends[1] - ends[0])
            if all(np.hypot(*(at - q)) > room for q in placed):
                break
        placed.append(at)
        colour = {"fail": "darkred", "undecided": "darkorange"}.get(s.verdict or "", "k")
        ax.text(at[0], at[1], label, ha="center", va="center", fontsize=8, color=colour,
                bbox={"fc": "white", "ec": "none", "alpha": 0.8, "pad": 1.5})
    for p in piles:
        circ = plt.Circle((p.x - ref[0], p.y - ref[1]), p.radius, fill=False, color="red", lw=1.5)
        ax.add_patch(circ)
        out_dir = np.sign([p.x - ref[0], p.y - ref[1]]) + 1e-9  # the id outside the jacket
        ax.annotate(f"{p.id}", (p.x - ref[0], p.y - ref[1]), xytext=(10 * out_dir[0], 10 * out_dir[1]),
                    textcoords="offset points", color="red", fontsize=11, weight="bold",
                    ha="left" if out_dir[0] > 0 else "right", va="bottom" if out_dir[1] > 0 else "top")
    from matplotlib.lines import Line2D
    handles = [Line2D([], [], marker="o", ls="", mfc="none", mec="red", ms=9, label="fitted pile top"),
               Line2D([], [], color="0.5", lw=1.2, label="spacing (m; mm vs design)"),
               Line2D([], [], marker="s", ls="", color="darkorange", label="undecided at 95 % (text)"),
               Line2D([], [], marker="s", ls="", color="darkred", label="fails tolerance (text)")]
    ax.legend(handles=handles, loc="upper left", fontsize=7, framealpha=0.85)
    ax.set_title(title, fontsize=10)
    ax.set_aspect("equal")
    map_furniture(ax, crs_name=crs_name(crs_of(result)), origin=(float(ref[0]), float(ref[1])))
    return save_figure(fig, path)


def pile_figures(result: Any, points: np.ndarray, out: Path) -> dict[str, bytes]:
    """The pile figures: plan view, one per pile, convergence.

    Parameters
    ----------
    result : PileResult
    points : ndarray, shape (N, 3)
    out : Path
        Folder the PNGs are written to.

    Returns
    -------
    dict
        Name -> PNG bytes.
    """
    return {name: png for job in pile_figure_jobs(result, points, out) for name, png in job().items()}


def pile_figure_jobs(result: Any, points: np.ndarray, out: Path) -> list[Callable[[], dict[str, bytes]]]:
    """The pile figures as independent drawing jobs in report order, the plan maps first: each
    draws one figure into ``out`` and returns {name: PNG bytes}
    (:attr:`~mbinspect.report.writers.Outputs.figures`)."""
    piles = list(result.piles)
    groups = sorted({p.group for p in piles})
    if len(groups) == 1:
        jobs = [figure_job("plan", _plan, result, points, piles, list(result.spacings), out / "plan.png",
                           "Plan view: median sounding per 0.2 m cell, fitted tops (red), spacings and their "
                           "deviation from the design")]
    else:  # an overview without labels, and one map per jacket
        jobs = [figure_job("plan", _plan, result, points, piles, [], out / "plan.png",
                           "Plan view of every jacket: median sounding per 0.2 m cell, fitted tops (red)")]
        jobs += [figure_job(f"jacket{g}", _plan, result, points, [p for p in piles if p.group == g],
                            [sp for sp in result.spacings if sp.group == g], out / f"plan_jacket_{g}.png",
                            f"Jacket {g}: fitted tops (red), spacings and their deviation from the design")
                 for g in groups]
    jobs += [figure_job(f"pile{p.id}", _pile_figure, p, result.segments[p.id], result.cylinders.get(p.id),
                        out / f"pile_{p.id}.png") for p in piles if result.segments.get(p.id) is not None]
    if result.iterations:
        jobs.append(figure_job("convergence", _convergence, result, out / "convergence.png"))
    return jobs


def _pile_figure(p: Any, seg: Any, cyl: Any, path: Path) -> bytes:
    """One pile: its top, side and other points in plan and in an east-west section, the
    fitted top and axis."""
    plt = mpl()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4.6))
    pts = seg.points - [p.x, p.y, 0.0]
    other = ~(seg.top | seg.side)
    for ax_, i, j in ((a1, 0, 1), (a2, 0, 2)):
        ax_.scatter(pts[other, i], pts[other, j], s=2, c="0.7", label="other")
        ax_.scatter(pts[seg.side, i], pts[seg.side, j], s=2, c="tab:blue", label="side")
        ax_.scatter(pts[seg.top, i], pts[seg.top, j], s=2, c="tab:orange", label="top")
    t = np.linspace(0, 2 * np.pi, 200)
    a1.plot(p.radius * np.cos(t), p.radius * np.sin(t), "r-", lw=1.2, label="fitted top")
    a1.set_aspect("equal")
    a1.set_xlabel("east from centre (m)")
    a1.set_ylabel("north from centre (m)")
    a1.legend(loc="upper right", fontsize=7, markerscale=4)
    zlo = float(pts[:, 2].min())
    if cyl is not None:
        ax_dir = cyl.axis / cyl.axis[2]
        zz = np.array([zlo, p.z])
        dx = (zz - p.z) * ax_dir[0]
        a2.plot(dx, zz, "r--", lw=1, label="axis")
        for sgn in (-1, 1):
            a2.plot(dx + sgn * p.radius / cyl.axis[2], zz, "r-", lw=1.2)
    a2.set_xlabel("east from centre (m)")
    a2.set_ylabel("elevation (m)")
    tilt = ("" if p.tilt_deg is None else ", no tilt shown: axis held plumb" if p.tilt_held
            else f", tilt {p.tilt_deg:.2f} deg toward {p.tilt_azimuth_deg:.0f} deg")
    fig.suptitle(f"Pile {p.id}: {p.n_top} top and {p.n_side} side points{tilt}")
    return save_figure(fig, path)


def _convergence(result: Any, path: Path) -> bytes:
    """Each spacing's deviation from the design, iteration by iteration (the paper's Fig. 4)."""
    plt = mpl()
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    its = [it["iteration"] for it in result.iterations]
    design = {f"{s.a}-{s.b}": s.design for s in result.spacings}
    final = result.iterations[-1]["spacings"]
    for key in final:
        vals = np.array([it["spacings"].get(key, np.nan) for it in result.iterations])
        base = design.get(key)
        dev = vals - (base if base is not None else final[key])
        ax.plot(its, 100 * dev, "o-", ms=3, label=key)
    ax.axhline(0, color="k", lw=0.6)
    ax.set_xlabel("iteration")
    ax.set_ylabel("deviation from design (cm)" if any(v is not None for v in design.values())
                  else "change from the final value (cm)")
    ax.set_title("Spacing convergence")
    ax.legend(fontsize=7, ncol=3)
    return save_figure(fig, path)


def pile_outputs(result: Any, points: np.ndarray, *, title: str = "Pile positions and spacings",
                 truth: Mapping[str, Any] | None = None) -> Outputs:
    """What the writers write of a pile result: ``piles.json``, ``piles.csv``,
    ``spacings.csv``, ``levels.csv``, the GeoJSON, the figures and ``report.html``.

    Parameters
    ----------
    result : PileResult
    points : ndarray, shape (N, 3)
        The soundings, for the figures.
    title : str
    truth : mapping, optional
        A simulator truth dict: adds the errors against truth to the report.

    Returns
    -------
    Outputs
    """
    d = result.to_dict()
    # with both methods, both methods' piles: one row per pile and method
    rows = d["piles"] + d["other_piles"]
    features = [{"type": "Feature", "geometry": {"type": "Point", "coordinates": [p["x"], p["y"]]},
                 "properties": {c: p.get(c) for c in PILE_COLS if c != "flags"}
                 | {"flags": "; ".join(p.get("flags", []))}} for p in rows]
    tables = (("piles.csv", rows, PILE_COLS + LEAST_COLS), ("spacings.csv", d["spacings"], SPACING_COLS),
              ("levels.csv", d["levels"], LEVEL_COLS))
    return Outputs("piles", d, tables, features, crs_of(result),
                   lambda out: pile_figure_jobs(result, points, out), _figure_file,
                   lambda images: html_page(title, _page(result, d, images, truth), images))


def write_pile_outputs(result: Any, points: np.ndarray, out: Path, *, figures: bool = True,
                       title: str = "Pile positions and spacings",
                       truth: Mapping[str, Any] | None = None) -> list[str]:
    """Write every output of a pile result into ``out`` (:func:`pile_outputs`, :data:`WRITERS`).

    Parameters
    ----------
    result : PileResult
    points : ndarray, shape (N, 3)
        The soundings, for the figures.
    out : Path
        The (staging) output folder.
    figures : bool
    title : str
    truth : mapping, optional

    Returns
    -------
    list of str
        The files written.
    """
    return write_outputs(pile_outputs(result, points, title=title, truth=truth), out, figures=figures)


def _figure_file(name: str) -> str:
    if name in ("plan", "convergence"):
        return f"{name}.png"
    return f"plan_jacket_{name[6:]}.png" if name.startswith("jacket") else f"pile_{name[4:]}.png"


def _page(result: Any, d: Mapping[str, Any], images: dict[str, bytes],
          truth: Mapping[str, Any] | None) -> list[tuple[str, str]]:
    """The report's sections."""
    sections = [("Verdict", verdict_banner(pile_verdicts(result)))]
    if result.warnings:
        sections.append(("Warnings", "<ul>" + "".join(f"<li class='warn'>{html.escape(w)}</li>"
                                                      for w in result.warnings) + "</ul>"))
    sections.append(("Coordinates", f"<p>{html.escape(crs_label(result))}</p>"
                                    f"<p>Heights: {html.escape(heights_label(result))}</p>"))
    for g in sorted({s.group for s in result.spacings}):
        rows = [spacing_row(s) for s in result.spacings if s.group == g]
        heading = f"Jacket {g}: spacings" if g else "Spacings between jackets"
        sections.append((heading, html_table(rows, list(SPACING_HEAD), list(SPACING_HEAD.values()))))
    sections += [frame_section(f) for f in result.frames]
    sections += [level_section(result, g) for g in sorted({lv.group for lv in result.levels})]
    sections.append(clearance_section([(f"pile {p['id']} top", p) for p in d["piles"]], d["parameters"]))
    sections.append(("Piles (top centre)", html_table([pile_row(q) for q in result.piles], list(PILE_HEAD),
                                                      list(PILE_HEAD.values()))))
    if result.other_piles:
        sections.append(("Piles by the centre method (top centre)",
                         html_table([pile_row(q) for q in result.other_piles], list(PILE_HEAD),
                                    list(PILE_HEAD.values()))))
    if truth is not None:
        tp = {(s["a"], s["b"]): s["distance"] for s in truth.get("spacings", [])}
        sections.append(("Errors against simulator truth",
                         f"<pre>{html.escape(spacing_table(result, tp))}</pre>"))
    if images:
        sections.append(("Plan view", "{img:plan}"))
        for n in images:
            if n.startswith("jacket"):
                sections.append((f"Jacket {n[6:]}: plan", "{img:" + n + "}"))
        sections.append(("Convergence (the paper's Fig. 4)", "{img:convergence}"))
        sections.append(("Each pile", "".join("{img:" + n + "}" for n in images if n.startswith("pile"))))
    sections.append(("Input and software", provenance_table(d["parameters"])))
    sections.append(("Parameters", parameter_table(d["parameters"])))
    return sections
