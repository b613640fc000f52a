"""The format table: one :class:`~mbinspect.formats.base.Format` row per file format, and
every list derived from it.

Adding a format is one module here defining its ``FORMAT`` row and one line in
``_ROWS`` below; the command line's ``--format`` choices, the extension lookup and the
survey's memory estimate follow (and a row in docs/formats.md).

Examples
--------
>>> format_from_path("survey.LAZ"), format_from_path("a.dat", "csv"), format_from_path("x.mb121")
('las', 'xyz', 'gsf')
>>> FORMAT_NAMES
('xyz', 'las', 'laz', 'ply', 'npz', 'gsf', 'kmall', 'all', 'xtf')
"""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import InputError, ParameterError
from . import ascii, las, npz, ply, sonar
from .base import Format, ReadRequest

__all__ = ["Format", "ReadRequest", "FORMATS", "FORMAT_NAMES", "SONAR_FORMATS", "EXTENSIONS", "ALIASES",
           "format_from_path", "format_of"]

_ROWS: tuple[Format, ...] = (ascii.FORMAT, las.FORMAT, ply.FORMAT, npz.FORMAT, sonar.GSF, sonar.KMALL,
                             sonar.ALL, sonar.XTF)

#: Format name -> its row.
FORMATS: dict[str, Format] = {f.name: f for f in _ROWS}

#: Other names a format is given by (``laz`` is read by the LAS reader).
ALIASES: dict[str, str] = {a: f.name for f in _ROWS for a in f.aliases}

#: Every name ``format=`` accepts: the formats, each followed by its aliases that are
#: formats' names users write (``laz``).
FORMAT_NAMES: tuple[str, ...] = tuple(n for f in _ROWS for n in (f.name, *[a for a in f.aliases
                                                                           if a == "laz"]))

#: The sonar makers' formats, projected on reading.
SONAR_FORMATS: tuple[str, ...] = tuple(f.name for f in _ROWS if f.sonar)

#: Every extension that selects a format.
EXTENSIONS: tuple[str, ...] = tuple(e for f in _ROWS for e in f.extensions)


def format_from_path(path: str | os.PathLike[str], format: str | None = None) -> str:
    """The format name for ``path`` (or the explicit ``format``).

    Parameters
    ----------
    path : path-like
    format : str, optional
        An explicit format name or alias (``laz`` is read by the LAS reader).

    Returns
    -------
    str
        A key of ``FORMATS``.

    Raises
    ------
    ParameterError
        An unknown ``format`` (``option="format"``).
    InputError
        An extension that names no format.
    """
    if format is not None:
        fmt = ALIASES.get(format.lower(), format.lower())
        if fmt not in FORMATS:
            raise ParameterError(f"format: {format!r}; expected one of {', '.join(FORMAT_NAMES)}",
                                 option="format")
        return fmt
    suffix = Path(path).suffix.lower()
    for row in _ROWS:
        if suffix in row.extensions:
            return row.name
    raise InputError(f"{path}: unknown extension {suffix or '(none)'!r}; expected one of "
                     f"{' '.join(EXTENSIONS)} or an explicit `format`")


def format_of(path: str | os.PathLike[str], format: str | None = None) -> Format:
    """The row of :data:`FORMATS` that reads ``path`` (see :func:`format_from_path`).

    Parameters
    ----------
    path : path-like
    format : str, optional

    Returns
    -------
    Format

    Examples
    --------
    >>> format_of("a.kmall").sonar, format_of("a.laz").write is not None
    (True, True)
    """
    return FORMATS[format_from_path(path, format)]
