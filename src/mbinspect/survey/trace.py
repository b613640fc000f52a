"""Which files and pings lie behind an object: its soundings' sources."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..cloud import ping_ranges, sources
from ..io import sha256_of

__all__ = ["ping_ranges", "sources", "object_soundings"]


def object_soundings(kind: str, obj: Mapping[str, Any], *, margin: float = 0.5,
                     read_options: Mapping[str, Any] | None = None,
                     recorded: Mapping[str, str] | None = None) -> list[dict[str, Any]]:
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
    recorded : mapping, optional
        File -> the sha256 the result recorded of it: a file that changed since is refused
        (its soundings would be another survey's).

    Returns
    -------
    list of dict
        ``x, y, z, file, ping`` (and ``beam``, ``beam_angle`` when the file has them) per
        sounding, in file order.

    Raises
    ------
    InputError
        An object without sources (a result of an older version), a source file gone, or
        one that is no longer the file the result was made from.
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
        want = (recorded or {}).get(src["file"])
        if want is not None and Path(src["file"]).is_file() and sha256_of(src["file"]) != want:
            raise InputError(f"{src['file']}: not the file the result was made from (its sha256 differs "
                             "from the one the result recorded); expected the survey's own files")
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
