"""The reef pipeline as its list of stages: :func:`extract_reefs`."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from .. import __version__
from ..errors import DataError, ParameterError
from ..io import PointCloud, pipeline_input
from ..seabed import GROUND_BAND
from .detect import clean_reef_points, denoise, radius_keeping, reef_points
from .fit_design import fit_reef_design, join_by_design, share_by_design, with_design
from .ground import Seabed, fit_seabed
from .group import number_reefs
from .measure import measure_reef
from .options import ReefOptions
from .paper import paper_clusters
from .results import Reef, ReefResult
from .score import score_reefs
from .split import split_reefs
from .terrain import screen_terrain

__all__ = ["extract_reefs", "single_reefs"]


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
    cloud, pts = pipeline_input(data, crop=opts.crop)
    report = progress or (lambda f: None)
    local = opts.method == "local"
    keep, rep = denoise(pts, radius=opts.noise_radius, min_neighbors=opts.noise_neighbors)
    filters: dict[str, Any] = {"radius": rep.to_dict()}
    filter_note = _filter_loss(pts, rep.n_removed, opts)
    report(0.25)
    ground = screen_terrain(pts[keep], local=local, seabed=opts.seabed, exclude_rough=opts.exclude_rough,
                            max_slope_deg=opts.max_slope_deg, max_roughness=opts.max_roughness,
                            seabed_cell=opts.seabed_cell, seabed_window=opts.seabed_window)
    warnings = ([filter_note] if filter_note else []) + list(ground.warnings)
    if ground.report is not None:
        filters["rough_terrain"] = ground.report
    kept = ground.points
    if len(kept) < 10:
        raise DataError("fewer than 10 soundings left after filtering; nothing to extract"
                        + (f": {filter_note}" if filter_note else ""))
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
    others: list[dict[str, Any]] = []
    used_area = None
    if is_reef.any() and local:
        reefs, others, used_area = single_reefs(kept, is_reef, surf, h_all, opts)
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


def single_reefs(points: np.ndarray, is_reef: np.ndarray, seabed: Seabed, height: np.ndarray,
                 options: ReefOptions) -> tuple[list[Reef], list[dict[str, Any]], float]:
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

    Examples
    --------
    >>> from mbinspect.simulate import simulate
    >>> sim = simulate("reef-field", seed=1, groups="cross1", per_group=4, ping_spacing=0.8,
    ...                close_pairs=0, boulders=0, debris=0)
    >>> from mbinspect.reefs import ReefOptions, fit_seabed, reef_points
    >>> seabed, _ = fit_seabed(sim.cloud.xyz)
    >>> is_reef, height = reef_points(sim.cloud.xyz, seabed)
    >>> reefs, others, area = single_reefs(sim.cloud.xyz, is_reef, seabed, height, ReefOptions())
    >>> len(reefs)
    4

    Returns
    -------
    reefs : list of Reef
        Unnumbered (id 0).
    others : list of dict
        Objects smaller than ``min_area``: position, height, area, top, points.
    reef_area : float
        The single-reef area used (m²).
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
        o = measure_reef(points, p, raster, seabed, is_reef=is_reef)
        others.append({"x": o.x, "y": o.y, "height": o.height, "area": o.area, "z_top": o.z_top,
                       "n_points": o.n_points})
    return reefs, others, used_area
