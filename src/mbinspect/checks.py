"""Input and option checks with one message grammar.

Every check raises :class:`~mbinspect.errors.ParameterError` whose message reads
``"<name>: <value>; expected <what>"`` and whose ``option`` attribute is the option's
library name, so the command line can print the same message under its flag name.

Examples
--------
>>> from mbinspect.checks import positive
>>> positive("radius", 0.75)
0.75
>>> try:
...     positive("radius", -1)
... except ValueError as exc:
...     print(exc)
radius: -1; expected a positive finite number
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from typing import Any

import numpy as np

from .errors import FileAccessError, InputError, NotEnoughPointsError, ParameterError

__all__ = [
    "csv_rows",
    "fail",
    "positive",
    "non_negative",
    "finite",
    "integer",
    "within",
    "one_of",
    "check_points",
    "numbers",
]


def fail(name: str, value: Any, expected: str) -> ParameterError:
    """The error for option ``name`` holding ``value`` where ``expected`` was wanted.

    Parameters
    ----------
    name : str
        The option's library name (``radius``, ``max_sigma``).
    value : object
        The bad value, shown with ``repr`` for strings.
    expected : str
        What a good value is, in words.

    Returns
    -------
    ParameterError
        To raise; its ``option`` attribute is ``name``.
    """
    shown = repr(value) if isinstance(value, str) else value
    return ParameterError(f"{name}: {shown}; expected {expected}", option=name)


def _number(value: Any) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)


def finite(name: str, value: Any) -> float:
    """``value`` as a float when it is a finite number; else a :class:`ParameterError`.

    Parameters
    ----------
    name : str
        Option name for the message.
    value : float

    Returns
    -------
    float
    """
    if not (_number(value) and math.isfinite(float(value))):
        raise fail(name, value, "a finite number")
    return float(value)


def positive(name: str, value: Any) -> float:
    """``value`` as a float when it is a finite number above zero.

    Parameters
    ----------
    name : str
        Option name for the message.
    value : float

    Returns
    -------
    float
    """
    if not (_number(value) and math.isfinite(float(value)) and value > 0):
        raise fail(name, value, "a positive finite number")
    return float(value)


def non_negative(name: str, value: Any) -> float:
    """``value`` as a float when it is a finite number at or above zero.

    Parameters
    ----------
    name : str
        Option name for the message.
    value : float

    Returns
    -------
    float
    """
    if not (_number(value) and math.isfinite(float(value)) and value >= 0):
        raise fail(name, value, "a finite number >= 0")
    return float(value)


def integer(name: str, value: Any, *, minimum: int | None = None, maximum: int | None = None) -> int:
    """``value`` when it is a whole number within ``[minimum, maximum]``.

    Parameters
    ----------
    name : str
        Option name for the message.
    value : int
    minimum, maximum : int, optional
        Bounds, inclusive.

    Returns
    -------
    int

    Examples
    --------
    >>> integer("count", 4, minimum=1)
    4
    """
    if not isinstance(value, (int, np.integer)) or isinstance(value, bool):
        raise fail(name, value, "a whole number")
    if minimum is not None and value < minimum or maximum is not None and value > maximum:
        lo = "" if minimum is None else f">= {minimum}"
        hi = "" if maximum is None else f"<= {maximum}"
        raise fail(name, value, f"a whole number {' and '.join(s for s in (lo, hi) if s)}")
    return int(value)


def within(name: str, value: Any, lo: float, hi: float, *, open_lo: bool = False,
           open_hi: bool = False, unit: str = "") -> float:
    """``value`` when it is a finite number between ``lo`` and ``hi``.

    ``open_lo`` / ``open_hi`` exclude the bound itself.

    Parameters
    ----------
    name : str
        Option name for the message.
    value : float
    lo, hi : float
        The bounds, in the option's unit.
    open_lo, open_hi : bool
        Exclude the bound itself.
    unit : str
        Unit named in the message.

    Returns
    -------
    float
    """
    ok = _number(value) and math.isfinite(float(value))
    if ok:
        v = float(value)
        ok = (v > lo if open_lo else v >= lo) and (v < hi if open_hi else v <= hi)
    if not ok:
        u = f" {unit}" if unit else ""
        raise fail(name, value, f"a number {'>' if open_lo else '>='} {lo:g}{u} and "
                                f"{'<' if open_hi else '<='} {hi:g}{u}")
    return float(value)


def one_of(name: str, value: Any, choices: Collection[str]) -> str:
    """``value`` when it is one of ``choices``.

    Parameters
    ----------
    name : str
        Option name for the message.
    value : str
    choices : collection of str

    Returns
    -------
    str
    """
    if value not in choices:
        raise fail(name, value, f"one of {', '.join(map(str, choices))}")
    return str(value)


def check_points(points: Any, *, minimum: int = 1, name: str = "points") -> np.ndarray:
    """Return ``points`` as ``(N, 3)`` float64 metres, checking shape, finiteness and count.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        x east, y north, z elevation (m).
    minimum : int
        Fewest points the caller can work with.
    name : str
        What the array is called in messages.

    Returns
    -------
    ndarray, shape (N, 3), float64

    Raises
    ------
    ParameterError
        Wrong shape or non-finite values.
    NotEnoughPointsError
        Fewer than ``minimum`` points.

    Examples
    --------
    >>> check_points([[0, 0, -20]]).dtype
    dtype('float64')
    """
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ParameterError(f"{name}: shape {pts.shape}; expected an (N, 3) array", option=name)
    if pts.shape[0] < minimum:
        raise NotEnoughPointsError(f"{name}: {pts.shape[0]} points; expected at least {minimum}")
    # one sum is finite exactly when every value is (short of overflow, which the full
    # test below then settles); it is three times cheaper than testing every value
    if not math.isfinite(float(pts.sum())) and not np.isfinite(pts).all():
        bad = int(np.flatnonzero(~np.isfinite(pts).all(axis=1))[0])
        raise ParameterError(f"{name}: point {bad} is {pts[bad].tolist()}; expected finite "
                             "coordinates", option=name)
    far = beyond_the_earth(pts)
    if far is not None:
        raise ParameterError(f"{name}: point {far} is {pts[far].tolist()}; {EARTH_BOUND_TEXT}", option=name)
    return pts


#: The largest plan coordinate (m) and height (m) a survey on Earth can have in a projected
#: CRS: beyond them a value is corrupt (1e308 made every grid run away), not a position.
MAX_PLAN, MAX_HEIGHT = 1e8, 1e5
EARTH_BOUND_TEXT = (f"expected metres in a projected CRS: x and y within ±{MAX_PLAN:.0e} m, z within "
                    f"±{MAX_HEIGHT:.0e} m")


def beyond_the_earth(points: np.ndarray) -> int | None:
    """The first point whose coordinates no survey on Earth can have, or None.

    Parameters
    ----------
    points : ndarray, shape (N, 3)

    Returns
    -------
    int or None

    Examples
    --------
    >>> beyond_the_earth(np.array([[5e5, 4e6, -10.0], [1e308, 0.0, 0.0]]))
    1
    """
    pts = np.asarray(points, np.float64)
    if not len(pts):
        return None
    # the whole array in one pass bounds the plan (MAX_PLAN is the larger bound), then the
    # heights' column alone: a reduction along the long axis of an (N, 3) array is slow
    every = max(abs(float(pts.min())), abs(float(pts.max())))
    height = max(abs(float(pts[:, 2].min())), abs(float(pts[:, 2].max()))) if every > MAX_HEIGHT else every
    if every <= MAX_PLAN and height <= MAX_HEIGHT:
        return None
    bad = (np.abs(pts[:, :2]) > MAX_PLAN).any(axis=1) | (np.abs(pts[:, 2]) > MAX_HEIGHT)
    return int(np.flatnonzero(bad)[0])


def numbers(name: str, values: Sequence[Any]) -> tuple[float, ...]:
    """Every value of ``values`` as a finite float.

    Parameters
    ----------
    name : str
        Option name for the message.
    values : sequence of float

    Returns
    -------
    tuple of float
    """
    return tuple(finite(name, v) for v in values)


def csv_rows(path: Any, kind: str, expected: str) -> tuple[list[str], list[tuple[int, list[str]]]]:
    """A small CSV table a user gives (a tide, a plan): its header, lower-cased, and its rows
    with their line numbers; blank and ``#`` lines skipped, Excel's BOM read.

    Parameters
    ----------
    path : path-like
    kind : str
        What the file is, for the messages ("tide file").
    expected : str
        What it should hold ("a header time,height and rows").

    Raises
    ------
    FileAccessError
        No such file, or a folder.
    InputError
        No header.
    """
    import csv
    from pathlib import Path

    p = Path(path)
    if not p.is_file():
        raise FileAccessError(f"{p}: no such {kind}" if not p.exists() else f"{p}: is a directory, "
                              f"expected {expected}")
    with open(p, newline="", encoding="utf-8-sig") as fh:
        rows = [(k, [c.strip() for c in r]) for k, r in enumerate(csv.reader(fh), start=1)
                if any(c.strip() for c in r) and not r[0].strip().startswith("#")]
    if not rows:
        raise InputError(f"{p}: the {kind} is empty; expected {expected}")
    return [h.lower() for h in rows[0][1]], rows
