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


def _add_reef_options(p: argparse.ArgumentParser) -> None:
    from ..reefs import ReefOptions
    from .flags import add_flags

    g = p.add_argument_group("reefs (every option of mbinspect.reefs.ReefOptions)")
    g.add_argument("--reference", metavar="CSV", help="reference reef positions: x,y[,id]")
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
        result = provenance(run.result, args, argv, reference=args.reference)
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
    for w in result.warnings:
        print(f"mbinspect: warning: {w}", file=sys.stderr)
    rep.info(f"results in {out}/ (report.html, reefs.json, reefs.csv, reefs.geojson)")
    return 0


def add_parser(sub: Any) -> None:
    """``mbinspect reefs``: its flags."""
    from ..reefs import ReefOptions

    p = subcommand(sub, "reefs", "extract, separate, measure and score artificial reefs",
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
