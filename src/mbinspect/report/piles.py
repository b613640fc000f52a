"""The pile report: figures, the spacing table, and the outputs of ``mbinspect piles``."""

from __future__ import annotations

import html
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .gis import crs_label, crs_name, crs_of
from .html import html_page, html_table, parameter_table, provenance_table, verdict_banner
from .maps import map_furniture, mpl, plan_image, save_figure
from .writers import Outputs, write_outputs

__all__ = ["pile_figures", "spacing_table", "pile_outputs", "write_pile_outputs", "pile_verdicts"]


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
    """The pile figures: plan view, one per pile, convergence. Returns name -> PNG bytes.

    Parameters
    ----------
    result : PileResult
    points : ndarray, shape (N, 3)
    out : Path
        Folder the PNGs are written to.

    Returns
    -------
    dict
    """
    images: dict[str, bytes] = {}
    piles = list(result.piles)
    groups = sorted({p.group for p in piles})
    if len(groups) == 1:
        images["plan"] = _plan(result, points, piles, list(result.spacings), out / "plan.png",
                               "Plan view: median sounding per 0.2 m cell, fitted tops (red), spacings and "
                               "their deviation from the design")
    else:  # an overview without labels, and one map per jacket
        images["plan"] = _plan(result, points, piles, [], out / "plan.png",
                               "Plan view of every jacket: median sounding per 0.2 m cell, fitted tops (red)")
        for g in groups:
            images[f"jacket{g}"] = _plan(result, points, [p for p in piles if p.group == g],
                                         [sp for sp in result.spacings if sp.group == g],
                                         out / f"plan_jacket_{g}.png",
                                         f"Jacket {g}: fitted tops (red), spacings and their deviation "
                                         "from the design")
    for p in piles:
        seg = result.segments.get(p.id)
        if seg is not None:
            images[f"pile{p.id}"] = _pile_figure(p, seg, result.cylinders.get(p.id), out / f"pile_{p.id}.png")
    if result.iterations:
        images["convergence"] = _convergence(result, out / "convergence.png")
    return images


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


_PILE_COLS = ["id", "group", "x", "y", "z", "radius", "tilt_deg", "tilt_azimuth_deg", "tilt_held", "method",
              "n_top", "n_side", "side_coverage_deg", "rms", "sigma_xy", "flags"]


_SPACING_COLS = ["group", "a", "b", "distance", "sigma", "low_95", "high_95", "design", "deviation",
                 "verdict", "pass", "method"]


_FRAME_COLS = ["id", "dx", "dy", "miss", "sigma", "miss_95", "verdict"]


#: Table columns and their headers with units (values rounded to what they mean).
_SPACING_HEAD = {"pair": "pair", "distance": "measured (m)", "design": "design (m)",
                 "deviation": "deviation (mm)", "sigma": "1σ (mm)", "interval": "95 % interval (mm)",
                 "verdict": "at 95 %"}
_PILE_HEAD = {"id": "pile", "group": "jacket", "x": "easting (m)", "y": "northing (m)", "z": "top (m)",
              "radius": "radius (m)", "tilt": "tilt (°)", "toward": "toward (°)", "method": "method",
              "n_top": "top points", "n_side": "side points", "arc": "side arc (°)", "rms": "rms (mm)",
              "sigma": "1σ plan (mm)", "flags": "flags"}
_FRAME_HEAD = {"id": "pile", "dx": "east miss (mm)", "dy": "north miss (mm)", "miss": "miss (mm)",
               "sigma": "1σ (mm)", "miss_95": "miss at 95 % (mm)", "verdict": "at 95 %"}


def _spacing_row(s: Any) -> dict[str, Any]:
    dev = None if s.deviation is None else 1000 * s.deviation
    return {"pair": f"{s.a}–{s.b}", "distance": f"{s.distance:.3f}",
            "design": "" if s.design is None else f"{s.design:.3f}",
            "deviation": "" if dev is None else f"{dev:+.1f}", "sigma": f"{1000 * s.sigma:.1f}",
            "interval": f"±{1960 * s.sigma:.1f}" if dev is None
            else f"{dev - 1960 * s.sigma:+.1f} … {dev + 1960 * s.sigma:+.1f}",
            "verdict": s.verdict or ""}


def _pile_row(p: Any) -> dict[str, Any]:
    return {"id": p.id, "group": p.group, "x": f"{p.x:.3f}", "y": f"{p.y:.3f}", "z": f"{p.z:.3f}",
            "radius": f"{p.radius:.3f}",
            "tilt": "" if p.tilt_deg is None else "plumb (held)" if p.tilt_held else f"{p.tilt_deg:.1f}",
            "toward": "" if p.tilt_azimuth_deg is None or p.tilt_held else f"{p.tilt_azimuth_deg:.0f}",
            "method": p.method,
            "n_top": p.n_top, "n_side": p.n_side, "arc": f"{p.side_coverage_deg:.0f}",
            "rms": f"{1000 * p.rms:.1f}", "sigma": f"{1000 * p.sigma_xy:.1f}", "flags": "; ".join(p.flags)}


def pile_verdicts(result: Any) -> list[tuple[str, str]]:
    """The report's first lines: per jacket, whether its frame fits and how many spacings
    pass at 95 %; each flagged pile; or, without a design, what was located.

    Parameters
    ----------
    result : PileResult

    Returns
    -------
    list of (text, level)
        ``level`` is ``pass``, ``fail``, ``undecided`` or ``info``.
    """
    lines: list[tuple[str, str]] = []
    frames = {f.group: f for f in result.frames}
    for g in sorted({s.group for s in result.spacings if s.group}):
        sp = [s for s in result.spacings if s.group == g and s.verdict is not None]
        if not sp and g not in frames:
            continue
        verdicts = [s.verdict for s in sp] + ([frames[g].verdict] if g in frames else [])
        level = "fail" if "fail" in verdicts else "undecided" if "undecided" in verdicts else "pass"
        said = {"pass": "frame fits", "fail": "frame FAILS", "undecided": "frame fit undecided"}
        head = f"Jacket {g}: " + (said[frames[g].verdict] + ", " if g in frames else "")
        fails = sum(s.verdict == "fail" for s in sp)
        open_ = sum(s.verdict == "undecided" for s in sp)
        text = head + f"{sum(s.verdict == 'pass' for s in sp)} of {len(sp)} spacings pass at 95 %"
        text += (f", {fails} fail" if fails else "") + (f", {open_} undecided" if open_ else "")
        lines.append((text, level))
    if not lines:
        n_groups = len({p.group for p in result.piles})
        lines.append((f"{len(result.piles)} piles located in {n_groups} jacket(s), {len(result.spacings)} "
                      "spacings; no design to compare with", "info"))
    for p in result.piles:
        if p.flags:
            lines.append((f"Pile {p.id}: {p.flags[0]}", "undecided"))
    return lines


def spacing_table(result: Any, truth: Mapping[tuple[int, int], float] | None = None) -> str:
    """The spacing table as plain text (what ``mbinspect piles`` prints).

    With both centre methods, each method's spacings, marked by a ``method`` column.
    """
    both = bool(result.other_spacings)
    head = (f"{'jacket':>6} {'pair':>6} {'distance m':>11} {'1-sigma mm':>10} {'design m':>9} {'dev cm':>7} "
            f"{'at 95 %':>9}")
    if both:
        head += f" {'method':>12}"
    if truth:
        head += f" {'error vs truth mm':>17}"
    lines = [head]
    for s in tuple(result.spacings) + tuple(result.other_spacings):
        verdict = {"fail": "FAIL", "undecided": "undecided"}.get(s.verdict or "", s.verdict or "")
        row = (f"{s.group or '-':>6} {s.a:>3}-{s.b:<2} {s.distance:>11.4f} {1000 * s.sigma:>10.1f} "
               f"{'' if s.design is None else f'{s.design:.3f}':>9} "
               f"{'' if s.deviation is None else f'{100 * s.deviation:+.1f}':>7} "
               f"{verdict:>9}")
        if both:
            row += f" {s.method:>12}"
        if truth:
            t = truth.get((s.a, s.b))
            row += f" {'' if t is None else f'{1000 * (s.distance - t):+.1f}':>17}"
        lines.append(row)
    for f in getattr(result, "frames", ()):
        worst = max(f.residuals, key=lambda q: q["miss_95"])
        said = {"pass": "frame fits", "fail": "frame FAILS"}.get(f.verdict, "undecided")
        lines.append(f"jacket {f.group}: design frame fitted (rotation {f.rotation_deg:+.3f} deg, shift "
                     f"{f.shift_x:+.3f}, {f.shift_y:+.3f} m); largest miss {1000 * worst['miss']:.0f} mm "
                     f"(pile {worst['id']}, {1000 * worst['miss_95']:.0f} mm at 95 %): {said} "
                     f"(tolerance {1000 * f.tolerance:.0f} mm)")
    return "\n".join(lines)


def pile_outputs(result: Any, points: np.ndarray, *, title: str = "Pile positions and spacings",
                 truth: Mapping[str, Any] | None = None) -> Outputs:
    """What the writers write of a pile result: ``piles.json``, ``piles.csv``,
    ``spacings.csv``, the GeoJSON, the figures and ``report.html``.

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
                 "properties": {c: p.get(c) for c in _PILE_COLS if c != "flags"}
                 | {"flags": "; ".join(p.get("flags", []))}} for p in rows]
    tables = (("piles.csv", rows, _PILE_COLS), ("spacings.csv", d["spacings"], _SPACING_COLS))
    return Outputs("piles", d, tables, features, crs_of(result),
                   lambda out: pile_figures(result, points, out), _figure_file,
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
    sections.append(("Coordinates", f"<p>{html.escape(crs_label(result))}</p>"))
    for g in sorted({s.group for s in result.spacings}):
        rows = [_spacing_row(s) for s in result.spacings if s.group == g]
        heading = f"Jacket {g}: spacings" if g else "Spacings between jackets"
        sections.append((heading, html_table(rows, list(_SPACING_HEAD), list(_SPACING_HEAD.values()))))
    sections += [_frame_section(f) for f in result.frames]
    sections.append(("Piles (top centre)", html_table([_pile_row(q) for q in result.piles], list(_PILE_HEAD),
                                                      list(_PILE_HEAD.values()))))
    if result.other_piles:
        sections.append(("Piles by the centre method (top centre)",
                         html_table([_pile_row(q) for q in result.other_piles], list(_PILE_HEAD),
                                    list(_PILE_HEAD.values()))))
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


def _frame_section(f: Any) -> tuple[str, str]:
    """A jacket's design frame fit: its heading and table."""
    rows = [{"id": q["id"], "dx": f"{1000 * q['dx']:+.0f}", "dy": f"{1000 * q['dy']:+.0f}",
             "miss": f"{1000 * q['miss']:.0f}", "sigma": f"{1000 * q['sigma']:.1f}",
             "miss_95": f"{1000 * q['miss_95']:.0f}", "verdict": q["verdict"]} for q in f.residuals]
    return (f"Jacket {f.group}: design frame fit ({f.verdict} at 95 %, tolerance "
            f"{1000 * f.tolerance:.0f} mm; rotation {f.rotation_deg:+.3f}°, shift "
            f"{f.shift_x:+.3f} m east, {f.shift_y:+.3f} m north)",
            html_table(rows, list(_FRAME_HEAD), list(_FRAME_HEAD.values())))
