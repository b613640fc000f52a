"""The reef pipeline as its list of stages: :func:`extract_reefs`."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from ..cloud import sources
from ..errors import DataError, ParameterError
from ..grid import extent_bytes, machine_memory, patched_spacing
from ..io import PointCloud, pipeline_input
from ..pings import ping_keys
from ..seabed import GROUND_BAND
from ..timing import StageTimes
from ..version import __version__
from .beam import Sight, contrast_db, sight
from .detect import clean_reef_points, denoise, radius_keeping, reef_points
from .ground import Seabed, fit_seabed
from .group import number_reefs
from .options import ReefOptions
from .paper import paper_clusters
from .plan import ReefPlan, place_reefs
from .results import OtherObject, Reef, ReefResult
from .score import score_reefs
from .single import reef_islands
from .terrain import screen_terrain

__all__ = ["extract_reefs"]


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
    spacing = patched_spacing(pts, seed=opts.seed, sample=20_000)  # over 1 M: in patches
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
                  progress: Callable[[float], None] | None = None, times: StageTimes | None = None,
                  plan: ReefPlan | None = None, **overrides: Any) -> ReefResult:
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
    plan : ReefPlan, optional
        The deployment plan (:func:`~mbinspect.reefs.plan.read_plan`): each reef placed
        against it (:func:`~mbinspect.reefs.plan.place_reefs`).
    progress : callable, optional
        Called with the fraction done (0 to 1).
    times : StageTimes, optional
        Given, each stage's seconds (and peak memory) are recorded in it.
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
    lap = _laps(times)
    cloud, pts, notes = pipeline_input(data, crop=opts.crop)
    lap("input checks")
    report = progress or (lambda f: None)
    local = opts.method == "local"
    keep, filters, filter_note = _denoise(pts, opts)
    lap("radius filter")
    report(0.25)
    clean = np.compress(keep, pts, axis=0)  # 2-3x faster than pts[keep] for (N, 3) rows
    _check_resolution(clean, opts, filter_note)
    lap("resolution check")
    ground = screen_terrain(clean, local=local, seabed=opts.seabed, exclude_rough=opts.exclude_rough,
                            max_slope_deg=opts.max_slope_deg, max_roughness=opts.max_roughness,
                            seabed_cell=opts.seabed_cell, seabed_window=opts.seabed_window,
                            skirt=_bloom(clean, opts))
    warnings = [*notes, *([filter_note] if filter_note else []), *ground.warnings,
                *_beam_note(cloud, opts)]
    if ground.report is not None:
        filters["rough_terrain"] = ground.report
    kept = ground.points
    rows = np.flatnonzero(keep) if ground.kept is None else np.flatnonzero(keep)[ground.kept]
    _enough(kept, filter_note)
    lap("terrain")
    report(0.35)
    surf, seabed_info = fit_seabed(kept, mode=opts.seabed if local else "plane",
                                   threshold=opts.plane_threshold, confidence=opts.confidence,
                                   cell=opts.seabed_cell, window=opts.seabed_window,
                                   max_plane_dev=opts.max_plane_dev, seed=opts.seed, grid=ground.grid,
                                   grid_height=ground.height)
    lap("seabed")
    report(0.55)
    h_all = ground.height if surf is ground.grid and ground.height is not None else surf.height_above(kept)
    seabed_info["coverage"] = ground.coverage
    warnings += _seabed_note(h_all, ground.coverage)
    is_reef = _reef_mask(kept, surf, h_all, opts, filters)
    lap("reef points")
    report(0.7)
    reefs, others, used_area = _objects(cloud, kept, rows, is_reef, surf, h_all, opts)
    lap("single reefs")
    reefs, groups = number_reefs(reefs, opts.group_link)
    evaluation, ref_xy = None, None
    if reference is not None:
        evaluation, ref_xy = _score(reefs, reference, opts, warnings)
    lap("groups and score")
    report(1.0)
    parameters = {**opts.to_dict(), "input": {"source": cloud.source, "n_points": len(pts), "crs": cloud.crs},
                  "software": f"mbinspect {__version__}"}
    result = ReefResult(tuple(reefs), tuple(groups), tuple(others), seabed_info, filters, evaluation,
                        parameters, tuple(warnings), ground.region, surf, {"reef_area_used": used_area},
                        ref_xy)
    return result if plan is None else place_reefs(result, plan, tolerance=opts.placement_tolerance,
                                                   position_sigma=opts.position_sigma,
                                                   bearing_sigma_deg=opts.bearing_sigma_deg)


def _bloom(pts: np.ndarray, opts: ReefOptions) -> float:
    """How far (m, in plan) a wide beam's echo of an object reaches past its edge: a
    footprint at the median depth with the beam correction on (along the track the bloom
    stands up to 0.85 of one), else 0."""
    if not opts.beam_correction:
        return 0.0
    return abs(float(np.median(pts[:, 2]))) * math.tan(math.radians(opts.beam_width_deg))


def _beam_note(cloud: PointCloud, opts: ReefOptions) -> list[str]:
    """Told the beam, what the soundings lack to show how each was seen."""
    missing = [k for k in ("ping", "beam_angle") if cloud.fields.get(k) is None]
    if not opts.beam_correction or not missing:
        return []
    return [f"the soundings carry no {' or '.join(missing)}: the beam correction placed every transducer "
            "at the surface over its sounding and took the bloom's shape as the same every way (a sonar "
            "file or an .npz that keeps them sees each reef's edges as its lines saw them)"]


def _laps(times: StageTimes | None) -> Callable[[str], None]:
    """``times.lap`` once ``times`` is started, or a lap that records nothing."""
    if times is None:
        return lambda name: None
    times.start()
    return times.lap


def _denoise(pts: np.ndarray, opts: ReefOptions) -> tuple[np.ndarray, dict[str, Any], str | None]:
    """The paper's radius filter (with the spacing rescue in our method): the soundings
    kept, the filters' report and a note when it removed many."""
    keep, rep = denoise(pts, radius=opts.noise_radius, min_neighbors=opts.noise_neighbors,
                        spacing_factor=opts.noise_spacing if opts.method == "local" else 0.0)
    return keep, {"radius": rep.to_dict()}, _filter_loss(pts, rep.n_removed, opts)


def _seabed_note(height: np.ndarray, coverage: float) -> list[str]:
    """A warning when few soundings lie on the fitted seabed of a well-covered area."""
    on_ground = float(np.mean(np.abs(height) <= GROUND_BAND))
    if coverage >= 0.25 and on_ground < 0.3:
        return [f"only {100 * on_ground:.0f} % of the soundings lie on the fitted seabed: is "
                "there a seabed in this cloud?"]
    return []


def _reef_mask(points: np.ndarray, seabed: Seabed, height: np.ndarray, opts: ReefOptions,
               filters: dict[str, Any]) -> np.ndarray:
    """The reef points: standing off the seabed (and through the statistical filter, in our
    method); the paper's: farther than its plane threshold above the plane."""
    if opts.method != "local":
        return (np.abs(height) > opts.plane_threshold) & (height > 0)
    is_reef, _ = reef_points(points, seabed, min_height=opts.min_height, foot_height=opts.foot_height,
                             height=height)
    is_reef, stat = clean_reef_points(points, is_reef, k=opts.statistical_k, std_ratio=opts.statistical_ratio)
    if stat is not None:
        filters["statistical"] = stat.to_dict()
    return is_reef


def _objects(cloud: PointCloud, points: np.ndarray, rows: np.ndarray, is_reef: np.ndarray, seabed: Seabed,
             height: np.ndarray, opts: ReefOptions) -> tuple[list[Reef], list[OtherObject], float | None]:
    """The reefs and the other objects among the reef points (``rows``: each point's row in
    the cloud, for the reefs' sources), and the single-reef area used."""
    if not is_reef.any():
        return [], [], None
    if opts.method != "local":
        reefs, others = paper_clusters(points, is_reef, seabed, eps=opts.cluster_eps, min_area=opts.min_area)
        return reefs, others, math.nan
    ping, line = (None if cloud.fields.get(k) is None else cloud.fields[k][rows] for k in ("ping", "line"))
    view = _sight(cloud, points, rows, is_reef, height, opts)
    reefs, others, used_area, members = reef_islands(points, is_reef, seabed, height, opts, ping=ping,
                                                     line=line, view=view)
    files = cloud.meta.get("files") or [cloud.source or "(array)"]
    reefs = [replace(r, sources=sources(rows[m], cloud.fields, files),
                     beam_footprint=math.nan if view is None else _footprint(points, m, view))
             for r, m in zip(reefs, members, strict=True)]
    return reefs, others, used_area


def _footprint(points: np.ndarray, rows: np.ndarray, view: Sight) -> float:
    """The width (m) of the beam's footprint where the soundings ``rows`` were heard: their
    median slant range from their transducers times the beam's width across."""
    if not len(rows):
        return math.nan
    rng = float(np.median(np.linalg.norm(points[rows] - view.origins[rows], axis=1)))
    return 2.0 * rng * math.tan(math.radians(view.beam.beam_across_deg) / 2)


def _sight(cloud: PointCloud, points: np.ndarray, rows: np.ndarray, is_reef: np.ndarray,
           height: np.ndarray, opts: ReefOptions) -> Sight | None:
    """How each sounding was seen, for the beam correction (None when it is off)."""
    beam = opts.beam()
    if beam is None:
        return None
    angle, intensity = (None if cloud.fields.get(k) is None else cloud.fields[k][rows]
                        for k in ("beam_angle", "intensity"))
    ping = None if cloud.fields.get("ping") is None else ping_keys(
        {k: v[rows] for k, v in cloud.fields.items() if k in ("ping", "line", "file")})
    contrast = opts.beam_contrast_db
    if contrast is None:
        contrast = contrast_db(intensity, is_reef, height)
    return sight(points, ping, angle, beam, contrast, seabed=~is_reef)


def _score(reefs: list[Reef], reference: Any, opts: ReefOptions, warnings: list[str]
           ) -> tuple[Any, np.ndarray]:
    """The reefs scored against the reference (its warnings added to ``warnings``)."""
    if not (isinstance(reference, tuple) and len(reference) == 2
            and np.ndim(reference[0]) == 2 and np.shape(reference[0])[1] == 2):
        raise ParameterError("reference: not a pair (positions (R, 2), ids); expected what "
                             "mbinspect.evaluate.read_reference returns", option="reference")
    evaluation, warn = score_reefs(reefs, reference, tolerance=opts.tolerance)
    warnings += warn
    return evaluation, np.asarray(reference[0])
