"""Numbers of an ASCII point file parsed in a compiled loop, exactly as NumPy parses them.

:func:`parse_numbers` reads the common case, decimal numbers such as ``402432.620`` or
``-1.5e-3`` in a fixed number of columns, and gives up (returns None) on anything else, so
that the caller parses that chunk with :func:`numpy.loadtxt` as before and reports its
errors the same way. A number is accepted only when it converts exactly: its digits form
an integer ``m`` of at most 2**53 and its decimal exponent ``e`` lies within ±22, so that
``m`` and ``10**|e|`` are both exact doubles and the one multiplication or division between
them is correctly rounded by IEEE arithmetic (Clinger's fast path), the same double a
correctly rounded parser (NumPy's, Python's ``float``) gives. Other numbers (more than 15
or so significant digits, ``nan``, ``inf``), other bytes (controls, non-ASCII) and a line
with a different number of columns make it give up.

Why compiled (numba): ``numpy.loadtxt`` parses about 60 MB of text a second per core; the
3.7 M-sounding field (185 MB of seven columns) took 2.4-2.7 s to read on two cores, more
than the reef chain's largest stage (``benchmarks/RESULTS.md``).
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["parse_numbers"]

_POW10 = np.array([float(10**k) for k in range(23)])
_MAX_EXACT = 2**53


def parse_numbers(data: bytes, delimiter: str | None, slot: np.ndarray, xyz: np.ndarray, fields: np.ndarray,
                  base: int) -> int | None:
    """Parse every line of ``data`` into rows ``base``, ``base + 1``, ... of ``xyz``
    ((N, 3)) and ``fields`` ((F, N)); the number of rows, or None where the fast path
    gives up (see the module's notes; rows may then have been written).

    ``slot[k]`` says where column ``k`` goes: 0-2 the column of ``xyz``, 3 + f the row of
    ``fields``, -1 nowhere (the column is skipped unread). ``delimiter`` None splits on
    spaces and tabs; otherwise fields are split on that one character and may carry spaces
    or tabs around them. Empty lines are skipped; every other line must hold ``len(slot)``
    fields. ``xyz`` and ``fields`` must have room for a row per line of ``data``.
    """
    if delimiter is not None and (len(delimiter) != 1 or ord(delimiter) > 127 or delimiter in " \r\n"):
        return None
    buf = np.frombuffer(data, dtype=np.uint8)
    rows = _parse(buf, -1 if delimiter is None else ord(delimiter), np.asarray(slot, np.int64), xyz, fields,
                  base, _POW10)
    return None if rows < 0 else rows


@numba.njit(cache=True, nogil=True)
def _exponent(buf, i):
    """The exponent after an ``e`` at ``buf[i - 1]`` and the index after it; -1 if none."""
    n = len(buf)
    neg = i < n and buf[i] == 45
    if i < n and (buf[i] == 43 or buf[i] == 45):
        i += 1
    e = 0
    first = i
    while i < n and buf[i] >= 48 and buf[i] <= 57:
        e = min(e * 10 + np.int64(buf[i] - 48), 10000)
        i += 1
    return (-e if neg else e), (i if i > first else -1)


@numba.njit(cache=True, nogil=True)
def _parse(buf, delim, slot, xyz, fields, base, pow10):  # noqa: C901 - one pass over the bytes
    """Rows parsed into ``xyz`` and ``fields``, or -1 to give up."""
    n, ncols = len(buf), len(slot)
    i = row = col = 0  # col: fields so far on this line
    need = gap = blanks = False  # a field just ended; blanks since it; blanks on this line
    while True:
        c = buf[i] if i < n else 10
        if (c == 32 or c == 9) and c != delim:
            gap = blanks = True
            i += 1
        elif c == 10 or c == 13:  # a '\r' must end a line with its '\n'
            if (c == 13 and i + 1 < n and buf[i + 1] != 10) or (col > 0 and (col != ncols or not need)):
                return -1  # a lone '\r', another column count or an empty last field
            if col == 0 and delim >= 0 and blanks:
                return -1  # a line of blanks, which NumPy refuses between delimiters
            row += col > 0
            if i >= n:
                return row
            i += 2 if c == 13 and i + 1 < n else 1
            col, need, gap, blanks = 0, False, False, False
        elif c == delim:
            if not need:
                return -1  # an empty field
            need = False
            i += 1
        elif (need and (delim >= 0 or not gap)) or col >= ncols:
            return -1  # a field runs into the next, or one field too many
        elif slot[col] < 0:  # skipped unread
            while i < n and buf[i] > 32 and buf[i] < 127 and buf[i] != delim:
                i += 1
            col += 1
            need, gap = True, False
        else:
            neg = c == 45
            i += c == 43 or c == 45
            m, first, dot = 0, i, -1
            while i < n:
                d = buf[i]
                if d >= 48 and d <= 57:
                    m = m * 10 + np.int64(d - 48)
                elif d == 46 and dot < 0:
                    dot = i
                else:
                    break
                i += 1
            digits = i - first - (dot >= 0)
            exp = dot + 1 - i if dot >= 0 else 0
            if i < n and (buf[i] == 101 or buf[i] == 69):  # e E
                e, i = _exponent(buf, i + 1)
                if i < 0:
                    return -1
                exp += e
            if digits == 0 or digits > 18 or (m != 0 and (m > _MAX_EXACT or abs(exp) > 22)):
                return -1  # no digit, or not exact in one operation: NumPy's parser decides
            v = 0.0 if m == 0 else float(m) * pow10[exp] if exp >= 0 else float(m) / pow10[-exp]
            if slot[col] < 3:
                xyz[base + row, slot[col]] = -v if neg else v
            else:
                fields[slot[col] - 3, base + row] = -v if neg else v
            col += 1
            need, gap = True, False
