"""The pile report's tables: piles, spacings, level differences and frame fits, as CSV
columns, HTML rows and the plain text ``mbinspect piles`` prints."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from .html import html_table

__all__ = ["spacing_table", "pile_verdicts", "pile_row", "spacing_row", "frame_section", "level_section"]


PILE_COLS = ["id", "group", "x", "y", "z", "radius", "tilt_deg", "tilt_azimuth_deg", "tilt_held", "method",
             "n_top", "n_side", "side_coverage_deg", "rms", "sigma_xy", "top_z", "top_z_sigma",
             "top_z_lower_bound", "top_design", "top_deviation", "top_verdict", "flags"]


SPACING_COLS = ["group", "a", "b", "distance", "sigma", "low_95", "high_95", "design", "deviation",
                 "verdict", "pass", "method"]


LEVEL_COLS = ["group", "a", "b", "difference", "sigma", "design", "deviation", "verdict", "lower_bound"]


#: Table columns and their headers with units (values rounded to what they mean).
SPACING_HEAD = {"pair": "pair", "distance": "measured (m)", "design": "design (m)",
                 "deviation": "deviation (mm)", "sigma": "1σ (mm)", "interval": "95 % interval (mm)",
                 "verdict": "at 95 %"}
PILE_HEAD = {"id": "pile", "group": "jacket", "x": "easting (m)", "y": "northing (m)", "z": "top (m)",
              "radius": "radius (m)", "tilt": "tilt (°)", "toward": "toward (°)", "method": "method",
              "n_top": "top points", "n_side": "side points", "arc": "side arc (°)", "rms": "rms (mm)",
              "sigma": "1σ plan (mm)", "level": "top level (m)", "level_sigma": "1σ level (mm)",
              "level_dev": "level − design (mm)", "flags": "flags"}
FRAME_HEAD = {"id": "pile", "dx": "east miss (mm)", "dy": "north miss (mm)", "miss": "miss (mm)",
               "sigma": "1σ (mm)", "miss_95": "miss at 95 % (mm)", "verdict": "at 95 %",
              "shim": "shim under a level frame (mm, 1σ)"}
LEVEL_HEAD = {"pair": "pair", "difference": "b − a (mm)", "sigma": "1σ (mm)", "design": "design (mm)",
              "deviation": "deviation (mm)", "verdict": "at 95 %"}


def level_section(result: Any, group: int) -> tuple[str, str]:
    """A jacket's top level differences: its heading and table."""
    rows = [{"pair": f"{lv.a}–{lv.b}", "difference": f"{1000 * lv.difference:+.0f}"
             + (" (a top not sounded)" if lv.lower_bound else ""),
             "sigma": _mm(lv.sigma, "{:.1f}"), "design": _mm(lv.design, "{:+.0f}"),
             "deviation": _mm(lv.deviation, "{:+.0f}"), "verdict": lv.verdict or ""}
            for lv in result.levels if lv.group == group]
    tol = result.parameters.get("level_tolerance")
    return (f"Jacket {group}: top levels (line offsets fitted out"
            + (f"; tolerance {1000 * tol:.0f} mm" if tol else "") + ")",
            html_table(rows, list(LEVEL_HEAD), list(LEVEL_HEAD.values())))


def spacing_row(s: Any) -> dict[str, Any]:
    dev = None if s.deviation is None else 1000 * s.deviation
    return {"pair": f"{s.a}–{s.b}", "distance": f"{s.distance:.3f}",
            "design": "" if s.design is None else f"{s.design:.3f}",
            "deviation": "" if dev is None else f"{dev:+.1f}", "sigma": f"{1000 * s.sigma:.1f}",
            "interval": f"±{1960 * s.sigma:.1f}" if dev is None
            else f"{dev - 1960 * s.sigma:+.1f} … {dev + 1960 * s.sigma:+.1f}",
            "verdict": s.verdict or ""}


def pile_row(p: Any) -> dict[str, Any]:
    return {"id": p.id, "group": p.group, "x": f"{p.x:.3f}", "y": f"{p.y:.3f}", "z": f"{p.z:.3f}",
            "radius": f"{p.radius:.3f}",
            "tilt": "" if p.tilt_deg is None else "plumb (held)" if p.tilt_held else f"{p.tilt_deg:.1f}",
            "toward": "" if p.tilt_azimuth_deg is None or p.tilt_held else f"{p.tilt_azimuth_deg:.0f}",
            "method": p.method,
            "n_top": p.n_top, "n_side": p.n_side, "arc": f"{p.side_coverage_deg:.0f}",
            "rms": f"{1000 * p.rms:.1f}", "sigma": f"{1000 * p.sigma_xy:.1f}",
            "level": "" if p.top_z is None else f"{'≥ ' if p.top_z_lower_bound else ''}{p.top_z:.3f}",
            "level_sigma": _mm(p.top_z_sigma, "{:.1f}"), "level_dev": _mm(p.top_deviation, "{:+.0f}")
            + (f" ({p.top_verdict})" if p.top_verdict else ""), "flags": "; ".join(p.flags)}


def _mm(value: float | None, form: str) -> str:
    """A length in mm, or blank when unknown."""
    return "" if value is None or not math.isfinite(value) else form.format(1000 * value)


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
        tops = [p.top_verdict for p in result.piles if p.group == g and p.top_verdict]
        if tops:
            lines.append((f"Jacket {g}: {tops.count('pass')} of {len(tops)} tops at their design level "
                          "at 95 %"
                          + (f", {tops.count('fail')} fail" if "fail" in tops else "")
                          + (f", {tops.count('undecided')} undecided" if "undecided" in tops else ""),
                          "fail" if "fail" in tops else "undecided" if "undecided" in tops else "pass"))
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
    for g in sorted({p.group for p in result.piles if p.top_z is not None}):
        tops = [f"{p.id}: {p.top_z:.3f}{'+' if p.top_z_lower_bound else ''}"
                + (f" ± {1000 * p.top_z_sigma:.0f} mm" if math.isfinite(p.top_z_sigma) else "")
                for p in result.piles if p.group == g and p.top_z is not None]
        lines.append(f"jacket {g}: top levels (m, 1-sigma; + a lower bound) " + ", ".join(tops))
    return "\n".join(lines)


def frame_section(f: Any) -> tuple[str, str]:
    """A jacket's design frame fit: its heading and table."""
    rows = [{"id": q["id"], "dx": f"{1000 * q['dx']:+.0f}", "dy": f"{1000 * q['dy']:+.0f}",
             "miss": f"{1000 * q['miss']:.0f}", "sigma": f"{1000 * q['sigma']:.1f}",
             "miss_95": f"{1000 * q['miss_95']:.0f}", "verdict": q["verdict"],
             "shim": _mm(q.get("shim"), "{:.0f}") + (f" ± {_mm(q.get('shim_sigma'), '{:.0f}')}"
                                                    if _mm(q.get("shim_sigma"), "{:.0f}") else "")}
            for q in f.residuals]
    return (f"Jacket {f.group}: design frame fit ({f.verdict} at 95 %, tolerance "
            f"{1000 * f.tolerance:.0f} mm; rotation {f.rotation_deg:+.3f}°, shift "
            f"{f.shift_x:+.3f} m east, {f.shift_y:+.3f} m north)",
            html_table(rows, list(FRAME_HEAD), list(FRAME_HEAD.values())))
