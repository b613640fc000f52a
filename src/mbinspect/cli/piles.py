"""``mbinspect piles``: locate piles, every pile spacing and each jacket's frame."""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .common import Reporter, add_output, subcommand
from .exits import EXIT_FLAGGED, EXIT_UNDECIDED
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
COMMAND = ("piles", "locate piles and every pile spacing")


def _add_pile_options(p: argparse.ArgumentParser) -> None:
    from ..piles import PileOptions
    from .flags import add_flags

    g = p.add_argument_group("piles (every option of mbinspect.piles.PileOptions)")
    g.add_argument("--design", metavar="CSV", help="design positions (id,x,y) or spacings (a,b,distance)")
    add_flags(g, PileOptions)
    add_survey_flags(p)
    add_output(p, "piles-out")


def finish_piles(result: Any, points: Any, tmp: Path, out: Path, args: argparse.Namespace,
                  rep: Reporter, truth: Any = None, title: str = "Pile positions and spacings") -> int:
    from ..report import spacing_table, write_pile_outputs

    write_pile_outputs(result, points, tmp, figures=not args.no_figures, truth=truth, title=title)
    tp = None if truth is None else {(s["a"], s["b"]): s["distance"] for s in truth["spacings"]}
    if rep.verbosity >= 0:
        print(spacing_table(result, tp))
    for w in result.warnings:
        print(f"mbinspect: warning: {w}", file=sys.stderr)
    for p in result.piles:
        for f in p.flags:
            print(f"mbinspect: warning: pile {p.id}: {f}", file=sys.stderr)
    rep.info(f"results in {out}/ (report.html, piles.json, piles.csv, spacings.csv, levels.csv)")
    verdicts = [s.verdict for s in result.spacings] + [f.verdict for f in result.frames] + [
        v.verdict for v in result.levels] + [p.top_verdict for p in result.piles]
    if "fail" in verdicts or not result.ok:
        rep.info(FLAGGED_MEANING)
        return EXIT_FLAGGED
    return EXIT_UNDECIDED if "undecided" in verdicts else 0


#: The one line that says what the exit status 3 and the pile flags mean.
FLAGGED_MEANING = ("exit 3: a spacing, frame or top level failed its tolerance, or a pile is flagged: its "
                   "warning says why the data cannot support a centimetre answer there (too few lines "
                   "or sides seen, a plan 1-sigma over --max-sigma); the results are written and the "
                   "report shows each reason")


def _cmd_piles(args: argparse.Namespace, rep: Reporter, argv: Sequence[str]) -> int:
    from ..outputs import output_dir
    from ..piles import PileOptions, read_design
    from .flags import given_options

    options = PileOptions.from_given(given_options(args, PileOptions))
    survey = survey_options(args)
    check_input(args)
    design = read_design(args.design) if args.design else None
    out = Path(args.out or "piles-out")
    with output_dir(out, overwrite=args.overwrite, inputs=[*map(str, args.files), args.design]) as tmp, \
            no_answer_written(tmp, "piles", args, argv) as caught:
        t = time.perf_counter()
        run = run_pipeline("piles", args, args.files, options, survey, verbosity=rep.verbosity,
                           extra={"design": design}, staging=tmp, stages=rep.progress)
        rep.debug(f"located {len(run.result.piles)} piles in {time.perf_counter() - t:.2f} s")
        result = provenance(run.result, args, argv, design=args.design)
        code = finish_piles(result, run.points, tmp, out, args, rep)
    raise_no_answer(caught, out)
    return code


def add_parser(sub: Any) -> None:
    """``mbinspect piles``: its flags."""
    from ..piles import PileOptions

    p = subcommand(sub, *COMMAND,
             "Locate underwater piles (top centre, radius, tilt) and every pile-to-pile spacing; "
             "compare with a design. Writes piles.json, piles.csv, spacings.csv, levels.csv, figures and "
             "report.html. Exit status 3: results written, but a pile is flagged or a spacing "
             "fails the design tolerance.",
             "examples:\n  mbinspect piles survey.laz --count 4 --radius 0.75 --design design.csv\n"
             "  mbinspect piles soundings.xyz --radius 0.75 --method both --out piles-out\n"
             "  mbinspect piles depths.csv --columns x,y,z --depth-positive --count 4 --radius 1.0")
    add_input(p, many=True)
    _add_pile_options(p)
    p.set_defaults(func=_cmd_piles, options_class=PileOptions)
