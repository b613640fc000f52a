"""Outputs: JSON-ready values, atomic files, output folders, JSON and CSV writers.

Every output is written atomically: a file goes to a temporary name beside its target and
is renamed into place on success; a folder of results is built in a hidden staging folder
beside the target, created (so checked) before any work, and moved into place only when
everything in it is written. An interrupted or failed run leaves the target as it was; a
staging folder left by a killed run is cleared by the next run that writes there.

Examples
--------
>>> import tempfile, pathlib
>>> from mbinspect.outputs import output_dir, write_json
>>> base = pathlib.Path(tempfile.mkdtemp())
>>> with output_dir(base / "out") as tmp:
...     write_json({"a": 1}, tmp / "a.json")
>>> sorted(p.name for p in (base / "out").iterdir())  # and the marker --overwrite looks for
['.mbinspect-result', 'a.json']
"""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from dataclasses import fields as dataclass_fields
from pathlib import Path
from typing import Any

import numpy as np

from .errors import FileAccessError

__all__ = [
    "to_jsonable",
    "MARKER",
    "dataclasses_asdict",
    "atomic_path",
    "check_output_dir",
    "output_dir",
    "write_json",
    "write_table",
    "discard_unfinished",
    "Recorded",
    "record_from",
]

_STAGING = ".mbinspect-"  # marks the staging folders this package owns

# Staging folders and temporary files being written now, removed by
# :func:`discard_unfinished` when the process is interrupted.
_UNFINISHED: set[Path] = set()


def discard_unfinished() -> None:
    """Remove every staging folder and temporary file this process is still writing.

    Called on an interrupt (Ctrl-C, SIGTERM) just before the process exits, so that
    nothing partial is left behind.
    """
    for p in list(_UNFINISHED):
        if p.is_dir():
            shutil.rmtree(p, ignore_errors=True)
        else:
            p.unlink(missing_ok=True)
        _UNFINISHED.discard(p)


def to_jsonable(value: Any) -> Any:
    """``value`` with numpy scalars and arrays (nested in dicts, lists, tuples) made plain.

    Non-finite floats become ``None`` (JSON has no NaN).

    Parameters
    ----------
    value : object

    Returns
    -------
    object
        Built of dict, list, str, int, float, bool and None only.

    Examples
    --------
    >>> to_jsonable({"a": np.float64(1.5), "b": np.array([1, 2]), "c": float("nan")})
    {'a': 1.5, 'b': [1, 2], 'c': None}
    """
    kind = type(value)
    if kind is float:  # the leaves first: outlines hold hundreds of thousands
        return value if math.isfinite(value) else None
    if kind is int or kind is str or kind is bool or value is None:
        return value
    if isinstance(value, dict):
        return {str(k): to_jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        if all(type(v) is float and math.isfinite(v) for v in value):  # a coordinate pair
            return list(value)
        return [to_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return to_jsonable(value.tolist())
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        f = float(value)
        return f if math.isfinite(f) else None
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def dataclasses_asdict(obj: Any) -> dict[str, Any]:
    """``dataclasses.asdict(obj)`` made JSON-ready (:func:`to_jsonable`).

    Parameters
    ----------
    obj : dataclass instance

    Returns
    -------
    dict
    """
    import dataclasses

    out: dict[str, Any] = to_jsonable(dataclasses.asdict(obj))
    return out


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; it replaces ``path`` only on success.

    Parameters
    ----------
    path : path-like
        The file to write.

    Yields
    ------
    Path
        Where to write; removed again when the block fails or is interrupted.
    """
    target = Path(path)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=target.suffix, dir=target.parent)
    except OSError as exc:
        raise FileAccessError(f"{target}: cannot be written ({exc.strerror})") from None
    os.close(fd)
    os.chmod(tmp, 0o666 & ~_umask())
    _UNFINISHED.add(Path(tmp))
    try:
        yield Path(tmp)
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    finally:
        _UNFINISHED.discard(Path(tmp))


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _clear_stale(target: Path) -> None:
    """Remove staging folders for ``target`` left by runs that no longer exist."""
    prefix = f".{target.name}{_STAGING}"
    try:
        stale = [p for p in target.parent.iterdir() if p.name.startswith(prefix) and p.is_dir()]
    except OSError:
        return
    for p in stale:
        pid = p.name[len(prefix):].split(".", 1)[0]
        if pid.isdigit() and int(pid) != os.getpid() and not _alive(int(pid)):
            shutil.rmtree(p, ignore_errors=True)


#: The file that marks a folder as an mbinspect result, which ``overwrite`` may replace (and
#: nothing else: a user's own folder is never deleted).
MARKER = ".mbinspect-result"


def check_output_dir(path: str | os.PathLike[str], *, overwrite: bool = False,
                     inputs: Sequence[str | os.PathLike[str]] = ()) -> Path:
    """Check that results may be written to the folder ``path``; return it as a Path.

    Parameters
    ----------
    path : path-like
        The output folder.
    overwrite : bool
        Whether an existing, non-empty folder may be replaced.
    inputs : sequence of path-like
        Every file the run reads; a folder that is or holds one is refused, with or
        without ``overwrite`` (replacing it would delete the input).

    Raises
    ------
    FileAccessError
        With ``option="out"``: not a folder, not empty without ``overwrite``, or it holds
        an input.
    """
    target = Path(path)
    where = target.resolve()
    for inp in inputs:
        if inp is None:
            continue
        full = Path(inp).resolve()
        if full == where or where in full.parents:
            raise FileAccessError(f"out: {target} holds the input {inp}; expected a folder that "
                                  "holds no input (an input is never replaced)", option="out")
    if target.exists() and not target.is_dir():
        raise FileAccessError(f"out: {target} exists and is not a folder; expected a folder",
                              option="out")
    if target.is_dir() and any(target.iterdir()):
        if not overwrite:
            raise FileAccessError(f"out: {target} exists and is not empty; expected a new or empty "
                                  "folder, or `overwrite` to replace it", option="out")
        if not (target / MARKER).is_file():
            raise FileAccessError(f"out: {target} holds files mbinspect did not write (no {MARKER}); "
                                  "expected a folder of an earlier mbinspect result to replace, or a new one",
                                  option="out")
    return target


@contextmanager
def output_dir(path: str | os.PathLike[str], *, overwrite: bool = False,
               inputs: Sequence[str | os.PathLike[str]] = ()) -> Iterator[Path]:
    """A staging folder that replaces the folder ``path`` only when the block succeeds.

    The target is checked (:func:`check_output_dir`) and the staging folder created on
    entry, before the caller's work, so that a bad ``path`` fails at once. Stale staging
    folders of killed runs are cleared.

    Parameters
    ----------
    path : path-like
        The output folder.
    overwrite : bool
        Replace an existing, non-empty folder.
    inputs : sequence of path-like
        The run's input files (see :func:`check_output_dir`).

    Yields
    ------
    Path
        The staging folder to write into.
    """
    target = check_output_dir(path, overwrite=overwrite, inputs=inputs)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        _clear_stale(target)
        tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}{_STAGING}{os.getpid()}.",
                                    dir=target.parent))
    except OSError as exc:
        raise FileAccessError(f"out: {target} cannot be created ({exc.strerror}); expected a "
                              "writable place", option="out") from None
    os.chmod(tmp, 0o777 & ~_umask())
    _UNFINISHED.add(tmp)
    try:
        yield tmp
        (tmp / MARKER).write_text("written by mbinspect: `overwrite` may replace this folder\n",
                                  encoding="utf-8")
        old = None
        if target.exists():
            old = target.with_name(f".{target.name}{_STAGING}{os.getpid()}.old")
            os.replace(target, old)
        os.replace(tmp, target)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    finally:
        _UNFINISHED.discard(tmp)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def write_json(obj: Any, path: str | os.PathLike[str]) -> None:
    """Write ``obj`` as indented JSON (LF line ends), atomically, numpy values made plain.

    Parameters
    ----------
    obj : object
        Anything :func:`to_jsonable` accepts.
    path : path-like
    """
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(to_jsonable(obj), indent=2) + "\n", encoding="utf-8")


def write_table(rows: Sequence[Mapping[str, Any]], path: str | os.PathLike[str],
                columns: Sequence[str] | None = None) -> None:
    """Write flat dicts as CSV with LF line ends, atomically; lists and dicts are left out.

    Parameters
    ----------
    rows : sequence of mapping
        One dict per row.
    path : path-like
    columns : sequence of str, optional
        Columns in order; default the first row's scalar keys. Floats get 4 decimals,
        None an empty cell.
    """
    import csv

    cols = list(columns) if columns is not None else (
        [k for k, v in rows[0].items() if not isinstance(v, (list, dict))] if rows else [])
    with atomic_path(path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(cols)
        for row in rows:
            vals = []
            for c in cols:
                v = to_jsonable(row.get(c))
                vals.append("" if v is None else (f"{v:.4f}" if isinstance(v, float) else v))
            w.writerow(vals)


@dataclass(frozen=True)
class Recorded:
    """A summary read back from a result's JSON (a seabed, a terrain mask) in place of the
    model that wrote it: ``to_dict()`` gives the summary as it was written.

    Examples
    --------
    >>> Recorded({"method": "grid", "cell": 1.0}).to_dict()
    {'method': 'grid', 'cell': 1.0}
    """

    data: dict[str, Any]

    def to_dict(self) -> dict[str, Any]:
        """The summary as written."""
        return dict(self.data)


def record_from(cls: type, d: Mapping[str, Any], **given: Any) -> Any:
    """A frozen dataclass ``cls`` built from its JSON row ``d`` (the inverse of its
    ``to_dict()`` for plain fields): keys that name fields are taken, lists become tuples
    for tuple fields (nested ones too), and ``None`` becomes NaN for a float field that
    cannot be None (JSON has no NaN); ``given`` overrides or adds fields.

    Parameters
    ----------
    cls : type
        A dataclass.
    d : mapping
    **given
        Fields set here, not from ``d``.

    Returns
    -------
    object
        An instance of ``cls``.

    Examples
    --------
    >>> @dataclass(frozen=True)
    ... class Row:
    ...     a: float
    ...     b: tuple[int, ...] = ()
    >>> record_from(Row, {"a": None, "b": [1, 2], "c": 3})
    Row(a=nan, b=(1, 2))
    """
    kw: dict[str, Any] = {}
    for f in dataclass_fields(cls):
        if f.name in given or f.name not in d:
            continue
        v, kind = d[f.name], str(f.type)
        if v is None and kind.startswith("float") and "None" not in kind:
            v = math.nan
        elif isinstance(v, list) and kind.startswith("tuple"):
            v = tuple(tuple(x) if isinstance(x, list) and "tuple[tuple" in kind else x for x in v)
        kw[f.name] = v
    return cls(**kw, **given)
