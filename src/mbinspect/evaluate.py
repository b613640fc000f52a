"""Scores against a reference list: one-to-one matching, TP/FP/FN, correctness, completeness.

Counting rules (the reef paper leaves them open, see its TP + FP = 96 against 98 reefs
interpreted): detections and references are matched one to one (Hungarian, minimum total
distance) among pairs closer than ``tolerance``. A matched pair is a TP; a detection left
unmatched is an FP; a reference left unmatched is an FN. So a cluster that merges two
reefs counts once as TP (for the nearer reference) and the other reef as FN; a reef split
in two counts once as TP and the extra part as FP.

Examples
--------
>>> import numpy as np
>>> from mbinspect.evaluate import match_points
>>> ev = match_points(np.array([[0.0, 0.0], [10.0, 0.0]]), np.array([[0.2, 0.1], [50.0, 0.0]]))
>>> ev.tp, ev.fp, ev.fn
(1, 1, 1)
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import linear_sum_assignment

from .checks import positive
from .errors import FileAccessError, InputError
from .outputs import to_jsonable

__all__ = ["Evaluation", "match_points", "read_reference"]


@dataclass(frozen=True)
class Evaluation:
    """Matching of detections to references and the scores."""

    tp: int
    fp: int
    fn: int
    tolerance: float
    matches: tuple[tuple[int, int, float], ...]  # (detection index, reference index, distance)
    unmatched_detections: tuple[int, ...]
    unmatched_references: tuple[int, ...]
    reference_ids: tuple[Any, ...] = field(default=())

    @property
    def correctness(self) -> float:
        """TP / (TP + FP), the paper's AC."""
        return self.tp / (self.tp + self.fp) if self.tp + self.fp else math.nan

    @property
    def completeness(self) -> float:
        """TP / (TP + FN), the paper's IN."""
        return self.tp / (self.tp + self.fn) if self.tp + self.fn else math.nan

    @property
    def f1(self) -> float:
        c, k = self.correctness, self.completeness
        return 2 * c * k / (c + k) if c + k else math.nan

    def position_errors(self) -> np.ndarray:
        return np.array([d for _, _, d in self.matches])

    def to_dict(self) -> dict[str, Any]:
        e = self.position_errors()
        ids = self.reference_ids or tuple(range(1, 10**9))
        return to_jsonable({
            "tp": self.tp, "fp": self.fp, "fn": self.fn, "tolerance": self.tolerance,
            "correctness": self.correctness, "completeness": self.completeness, "f1": self.f1,
            "position_error": {
                "mean": float(e.mean()) if len(e) else None,
                "rms": float(np.sqrt(np.mean(e**2))) if len(e) else None,
                "p95": float(np.percentile(e, 95)) if len(e) else None,
                "max": float(e.max()) if len(e) else None,
            },
            "matches": [{"detection": i, "reference": ids[j], "distance": d}
                        for i, j, d in self.matches],
            "unmatched_detections": list(self.unmatched_detections),
            "unmatched_references": [ids[j] for j in self.unmatched_references],
            "counting": "one-to-one Hungarian matching within the tolerance; a merged "
                        "cluster is one TP plus one FN, a split reef one TP plus one FP",
        })


def match_points(detected: np.ndarray, reference: np.ndarray, *, tolerance: float = 1.5,
                 reference_ids: tuple[Any, ...] = ()) -> Evaluation:
    """Match detected positions (D, 2) to reference positions (R, 2) one to one.

    Parameters
    ----------
    detected : ndarray, shape (D, 2)
        Detected positions (m).
    reference : ndarray, shape (R, 2)
        Reference positions (m).
    tolerance : float
        Largest distance of a match (m).
    reference_ids : sequence, optional
        The references' ids (default 1..R).

    Returns
    -------
    Evaluation
        TP, FP, FN, the matches and the unmatched on each side.

    Examples
    --------
    >>> ev = match_points(np.array([[0.0, 0.0], [9.0, 9.0]]), np.array([[0.2, 0.1]]))
    >>> ev.tp, ev.fp, ev.fn
    (1, 1, 0)
    """
    if not tolerance > 0:
        positive("tolerance", tolerance)
    det = np.asarray(detected, np.float64).reshape(-1, 2)
    ref = np.asarray(reference, np.float64).reshape(-1, 2)
    matches: list[tuple[int, int, float]] = []
    if len(det) and len(ref):
        d = np.hypot(det[:, None, 0] - ref[None, :, 0], det[:, None, 1] - ref[None, :, 1])
        cost = np.where(d <= tolerance, d, 1e6 + d)
        rows, cols = linear_sum_assignment(cost)
        matches = [(int(r), int(c), float(d[r, c])) for r, c in zip(rows, cols, strict=True)
                   if d[r, c] <= tolerance]
    md = {m[0] for m in matches}
    mr = {m[1] for m in matches}
    return Evaluation(
        tp=len(matches), fp=len(det) - len(matches), fn=len(ref) - len(matches),
        tolerance=tolerance, matches=tuple(matches),
        unmatched_detections=tuple(i for i in range(len(det)) if i not in md),
        unmatched_references=tuple(j for j in range(len(ref)) if j not in mr),
        reference_ids=tuple(reference_ids))


#: Reference header names understood (after units and quotes are dropped).
_REF_NAMES = {"x": "x", "easting": "x", "east": "x", "e": "x", "y": "y", "northing": "y", "north": "y",
              "n": "y", "id": "id", "name": "id", "label": "id", "reef": "id", "number": "id"}


def _plain(cell: str) -> str:
    """A header cell in lower case without quotes and units (``Easting (m)`` -> ``easting``)."""
    import re

    return re.sub(r"\s*[\(\[].*?[\)\]]\s*", "", cell.strip().strip('"')).strip().lower()


def read_reference(path: str | Path) -> tuple[np.ndarray, tuple[Any, ...]]:
    """Read a reference CSV of ``x, y[, id]`` (a header row is optional).

    Returns the positions (R, 2) and the ids (1-based row numbers when there is no id
    column). A bad row raises :class:`InputError` naming the line and column.

    Parameters
    ----------
    path : path-like

    Returns
    -------
    positions : ndarray, shape (R, 2)
    ids : tuple

    Raises
    ------
    FileAccessError
        No such file.
    InputError
        A bad row, naming the line and column.
    """
    p = Path(path)
    if not p.exists():
        raise FileAccessError(f"{p}: no such file")
    if p.is_dir():
        raise FileAccessError(f"{p}: is a directory, expected a reference CSV")
    xy: list[tuple[float, float]] = []
    ids: list[Any] = []
    cols = (0, 1, 2)
    with open(p, newline="", encoding="utf-8-sig") as fh:  # Excel's "CSV UTF-8" starts with a BOM
        sample = fh.read(4096)
        fh.seek(0)
        delim = ";" if sample.count(";") > sample.count(",") else ("\t" if "\t" in sample and
                                                                   "," not in sample else ",")
        first = True
        for lineno, row in enumerate(csv.reader(fh, delimiter=delim), start=1):
            cells = [c.strip() for c in row]
            if not any(cells) or cells[0].startswith("#"):
                continue
            if first:
                first = False
                low = [_REF_NAMES.get(_plain(c), _plain(c)) for c in cells]
                if "x" in low and "y" in low:
                    cols = (low.index("x"), low.index("y"), low.index("id") if "id" in low else -1)
                    continue
                try:
                    float(cells[0])
                except ValueError:
                    raise InputError(f"{p}, line {lineno}: header {cells} has no x and y columns") from None
            if len(cells) <= max(cols[0], cols[1]):
                raise InputError(f"{p}, line {lineno}: {len(cells)} values, expected at least "
                                 f"{max(cols[0], cols[1]) + 1} (x, y[, id])")
            vals = []
            for c in cols[:2]:
                try:
                    v = float(cells[c])
                except ValueError:
                    raise InputError(f"{p}, line {lineno}, column {c + 1}: {cells[c]!r} is not a "
                                     "number") from None
                if not math.isfinite(v):
                    raise InputError(f"{p}, line {lineno}, column {c + 1}: {cells[c]!r} is not finite")
                vals.append(v)
            xy.append((vals[0], vals[1]))
            ids.append(cells[cols[2]] if 0 <= cols[2] < len(cells) else len(xy))
    if not xy:
        raise InputError(f"{p}: the reference file holds no positions")
    ids = [int(i) if isinstance(i, str) and i.isdigit() else i for i in ids]
    return np.array(xy), tuple(ids)
