"""ASCII point files as survey software writes them.

Whitespace, comma, semicolon or tab delimited; an optional header whose names may carry
units (``Easting (m)``, ``X [m]``) and quotes; ``#`` comment lines (a ``#`` inside a line
is an error, not a comment); CR, LF or CRLF line ends; a Leica ``.pts`` point count on the
first line; decimal commas (``554845,028;4179000,717;-10,983``, detected, or
``decimal=","``); text columns (times, dates, DMS positions) anywhere, which are never parsed
when skipped (``-`` in ``columns``) and, for a column named ``time`` (ISO 8601 or
MB-System's ``YYYY/MM/DD/HH/MM/SS.ssssss``), kept as seconds since 1970. Large files are
parsed in chunks of :data:`CHUNK_BYTES` by worker processes that die with their parent; the
chunks' rows are copied into the final arrays as they come, so a read holds about the
parsed values once (plus a chunk per worker), never the whole text.

What the columns hold comes from ``columns``, else the header, else the column count (3: x
y z; 4: x y z intensity). A header naming latitude and longitude says the file is
geographic; so do values within degree ranges spanning less than a degree without a
header (the caller projects them).
"""

from __future__ import annotations

import datetime as dt
import io as _io
import math
import os
import re
import tempfile
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import InputError, ParameterError

__all__ = ["ALIASES", "DELIMITERS", "AsciiTable", "parse_columns", "read_ascii"]

#: Header names understood, mapped to the canonical field names.
ALIASES: dict[str, str] = {
    "x": "x", "easting": "x", "east": "x", "e": "x", "lon": "lon", "long": "lon", "longitude": "lon",
    "y": "y", "northing": "y", "north": "y", "n": "y", "lat": "lat", "latitude": "lat",
    "z": "z", "elevation": "z", "height": "z", "h": "z", "depth": "z", "d": "z",
    "intensity": "intensity", "backscatter": "intensity", "bs": "intensity",
    "amplitude": "intensity", "reflectivity": "intensity", "i": "intensity",
    "beam_angle": "beam_angle", "angle": "beam_angle", "beam": "beam_angle",
    "scan_angle": "beam_angle",
    "line": "line", "line_id": "line", "linename": "line", "line_name": "line",
    "ping": "ping", "ping_id": "ping", "ping_number": "ping",
    "classification": "classification", "class": "classification",
    "time": "time", "datetime": "time", "timestamp": "time",
}
DEPTH_NAMES = {"depth", "d"}
ELEVATION_NAMES = {"elevation", "height", "h"}

#: Delimiters ``delimiter=`` accepts and the character each stands for (None: whitespace).
DELIMITERS: dict[str, str | None] = {",": ",", ";": ";", "tab": "\t", "\t": "\t", "space": None,
                                     " ": None, "whitespace": None}

#: Files are parsed this many bytes of text at a time; a file of more than one chunk is
#: parsed by worker processes (one per core, at most :data:`MAX_WORKERS`).
CHUNK_BYTES = 8 * 2**20
MAX_WORKERS = 8
_DECIMAL_COMMA = re.compile(r"^-?\d+,\d+$")
_COMMENT_LINES = re.compile(rb"(?m)^[ \t]*#[^\n]*\n?")
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


def _split(line: str, delimiter: str | None) -> list[str]:
    if delimiter is None:
        return line.split()
    return [c.strip() for c in line.split(delimiter)]


def _number(token: str, decimal: str = ".") -> bool:
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
        for raw in fh:
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
            mark = mark or "."
            cells = _split(stripped, delimiter)
            trailing = len(cells) > 1 and cells[-1] == ""
            if trailing:
                cells = cells[:-1]
            if header is None and not any(_number(c, mark) for c in cells if c):
                header = [c.strip().strip('"').strip("'") for c in cells]
                offset += len(raw)
                continue
            ncols = len(cells)
            first_cells = cells
            break
        else:
            raise InputError(f"{path}: no data lines (only comments, blank lines or a header)")
    names = _names(path, lineno, ncols, columns, header)
    quoted = any(c.startswith('"') for c in first_cells)
    for k, (name, cell) in enumerate(zip(names, first_cells, strict=True)):
        if name is not None and name != "time" and not _number(cell, mark or "."):
            raise InputError(f"{path}, line {lineno}, column {k + 1}: {cell!r} is not a number; give "
                             "`columns` with '-' for a text column (e.g. -,x,y,z)")
    header_names = [_header_name(h) for h in header] if header else None
    geographic = "lon" in names or "lat" in names
    z_col = names.index("z")
    z_name = header_names[z_col] if header_names else None
    return AsciiTable(delimiter, mark or ".", quoted, names, ncols, trailing, offset, lineno, header,
                      geographic, z_name, count)


def _names(path: Path, lineno: int, ncols: int, columns: str | Sequence[str] | None,
           header: list[str] | None) -> list[str | None]:
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
    """
    s = text.decode() if isinstance(text, bytes) else text
    s = s.strip().strip('"')
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


def _parse_chunk(args: tuple[str, int, int, AsciiTable]) -> np.ndarray | str:
    path, start, stop, table = args
    with open(path, "rb") as fh:
        fh.seek(start)
        data = fh.read(stop - start)
    if b"#" in data:  # a comment is a whole line; a '#' elsewhere stays and is an error
        data = _COMMENT_LINES.sub(b"", data)
    if table.quoted or b'"' in data:
        data = data.replace(b'"', b"")
    if table.decimal == ",":
        data = data.replace(b",", b".")
    use = [k for k, n in enumerate(table.names) if n is not None]
    # every column used: let loadtxt check the column count of every line too
    cols = None if len(use) == table.ncols and not table.trailing else use
    conv: dict[int | str, Callable[[str], float]] = {k: parse_time for k, n in enumerate(table.names)
                                                     if n == "time"}
    try:
        with _quiet_empty():
            arr = np.loadtxt(_io.BytesIO(data), delimiter=table.delimiter, comments=None,
                             dtype=np.float64, ndmin=2, usecols=cols, converters=conv or None,
                             encoding="utf-8")
    except ValueError as exc:
        return str(exc)
    if arr.size == 0:
        return np.empty((0, len(use)))
    if arr.shape[1] != len(use):
        return f"the number of columns changed from {len(use)} to {arr.shape[1]}"
    return arr


@contextmanager
def _quiet_empty() -> Iterator[None]:
    import warnings

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*input contained no data.*")
        yield


def _chunk_bounds(path: Path, start: int, size: int) -> list[tuple[int, int]]:
    """Byte ranges of about ``size`` each from ``start`` to the end, cut at line ends."""
    total = path.stat().st_size
    parts = max(1, -(-(total - start) // size))
    cuts = [start]
    with open(path, "rb") as fh:
        for k in range(1, parts):
            fh.seek(start + (total - start) * k // parts)
            fh.readline()
            cuts.append(max(fh.tell(), cuts[-1]))
    cuts.append(total)
    return [(a, b) for a, b in zip(cuts[:-1], cuts[1:], strict=True) if b > a]


def _data_lines(path: Path, table: AsciiTable) -> Iterator[tuple[int, list[str]]]:
    """Each data line of an ASCII file as (1-based line number, cells); slow, for errors."""
    with open(path, encoding="utf-8", errors="replace") as fh:
        for lineno, line in enumerate(fh, start=1):
            stripped = line.strip()
            if lineno < table.first_line or not stripped or stripped.startswith("#"):
                continue
            cells = _split(stripped, table.delimiter)
            if table.trailing and cells and cells[-1] == "":
                cells = cells[:-1]
            yield lineno, cells


def _locate_error(path: Path, table: AsciiTable) -> str:
    """Describe the first bad line exactly (column count or a non-number)."""
    for lineno, cells in _data_lines(path, table):
        if len(cells) != table.ncols:
            return (f"{path}, line {lineno}: {len(cells)} columns, expected {table.ncols} like the "
                    "lines before")
        for col, (cell, name) in enumerate(zip(cells, table.names, strict=True), start=1):
            if name is None:
                continue
            if name == "time":
                try:
                    parse_time(cell)
                except ValueError:
                    return f"{path}, line {lineno}, column {col}: {cell!r} is not a time"
            elif not _number(cell, table.decimal):
                return f"{path}, line {lineno}, column {col}: {cell!r} is not a number"
    return f"{path}: could not be parsed as a {table.ncols}-column point file"


def _locate_nonfinite(path: Path, table: AsciiTable, row: int) -> str:
    """Name the line and column of the first non-finite value (data row ``row``)."""
    for seen, (lineno, cells) in enumerate(_data_lines(path, table)):
        if seen == row:
            for col, cell in enumerate(cells, start=1):
                if _number(cell, table.decimal) and not math.isfinite(float(cell.replace(",", "."))):
                    return (f"{path}, line {lineno}, column {col}: {cell!r} is not a finite number; "
                            "expected a finite value")
            break
    return f"{path}: data row {row + 1} holds a non-finite value"


def _worker_init() -> None:
    """A reader worker ignores Ctrl-C (the main process handles it and ends the workers)
    and, on Linux, is killed when the main process dies, however it dies."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    # the command line blocks both in its main thread; a worker must die on SIGTERM
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # not Linux: the main process still ends the workers
        pass


@contextmanager
def _parsed(chunks: list[tuple[str, int, int, AsciiTable]]) -> Iterator[Iterator[np.ndarray | str]]:
    """Each chunk parsed, in order: in worker processes when there are several chunks and
    cores. On leaving (an error, an interrupt or the end) the workers are killed at once:
    no worker outlives the read, none prints a traceback."""
    workers = min(os.cpu_count() or 1, MAX_WORKERS, len(chunks))
    if workers < 2:
        yield (_parse_chunk(c) for c in chunks)
        return
    import multiprocessing as mp

    ctx = mp.get_context("fork") if "fork" in mp.get_all_start_methods() else mp.get_context()
    pool = ctx.Pool(workers, initializer=_worker_init)
    try:
        yield pool.imap(_parse_chunk, chunks, chunksize=1)
        pool.close()
    finally:
        pool.terminate()
        pool.join()


@contextmanager
def _lf_lines(path: Path) -> Iterator[Path]:
    """The file itself, or a temporary LF copy of a file with CR-only line ends."""
    with open(path, "rb") as fh:
        head = fh.read(1 << 16)
    if b"\r" not in head or b"\n" in head:
        yield path
        return
    fd, tmp = tempfile.mkstemp(suffix=path.suffix)
    try:
        with os.fdopen(fd, "wb") as out, open(path, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 22), b""):
                out.write(block.replace(b"\r", b"\n"))
        yield Path(tmp)
    finally:
        os.unlink(tmp)


def read_ascii(path: Path, *, columns: str | Sequence[str] | None = None, delimiter: str | None = None,
               decimal: str | None = None, progress: Callable[[float], None] | None = None,
               ) -> tuple[np.ndarray, dict[str, np.ndarray], AsciiTable]:
    """Read an ASCII point file.

    Parameters
    ----------
    path : Path
    columns : str or sequence, optional
        A column map (:func:`parse_columns`).
    delimiter : str, optional
        One of :data:`DELIMITERS`' keys; sniffed when None.
    decimal : {".", ","}, optional
        The decimal mark; sniffed when None.
    progress : callable, optional
        Called with the fraction of the file parsed, after each chunk.

    Returns
    -------
    xyz : ndarray, shape (N, 3)
        As stored: x y z, or longitude latitude z for a geographic file.
    fields : dict of ndarray
    table : AsciiTable
        The layout found.

    Raises
    ------
    InputError
        A malformed file, naming the line and column.
    """
    if delimiter is not None:
        delimiter = DELIMITERS[delimiter.lower()]
    with _lf_lines(path) as lf:
        table = sniff(lf, columns, delimiter, decimal)
        if table.decimal == "," and table.delimiter == ",":
            raise InputError(f"{path}: decimal commas in comma-delimited columns cannot be told apart; "
                             "expected another `delimiter`")
        chunks = [(str(lf), a, b, table) for a, b in _chunk_bounds(lf, table.data_start, CHUNK_BYTES)]
        used = [n for n in table.names if n is not None]
        out = _Columns(used, _line_count(lf, table.data_start), table.geographic)
        with _parsed(chunks) as results:
            for k, r in enumerate(results):
                if isinstance(r, str):
                    raise InputError(_locate_error(lf, table).replace(str(lf), str(path)))
                bad = ~np.isfinite(r).all(axis=1)
                if bad.any():
                    where = _locate_nonfinite(lf, table, out.rows + int(np.flatnonzero(bad)[0]))
                    raise InputError(where.replace(str(lf), str(path)))
                out.add(r)
                if progress is not None:
                    progress((k + 1) / len(chunks))
    if table.count is not None and table.count != out.rows:
        raise InputError(f"{path}, line 1: the file says {table.count} points but holds {out.rows}")
    xyz, cols = out.arrays()
    return xyz, cols, table


def _line_count(path: Path, start: int) -> int:
    """The line ends after ``start`` plus one: at least the data rows (comments and blank
    lines count too), so the columns can be allocated before parsing."""
    n = 1
    with open(path, "rb") as fh:
        fh.seek(start)
        for block in iter(lambda: fh.read(1 << 23), b""):
            n += block.count(b"\n")
    return n


class _Columns:
    """x y z and one array per other field, allocated for at most ``capacity`` rows (pages
    never written are never resident) and filled chunk by chunk as the parsers return
    them, so that the values are held once, not once in chunks and again in the result."""

    def __init__(self, used: list[str], capacity: int, geographic: bool) -> None:
        x, y = ("lon", "lat") if geographic else ("x", "y")
        at = {name: i for i, name in enumerate(used)}
        self._xyz_at = [at[x], at[y], at["z"]]
        self._field_at = {name: i for name, i in at.items() if name not in (x, y, "z")}
        self.xyz = np.empty((capacity, 3))
        self.fields = {name: np.empty(capacity) for name in self._field_at}
        self.rows = 0

    def add(self, part: np.ndarray) -> None:
        start, stop = self.rows, self.rows + len(part)
        self.xyz[start:stop] = part[:, self._xyz_at]
        for name, col in self._field_at.items():
            self.fields[name][start:stop] = part[:, col]
        self.rows = stop

    def arrays(self) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        n = self.rows
        return self.xyz[:n], {name: col[:n] for name, col in self.fields.items()}
