"""``mbinspect reefs``: extract, separate, measure and score artificial reefs."""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .common import Reporter, add_output, percent, subcommand
from .inputs import (
    add_input,
    add_survey_flags,
    check_input,
    no_answer_written,
    provenance,
    raise_no_answer,
    run_pipeline,
    survey_options,
)

#: The command's name and its line in ``mbinspect --help``.
COMMAND = ("reefs", "extract, separate, measure and score artificial reefs")


def _add_reef_options(p: argparse.ArgumentParser) -> None:
    from ..reefs import ReefOptions
    from .flags import add_flags

    g = p.add_argument_group("reefs (every option of mbinspect.reefs.ReefOptions)")
    g.add_argument("--reference", metavar="CSV", help="reference reef positions: x,y[,id]")
    g.add_argument("--plan", metavar="CSV",
                   help="the deployment plan: id,x,y[,bearing_deg][,kind][,group]; each reef's offset and "
                        "bearing error, pass/fail against --placement-tolerance, units not found")
    g.add_argument("--permit-area", metavar="POLYGON",
                   help="with --plan: the permitted area, a GeoJSON file (WGS 84 unless it names a CRS) or "
                        "WKT POLYGON text in the survey's CRS; each reef inside or outside it")
    add_flags(g, ReefOptions)
    add_survey_flags(p)
    add_output(p, "reefs-out")


def _cmd_reefs(args: argparse.Namespace, rep: Reporter, argv: Sequence[str]) -> int:
    from ..evaluate import read_reference
    from ..outputs import output_dir
    from ..reefs import ReefOptions
    from ..report import write_reef_outputs
    from ..report.html import number
    from ..timing import StageTimes
    from .flags import given_options

    options = ReefOptions.from_given(given_options(args, ReefOptions))  # a bad design fails here
    survey = survey_options(args)
    check_input(args)
    reference = read_reference(args.reference) if args.reference else None
    plan = _plan(args)
    design_files = [s for s in (args.opt_design or "").split(",") if s.strip().lower().endswith(".json")]
    out = Path(args.out or "reefs-out")
    with output_dir(out, overwrite=args.overwrite, inputs=[*map(str, args.files), args.reference,
                                                            *design_files]) as tmp, \
            no_answer_written(tmp, "reefs", args, argv) as caught:
        times = StageTimes() if rep.verbosity > 0 else None
        t = time.perf_counter()
        run = run_pipeline("reefs", args, args.files, options, survey, verbosity=rep.verbosity,
                           extra={"reference": reference, "times": times}, staging=tmp, stages=rep.progress)
        rep.debug(f"extracted {len(run.result.reefs)} reefs in {time.perf_counter() - t:.2f} s")
        result = provenance(run.result, args, argv, reference=args.reference, plan=args.plan)
        if plan is not None:
            result = _placed(result, plan, args, options)
        t_out = time.perf_counter()
        write_reef_outputs(result, run.points, tmp, figures=not args.no_figures)
        if times is not None and times.started is not None:  # in memory: each stage's time
            rep.debug(f"stages: reading {times.started - t:.2f} s, {times.line()}, outputs "
                      f"{time.perf_counter() - t_out:.2f} s")
    raise_no_answer(caught, out)
    d = result.to_dict()
    if rep.verbosity >= 0:
        rms = number(d["seabed"].get("residual_rms"))
        print(f"{len(d['reefs'])} reefs in {len(d['groups'])} groups, {len(d['others'])} other "
              f"objects; seabed: {d['seabed'].get('method')} (residual {rms} m)")
        ev = d["evaluation"]
        if ev is not None:
            print(f"against {args.reference}: TP {ev['tp']}, FP {ev['fp']}, FN {ev['fn']}, "
                  f"correctness {percent(ev['correctness'])}, completeness {percent(ev['completeness'])}")
        if plan is not None:
            placed = [r["placement"] for r in d["reefs"] if r.get("placement")]
            print(f"against the plan {args.plan}: {len(placed)} of {len(plan.rows)} units found, "
                  f"{placed.count('pass')} placed within {options.placement_tolerance:g} m at 95 %, "
                  f"{placed.count('fail')} not, {placed.count('undecided')} undecided; "
                  f"{len(d['plan_missing'])} missing, {sum(r.get('plan_id') is None for r in d['reefs'])} "
                  "reefs not in the plan"
                  + (f"; {sum(r.get('in_permit') is False for r in d['reefs'])} outside the permit area"
                     if args.permit_area else ""))
        _print_rest(d["reefs"])
    for w in result.warnings:
        print(f"mbinspect: warning: {w}", file=sys.stderr)
    rep.info(f"results in {out}/ (report.html, reefs.json, reefs.csv, reefs.geojson"
             + (", placement.geojson)" if plan is not None else ")"))
    return 0


def _plan(args: argparse.Namespace) -> Any:
    """The plan of ``--plan`` (read now: a bad row stops the run before it starts)."""
    from ..errors import ParameterError
    from ..reefs.plan import read_permit, read_plan

    if args.permit_area and not args.plan:
        raise ParameterError("permit_area: given without --plan; expected a plan to place the reefs by",
                             option="permit_area")
    args.permit = read_permit(args.permit_area) if args.permit_area else None  # a bad polygon stops here
    return read_plan(args.plan) if args.plan else None


def _placed(result: Any, plan: Any, args: argparse.Namespace, options: Any) -> Any:
    """The result placed against the plan (and the permit area, in the survey's CRS)."""
    import dataclasses

    import numpy as np

    from ..reefs.plan import permit_in, place_reefs
    from ..report import crs_of

    if args.permit is not None:
        xy = np.array([[u["x"], u["y"]] for u in plan.rows])
        ring, note = permit_in(args.permit, crs_of(result), xy)
        plan = dataclasses.replace(plan, permit=ring, permit_source=note)
    return place_reefs(result, plan, tolerance=options.placement_tolerance,
                       position_sigma=options.position_sigma, bearing_sigma_deg=options.bearing_sigma_deg)


def add_parser(sub: Any) -> None:
    """``mbinspect reefs``: its flags."""
    from ..reefs import ReefOptions

    p = subcommand(sub, *COMMAND,
             "Extract artificial reefs from the seabed, separate them (close and touching ones "
             "too), measure each (centre, height, area, size, orientation, volumes), group them "
             "and, with --reference, score them (TP/FP/FN, correctness, completeness). Writes "
             "reefs.json, reefs.csv, reefs.geojson, figures and report.html.",
             "examples:\n  mbinspect reefs field.laz --reference reefs.csv --out reefs-out\n"
             "  mbinspect reefs field.laz --design cross2,cross1 --out reefs-out\n"
             "  mbinspect reefs soundings.xyz --method paper --no-figures")
    add_input(p, many=True)
    _add_reef_options(p)
    p.set_defaults(func=_cmd_reefs, options_class=ReefOptions)


def _print_rest(reefs: list[dict]) -> None:
    """The units overturned, and those whose orientation the beam leaves undecided."""
    from ..reefs.orient import UNTOLD

    turned = [r for r in reefs if r.get("overturned")]
    if turned:
        print(f"{len(turned)} overturned: " + ", ".join(f"reef {r['id']} {r['resting']}" for r in turned))
    untold = [r for r in reefs if UNTOLD in (r.get("resting_note") or "")]
    if untold:
        print(f"{len(untold)} whose orientation the beam leaves undecided (see resting_note): "
              + ", ".join(f"reef {r['id']}" for r in untold))
