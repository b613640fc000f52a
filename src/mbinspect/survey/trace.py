"""Which files and pings lie behind an object: its soundings' sources."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

__all__ = ["ping_ranges", "sources", "object_soundings"]


def ping_ranges(pings: np.ndarray) -> list[list[int]]:
    """Runs of consecutive ping numbers, each ``[first, last]``.

    Examples
    --------
    >>> ping_ranges(np.array([7, 3, 4, 5, 7, 9, 10]))
    [[3, 5], [7, 7], [9, 10]]
    """
    u = np.unique(np.asarray(pings, np.int64))
    if len(u) == 0:
        return []
    breaks = np.flatnonzero(np.diff(u) > 1)
    starts = np.concatenate([[0], breaks + 1])
    ends = np.concatenate([breaks, [len(u) - 1]])
    return [[int(u[a]), int(u[b])] for a, b in zip(starts, ends, strict=True)]


def sources(index: np.ndarray, fields: Mapping[str, np.ndarray], files: Sequence[str]
            ) -> tuple[dict[str, Any], ...]:
    """The files and ping ranges of the soundings ``index`` of a cloud.

    Parameters
    ----------
    index : ndarray of int
        The object's soundings (rows of the cloud).
    fields : mapping
        The cloud's fields: ``file`` (index into ``files``; absent: every sounding is from
        ``files[0]``) and ``ping`` (absent: no ranges).
    files : sequence of str
        The survey's files.

    Returns
    -------
    tuple of dict
        ``{"file", "pings" ([[first, last], ...] or None), "soundings"}`` per file, in
        file order.

    Examples
    --------
    >>> f = {"file": np.array([0, 0, 1, 1]), "ping": np.array([4, 5, 1, 9])}
    >>> sources(np.array([0, 1, 3]), f, ["a.laz", "b.laz"])[1]
    {'file': 'b.laz', 'pings': [[9, 9]], 'soundings': 1}
    """
    index = np.asarray(index, np.int64)
    file_of = fields.get("file")
    which = np.zeros(len(index), np.int64) if file_of is None else np.asarray(file_of)[index].astype(np.int64)
    ping = fields.get("ping")
    out = []
    for f in np.unique(which):
        rows = index[which == f]
        out.append({"file": str(files[int(f)]) if int(f) < len(files) else str(int(f)),
                    "pings": None if ping is None else ping_ranges(np.asarray(ping)[rows]),
                    "soundings": len(rows)})
    return tuple(out)


def object_soundings(kind: str, obj: Mapping[str, Any], *, margin: float = 0.5,
                     read_options: Mapping[str, Any] | None = None) -> list[dict[str, Any]]:
    """The soundings behind one object of a result: its source files read again, the
    soundings of its ping ranges inside it (a reef's outline, a pile's radius) plus
    ``margin`` m.

    Parameters
    ----------
    kind : {"reefs", "piles"}
    obj : mapping
        One row of ``reefs.json`` or ``piles.json`` (with ``sources``).
    margin : float
    read_options : mapping, optional
        For :func:`mbinspect.io.read` (the reading the result was made with).

    Returns
    -------
    list of dict
        ``x, y, z, file, ping`` (and ``beam``, ``beam_angle`` when the file has them) per
        sounding, in file order.

    Raises
    ------
    InputError
        An object without sources (a result of an older version), or a source file gone.
    """
    from ..errors import InputError
    from ..geometry import points_in_polygon
    from ..io import read

    srcs = obj.get("sources") or []
    if not srcs:
        raise InputError(f"object {obj.get('id')}: the result records no sources (soundings "
                         "given as an array, or a result of an older mbinspect)")
    out: list[dict[str, Any]] = []
    opts = {k: v for k, v in (read_options or {}).items() if v is not None}
    for src in srcs:
        cloud = read(src["file"], **opts)
        keep = np.ones(len(cloud), bool)
        ping = cloud.fields.get("ping")
        if ping is not None and src.get("pings"):
            inside = np.zeros(len(cloud), bool)
            for a, b in src["pings"]:
                inside |= (ping >= a) & (ping <= b)
            keep &= inside
        xy = cloud.xyz[:, :2]
        if kind == "reefs" and obj.get("outline"):
            poly = np.asarray(obj["outline"], np.float64)
            c = poly.mean(axis=0)
            grown = c + (poly - c) * (1 + margin / max(float(np.linalg.norm(poly - c, axis=1).min()), 1e-6))
            rows = np.flatnonzero(keep)
            keep[rows] = points_in_polygon(xy[rows], grown)
        else:
            reach = float(obj.get("radius") or 0.0) + margin
            keep &= np.hypot(xy[:, 0] - obj["x"], xy[:, 1] - obj["y"]) <= reach
        for r in np.flatnonzero(keep):
            row = {"x": float(cloud.xyz[r, 0]), "y": float(cloud.xyz[r, 1]), "z": float(cloud.xyz[r, 2]),
                   "file": src["file"], "ping": int(ping[r]) if ping is not None else ""}
            for name in ("beam", "beam_angle"):
                if name in cloud.fields:
                    row[name] = cloud.fields[name][r].item()
            out.append(row)
    return out
