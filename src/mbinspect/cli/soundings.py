"""``mbinspect soundings``: the soundings behind one reef or pile of a saved result."""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .common import subcommand

#: The command's name and its line in ``mbinspect --help``.
COMMAND = ("soundings", "write the soundings behind one reef or pile of a result")


def _margin(text: str) -> float:
    """A margin: a finite number of metres, zero or more."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"{text!r}; expected a finite number of metres, 0 or more")
    return value


def add_parser(sub: Any) -> None:
    """``mbinspect soundings RESULT.json ID``."""
    p = subcommand(sub, *COMMAND,
             "Read the files and pings a reef or pile of RESULT.json records under `sources` and write "
             "the soundings of those pings inside the object (a reef's outline; a pile's radius plus "
             "--margin) as CSV: x, y, z, file, ping, and beam and beam_angle when the file has them.",
             "example:\n  mbinspect soundings reefs-out/reefs.json 17 --out reef17.csv")
    p.add_argument("result", help="a reefs.json or piles.json written by mbinspect")
    p.add_argument("id", type=int, help="the reef or pile id")
    p.add_argument("--out", metavar="CSV", help="output CSV (default: standard output)")
    p.add_argument("--margin", type=_margin, default=0.5, metavar="M",
                   help="metres around the object kept (default 0.5)")
    p.set_defaults(func=cmd_soundings)


def cmd_soundings(args: argparse.Namespace, rep: Any, argv: Sequence[str]) -> int:
    """The soundings of one object of a result, as CSV."""
    from ..errors import InputError, ParameterError
    from ..survey.trace import object_soundings

    path = Path(args.result)
    try:
        result = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except (ValueError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: not a JSON result of mbinspect ({exc})") from None
    kind = next((k for k in ("reefs", "piles") if isinstance(result, dict)
                 and isinstance(result.get(k), list)), None)
    if kind is None:
        raise InputError(f"{path}: neither a reefs.json nor a piles.json (no 'reefs' or 'piles' list)")
    found = [o for o in result[kind] if isinstance(o, dict) and o.get("id") == args.id]
    if not found:
        ids = [o["id"] for o in result[kind] if isinstance(o, dict) and isinstance(o.get("id"), int)]
        raise ParameterError(f"id: {args.id}; expected one of the {kind} in {path} "
                             f"({min(ids) if ids else '-'}..{max(ids) if ids else '-'})", option="id")
    params: dict[str, Any] = result["parameters"] if isinstance(result.get("parameters"), dict) else {}
    reading = dict(params.get("reading") or {})
    inputs: dict[str, Any] = params["input"] if isinstance(params.get("input"), dict) else {}
    if reading.get("crs") is None:
        reading["crs"] = inputs.get("crs")
    records = inputs.get("files") or ([inputs] if "sha256" in inputs else [])
    recorded = {r["file"]: r["sha256"] for r in records if isinstance(r, dict) and "sha256" in r}
    rows = object_soundings(kind, found[0], margin=args.margin, read_options=reading, recorded=recorded)
    from ..outputs import atomic_path

    header = list(rows[0].keys()) if rows else ["x", "y", "z", "file", "ping"]
    text = ",".join(header) + "\n" + "".join(",".join(str(r[h]) for h in header) + "\n" for r in rows)
    if args.out:
        with atomic_path(args.out) as tmp:
            tmp.write_text(text, encoding="utf-8")
        rep.info(f"{len(rows):,} soundings of {kind[:-1]} {args.id} in {args.out}")
    else:
        sys.stdout.write(text)
    return 0
