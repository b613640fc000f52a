"""Options as data: one frozen dataclass per pipeline, each option with unit, default and check.

A pipeline's options class (:class:`mbinspect.piles.PileOptions`,
:class:`mbinspect.reefs.ReefOptions`) declares every option once, with :func:`option`:
its default, unit, one line of help and the check of its value. Building an instance
checks every value (a :class:`~mbinspect.errors.ParameterError` names the option by its
library name); ``to_dict()`` is what a result records under ``parameters``; the command
line generates its flags from the same declarations (:func:`add_flags`), so no default or
choice list is written twice.

String options take their choices from one registry, :data:`CHOICES`.

Examples
--------
>>> from dataclasses import dataclass
>>> from mbinspect.options import Options, option
>>> @dataclass(frozen=True)
... class Demo(Options):
...     radius: float = option(1.0, unit="m", help="pile radius", check="positive")
>>> Demo(radius=2.0).to_dict()
{'radius': 2.0}
>>> Demo(radius=-1.0)
Traceback (most recent call last):
...
mbinspect.errors.ParameterError: radius: -1.0; expected a positive finite number
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator
from dataclasses import MISSING, dataclass, field
from typing import Any

from . import checks
from .errors import ParameterError
from .outputs import to_jsonable

__all__ = ["CHOICES", "OptionSpec", "option", "Options", "flag_names", "flag_text", "parse_crop",
           "crop_value"]

#: Every string option's choices, by registry key.
CHOICES: dict[str, tuple[str, ...]] = {
    "pile_method": ("intersection", "centre", "both"),
    "segmentation": ("joint", "paper"),
    "radius_mode": ("auto", "each", "fixed", "free"),
    "pile_weights": ("angle", "file", "none"),
    "axis_mode": ("auto", "free"),
    "reef_method": ("local", "paper"),
    "seabed": ("auto", "plane", "grid"),
    "pile_groups": ("auto", "none"),
    "beam_spacing": ("equidistant", "equiangular"),
    "motion_phase": ("random", "fixed"),
}

Check = Callable[[str, Any], Any]

_CHECKS: dict[str, Check] = {
    "positive": checks.positive,
    "non_negative": checks.non_negative,
    "finite": checks.finite,
    "count": lambda n, v: checks.integer(n, v, minimum=1),
    "whole": lambda n, v: checks.integer(n, v, minimum=0),
    "seed": lambda n, v: checks.integer(n, v, minimum=0, maximum=2**32 - 1),
    "fraction": lambda n, v: checks.within(n, v, 0.0, 1.0, open_lo=True, open_hi=True),
    "angle": lambda n, v: checks.within(n, v, 0.0, 90.0, open_lo=True, open_hi=True, unit="deg"),
    "bool": lambda n, v: _boolean(n, v),
}


def _boolean(name: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise checks.fail(name, value, "true or false")
    return value


@dataclass(frozen=True)
class OptionSpec:
    """How one option is checked, documented and offered on the command line."""

    unit: str = ""
    help: str = ""
    check: str | Check | None = None
    choices: str | None = None
    flag: str | None = None
    cli: bool = True
    kind: type | None = None
    metavar: str | None = None
    parse: Callable[[str], Any] | None = None

    def validate(self, name: str, value: Any) -> Any:
        """``value`` checked (and normalised by the check, for example a crop to a tuple)."""
        if self.choices is not None:
            return checks.one_of(name, value, CHOICES[self.choices])
        if self.check is None:
            return value
        fn = _CHECKS[self.check] if isinstance(self.check, str) else self.check
        out = fn(name, value)
        # keep ints as ints and floats as given: a check only refuses or normalises tuples
        return out if isinstance(out, tuple) else value


def option(default: Any = MISSING, *, unit: str = "", help: str = "", check: str | Check | None = None,
           choices: str | None = None, flag: str | None = None, cli: bool = True,
           kind: type | None = None, metavar: str | None = None,
           parse: Callable[[str], Any] | None = None) -> Any:
    """A dataclass field declaring one option.

    Parameters
    ----------
    default : object
        The default (omit for a required option).
    unit : str
        Unit of the value (``"m"``, ``"deg"``, ``"m²"``) for help and docs.
    help : str
        One line on what the option does.
    check : str or callable, optional
        A named check (``positive``, ``non_negative``, ``count``, ``whole``, ``seed``,
        ``fraction``, ``angle``, ``finite``, ``bool``) or ``f(name, value)`` that raises.
        ``None`` values of an optional option are not checked.
    choices : str, optional
        Key of :data:`CHOICES` for a string option.
    flag : str, optional
        The command-line flag without ``--`` when it differs from the name.
    cli : bool
        Whether the command line offers it.
    kind : type, optional
        The value's type when the default does not show it (a default of None).
    metavar, parse : optional
        Command-line placeholder and parser of the flag's text.

    Returns
    -------
    dataclasses.Field
    """
    spec = OptionSpec(unit, help, check, choices, flag, cli, kind, metavar, parse)
    return field(default=default, metadata={"option": spec})


@dataclass(frozen=True)
class Options:
    """Base of the options classes: checks every value on creation; ``to_dict()``."""

    def __post_init__(self) -> None:
        for f, spec in self.specs():
            value = getattr(self, f.name)
            if value is None and f.default is None:
                continue
            if f.default is MISSING and value is None:
                raise checks.fail(f.name, value, f"a value ({spec.help})")
            object.__setattr__(self, f.name, spec.validate(f.name, value))
        self.check_together()

    def check_together(self) -> None:
        """Checks that involve more than one option; subclasses override it."""

    def replace(self, **changes: Any) -> Any:
        """A copy with ``changes`` (option name -> value), checked again."""
        unknown = sorted(set(changes) - {f.name for f, _ in self.specs()})
        if unknown:
            names = ", ".join(f.name for f, _ in self.specs())
            raise ParameterError(f"{unknown[0]}: not an option; expected one of {names}", option=unknown[0])
        return dataclasses.replace(self, **changes)

    @classmethod
    def from_given(cls, given: dict[str, Any]) -> Any:
        """An instance from the options given by name; a missing required one is named."""
        for f, spec in cls.specs():
            if f.default is MISSING and f.name not in given:
                raise ParameterError(f"{f.name}: missing; expected {spec.help} ({spec.unit})", option=f.name)
        return cls(**given)

    @classmethod
    def specs(cls) -> Iterator[tuple[dataclasses.Field[Any], OptionSpec]]:
        """Every option's field and spec, in declaration order."""
        for f in dataclasses.fields(cls):
            spec = f.metadata.get("option")
            if spec is not None:
                yield f, spec

    def to_dict(self) -> dict[str, Any]:
        """Every option by name, JSON-ready."""
        return {f.name: to_jsonable(self.value_for_json(f.name)) for f, _ in self.specs()}

    def value_for_json(self, name: str) -> Any:
        """An option's value as ``to_dict`` records it; subclasses may expand one."""
        return getattr(self, name)

    @classmethod
    def describe(cls) -> str:
        """A Markdown table of the options: name, unit, default, help."""
        rows = ["| option | unit | default | meaning |", "|---|---|---|---|"]
        for f, spec in cls.specs():
            default = "required" if f.default is MISSING else repr(f.default)
            rows.append(f"| `{f.name}` | {spec.unit} | {default} | {spec.help} |")
        return "\n".join(rows)


# ----------------------------------------------------------------------------- command line


def flag_text(f: dataclasses.Field[Any], spec: OptionSpec) -> str:
    return "--" + (spec.flag or f.name.replace("_", "-"))


def flag_names(cls: type[Options]) -> dict[str, str]:
    """Option name -> command-line flag (``max_slope_deg`` -> ``--max-slope``).

    Parameters
    ----------
    cls : type
        An options class.

    Returns
    -------
    dict
    """
    return {f.name: flag_text(f, spec) for f, spec in cls.specs() if spec.cli}










# ----------------------------------------------------------------------------- crop


def parse_crop(text: str) -> tuple[float, ...]:
    """A crop from its flag text: ``xmin,ymin,xmax,ymax`` or ``x1,y1,x2,y2,x3,y3,...``.

    Parameters
    ----------
    text : str

    Returns
    -------
    tuple of float
    """
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise ParameterError(f"crop: {text!r}; expected a comma-separated list of numbers",
                             option="crop") from None
    return values


def crop_value(name: str, value: Any) -> tuple[Any, ...]:
    """Check a crop and return it as a tuple: a box ``(xmin, ymin, xmax, ymax)`` or a polygon
    of at least 3 vertices ``((x, y), ...)``; a flat list of 6 or more numbers (an even
    count) is a polygon too.

    Parameters
    ----------
    name : str
        Option name for the message.
    value : sequence or ndarray
        4 numbers, (K, 2) vertices or 2 K numbers (m).

    Returns
    -------
    tuple
        ``(xmin, ymin, xmax, ymax)`` or ``((x, y), ...)``.

    Examples
    --------
    >>> crop_value("crop", [0, 0, 4, 0, 0, 3])
    ((0.0, 0.0), (4.0, 0.0), (0.0, 3.0))
    """
    import numpy as np

    try:
        arr = np.asarray(value, np.float64)
    except (TypeError, ValueError):
        raise checks.fail(name, value, "4 numbers (xmin,ymin,xmax,ymax) or a polygon") from None
    if arr.ndim == 1 and len(arr) >= 6 and len(arr) % 2 == 0:
        arr = arr.reshape(-1, 2)
    if not np.isfinite(arr).all():
        raise checks.fail(name, arr.tolist(), "finite coordinates")
    if arr.shape == (4,):
        if not (arr[2] > arr[0] and arr[3] > arr[1]):
            raise checks.fail(name, arr.tolist(), "xmin,ymin,xmax,ymax with xmin < xmax and ymin < ymax")
        return tuple(float(v) for v in arr)
    if arr.ndim == 2 and arr.shape[1] == 2 and len(arr) >= 3:
        return tuple((float(x), float(y)) for x, y in arr)
    raise ParameterError(f"{name}: shape {arr.shape}; expected 4 numbers (xmin,ymin,xmax,ymax) or a "
                         "polygon of at least 3 vertices (x1,y1,x2,y2,x3,y3,...)", option=name)
