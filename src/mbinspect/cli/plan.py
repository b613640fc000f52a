"""``mbinspect plan``: the survey lines that will measure every spacing of a pile design to a
target, predicted in the simulator before sailing."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .common import Reporter, add_output, subcommand


def add_parser(sub: Any) -> None:
    """``mbinspect plan DESIGN``."""
    from ..plan import PlanOptions
    from .flags import add_flags

    p = subcommand(sub, "plan", "plan the survey lines round a pile design before sailing",
             "Generate candidate line layouts round the design (pairs of lines along and across it at "
             "several offsets, the pile paper's '#', lines over the rows of tops, each sailed one way or "
             "both), survey each a few times in the simulator with the sonar's beam and error model at the "
             "ping spacing the speed and ping rate give, measure the piles as 'mbinspect piles' would, and "
             "choose the layout that meets the target 1-sigma for every spacing in the least time on site. "
             "Writes lines.csv (line,x_start,y_start,x_end,y_end,heading), lines.geojson (WGS 84 with "
             "--crs), plan.json, plan.png and report.html.",
             "examples:\n  mbinspect plan design.csv --radius 0.75 --depth 21 --height 5 --out plan-out\n"
             "  mbinspect plan design.csv --radius 0.75 --depth 21 --target-sigma 0.015 --speed 3 "
             "--crs EPSG:32650")
    p.add_argument("design", help="pile design CSV: id,x,y[,group][,top] (m, the design's projected CRS)")
    p.add_argument("--crs", help="the design's projected CRS (EPSG:32650, say): lines.geojson is then in "
                                 "WGS 84")
    g = p.add_argument_group("plan (every option of mbinspect.plan.PlanOptions)")
    add_flags(g, PlanOptions)
    add_output(p, "plan-out")
    p.set_defaults(func=cmd_plan)


def cmd_plan(args: argparse.Namespace, rep: Reporter, argv: Sequence[str]) -> int:
    """Plan the lines and write them."""
    import dataclasses

    from ..outputs import check_output_dir, output_dir
    from ..piles import read_design
    from ..plan import PlanOptions, plan_survey
    from ..plan.outputs import write_plan_outputs
    from .flags import given_options

    options = PlanOptions.from_given(given_options(args, PlanOptions))
    crs = _crs(args.crs)
    out = Path(args.out or "plan-out")
    check_output_dir(out, overwrite=args.overwrite, inputs=[args.design])
    design = read_design(args.design)
    result = plan_survey(design, options, progress=rep.progress("simulating candidate surveys"))
    params = {**result.parameters, "command_line": ["mbinspect", *argv], "crs": crs}
    result = dataclasses.replace(result, parameters=params)
    with output_dir(out, overwrite=args.overwrite, inputs=[args.design]) as tmp:
        write_plan_outputs(result, tmp, crs=crs, figures=not args.no_figures)
    if rep.verbosity >= 0:
        _print(result)
    rep.info(f"results in {out}/ (lines.csv, lines.geojson, plan.json, report.html)")
    return 0


def _crs(text: str | None) -> str | None:
    """The CRS given, checked to be a projected one in metres."""
    if text is None:
        return None
    from ..crs import projected_metres

    projected_metres(text)
    return text


def _print(result: Any) -> None:
    best = result.best
    print(f"chosen: {best.layout.name} ({best.layout.description}): {len(best.layout.lines)} lines, "
          f"{best.time_on_site_s / 60:.0f} min on site, every spacing within "
          f"{1000 * best.worst_sigma:.1f} mm (1-sigma, predicted from {best.surveys} simulated surveys; "
          f"target {1000 * result.target_sigma:g} mm)")
    for k, ln in enumerate(best.layout.lines):
        print(f"  line {k + 1}: {ln.start[0]:.2f}, {ln.start[1]:.2f} -> {ln.end[0]:.2f}, {ln.end[1]:.2f} "
              f"heading {ln.heading:.1f} deg")
    unseen = [f"pile {i}: {', '.join(s)}" for i, s in best.unseen if s]
    if unseen:
        print("  sides no beam reaches: " + "; ".join(unseen))
    others = [p for p in result.predictions if p.layout.name != result.chosen]
    if others:
        print("runner-up layouts (fastest first):")
        for p in others[:6]:
            worst = (f"{1000 * p.worst_sigma:.1f} mm" if math.isfinite(p.worst_sigma)
                     else "a spacing not measured")
            print(f"  {p.layout.name}: {p.time_on_site_s / 60:.0f} min, worst {worst}"
                  f"{' (meets)' if p.meets_target else ''}, {p.surveys} surveys")
    for w in result.warnings:
        print(f"mbinspect: warning: {w}", file=sys.stderr)
