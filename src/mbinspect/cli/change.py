"""``mbinspect change``: two surveys of one reef field, or of one jacket, compared object by
object."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .common import Reporter, add_output, subcommand

#: The command's name and its line in ``mbinspect --help``.
COMMAND = ("change", "compare two surveys of one reef field or jacket, object by object")


def add_parser(sub: Any) -> None:
    """``mbinspect change BEFORE AFTER``."""
    from ..change import ChangeOptions
    from .flags import add_flags

    p = subcommand(sub, *COMMAND,
             "Register the AFTER survey on the BEFORE survey's seabed away from the objects (vertical "
             "offset, plan shift, small rotation, each with its 1-sigma), match the objects one to one, "
             "and give each its change: a reef's displacement, turn, settlement, height, tilt, how it "
             "rests and the scour round it; a pile's top displacement, settlement, lean and scour; every "
             "change with its 95 % level of detection (a change inside it is 'no detectable change'). "
             "BEFORE and AFTER are result folders (or reefs.json / piles.json) written by 'mbinspect "
             "reefs' or 'mbinspect piles'; their soundings are read again from the files the results "
             "record. Writes change.json, change.csv, change.geojson, difference.png and report.html.",
             "examples:\n  mbinspect reefs survey-2025/ --design cross2 --out reefs-2025\n"
             "  mbinspect reefs survey-2026/ --design cross2 --out reefs-2026\n"
             "  mbinspect change reefs-2025 reefs-2026 --out change-2025-2026 --register site.gpkg\n"
             "  mbinspect change site.gpkg --out change-last        (the register's last two surveys)\n"
             "  mbinspect change site.gpkg --history 17             (one unit's life)\n"
             "  mbinspect change piles-2025 piles-2026 --kind piles --out jacket-change")
    p.add_argument("before", help="the earlier survey's result folder (reefs.json or piles.json), or a site "
                   "register (.gpkg)")
    p.add_argument("after", nargs="?", help="the later survey's result folder (reefs.json or piles.json)")
    p.add_argument("--register", metavar="SITE.gpkg",
                   help="add the comparison to a site register (a GeoPackage, created when new): the "
                        "surveys, every unit with its history, every change")
    p.add_argument("--kind", choices=("reefs", "piles"),
                   help="what the results must hold (default: what they hold, both the same)")
    p.add_argument("--history", type=int, metavar="ID",
                   help="with a register as BEFORE: print one unit's life (its id in the register)")
    g = p.add_argument_group("change (every option of mbinspect.change.ChangeOptions)")
    add_flags(g, ChangeOptions)
    add_output(p, "change-out")
    p.set_defaults(func=cmd_change)


def cmd_change(args: argparse.Namespace, rep: Reporter, argv: Sequence[str]) -> int:
    """Compare the two results and write the change."""
    from ..change import ChangeOptions, compare_surveys
    from ..change.outputs import write_change_outputs
    from ..errors import ParameterError
    from ..outputs import output_dir
    from ..report import crs_of
    from .flags import given_options

    options = ChangeOptions.from_given(given_options(args, ChangeOptions))
    if str(args.before).lower().endswith(".gpkg") and args.after is None:
        from ..change.site import last_two

        if args.history is not None:
            return _history(args.before, args.history)
        if args.register:
            raise ParameterError("register: the register's last two surveys are in it already; expected "
                                 "BEFORE AFTER result folders to add a survey", option="register")
        args.before, args.after = last_two(args.before)
    elif args.after is None:
        raise ParameterError(f"after: missing; expected the later survey's result after {args.before} (or a "
                             "site register .gpkg alone)", option="after")
    elif args.history is not None:
        raise ParameterError("history: goes with a register alone (mbinspect change SITE.gpkg --history ID)",
                             option="history")
    before, b_cloud, b_files = _side(args.before, "before", rep, args.kind)
    after, a_cloud, a_files = _side(args.after, "after", rep, args.kind)
    out = Path(args.out or "change-out")
    with output_dir(out, overwrite=args.overwrite, inputs=[*b_files, *a_files]) as tmp:
        result = compare_surveys(before, after, b_cloud.xyz, a_cloud.xyz, options=options,
                                 before_fields=b_cloud.fields, after_fields=a_cloud.fields,
                                 progress=rep.progress("comparing"))
        params = {**result.parameters, "command_line": ["mbinspect", *argv],
                  "before_result": str(args.before), "after_result": str(args.after)}
        import dataclasses

        result = dataclasses.replace(result, parameters=params)
        write_change_outputs(result, tmp, crs=crs_of(before), figures=not args.no_figures)
        if args.register:  # last, so that a register refused leaves no results behind
            from ..change.site import register_change

            added = register_change(args.register, result, before, after, before_path=args.before,
                                    after_path=args.after, crs=crs_of(before))
            rep.info(f"{args.register}: surveys {added['survey_before']} and {added['survey_after']}, "
                     f"{added['objects']} units in all")
    if rep.verbosity >= 0:
        _print(result)
    rep.info(f"results in {out}/ (report.html, change.json, change.csv, change.geojson)")
    return 0


def _history(path: str, obj: int) -> int:
    """Print one unit's life from a register."""
    from ..change.site import history
    from ..report.html import number

    h = history(path, obj)
    print(f"unit {h['object']} ({h['design'] or 'no design'}): surveys "
          f"{h['first_survey']}..{h['last_survey']}, "
          f"{h['status']}")
    word = h["kind"][:-1]
    for o in h["observations"]:
        parts = [f"top {number(o['z_top'], '.3f')} m" if word == "pile" else
                 f"height {number(o['height'], '.2f')} m",
                 f"least depth {number(o['least_depth'], '.2f')} m",
                 f"{'lean' if word == 'pile' else 'tilt'} {number(o['top_tilt_deg'], '.1f')} deg"]
        if word == "reef":
            parts.append(f"overturned {o['overturned'] or 'undecided'}")
        print(f"  survey {o['survey']}: {word} {o['result_id']} at {o['x']:.2f}, {o['y']:.2f}; "
              + ", ".join(parts))
    for c in h["changes"]:
        print(f"  {c['survey_before']} -> {c['survey_after']}: {c['status']}"
              + (f" ({c['detected']})" if c["detected"] else "")
              + f"; moved {number(c['displacement'], '.2f')} ± {number(c['displacement_lod95'], '.2f')} m, "
                f"settled {number(c['settlement'], '.2f')} ± {number(c['settlement_lod95'], '.2f')} m")
    return 0


def _print(result: Any) -> None:
    c = result.counts()
    reg = result.registration
    print(f"registration: dx {reg.dx:+.3f} ± {reg.sigma_dx:.3f} m, dy {reg.dy:+.3f} ± {reg.sigma_dy:.3f} m, "
          f"dz {reg.dz:+.3f} ± {reg.sigma_dz:.3f} m (1-sigma)"
          + (f"; plan shift refined on {reg.ties} objects that kept their place" if reg.ties else "")
          if math.isfinite(reg.sigma_dz) else f"registration: none ({reg.note})")
    print(f"{c['changed']} changed, {c['unchanged']} no detectable change, {c['removed']} removed, "
          f"{c['new']} new")
    words = {"displacement": "moved", "rotation_deg": "turned", "settlement": "settled",
             "height_change": "height changed", "tilt_change_deg": "tilted", "scour_depth": "scoured"}
    for o in result.objects:
        if o.status != "changed":
            continue
        parts = [f"{words[k]} {o.values[k]:+.2f} ± {o.values[k + '_lod95']:.2f}"
                 for k in o.detected if k in words]
        if "overturned" in o.detected:
            parts.append("overturned" if o.values.get("overturned_after") else "upright again")
        print(f"  {result.kind[:-1]} {o.id_before} (after: {o.id_after}): " + ", ".join(parts))
    for w in result.warnings:
        print(f"mbinspect: warning: {w}", file=sys.stderr)


def _side(path: str, which: str, rep: Reporter, kind: str | None = None) -> tuple[Any, Any, list[str]]:
    """One side's result and its soundings, read again from the files it records."""
    from ..errors import InputError, ParameterError
    from ..io import sha256_of
    from ..piles.results import PileResult
    from ..results import read_result
    from ..survey.inputs import READ_OPTIONS, read_survey

    result = read_result(path)
    held = "piles" if isinstance(result, PileResult) else "reefs"
    if kind is not None and held != kind:
        raise ParameterError(f"{which}: {path} holds {held}; expected {kind} (--kind)", option=which)
    params = result.parameters
    inputs = params.get("input") or {}
    records = inputs.get("files") or ([inputs] if "file" in inputs else [])
    if not records:
        raise InputError(f"{path}: the result records no input files (made from an array, or by an older "
                         "mbinspect); expected a result written by 'mbinspect reefs' or 'mbinspect piles'")
    base = Path(path) if Path(path).is_dir() else Path(path).parent
    files = []
    for rec in records:
        f = Path(rec["file"])
        if not f.is_file() and (base.parent / f).is_file():
            f = base.parent / f
        if not f.is_file():
            raise InputError(f"{path}: its input {rec['file']} is not there; expected the survey file the "
                             "result was made from")
        if rec.get("sha256") and sha256_of(f) != rec["sha256"]:
            raise InputError(f"{f}: not the file {path} was made from (its sha256 differs); expected the "
                             "same survey file")
        files.append(str(f))
    reading = {k: v for k, v in (params.get("reading") or {}).items() if k in READ_OPTIONS}
    cloud = read_survey([Path(f) for f in files], progress=rep.progress(f"reading {which}"), **reading)
    return result, cloud, files
