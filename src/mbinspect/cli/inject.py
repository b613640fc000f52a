"""``mbinspect inject``: known piles and reefs put into a real survey."""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..beam import Beam
from ..errors import ParameterError
from .common import Reporter, subcommand
from .flags import add_flags, given_options
from .inputs import add_input, check_input, file_record, read_input

#: The command's name and its line in ``mbinspect --help``.
COMMAND = ("inject", "put known piles and reefs into a real survey (its own noise and shadows)")


def _cmd_inject(args: argparse.Namespace, rep: Reporter, argv: Sequence[str]) -> int:

    from ..inject import inject, read_pile_file, read_reef_file
    from ..io import PointCloud
    from ..outputs import output_dir
    from ..simulate import write_bundle

    check_input(args)
    pits = [_pit(v) for v in args.pit or ()]
    if not args.piles and not args.reefs and not pits:
        raise ParameterError("nothing to inject; give `piles`, `reefs` or `pit`", option="piles")
    piles = read_pile_file(args.piles) if args.piles else []
    reefs = read_reef_file(args.reefs) if args.reefs else []
    out = Path(args.out or "inject-out")
    lists = [f for f in (args.piles, args.reefs) if f]
    with output_dir(out, overwrite=args.overwrite, inputs=[args.input, *lists]) as tmp:
        cloud = read_input(args, rep)
        t = time.perf_counter()
        given = given_options(args, Beam)
        inj = inject(cloud.xyz, cloud.fields, piles=piles, reefs=reefs, beam=Beam(**given) if given else None,
                     pits=pits)
        rep.debug(f"injected {len(piles)} piles, {len(reefs)} reefs and {len(pits)} pits in "
                  f"{time.perf_counter() - t:.2f} s")
        injected = PointCloud(inj.xyz, dict(cloud.fields), source=cloud.source, crs=cloud.crs,
                              meta=dict(cloud.meta))
        truth = {**inj.to_dict(), "survey": file_record(args.input), "command_line": ["mbinspect", *argv]}
        reference = [(r["x"], r["y"], r["id"]) for r in inj.truth["reefs"]] if reefs else None
        write_bundle(tmp, truth, cloud=injected, labels=inj.labels,
                     ident=inj.ident, reference=reference)
    counts = inj.truth["counts"]
    hits = [f"pile {k}: {v:,}" for k, v in counts["per_pile"].items()]
    hits += [f"reef {k}: {v:,}" for k, v in counts["per_reef"].items()]
    written = " and ".join(n for n, want in (("design.csv", piles), ("reference.csv", reefs)) if want)
    what = " and ".join(f"{len(v)} {k}" for k, v in (("piles", piles), ("reefs", reefs), ("pits", pits)) if v)
    rep.info(f"{what} injected into {len(cloud):,} soundings "
             f"({', '.join(hits) or 'the seabed lowered'}); written to {out}/soundings.npz with truth.json"
             + (f" and {written}" if written else ""))
    for note in inj.truth["warnings"]:
        print(f"mbinspect: warning: {note}", file=sys.stderr)
    if counts["without_ping_geometry"]:
        print(f"mbinspect: warning: {counts['without_ping_geometry']:,} soundings of pings too short to "
              "place their transducer were left as they were", file=sys.stderr)
    for kind in ("pile", "reef"):
        for k, v in counts[f"per_{kind}"].items():
            if v == 0:
                print(f"mbinspect: warning: {kind} {k}: no beam of the survey reaches it", file=sys.stderr)
    return 0


def _pit(text: str) -> tuple[float, float, float, float]:
    """``X,Y,DEPTH,RADIUS`` (m) as a pit, or one line naming the option and the value."""
    parts = text.split(",")
    try:
        x, y, depth, radius = (float(v) for v in parts)
    except ValueError:
        raise ParameterError(f"pit: {text!r}; expected X,Y,DEPTH,RADIUS in metres (four numbers)",
                             option="pit") from None
    if not all(math.isfinite(v) for v in (x, y, depth, radius)) or depth < 0 or radius <= 0:
        raise ParameterError(f"pit: {text!r}; expected finite numbers, DEPTH at least 0 and RADIUS above 0",
                             option="pit")
    return x, y, depth, radius


def add_parser(sub: Any) -> None:
    """``mbinspect inject``: its flags."""
    p = subcommand(sub, *COMMAND,
             "Put piles and reefs of known position into a real survey: every sounding whose beam meets "
             "an object is moved to the hit point and then along its beam by its own seabed residual, so "
             "the objects carry the survey's real noise and cast its real shadows. Uses the ping and "
             "beam angle of each sounding (GSF, KMALL, .all, or an .npz that keeps them); for an XYZ or "
             "LAS export without them, estimates them from the soundings' order, with a warning. Writes "
             "soundings.npz, truth.json (as simulate writes it), labels.npz, and design.csv (piles) "
             "or reference.csv (reefs).",
             "example:\n  mbinspect inject line.all --piles piles.csv --out injected\n"
             "  mbinspect piles injected/soundings.npz --radius 0.5 --design injected/design.csv\n"
             "  mbinspect inject line.all --reefs reefs.csv --out reefs-in\n"
             "  mbinspect reefs reefs-in/soundings.npz --reference reefs-in/reference.csv\n"
             "  mbinspect inject line.all --piles piles.csv --pit 500012,6400034,0.5,3 --out scoured\n\n"
             "piles.csv: id,x,y,radius and top (elevation, m) or height (above the seabed, m);\n"
             "optional tilt_deg, tilt_azimuth_deg, group\n"
             "reefs.csv: id,x,y,kind (cross2, cross1, hollow, triangle, cube); optional bearing_deg,\n"
             "scale (as built / design), burial (m sunk, default 0.1), group")
    add_input(p)
    p.add_argument("--piles", metavar="CSV", help="the piles to inject (see below)")
    p.add_argument("--reefs", metavar="CSV", help="the reefs to inject (see below)")
    p.add_argument("--pit", metavar="X,Y,DEPTH,RADIUS", action="append",
                   help="dig a scour pit into the survey's seabed first (m; a cosine bell DEPTH deep at "
                        "X,Y and RADIUS wide, as the simulator digs them); repeat for more")
    p.add_argument("--out", metavar="DIR", help="output folder (default inject-out)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing --out folder")
    add_flags(p.add_argument_group("the survey's beam (thin rays unless a width is given)"), Beam)
    p.set_defaults(func=_cmd_inject)
