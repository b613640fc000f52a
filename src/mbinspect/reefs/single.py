"""Stage 6 of the reefs: the single reefs among the reef points, each measured, fitted by its
design and judged (:mod:`mbinspect.reefs.reject`); groups of reef points far apart measured
apart (:func:`reef_islands`), so that time and memory follow the reef points."""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np
from scipy import ndimage

from ..grid import cell_index, fill_holes
from ..noise import robust_sigma
from ..reef_designs import ReefDesign
from ..seabed import GROUND_BAND
from ..strays import cell_groups
from .beam import Bloom, Sight, unbloom_parts
from .fit_design import fit_reef_design, join_by_design, share_by_design, with_design
from .footprint import Raster
from .ground import Seabed
from .least import with_least_depth
from .measure import measure_reef, own_soundings, soundings_around
from .options import ReefOptions
from .orient import overturned_unit, with_rest
from .pose import DesignFit
from .reject import Candidate, Context, design_misfit, other_object, why_not_a_reef
from .results import OtherObject, Reef
from .shape import cone_radius, cone_reach, ground_soundings
from .split import split_reefs

__all__ = ["reef_islands", "single_reefs", "ISLAND_GAP", "ISLAND_CELL"]


#: Reef points farther apart than this (m) are measured apart, each group on the soundings
#: around it: no stage links soundings that far (the single-reef area looks
#: :data:`~mbinspect.reefs.split.AREA_RADIUS` m around, the footprint spacing and the
#: statistical filter 10 m), and a raster then spans each group, not
#: the survey (strips kilometres apart made one raster of their whole extent).
ISLAND_GAP = 50.0
#: Side (m) of the plan cells the groups are found in; a group's soundings are those in its
#: reef points' cells and the cells around them.
ISLAND_CELL = 10.0


def reef_islands(points: np.ndarray, is_reef: np.ndarray, seabed: Seabed, height: np.ndarray,
                 options: ReefOptions, ping: np.ndarray | None = None, line: np.ndarray | None = None,
                 view: Sight | None = None) -> tuple[list[Reef], list[OtherObject], float, list[np.ndarray]]:
    """:func:`single_reefs` on each group of reef points at least :data:`ISLAND_GAP` m from
    the others, so that time and memory follow the reef points, not their extent.

    Takes and returns what :func:`single_reefs` does; the single-reef area is the median of
    the groups'. One group: :func:`single_reefs` itself.
    """
    rows = np.flatnonzero(is_reef)
    ci, cj = cell_index(points[rows], 0.0, 0.0, ISLAND_CELL)
    cells, inverse = np.unique(np.column_stack([ci, cj]), axis=0, return_inverse=True)
    n, group = cell_groups(cells, int(math.ceil(ISLAND_GAP / ISLAND_CELL)) + 1)
    if n <= 1:
        return single_reefs(points, is_reef, seabed, height, options, ping=ping, line=line, view=view)
    # each sounding's cell, as one sortable key, and the soundings of a group's cells and
    # the cells around them (more than the raster's pad around any reef point)
    ai, aj = cell_index(points, 0.0, 0.0, ISLAND_CELL)
    lo_i, lo_j = int(ai.min()) - 1, int(aj.min()) - 1
    width = int(ai.max()) - lo_i + 2
    key = (aj - lo_j).astype(np.int64) * width + (ai - lo_i)
    order = np.argsort(key, kind="stable")
    skey = key[order]
    reefs: list[Reef] = []
    others: list[OtherObject] = []
    areas: list[float] = []
    members: list[np.ndarray] = []
    group_of_row = group[inverse.ravel()]
    for g in range(n):
        own = cells[group == g]
        near = np.unique(np.concatenate([(own[:, 1:] + dj - lo_j) * width + (own[:, :1] + di - lo_i)
                                         for di in (-1, 0, 1) for dj in (-1, 0, 1)]).ravel())
        a, b = np.searchsorted(skey, near), np.searchsorted(skey, near, side="right")
        sub = np.sort(np.concatenate([order[x:y] for x, y in zip(a, b, strict=True)]))
        flag = np.zeros(len(sub), dtype=bool)
        flag[np.searchsorted(sub, rows[group_of_row == g])] = True
        r, o, area, m = single_reefs(points[sub], flag, seabed, height[sub], options,
                                     ping=None if ping is None else ping[sub],
                                     line=None if line is None else line[sub],
                                     view=None if view is None else view.subset(sub))
        reefs += r
        others += o
        areas.append(area)
        members += [sub[x] for x in m]
    return reefs, others, float(np.nanmedian(areas)) if np.isfinite(areas).any() else math.nan, members


def single_reefs(points: np.ndarray, is_reef: np.ndarray, seabed: Seabed, height: np.ndarray,
                 options: ReefOptions, ping: np.ndarray | None = None, line: np.ndarray | None = None,
                 view: Sight | None = None) -> tuple[list[Reef], list[OtherObject], float, list[np.ndarray]]:
    """The single reefs among the reef points, each measured (our method).

    Footprints split into single reefs (:func:`split_reefs`), each measured
    (:func:`measure_reef`); given designs, each fitted by its design
    (:func:`fit_reef_design`), parts one design explains joined (:func:`join_by_design`)
    and touching reefs' soundings shared (:func:`share_by_design`).

    Parameters
    ----------
    points : ndarray, shape (N, 3)
    is_reef : ndarray of bool, shape (N,)
    seabed : Seabed
    height : ndarray, shape (N,)
        Heights above ``seabed`` (m).
    options : ReefOptions
    ping : ndarray of int, shape (N,), optional
        Each sounding's ping: a reef seen by fewer than ``options.min_pings`` pings is
        listed among the others with the reason.
    line : ndarray of int, shape (N,), optional
        Each sounding's line: its height offset from the others
        (:func:`~mbinspect.reefs.shape.line_levels`) is removed before a candidate's shape
        is judged.

    Examples
    --------
    >>> from mbinspect.simulate import simulate
    >>> sim = simulate("reef-field", seed=1, groups="cross1", per_group=4, ping_spacing=0.8,
    ...                close_pairs=0, boulders=0, debris=0)
    >>> from mbinspect.reefs import ReefOptions, fit_seabed, reef_points
    >>> seabed, _ = fit_seabed(sim.cloud.xyz)
    >>> is_reef, height = reef_points(sim.cloud.xyz, seabed)
    >>> reefs, others, area, members = single_reefs(sim.cloud.xyz, is_reef, seabed, height, ReefOptions())
    >>> len(reefs)
    4

    Returns
    -------
    reefs : list of Reef
        Unnumbered (id 0).
    others : list of OtherObject
        Objects smaller than ``min_area``: position, height, area, top, points.
    reef_area : float
        The single-reef area used (m²).
    members : list of ndarray of int
        Each reef's soundings: the reef points (rows of ``points``) in its footprint.
    """
    parts, small, raster, used_area, heard, blooms = _footprints(points, is_reef, height, options, view)
    ground = ~is_reef & (np.abs(height) <= GROUND_BAND)
    noise = robust_sigma(height[ground]) if ground.sum() >= 10 else None  # the seabed's spread: the noise
    reach, cone = _cones(points, view)
    sigma = None if reach is None else np.hypot(noise or 0.05, reach)
    reefs = [measure_reef(points, p, raster, seabed, reef_id=0, is_reef=is_reef, sigma=sigma) for p in parts]
    designs = options.designs
    if designs:
        parts, reefs, fits = _by_design(points, is_reef, height, seabed, raster, parts, reefs, blooms,
                                        designs, sigma)
    free = reefs
    if designs:
        reefs = [with_design(r, f, designs) for r, f in zip(reefs, fits, strict=True)]
    context = Context(points, is_reef, raster, ping, line,
                      ground_soundings(points, is_reef, height, line) if line is not None else None, reach)
    clear = options.min_clearance
    small_note = f"smaller than `min_area` {options.min_area:g} m²"
    others = [other_object(with_least_depth(measure_reef(points, p, raster, seabed, is_reef=is_reef,
                                                         shape=False, sigma=sigma), m,
                                            context, clear, noise), small_note)
              for p, m in zip(small, _members(points, is_reef, raster, small), strict=True)]
    kept, kept_members = [], []
    poses = [None if f is None else f.pose for f in fits] if designs else [None] * len(parts)
    for r, f, p, m, pose in zip(reefs, free, parts, _members(points, is_reef, raster, parts), poses,
                                strict=True):
        r = with_least_depth(r, m, context, clear, noise)
        f = replace(f, least=r.least)  # the same soundings: the same least depth
        # how it rests, from its soundings and those 0.6 m around (noise: the seabed's spread,
        # or 5 cm when too little seabed shows to measure it)
        around = _around(points, p, raster)
        rest = functools.partial(with_rest, rows=around, own=m, points=points, height=height,
                                 designs=designs, noise=noise or 0.05, ping=ping, cone=cone)
        r = rest(r, pose=pose)
        misfit = design_misfit(Candidate(r, p), context, options)
        if misfit:  # no design given fits it: its free-form measures, judged by its shape
            r = _free_rest(r, f, rest, designs) if designs else f  # every design, every way it may lie
            why = why_not_a_reef(Candidate(f, p, _heard(heard, p)), context, options)
            why = f"{misfit}; as a free-form object: {why}" if why else None
        else:
            why = why_not_a_reef(Candidate(r, p, _heard(heard, p)), context, options)
            if why and designs and r.design:
                r = _free_rest(r, f, rest, designs)
        if (misfit or why) and overturned_unit(r, designs):  # on its side or upside down
            why = None
        if why:
            others.append(other_object(r, why))
        else:
            kept.append(r)
            kept_members.append(m)
    return kept, others, used_area, kept_members


def _by_design(points: np.ndarray, is_reef: np.ndarray, height: np.ndarray, seabed: Seabed, raster: Raster,
               parts: list[np.ndarray], reefs: list[Reef], blooms: list[Bloom | None],
               designs: Sequence[ReefDesign], sigma: np.ndarray | None
               ) -> tuple[list[np.ndarray], list[Reef], list[DesignFit | None]]:
    """Each part fitted by its design (:func:`fit_reef_design`; told the beam, as heard with
    its bloom), parts one design explains joined (:func:`join_by_design`) and measured again,
    touching reefs' soundings shared (:func:`share_by_design`): the parts, their free-form
    measures and their fits."""
    fits = [fit_reef_design(points, p, raster, is_reef, height, designs, reef_height=r.height, bloom=b)
            for r, p, b in zip(reefs, parts, blooms, strict=True)]
    measured = {id(p): r for p, r in zip(parts, reefs, strict=True)}
    by_cell = {int(p[0]): b for p, b in zip(parts, blooms, strict=True)}
    parts, fits, heights = join_by_design(points, parts, raster, is_reef, height, designs, fits,
                                          [r.height for r in reefs], blooms=blooms)
    blooms = [by_cell.get(int(p[0])) for p in parts]  # a joined part starts with its first's cells
    # only the joined parts are new arrays: measure those again
    reefs = [measured.get(id(p)) or measure_reef(points, p, raster, seabed, is_reef=is_reef, sigma=sigma)
             for p in parts]
    fits = share_by_design(points, parts, raster, is_reef, height, designs, fits, heights, blooms=blooms)
    return parts, reefs, fits


def _free_rest(posed: Reef, free: Reef, rest: Callable[[Reef], Reef], designs: Sequence[ReefDesign]) -> Reef:
    """How a unit its upright design fit does not hold rests: its free-form measures, every
    design compared every way at its design size (``rest(free)``); where that comparison
    cannot tell (``overturned`` None), the comparison at the design fit's pose and size
    (``posed``) when it found the unit overturned (:func:`overturned_unit`) and fits it
    better. Through 1° cones, double crosses on their side were found so at the design fit's
    pose (misfit 0.41-0.48 m) and then read upright at their design size (0.59-0.61 m, 51-60 %
    of the cells where the two differ siding with on its side): lost among the rocks. A rock
    the free form reads upright (29 %) stays a rock, however well a shrunken unit on its side
    fits it."""
    r = rest(free)
    if posed.overturned and r.overturned is None and overturned_unit(posed, designs) \
            and posed.resting_misfit < r.resting_misfit:
        return replace(r, resting=posed.resting, overturned=True, resting_misfit=posed.resting_misfit,
                       resting_note=posed.resting_note, design=posed.design)
    return r


def _cones(points: np.ndarray, view: Sight | None) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Told the beam, how far each sounding's cone may sound it above or below the surface
    (:func:`~mbinspect.reefs.shape.cone_reach`) and the cone's radius where it was heard
    (:func:`~mbinspect.reefs.shape.cone_radius`); None and None when not told."""
    if view is None:
        return None, None
    width = view.beam.beam_across_deg
    return cone_reach(points, view.origins, width), cone_radius(points, view.origins, width)


def _around(points: np.ndarray, cells: np.ndarray, raster: Raster) -> np.ndarray:
    """The soundings 0.6 m round a reef that show how it rests: told the beam, not those
    standing where its bloom was taken off (heard on the unit beyond its edge, they stand
    where every orientation of the design puts the seabed)."""
    around = soundings_around(raster, *np.divmod(cells, raster.labels.shape[1]), 6)
    return around[~raster.in_bloom(points[around])]


#: Each unbloomed part's cells as heard, by the part's ``id`` (with the part, to check it is the same).
Heard = dict[int, tuple[np.ndarray, np.ndarray]]


def _footprints(points: np.ndarray, is_reef: np.ndarray, height: np.ndarray, options: ReefOptions,
                view: Sight | None
                ) -> tuple[list[np.ndarray], list[np.ndarray], Raster, float, Heard, list[Bloom | None]]:
    """The footprints split into single reefs (:func:`split_reefs`), each with the beam's
    bloom taken off when told the beam (:func:`~mbinspect.reefs.beam.unbloom_parts`), each
    such part's cells as heard, by the part's ``id`` (a part joined by design has none), and
    each part's bloom (None when not told; the pieces of a part the bloom joined share it)."""
    parts, small, raster, used_area = split_reefs(points, is_reef, cell=options.cell,
                                                  reef_area=options.reef_area, height=height,
                                                  min_area=options.min_area, seed=options.seed)
    heard: Heard = {}
    if view is None:
        return parts, small, raster, used_area, heard, [None] * len(parts)
    bloomed = parts
    parts, raster, blooms = unbloom_parts(points, parts, raster, is_reef, height, view,
                                          min_height=options.min_height)
    # what is left of a part under min_area was mostly bloom: a small object heard wide
    least = options.min_area / raster.cell**2
    small = small + [p for p in parts if len(p) < least]
    heard = {id(p): (p, b) for p, b in zip(parts, bloomed, strict=True) if len(p) < len(b)}
    # two reefs the bloom joined come apart once it is off: each its own part (heard as none)
    big = [(p, b) for p, b in zip(parts, blooms, strict=True) if len(p) >= least]
    one = APART_SHARE * float(np.median([len(p) for p, _ in big])) if big else least
    nx = raster.labels.shape[1]
    split = [(q, b) for p, b in big
             for q in _apart(p, nx, max(least, one), _neck(points, p, raster, is_reef, view), hollow=least)]
    return [q for q, _ in split], small, raster, used_area, heard, [b for _, b in split]


#: Least share of the median reef's cells (once the bloom is off) a piece of a part must hold
#: to stand as a reef of its own: a hollow square's walls cut apart by the erosion hold less.
APART_SHARE = 0.6
#: Least share of a part's enclosed cells its pieces, parted at a neck, must still enclose.
NECK_HOLES = 0.8


def _neck(points: np.ndarray, cells: np.ndarray, raster: Raster, is_reef: np.ndarray, view: Sight) -> int:
    """Cells of half a cone's width at the part's median depth under its transducers: the
    widest neck the bloom may have left between two reefs it joined (m / cell, whole)."""
    rows = own_soundings(cells, raster, is_reef)
    if not len(rows):
        return 0
    depth = float(np.median(view.origins[rows, 2] - points[rows, 2]))
    return int(depth * math.tan(math.radians(view.beam.beam_across_deg)) / 2 / raster.cell)


def _apart(cells: np.ndarray, nx: int, least: float, neck: int = 0, hollow: float = math.inf
           ) -> list[np.ndarray]:
    """A part's cells (flat indices in rows of ``nx``) as the pieces they fall into (8-connected),
    eroded by up to ``neck`` cells, when at least two of them hold ``least`` cells each (a
    piece's cells: those of the part nearest to it); the smaller pieces go with the nearest of
    those. Failing that, a part that encloses two or more interiors of ``hollow`` cells each as
    many hollow reefs (each cell with the nearest interior). Else the part whole."""
    cj, ci = np.divmod(cells, nx)
    j0, i0 = int(cj.min()), int(ci.min())
    mask = np.zeros((int(cj.max()) - j0 + 3, int(ci.max()) - i0 + 3), bool)
    mask[cj - j0 + 1, ci - i0 + 1] = True
    for step in range(neck + 1):
        core = ndimage.binary_erosion(mask, iterations=step) if step else mask
        lab, k = ndimage.label(core, structure=np.ones((3, 3), bool))
        if k < 2:
            continue
        owner = _nearest_label(lab)[cj - j0 + 1, ci - i0 + 1]
        big = np.flatnonzero(np.bincount(owner, minlength=k + 1) >= least)
        big = big[big > 0]
        if len(big) < 2:
            continue
        owner = _nearest_label(np.where(np.isin(lab, big), lab, 0))[cj - j0 + 1, ci - i0 + 1]
        pieces = [np.zeros_like(mask) for _ in big]
        for p, b in zip(pieces, big, strict=True):
            p[cj[owner == b] - j0 + 1, ci[owner == b] - i0 + 1] = True
        if step and not _holes_kept(mask, pieces):
            continue
        return [cells[owner == b] for b in big]
    holes, k = ndimage.label(fill_holes(mask) & ~mask)
    big = np.flatnonzero(np.bincount(holes.ravel(), minlength=k + 1) >= hollow)
    big = big[big > 0]
    if len(big) < 2:
        return [cells]
    owner = _nearest_label(np.where(np.isin(holes, big), holes, 0))[cj - j0 + 1, ci - i0 + 1]
    return [cells[owner == b] for b in big]


def _holes_kept(mask: np.ndarray, pieces: list[np.ndarray]) -> bool:
    """Whether the pieces (boolean masks like ``mask``) together still enclose at least
    :data:`NECK_HOLES` of the cells ``mask`` encloses. One hollow square whose wall an erosion
    cut falls into arcs that enclose nothing; two hollow squares joined at a corner, or two
    solid reefs side by side, keep their interiors."""
    enclosed = int((fill_holes(mask) & ~mask).sum())
    kept = sum(int((fill_holes(p) & ~p).sum()) for p in pieces)
    return kept >= NECK_HOLES * enclosed


def _nearest_label(lab: np.ndarray) -> np.ndarray:
    """Each pixel's nearest labelled pixel's label."""
    _, (jj, ii) = ndimage.distance_transform_edt(lab == 0, return_indices=True)
    return lab[jj, ii]


def _heard(heard: Heard, part: np.ndarray) -> np.ndarray | None:
    """The cells as heard of ``part`` (:func:`_footprints`), or None."""
    kept, cells = heard.get(id(part), (None, None))
    return cells if kept is part else None


def _members(points: np.ndarray, is_reef: np.ndarray, raster: Raster, parts: list[np.ndarray]
             ) -> list[np.ndarray]:
    """The reef points inside each footprint (flat raster cells), as rows of ``points``."""
    ny, nx = raster.labels.shape
    owner = np.full(ny * nx, -1, np.int64)
    for k, p in enumerate(parts):
        owner[p] = k
    rows = np.flatnonzero(is_reef)
    i, j = cell_index(points[rows], raster.x0, raster.y0, raster.cell)
    inside = (i >= 0) & (i < nx) & (j >= 0) & (j < ny)
    who = np.full(len(rows), -1, np.int64)
    who[inside] = owner[j[inside] * nx + i[inside]]
    order = np.argsort(who, kind="stable")
    bounds = np.searchsorted(who[order], np.arange(len(parts) + 1))
    return [rows[order[bounds[k]:bounds[k + 1]]] for k in range(len(parts))]
