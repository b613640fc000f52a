"""Point clouds in and out: one entry point, :func:`read` and :func:`write`, for every
format of the table in :mod:`mbinspect.formats`.

Points are ``(N, 3)`` float64 in metres, x east, y north, z elevation (up, so
depths are negative). Readers never guess the sign of z: exports that write depth
positive down are read with ``depth_positive=True``. docs/formats.md lists the formats,
their extensions and the fields each keeps (``FORMATS`` here, ``--format`` on the command line).

Examples
--------
>>> import numpy as np, tempfile, pathlib
>>> from mbinspect.io import PointCloud, read, write
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> cloud = PointCloud(np.array([[0.0, 0.0, -20.0], [1.0, 0.0, -20.5]]))
>>> write(cloud, d / "two.xyz")
>>> len(read(d / "two.xyz"))
2
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from .checks import EARTH_BOUND_TEXT, beyond_the_earth
from .cloud import PointCloud, crs_name, pipeline_input
from .crs import to_metres
from .datum import VerticalReference, vertical_reference
from .describe import CloudSummary, describe
from .errors import FileAccessError, InputError, InputWarning, MBInspectError, ParameterError
from .formats import FORMAT_NAMES, FORMATS, SONAR_FORMATS, ReadRequest, format_from_path
from .formats.ascii_parse import DELIMITERS, parse_columns
from .outputs import atomic_path

__all__ = [
    "PointCloud",
    "on_reference",
    "FORMATS",
    "FORMAT_NAMES",
    "SONAR_FORMATS",
    "InputWarning",
    "read",
    "write",
    "format_from_path",
    "parse_columns",
    "check_read_options",
    "pipeline_input",
    "CloudSummary",
    "crs_name",
    "describe",
    "in_metres",
    "sha256_of",
]


# --------------------------------------------------------------------------- reading


def check_read_options(path: str | os.PathLike[str], *, format: str | None = None,
                       columns: str | Sequence[str] | None = None, delimiter: str | None = None) -> str:
    """Check the reading options of :func:`read` without reading; return the format.

    Parameters
    ----------
    path : path-like
        The file (its extension decides the format unless ``format`` is given).
    format, columns, delimiter
        As :func:`read`.

    Returns
    -------
    str
        The format name (``xyz``, ``las``, ``ply`` or ``npz``).

    Raises
    ------
    ParameterError
        Naming the option: an unknown format or delimiter, a column map without one x, y
        and z, a column map for a file that is not ASCII.
    InputError
        An extension that names no format.

    Examples
    --------
    >>> check_read_options("survey.laz"), check_read_options("a.txt", format="laz")
    ('las', 'las')
    """
    fmt = format_from_path(path, format)
    if delimiter is not None and delimiter.lower() not in DELIMITERS:
        raise ParameterError(f"delimiter: {delimiter!r}; expected one of ',' ';' tab space",
                             option="delimiter")
    if columns is not None:
        if "columns" not in FORMATS[fmt].options:
            raise ParameterError(f"columns: {columns!r} given for the {fmt} file {path}; expected it "
                                 "for ASCII files only", option="columns")
        parse_columns(columns)
    return fmt


def read(
    path: str | os.PathLike[str],
    *,
    format: str | None = None,
    columns: str | Sequence[str] | None = None,
    depth_positive: bool = False,
    delimiter: str | None = None,
    crs: str | None = None,
    keep_rejected: bool = False,
    decimal: str | None = None,
    z_up: bool = False,
    tide: str | os.PathLike[str] | None = None,
    datum_offset: float | None = None,
    progress: Callable[[float], None] | None = None,
) -> PointCloud:
    """Read a point cloud file.

    Parameters
    ----------
    path : path-like
        The file to read.
    format : {"xyz", "las", "laz", "ply", "npz"}, optional
        Overrides the format inferred from the extension.
    columns : str or sequence of str, optional
        ASCII only: what each column holds, e.g. ``"x,y,z,intensity"`` or
        ``"x,y,-,z"`` (``-`` skips a column). Default: the header names when there
        is a header; else 3 columns are x y z and 4 are x y z intensity.
    depth_positive : bool
        The file stores depth positive down: z is negated so that it is elevation.
        Never guessed; default False.
    delimiter : {",", ";", "tab", "space"}, optional
        ASCII only: the column delimiter. Default: sniffed from the first data
        line (comma, semicolon, tab or whitespace).
    crs : str, optional
        The projected metre CRS to put the soundings in, reprojecting a file that declares
        another (:func:`mbinspect.crs.to_metres`; default: the file's own CRS, or the UTM
        zone of data in degrees or feet). For a file that declares none: the CRS of its
        coordinates.
    keep_rejected : bool
        Sonar formats: keep the soundings the sonar or the file rejected (the ``valid``
        field says which); default False.
    decimal : {".", ","}, optional
        ASCII only: the decimal mark; default sniffed (``554845,028;...`` has commas).
    z_up : bool
        The file's z is elevation, positive up. With neither this nor ``depth_positive``, a
        file whose z is mostly positive under a header that does not say which (``z``, or
        none) is read as given but marked doubtful (``meta["z_doubt"]``); the pipelines
        refuse such a cloud.
    tide : path-like, optional
        A tide CSV (``time,height``: the water level above chart datum by UTC time): each
        sounding's height gains the level at its time (:mod:`mbinspect.datum`); refused when
        the soundings carry no time or the series does not cover them.
    datum_offset : float, optional
        Metres added to every height (after the tide).
    progress : callable, optional
        ASCII only: called with the fraction of the file parsed.

    Returns
    -------
    PointCloud
        ``meta["vertical_reference"]`` says what its heights are.

    Raises
    ------
    FileAccessError
        Missing file, a directory, unreadable.
    InputError
        Malformed content; the message names the line and column.
    """
    ref = vertical_reference(None if tide is None else str(tide), datum_offset)
    cloud = _read_file(Path(path), format=format, columns=columns, depth_positive=depth_positive,
                       delimiter=delimiter, crs=crs, keep_rejected=keep_rejected, decimal=decimal, z_up=z_up,
                       progress=progress)
    return on_reference(cloud, ref, str(path))


def on_reference(cloud: PointCloud, ref: VerticalReference, where: str) -> PointCloud:
    """The cloud with its heights on ``ref`` (:mod:`mbinspect.datum`), saying so in its meta."""
    meta = {**cloud.meta, "vertical_reference": ref.to_dict()}
    if not ref.stated:
        return replace(cloud, meta=meta)
    z = ref.apply(cloud.xyz[:, 2], dict(cloud.fields), where)
    xyz = cloud.xyz.copy()
    xyz[:, 2] = z
    return replace(cloud, xyz=xyz, meta=meta)


def _read_file(p: Path, *, format: str | None, columns: str | Sequence[str] | None, depth_positive: bool,
               delimiter: str | None, crs: str | None, keep_rejected: bool, decimal: str | None, z_up: bool,
               progress: Callable[[float], None] | None) -> PointCloud:
    """:func:`read` before the vertical reference."""
    if not p.exists():
        raise FileAccessError(f"{p}: no such file")
    if p.is_dir():
        raise FileAccessError(f"{p}: is a directory, expected a point cloud file")
    fmt = check_read_options(p, format=format, columns=columns, delimiter=delimiter)
    try:
        if p.stat().st_size == 0:
            raise InputError(f"{p}: the file is empty")
        row = FORMATS[fmt]
        if row.sonar and depth_positive:
            raise ParameterError(f"depth_positive: given for the {fmt} file {p}; expected it only "
                                 "for exports (a sonar file says what its heights are)",
                                 option="depth_positive")
        request = ReadRequest(columns=columns, delimiter=delimiter, decimal=decimal,
                              depth_positive=depth_positive, z_up=z_up, crs=crs,
                              keep_rejected=keep_rejected, progress=progress)
        cloud = _read_row(row, p, request)
        if row.sonar:
            return cloud
        if cloud.meta.get("geographic"):
            crs = None
    except PermissionError as exc:
        raise FileAccessError(f"{p}: cannot be read ({exc.strerror})") from None
    if len(cloud) == 0:
        raise InputError(f"{p}: the file holds no points")
    finite = math.isfinite(float(cloud.xyz.sum()))  # one sum settles the common case
    bad = None if finite else ~np.isfinite(cloud.xyz).all(axis=1)
    if bad is not None and bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(
            f"{p}: point {i + 1} has a non-finite coordinate {cloud.xyz[i].tolist()}; "
            "expected finite numbers"
        )
    far = beyond_the_earth(cloud.xyz)
    if far is not None:
        raise InputError(f"{p}: point {far + 1} is {cloud.xyz[far].tolist()}; {EARTH_BOUND_TEXT}")
    if depth_positive:
        xyz = cloud.xyz.copy()
        xyz[:, 2] *= -1.0
        cloud = replace(cloud, xyz=xyz, z_convention="depth")
    return in_metres(cloud, crs)








def _read_row(row: Any, path: Path, request: ReadRequest) -> PointCloud:
    """A format's reader, any exception it lets out (a corrupt record no check foresaw: a
    date of month 13, a length past the buffer) made one line naming the file."""
    try:
        return row.read(path, request)
    except (MBInspectError, PermissionError, KeyboardInterrupt, SystemExit):
        raise
    except MemoryError:
        raise InputError(f"{path}: more than this machine's memory to read as {row.name}; the file may "
                         "be corrupt, or is a survey to run in tiles") from None
    except Exception as exc:
        reason = str(exc).splitlines()[0][:160] if str(exc) else ""
        raise InputError(f"{path}: cannot be read as {row.name} ({type(exc).__name__}"
                         f"{': ' + reason if reason else ''}); expected an intact {row.name} file") from None


def in_metres(cloud: PointCloud, crs: str | None = None) -> PointCloud:
    """The cloud in a projected metre CRS (:func:`mbinspect.crs.to_metres`), each
    conversion said in one warning.

    Parameters
    ----------
    cloud : PointCloud
    crs : str, optional
        The CRS wanted (or, for a file that declares none, the CRS of its coordinates).

    Returns
    -------
    PointCloud
    """
    out, notes = to_metres(cloud, crs)
    for note in notes:
        warnings.warn(note, InputWarning, stacklevel=3)
    return out


# --------------------------------------------------------------------------- writing


def write(
    cloud: PointCloud,
    path: str | os.PathLike[str],
    *,
    format: str | None = None,
    precision: int = 3,
) -> None:
    """Write ``cloud`` to ``path`` atomically (a crash never leaves half a file).

    Parameters
    ----------
    cloud : PointCloud
    path : path-like
    format : {"xyz", "las", "laz", "ply", "npz"}, optional
        Default from the extension (``.laz`` writes compressed LAS).
    precision : int
        Decimals for ASCII output and the LAS scale (3 = millimetres).
    """
    row = FORMATS[format_from_path(path, format)]
    if row.write is None:
        raise ParameterError(f"format: {row.name} is read only; expected one of "
                             f"{', '.join(f.name for f in FORMATS.values() if f.write)}", option="format")
    with atomic_path(path) as tmp:  # the temporary keeps the suffix (.laz compresses)
        row.write(cloud, tmp, precision)


def sha256_of(path: str | os.PathLike[str]) -> str:
    """The sha256 of a file's bytes (hex), read a few megabytes at a time: what a result
    records of its inputs, and what a command building on it checks.

    Parameters
    ----------
    path : path-like

    Returns
    -------
    str

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "a.txt"
    >>> _ = p.write_bytes(b"abc")
    >>> sha256_of(p)[:16]
    'ba7816bf8f01cfea'
    """
    import hashlib

    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 22), b""):
            h.update(block)
    return h.hexdigest()
