"""Fragments of one reef (the walls of a hollow reef, a cross cut by a shadow) joined into
the whole reef they most nearly make."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from .sizes import AREA_RADIUS, diameter

__all__ = ["merge_fragments", "SPECK"]


#: Share of a single reef's area below which a footprint part is a speck, not a fragment.
SPECK = 0.01


def merge_fragments(parts: list[np.ndarray], areas: np.ndarray, nx: int, cell: float,
                     reef_area: float | np.ndarray) -> tuple[list[np.ndarray], np.ndarray]:
    """Join fragments that together make one reef.

    A thin wall square to the track can fall between two pings and vanish, so a hollow
    reef shows as two, three or four separate walls. Fragments (parts under 0.6 of the
    single-reef area there, ``reef_area`` per part or one value) are joined while the
    union stays no larger than one reef: area within 1.3 reef areas and
    diameter within 1.15 times the 90th-percentile diameter of the single reefs around it
    (within :data:`AREA_RADIUS` m, or its 3 nearest) plus one cell (a field may mix kinds
    of reef), the union whose diameter is nearest to that of the whole reefs around it
    first. A union stays open to more fragments while it is
    smaller than one reef area.

    Parameters
    ----------
    parts : list of ndarray
        Each part's flat raster cells.
    areas : ndarray
        Their areas (m²).
    nx : int
        Raster columns.
    cell : float
        Cell size (m).
    reef_area : float or ndarray
        Single-reef area (m²), one or per part.

    Returns
    -------
    parts : list of ndarray
    areas : ndarray
    """
    ra = np.broadcast_to(np.asarray(reef_area, np.float64), (len(parts),))
    if len(parts) < 2 or not np.isfinite(ra).any():
        return parts, areas
    # fragments: under 0.6 of a reef, over a hundredth of one (specks of noise join no reef,
    # and thousands of them in a noisy field made the pairing below quadratic)
    frag = [i for i in range(len(parts)) if SPECK * ra[i] < areas[i] < 0.6 * ra[i]]
    single = [i for i in range(len(parts)) if 0.7 * ra[i] <= areas[i] <= 1.3 * ra[i]]
    if len(frag) < 2 or not single:
        return parts, areas

    def cells_xy(p: np.ndarray) -> np.ndarray:
        j, k = np.divmod(p, nx)
        return np.column_stack([k, j]).astype(np.float64) * cell

    diam = np.array([diameter(cells_xy(parts[i])) for i in single])
    singles = _Singles(cKDTree(np.array([cells_xy(parts[i]).mean(axis=0) for i in single])), diam, cell)
    limit = 1.15 * float(diam.max()) + cell  # no union anywhere is wider
    # open unions: (cells, their plan positions, area, single-reef area there, centre)
    pool = {}
    for i in frag:
        xy = cells_xy(parts[i])
        pool[i] = (parts[i], xy, float(areas[i]), float(ra[i]), xy.mean(axis=0))
    parts = list(parts)
    gone = _join(pool, parts, lambda a, b: _union_score(pool, singles, a, b), limit)
    out = [p for i, p in enumerate(parts) if i not in gone]
    return out, np.array([len(p) for p in out]) * cell * cell


class _Singles:
    """The whole single reefs near a place: those within :data:`AREA_RADIUS` m, or else its
    3 nearest (so that nothing depends on reefs far away, nor on what else a tile of a
    survey holds), and their diameters."""

    def __init__(self, tree: cKDTree, diam: np.ndarray, cell: float) -> None:
        self.tree, self.diam, self.cell = tree, diam, cell

    def near(self, c: np.ndarray) -> np.ndarray:
        near = self.tree.query_ball_point(c, AREA_RADIUS)
        if len(near) < 3:
            near = np.atleast_1d(self.tree.query(c, k=min(3, len(self.diam)))[1])
        return self.diam[np.asarray(near, int)]

    def typical(self, c: np.ndarray) -> float:
        """The diameter of a whole reef there."""
        return float(np.median(self.near(c)))

    def limit_at(self, c: np.ndarray) -> float:
        """The largest union there."""
        return 1.15 * float(np.percentile(self.near(c), 90)) + self.cell


def _union_score(pool: dict[int, Any], singles: _Singles, a: int, b: int) -> float | None:
    """How nearly fragments ``a`` and ``b`` make one whole reef (lower is nearer; None: not
    one reef): of the possible unions, first the one spanning most nearly one whole reef
    (two walls of one hollow reef, not the facing walls of two neighbours)."""
    _, xa, aa, ra_a, ca = pool[a]
    _, xb, ab, ra_b, cb = pool[b]
    if aa + ab > 1.3 * max(ra_a, ra_b):
        return None
    d_union = diameter(np.vstack([xa, xb]))
    mid = (ca + cb) / 2
    return abs(d_union - singles.typical(mid)) if d_union <= singles.limit_at(mid) else None


def _join(pool: dict[int, Any], parts: list[np.ndarray], score: Callable[[int, int], float | None],
          limit: float) -> set[int]:
    """Join the best-scoring pair of open fragments until none scores; ``parts`` takes the
    unions, and the parts absorbed into another are returned.

    Only fragments whose centres lie within ``limit`` can be one reef: asked of a tree, so
    that a noisy field's many specks do not make every pair a candidate; each pair is
    scored once, and after a union only the union's pairs again.
    """
    gone: set[int] = set()
    keys = sorted(pool)
    near = cKDTree(np.array([pool[k][4] for k in keys])).query_pairs(limit, output_type="ndarray")
    scores = {(keys[i], keys[j]): score(keys[i], keys[j]) for i, j in map(tuple, near)}
    while True:
        valid = [(v, ab) for ab, v in scores.items() if v is not None]
        if not valid:
            return gone
        _, (a, b) = min(valid)  # the lowest score; of equal scores the first pair
        pa, xa, aa, ra_a, _ = pool.pop(a)
        pb, xb, ab, ra_b, _ = pool.pop(b)
        scores = {k: v for k, v in scores.items() if a not in k and b not in k}
        parts[a] = np.concatenate([pa, pb])
        gone.add(b)
        r = max(ra_a, ra_b)
        if aa + ab < r:  # still smaller than one reef: open to more fragments
            xy = np.vstack([xa, xb])
            pool[a] = (parts[a], xy, aa + ab, r, xy.mean(axis=0))
            c = pool[a][4]
            for k in pool:
                if k != a and np.hypot(*(pool[k][4] - c)) <= limit:
                    scores[min(a, k), max(a, k)] = score(min(a, k), max(a, k))
