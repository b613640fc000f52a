"""``mbinspect simulate``: a simulated survey with its exact truth."""

from __future__ import annotations

import argparse
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..errors import ParameterError
from .common import Reporter, subcommand
from .flags import add_flags, typed_parser

#: The command's name and its line in ``mbinspect --help``.
COMMAND = ("simulate", "simulate a multibeam survey with exact truth")


def _add_simulate_options(p: argparse.ArgumentParser) -> None:
    """One flag per preset and sonar option, generated from their options classes; an option
    two presets share is offered once, under the first."""
    from ..simulate import PRESETS, Sonar, SonarChoice

    seen: tuple[str, ...] = ()
    for preset, cls in PRESETS.items():
        g = p.add_argument_group(f"{preset} options (defaults in 'mbinspect simulate "
                                 f"{preset} --show-options')")
        add_flags(g, cls, skip=seen)
        seen += tuple(f.name for f, _ in cls.specs())
    g = p.add_argument_group("sonar options (defaults by --sonar, in --show-options)")
    add_flags(g, SonarChoice)
    add_flags(g, Sonar, default_text="default set by --sonar")


def _writable() -> dict[str, str]:
    """Format name -> the extension of its soundings file, for every format mbinspect writes."""
    from ..formats import FORMATS

    return {ext[1:]: ext for row in FORMATS.values() for ext in row.written_extensions}


def _cmd_simulate(args: argparse.Namespace, rep: Reporter, argv: Sequence[str]) -> int:

    from ..outputs import output_dir
    from ..simulate import DEFAULT_SONAR, default_options, option_fields, simulate, write_bundle

    names = {f.name for f in option_fields(args.preset)}
    given = {k[4:]: v for k, v in vars(args).items() if k.startswith("opt_") and v is not None}
    foreign = sorted(set(given) - names)
    if foreign:
        raise ParameterError(f"{foreign[0]}: not an option of the {args.preset} preset; expected one "
                             f"of {', '.join(sorted(names))}", option=foreign[0])
    if args.show_options:
        values = default_options(args.preset, given.get("sonar", DEFAULT_SONAR))
        for f in option_fields(args.preset):
            print(f"--{f.name.replace('_', '-'):24s} {values[f.name]}")
        return 0
    out = Path(args.out) if args.out else Path(f"sim-{args.preset}-{args.seed}")
    ext = _writable()[args.format]
    if args.survey_lines and (args.resurvey or args.per_line):
        raise ParameterError("survey_lines: goes with one survey in memory; expected no --resurvey or "
                             "--per-line with it", option="survey_lines")
    if args.resurvey:
        return _resurvey(args, given, out, ext, rep, argv)
    if args.changes or args.shift or args.line_shift is not None:
        raise ParameterError("changes: --changes, --shift and --line-shift go with --resurvey TRUTH.json; "
                             "expected --resurvey too", option="changes")
    if args.per_line:
        return _simulate_lines(args, given, out, ext, rep, argv)
    if args.survey_lines:
        from ..plan.outputs import read_line_plan, read_line_speed

        given["survey_lines"] = read_line_plan(args.survey_lines)
        speed = read_line_speed(args.survey_lines)  # a plan's lines at its speed
        if speed is not None:
            given["survey_speed"] = speed
    with output_dir(out, overwrite=args.overwrite) as tmp:
        t = time.perf_counter()
        sim = simulate(args.preset, seed=args.seed, progress=rep.progress("ray casting"),
                       force=args.force, **given)
        rep.debug(f"simulated {len(sim.cloud):,} soundings in {time.perf_counter() - t:.2f} s")
        cloud_path = tmp / f"soundings{ext}"
        reference = sim.reference_rows(seed=args.seed) if sim.truth["reefs"] else None
        write_bundle(tmp, {**sim.truth, "command_line": ["mbinspect", *argv]}, cloud=sim.cloud,
                     cloud_name=cloud_path.name, labels=sim.labels, ident=sim.ident, reference=reference)
    n_obj = (f"{len(sim.truth['piles'])} piles" if sim.truth["piles"]
             else f"{len(sim.truth['reefs'])} reefs")
    rep.info(f"{args.preset}: {len(sim.cloud):,} soundings, {n_obj}, written to "
             f"{out / cloud_path.name} with truth.json")
    return 0


def _resurvey(args: argparse.Namespace, given: dict[str, Any], out: Path, ext: str, rep: Reporter,
              argv: Sequence[str]) -> int:
    """``simulate --resurvey TRUTH.json``: the scene of an earlier simulation, changed, surveyed
    again."""
    import dataclasses
    import json

    from ..errors import InputError
    from ..outputs import output_dir, write_table
    from ..simulate import write_bundle
    from ..simulate.resurvey import Change, random_changes, random_pile_changes, read_changes, resurvey

    if given:
        raise ParameterError(f"{sorted(given)[0]}: the scene and sonar are the earlier simulation's under "
                             "--resurvey; expected none of the preset's options", option=sorted(given)[0])
    if args.per_line:
        raise ParameterError("per_line: not with --resurvey (one file of soundings); expected one or the "
                             "other", option="per_line")
    path = Path(args.resurvey)
    try:
        truth = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except (ValueError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: not a truth.json of mbinspect simulate ({exc})") from None
    if not isinstance(truth, dict) or truth.get("preset") != args.preset or "seed" not in truth:
        raise InputError(f"{path}: not the truth.json of a {args.preset} simulation; expected the one "
                         f"'mbinspect simulate {args.preset}' wrote")
    if truth.get("per_line") or truth.get("files"):
        raise InputError(f"{path}: a simulation of one file per line; expected one simulated as one file")
    if (args.changes or "random") != "random":
        changes = read_changes(args.changes)
    elif truth.get("reefs"):
        changes = random_changes(truth, seed=args.seed)
    else:
        changes = random_pile_changes(truth, seed=args.seed)
    with output_dir(out, overwrite=args.overwrite, inputs=[str(path)]) as tmp:
        sim = resurvey(truth, changes, seed=args.seed, shift=args.shift or (0.0, 0.0, 0.0),
                       line_shift=args.line_shift, progress=rep.progress("ray casting"))
        cloud_path = tmp / f"soundings{ext}"
        write_bundle(tmp, {**sim.truth, "command_line": ["mbinspect", *argv]}, cloud=sim.cloud,
                     cloud_name=cloud_path.name, labels=sim.labels, ident=sim.ident)
        rows = [{k: ("" if v is None or (isinstance(v, float) and v != v) else v)
                 for k, v in dataclasses.asdict(c).items()} for c in changes]
        write_table(rows, tmp / "changes.csv", [f.name for f in dataclasses.fields(Change)])
    objs = sim.truth["change"]["objects"]
    n = {s: sum(o["status"] == s for o in objs) for s in ("changed", "removed", "new")}
    what = "reefs" if truth.get("reefs") else "piles"
    rep.info(f"{args.preset} surveyed again: {len(sim.cloud):,} soundings, {n['changed']} {what} changed, "
             f"{n['removed']} removed, {n['new']} new, written to {out / cloud_path.name} with truth.json "
             "(its 'change') and changes.csv")
    return 0


def _triple(text: str) -> tuple[float, float, float]:
    """``dx,dy,dz`` in metres."""
    import math

    parts = text.split(",")
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}; expected three numbers dx,dy,dz in metres") from None
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"{text!r}; expected three finite numbers dx,dy,dz in metres")
    return values[0], values[1], values[2]


def _simulate_lines(args: argparse.Namespace, given: dict[str, Any], out: Path, ext: str, rep: Reporter,
                    argv: Sequence[str]) -> int:
    """``simulate --per-line``: one file per survey line, streamed line by line."""
    from ..outputs import output_dir
    from ..simulate import reef_reference_rows, simulate_lines, write_bundle

    with output_dir(out, overwrite=args.overwrite) as tmp:
        t = time.perf_counter()
        truth = simulate_lines(args.preset, tmp, seed=args.seed, suffix=ext,
                               progress=rep.progress("lines"), **given)
        reference = reef_reference_rows(truth, seed=args.seed) if truth["reefs"] else None
        write_bundle(tmp, {**truth, "command_line": ["mbinspect", *argv]}, reference=reference)
        rep.debug(f"simulated {truth['n_soundings']:,} soundings in {time.perf_counter() - t:.2f} s")
    rep.info(f"{args.preset}: {truth['n_soundings']:,} soundings in {len(truth['files'])} line files in "
             f"{out}/ with truth.json")
    return 0


def add_parser(sub: Any) -> None:
    """``mbinspect simulate``: its flags."""
    p = subcommand(sub, *COMMAND,
             "Ray-cast a multibeam survey over a scene whose piles and reefs are known exactly; "
             "write the soundings, truth.json, labels.npz and design.csv (jacket) or reference.csv "
             "(reef-field).",
             "examples:\n  mbinspect simulate jacket --seed 3 --out sim3\n"
             "  mbinspect simulate jacket --tilt-max-deg 5 --noise-scale 2 --format laz\n"
             "  mbinspect simulate reef-field --touching-pairs 4 --sand-wave-amplitude 0.4\n"
             "  mbinspect simulate jacket --show-options")
    p.add_argument("preset", choices=["jacket", "wharf", "reef-field"])
    p.add_argument("--seed", type=typed_parser(int, "seed"), default=0, help="random seed (default 0)")
    p.add_argument("--out", metavar="DIR", help="output folder (default sim-PRESET-SEED)")
    p.add_argument("--format", choices=list(_writable()), default="xyz",
                   help="format of the soundings file (default xyz)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing --out folder")
    p.add_argument("--force", action="store_true",
                   help="simulate even a survey of more than 50 million soundings")
    p.add_argument("--show-options", action="store_true",
                   help="list the preset's options and defaults, then stop")
    p.add_argument("--per-line", action="store_true",
                   help="write one file per survey line (line_001.laz ...), streaming line by line: a survey "
                        "of any size in the memory of one line")
    p.add_argument("--survey-lines", metavar="LINES.csv",
                   help="sail these lines instead of the preset's: a lines.csv of 'mbinspect plan' "
                        "(x_start,y_start,x_end,y_end in the scene's coordinates), at its speed_kn "
                        "where it gives one; --ping-spacing stays yours to set")
    g = p.add_argument_group("survey again (change between surveys)")
    g.add_argument("--resurvey", metavar="TRUTH.json",
                   help="the scene of an earlier simulation (its truth.json), changed by --changes and "
                        "surveyed again with other lines and noise (--seed); truth.json gains 'change', the "
                        "true change of every reef")
    g.add_argument("--changes", metavar="CSV",
                   help="with --resurvey: id,status,dx,dy,rotation_deg,settlement,orientation,tilt_deg,"
                        "tilt_bearing_deg,scour_depth,scour_radius[,kind,x,y,bearing_deg] per reef, or "
                        "'random' (the default: about half the reefs changed one way each)")
    g.add_argument("--shift", type=_triple, metavar="DX,DY,DZ",
                   help="with --resurvey: metres added to every sounding (the new survey's position and "
                        "datum offset); default 0,0,0")
    g.add_argument("--line-shift", type=typed_parser(float, "line_shift"), metavar="M",
                   help="with --resurvey: the lines moved across their track (m); default half the line "
                        "spacing")
    _add_simulate_options(p)
    p.set_defaults(func=_cmd_simulate)
