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

from .outputs import atomic_path

__all__ = ["html_table", "html_page", "save_figure", "plan_image", "pile_figures"]


def _mpl() -> Any:
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig: Any, path: str | Path) -> bytes:
    """Save a matplotlib figure as PNG atomically; return the PNG bytes for embedding.

    Parameters
    ----------
    fig : matplotlib Figure
    path : path-like

    Returns
    -------
    bytes
    """
    buf = _io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    _mpl().close(fig)
    data = buf.getvalue()
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return data


def plan_image(points: np.ndarray, *, cell: float = 0.25, bounds: Sequence[float] | None = None,
               fill: float = 1.0) -> tuple[np.ndarray, list[float]]:
    """Median elevation per plan cell and its extent for ``imshow``.

    Empty cells within ``fill`` m of a cell with data take its value (gaps between pings);
    farther ones stay NaN.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
    cell : float
        Image cell (m).
    bounds : (xmin, ymin, xmax, ymax), optional
    fill : float
        Gap-filling distance (m).

    Returns
    -------
    image : ndarray, shape (ny, nx)
    extent : list of float
        ``[xmin, xmax, ymin, ymax]`` for ``imshow``.
    """
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
    from scipy import ndimage

    from .grid import cell_percentile

    img = cell_percentile(j * nx + i, p[:, 2], 50.0, nx * ny).reshape(ny, nx)
    empty = ~np.isfinite(img)
    if fill > 0 and empty.any() and not empty.all():
        # gaps between pings: take the nearest cell with data, up to ``fill`` m away
        dist, idx = ndimage.distance_transform_edt(empty, return_indices=True)
        img = np.where(empty & (dist * cell <= fill), img[tuple(idx)], img)
    return img, [xmin, xmin + nx * cell, ymin, ymin + ny * cell]


def html_table(rows: Sequence[Mapping[str, Any]], columns: Sequence[str],
               headers: Sequence[str] | None = None, digits: int = 3) -> str:
    """An HTML table of ``rows`` (dicts) with the given columns.

    Parameters
    ----------
    rows : sequence of mapping
    columns : sequence of str
    headers : sequence of str, optional
    digits : int
        Decimals of floats.

    Returns
    -------
    str
    """
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
    """A complete HTML document; ``{img:NAME}`` in a section becomes an embedded PNG.

    Parameters
    ----------
    title : str
    sections : sequence of (heading, html)
    images : mapping of name -> PNG bytes

    Returns
    -------
    str
    """
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


_PILE_COLS = ["id", "group", "x", "y", "z", "radius", "tilt_deg", "tilt_azimuth_deg", "method", "n_top",
              "n_side", "side_coverage_deg", "rms", "sigma_xy", "flags"]
_SPACING_COLS = ["group", "a", "b", "distance", "sigma", "design", "deviation", "verdict", "pass", "method"]
_FRAME_COLS = ["id", "dx", "dy", "miss", "sigma", "miss_95", "verdict"]


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


def write_pile_outputs(result: Any, points: np.ndarray, out: Path, *, figures: bool = True,
                       title: str = "Pile positions and spacings",
                       truth: Mapping[str, Any] | None = None) -> list[str]:
    """Write ``piles.json``, ``piles.csv``, ``spacings.csv``, figures and ``report.html``.

    Returns the names of the files written. ``truth`` (a simulator truth dict) adds the
    errors against truth to the report.

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
    """
    from .outputs import write_json, write_table

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    d = result.to_dict()
    write_json(d, out / "piles.json")
    # with both methods, both methods' piles: one row per pile and method
    write_table(d["piles"] + d["other_piles"], out / "piles.csv", _PILE_COLS)
    write_table(d["spacings"], out / "spacings.csv", _SPACING_COLS)
    features = [{"type": "Feature", "geometry": {"type": "Point", "coordinates": [p["x"], p["y"]]},
                 "properties": {c: p.get(c) for c in _PILE_COLS if c != "flags"}
                 | {"flags": "; ".join(p.get("flags", []))}} for p in d["piles"] + d["other_piles"]]
    written = ["piles.json", "piles.csv", "spacings.csv", *write_gis(features, crs_of(result), out, "piles")]
    images: dict[str, bytes] = {}
    if figures:
        images = pile_figures(result, points, out)
        written += sorted(f"{n if n in ('plan', 'convergence') else 'pile_' + n[4:]}.png"
                          for n in images)
    sections = []
    if result.warnings:
        sections.append(("Warnings", "<ul>" + "".join(f"<li class='warn'>{html.escape(w)}</li>"
                                                      for w in result.warnings) + "</ul>"))
    sections.append(("Coordinates", f"<p>{html.escape(crs_label(result))}</p>"))
    sections.append(("Spacings (m)", html_table(d["spacings"], _SPACING_COLS, digits=4)))
    for f in d["frames"]:
        sections.append((f"Jacket {f['group']}: design frame fit ({f['verdict']} at 95 %, tolerance "
                         f"{f['tolerance']} m; rotation {f['rotation_deg']:.3f} deg, shift "
                         f"{f['shift_x']:.3f}, {f['shift_y']:.3f} m)",
                         html_table(f["residuals"], _FRAME_COLS, digits=4)))
    sections.append(("Piles (top centre, m)", html_table(d["piles"], _PILE_COLS, digits=4)))
    if d["other_piles"]:
        sections.append(("Piles by the centre method (top centre, m)",
                         html_table(d["other_piles"], _PILE_COLS, digits=4)))
    if truth is not None:
        tp = {(s["a"], s["b"]): s["distance"] for s in truth.get("spacings", [])}
        sections.append(("Errors against simulator truth",
                         f"<pre>{html.escape(spacing_table(result, tp))}</pre>"))
    if images:
        sections.append(("Plan view", "{img:plan}"))
        sections.append(("Convergence (the paper's Fig. 4)", "{img:convergence}"))
        sections.append(("Each pile", "".join("{img:" + n + "}" for n in images if n.startswith("pile"))))
    sections.append(("Parameters", f"<pre>{html.escape(json_dumps(d['parameters']))}</pre>"))
    page = html_page(title, sections, images)
    with atomic_path(out / "report.html") as tmp:
        tmp.write_text(page, encoding="utf-8")
    written.append("report.html")
    return written


def crs_of(result: Any) -> str | None:
    """The CRS (WKT) of a result's coordinates, as its input gave it, or None."""
    crs: str | None = result.parameters.get("input", {}).get("crs")
    return crs


def crs_label(result: Any) -> str:
    """A line naming a result's CRS, or saying there is none."""
    crs = crs_of(result)
    if crs is None:
        return "the input's own coordinates (no CRS given: give --crs to place them on a map)"
    from pyproj import CRS

    c = CRS.from_user_input(crs)
    return f"{c.name}" + (f" (EPSG:{c.to_epsg()})" if c.to_epsg() else "")


def lonlat_transform(crs: str | None) -> Any:
    """``f(x, y) -> (lon, lat)`` from ``crs`` to WGS 84, or None without a CRS.

    Parameters
    ----------
    crs : str or None
        WKT or any CRS pyproj accepts.

    Returns
    -------
    callable or None
    """
    if crs is None:
        return None
    from pyproj import Transformer

    return Transformer.from_crs(crs, "EPSG:4326", always_xy=True).transform


def write_geojson(features: list[dict[str, Any]], path: Path, *, lonlat: bool,
                  crs_name: str | None = None) -> None:
    """A GeoJSON FeatureCollection, atomically.

    With ``lonlat`` the coordinates are WGS 84 longitude and latitude, as RFC 7946 says; a
    GIS places them without being told. Without it (no CRS known) they are the input's own
    coordinates, and the file says so in a ``crs_note`` member.

    Parameters
    ----------
    features : list of dict
    path : Path
    lonlat : bool
    crs_name : str, optional
        A named CRS (``urn:ogc:def:crs:EPSG::32631``) for coordinates that are not WGS 84:
        written as the GeoJSON 2008 ``crs`` member, which GDAL and QGIS honour.
    """
    import json

    from .outputs import to_jsonable

    doc: dict[str, Any] = {"type": "FeatureCollection", "features": features}
    if crs_name is not None:
        doc["crs"] = {"type": "name", "properties": {"name": crs_name}}
    elif not lonlat:
        doc["crs_note"] = "coordinates in the input's own (unknown) CRS, not WGS 84"
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(to_jsonable(doc)) + "\n", encoding="utf-8")


def write_gis(features: list[dict[str, Any]], crs: str | None, out: Path, stem: str) -> list[str]:
    """The features as GeoJSON a GIS places right: ``STEM.geojson`` in WGS 84 longitude and
    latitude (RFC 7946) and, when the CRS has an EPSG code, ``STEM_projected.geojson`` in the
    survey's own CRS, named in a ``crs`` member (which GDAL and QGIS read).

    Parameters
    ----------
    features : list of dict
        Point or Polygon features in the survey's projected coordinates (m).
    crs : str or None
        Their CRS (WKT); None: one file in those coordinates, saying so.
    out : Path
    stem : str

    Returns
    -------
    list of str
        The files written.
    """
    to_lonlat = lonlat_transform(crs)
    if to_lonlat is None:
        write_geojson(features, out / f"{stem}.geojson", lonlat=False)
        return [f"{stem}.geojson"]

    def moved(geom: dict[str, Any] | None) -> dict[str, Any] | None:
        if geom is None:
            return None
        if geom["type"] == "Point":
            lon, lat = to_lonlat(np.array([geom["coordinates"][0]]), np.array([geom["coordinates"][1]]))
            return {"type": "Point", "coordinates": [float(lon[0]), float(lat[0])]}
        rings = []
        for ring in geom["coordinates"]:
            lon, lat = to_lonlat(*np.asarray(ring, np.float64).reshape(-1, 2).T)
            rings.append([[float(a), float(b)] for a, b in zip(lon, lat, strict=True)])
        return {"type": geom["type"], "coordinates": rings}

    write_geojson([{**f, "geometry": moved(f["geometry"])} for f in features], out / f"{stem}.geojson",
                  lonlat=True)
    from pyproj import CRS

    epsg = CRS.from_user_input(crs).to_epsg()
    if epsg is None:
        return [f"{stem}.geojson"]
    write_geojson(features, out / f"{stem}_projected.geojson", lonlat=True,
                  crs_name=f"urn:ogc:def:crs:EPSG::{epsg}")
    return [f"{stem}.geojson", f"{stem}_projected.geojson"]


def json_dumps(obj: Any) -> str:
    import json

    from .outputs import to_jsonable

    return json.dumps(to_jsonable(obj), indent=1)


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

    plt = _mpl()
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

    from .outputs import write_json, write_table

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
