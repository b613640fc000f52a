"""What every command that reads a survey shares: the input and reading flags, the survey
flags, reading with progress, the inputs' size and sha256 in ``parameters``, and the run."""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from .common import Reporter


def add_input(p: argparse.ArgumentParser, many: bool = False) -> None:
    from ..io import FORMAT_NAMES

    if many:
        add_inputs(p)
    else:
        p.add_argument("input", help="point cloud or sonar file (.xyz .txt .csv .las .laz .ply .npz .gsf "
                                     ".kmall .all)")
    g = p.add_argument_group("reading")
    g.add_argument("--format", choices=FORMAT_NAMES, help="file format when the extension does not say it")
    g.add_argument("--columns", metavar="MAP",
                   help="ASCII columns, e.g. x,y,z,intensity or x,y,-,z ('-' skips)")
    g.add_argument("--delimiter", metavar="D",
                   help="ASCII delimiter: ',' ';' tab or space (default: sniffed)")
    g.add_argument("--depth-positive", action="store_true",
                   help="z in the file is depth, positive down (it is negated)")
    g.add_argument("--crs", metavar="CRS",
                   help="the projected metre CRS to put the soundings in, reprojecting a file that "
                        "declares another (default: the file's own, or the UTM zone of data in degrees "
                        "or feet); for a file that declares none, the CRS of its coordinates "
                        "(e.g. EPSG:32631)")
    g.add_argument("--decimal", choices=[".", ","], help="ASCII decimal mark (default: sniffed)")
    g.add_argument("--z-up", action="store_true",
                   help="z in the file is elevation, positive up (settles a mostly positive z)")
    g.add_argument("--keep-rejected", action="store_true",
                   help="sonar files: keep the soundings the sonar or the file rejected (field 'valid')")
    g.add_argument("--tide", metavar="CSV",
                   help="a tide series (time,height: UTC, the water level in m above chart datum), added to "
                        "each sounding's height at its time; refused when the soundings carry no time or "
                        "the series does not cover them")
    g.add_argument("--datum-offset", metavar="M", type=float,
                   help="metres added to every height (after the tide): the separation to the datum wanted")


def check_input(args: argparse.Namespace) -> None:
    """The inputs expanded (several files, folders, globs) into ``args.files`` and the
    reading options checked on each, before any work (the files are read later)."""
    from ..errors import ParameterError
    from ..io import check_read_options

    need = getattr(args, "opt_min_clearance", None)
    if need is not None and args.tide is None and args.datum_offset is None:
        raise ParameterError(f"min_clearance: {need:g} m given without a vertical reference; "
                             "expected --tide or --datum-offset (0 when the files' heights are already on "
                             "chart datum): nothing is said of clearance without a stated datum",
                             option="min_clearance")
    if isinstance(args.input, list):
        args.files = input_files(args)
        args.input = str(args.files[0]) if len(args.files) == 1 else args.input
        return
    check_read_options(args.input, format=args.format, columns=args.columns, delimiter=args.delimiter)
    args.files = [Path(args.input)]


def read_input(args: argparse.Namespace, rep: Reporter) -> Any:
    from ..survey.inputs import read_survey

    hash_soon(args.files)
    t = time.perf_counter()
    cloud = read_survey(args.files, progress=rep.progress("reading"), **read_options(args))
    rep.debug(f"read {len(cloud):,} points from {len(args.files)} file(s) in {time.perf_counter() - t:.2f} s")
    return cloud


def file_record(path: str) -> dict[str, Any]:
    """Name, size and sha256 of an input file (for ``parameters``)."""
    return file_records([Path(path)])[0]


def provenance(result: Any, args: argparse.Namespace, argv: Sequence[str], **others: str | None) -> Any:
    """The result with the input files, the reading options and the command line added to
    its parameters."""
    from ..datum import vertical_reference

    params = dict(result.parameters)
    inputs = args.files if hasattr(args, "files") else [Path(args.input)]
    if len(inputs) == 1:
        params["input"] = {**params.get("input", {}), **file_record(str(inputs[0]))}
    else:
        params["input"] = {**params.get("input", {}), "files": file_records(inputs)}
    params["reading"] = read_options(args)
    params["vertical_reference"] = vertical_reference(args.tide, args.datum_offset).to_dict()
    for name, path in others.items():
        if path is not None:
            params[name] = file_record(path) if Path(path).is_file() else path
    params["command_line"] = ["mbinspect", *argv]
    return dataclasses.replace(result, parameters=params)


def add_inputs(p: argparse.ArgumentParser) -> None:
    """The input argument of a command that takes a whole survey."""
    p.add_argument("input", nargs="+", metavar="INPUT",
                   help="point cloud or sonar files (.xyz .txt .csv .las .laz .ply .npz .gsf .kmall .all), "
                        "folders of them or glob patterns ('lines/*.laz'): read as one survey, each "
                        "sounding keeping its file, line and ping")


def add_survey_flags(p: argparse.ArgumentParser) -> None:
    """The flags of :class:`mbinspect.survey.run.SurveyOptions`."""
    from ..survey.run import SurveyOptions
    from .flags import add_flags

    g = p.add_argument_group("whole surveys (tiles, Dask)")
    add_flags(g, SurveyOptions)


def input_files(args: argparse.Namespace) -> list[Path]:
    """The files the INPUT arguments name, each checked with the reading options."""
    from ..io import check_read_options
    from ..survey.inputs import expand_inputs

    files = expand_inputs(args.input)
    for f in files:
        check_read_options(f, format=args.format, columns=args.columns, delimiter=args.delimiter)
    return files


def survey_options(args: argparse.Namespace) -> Any:
    """The :class:`SurveyOptions` given on the command line."""
    from ..survey.run import SurveyOptions
    from .flags import given_options

    return SurveyOptions.from_given(given_options(args, SurveyOptions))


def read_options(args: argparse.Namespace) -> dict[str, Any]:
    """The reading flags as :func:`mbinspect.io.read` keywords."""
    from ..survey.inputs import READ_OPTIONS

    return {k: getattr(args, k) for k in READ_OPTIONS}


def task_progress(label: str, verbosity: int, stream: Any = None
                  ) -> Callable[[int, int, float | None], None]:
    """A progress line over tasks with the time left: ``tiles: 3/12, about 40 s left``."""
    out = stream if stream is not None else sys.stderr
    tty = hasattr(out, "isatty") and out.isatty()
    state = {"last": -1.0, "total": -1}

    def update(done: int, total: int, left: float | None) -> None:
        from ..survey.cluster import eta_text

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
    from ..survey.run import run_survey

    hash_soon(files)

    def note(text: str) -> None:
        if verbosity >= 0:
            print(f"mbinspect: {text}", file=sys.stderr, flush=True)

    return run_survey(kind, files, options, survey, read_options=read_options(args),
                      extra=extra, workdir=staging, note=note,
                      progress=task_progress(f"{kind}: files, then tiles", verbosity),
                      stage_progress=stages)


#: Each input's sha256 being taken beside the run, by the file's path, size and change time.
_HASHES: dict[tuple[str, int, int], Future[str]] = {}


def _file_key(path: str | os.PathLike[str]) -> tuple[str, int, int]:
    st = os.stat(path)
    return str(path), st.st_size, st.st_mtime_ns


def hash_soon(files: Sequence[Path]) -> None:
    """Start the inputs' sha256 in a thread, one file after the other, beside the read and
    the work (hashlib lets go of the interpreter's lock while it hashes: 0.25 s for a 110 MB
    ASCII file, which the provenance then waited for at the end); :func:`file_records` takes
    each digest."""
    from ..io import sha256_of

    todo: list[tuple[Future[str], Path]] = []
    for path in files:
        try:
            key = _file_key(path)
        except OSError:  # the read says what is wrong with it
            continue
        if key not in _HASHES:
            started: Future[str] = Future()
            _HASHES[key] = started
            todo.append((started, path))
    if todo:
        threading.Thread(target=_hash_into, args=(todo, sha256_of), name="mbinspect-sha256",
                         daemon=True).start()


def _hash_into(todo: list[tuple[Future[str], Path]], sha256_of: Callable[[Path], str]) -> None:
    for started, path in todo:
        try:
            started.set_result(sha256_of(path))
        except BaseException as exc:  # raised where the digest is wanted
            started.set_exception(exc)


def file_records(files: Sequence[Path]) -> list[dict[str, Any]]:
    """Name, size and sha256 of each input file (the one :func:`hash_soon` took, when it
    was started for the file as it still is)."""
    from ..io import sha256_of

    out = []
    for path in files:
        started = _HASHES.pop(_file_key(path), None)
        digest = started.result() if started is not None else sha256_of(path)
        out.append({"file": str(path), "size": os.path.getsize(path), "sha256": digest})
    return out


#: What a folder holds when its data could not support the command's answer.
NO_ANSWER = "no_answer.json"


@contextmanager
def no_answer_written(staging: Path, kind: str, args: argparse.Namespace, argv: Sequence[str]
                      ) -> Iterator[list[Exception]]:
    """Run the block; if the data cannot support an answer (``DataError``, too few
    soundings), write the reason to ``NO_ANSWER`` in ``staging`` and hold the error in the
    yielded list, so that the folder is kept and the caller raises ``NoAnswer`` after it."""
    from ..errors import DataError, NotEnoughPointsError
    from ..outputs import write_json

    caught: list[Exception] = []
    try:
        yield caught
    except (DataError, NotEnoughPointsError) as exc:
        write_json({"answer": None, "kind": kind, "reason": str(exc),
                    "input": file_records(list(args.files)), "reading": read_options(args),
                    "command_line": ["mbinspect", *argv]}, staging / NO_ANSWER)
        caught.append(exc)


def raise_no_answer(caught: list[Exception], out: Path) -> None:
    """Raise ``NoAnswer`` for the error :func:`no_answer_written` held, if any."""
    from ..errors import MBInspectError, NoAnswer

    if caught and isinstance(caught[0], MBInspectError):
        raise NoAnswer(caught[0], str(out / NO_ANSWER))
