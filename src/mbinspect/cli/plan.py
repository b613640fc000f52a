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

#: The command's name and its line in ``mbinspect --help``.
COMMAND = ("plan", "plan the survey lines round a pile design before sailing")


def add_parser(sub: Any) -> None:
    """``mbinspect plan DESIGN``."""
    from ..plan import PlanOptions
    from .flags import add_flags

    p = subcommand(sub, *COMMAND,
             "Generate candidate line layouts round the design (pairs of lines along and across it at "
             "several offsets, the pile paper's '#', lines over the rows of tops, each sailed one way or "
             "both), survey each a few times in the simulator with the sonar's beam and error model at the "
             "ping spacing the speed and ping rate give, measure the piles as 'mbinspect piles' would, and "
             "choose the layout that meets the target 1-sigma for every spacing in the least time on site. "
             "Writes lines.csv (line,x_start,y_start,x_end,y_end,heading,speed_kn), lines.geojson "
             "(WGS 84 with --crs), plan.json, plan.png and report.html.",
             "examples:\n  mbinspect plan design.csv --radius 0.75 --depth 21 --height 5 --out plan-out\n"
             "  mbinspect plan design.csv --radius 0.75 --depth 21 --target-sigma 0.015 --speed 3 "
             "--crs EPSG:32650\n"
             "  mbinspect plan plan-out --check survey/*.xtf --out check-out   (the survey run, against "
             "its plan)")
    p.add_argument("design", help="pile design CSV: id,x,y[,group][,top] (m, the design's projected CRS); "
                                  "with --check, the plan (plan.json or its folder)")
    p.add_argument("--check", nargs="+", metavar="SURVEY",
                   help="compare the survey run (its files) with the plan: the lines sailed, the sides of "
                        "each pile reached, each spacing's 1-sigma against the one predicted; writes "
                        "check.json")
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
    from ..plan import PlanOptions, PlanResult, plan_input, plan_survey
    from ..plan.outputs import write_plan_outputs
    from ..plan.reef_outputs import write_reef_plan_outputs
    from ..reefs.plan import read_plan
    from .flags import given_options

    if args.check:
        return _check(args, rep, argv)
    options = PlanOptions.from_given(given_options(args, PlanOptions))
    crs = _crs(args.crs)
    out = Path(args.out or "plan-out")
    check_output_dir(out, overwrite=args.overwrite, inputs=[args.design])
    reefs = plan_input(args.design, options) == "reefs"
    design = read_plan(args.design) if reefs else read_design(args.design)
    result = plan_survey(design, options, progress=rep.progress("simulating candidate surveys"))
    params = {**result.parameters, "command_line": ["mbinspect", *argv], "crs": crs}
    result = dataclasses.replace(result, parameters=params)
    with output_dir(out, overwrite=args.overwrite, inputs=[args.design]) as tmp:
        if isinstance(result, PlanResult):
            write_plan_outputs(result, tmp, crs=crs, figures=not args.no_figures)
        else:
            write_reef_plan_outputs(result, tmp, crs=crs, figures=not args.no_figures)
    if rep.verbosity >= 0 and isinstance(result, PlanResult):
        _print(result)
    elif rep.verbosity >= 0:
        _print_reefs(result)
    rep.info(f"results in {out}/ (lines.csv, lines.geojson, plan.json, report.html)")
    return 0


def _print_reefs(result: Any) -> None:
    """A reef plan's chosen layout, its lines and the others, on the terminal."""
    best = result.best
    for w in result.warnings:
        print(f"warning: {w}")
    if best is None:
        return
    cubes = "" if best.cubes_detected is None else \
        f", {100 * best.cubes_detected:.0f} % of the S-44 {result.s44_order} cubes detected"
    print(f"chosen: {best.layout.name} ({best.layout.description}), {best.time_on_site_s / 60:.0f} min on "
          f"site: {100 * best.found:.0f} % of the units found, the fewest soundings on one "
          f"{best.min_soundings} (target {result.min_soundings}){cubes}; a reef's height to "
          f"{1000 * best.height_sigma:.0f} mm and centre to {1000 * best.centre_sigma:.0f} mm (1-sigma)")
    for k, ln in enumerate(best.layout.lines):
        print(f"  line {k + 1}: ({ln.start[0]:.1f}, {ln.start[1]:.1f}) -> ({ln.end[0]:.1f}, "
              f"{ln.end[1]:.1f}), heading {ln.heading:.0f}")
    for p in result.predictions:
        if p.layout.name != result.chosen:
            print(f"  {p.layout.name}: {p.time_on_site_s / 60:.0f} min, units found {100 * p.found:.0f} %, "
                  f"fewest soundings {p.min_soundings}" + ("" if p.meets_target else " (misses)"))


def _check(args: argparse.Namespace, rep: Reporter, argv: Sequence[str]) -> int:
    """A survey run against its plan: check.json and a summary."""
    import json

    from ..errors import InputError
    from ..outputs import output_dir, write_json
    from ..plan import PlanResult
    from ..plan.check import check_survey
    from ..survey.inputs import read_survey

    path = Path(args.design)
    path = path / "plan.json" if path.is_dir() else path
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
        if isinstance(doc, dict) and doc.get("kind") == "reef-plan":
            raise InputError(f"{path}: a plan over a reef plan; --check compares a survey with a pile plan "
                             "only (the check of a reef survey against its plan is not built)")
        plan = PlanResult.from_dict(doc)
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise InputError(f"{path}: not a plan written by 'mbinspect plan' ({e}); expected plan.json"
                         ) from None
    crs = args.crs or plan.parameters.get("crs")
    cloud = read_survey([Path(f) for f in args.check], progress=rep.progress("reading the survey"),
                        **({"crs": crs} if crs else {}))
    out = Path(args.out or "check-out")
    with output_dir(out, overwrite=args.overwrite, inputs=[str(path), *args.check]) as tmp:
        result = check_survey(plan, cloud)
        doc = result.to_dict()
        doc["parameters"].update(command_line=["mbinspect", *argv], plan=str(path), survey=list(args.check))
        write_json(doc, tmp / "check.json")
    if rep.verbosity >= 0:
        for ln in result.lines:
            print(f"line {ln['line']} (heading {ln['heading']:.0f}): " + (
                "not sailed" if ln["sailed"] is None else
                f"sailed {ln['offset']:.1f} m off, heading {ln['heading_diff']:.0f} deg off, "
                f"{100 * ln['covered']:.0f} % of it"))
        for s in result.spacings:
            pred = s["predicted_sigma"]
            print(f"spacing {s['a']}-{s['b']}: {s['distance']:.3f} m ± {s['sigma']:.4f} (predicted ± "
                  + (f"{pred:.4f})" if pred is not None else "none)"))
        for p in result.piles:
            if p.get("found") and p["unseen"] != p["unseen_planned"]:
                print(f"pile {p['id']}: sides unseen {', '.join(p['unseen']) or 'none'} (planned: "
                      f"{', '.join(p['unseen_planned']) or 'none'})")
        for n in result.notes:
            print(n)
    rep.info(f"results in {out}/ (check.json)")
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
                  f"{' (meets)' if p.meets_target else ''}, {p.surveys} survey{'s' * (p.surveys != 1)}")
    for w in result.warnings:
        print(f"mbinspect: warning: {w}", file=sys.stderr)
