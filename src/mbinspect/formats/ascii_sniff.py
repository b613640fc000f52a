"""What an ASCII export holds, from its first lines: the delimiter, the decimal mark, the
header's names (with their units stripped), the columns to keep and whether it is
geographic. The rows are parsed by :mod:`.ascii_parse`."""

from __future__ import annotations

import datetime as dt
import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import InputError, ParameterError

__all__ = ["ALIASES", "DELIMITERS", "DEPTH_NAMES", "ELEVATION_NAMES", "TEXT_NAMES", "AsciiTable",
           "parse_columns", "sniff", "parse_time", "split_cells", "is_number"]


#: Header names understood, mapped to the canonical field names.
ALIASES: dict[str, str] = {
    "x": "x", "easting": "x", "east": "x", "e": "x", "lon": "lon", "long": "lon", "longitude": "lon",
    "y": "y", "northing": "y", "north": "y", "n": "y", "lat": "lat", "latitude": "lat",
    "z": "z", "elevation": "z", "height": "z", "h": "z", "depth": "z", "d": "z",
    "intensity": "intensity", "backscatter": "intensity", "bs": "intensity",
    "amplitude": "intensity", "reflectivity": "intensity", "i": "intensity",
    "beam_angle": "beam_angle", "angle": "beam_angle", "beam": "beam", "beam_number": "beam",
    "scan_angle": "beam_angle",
    "line": "line", "line_id": "line", "linename": "line", "line_name": "line",
    "ping": "ping", "ping_id": "ping", "ping_number": "ping",
    "classification": "classification", "class": "classification",
    "time": "time", "datetime": "time", "timestamp": "time", "date": "date",
}

#: Columns of text a header may name: read as times (a ``date`` column joins the ``time``).
TEXT_NAMES = ("time", "date")


DEPTH_NAMES = {"depth", "d"}


ELEVATION_NAMES = {"elevation", "height", "h"}


#: Delimiters ``delimiter=`` accepts and the character each stands for (None: whitespace).
DELIMITERS: dict[str, str | None] = {",": ",", ";": ";", "tab": "\t", "\t": "\t", "space": None,
                                     " ": None, "whitespace": None}


_DECIMAL_COMMA = re.compile(r"^-?\d+,\d+$")


_UNITS = re.compile(r"\s*[\(\[].*?[\)\]]\s*")


@dataclass(frozen=True)
class AsciiTable:
    """How an ASCII file is laid out (found by :func:`sniff`).

    ``names`` holds the field of each column (None: skipped); ``header`` the header's own
    names, if any; ``geographic`` whether the x and y columns are longitude and latitude
    (by their header names); ``z_name`` the header's name of the z column.
    """

    delimiter: str | None
    decimal: str
    quoted: bool
    names: list[str | None]
    ncols: int
    trailing: bool
    data_start: int
    first_line: int
    header: list[str] | None
    geographic: bool
    z_name: str | None
    count: int | None


def parse_columns(spec: str | Sequence[str]) -> list[str | None]:
    """Parse a column map such as ``"x,y,z,intensity"`` or ``"x,y,-,depth"``.

    ``-`` (or ``skip``) skips a column: it is never parsed. Names are the canonical fields
    or any alias (``easting``, ``backscatter``, ``lat``, ``time`` ...); other names are kept
    as extra fields.

    Parameters
    ----------
    spec : str or sequence of str
        Comma-separated names, one per column.

    Returns
    -------
    list of str or None
        The field of each column; None for a skipped one.

    Raises
    ------
    ParameterError
        Not exactly one x, y and z (or lon and lat), or a name twice (``option="columns"``).

    Examples
    --------
    >>> parse_columns("easting,northing,-,depth")
    ['x', 'y', None, 'z']
    """
    items = spec.split(",") if isinstance(spec, str) else list(spec)
    out: list[str | None] = []
    for raw in items:
        name = raw.strip().lower()
        out.append(None if name in ("-", "skip", "_", "") else ALIASES.get(name, name))
    present = [c for c in out if c is not None]
    geographic = "lon" in present or "lat" in present
    for axis in (("lon", "lat", "z") if geographic else ("x", "y", "z")):
        if present.count(axis) != 1:
            raise ParameterError(f"columns: {','.join(items)!r}; expected exactly one {axis!r} column",
                                 option="columns")
    dup = {c for c in present if present.count(c) > 1}
    if dup:
        raise ParameterError(f"columns: {sorted(dup)[0]!r} named twice; expected each column once",
                             option="columns")
    return out


def split_cells(line: str, delimiter: str | None) -> list[str]:
    if delimiter is None:
        return line.split()
    return [c.strip() for c in line.split(delimiter)]


def is_number(token: str, decimal: str = ".") -> bool:
    t = token.strip().strip('"').strip("'")
    if decimal == ",":
        t = t.replace(",", ".")
    try:
        float(t)
    except ValueError:
        return False
    return True


def _header_name(cell: str) -> str:
    """A header cell without quotes and units: ``"Easting (m)"`` -> ``easting``."""
    name = _UNITS.sub(" ", cell.strip().strip('"').strip("'")).strip().lower()
    return name.replace(" ", "_")


def _guess_delimiter(line: str) -> tuple[str | None, str]:
    """Delimiter and decimal mark of a first line (semicolons first: decimal commas)."""
    if ";" in line:
        return ";", "," if any(_DECIMAL_COMMA.match(c.strip().strip('"')) for c in line.split(";")) else "."
    if "\t" in line:
        cells = line.split("\t")
        return None, "," if any(_DECIMAL_COMMA.match(c.strip()) for c in cells) else "."
    if "," in line:
        cells = line.split()
        # "554845,028 4179000,717 -10,983": whitespace columns of decimal-comma numbers
        if len(cells) >= 3 and all(_DECIMAL_COMMA.match(c) for c in cells):
            return None, ","
        return ",", "."
    return None, "."


#: No line of a point file is this long: a longer one is binary data or not a point file.
_LONGEST_LINE = 2**20


def _lines(path: Path, fh: Any) -> Iterator[bytes]:
    """The file's lines, refusing binary data (a NUL in its first MB) and a line longer than
    :data:`_LONGEST_LINE` (a 1 GB file of zeros once took 10 GB to be told it held no data)."""
    nul = fh.read(_LONGEST_LINE).find(b"\0")
    if nul >= 0:
        raise InputError(f"{path}, byte {nul}: a NUL byte (binary data); expected an ASCII point file")
    fh.seek(0)
    for lineno, raw in enumerate(iter(lambda: fh.readline(_LONGEST_LINE), b""), 1):
        if len(raw) == _LONGEST_LINE and not raw.endswith(b"\n"):
            raise InputError(f"{path}, line {lineno}: over {_LONGEST_LINE // 2**20} MB without a line end; "
                             "expected lines of points")
        yield raw


def sniff(path: Path, columns: str | Sequence[str] | None, delimiter: str | None,
          decimal: str | None = None) -> AsciiTable:
    """The layout of an ASCII point file, from its first lines.

    Parameters
    ----------
    path : Path
    columns : str or sequence, optional
        A column map (:func:`parse_columns`).
    delimiter : str or None
        The delimiter character (None: sniffed).
    decimal : {".", ","}, optional
        The decimal mark (None: sniffed).

    Returns
    -------
    AsciiTable

    Raises
    ------
    InputError
        Naming the line and column: no data, too few columns, a header without x y z, a
        text column not skipped.
    """
    offset, lineno, count = 0, 0, None
    header: list[str] | None = None
    seen_delimiter = delimiter is not None
    mark = decimal
    with open(path, "rb") as fh:
        for raw in _lines(path, fh):
            lineno += 1
            try:
                line = raw.decode("utf-8-sig" if lineno == 1 else "utf-8")
            except UnicodeDecodeError:
                raise InputError(f"{path}, line {lineno}: not text (undecodable bytes); expected an ASCII "
                                 "point file") from None
            stripped = line.strip()
            if not stripped or stripped.startswith("#"):
                offset += len(raw)
                continue
            if header is None and count is None and re.fullmatch(r"\d+", stripped):
                count = int(stripped)  # Leica .pts: the number of points
                offset += len(raw)
                continue
            if not seen_delimiter:
                delimiter, sniffed_mark = _guess_delimiter(stripped)
                mark = mark or sniffed_mark
                seen_delimiter = True
            cells = split_cells(stripped, delimiter)
            trailing = len(cells) > 1 and cells[-1] == ""
            if trailing:
                cells = cells[:-1]
            if header is None and not any(is_number(c, mark or ".") for c in cells if c):
                header = [c.strip().strip('"').strip("'") for c in cells]
                offset += len(raw)
                mark = decimal  # a header shows no decimal mark: the first data line does
                continue
            if mark is None:
                mark = "," if delimiter != "," and any(_DECIMAL_COMMA.match(c.strip().strip('"'))
                                                       for c in cells) else "."
            ncols = len(cells)
            first_cells = cells
            break
        else:
            raise InputError(f"{path}: no data lines (only comments, blank lines or a header)")
    names = _names(path, lineno, ncols, columns, header, leica=count is not None)
    quoted = any(c.startswith('"') for c in first_cells)
    for k, (name, cell) in enumerate(zip(names, first_cells, strict=True)):
        if name is not None and name not in TEXT_NAMES and not is_number(cell, mark or "."):
            raise InputError(f"{path}, line {lineno}, column {k + 1}: {cell!r} is not a number; give "
                             "`columns` with '-' for a text column (e.g. -,x,y,z)")
    header_names = [_header_name(h) for h in header] if header else None
    geographic = "lon" in names or "lat" in names
    z_col = names.index("z")
    z_name = header_names[z_col] if header_names else None
    return AsciiTable(delimiter, mark or ".", quoted, names, ncols, trailing, offset, lineno, header,
                      geographic, z_name, count)


def _names(path: Path, lineno: int, ncols: int, columns: str | Sequence[str] | None,
           header: list[str] | None, leica: bool = False) -> list[str | None]:
    """What each column holds: from ``columns``, the header or the column count."""
    names: list[str | None]
    if columns is not None:
        names = parse_columns(columns)
        if len(names) != ncols:
            raise InputError(f"{path}, line {lineno}: {ncols} columns, but `columns` names {len(names)}")
        return names
    if header is not None:
        if len(header) != ncols:
            raise InputError(f"{path}, line {lineno}: {ncols} columns, but the header names {len(header)}")
        names = [ALIASES.get(_header_name(h), _header_name(h)) for h in header]
        geographic = "lon" in names or "lat" in names
        missing = [a for a in (("lon", "lat", "z") if geographic else ("x", "y", "z")) if a not in names]
        if missing:
            raise InputError(f"{path}, header: no column for {', '.join(missing)} in {header}; name them "
                             "(x,y,z / easting,northing,depth / lon,lat,depth) or give `columns`")
        return names
    if ncols == 3:
        return ["x", "y", "z"]
    if ncols == 4:
        return ["x", "y", "z", "intensity"]
    if ncols == 7 and leica:  # Leica PTS: a count line, then x y z intensity red green blue
        return ["x", "y", "z", "intensity", "red", "green", "blue"]
    if ncols < 3:
        raise InputError(f"{path}, line {lineno}: {ncols} column{'s' if ncols != 1 else ''}; expected at "
                         "least 3 (x y z)")
    raise InputError(f"{path}, line {lineno}: {ncols} columns and no header; give `columns` (e.g. "
                     "x,y,z,intensity,-) to say which is which")


def parse_time(text: str | bytes) -> float:
    """Seconds since 1970 (UTC) of an ISO 8601 or MB-System (``YYYY/MM/DD/HH/MM/SS.ssssss``) time.

    Parameters
    ----------
    text : str or bytes

    Returns
    -------
    float

    Examples
    --------
    >>> parse_time("2015-07-08T23:52:15+00:00") == parse_time("2015/07/08/23/52/15.000000")
    True
    >>> parse_time("2015-07-08") + parse_time("23:52:15.000000") == parse_time("2015-07-08T23:52:15")
    True
    >>> parse_time("1436399535.250000")  # seconds since 1970, as mbinspect writes them
    1436399535.25
    """
    s = text.decode() if isinstance(text, bytes) else text
    s = s.strip().strip('"')
    if re.fullmatch(r"[-+]?\d+(\.\d*)?([eE][-+]?\d+)?", s):  # seconds since 1970, as mbinspect writes them
        return float(s)
    if re.fullmatch(r"\d{1,2}:\d{2}(:\d{2}(\.\d*)?)?", s):  # a time of day, its date in a date column
        h, m, *rest = s.split(":")
        return int(h) * 3600.0 + int(m) * 60.0 + (float(rest[0]) if rest else 0.0)
    parts = s.split("/")
    if len(parts) == 6:
        sec = float(parts[5])
        t = dt.datetime(int(parts[0]), int(parts[1]), int(parts[2]), int(parts[3]), int(parts[4]),
                        tzinfo=dt.UTC)
        return t.timestamp() + sec
    t = dt.datetime.fromisoformat(s.replace("Z", "+00:00"))
    if t.tzinfo is None:
        t = t.replace(tzinfo=dt.UTC)
    return t.timestamp()
