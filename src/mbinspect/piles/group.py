"""Stage 6b: piles grouped into jackets, as the pile paper groups them (its groups 38 and 39)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.sparse.csgraph import connected_components, minimum_spanning_tree
from scipy.spatial.distance import pdist, squareform

from .design import Design
from .results import PileFit

__all__ = ["group_piles", "jacket_groups"]


def jacket_groups(xy: np.ndarray, *, ratio: float = 1.3) -> np.ndarray:
    """Jackets among pile centres: piles of one jacket lie closer than the gap between jackets.

    The minimum spanning tree of the centres is cut at its largest jump in edge length
    that exceeds ``ratio`` and leaves every jacket at least three piles; otherwise all piles
    are one group.

    Parameters
    ----------
    xy : ndarray, shape (K, 2)
        Pile centres (m).
    ratio : float
        Smallest jump between sorted tree edges that separates jackets.

    Returns
    -------
    ndarray of int, shape (K,)
        Group 1, 2... of each pile, numbered west to east (then south to north).

    Examples
    --------
    >>> sq = np.array([[0, 0], [14, 0], [0, 14], [14, 14]], float)
    >>> jacket_groups(np.vstack([sq, sq + [40, 0]])).tolist()
    [1, 1, 1, 1, 2, 2, 2, 2]
    >>> jacket_groups(np.array([[0, 0], [10, 0], [0, 14], [10, 14]], float)).tolist()  # one rectangle
    [1, 1, 1, 1]
    """
    xy = np.asarray(xy, np.float64)
    if len(xy) < 3:
        return np.ones(len(xy), dtype=np.int64)
    tree = minimum_spanning_tree(squareform(pdist(xy))).toarray()
    edges = np.sort(tree[tree > 0])
    jumps = edges[1:] / np.maximum(edges[:-1], 1e-9)
    labels = np.zeros(len(xy), dtype=np.int64)
    # the largest jumps first; a cut stands only if every jacket keeps three piles or more
    # (a rectangular jacket's long side is a jump too, but would leave pairs)
    for k in np.argsort(-jumps):
        if jumps[k] < ratio:
            break
        cut = float(np.sqrt(edges[k] * edges[k + 1]))
        _, trial = connected_components(np.where(tree > cut, 0, tree), directed=False)
        if np.bincount(trial).min() >= 3:
            labels = trial
            break
    if labels.max() == 0:
        return np.ones(len(xy), dtype=np.int64)
    centres = np.array([xy[labels == k].mean(axis=0) for k in range(labels.max() + 1)])
    order = np.lexsort((centres[:, 1], centres[:, 0]))
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return rank[labels] + 1


def group_piles(piles: tuple[PileFit, ...], design: Design | None, *, mode: str = "auto"
                ) -> tuple[PileFit, ...]:
    """The piles with their jacket (``group``): the design's groups when it has them, else
    found from the centres (``mode="auto"``, :func:`jacket_groups`), or one group (``"none"``).

    Parameters
    ----------
    piles : tuple of PileFit
        With their design ids when the design gives positions.
    design : Design, optional
    mode : {"auto", "none"}

    Returns
    -------
    tuple of PileFit
    """
    if design is not None and design.groups:
        return tuple(replace(p, group=design.groups.get(p.id, 0)) for p in piles)
    if mode == "none" or not piles:
        return piles
    labels = jacket_groups(np.array([[p.x, p.y] for p in piles]))
    return tuple(replace(p, group=int(g)) for p, g in zip(piles, labels, strict=True))
