"""The parser class with one-line errors, the reporter of progress and messages, and the
flags every command shares."""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from typing import Any, NoReturn

from ..errors import MBInspectError


class UsageError(MBInspectError):
    pass


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors (raised, so ``main`` prints them like any other) and
    options matched whole, never by a prefix (``--plan`` is not ``--plane-threshold``; a
    new option must not change what an abbreviation meant)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> NoReturn:
        raise UsageError(f"{self.prog}: {message} (see '{self.prog} --help')")


class Reporter:
    """Progress and messages on stderr, silenced by ``-q``, detailed by ``-v``."""

    def __init__(self, verbosity: int = 0, stream: Any = None) -> None:
        self.verbosity = verbosity
        self.stream = stream if stream is not None else sys.stderr
        self._t0 = time.perf_counter()
        self._last = -1.0

    def info(self, message: str) -> None:
        """A line for the user (not with ``-q``)."""
        if self.verbosity >= 0:
            print(message, file=self.stream, flush=True)

    def debug(self, message: str) -> None:
        """A timed line (``-v`` only)."""
        if self.verbosity > 0:
            print(f"[{time.perf_counter() - self._t0:7.2f} s] {message}", file=self.stream,
                  flush=True)

    def progress(self, label: str) -> Callable[[float], None]:
        """A callback that shows ``label NN %`` for work of more than a second or two."""
        start = time.perf_counter()
        self._last = -1.0
        tty = hasattr(self.stream, "isatty") and self.stream.isatty()

        def update(fraction: float) -> None:
            if self.verbosity < 0 or time.perf_counter() - start < 1.5 and (fraction < 1 or self._last < 0):
                return  # quick work shows nothing, not even its end
            pct = int(100 * fraction)
            step = 1 if tty else 25
            if pct // step == self._last // step and fraction < 1:
                return
            self._last = pct
            end = "\r" if tty and fraction < 1 else "\n"
            print(f"{label}: {pct:3d} %", end=end, file=self.stream, flush=True)

        return update


def add_output(p: argparse.ArgumentParser, default: str) -> None:
    o = p.add_argument_group("output")
    o.add_argument("--out", metavar="DIR", help=f"output folder (default {default})")
    o.add_argument("--overwrite", action="store_true", help="replace an existing --out folder")
    o.add_argument("--no-figures", action="store_true", help="tables and JSON only")


def percent(v: float | None) -> str:
    return "undefined" if v is None else f"{100 * v:.2f} %"


def subcommand(sub: Any, name: str, help: str, description: str, epilog: str) -> argparse.ArgumentParser:
    parser: argparse.ArgumentParser = sub.add_parser(name, help=help, description=description, epilog=epilog,
                                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    return parser
