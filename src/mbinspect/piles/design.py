"""Pile designs: the positions or spacings a jacket was built to, read from CSV and matched.

A design gives pile positions (``id,x,y``) or pile-pair spacings (``a,b,distance``);
:func:`match_design` gives each measured pile its design id (one-to-one nearest matching).

Examples
--------
>>> d = Design(positions={1: (0.0, 0.0), 2: (22.0, 0.0)})
>>> d.spacing(1, 2)
22.0
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import FileAccessError, InputError

__all__ = ["Design", "read_design", "searched_tilt"]


@dataclass(frozen=True)
class Design:
    """A design: pile positions (id -> x, y) or pile-pair spacings ((a, b) -> distance), the
    jacket (group) of each pile id when the design file has a ``group`` column, and each
    pile's top elevation (m, the survey's vertical reference) with a ``top`` or ``cutoff``
    column, and each raked pile's designed lean (``tilts``: id -> (degrees from vertical,
    the bearing its top leans toward)) with ``tilt_deg`` or ``rake`` and ``tilt_azimuth_deg``."""

    positions: dict[int, tuple[float, float]] = field(default_factory=dict)
    spacings: dict[tuple[int, int], float] = field(default_factory=dict)
    source: str | None = None
    groups: dict[int, int] = field(default_factory=dict)
    tops: dict[int, float] = field(default_factory=dict)
    tilts: dict[int, tuple[float, float]] = field(default_factory=dict)

    @property
    def rake_deg(self) -> float:
        """The largest designed lean (degrees from vertical; 0 for a design of plumb piles)."""
        return max((float(t) for t, _ in self.tilts.values()), default=0.0)

    def spacing(self, a: int, b: int) -> float | None:
        """The design distance between piles ``a`` and ``b`` (m), or None if not designed."""
        if self.positions:
            if a in self.positions and b in self.positions:
                (xa, ya), (xb, yb) = self.positions[a], self.positions[b]
                return math.hypot(xa - xb, ya - yb)
            return None
        return self.spacings.get((min(a, b), max(a, b)))


def read_design(path: str | Path) -> Design:
    """Read a design CSV: ``[group,]id,x,y[,top][,tilt_deg|rake,tilt_azimuth_deg]`` (positions
    and top elevations, m; ``cutoff`` for ``top`` too; a raked pile's lean from vertical in
    degrees, or as its rake 1:N with ``0`` for plumb, and the bearing its top leans toward,
    degrees clockwise from north) or ``a,b,distance`` (spacings, m).

    A header row is required; ``#`` lines and blank lines are skipped.

    Parameters
    ----------
    path : path-like
        The design file.

    Returns
    -------
    Design

    Raises
    ------
    FileAccessError
        No such file, or a folder.
    InputError
        A bad row; the message names the line and column.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "design.csv"
    >>> _ = f.write_text("id,x,y\\n1,0,0\\n2,22,0\\n")
    >>> read_design(f).spacing(1, 2)
    22.0
    """
    p = Path(path)
    if not p.exists():
        raise FileAccessError(f"{p}: no such file")
    if p.is_dir():
        raise FileAccessError(f"{p}: is a directory, expected a design CSV")
    rows: list[tuple[int, list[str]]] = []
    with open(p, newline="", encoding="utf-8-sig") as fh:  # Excel's "CSV UTF-8" starts with a BOM
        for lineno, row in enumerate(csv.reader(fh), start=1):
            cells = [c.strip() for c in row]
            if not any(cells) or cells[0].startswith("#"):
                continue
            rows.append((lineno, cells))
    if not rows:
        raise InputError(f"{p}: the design file is empty")
    header = [h.lower() for h in rows[0][1]]
    body = rows[1:]
    if not body:
        raise InputError(f"{p}: the design file has a header but no rows")
    if {"id", "x", "y"} <= set(header):
        return _positions(p, header, body)
    if {"a", "b", "distance"} <= set(header):
        cols = [header.index(c) for c in ("a", "b", "distance")]
        spacings: dict[tuple[int, int], float] = {}
        for lineno, cells in body:
            v = _design_row(p, lineno, cells, cols, header, n_ids=2)
            a, b, d = int(v[0]), int(v[1]), v[2]
            if a == b:
                raise InputError(f"{p}, line {lineno}: a spacing from pile {a} to itself")
            if not d > 0:
                raise InputError(f"{p}, line {lineno}: distance {d} must be positive")
            spacings[(min(a, b), max(a, b))] = float(d)
        return Design(spacings=spacings, source=str(p))
    raise InputError(
        f"{p}, line {rows[0][0]}: header {rows[0][1]} has neither id,x,y nor a,b,distance"
    )


def _positions(p: Path, header: list[str], body: list[tuple[int, list[str]]]) -> Design:
    """A design of positions: ``[group,]id,x,y[,top|cutoff][,tilt_deg|rake,tilt_azimuth_deg]``."""
    grouped = "group" in header
    top_col = next((c for c in ("top", "cutoff") if c in header), None)
    lean = _lean_columns(p, header)
    names = (("group",) if grouped else ()) + ("id", "x", "y") + ((top_col,) if top_col else ()) + lean
    cols = [header.index(c) for c in names]
    positions: dict[int, tuple[float, float]] = {}
    groups: dict[int, int] = {}
    tops: dict[int, float] = {}
    tilts: dict[int, tuple[float, float]] = {}
    for lineno, cells in body:
        v = _design_row(p, lineno, cells, cols, header, n_ids=2 if grouped else 1)
        if grouped:
            groups[int(v[1])] = int(v[0])
            v = v[1:]
        pid, x, y = int(v[0]), v[1], v[2]
        if pid in positions:
            raise InputError(f"{p}, line {lineno}: pile id {pid} appears twice")
        positions[pid] = (x, y)
        if top_col:
            tops[pid] = v[3]
        if lean:
            tilt = _tilt(p, lineno, header, lean[0], v[-2])
            if tilt > 0:
                tilts[pid] = (tilt, v[-1] % 360.0)
    return Design(positions=positions, source=str(p), groups=groups, tops=tops, tilts=tilts)


def _lean_columns(p: Path, header: list[str]) -> tuple[str, ...]:
    """The design's lean columns: ``(tilt_deg | rake, tilt_azimuth_deg)``, or none."""
    given = [c for c in ("tilt_deg", "rake") if c in header]
    if len(given) > 1:
        raise InputError(f"{p}: has both tilt_deg and rake; expected one way of giving a pile's lean")
    if given and "tilt_azimuth_deg" not in header:
        raise InputError(f"{p}: has {given[0]} but no tilt_azimuth_deg; expected the bearing each "
                         "raked pile's top leans toward (degrees clockwise from north)")
    if not given and "tilt_azimuth_deg" in header:
        raise InputError(f"{p}: has tilt_azimuth_deg but no tilt_deg or rake column")
    return (given[0], "tilt_azimuth_deg") if given else ()


def _tilt(p: Path, lineno: int, header: list[str], col: str, value: float) -> float:
    """A lean from vertical (degrees) from a ``tilt_deg`` or a ``rake`` (1:N) value."""
    where = f"{p}, line {lineno}, column {header.index(col) + 1} ({col})"
    if col == "rake":
        if value != 0 and value < 1:
            raise InputError(f"{where}: {value:g}; expected a rake 1:N with N >= 1, or 0 for a plumb pile")
        return math.degrees(math.atan(1.0 / value)) if value else 0.0
    if not 0 <= value < 45:
        raise InputError(f"{where}: {value:g}; expected a lean from vertical of 0 to 45 degrees")
    return value


def _design_row(p: Path, lineno: int, cells: list[str], cols: list[int], header: list[str],
                *, n_ids: int) -> list[float]:
    """The numbers of one design row; the first ``n_ids`` must be whole (pile ids)."""
    if len(cells) < len(header):
        raise InputError(f"{p}, line {lineno}: {len(cells)} values, expected {len(header)}")
    out: list[float] = []
    for k, c in enumerate(cols):
        text = cells[c]
        try:
            v = float(text)
        except ValueError:
            raise InputError(
                f"{p}, line {lineno}, column {c + 1} ({header[c]}): {text!r} is not a number"
            ) from None
        if not math.isfinite(v):
            raise InputError(f"{p}, line {lineno}, column {c + 1}: {text!r} is not finite")
        if k < n_ids and v != int(v):
            raise InputError(
                f"{p}, line {lineno}, column {c + 1} ({header[c]}): pile id {text!r} "
                "is not a whole number"
            )
        out.append(v)
    return out


def searched_tilt(options: Any, design: Design | None) -> Any:
    """``options`` with ``max_tilt_deg`` counted beyond the design's largest rake: a pile
    raked 14° that leans 2° more is a pile leaning anew, not something that is no pile (a
    design of plumb piles, or none, leaves the options as they are)."""
    rake = 0.0 if design is None else design.rake_deg
    return options if rake <= 0 else options.replace(max_tilt_deg=options.max_tilt_deg + rake)
