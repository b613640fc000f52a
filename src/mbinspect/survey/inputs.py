"""Many inputs as one survey: files, folders and globs expanded, read and joined, each
sounding keeping its file, its line and its ping."""

from __future__ import annotations

import glob
import os
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..cloud import PointCloud, crs_name
from ..crs import ScaleError, projected_metres, to_metres
from ..errors import FileAccessError, InputError
from ..formats import EXTENSIONS, FORMATS, format_of
from ..io import in_metres, read

__all__ = ["expand_inputs", "read_survey", "survey_lines", "survey_crs", "conform", "SurveyCRS",
           "READ_OPTIONS"]

#: The keyword arguments of :func:`mbinspect.io.read` a survey passes to every file.
READ_OPTIONS = ("format", "columns", "depth_positive", "delimiter", "crs", "keep_rejected", "decimal", "z_up",
                "tide", "datum_offset")

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
    which). Every file is brought into the CRS of the first one (or ``crs``), with a
    warning for each reprojected; a file without a CRS beside files with one is refused.

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
        A file without a CRS beside files with one.
    """
    files = [Path(p) for p in paths]
    if len(files) == 1:
        return read(files[0], progress=progress, **read_options)
    clouds: list[PointCloud] = []
    crs = read_options.pop("crs", None)
    target: str | None = crs
    for k, f in enumerate(files):
        sonar = format_of(f, read_options.get("format")).sonar
        within = None if progress is None else (lambda f, k=k: progress((k + f) / len(files)))
        c = _read_into(f, crs if crs is not None or not sonar else target, crs is not None, files[0],
                       progress=within, **read_options)
        if k == 0:
            target = c.crs
        clouds.append(conform(c, target, files[0]))
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


def _read_into(path: Path, crs: str | None, asked: bool, first: Path, **read_options: Any) -> PointCloud:
    """A file read into the survey's CRS; one that lies where that CRS (not one the user
    asked for) cannot hold it is refused naming both files."""
    try:
        return read(path, crs=crs, **read_options)
    except ScaleError as exc:
        if asked:
            raise
        raise _elsewhere(path, first, exc) from None


def _elsewhere(path: str | os.PathLike[str], first: str | os.PathLike[str], exc: ScaleError) -> InputError:
    how = f"1:{exc.ratio:,.0f}" if exc.ratio >= 2 else "a factor of two or more"
    return InputError(f"{path}: lies where the CRS of {first} ({exc.name}) distorts distances by {how} "
                      f"(its own UTM zone is {exc.utm}); expected the files of one survey in one place, or "
                      "--crs to put them in one CRS")


@dataclass(frozen=True)
class SurveyCRS:
    """The CRS every file of a survey is brought to, and the file that set it."""

    crs: str | None
    first: str


def survey_crs(paths: Sequence[str | os.PathLike[str]], read_options: Mapping[str, Any]) -> SurveyCRS:
    """The CRS a survey is read into: the one asked for (``crs``), else its first file's,
    in metres (a LAS/LAZ file's first chunk, any other file whole, read to learn it).

    Parameters
    ----------
    paths : sequence of path-like
    read_options : mapping
        As :func:`mbinspect.io.read` takes them.

    Returns
    -------
    SurveyCRS
    """
    first = Path(paths[0])
    opts = dict(read_options)
    if opts.get("crs") is not None:
        return SurveyCRS(projected_metres(opts["crs"]).to_wkt(), str(first))
    row = format_of(first, opts.get("format"))
    if row.chunks is not None:
        head = next(iter(row.chunks(first, 100_000, keep_rejected=True)))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # said again when the file is read
            return SurveyCRS(to_metres(head)[0].crs, str(first))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return SurveyCRS(read(first, **opts).crs, str(first))


def conform(cloud: PointCloud, target: str | None, first: str | os.PathLike[str]) -> PointCloud:
    """A file of a survey in the survey's CRS (its first file's, or the one asked for):
    reprojected, with a warning, when it has another; refused when it declares none.

    Parameters
    ----------
    cloud : PointCloud
        One file (or chunk of one) as read.
    target : str, optional
        The survey's CRS.
    first : path-like
        The file that set it, for the message.

    Returns
    -------
    PointCloud

    Raises
    ------
    InputError
        A file without a CRS in a survey that has one, or the other way round.
    """
    if same_crs(cloud.crs, target):
        return cloud
    if cloud.crs is None or target is None:
        raise InputError(f"{cloud.source}: its CRS ({crs_name(cloud.crs) or 'none'}) differs from {first}'s "
                         f"({crs_name(target) or 'none'}); expected every file of a survey in one CRS "
                         "(give --crs)")
    try:
        return in_metres(cloud, target)
    except ScaleError as exc:
        raise _elsewhere(cloud.source or "a file", first, exc) from None


def same_crs(a: str | None, b: str | None) -> bool:
    """Whether two CRS descriptions (WKT, EPSG codes or None) name one CRS."""
    if a is None or b is None or a == b:
        return a == b or (a is None and b is None)
    from pyproj import CRS

    try:
        return bool(CRS.from_user_input(a) == CRS.from_user_input(b))
    except Exception:  # an unparsable CRS is only equal to itself
        return False
