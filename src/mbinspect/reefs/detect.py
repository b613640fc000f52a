"""Stage 2 and 4: the paper's radius filter on every sounding, and the reef points (high
above the seabed, with their feet) cleaned by a statistical filter."""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from ..checks import check_points, fail, positive
from ..filters import FilterReport, radius_outlier
from ..neighbours import Cells, count_within, kth_distance
from .ground import Seabed

__all__ = ["radius_keeping", "denoise", "reef_points", "clean_reef_points"]


def denoise(points: np.ndarray, *, radius: float = 0.5, min_neighbors: int = 3, spacing_factor: float = 0.0
            ) -> tuple[np.ndarray, FilterReport]:
    """The paper's radius filter: noise if ``<= min_neighbors`` neighbours within ``radius`` m,
    the radius growing with the local sounding spacing when ``spacing_factor`` > 0.

    With ``spacing_factor`` f, a sounding the fixed filter would remove is kept when its
    ``min_neighbors + 1``-th nearest other sounding lies within ``f`` local spacings, the
    spacing measured in plan from its 16 nearest soundings (``d16 √(π/16)``: the side of
    the square each would cover if they filled the disc evenly). A spike above or below a
    dense seabed has dense soundings around it in plan, so its radius stays small; on a deep
    or sparse line every sounding's radius grows with the line's own spacing.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        Soundings (m).
    radius : float
        r (m): the radius, and its floor when it grows.
    min_neighbors : int
        n.
    spacing_factor : float
        f (0: the paper's fixed radius).

    Returns
    -------
    keep : ndarray of bool, shape (N,)
    report : FilterReport
        How many were seen and removed (and how many the growing radius kept).

    Examples
    --------
    >>> pts = np.array([[0.0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0.1, 0.1, 0], [0.05, 0.05, 0], [9, 9, 9]])
    >>> keep, report = denoise(pts)
    >>> keep.tolist(), report.n_removed
    ([True, True, True, True, True, False], 1)
    >>> g = np.arange(0.0, 40.0, 2.0)  # a 2 m grid: the fixed 0.5 m filter removes it all
    >>> grid = np.column_stack([np.repeat(g, 20), np.tile(g, 20), np.zeros(400)])
    >>> int(denoise(grid)[0].sum()), int(denoise(grid, spacing_factor=3)[0].sum())
    (0, 400)
    """
    pts = check_points(points, minimum=0)
    cells = Cells.build(pts, radius)  # one index for both searches
    keep = radius_outlier(pts, radius=radius, min_neighbors=min_neighbors, cells=cells)
    params: dict[str, float] = {"radius": radius, "min_neighbors": min_neighbors}
    if spacing_factor > 0 and not keep.all():
        rescued = _spacing_rescue(pts, cells, ~keep, radius, min_neighbors, spacing_factor)
        keep |= rescued
        params.update(spacing_factor=spacing_factor, kept_by_spacing=int(rescued.sum()))
    return keep, FilterReport("radius", len(keep), int((~keep).sum()), params)


def _spacing_rescue(pts: np.ndarray, cells: Cells, candidates: np.ndarray, radius: float,
                    min_neighbors: int, factor: float) -> np.ndarray:
    """Which ``candidates`` have their ``min_neighbors + 1``-th neighbour within ``factor``
    local plan spacings (see :func:`denoise`).

    Each candidate's 16th plan neighbour is sought ring by ring in plan cells, then its
    limit, and the soundings within it are counted up to ``min_neighbors + 1``
    (:mod:`mbinspect.neighbours`, ``cells`` an index of ``pts``): exact distances, as a
    KD-tree over all the soundings would give, in the survey's own coordinates, so that a
    tile of it gets the very distances the whole survey gets."""
    rows = np.flatnonzero(candidates)
    out = np.zeros(len(pts), dtype=bool)
    k = min_neighbors + 1
    if len(pts) < k + 1 or len(rows) == 0:
        return out
    kp = min(16, len(pts) - 1)
    d2 = kth_distance(cells, pts[rows], kp + 1, plan=True)
    lim = np.maximum(radius, factor * d2 * math.sqrt(math.pi / kp))
    out[rows] = count_within(cells, pts[rows], lim, k + 1, strict=False) >= k + 1
    return out


def radius_keeping(points: np.ndarray, min_neighbors: int, share: float = 0.99, *, sample: int = 50_000,
                   seed: int = 0) -> float:
    """The smallest radius filter ``r`` under which ``share`` of the soundings keep more than
    ``min_neighbors`` neighbours (the ``share`` quantile of the distance to the
    ``min_neighbors + 1``-th nearest other sounding, from a seeded sample).

    Parameters
    ----------
    points : ndarray, shape (N, 3)
    min_neighbors : int
    share : float
    sample : int
    seed : int

    Returns
    -------
    float
        NaN for fewer than ``min_neighbors + 2`` soundings.

    Examples
    --------
    >>> g = np.arange(0.0, 30.0, 1.0)
    >>> grid = np.column_stack([np.repeat(g, 30), np.tile(g, 30), np.zeros(900)])
    >>> round(radius_keeping(grid, 3, 0.8), 3)  # inside a 1 m grid the 4th neighbour is 1 m away
    1.0
    >>> round(radius_keeping(grid, 3), 3)  # on its edges, on the diagonal
    1.414
    """
    from scipy.spatial import cKDTree

    pts = np.asarray(points, float)
    k = min_neighbors + 1
    if len(pts) < k + 1:
        return math.nan
    local = pts - pts.mean(axis=0)
    rng = np.random.default_rng(seed)
    rows = rng.choice(len(pts), size=min(sample, len(pts)), replace=False)
    d, _ = cKDTree(local).query(local[rows], k=k + 1)  # the first is the sounding itself
    return float(np.quantile(d[:, k], share))


def reef_points(points: np.ndarray, seabed: Seabed, *, min_height: float = 0.3,
                foot_height: float = 0.15, link: float = 0.5, height: np.ndarray | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """Reef points: above ``min_height`` m over the seabed, plus connected lower parts.

    A point between ``foot_height`` and ``min_height`` belongs to a reef when it lies
    within ``link`` m (plan) of a core point (hysteresis): the reef's feet are kept, a
    lone seabed bump is not. ``height`` may give the heights above ``seabed`` when the
    caller already has them.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        Soundings (m).
    seabed : Seabed
        The seabed surface (:func:`fit_seabed`).
    min_height, foot_height : float
        Core and foot heights above the seabed (m).
    link : float
        Plan distance (m) from a foot point to a core point.
    height : ndarray (N,), optional
        Heights above ``seabed`` (m).

    Examples
    --------
    >>> from mbinspect.simulate import simulate
    >>> sim = simulate("reef-field", seed=1, groups="cross1", per_group=4, ping_spacing=0.8,
    ...                close_pairs=0, boulders=0, debris=0)
    >>> from mbinspect.reefs import fit_seabed
    >>> from mbinspect.simulate import LABELS
    >>> seabed, _ = fit_seabed(sim.cloud.xyz)
    >>> mask, height = reef_points(sim.cloud.xyz, seabed)
    >>> bool(mask[sim.labels == LABELS["reef"]].mean() > 0.8), bool(mask[sim.labels == 0].mean() < 0.01)
    (True, True)

    Returns
    -------
    mask : ndarray of bool, shape (N,)
    height : ndarray, shape (N,)
        Height of every point above the seabed.
    """
    pts = np.asarray(points, np.float64)
    positive("min_height", min_height)
    positive("foot_height", foot_height)
    if foot_height > min_height:
        raise fail("foot_height", foot_height, f"at most min_height ({min_height} m)")
    h = seabed.height_above(pts) if height is None else np.asarray(height, np.float64)
    core = h > min_height
    low = (h > foot_height) & ~core
    mask = core.copy()
    if core.any() and low.any():
        tree = cKDTree(pts[core, :2], balanced_tree=False, compact_nodes=False)
        d, _ = tree.query(pts[low, :2], k=1, distance_upper_bound=link, workers=-1)
        idx = np.flatnonzero(low)
        mask[idx[np.isfinite(d)]] = True
    return mask, h


#: The statistical filter's mean and spread are counted over blocks of this side (m) ...
STAT_BLOCK = 5.0
#: ... within this many blocks each way of a reef point's block (5 to 10 m).
STAT_REACH = 1


def clean_reef_points(points: np.ndarray, is_reef: np.ndarray, *, k: int, std_ratio: float
                      ) -> tuple[np.ndarray, FilterReport | None]:
    """The reef points without the statistical filter's outliers (``k`` 0: unchanged).

    The paper's statistical filter, counted near each point: a reef point whose mean
    distance to its ``k`` nearest reef points exceeds the mean of that distance by
    ``std_ratio`` standard deviations is an outlier, the mean and standard deviation taken
    over the reef points in the :data:`STAT_BLOCK` m blocks (a lattice from (0, 0)) within
    :data:`STAT_REACH` blocks of its own, rather than over the whole cloud. On a scene
    that small it is the paper's filter; on a survey, a point's verdict does not depend on
    what lies farther away, so a tile of the survey gives the whole survey's answer.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
    is_reef : ndarray of bool, shape (N,)
    k : int
        Neighbours of the statistical filter; 0 switches it off.
    std_ratio : float
        Points whose mean neighbour distance exceeds the mean by this many standard
        deviations are outliers.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> pts = np.vstack([rng.uniform(0, 1, (200, 3)), [[2.0, 2.0, 3.0]]])
    >>> mask, report = clean_reef_points(pts, np.ones(201, bool), k=8, std_ratio=3.0)
    >>> bool(mask[-1]), report.n_removed
    (False, 1)

    Returns
    -------
    is_reef : ndarray of bool
        A new mask.
    report : FilterReport or None
        What the filter removed; None when it did not run.
    """
    from ..grid import cell_index

    is_reef = is_reef.copy()
    if k <= 0 or is_reef.sum() <= k:
        return is_reef, None
    idx = np.flatnonzero(is_reef)
    pts = np.asarray(points, np.float64)[idx]
    centre = pts.mean(axis=0)
    d, _ = cKDTree(pts - centre, balanced_tree=False, compact_nodes=False).query(pts - centre, k=k + 1,
                                                                                  workers=-1)
    mean_d = d[:, 1:].mean(axis=1)
    bi, bj = cell_index(pts, 0.0, 0.0, STAT_BLOCK)
    bi = bi - bi.min()
    bj = bj - bj.min()
    nbx, nby = int(bi.max()) + 1, int(bj.max()) + 1
    flat = bi * nby + bj
    r = STAT_REACH
    pad = ((r, r), (r, r))
    n = np.pad(np.bincount(flat, minlength=nbx * nby).reshape(nbx, nby), pad)
    s1 = np.pad(np.bincount(flat, mean_d, nbx * nby).reshape(nbx, nby), pad)
    s2 = np.pad(np.bincount(flat, mean_d * mean_d, nbx * nby).reshape(nbx, nby), pad)
    wn = np.zeros((nbx, nby), np.int64)
    w1 = np.zeros((nbx, nby))
    w2 = np.zeros((nbx, nby))
    for di in range(2 * r + 1):  # block sums added in one fixed order: the same bits in any tile
        for dj in range(2 * r + 1):
            wn += n[di:di + nbx, dj:dj + nby]
            w1 += s1[di:di + nbx, dj:dj + nby]
            w2 += s2[di:di + nbx, dj:dj + nby]
    mean = w1[bi, bj] / wn[bi, bj]
    std = np.sqrt(np.maximum(w2[bi, bj] / wn[bi, bj] - mean * mean, 0.0))
    ok = mean_d <= mean + std_ratio * std
    is_reef[idx[~ok]] = False
    return is_reef, FilterReport("statistical", len(idx), int((~ok).sum()), {"k": k, "std_ratio": std_ratio})
