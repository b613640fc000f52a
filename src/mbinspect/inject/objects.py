"""The objects put into a survey (piles and reefs of known position) and the files that list them."""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..design_solids import ORIENTATIONS
from ..errors import InputError
from ..reef_designs import BUILTIN_DESIGNS

__all__ = ["InjectedPile", "InjectedReef", "Injection", "read_pile_file", "read_reef_file"]


@dataclass(frozen=True)
class InjectedPile:
    """A pile to inject, in the survey's coordinates (m, elevation up).

    ``top`` is the top centre's elevation; ``height``, when ``top`` is None, the top's
    height above the survey's seabed at the pile (the median elevation around it).
    """

    id: int
    x: float
    y: float
    radius: float
    top: float | None = None
    height: float | None = None
    tilt_deg: float = 0.0
    tilt_azimuth_deg: float = 0.0
    group: int = 1


@dataclass(frozen=True)
class InjectedReef:
    """A reef to inject: a built-in design (``cross2``, ``cross1``, ``hollow``, ``triangle``, ``cube``)
    at (x, y) in the survey's coordinates, turned by ``bearing_deg``, built ``scale`` times
    the design's size, its base ``burial`` m below the survey's seabed there (sunk); at rest
    ``orientation`` (upright, upside down, on its side, on its other side) and leaning
    ``tilt_deg`` toward ``tilt_bearing_deg`` (its lowest corner then sunk ``burial``)."""

    id: int
    x: float
    y: float
    kind: str
    bearing_deg: float = 0.0
    scale: float = 1.0
    burial: float = 0.1
    group: int = 1
    orientation: str = "upright"
    tilt_deg: float = 0.0
    tilt_bearing_deg: float = 0.0


@dataclass(frozen=True, eq=False)
class Injection:
    """An injected survey and its truth.

    Attributes
    ----------
    xyz : ndarray, shape (N, 3)
        The soundings, those on piles moved.
    labels, ident : ndarray (N,)
        What each sounding now hits (:data:`mbinspect.simulate.LABELS`) and the pile or
        reef id.
    truth : dict
        ``piles``, ``spacings`` and ``reefs`` as :func:`mbinspect.simulate.simulate` writes
        them, the counts, and the pings whose geometry could not be estimated.
    """

    xyz: np.ndarray
    labels: np.ndarray
    ident: np.ndarray
    truth: dict[str, Any]

    def to_dict(self) -> dict[str, Any]:
        """The truth (JSON-ready)."""
        return dict(self.truth)


_PILE_COLUMNS = ("id", "x", "y", "radius", "top", "height", "tilt_deg", "tilt_azimuth_deg", "group")
_REEF_COLUMNS = ("id", "x", "y", "kind", "bearing_deg", "scale", "burial", "group", "orientation",
                 "tilt_deg", "tilt_bearing_deg")
_TEXT = ("kind", "orientation")
_POSITIVE = ("radius", "scale")


def _read_rows(path: str | Path, columns: Sequence[str], required: Sequence[str], what: str
               ) -> list[tuple[int, dict[str, Any]]]:
    """The rows of an object CSV, typed (``id`` and ``group`` integers, ``kind`` text, the
    rest numbers), each with its line number; every missing or bad value named by file,
    line and column."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8-sig")
    except OSError as exc:
        raise InputError(f"{p}: cannot read ({exc.strerror})") from None
    reader = csv.DictReader(text.splitlines())
    names = [n.strip().lower() for n in reader.fieldnames or []]
    if set(required) - set(names):
        optional = [c for c in columns if c not in required]
        raise InputError(f"{p}: columns {','.join(names) or '(none)'}; expected {','.join(required)} "
                         f"(optional {','.join(optional)})")
    rows = []
    seen: dict[int, int] = {}
    for line, row in enumerate(reader, start=2):
        vals = {k.strip().lower(): (v or "").strip() for k, v in row.items() if k}
        parsed: dict[str, Any] = {}
        for key in columns:
            raw = vals.get(key, "")
            if raw == "":
                if key in required:
                    raise InputError(f"{p}: line {line}, column {key}: empty; expected a value")
                continue
            try:
                parsed[key] = raw if key in _TEXT else int(raw) if key in ("id", "group") else float(raw)
            except ValueError:
                raise InputError(f"{p}: line {line}, column {key}: {raw!r}; expected "
                                 f"{'an integer' if key in ('id', 'group') else 'a number'}") from None
            wrong = _value_problem(key, parsed[key])
            if wrong:
                raise InputError(f"{p}: line {line}, column {key}: {raw!r}; expected {wrong}")
        first = seen.setdefault(parsed["id"], line)
        if first != line:
            raise InputError(f"{p}: line {line}, column id: {parsed['id']} again (line {first}); expected "
                             f"one row per {what}, each with its own id")
        rows.append((line, parsed))
    if not rows:
        raise InputError(f"{p}: no {what}s; expected a row per {what}")
    return rows


def _value_problem(key: str, value: Any) -> str | None:
    """What a parsed value should have been, or None when it is fine."""
    if isinstance(value, float) and not math.isfinite(value):
        return "a finite number"
    if key in _POSITIVE and not value > 0:
        return "a positive number"
    if key == "burial" and not value >= 0:
        return "a number >= 0 (m sunk)"
    if key == "tilt_deg" and not 0 <= value <= 60:
        return "a lean from 0 to 60 degrees"
    return None


def read_pile_file(path: str | Path) -> list[InjectedPile]:
    """Piles to inject from a CSV: ``id,x,y,radius`` and ``top`` (elevation, m) or ``height``
    (above the seabed, m); optional ``tilt_deg``, ``tilt_azimuth_deg``, ``group``.

    Raises
    ------
    InputError
        A missing column or a bad value, naming the file, line and column.
    """
    piles = []
    for line, parsed in _read_rows(path, _PILE_COLUMNS, ("id", "x", "y", "radius"), "pile"):
        if "top" not in parsed and "height" not in parsed:
            raise InputError(f"{path}: line {line}: no top or height; expected one of them")
        piles.append(InjectedPile(**parsed))
    return piles


def read_reef_file(path: str | Path) -> list[InjectedReef]:
    """Reefs to inject from a CSV: ``id,x,y,kind`` (a built-in design: cross2, cross1,
    hollow, triangle); optional ``bearing_deg``, ``scale`` (as built / design), ``burial``
    (m sunk below the seabed, default 0.1), ``group``, ``orientation`` (upright, upside down,
    on its side, on its other side), ``tilt_deg`` and ``tilt_bearing_deg``.

    Raises
    ------
    InputError
        A missing column or a bad value, naming the file, line and column.
    """
    reefs = []
    for line, parsed in _read_rows(path, _REEF_COLUMNS, ("id", "x", "y", "kind"), "reef"):
        if parsed["kind"] not in BUILTIN_DESIGNS:
            raise InputError(f"{path}: line {line}, column kind: {parsed['kind']!r}; expected one of "
                             f"{', '.join(BUILTIN_DESIGNS)}")
        if parsed.get("orientation", "upright") not in ORIENTATIONS:
            raise InputError(f"{path}: line {line}, column orientation: {parsed['orientation']!r}; expected "
                             f"one of {', '.join(ORIENTATIONS)}")
        reefs.append(InjectedReef(**parsed))
    return reefs
