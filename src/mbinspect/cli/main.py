"""The ``mbinspect`` command: the parser built from each command's module, and :func:`main`,
which turns every user's mistake into one line and an exit status (:mod:`.exits`)."""

from __future__ import annotations

import argparse
import os
import re
import sys
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from ..errors import MBInspectError, NoAnswer
from ..version import __version__
from . import change, demo, info, inject, piles, plan, reefs, simulate, soundings
from .common import Parser, Reporter
from .exits import EXIT_DATA, EXIT_IO, EXIT_PIPE, EXIT_USER

_EPILOG = """\
examples:
  mbinspect demo
  mbinspect piles survey.laz --count 4 --radius 0.75 --design design.csv --out piles-out
  mbinspect reefs field.laz --reference reefs.csv --out reefs-out
  mbinspect reefs lines/ --workers 2 --out reefs-out        (a folder of line files, tiled on Dask)
  mbinspect soundings reefs-out/reefs.json 17 --out reef17.csv
  mbinspect simulate jacket --seed 1 --out sim-jacket
  mbinspect plan design.csv --radius 0.75 --depth 21 --out plan-out   (the lines to sail)
  mbinspect info sim-jacket/soundings.xyz
  mbinspect info survey.csv --columns x,y,-,depth --depth-positive --json
"""


#: The commands' modules, in the order ``mbinspect --help`` lists them.
COMMANDS = (info, simulate, inject, piles, reefs, change, plan, demo, soundings)


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The argument parser of the ``mbinspect`` command: every command's flags, or, given
    ``command``, only that one's (the others listed by name and help line), so that a run
    imports what its own command needs and nothing else."""

    parser = Parser(
        prog="mbinspect",
        description="Engineering answers about underwater piles and artificial reefs "
                    "from multibeam echosounder point clouds.",
        epilog=_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"mbinspect {__version__}")
    verbosity = parser.add_mutually_exclusive_group()
    verbosity.add_argument("-v", "--verbose", action="store_true", help="timings of each step")
    verbosity.add_argument("-q", "--quiet", action="store_true", help="errors only")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    sub.required = True

    for module in COMMANDS:
        name, line = module.COMMAND
        if command in (None, name):
            module.add_parser(sub)
        else:
            sub.add_parser(name, help=line)
    return parser


def _command_of(argv: Sequence[str]) -> str | None:
    """The command ``argv`` runs (its first word that is not a flag), if it names one."""
    words = [a for a in argv if not a.startswith("-")]
    names = {m.COMMAND[0] for m in COMMANDS}
    return words[0] if words and words[0] in names else None


def _flag_of(args: argparse.Namespace | None, option: str) -> str:
    """The command-line flag of a library option name, for the command run."""
    from ..options import flag_names

    flags = {"out": "--out", "cell": "--cell", "columns": "--columns", "delimiter": "--delimiter",
             "format": "--format", "seed": "--seed", "design": "--design", "overwrite": "--overwrite",
             "crs": "--crs", "keep_rejected": "--keep-rejected", "z_up": "--z-up", "tide": "--tide",
             "datum_offset": "--datum-offset", "permit_area": "--permit-area", "plan": "--plan",
             "decimal": "--decimal",
             "force": "--force", "depth_positive": "--depth-positive"}
    options_class = getattr(args, "options_class", None)  # set by a pipeline's command
    if options_class is not None:
        flags.update(flag_names(options_class))
    return flags.get(option, "--" + option.replace("_", "-"))


def _message(exc: MBInspectError, args: argparse.Namespace | None) -> str:
    """The error's one line, with a library option name turned into its flag."""
    text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    if exc.option and text.startswith(exc.option + ":"):
        text = _flag_of(args, exc.option) + text[len(exc.option):]
    # an option named in the text as `name` is shown as its flag
    return re.sub(r"`([a-z_]+)`", lambda m: _flag_of(args, m.group(1)), text)


@contextmanager
def one_line_warnings() -> Iterator[None]:
    """Python warnings shown as one ``mbinspect: warning: ...`` line each."""
    def show(message: Any, category: Any, filename: str, lineno: int, file: Any = None,
             line: str | None = None) -> None:
        text = re.sub(r"`([a-z_]+)`", lambda m: _flag_of(None, m.group(1)), str(message))
        print(f"mbinspect: warning: {text}", file=sys.stderr, flush=True)

    with warnings.catch_warnings():
        warnings.simplefilter("default")
        warnings.showwarning = show
        yield


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line on ``argv`` (default ``sys.argv[1:]``); return the exit status.

    Parameters
    ----------
    argv : sequence of str, optional
        The arguments, without the program name.

    Returns
    -------
    int
        0 done; 2 a user's mistake; 3 results written but a pile flagged or a spacing
        failed; 4 a verdict undecided; 5 the data cannot support an answer (the reason
        written to ``no_answer.json``); 1 the output could not be written; 130 / 143
        interrupted; 141 the reader of the output went away.

    Examples
    --------
    >>> main(["piles", "missing.xyz", "--radius", "-1"])
    2
    """
    from ..interrupt import exit_status

    argv = _join_dash_values(list(sys.argv[1:] if argv is None else argv))
    args = None
    try:
        with one_line_warnings():
            parser = build_parser(_command_of(argv))
            args = parser.parse_args(argv)
            rep = Reporter(-1 if args.quiet else (1 if args.verbose else 0))
            code: int = args.func(args, rep, argv)
            sys.stdout.flush()
            return code
    except NoAnswer as exc:
        print(f"mbinspect: no answer: {_message(exc.cause, args)} (written to {exc.written})",
              file=sys.stderr)
        return EXIT_DATA
    except MBInspectError as exc:
        print(f"mbinspect: error: {_message(exc, args)}", file=sys.stderr)
        return EXIT_USER
    except KeyboardInterrupt:
        print("mbinspect: interrupted", file=sys.stderr)
        return exit_status()
    except BrokenPipeError:
        # the reader went away (``mbinspect info f | head``): stop quietly
        _silence_stdout()
        return EXIT_PIPE
    except OSError as exc:
        if getattr(exc, "filename", None) is None and exc.errno is not None:
            _silence_stdout()
            print(f"mbinspect: error: cannot write the output ({exc.strerror})", file=sys.stderr)
            return EXIT_IO
        where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
        print(f"mbinspect: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return EXIT_IO


#: A list of numbers whose first is negative (``-0.1,0,0.05``).
_NUMBERS = re.compile(r"-\.?[0-9][0-9.eE+-]*,")


def _join_dash_values(argv: list[str]) -> list[str]:
    """``--columns -,x,y,z`` as ``--columns=-,x,y,z``: argparse takes a value starting with
    '-' for a flag, and column maps, crops and lists of numbers (``--shift -0.1,0,0.05``)
    often start so."""
    out: list[str] = []
    skip = False
    for k, a in enumerate(argv):
        if skip:
            skip = False
            continue
        nxt = argv[k + 1] if k + 1 < len(argv) else ""
        if (a in ("--columns", "--crop") and nxt.startswith("-") and nxt not in ("-h", "--help")) \
                or (a.startswith("--") and "=" not in a and _NUMBERS.match(nxt)):
            out.append(f"{a}={argv[k + 1]}")
            skip = True
        else:
            out.append(a)
    return out


def _silence_stdout() -> None:
    """Point stdout at /dev/null so that the interpreter's last flush cannot fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass
