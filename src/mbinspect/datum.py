"""The vertical reference of the soundings: the water level at each ping's time from a tide
series and a fixed offset, added to the heights the files give.

A sonar file's heights are what its maker computed: KMALL and .all give them from the water
level at the time of each ping (the transducer's draft and heave applied, no tide); a GSF
gives what its correctors applied; an export gives whatever it was exported with. Nothing is
said about clearance or a level against a chart until the reference is stated: ``--tide``
(the water level above chart datum, by UTC time) and ``--datum-offset`` (a fixed height to
add, e.g. a separation the survey's report gives) say it, and each result records it under
``parameters["vertical_reference"]``.

Examples
--------
>>> import numpy as np, tempfile, pathlib
>>> f = pathlib.Path(tempfile.mkdtemp()) / "tide.csv"
>>> _ = f.write_text("time,height\\n2024-05-01T10:00:00Z,1.20\\n2024-05-01T11:00:00Z,1.50\\n")
>>> tide = read_tide(f)
>>> float(tide.at(np.array([tide.times[0] + 1800.0]), "x.kmall")[0])
1.35
"""

from __future__ import annotations

import datetime as dt
import functools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .checks import csv_rows
from .errors import InputError, ParameterError
from .formats.ascii_sniff import parse_time

__all__ = ["Tide", "read_tide", "VerticalReference", "vertical_reference", "as_given"]

#: What the heights are when nothing is said of them.
AS_GIVEN = ("as the files give them (KMALL and .all: from the water level at each ping's time, no tide; "
            "GSF: what its correctors applied; exports: as exported)")


def _utc(t: float) -> str:
    return dt.datetime.fromtimestamp(t, dt.UTC).isoformat(timespec="seconds").replace("+00:00", "Z")


@dataclass(frozen=True, eq=False)
class Tide:
    """A series of water levels (m above chart datum) at UTC times (s since 1970), rising
    in time, from ``source``."""

    times: np.ndarray
    heights: np.ndarray
    source: str

    def at(self, times: np.ndarray, where: str) -> np.ndarray:
        """The water level at each time, interpolated linearly.

        Raises
        ------
        InputError
            A time outside the series (``where`` names the soundings' file).
        """
        t = np.asarray(times, np.float64)
        if not np.isfinite(t).all():
            raise InputError(f"{where}: {int((~np.isfinite(t)).sum()):,} soundings have no time; the tide "
                             f"{self.source} is applied by time")
        lo, hi = float(t.min()), float(t.max())
        if lo < self.times[0] or hi > self.times[-1]:
            raise InputError(f"{where}: soundings from {_utc(lo)} to {_utc(hi)}; the tide {self.source} "
                             f"covers {_utc(self.times[0])} to {_utc(self.times[-1])}, expected it to cover "
                             "every sounding's time")
        return np.interp(t, self.times, self.heights)


@functools.lru_cache(maxsize=8)
def read_tide(path: str | Path) -> Tide:
    """Read a tide CSV: a header naming ``time`` and ``height`` (or ``tide``, ``level``),
    times as ISO 8601 (UTC unless they say otherwise) or seconds since 1970, heights in
    metres above chart datum, rising in time; ``#`` lines and blank lines skipped.

    Raises
    ------
    FileAccessError
        No such file.
    InputError
        A bad row (the message names the line and column), fewer than two rows, or times
        that do not rise.
    """
    p = Path(path)
    head, rows = csv_rows(p, "tide file", "a tide CSV: a header time,height and rows")
    hcol = next((head.index(n) for n in ("height", "tide", "level", "water_level") if n in head), None)
    if "time" not in head or hcol is None:
        raise InputError(f"{p}, line {rows[0][0]}: header {rows[0][1]}; expected columns time and height")
    tcol = head.index("time")
    times, heights = [], []
    for lineno, cells in rows[1:]:
        if len(cells) <= max(tcol, hcol):
            raise InputError(f"{p}, line {lineno}: {len(cells)} values, expected {len(head)}")
        try:
            times.append(parse_time(cells[tcol]))
        except ValueError:
            raise InputError(f"{p}, line {lineno}, column {tcol + 1} (time): {cells[tcol]!r} is not a time; "
                             "expected ISO 8601 (2024-05-01T10:00:00Z) or seconds since 1970") from None
        try:
            h = float(cells[hcol])
        except ValueError:
            h = math.nan
        if not math.isfinite(h):
            raise InputError(f"{p}, line {lineno}, column {hcol + 1} ({head[hcol]}): {cells[hcol]!r} is not "
                             "a height; expected metres above chart datum")
        heights.append(h)
    if len(times) < 2:
        raise InputError(f"{p}: {len(times)} tide row(s); expected at least two to interpolate between")
    t = np.array(times)
    back = np.flatnonzero(np.diff(t) <= 0)
    if len(back):
        k = int(back[0]) + 1
        raise InputError(f"{p}, line {rows[k + 1][0]}, column {tcol + 1} (time): {rows[k + 1][1][tcol]!r} "
                         "does not follow the row before; expected times rising")
    return Tide(t, np.array(heights), str(p))


@dataclass(frozen=True)
class VerticalReference:
    """What is added to every sounding's height: the tide at its time and a fixed offset.

    Attributes
    ----------
    tide : str or None
        The tide CSV (:func:`read_tide`).
    offset : float or None
        Metres added to every height; given as 0, it states that the files' heights are
        already on the datum wanted.
    """

    tide: str | None = None
    offset: float | None = None

    def __post_init__(self) -> None:
        if self.offset is not None and not math.isfinite(self.offset):
            raise ParameterError(f"datum_offset: {self.offset!r}; expected a finite height in metres",
                                 option="datum_offset")

    @property
    def stated(self) -> bool:
        """Whether a reference was stated (a tide or an offset was given)."""
        return self.tide is not None or self.offset is not None

    def apply(self, z: np.ndarray, fields: dict[str, Any], where: str) -> np.ndarray:
        """The heights ``z`` on this reference (``fields["time"]`` gives each one's time).

        Raises
        ------
        InputError
            A tide with soundings that carry no time, or times it does not cover.
        """
        out = np.asarray(z, np.float64) + (self.offset or 0.0)
        if self.tide is not None:
            if "time" not in fields:
                raise InputError(f"{where}: the soundings carry no time; the tide {self.tide} is applied by "
                                 "each sounding's time (sonar files and ASCII with a time column carry it)")
            out = out + read_tide(self.tide).at(fields["time"], where)
        return out

    def describe(self) -> str:
        """One line for reports: what the heights are."""
        if not self.stated:
            return "heights " + AS_GIVEN
        parts = ["the files' heights"]
        if self.tide is None and not self.offset:
            return "stated datum: the files' heights, stated to be on it (--datum-offset 0)"
        if self.tide is not None:
            parts.append(f"the tide of {self.tide} (water level above chart datum, by each sounding's "
                         "UTC time)")
        if self.offset:
            parts.append(f"{self.offset:+.3f} m")
        return ("chart datum: " if self.tide is not None else "stated datum: ") + " + ".join(parts)

    def to_dict(self) -> dict[str, Any]:
        """What ``parameters["vertical_reference"]`` records."""
        return {"tide": self.tide, "offset": self.offset, "stated": self.stated, "text": self.describe()}


def vertical_reference(tide: str | Path | None = None, offset: float | None = None) -> VerticalReference:
    """The reference of ``--tide`` and ``--datum-offset``; the tide file is read (and checked)
    now."""
    ref = VerticalReference(None if tide is None else str(tide), None if offset is None else float(offset))
    if ref.tide is not None:
        read_tide(ref.tide)
    return ref


def as_given() -> VerticalReference:
    """No reference stated: heights as the files give them."""
    return VerticalReference()
