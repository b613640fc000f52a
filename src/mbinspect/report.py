"""Figures and a self-contained HTML report (images embedded, readable offline).

Examples
--------
>>> from mbinspect.report import html_table
>>> print(html_table([{"a": 1, "b": 2.5}], ["a", "b"]).splitlines()[0])
<table>
"""

from __future__ import annotations

import base64
import html
import io as _io
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .io import atomic_path

__all__ = ["html_table", "html_page", "save_figure", "plan_image", "pile_figures"]


def _mpl() -> Any:
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig: Any, path: str | Path) -> bytes:
    """Save a matplotlib figure as PNG atomically; return the PNG bytes for embedding."""
    buf = _io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    _mpl().close(fig)
    data = buf.getvalue()
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return data


def plan_image(points: np.ndarray, *, cell: float = 0.25, bounds: Sequence[float] | None = None
               ) -> tuple[np.ndarray, list[float]]:
    """Median elevation per plan cell (NaN where empty) and its extent for ``imshow``."""
    p = np.asarray(points, np.float64)
    if bounds is None:
        xmin, ymin = p[:, :2].min(axis=0)
        xmax, ymax = p[:, :2].max(axis=0)
    else:
        xmin, ymin, xmax, ymax = bounds
        inside = (p[:, 0] >= xmin) & (p[:, 0] <= xmax) & (p[:, 1] >= ymin) & (p[:, 1] <= ymax)
        p = p[inside]
    nx = max(1, int(math.ceil((xmax - xmin) / cell)))
    ny = max(1, int(math.ceil((ymax - ymin) / cell)))
    i = np.clip(((p[:, 0] - xmin) / cell).astype(np.int64), 0, nx - 1)
    j = np.clip(((p[:, 1] - ymin) / cell).astype(np.int64), 0, ny - 1)
    from .seabed import _cell_percentile

    img = _cell_percentile(j * nx + i, p[:, 2], 50.0, nx * ny)
    return img.reshape(ny, nx), [xmin, xmin + nx * cell, ymin, ymin + ny * cell]


def html_table(rows: Sequence[Mapping[str, Any]], columns: Sequence[str],
               headers: Sequence[str] | None = None, digits: int = 3) -> str:
    """An HTML table of ``rows`` (dicts) with the given columns."""
    def fmt(v: Any) -> str:
        if v is None:
            return ""
        if isinstance(v, bool):
            return "pass" if v else "<b class='fail'>FAIL</b>"
        if isinstance(v, float):
            return "" if not math.isfinite(v) else f"{v:.{digits}f}"
        if isinstance(v, (list, tuple)):
            return html.escape("; ".join(map(str, v)))
        return html.escape(str(v))

    head = "".join(f"<th>{html.escape(h)}</th>" for h in (headers or columns))
    body = "\n".join("<tr>" + "".join(f"<td>{fmt(r.get(c))}</td>" for c in columns) + "</tr>"
                     for r in rows)
    return f"<table>\n<tr>{head}</tr>\n{body}\n</table>"


_CSS = """
body{font-family:system-ui,Segoe UI,Helvetica,Arial,sans-serif;margin:2em;max-width:1100px;color:#222}
h1{font-size:1.5em}h2{font-size:1.2em;margin-top:1.6em;border-bottom:1px solid #ccc}
table{border-collapse:collapse;margin:.6em 0;font-size:.9em}
td,th{border:1px solid #bbb;padding:.25em .6em;text-align:right}th{background:#eef}
td:last-child{text-align:left}.fail{color:#b00}.warn{color:#a60}
img{max-width:100%;border:1px solid #ddd;margin:.4em 0}
pre{background:#f6f6f6;padding:.6em;font-size:.8em;overflow-x:auto}
"""


def html_page(title: str, sections: Sequence[tuple[str, str]],
              images: Mapping[str, bytes] | None = None) -> str:
    """A complete HTML document; ``{img:NAME}`` in a section becomes an embedded PNG."""
    parts = [f"<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
             f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>",
             f"<h1>{html.escape(title)}</h1>"]
    for heading, body in sections:
        for name, data in (images or {}).items():
            token = "{img:" + name + "}"
            if token in body:
                uri = base64.b64encode(data).decode("ascii")
                body = body.replace(token, f"<img alt='{html.escape(name)}' "
                                           f"src='data:image/png;base64,{uri}'>")
        parts.append(f"<h2>{html.escape(heading)}</h2>\n{body}")
    parts.append("</body></html>")
    return "\n".join(parts)


def pile_figures(result: Any, points: np.ndarray, out: Path) -> dict[str, bytes]:
    """The pile figures: plan view, one per pile, convergence. Returns name -> PNG bytes."""
    plt = _mpl()
    images: dict[str, bytes] = {}
    piles = list(result.piles)
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
    for s in result.spacings:
        a, b = by_id[s.a], by_id[s.b]
        ax.plot([a.x - ref[0], b.x - ref[0]], [a.y - ref[1], b.y - ref[1]], "w-", lw=0.8, alpha=0.8)
        label = f"{s.distance:.3f}"
        if s.deviation is not None:
            label += f"\n{100 * s.deviation:+.1f} cm"
        ax.text((a.x + b.x) / 2 - ref[0], (a.y + b.y) / 2 - ref[1], label, ha="center",
                va="center", fontsize=8, color="k" if s.passed is not False else "darkred",
                bbox={"fc": "white", "ec": "none", "alpha": 0.8, "pad": 1.5})
    for p in piles:
        circ = plt.Circle((p.x - ref[0], p.y - ref[1]), p.radius, fill=False, color="red", lw=1.5)
        ax.add_patch(circ)
        ax.annotate(f"{p.id}", (p.x - ref[0], p.y - ref[1]), xytext=(8, 8),
                    textcoords="offset points", color="red", fontsize=11, weight="bold")
    ax.set_xlabel(f"easting - {ref[0]:.2f} (m)")
    ax.set_ylabel(f"northing - {ref[1]:.2f} (m)")
    ax.set_title("Plan view: median sounding per 0.2 m cell, fitted tops, spacings (m)")
    ax.set_aspect("equal")
    images["plan"] = save_figure(fig, out / "plan.png")
    for p in piles:
        seg = result.segments.get(p.id)
        if seg is None:
            continue
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
        cyl = result.cylinders.get(p.id)
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
        tilt = ("" if p.tilt_deg is None
                else f", tilt {p.tilt_deg:.2f} deg toward {p.tilt_azimuth_deg:.0f} deg")
        fig.suptitle(f"Pile {p.id}: {p.n_top} top and {p.n_side} side points{tilt}")
        images[f"pile{p.id}"] = save_figure(fig, out / f"pile_{p.id}.png")
    if result.iterations:
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
        images["convergence"] = save_figure(fig, out / "convergence.png")
    return images


_PILE_COLS = ["id", "x", "y", "z", "radius", "tilt_deg", "tilt_azimuth_deg", "method", "n_top",
              "n_side", "side_coverage_deg", "rms", "sigma_xy", "flags"]
_SPACING_COLS = ["a", "b", "distance", "sigma", "design", "deviation", "pass", "method"]


def spacing_table(result: Any, truth: Mapping[tuple[int, int], float] | None = None) -> str:
    """The spacing table as plain text (what ``mbinspect piles`` prints)."""
    head = f"{'pair':>6} {'distance m':>11} {'1-sigma mm':>10} {'design m':>9} {'dev cm':>7} {'':>5}"
    if truth:
        head += f" {'error vs truth mm':>17}"
    lines = [head]
    for s in result.spacings:
        row = (f"{s.a:>3}-{s.b:<2} {s.distance:>11.4f} {1000 * s.sigma:>10.1f} "
               f"{'' if s.design is None else f'{s.design:.3f}':>9} "
               f"{'' if s.deviation is None else f'{100 * s.deviation:+.1f}':>7} "
               f"{'' if s.passed is None else ('pass' if s.passed else 'FAIL'):>5}")
        if truth:
            t = truth.get((s.a, s.b))
            row += f" {'' if t is None else f'{1000 * (s.distance - t):+.1f}':>17}"
        lines.append(row)
    return "\n".join(lines)


def write_pile_outputs(result: Any, points: np.ndarray, out: Path, *, figures: bool = True,
                       title: str = "Pile positions and spacings",
                       truth: Mapping[str, Any] | None = None) -> list[str]:
    """Write ``piles.json``, ``piles.csv``, ``spacings.csv``, figures and ``report.html``.

    Returns the names of the files written. ``truth`` (a simulator truth dict) adds the
    errors against truth to the report.
    """
    from .io import write_json, write_table

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    d = result.to_dict()
    write_json(d, out / "piles.json")
    write_table(d["piles"], out / "piles.csv", _PILE_COLS)
    write_table(d["spacings"], out / "spacings.csv", _SPACING_COLS)
    written = ["piles.json", "piles.csv", "spacings.csv"]
    images: dict[str, bytes] = {}
    if figures:
        images = pile_figures(result, points, out)
        written += sorted(f"{n if n in ('plan', 'convergence') else 'pile_' + n[4:]}.png"
                          for n in images)
    sections = []
    if result.warnings:
        sections.append(("Warnings", "<ul>" + "".join(f"<li class='warn'>{html.escape(w)}</li>"
                                                      for w in result.warnings) + "</ul>"))
    sections.append(("Spacings (m)", html_table(d["spacings"], _SPACING_COLS, digits=4)))
    sections.append(("Piles (top centre, m)", html_table(d["piles"], _PILE_COLS, digits=4)))
    if truth is not None:
        tp = {(s["a"], s["b"]): s["distance"] for s in truth.get("spacings", [])}
        sections.append(("Errors against simulator truth",
                         f"<pre>{html.escape(spacing_table(result, tp))}</pre>"))
    if images:
        sections.append(("Plan view", "{img:plan}"))
        sections.append(("Convergence (the paper's Fig. 4)", "{img:convergence}"))
        sections.append(("Each pile", "".join("{img:" + n + "}" for n in images if n.startswith("pile"))))
    params = {k: v for k, v in d["parameters"].items() if k != "segmentation_info"}
    sections.append(("Parameters", f"<pre>{html.escape(json_dumps(params))}</pre>"))
    page = html_page(title, sections, images)
    with atomic_path(out / "report.html") as tmp:
        tmp.write_text(page, encoding="utf-8")
    written.append("report.html")
    return written


def json_dumps(obj: Any) -> str:
    import json

    from .io import to_jsonable

    return json.dumps(to_jsonable(obj), indent=1)
