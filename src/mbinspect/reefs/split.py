"""Stage 5b: the footprint's parts made single reefs: fragments of one reef joined, parts
of several reefs (close or touching) split by K-means, small ones set aside."""

from __future__ import annotations

import math

import numpy as np

from ..segment import kmeans
from .footprint import Raster, label_parts, nearest_label_raster
from .merge import merge_fragments
from .sizes import AREA_RADIUS, LEARN_PARTS, diameter, local_reef_area, row_ends

__all__ = ["split_reefs", "split_large", "local_reef_area", "merge_fragments", "row_ends", "diameter",
           "AREA_RADIUS"]


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
