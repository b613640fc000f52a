"""The command line's whole-survey pieces: many inputs, the tiling and Dask flags, the
progress over tiles, and ``mbinspect soundings``."""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

__all__ = ["add_inputs", "add_survey_flags", "input_files", "survey_options", "run_pipeline",
           "file_records", "task_progress", "cmd_soundings", "add_soundings_parser"]


def add_inputs(p: argparse.ArgumentParser) -> None:
    """The input argument of a command that takes a whole survey."""
    p.add_argument("input", nargs="+", metavar="INPUT",
                   help="point cloud or sonar files (.xyz .txt .csv .las .laz .ply .npz .gsf .kmall .all), "
                        "folders of them or glob patterns ('lines/*.laz'): read as one survey, each "
                        "sounding keeping its file, line and ping")


def add_survey_flags(p: argparse.ArgumentParser) -> None:
    """The flags of :class:`mbinspect.survey.run.SurveyOptions`."""
    from .options import add_flags
    from .survey.run import SurveyOptions

    g = p.add_argument_group("whole surveys (tiles, Dask)")
    add_flags(g, SurveyOptions)


def input_files(args: argparse.Namespace) -> list[Path]:
    """The files the INPUT arguments name, each checked with the reading options."""
    from .io import check_read_options
    from .survey.inputs import expand_inputs

    files = expand_inputs(args.input)
    for f in files:
        check_read_options(f, format=args.format, columns=args.columns, delimiter=args.delimiter)
    return files


def survey_options(args: argparse.Namespace) -> Any:
    """The :class:`SurveyOptions` given on the command line."""
    from .options import given_options
    from .survey.run import SurveyOptions

    return SurveyOptions.from_given(given_options(args, SurveyOptions))


def read_options(args: argparse.Namespace) -> dict[str, Any]:
    """The reading flags as :func:`mbinspect.io.read` keywords."""
    from .survey.inputs import READ_OPTIONS

    return {k: getattr(args, k) for k in READ_OPTIONS}


def task_progress(label: str, verbosity: int, stream: Any = None
                  ) -> Callable[[int, int, float | None], None]:
    """A progress line over tasks with the time left: ``tiles: 3/12, about 40 s left``."""
    out = stream if stream is not None else sys.stderr
    tty = hasattr(out, "isatty") and out.isatty()
    state = {"last": -1.0, "total": -1}

    def update(done: int, total: int, left: float | None) -> None:
        from .survey.cluster import eta_text

        if verbosity < 0:
            return
        if total != state["total"]:
            state.update(total=total, last=-1.0)
        now = time.perf_counter()
        if done < total and now - state["last"] < (0.5 if tty else 10.0):
            return
        state["last"] = now
        end = "\r" if tty and done < total else "\n"
        print(f"{label}: {done}/{total}, {eta_text(left) if done < total else 'done'}", end=end,
              file=out, flush=True)

    return update


def run_pipeline(kind: str, args: argparse.Namespace, files: Sequence[Path], options: Any, survey: Any, *,
                 verbosity: int, extra: dict[str, Any], staging: Path,
                 stages: Callable[[str], Callable[[float], None]] | None = None) -> Any:
    """:func:`mbinspect.survey.run.run_survey` with the command line's progress (``stages``
    makes the percentage callback of each step of a run in one piece); tile parts go into
    the output's staging folder, so that an interrupted run leaves none behind."""
    from .survey.run import run_survey

    def note(text: str) -> None:
        if verbosity >= 0:
            print(f"mbinspect: {text}", file=sys.stderr, flush=True)

    return run_survey(kind, files, options, survey, read_options=read_options(args),
                      extra=extra, workdir=staging, note=note,
                      progress=task_progress(f"{kind}: files, then tiles", verbosity),
                      stage_progress=stages)


def file_records(files: Sequence[Path]) -> list[dict[str, Any]]:
    """Name, size and sha256 of each input file."""
    out = []
    for path in files:
        h = hashlib.sha256()
        with open(path, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
        out.append({"file": str(path), "size": os.path.getsize(path), "sha256": h.hexdigest()})
    return out


# ----------------------------------------------------------------------------- soundings


def add_soundings_parser(sub: Any, make: Callable[..., argparse.ArgumentParser]) -> None:
    """``mbinspect soundings RESULT.json ID``."""
    p = make(sub, "soundings", "write the soundings behind one reef or pile of a result",
             "Read the files and pings a reef or pile of RESULT.json records under `sources` and write "
             "the soundings of those pings inside the object (a reef's outline; a pile's radius plus "
             "--margin) as CSV: x, y, z, file, ping, and beam and beam_angle when the file has them.",
             "example:\n  mbinspect soundings reefs-out/reefs.json 17 --out reef17.csv")
    p.add_argument("result", help="a reefs.json or piles.json written by mbinspect")
    p.add_argument("id", type=int, help="the reef or pile id")
    p.add_argument("--out", metavar="CSV", help="output CSV (default: standard output)")
    p.add_argument("--margin", type=float, default=0.5, metavar="M",
                   help="metres around the object kept (default 0.5)")
    p.set_defaults(func=cmd_soundings)


def cmd_soundings(args: argparse.Namespace, rep: Any, argv: Sequence[str]) -> int:
    """The soundings of one object of a result, as CSV."""
    from .errors import InputError, ParameterError
    from .survey.trace import object_soundings

    path = Path(args.result)
    try:
        result = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except (ValueError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: not a JSON result of mbinspect ({exc})") from None
    kind = "reefs" if "reefs" in result else "piles" if "piles" in result else None
    if kind is None:
        raise InputError(f"{path}: neither a reefs.json nor a piles.json (no 'reefs' or 'piles' list)")
    found = [o for o in result[kind] if o.get("id") == args.id]
    if not found:
        ids = [o.get("id") for o in result[kind]]
        raise ParameterError(f"id: {args.id}; expected one of the {kind} in {path} "
                             f"({min(ids) if ids else '-'}..{max(ids) if ids else '-'})", option="id")
    params = result.get("parameters", {})
    reading = dict(params.get("reading") or {})
    if reading.get("crs") is None:
        reading["crs"] = (params.get("input") or {}).get("crs")
    rows = object_soundings(kind, found[0], margin=args.margin, read_options=reading)
    from .outputs import atomic_path

    header = list(rows[0].keys()) if rows else ["x", "y", "z", "file", "ping"]
    text = ",".join(header) + "\n" + "".join(",".join(str(r[h]) for h in header) + "\n" for r in rows)
    if args.out:
        with atomic_path(args.out) as tmp:
            tmp.write_text(text, encoding="utf-8")
        rep.info(f"{len(rows):,} soundings of {kind[:-1]} {args.id} in {args.out}")
    else:
        sys.stdout.write(text)
    return 0
