"""Saved results read back: :func:`read_result` turns a ``piles.json`` or ``reefs.json``
into the frozen result that wrote it, so that one command can build on another's output.

Examples
--------
>>> import json, tempfile, pathlib
>>> from mbinspect.piles import locate_piles
>>> from mbinspect.simulate import simulate
>>> sim = simulate("jacket", seed=1)
>>> res = locate_piles(sim.cloud, count=4, radius=0.75)
>>> path = pathlib.Path(tempfile.mkdtemp()) / "piles.json"
>>> _ = path.write_text(json.dumps(res.to_dict()))
>>> back = read_result(path)
>>> back.to_dict() == json.loads(path.read_text()), len(back.piles)
(True, 4)
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from .errors import FileAccessError, InputError
from .piles.results import PileResult
from .reefs.results import ReefResult

__all__ = ["read_result", "result_from_dict", "RESULT_TYPES"]

#: The key a result's JSON holds -> the result type that reads it.
RESULT_TYPES: dict[str, Callable[[dict[str, Any]], Any]] = {
    "piles": PileResult.from_dict,
    "reefs": ReefResult.from_dict,
}


def result_from_dict(d: Mapping[str, Any], *, source: str = "the result") -> PileResult | ReefResult:
    """The result a JSON dict holds, by the pipeline's key in it.

    Parameters
    ----------
    d : mapping
        ``to_dict()`` of a result, as the CLI writes it.
    source : str
        Named in the error.

    Returns
    -------
    PileResult or ReefResult

    Raises
    ------
    InputError
        A dict that is no result of ours, or one whose rows lack what a result holds.
    """
    kind = next((k for k in RESULT_TYPES if isinstance(d, Mapping) and k in d), None)
    if kind is None:
        raise InputError(f"{source}: not an mbinspect result; expected a JSON object with "
                         f"{' or '.join(repr(k) for k in RESULT_TYPES)}")
    try:
        return RESULT_TYPES[kind](dict(d))
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise InputError(f"{source}: a {kind} result that cannot be read back ({type(exc).__name__}: "
                         f"{exc}); expected the JSON mbinspect wrote") from None


def read_result(path: str | os.PathLike[str]) -> PileResult | ReefResult:
    """Read a saved ``piles.json`` or ``reefs.json`` (or the folder holding one).

    Parameters
    ----------
    path : path-like
        The JSON file, or a result folder (``--out``) holding ``piles.json`` or
        ``reefs.json``.

    Returns
    -------
    PileResult or ReefResult
        Its ``to_dict()`` equals the JSON read.

    Raises
    ------
    FileAccessError
        No such file, or a folder without a result.
    InputError
        Not JSON, or not a result of ours.
    """
    p = Path(path)
    if p.is_dir():
        found = [p / f"{k}.json" for k in RESULT_TYPES if (p / f"{k}.json").is_file()]
        if not found:
            names = ' or '.join(f'{k}.json' for k in RESULT_TYPES)
            raise FileAccessError(f"{p}: the folder holds no {names}")
        p = found[0]
    if not p.is_file():
        raise FileAccessError(f"{p}: no such file")
    try:
        d = json.loads(p.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{p}: not JSON ({exc})") from None
    return result_from_dict(d, source=str(p))
