"""Command-line flags generated from an options class (:mod:`mbinspect.options`): one flag per
option, its unit, default and check written once in the class."""

from __future__ import annotations

import argparse
import dataclasses
import math
from collections.abc import Callable
from dataclasses import MISSING
from typing import Any

from ..options import CHOICES, Options, flag_text


def typed_parser(kind: type, name: str) -> Callable[[str], Any]:
    """An argparse ``type=`` for ``kind`` (int or float) that refuses non-finite numbers.

    Parameters
    ----------
    kind : type
        ``int`` or ``float``.
    name : str
        The option's name.

    Returns
    -------
    callable
        Text -> value; raises ``argparse.ArgumentTypeError`` on bad text.
    """
    def parse(text: str) -> Any:
        try:
            value = kind(text)
        except ValueError:
            what = "whole number" if kind is int else "number"
            raise argparse.ArgumentTypeError(f"{text!r} is not a {what}") from None
        if isinstance(value, float) and not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"{text!r} is not a finite number")
        return value

    parse.__name__ = kind.__name__  # argparse names the type in its messages
    return parse


def _annotated(f: dataclasses.Field[Any]) -> type:
    """The type a field's annotation names first (``"float | None"`` -> float)."""
    name = str(f.type).split("|")[0].strip()
    return {"float": float, "int": int, "bool": bool}.get(name, str)


def add_flags(group: argparse._ArgumentGroup | argparse.ArgumentParser, cls: type[Options], *,
              skip: tuple[str, ...] = (), default_text: str | None = None) -> None:
    """Add one flag per command-line option of ``cls`` to ``group``.

    Every flag's destination is ``opt_<name>`` with default None, so that only the
    options given on the command line override the class's defaults
    (:func:`given_options`). A boolean option becomes ``--flag`` / ``--no-flag``.

    Parameters
    ----------
    group : argparse group or parser
    cls : type
        An options class.
    skip : tuple of str
        Options not to offer.
    default_text : str, optional
        What the help says of every default, where another option sets them (the sonar's
        fields by ``--sonar``); each option's own default otherwise.
    """
    for f, spec in cls.specs():
        if not spec.cli or f.name in skip:
            continue
        default = None if f.default is MISSING else f.default
        kind = spec.kind or (type(default) if default is not None else _annotated(f))
        unit = f" ({spec.unit})" if spec.unit else ""
        shown = "required" if f.default is MISSING else ("none" if default is None else default)
        text = f"{spec.help}{unit}; " + (default_text or ("required" if f.default is MISSING
                                                          else f"default {shown}"))
        flag = flag_text(f, spec)
        dest = f"opt_{f.name}"
        if kind is bool:
            group.add_argument(flag, dest=dest, default=None, action=argparse.BooleanOptionalAction,
                               help=text)
        elif spec.choices is not None:
            group.add_argument(flag, dest=dest, default=None, choices=CHOICES[spec.choices], help=text)
        else:
            parse = _flag_parser(spec.parse) if spec.parse else typed_parser(kind, f.name)
            metavar = spec.metavar or (spec.unit.upper() if spec.unit else kind.__name__.upper())
            group.add_argument(flag, dest=dest, default=None, type=parse, help=text, metavar=metavar)


def given_options(args: argparse.Namespace, cls: type[Options]) -> dict[str, Any]:
    """The options of ``cls`` given on the command line (name -> value).

    Parameters
    ----------
    args : argparse.Namespace
        Parsed with flags from :func:`add_flags`.
    cls : type
        The options class.

    Returns
    -------
    dict
    """
    names = {f.name for f, _ in cls.specs()}
    return {k[4:]: v for k, v in vars(args).items()
            if k.startswith("opt_") and k[4:] in names and v is not None}


def _flag_parser(parse: Callable[[str], Any]) -> Callable[[str], Any]:
    """An option's own text parser as an argparse ``type=``: its error shown on the flag."""
    def flag(text: str) -> Any:
        try:
            return parse(text)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc).split(": ", 1)[-1]) from None

    flag.__name__ = parse.__name__
    return flag
