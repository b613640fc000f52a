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

import io as _io
import math
import os
import re
import tempfile
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from .ascii_columns import Columns
from .ascii_sniff import (
    DELIMITERS,
    DEPTH_NAMES,
    ELEVATION_NAMES,
    TEXT_NAMES,
    AsciiTable,
    is_number,
    parse_columns,
    parse_time,
    sniff,
    split_cells,
)

__all__ = ["DELIMITERS", "DEPTH_NAMES", "ELEVATION_NAMES", "AsciiTable", "parse_columns", "read_ascii"]



#: Files are parsed this many bytes of text at a time; a file of more than one chunk is
#: parsed by worker processes (one per core, at most :data:`MAX_WORKERS`).
CHUNK_BYTES = 8 * 2**20
MAX_WORKERS = 8
_COMMENT_LINES = re.compile(rb"(?m)^[ \t]*#[^\n]*\n?")




















def _chunk_text(path: str, start: int, stop: int, table: AsciiTable) -> bytes:
    """The bytes ``start:stop`` of ``path``, comment lines, quotes and decimal commas
    taken out."""
    with open(path, "rb") as fh:
        fh.seek(start)
        data = fh.read(stop - start)
    if b"#" in data:  # a comment is a whole line; a '#' elsewhere stays and is an error
        data = _COMMENT_LINES.sub(b"", data)
    if table.quoted or b'"' in data:
        data = data.replace(b'"', b"")
    if table.decimal == ",":
        data = data.replace(b",", b".")
    return data


def _parse_chunk(args: tuple[str, int, int, AsciiTable]) -> np.ndarray | str:
    """A chunk's used columns by :func:`numpy.loadtxt`, or its error."""
    path, start, stop, table = args
    return _parse_text(_chunk_text(path, start, stop, table), table)


def _parse_text(data: bytes, table: AsciiTable) -> np.ndarray | str:
    use = [k for k, n in enumerate(table.names) if n is not None]
    # every column used: let loadtxt check the column count of every line too
    cols = None if len(use) == table.ncols and not table.trailing else use
    conv: dict[int | str, Callable[[str], float]] = {k: parse_time for k, n in enumerate(table.names)
                                                     if n in TEXT_NAMES}
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


def _fill_chunk(args: tuple[tuple[str, int, int, AsciiTable], int, Columns]) -> int | str:
    """A chunk parsed into ``out``'s rows from ``base`` on: by the compiled parser, else
    by :func:`numpy.loadtxt`; the rows written, or the error."""
    from .ascii_fast import parse_numbers

    (path, start, stop, table), base, out = args
    data = _chunk_text(path, start, stop, table)
    rows = parse_numbers(data, table.delimiter, out.slot, out.xyz, out.fields, base)
    if rows is not None:
        return rows
    arr = _parse_text(data, table)
    if isinstance(arr, str):
        return arr
    out.put(arr, base)
    return len(arr)


def _fast(table: AsciiTable) -> bool:
    """Whether the chunks of ``table`` go to the compiled parser first: no text column
    to convert, no empty last field."""
    return not table.trailing and not any(n in TEXT_NAMES for n in table.names if n is not None)


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
            cells = split_cells(stripped, table.delimiter)
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
            if name in TEXT_NAMES:
                try:
                    parse_time(cell)
                except ValueError:
                    return f"{path}, line {lineno}, column {col}: {cell!r} is not a time"
            elif not is_number(cell, table.decimal):
                return f"{path}, line {lineno}, column {col}: {cell!r} is not a number"
    return f"{path}: could not be parsed as a {table.ncols}-column point file"


#: The columns that must hold finite numbers (a field may hold NaN: a beam without backscatter).
COORDINATES = ("x", "y", "z", "lon", "lat")


def _locate_nonfinite(path: Path, table: AsciiTable, row: int) -> str:
    """Name the line and column of the first non-finite value (data row ``row``)."""
    for seen, (lineno, cells) in enumerate(_data_lines(path, table)):
        if seen == row:
            for col, (cell, name) in enumerate(zip(cells, table.names, strict=False), start=1):
                if name in COORDINATES and is_number(cell, table.decimal) and \
                        not math.isfinite(float(cell.replace(",", "."))):
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
def _parsed(chunks: list[tuple[str, int, int, AsciiTable]], out: Columns
            ) -> Iterator[Iterator[np.ndarray | int | str]]:
    """Each chunk parsed, in order: its rows (an array), or the count of rows it wrote
    into ``out`` from its row bound on, or its error. Chunks the compiled parser reads
    are parsed by threads (it releases the GIL) straight into ``out``; others by worker
    processes when there are several chunks and cores. On leaving (an error, an interrupt
    or the end) the workers are stopped at once: none outlives the read, none prints a
    traceback."""
    import multiprocessing as mp

    if chunks and _fast(chunks[0][3]):
        from concurrent.futures import ThreadPoolExecutor

        from ..neighbours import threads

        jobs = [(c, int(base), out) for c, base in zip(chunks, out.bases, strict=True)]
        parsers = ThreadPoolExecutor(max(1, min(threads(), len(chunks))))
        try:
            yield _ahead(parsers, jobs, 2 * threads())
        finally:
            parsers.shutdown(wait=True, cancel_futures=True)
        return
    workers = min(os.cpu_count() or 1, MAX_WORKERS, len(chunks))
    if workers < 2 or mp.current_process().daemon:
        # a daemonic process (a Dask worker, a pool's worker) may not start children: parse
        # here, one chunk after another
        yield (_parse_chunk(c) for c in chunks)
        return

    ctx = mp.get_context("fork") if "fork" in mp.get_all_start_methods() else mp.get_context()
    pool = ctx.Pool(workers, initializer=_worker_init)
    try:
        yield pool.imap(_parse_chunk, chunks, chunksize=1)
        pool.close()
    finally:
        pool.terminate()
        pool.join()


def _ahead(pool: Any, jobs: list[Any], depth: int) -> Iterator[int | str]:
    """Each job's :func:`_fill_chunk` by ``pool``, in order, at most ``depth`` submitted
    ahead of the one taken."""
    from collections import deque

    waiting: deque = deque()
    for job in jobs:
        waiting.append(pool.submit(_fill_chunk, job))
        if len(waiting) > depth:
            yield waiting.popleft().result()
    while waiting:
        yield waiting.popleft().result()


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
        out = Columns(table.names, _row_bounds(chunks), table.geographic)
        with _parsed(chunks, out) as results:
            for k, r in enumerate(results):
                if isinstance(r, str):
                    raise InputError(_locate_error(lf, table).replace(str(lf), str(path)))
                start = out.rows
                out.take(r, k)
                block = out.xyz[start:out.rows]
                if not np.isfinite(block.ravel()).all():  # a field may be NaN, not a coordinate
                    bad = ~np.isfinite(block).all(axis=1)
                    where = _locate_nonfinite(lf, table, start + int(np.flatnonzero(bad)[0]))
                    raise InputError(where.replace(str(lf), str(path)))
                if progress is not None:
                    progress((k + 1) / len(chunks))
    if table.count is not None and table.count != out.rows:
        raise InputError(f"{path}, line 1: the file says {table.count} points but holds {out.rows}")
    xyz, cols = out.arrays()
    if "date" in cols:  # a date column and a time-of-day column: one time
        cols["time"] = cols.pop("date") + cols.get("time", 0.0)
    return xyz, cols, table


def _row_bounds(chunks: list[tuple[str, int, int, AsciiTable]]) -> list[int]:
    """Each chunk's line ends, plus one for a last line without its own: at least the
    chunk's data rows (comments and blank lines count too), so the columns can be
    allocated before parsing. Counted by threads (NumPy's comparison releases the GIL)."""
    from concurrent.futures import ThreadPoolExecutor

    from ..neighbours import threads

    with ThreadPoolExecutor(max(1, min(threads(), len(chunks)))) as pool:
        return list(pool.map(_line_ends, chunks))


def _line_ends(chunk: tuple[str, int, int, AsciiTable]) -> int:
    path, start, stop, _ = chunk
    with open(path, "rb") as fh:
        fh.seek(start)
        data = np.frombuffer(fh.read(stop - start), np.uint8)
    return int(np.count_nonzero(data == 10)) + bool(len(data) and data[-1] != 10)
