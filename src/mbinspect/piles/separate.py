"""Stage 2: the elevated points separated into piles, in a stable order."""

from __future__ import annotations

import numpy as np

from ..checks import integer
from ..segment import components, kmeans

__all__ = ["stable_order", "separate_piles"]


def stable_order(xy: np.ndarray) -> np.ndarray:
    """Indices of pile centres in the documented order: rows south to north, then west to east.

    A new row starts where the northing jumps by more than half the smallest spacing.

    Parameters
    ----------
    xy : ndarray, shape (K, 2)
        Pile centres (m).

    Returns
    -------
    ndarray of int, shape (K,)

    Examples
    --------
    >>> stable_order(np.array([[22.0, 22.0], [0.0, 0.0], [0.0, 22.0], [22.0, 0.0]])).tolist()
    [1, 3, 2, 0]
    """
    xy = np.asarray(xy, np.float64)
    if len(xy) <= 1:
        return np.arange(len(xy))
    d = np.hypot(*(xy[:, None, :] - xy[None, :, :]).transpose(2, 0, 1))
    np.fill_diagonal(d, np.inf)
    gap = 0.5 * float(d.min())
    by_y = np.argsort(xy[:, 1], kind="stable")
    rows = np.cumsum(np.r_[0, np.diff(xy[by_y, 1]) > gap])
    row_of = np.empty(len(xy), dtype=np.int64)
    row_of[by_y] = rows
    return np.lexsort((xy[:, 0], row_of))


def separate_piles(points: np.ndarray, *, count: int | None = None, radius: float,
                   seed: int = 0, link: float = 0.4, min_points: int = 30
                   ) -> tuple[np.ndarray, list[str]]:
    """Split elevated points into piles.

    First the connected parts (points closer than ``link`` m in plan) that look like a
    pile (at least ``min_points``, no wider than ``2 r + 2`` m); lone clumps are left
    out. With ``count``, the paper's K-means (k-means++ seeding, seeded) runs on those
    points: a part that K-means splits into several large shares is touching piles and is
    split accordingly, while a K-means cluster can never take a neighbour's or stray
    points, because labels follow the parts. More parts than ``count``: the largest are
    kept; fewer: all are kept, with a warning.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        The elevated points (m).
    count : int, optional
        The number of piles K; None finds them from the data.
    radius : float
        Prior pile radius (m).
    seed : int
        K-means seed.
    link : float
        Plan distance (m) that connects points of one part.
    min_points : int
        Fewest points of a pile.

    Returns
    -------
    labels : ndarray of int, shape (N,)
        0..K-1 in the stable order (:func:`stable_order`); -1 for points of no pile.
    warnings : list of str

    Examples
    --------
    >>> g = np.linspace(-0.5, 0.5, 15)
    >>> a = np.column_stack([np.repeat(g, 15), np.tile(g, 15), np.zeros(225)])
    >>> labels, _ = separate_piles(np.vstack([a + [0, 22, 0], a]), count=2, radius=0.75)
    >>> np.bincount(labels).tolist(), int(labels[0])
    ([225, 225], 1)
    """
    pts = np.asarray(points, np.float64)
    warnings: list[str] = []
    if count is not None:
        integer("count", count, minimum=1)
    labels = np.full(len(pts), -1, dtype=np.int64)
    if len(pts) == 0:
        return labels, ["no points stand above the seabed"]
    comp = components(pts[:, :2], eps=link, min_points=min_points)
    parts: list[np.ndarray] = []
    wide = 0
    for c in range(int(comp.max()) + 1 if (comp >= 0).any() else 0):
        idx = np.flatnonzero(comp == c)
        span = float(np.ptp(pts[idx, :2], axis=0).max())
        if span > 2 * radius + 2.0 and count is None:
            wide += 1
            continue
        parts.append(idx)
    if wide:
        warnings.append(f"{wide} structure(s) wider than a pile of radius {radius} m were left out")
    if count is not None and parts:
        parts = _split_by_kmeans(pts, parts, count, radius, seed=seed, min_points=min_points)
        if len(parts) > count:
            parts.sort(key=len, reverse=True)
            warnings.append(f"count {count}: the data show {len(parts)} pile-like structures; "
                            f"the {count} largest were kept")
            parts = parts[:count]
        elif len(parts) < count:
            warnings.append(f"count {count}: only {len(parts)} piles found in the data; "
                            f"results are given for those {len(parts)}")
    if not parts:
        return labels, warnings + ["no pile found among the points above the seabed"]
    centres = np.array([pts[idx, :2].mean(axis=0) for idx in parts])
    for new_id, k in enumerate(stable_order(centres)):
        labels[parts[k]] = new_id
    for k, idx in enumerate(parts):
        span = float(np.ptp(pts[idx, :2], axis=0).max())
        if span > 2 * radius + 1.5:
            warnings.append(f"a pile cluster near ({centres[k, 0]:.1f}, {centres[k, 1]:.1f}) spans "
                            f"{span:.1f} m in plan, more than a pile of radius {radius} m: "
                            "merged structures?")
    return labels, warnings


def _split_by_kmeans(pts: np.ndarray, parts: list[np.ndarray], count: int, radius: float, *, seed: int,
                     min_points: int) -> list[np.ndarray]:
    """The paper's K-means on the parts' points: a part it splits into several large shares
    (touching piles) is split accordingly; labels follow the parts, so no cluster takes a
    neighbour's or stray points."""
    sel = np.concatenate(parts)
    # K-means splits a part only into its large shares (at most 1 / 0.25 = 4), and a
    # part no wider than one pile not at all: more clusters than that cannot be found
    possible = sum(1 if float(np.ptp(pts[idx, :2], axis=0).max()) <= 2 * radius + 0.5 else 4
                   for idx in parts)
    km, _ = kmeans(pts[sel, :2], min(count, len(sel), possible), seed=seed)
    km_of = np.full(len(pts), -1, dtype=np.int64)
    km_of[sel] = km
    split: list[np.ndarray] = []
    for idx in parts:
        shares = np.bincount(km_of[idx])
        big = np.flatnonzero(shares >= max(min_points, 0.25 * len(idx)))
        one_pile = float(np.ptp(pts[idx, :2], axis=0).max()) <= 2 * radius + 0.5
        if len(big) <= 1 or one_pile:
            split.append(idx)
        else:
            split += [idx[km_of[idx] == k] for k in big]
    return split
