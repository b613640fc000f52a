"""Many inputs as one survey: files, folders and globs expanded, read and joined, each
sounding keeping its file, its line and its ping."""

from __future__ import annotations

import glob
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..cloud import PointCloud, crs_name
from ..errors import FileAccessError, InputError
from ..formats import EXTENSIONS, FORMATS, format_of
from ..io import read

__all__ = ["expand_inputs", "read_survey", "survey_lines", "READ_OPTIONS"]

#: The keyword arguments of :func:`mbinspect.io.read` a survey passes to every file.
READ_OPTIONS = ("format", "columns", "depth_positive", "delimiter", "crs", "keep_rejected", "decimal", "z_up")

_SUFFIXES = EXTENSIONS


def expand_inputs(specs: Sequence[str | os.PathLike[str]]) -> list[Path]:
    """The files a list of inputs names: files as given, folders searched (recursively)
    for every supported extension, glob patterns expanded; each file once, in order. A
    folder's ASCII files (.xyz .txt .csv ...) are taken only when it holds no LAS, PLY, NPZ
    or sonar file: beside line files they are tables such as designs and references.

    Parameters
    ----------
    specs : sequence of path-like or str
        Files, folders and glob patterns (``lines/*.laz``).

    Returns
    -------
    list of Path

    Raises
    ------
    FileAccessError
        A file that does not exist, or a folder or pattern that names no supported file.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> for name in ("b.laz", "a.laz", "notes.md", "design.csv"):
    ...     _ = (d / name).write_text("")
    >>> [p.name for p in expand_inputs([d])]
    ['a.laz', 'b.laz']
    """
    out: list[Path] = []
    for spec in specs:
        text = os.fspath(spec)
        p = Path(text)
        if p.is_dir():
            found = sorted(f for f in p.rglob("*") if f.is_file() and f.suffix.lower() in _SUFFIXES)
            binary = [f for f in found if f.suffix.lower() not in FORMATS["xyz"].extensions]
            if binary:  # beside line files, .csv and .txt files are tables (designs, references)
                found = binary
            if not found:
                raise FileAccessError(f"{p}: the folder holds no supported file; expected "
                                      f"{' '.join(_SUFFIXES)}")
        elif any(c in text for c in "*?["):
            found = sorted(Path(f) for f in glob.glob(text, recursive=True) if Path(f).is_file())
            if not found:
                raise FileAccessError(f"{text}: the pattern matches no file")
        elif p.exists():
            found = [p]
        else:
            raise FileAccessError(f"{p}: no such file")
        out += found
    seen: set[str] = set()
    unique = []
    for f in out:
        key = os.path.realpath(f)
        if key not in seen:
            seen.add(key)
            unique.append(f)
    return unique


def survey_lines(file_index: np.ndarray, file_line: np.ndarray | None) -> np.ndarray:
    """One line number per (file, line within the file), numbered 1, 2, ... in that order.

    Examples
    --------
    >>> survey_lines(np.array([0, 0, 1, 1]), np.array([1, 2, 1, 1])).tolist()
    [1, 2, 3, 3]
    """
    own = np.zeros(len(file_index), np.int64) if file_line is None else np.asarray(file_line, np.int64)
    key = np.asarray(file_index, np.int64) * (1 << 32) + (own - own.min() if len(own) else own)
    _, inverse = np.unique(key, return_inverse=True)
    return (inverse.ravel() + 1).astype(np.int32)


def read_survey(paths: Sequence[str | os.PathLike[str]], *, progress: Callable[[float], None] | None = None,
                **read_options: Any) -> PointCloud:
    """Read several files as one survey.

    Each sounding keeps ``file`` (the index into ``meta["files"]``), ``ping`` (the file's
    own, when it has one) and ``line``: one number per file, or per line within a file
    that holds several. Fields not in every file are dropped (``meta["notes"]`` says
    which). Sonar files are projected into the CRS of the first one (or ``crs``); files
    whose CRS differs are refused.

    Parameters
    ----------
    paths : sequence of path-like
        The files (:func:`expand_inputs`).
    progress : callable, optional
        Called with the fraction read (of the files, and within a large ASCII file).
    **read_options
        Passed to :func:`mbinspect.io.read` for every file.

    Returns
    -------
    PointCloud

    Raises
    ------
    InputError
        A file in another CRS than the first.
    """
    files = [Path(p) for p in paths]
    if len(files) == 1:
        return read(files[0], progress=progress, **read_options)
    clouds: list[PointCloud] = []
    crs = read_options.pop("crs", None)
    first_crs: str | None = None
    for k, f in enumerate(files):
        sonar = format_of(f, read_options.get("format")).sonar
        within = None if progress is None else (lambda f, k=k: progress((k + f) / len(files)))
        c = read(f, crs=crs if crs is not None or not sonar else first_crs, progress=within, **read_options)
        if k == 0:
            first_crs = c.crs
        elif not same_crs(c.crs, first_crs):
            raise InputError(f"{f}: its CRS ({crs_name(c.crs) or 'none'}) differs from {files[0]}'s "
                             f"({crs_name(first_crs) or 'none'}); expected every file of a survey in one CRS "
                             "(give --crs)")
        clouds.append(c)
        if progress is not None:
            progress((k + 1) / len(files))
    return join_clouds(clouds, [str(f) for f in files])


def join_clouds(clouds: Sequence[PointCloud], names: Sequence[str]) -> PointCloud:
    """Clouds joined into one, with ``file``, ``line`` and the fields all of them hold."""
    common = set(clouds[0].fields)
    for c in clouds[1:]:
        common &= set(c.fields)
    dropped = sorted(set().union(*(c.fields for c in clouds)) - common - {"line"})
    fields: dict[str, np.ndarray] = {}
    for name in sorted(common - {"line"}):
        fields[name] = np.concatenate([c.fields[name] for c in clouds])
    file_index = np.concatenate([np.full(len(c), k, np.int32) for k, c in enumerate(clouds)])
    own = None
    if any("line" in c.fields for c in clouds):
        own = np.concatenate([np.asarray(c.fields.get("line", np.zeros(len(c))), np.int64) for c in clouds])
    fields["file"] = file_index
    fields["line"] = survey_lines(file_index, own)
    notes = [f"the field {name!r} is not in every file: left out" for name in dropped]
    meta = {"files": list(names), "notes": notes, "format": "survey"}
    return PointCloud(np.concatenate([c.xyz for c in clouds]), fields,
                      source=f"{len(names)} files ({names[0]} ...)", crs=clouds[0].crs,
                      z_convention=clouds[0].z_convention, meta=meta)


def same_crs(a: str | None, b: str | None) -> bool:
    """Whether two CRS descriptions (WKT, EPSG codes or None) name one CRS."""
    if a is None or b is None or a == b:
        return a == b or (a is None and b is None)
    from pyproj import CRS

    try:
        return bool(CRS.from_user_input(a) == CRS.from_user_input(b))
    except Exception:  # an unparsable CRS is only equal to itself
        return False
