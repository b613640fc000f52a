"""Stage 5b: the footprint's parts made single reefs: fragments of one reef joined, parts
of several reefs (close or touching) split by K-means, small ones set aside."""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from ..geometry import convex_hull
from ..segment import kmeans
from .footprint import Raster, label_parts, nearest_label_raster

__all__ = ["split_reefs", "split_large", "local_reef_area", "merge_fragments", "row_ends", "diameter"]


#: Fewest parts of at least ``min_area`` from which a single-reef area is learnt (fewer:
#: no part is split, unless ``reef_area`` is given).
LEARN_PARTS = 5

#: Single-reef areas are learnt from the parts within this many metres (a tiled survey reads
#: at least this far beyond each tile).
AREA_RADIUS = 22.0


def local_reef_area(parts: list[np.ndarray], areas: np.ndarray, nx: int, cell: float, overall: float,
                     radius: float = AREA_RADIUS, min_parts: int = 5, among: np.ndarray | None = None
                     ) -> np.ndarray:
    """Single-reef area near each part: the median area of the parts within ``radius`` m.

    A field may hold several kinds of reef in separate groups; a pair of small reefs that
    touch must be judged against its own kind. Only the parts flagged in ``among`` (all by
    default) count; fewer than ``min_parts`` of them around: the ``min_parts`` nearest;
    fewer than that in all: ``overall``.

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
    overall : float
        The field's single-reef area (m²).
    radius : float
        Neighbourhood (m).
    min_parts : int
    among : ndarray of bool, optional

    Returns
    -------
    ndarray
        Single-reef area near each part (m²).
    """
    if not parts:
        return np.zeros(0)
    centres = np.array([[(p % nx).mean(), (p // nx).mean()] for p in parts]) * cell
    use = np.ones(len(parts), bool) if among is None else np.asarray(among, bool)
    if not use.any():
        return np.full(len(parts), overall)
    sel = np.flatnonzero(use)
    tree = cKDTree(centres[sel])
    near = tree.query_ball_point(centres, radius)
    out = np.full(len(parts), overall)
    for k, n in enumerate(near):
        if len(n) < min_parts and len(sel) >= min_parts:
            # fewer around: the nearest ``min_parts`` (not the whole cloud, so that a tile of
            # a survey learns what the whole survey learns)
            n = np.atleast_1d(tree.query(centres[k], k=min_parts)[1])
        if len(n) >= min_parts:
            out[k] = float(np.median(areas[sel[np.asarray(n, int)]]))
    return out


def row_ends(xy: np.ndarray) -> np.ndarray:
    """The first and last point of every row (equal y) of a point set: the same convex
    hull as all of them (every point lies between its row's ends), far fewer points.

    Parameters
    ----------
    xy : ndarray, shape (N, 2)

    Returns
    -------
    ndarray, shape (M, 2)

    Examples
    --------
    >>> row_ends(np.array([[0.0, 0], [1, 0], [2, 0], [0, 1]])).tolist()
    [[0.0, 0.0], [2.0, 0.0], [0.0, 1.0]]
    """
    order = np.lexsort((xy[:, 0], xy[:, 1]))
    y = xy[order, 1]
    new = y[1:] != y[:-1]
    return xy[order[np.r_[True, new] | np.r_[new, True]]]


def diameter(xy: np.ndarray) -> float:
    """Largest distance between two of the points (on their convex hull).

    Parameters
    ----------
    xy : ndarray, shape (N, 2)

    Returns
    -------
    float

    Examples
    --------
    >>> diameter(np.array([[0.0, 0], [3, 0], [3, 4], [1, 1]]))
    5.0
    """
    h = convex_hull(row_ends(xy))
    if len(h) < 2:
        return 0.0
    d = h[:, None, :] - h[None, :, :]
    return float(np.sqrt((d**2).sum(axis=2)).max())


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
    # the single reefs near a place: those within AREA_RADIUS m, or else its 3 nearest (so
    # that nothing depends on reefs far away, nor on what else a tile of a survey holds)
    s_centres = np.array([cells_xy(parts[i]).mean(axis=0) for i in single])
    s_tree = cKDTree(s_centres)

    def near_singles(c: np.ndarray) -> np.ndarray:
        near = s_tree.query_ball_point(c, AREA_RADIUS)
        if len(near) < 3:
            near = np.atleast_1d(s_tree.query(c, k=min(3, len(single)))[1])
        return diam[np.asarray(near, int)]

    def typical(c: np.ndarray) -> float:  # the diameter of a whole reef there
        return float(np.median(near_singles(c)))

    def limit_at(c: np.ndarray) -> float:  # the largest union there
        return 1.15 * float(np.percentile(near_singles(c), 90)) + cell

    limit = 1.15 * float(diam.max()) + cell  # no union anywhere is wider

    # open unions: (cells, their plan positions, area, single-reef area there, centre)
    pool = {}
    for i in frag:
        xy = cells_xy(parts[i])
        pool[i] = (parts[i], xy, float(areas[i]), float(ra[i]), xy.mean(axis=0))
    parts = list(parts)
    gone: set[int] = set()  # parts absorbed into another

    def score(a: int, b: int) -> float | None:  # how nearly a and b make one whole reef
        _, xa, aa, ra_a, ca = pool[a]
        _, xb, ab, ra_b, cb = pool[b]
        if aa + ab > 1.3 * max(ra_a, ra_b):
            return None
        # of the possible unions, first the one spanning most nearly one whole reef
        # (two walls of one hollow reef, not the facing walls of two neighbours)
        d_union = diameter(np.vstack([xa, xb]))
        mid = (ca + cb) / 2
        return abs(d_union - typical(mid)) if d_union <= limit_at(mid) else None

    # only fragments whose centres lie within ``limit`` can be one reef: asked of a tree,
    # so that a noisy field's many specks do not make every pair a candidate; each pair is
    # scored once, and after a union only the union's pairs again
    keys = sorted(pool)
    near = cKDTree(np.array([pool[k][4] for k in keys])).query_pairs(limit, output_type="ndarray")
    scores = {(keys[i], keys[j]): score(keys[i], keys[j]) for i, j in map(tuple, near)}
    while True:
        valid = [(v, ab) for ab, v in scores.items() if v is not None]
        if not valid:
            break
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
    out = [p for i, p in enumerate(parts) if i not in gone]
    return out, np.array([len(p) for p in out]) * cell * cell


def split_reefs(points: np.ndarray, is_reef: np.ndarray, *, cell: float = 0.1,
                reach: float = 0.6, reef_area: float | None = None, min_area: float = 1.0,
                split_factor: float = 1.5, own: float = 1.5, bridge: float = 3.5,
                link: float = 0.3, seed: int = 0, height: np.ndarray | None = None,
                wall: float = 0.7
                ) -> tuple[list[np.ndarray], list[np.ndarray], Raster, float]:
    """Single reefs from reef points.

    A plan raster of ``cell`` m is labelled by its nearest sounding within ``reach`` m
    (reef or seabed), which places each outline halfway between reef and seabed
    soundings; a reef cell must also lie within ``own`` sounding spacings (the median
    distance between neighbouring soundings there) of a reef sounding, so that no reef
    spreads into its acoustic shadow; a sounding on a side wall (lower than ``wall`` times
    the highest reef sounding within 0.4 m, given ``height`` above the seabed) marks the
    edge itself and claims only the cells on the reef's side of it; gaps between pings
    inside a reef are bridged by a closing of radius ``bridge`` spacings (which does not
    grow outer edges) and enclosed gaps filled; parts closer than ``2 * link`` m are one
    candidate (walls of a hollow reef). Scaling ``own`` and ``bridge`` with the spacing
    keeps the footprint unbiased from sparse to dense surveys.
    A part whose area exceeds
    ``split_factor`` times the single-reef area (``reef_area``, or else the median area of
    the parts of at least ``min_area`` within :data:`AREA_RADIUS` m, so that each group of a mixed field is
    judged by its own kind) holds ``round(area / reef_area)`` reefs and is split by
    seeded K-means on its cells.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        Soundings (m).
    is_reef : ndarray of bool, shape (N,)
    cell : float
        Raster cell (m).
    reach : float
        Labelled cells lie within this of a reef sounding (m).
    reef_area : float, optional
        Single-reef area (m²); learnt when None.
    min_area : float
        Smaller parts are other objects (m²).
    split_factor : float
    own, bridge : float
        In sounding spacings (:func:`nearest_label_raster`).
    link : float
        Half the gap joining parts (m).
    seed : int
    height : ndarray (N,), optional
        Heights above the seabed (m).
    wall : float

    Examples
    --------
    >>> from mbinspect.simulate import simulate
    >>> sim = simulate("reef-field", seed=1, groups="cross1", per_group=4, ping_spacing=0.8,
    ...                close_pairs=0, boulders=0, debris=0)
    >>> from mbinspect.reefs import fit_seabed, reef_points
    >>> seabed, _ = fit_seabed(sim.cloud.xyz)
    >>> is_reef, height = reef_points(sim.cloud.xyz, seabed)
    >>> reefs, others, raster, area = split_reefs(sim.cloud.xyz, is_reef, height=height)
    >>> len(reefs), area  # four reefs are too few to learn a single reef's area from
    (4, nan)

    Returns
    -------
    reefs, others : lists of cell-index arrays (flat indices into the raster) of reefs and
        of objects smaller than ``min_area``
    raster : the labelled raster
    reef_area : the single-reef area used (m²)
    """
    pts = np.asarray(points, np.float64)
    if not is_reef.any():
        empty = Raster(0.0, 0.0, cell, np.zeros((1, 1), np.int64), np.full((1, 1), -1))
        return [], [], empty, reef_area or math.nan
    reef_mask, nearest, x0, y0 = nearest_label_raster(pts, is_reef, cell=cell, reach=reach,
                                                      own=own, bridge=bridge, height=height,
                                                      wall=wall, seed=seed)
    parts, (ny, nx) = label_parts(reef_mask, cell=cell, link=link)
    areas = np.array([len(p) for p in parts]) * cell * cell
    big = areas >= min_area
    given_area = reef_area
    if reef_area is None:
        # learnt from a few reefs at least: the median of two reefs of two kinds would
        # split the larger in two
        reef_area = float(np.median(areas[big])) if big.sum() >= LEARN_PARTS else math.nan
        near_area = local_reef_area(parts, areas, nx, cell, reef_area, among=big)
    else:
        near_area = np.full(len(parts), reef_area)
    parts, areas = merge_fragments(parts, areas, nx, cell, near_area)
    big = areas >= min_area
    others = [p for p, b in zip(parts, big, strict=True) if not b]
    big_parts = [p for p, b in zip(parts, big, strict=True) if b]
    local_area = local_reef_area(big_parts, areas[big], nx, cell, reef_area) if given_area is None \
        else np.full(len(big_parts), reef_area)
    reefs = split_large(big_parts, areas[big], local_area, nx=nx, cell=cell, split_factor=split_factor,
                        seed=seed, origin=(int(round(x0 / cell)), int(round(y0 / cell))))
    labels = np.zeros(ny * nx, dtype=np.int64)
    for i, p in enumerate(reefs):
        labels[p] = i + 1
    return reefs, others, Raster(x0, y0, cell, labels.reshape(ny, nx), nearest), reef_area


def split_large(parts: list[np.ndarray], areas: np.ndarray, reef_area: np.ndarray, *, nx: int, cell: float,
                split_factor: float = 1.5, seed: int = 0, origin: tuple[int, int] = (0, 0)
                ) -> list[np.ndarray]:
    """Parts larger than ``split_factor`` single reefs split into ``round(area / reef_area)``
    reefs by K-means on their cells (seeded by ``seed`` and the part's first cell counted
    from (0, 0), ``origin`` being the raster's corner in cells).

    Parameters
    ----------
    parts : list of ndarray
        Flat raster cell indices of each part.
    areas, reef_area : ndarray
        Each part's area and the single-reef area around it (m²).
    nx : int
        Raster columns.
    cell : float
        Raster cell (m).
    split_factor : float
        A part above this many single-reef areas is several reefs.
    seed : int

    Examples
    --------
    >>> cells = np.arange(200)  # a 20 x 10 strip of 0.1 m cells: two 1 m² reefs side by side
    >>> [len(p) for p in split_large([cells], np.array([2.0]), np.array([1.0]), nx=20, cell=0.1)]
    [100, 100]

    Returns
    -------
    list of ndarray
        The single reefs' cells.
    """
    reefs: list[np.ndarray] = []
    for p, a, ra in zip(parts, areas, reef_area, strict=True):
        n = max(2, int(round(a / ra))) if math.isfinite(ra) and a > split_factor * ra else 1
        if n <= 1:
            reefs.append(p)
            continue
        cj, ci = np.divmod(p, nx)
        # seeded by the part's own first cell, counted from (0, 0) modulo 1,000 cells: the
        # same part gets the same split in any tile, whatever else the cloud holds, and
        # wherever a survey moved by a whole number of 1,000 cells puts it
        first = int(np.argmin(p))
        own_seed = [seed, (int(origin[0]) + int(ci[first])) % 1000, (int(origin[1]) + int(cj[first])) % 1000]
        xy = np.column_stack([ci - ci.min(), cj - cj.min()]).astype(np.float64) * cell
        lab_k, _ = kmeans(xy, n, seed=own_seed)
        reefs += [p[lab_k == j] for j in range(n) if (lab_k == j).any()]
    return reefs
