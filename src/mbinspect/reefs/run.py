"""The reef pipeline as its list of stages: :func:`extract_reefs`."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from ..cloud import sources
from ..errors import DataError, ParameterError
from ..grid import cell_groups, cell_index, extent_bytes, machine_memory, sounding_spacing
from ..io import PointCloud, pipeline_input
from ..seabed import GROUND_BAND
from ..version import __version__
from .detect import clean_reef_points, denoise, radius_keeping, reef_points
from .fit_design import fit_reef_design, join_by_design, share_by_design, with_design
from .footprint import Raster
from .ground import Seabed, fit_seabed
from .group import number_reefs
from .measure import measure_reef
from .options import ReefOptions
from .paper import paper_clusters
from .results import OtherObject, Reef, ReefResult
from .score import score_reefs
from .split import split_reefs
from .terrain import screen_terrain

__all__ = ["extract_reefs", "single_reefs", "reef_islands"]


#: Least share of its design's height a reef fitted by that design shows above the seabed
#: (a cross of 1.2 m sunk 0.6 m still shows half).
LOWEST_SHARE = 0.4

#: Share of the soundings the radius filter may remove before the run says so.
FILTER_LOSS_WARNING = 0.05


def _filter_loss(pts: np.ndarray, removed: int, opts: ReefOptions) -> str | None:
    """A note when the radius filter removed more than :data:`FILTER_LOSS_WARNING` of the
    soundings: how many, under which options, and the radius that keeps 99 % of them."""
    if removed <= FILTER_LOSS_WARNING * len(pts):
        return None
    r99 = radius_keeping(pts, opts.noise_neighbors, seed=opts.seed)
    return (f"the radius filter removed {100 * removed / len(pts):.0f} % of the soundings (`noise_radius` "
            f"{opts.noise_radius:g} m, `noise_neighbors` {opts.noise_neighbors}): they lie farther apart "
            f"than it expects; `noise_radius` {r99:.2f} keeps 99 % of them")


def _enough(pts: np.ndarray, filter_note: str | None) -> None:
    """Stop when fewer than 10 soundings are left, with the filter's note as the reason."""
    if len(pts) < 10:
        raise DataError("fewer than 10 soundings left after filtering; nothing to extract"
                        + (f": {filter_note}" if filter_note else ""))


def _check_resolution(pts: np.ndarray, opts: ReefOptions, filter_note: str | None) -> None:
    """Stop when the soundings lie too far apart to resolve an object of ``min_area``: the
    footprint rasters and seabed grids would measure the gaps between soundings (and grow
    with a deep survey's extent) rather than any reef."""
    _enough(pts, filter_note)
    spacing = sounding_spacing(pts, seed=opts.seed)
    most = math.sqrt(opts.min_area)
    if spacing > most / 2:
        raise DataError(f"the soundings lie {spacing:.2f} m apart (median plan distance to the nearest): "
                        f"too sparse to resolve objects of `min_area` {opts.min_area:g} m², which need "
                        f"soundings under {most / 2:.2f} m apart; no reef can be reported from these data")
    grid = extent_bytes(pts, opts.seabed_cell)
    if grid > machine_memory() / 2:
        raise DataError(f"the soundings spread so wide that a seabed grid over their extent would take "
                        f"{grid / 1e9:.1f} GB (`seabed_cell` {opts.seabed_cell:g} m), more than half this "
                        "machine's memory: run `mbinspect reefs` (or mbinspect.survey.run_survey), which "
                        "cuts such a survey into tiles that follow its soundings")
    depth = -float(np.median(pts[:, 2]))
    footprint = 2 * depth * math.tan(math.radians(opts.beam_width_deg) / 2)
    if footprint > most:
        raise DataError(f"a {opts.beam_width_deg:g}° beam (`beam_width_deg`) at {depth:.0f} m lights a "
                        f"{footprint:.1f} m footprint: too coarse to resolve objects of `min_area` "
                        f"{opts.min_area:g} m², which need a footprint under {most:.2f} m; no reef can be "
                        "reported from these data")


def extract_reefs(data: PointCloud | np.ndarray, options: ReefOptions | None = None, *,
                  reference: tuple[np.ndarray, tuple[Any, ...]] | None = None,
                  progress: Callable[[float], None] | None = None, **overrides: Any) -> ReefResult:
    """Extract, separate and measure artificial reefs; score them against a reference.

    Stages: the paper's radius filter (:func:`denoise`), the terrain screen
    (:func:`screen_terrain`), the seabed (:func:`fit_seabed`), the reef points
    (:func:`reef_points`, :func:`clean_reef_points`), single reefs measured
    (:func:`single_reefs`; the paper's Euclidean clusters with ``method="paper"``),
    numbered and grouped (:func:`number_reefs`) and scored (:func:`score_reefs`).

    Parameters
    ----------
    data : PointCloud or ndarray, shape (N, 3)
        Soundings (m, z up).
    options : ReefOptions, optional
        Every option (:class:`ReefOptions`).
    reference : (positions (R, 2), ids), optional
        Reference reef positions (:func:`mbinspect.evaluate.read_reference`).
    progress : callable, optional
        Called with the fraction done (0 to 1).
    **overrides
        Options by name, over ``options`` (``extract_reefs(cloud, design="cross2")``).

    Returns
    -------
    ReefResult

    Raises
    ------
    ParameterError
        A bad option, named by its library name.
    DataError
        Fewer than 10 soundings left after filtering.

    Examples
    --------
    >>> from mbinspect.simulate import simulate
    >>> sim = simulate("reef-field", seed=1, groups="cross1", ping_spacing=0.8)
    >>> len(extract_reefs(sim.cloud).reefs)
    25
    """
    opts = ReefOptions(**overrides) if options is None else options.replace(**overrides)
    cloud, pts, notes = pipeline_input(data, crop=opts.crop)
    report = progress or (lambda f: None)
    local = opts.method == "local"
    keep, rep = denoise(pts, radius=opts.noise_radius, min_neighbors=opts.noise_neighbors,
                        spacing_factor=opts.noise_spacing if local else 0.0)
    filters: dict[str, Any] = {"radius": rep.to_dict()}
    filter_note = _filter_loss(pts, rep.n_removed, opts)
    report(0.25)
    _check_resolution(pts[keep], opts, filter_note)
    ground = screen_terrain(pts[keep], local=local, seabed=opts.seabed, exclude_rough=opts.exclude_rough,
                            max_slope_deg=opts.max_slope_deg, max_roughness=opts.max_roughness,
                            seabed_cell=opts.seabed_cell, seabed_window=opts.seabed_window)
    warnings = notes + ([filter_note] if filter_note else []) + list(ground.warnings)
    if ground.report is not None:
        filters["rough_terrain"] = ground.report
    kept = ground.points
    ping, line = (cloud.fields.get(k) for k in ("ping", "line"))
    ping, line = ((f[keep] if ground.kept is None else f[keep][ground.kept]) if f is not None else None
                  for f in (ping, line))
    _enough(kept, filter_note)
    report(0.35)
    surf, seabed_info = fit_seabed(kept, mode=opts.seabed if local else "plane",
                                   threshold=opts.plane_threshold, confidence=opts.confidence,
                                   cell=opts.seabed_cell, window=opts.seabed_window,
                                   max_plane_dev=opts.max_plane_dev, seed=opts.seed, grid=ground.grid,
                                   grid_height=ground.height)
    report(0.55)
    h_all = ground.height if surf is ground.grid and ground.height is not None else surf.height_above(kept)
    seabed_info["coverage"] = ground.coverage
    on_ground = float(np.mean(np.abs(h_all) <= GROUND_BAND))
    if ground.coverage >= 0.25 and on_ground < 0.3:
        warnings.append(f"only {100 * on_ground:.0f} % of the soundings lie on the fitted seabed: is "
                        "there a seabed in this cloud?")
    if local:
        is_reef, _ = reef_points(kept, surf, min_height=opts.min_height, foot_height=opts.foot_height,
                                 height=h_all)
        is_reef, stat = clean_reef_points(kept, is_reef, k=opts.statistical_k,
                                          std_ratio=opts.statistical_ratio)
        if stat is not None:
            filters["statistical"] = stat.to_dict()
    else:
        is_reef = (np.abs(h_all) > opts.plane_threshold) & (h_all > 0)
    report(0.7)
    reefs: list[Reef] = []
    others: list[OtherObject] = []
    used_area = None
    if is_reef.any() and local:
        reefs, others, used_area, members = reef_islands(kept, is_reef, surf, h_all, opts, ping=ping,
                                                               line=line)
        rows = np.flatnonzero(keep) if ground.kept is None else np.flatnonzero(keep)[ground.kept]
        files = cloud.meta.get("files") or [cloud.source or "(array)"]
        reefs = [replace(r, sources=sources(rows[m], cloud.fields, files))
                 for r, m in zip(reefs, members, strict=True)]
    elif is_reef.any():
        reefs, others = paper_clusters(kept, is_reef, surf, eps=opts.cluster_eps, min_area=opts.min_area)
        used_area = math.nan
    reefs, groups = number_reefs(reefs, opts.group_link)
    evaluation, ref_xy = None, None
    if reference is not None:
        if not (isinstance(reference, tuple) and len(reference) == 2
                and np.ndim(reference[0]) == 2 and np.shape(reference[0])[1] == 2):
            raise ParameterError("reference: not a pair (positions (R, 2), ids); expected what "
                                 "mbinspect.evaluate.read_reference returns", option="reference")
        evaluation, warn = score_reefs(reefs, reference, tolerance=opts.tolerance)
        warnings += warn
        ref_xy = np.asarray(reference[0])
    report(1.0)
    parameters = {**opts.to_dict(), "input": {"source": cloud.source, "n_points": len(pts), "crs": cloud.crs},
                  "software": f"mbinspect {__version__}"}
    return ReefResult(tuple(reefs), tuple(groups), tuple(others), seabed_info, filters, evaluation,
                      parameters, tuple(warnings), ground.region, surf, {"reef_area_used": used_area}, ref_xy)


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
                 options: ReefOptions, ping: np.ndarray | None = None, line: np.ndarray | None = None
                 ) -> tuple[list[Reef], list[OtherObject], float, list[np.ndarray]]:
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
        return single_reefs(points, is_reef, seabed, height, options, ping=ping, line=line)
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
                                     line=None if line is None else line[sub])
        reefs += r
        others += o
        areas.append(area)
        members += [sub[x] for x in m]
    return reefs, others, float(np.nanmedian(areas)) if np.isfinite(areas).any() else math.nan, members


def single_reefs(points: np.ndarray, is_reef: np.ndarray, seabed: Seabed, height: np.ndarray,
                 options: ReefOptions, ping: np.ndarray | None = None, line: np.ndarray | None = None
                 ) -> tuple[list[Reef], list[OtherObject], float, list[np.ndarray]]:
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
        Each sounding's line: its height offset from the others (:func:`line_levels`) is
        removed before a candidate's shape is judged.

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
    parts, small, raster, used_area = split_reefs(points, is_reef, cell=options.cell,
                                                  reef_area=options.reef_area, height=height,
                                                  min_area=options.min_area, seed=options.seed)
    reefs = [measure_reef(points, p, raster, seabed, reef_id=0, is_reef=is_reef) for p in parts]
    designs = options.designs
    if designs:
        fits = [fit_reef_design(points, p, raster, is_reef, height, designs, reef_height=r.height)
                for r, p in zip(reefs, parts, strict=True)]
        measured = {id(p): r for p, r in zip(parts, reefs, strict=True)}
        parts, fits, heights = join_by_design(points, parts, raster, is_reef, height, designs, fits,
                                              [r.height for r in reefs])
        # only the joined parts are new arrays: measure those again
        reefs = [measured.get(id(p)) or measure_reef(points, p, raster, seabed, is_reef=is_reef)
                 for p in parts]
        fits = share_by_design(points, parts, raster, is_reef, height, designs, fits, heights)
        reefs = [with_design(r, f) for r, f in zip(reefs, fits, strict=True)]
    others = []
    for p in small:
        others.append(_other(measure_reef(points, p, raster, seabed, is_reef=is_reef),
                             f"smaller than `min_area` {options.min_area:g} m²"))
    kept, kept_members = [], []
    ground = _ground_by_x(points, is_reef, height, line) if line is not None else None
    for r, p, m in zip(reefs, parts, _members(points, is_reef, raster, parts), strict=True):
        # a design that fits at its size (with few edge soundings astray) is a stronger
        # witness than the shape of a top: a deeply sunk triangle's sloping faces look rounded
        witness = r.design and abs(r.design_scale - 1) <= DESIGN_WITNESS_SCALE
        why = (_not_a_reef(r, p, raster, is_reef, ping, options)
               or (None if witness else _rounded(points, r, p, raster, options, line, ground)))
        if why:
            others.append(_other(r, why))
        else:
            kept.append(r)
            kept_members.append(m)
    return kept, others, used_area, kept_members


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


def _other(reef: Reef, reason: str) -> OtherObject:
    """An object that is not a reef, as ``others`` lists it."""
    return OtherObject(reef.x, reef.y, reef.height, reef.area, reef.z_top, reef.n_points, reason)


def _not_a_reef(reef: Reef, cells: np.ndarray, raster: Raster, is_reef: np.ndarray, ping: np.ndarray | None,
                options: ReefOptions) -> str | None:
    """Why a measured footprint is not a reef, or None: lower above the seabed around it than
    a reef point must stand, a ridge, far lower than the design fitted to it, or seen by too
    few pings."""
    if reef.height < options.min_height:
        return (f"{reef.height:.2f} m above the seabed around it (`min_height` {options.min_height:g} m): "
                "a bump of the seabed, not a reef")
    elongation = reef.length / max(reef.width, 1e-9)
    if options.max_elongation and elongation > options.max_elongation:
        return (f"elongated ({reef.length:.1f} × {reef.width:.1f} m, {elongation:.1f} times longer than "
                f"wide; `max_elongation` {options.max_elongation:g}): a ridge such as a sand-wave crest, "
                "not a compact reef")
    if options.designs and not reef.design:
        return "no design fits its plan: a rock or other object, not a reef of the designs given"
    design = next((d for d in options.designs if d.name == reef.design), None)
    if design is not None:
        if abs(reef.design_scale - 1) > options.design_scale_tolerance:
            return (f"fits the {design.name} design only at {reef.design_scale:.2f} of its size "
                    f"(`design_scale_tolerance` {options.design_scale_tolerance:g}): a rock or other object")
        if reef.design_misfit > options.design_misfit_max:
            return (f"fits the {design.name} design poorly ({reef.design_misfit:.0%} of its edge soundings "
                    f"on the wrong side; `design_misfit_max` {options.design_misfit_max:g})")
        scale = reef.design_scale if reef.design_scale > 0 else 1.0
        tall = max(b.dz + b.height for b in design.boxes) * scale
        if reef.height < LOWEST_SHARE * tall:
            return (f"{reef.height:.2f} m high where the {design.name} design fitted to its plan is "
                    f"{tall:.2f} m: not that design even if sunk (a reef shows at least "
                    f"{LOWEST_SHARE:.0%} of its height)")
    if ping is not None:
        n = _pings(cells, raster, is_reef, ping)
        if n < options.min_pings:
            return (f"seen by {n} ping{'s' * (n != 1)} (`min_pings` {options.min_pings}): "
                    "its plan shape is unknown")
    return None


#: Share of a candidate's height counted as its top (``rounded_plateau``), and the share of
#: its soundings, highest first, whose spread is its top's (``rounded_spread``).
PLATEAU_DEPTH = 0.15
TOP_SHARE = 0.3


def rounded_shape(height: np.ndarray) -> tuple[float, float]:
    """How rounded a candidate is, from the heights of its surface (one per footprint cell,
    or per sounding) above one level.

    Returns
    -------
    spread : float
        The 10th to 90th percentile of its highest :data:`TOP_SHARE` surface, as a share of
        its top (the 95th percentile): a reef's flat top holds it to the noise, a rock's
        dome spreads it.
    plateau : float
        The share of its surface within :data:`PLATEAU_DEPTH` of its top below it: most of a
        reef's, little of a rock's.

    Examples
    --------
    >>> r = np.sqrt(np.random.default_rng(0).uniform(0, 1, 2000))  # even over a disc
    >>> [round(v, 2) for v in rounded_shape(np.sqrt(1 - r**2))]  # a dome
    [0.14, 0.31]
    >>> [round(v, 2) for v in rounded_shape(np.r_[np.full(900, 1.0), np.linspace(0.2, 1, 100)])]  # a box
    [0.0, 0.92]
    """
    h = np.asarray(height, np.float64)
    if len(h) < 10:
        return math.nan, math.nan
    top = float(np.percentile(h, 95))
    high = h[h >= np.percentile(h, 100 * (1 - TOP_SHARE))]
    spread = float(np.percentile(high, 90) - np.percentile(high, 10)) / top
    return spread, float(np.mean(h >= (1 - PLATEAU_DEPTH) * top))


#: Share of a candidate's height above which its soundings are its upper part (:func:`dome_shape`),
#: and the most of its surface a dome holds near its top (``plateau`` of :func:`rounded_shape`;
#: rocks of the rocky field 0.14-0.52): a box's flat top holds most of it (solid 2 m cubes,
#: 0.80-0.97), though its rim falls like a dome's.
DOME_BASE = 0.3
DOME_PLATEAU = 0.6


def dome_shape(xy: np.ndarray, z: np.ndarray, across: float) -> tuple[float, float]:
    """How much a candidate is a dome: a quadratic surface fitted to its upper soundings
    (above :data:`DOME_BASE` of its top, the 95th percentile of ``z``).

    Parameters
    ----------
    xy : ndarray, shape (N, 2)
        Plan positions (m).
    z : ndarray, shape (N,)
        Heights (m) above the seabed.
    across : float
        The width (m) of its thickest part (:func:`thickness`).

    Returns
    -------
    misfit : float
        The fit's RMS residual as a share of its top: a rock's dome is within the noise of
        one, a stepped or hollow reef is not.
    drop : float
        How far the surface falls across half of ``across`` along its most curved direction,
        as a share of its top: most of a dome's height, nothing for a flat top. NaN both
        with fewer than 10 upper soundings.

    Examples
    --------
    >>> g = np.stack(np.meshgrid(np.linspace(-1, 1, 21), np.linspace(-1, 1, 21)), -1).reshape(-1, 2)
    >>> disc = g[np.hypot(*g.T) < 1]
    >>> dome = np.sqrt(1 - np.sum(disc**2, axis=1))
    >>> [round(v, 2) for v in dome_shape(disc, dome, 2.0)]
    [0.03, 0.75]
    >>> [abs(round(v, 2)) for v in dome_shape(disc, np.ones(len(disc)), 2.0)]  # a flat top
    [0.0, 0.0]
    """
    top = float(np.percentile(z, 95))
    up = z >= DOME_BASE * top
    if up.sum() < 10 or top <= 0:
        return math.nan, math.nan
    p = xy[up] - xy[up].mean(axis=0)
    design = np.column_stack([np.ones(len(p)), p, p**2, p[:, 0] * p[:, 1]])
    coef, *_ = np.linalg.lstsq(design, z[up], rcond=None)
    misfit = float(np.sqrt(np.mean((z[up] - design @ coef) ** 2))) / top
    hessian = np.array([[2 * coef[3], coef[5]], [coef[5], 2 * coef[4]]])
    curvature = -float(np.linalg.eigvalsh(hessian).min())  # the most downward, 1/m
    return misfit, curvature / 2 * (across / 2) ** 2 / top


#: A design fitted within this share of its size overrides the shape test for rocks (a
#: looser ``design_scale_tolerance``, for reefs built smaller, does not).
DESIGN_WITNESS_SCALE = 0.15

#: Soundings across a candidate's thickest part (:func:`thickness`) below which its shape
#: is not judged: a coarser grid blurs a flat top's edges into a dome (a 0.5 m export of
#: 3 m crosses with 1 m arms looks rounded).
SHAPE_SOUNDINGS_ACROSS = 6


def _rounded(points: np.ndarray, reef: Reef, cells: np.ndarray, raster: Raster, options: ReefOptions,
             line: np.ndarray | None, ground: tuple[np.ndarray, ...] | None
             ) -> str | None:
    """Why a candidate is a rock by its shape, or None. Its surface is the elevation of each
    footprint cell's nearest sounding above the seabed at its centre (its surface by plan
    area, however many soundings its walls caught from oblique beams; elevations, not heights
    above a seabed that bends under it on a sand wave), each less its line's level
    (:func:`line_levels`). A rock is a dome (:func:`dome_shape`) or rounded
    (:func:`rounded_shape`); neither is judged where too few soundings lie across it to
    show its top's edges (:data:`SHAPE_SOUNDINGS_ACROSS`: a coarse grid blurs a stepped
    cross into a dome)."""
    if not (options.rounded_spread or options.dome_misfit):
        return None
    idx = _cell_soundings(cells, raster)
    own = np.unique(idx)
    across = thickness(cells, raster)
    if len(own) < 10 or sounding_spacing(points[own]) > across / SHAPE_SOUNDINGS_ACROSS:
        return None
    z = points[idx, 2] - reef.z_seabed
    if line is not None and ground is not None:
        z = z - line_levels(points[idx], line[idx], ground)
    misfit, drop = dome_shape(points[idx, :2], z, across)
    spread, plateau = rounded_shape(z)
    if 0 < options.dome_misfit and misfit <= options.dome_misfit and drop >= options.dome_drop \
            and plateau <= DOME_PLATEAU:
        return (f"a dome: its upper soundings fit a curved surface within {misfit:.0%} of its height "
                f"(`dome_misfit` {options.dome_misfit:g}) that drops {drop:.0%} of its height across half "
                f"its {across:.1f} m width (`dome_drop` {options.dome_drop:g}), with {plateau:.0%} of it "
                "near its top: a rock, not a reef")
    if spread >= options.rounded_spread > 0 and plateau <= options.rounded_plateau:
        return (f"rounded: its highest soundings spread over {spread:.0%} of its height (`rounded_spread` "
                f"{options.rounded_spread:g}) and {plateau:.0%} lie near its top (`rounded_plateau` "
                f"{options.rounded_plateau:g}): a rock, not a reef's flat top")
    return None


#: Margin (m) around a candidate whose seabed soundings give each line's level, and the
#: least of them a line needs there for its level to be taken (else none is removed).
LEVEL_MARGIN = 2.0
LEVEL_MIN = 10


def _ground_by_x(points: np.ndarray, is_reef: np.ndarray, height: np.ndarray, line: np.ndarray
                 ) -> tuple[np.ndarray, ...]:
    """The seabed soundings (not reef points, within the ground band), sorted by x: their
    x, y, line and height above the seabed."""
    rows = np.flatnonzero(~is_reef & (np.abs(height) <= GROUND_BAND))
    rows = rows[np.argsort(points[rows, 0], kind="stable")]
    return points[rows, 0], points[rows, 1], line[rows], height[rows]


def line_levels(xy: np.ndarray, line: np.ndarray, ground: tuple[np.ndarray, ...],
                margin: float = LEVEL_MARGIN) -> np.ndarray:
    """Each sounding's line's level: the median height above the seabed of that line's
    seabed soundings within ``margin`` (m) of the soundings' extent (``ground`` as
    :func:`_ground_by_x` gives). Strips that disagree by a few centimetres put a reef's
    flat top at two heights, which spread like a dome's; a line with fewer than
    :data:`LEVEL_MIN` seabed soundings there keeps its height.

    Examples
    --------
    >>> gx = np.repeat(np.arange(10.0), 4)
    >>> ground = (gx, np.zeros(40), np.tile([1, 1, 2, 2], 10), np.tile([0.05, 0.05, -0.05, -0.05], 10))
    >>> line_levels(np.array([[4.0, 0.5], [5.0, 0.5]]), np.array([1, 2]), ground).tolist()
    [0.05, -0.05]
    """
    gx, gy, gline, gh = ground
    (x0, y0), (x1, y1) = xy[:, :2].min(axis=0) - margin, xy[:, :2].max(axis=0) + margin
    a, b = np.searchsorted(gx, [x0, x1], side="left")
    near = slice(a, b)
    inside = (gy[near] >= y0) & (gy[near] <= y1)
    lines, h = gline[near][inside], gh[near][inside]
    level = np.zeros(len(line))
    for k in np.unique(line):
        own = h[lines == k]
        if len(own) >= LEVEL_MIN:
            level[line == k] = np.median(own)
    return level


def thickness(cells: np.ndarray, raster: Raster) -> float:
    """The width (m) of a footprint's thickest part: the diameter of the largest disc its
    cells hold: about 1.4 arm widths at a cross's crossing, not its span; a rock's own width.

    Examples
    --------
    >>> from mbinspect.reefs.footprint import Raster
    >>> lab = np.zeros((40, 40), int)
    >>> lab[15:25, :] = lab[:, 15:25] = 1  # a cross of 0.1 m cells, arms 1 m wide, 4 m long
    >>> r = Raster(0.0, 0.0, 0.1, lab, np.full(lab.shape, -1))
    >>> round(thickness(np.flatnonzero(lab.ravel() == 1), r), 1)
    1.4
    """
    from scipy.ndimage import distance_transform_edt

    ny, nx = raster.labels.shape
    iy, ix = np.divmod(np.asarray(cells, np.int64), nx)
    mask = np.zeros((iy.max() - iy.min() + 3, ix.max() - ix.min() + 3), bool)
    mask[iy - iy.min() + 1, ix - ix.min() + 1] = True
    return float(2.0 * distance_transform_edt(mask).max() * raster.cell)


def _cell_soundings(cells: np.ndarray, raster: Raster) -> np.ndarray:
    """The nearest sounding of each of a footprint's cells that has one."""
    idx = raster.nearest.ravel()[cells]
    return idx[idx >= 0]


def _pings(cells: np.ndarray, raster: Raster, is_reef: np.ndarray, ping: np.ndarray) -> int:
    """How many pings the reef soundings behind a footprint's cells come from."""
    idx = _cell_soundings(cells, raster)
    return int(len(np.unique(ping[idx[is_reef[idx]]])))
