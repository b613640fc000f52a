"""Stage 7: reefs grouped by their centres, groups described."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from ..geometry import convex_hull, polygon_area
from ..segment import components
from .results import Reef

__all__ = ["group_reefs", "number_reefs"]


def group_reefs(reefs: Sequence[Reef], link: float) -> tuple[list[int], list[dict[str, Any]]]:
    """Reefs grouped: centres chained within ``link`` m; groups numbered in reading order
    (rows of ``link`` m from the northernmost group southward, west to east within a row).

    Parameters
    ----------
    reefs : sequence of Reef
    link : float
        Linking distance (m).

    Returns
    -------
    group_ids : list of int
        Each reef's group, from 1.
    groups : list of dict
        Per group: id, count, centre x and y, hull area and reef area (m²), mean height (m).
    """
    if not reefs:
        return [], []
    xy = np.array([[r.x, r.y] for r in reefs])
    lab = components(xy, eps=link, min_points=1)
    centres = np.array([xy[lab == g].mean(axis=0) for g in range(lab.max() + 1)])
    # rows counted from the northernmost group, so that the order does not depend on the origin
    rows = np.round((centres[:, 1].max() - centres[:, 1]) / max(link, 1e-9))
    order = np.lexsort((centres[:, 0] - centres[:, 0].min(), rows))
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    gid = [int(rank[g]) + 1 for g in lab]
    groups = []
    for g in range(1, len(order) + 1):
        members = [r for r, k in zip(reefs, gid, strict=True) if k == g]
        outline = np.concatenate([np.asarray(m.outline) if m.outline else np.array([[m.x, m.y]])
                                  for m in members])
        hull = convex_hull(outline)
        groups.append({"id": g, "count": len(members),
                       "x": float(np.mean([m.x for m in members])),
                       "y": float(np.mean([m.y for m in members])),
                       "area": polygon_area(hull) if len(hull) >= 3 else 0.0,
                       "reef_area": float(sum(m.area for m in members)),
                       "mean_height": float(np.mean([m.height for m in members]))})
    return gid, groups


def number_reefs(reefs: Sequence[Reef], link: float) -> tuple[list[Reef], list[dict[str, Any]]]:
    """Reefs in reading order (rows of 3 m from the northernmost reef southward, west to
    east within a row) with ids from 1 and their groups (:func:`group_reefs`).

    Parameters
    ----------
    reefs : sequence of Reef
    link : float
        Group linking distance (m).

    Examples
    --------
    >>> from mbinspect.reefs import Reef
    >>> reefs = [Reef(0, x, y, -17.0, -16.0, 1.0, 5.0, 3.0, 3.0, 0.0, 5.0, 9.0, 50)
    ...          for x, y in ((10.0, 0.0), (0.0, 0.0), (5.0, 50.0))]
    >>> numbered, groups = number_reefs(reefs, 12.0)
    >>> [(r.id, r.x, r.y, r.group) for r in numbered], [g["count"] for g in groups]
    ([(1, 5.0, 50.0, 1), (2, 0.0, 0.0, 2), (3, 10.0, 0.0, 2)], [1, 2])

    Returns
    -------
    reefs : list of Reef
    groups : list of dict
    """
    # rows of 3 m counted from the northernmost reef: the numbers do not depend on the origin
    top = max((r.y for r in reefs), default=0.0)
    order = sorted(range(len(reefs)), key=lambda i: (round((top - reefs[i].y) / 3.0), reefs[i].x))
    ordered = [reefs[i] for i in order]
    gid, groups = group_reefs(ordered, link)
    return [replace(r, id=i + 1, group=g) for i, (r, g) in enumerate(zip(ordered, gid, strict=True))], groups
