"""The pile pipeline as its list of stages: :func:`locate_piles`."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any, NamedTuple

import numpy as np

from ..beam import Beam
from ..cloud import sources
from ..errors import DataError
from ..grid import sounding_spacing
from ..io import PointCloud, pipeline_input
from ..pings import ping_keys
from ..seabed import GROUND_BAND
from ..version import __version__
from .accept import rejected_record, rejection_reasons
from .assess import PLAN_FLAG, assess_pile, plan_flag
from .beam import beam_contrast, pile_models, through_beam, top_through_beam
from .design import Design, searched_tilt
from .elevate import elevated_points, pile_base, pile_thresholds
from .iterate import iterate
from .level import top_lines
from .options import PileOptions
from .radius import joint_radius, with_radius_sigma
from .relate import MeasuredPiles, relate_piles
from .results import PileFit, PileResult, RejectedPile, plan_sigma
from .separate import separate_piles
from .split import segment_piles

__all__ = ["locate_piles", "measure_piles", "MeasuredPiles", "no_pile_found"]


def locate_piles(data: PointCloud | np.ndarray, options: PileOptions | None = None, *,
                 design: Design | None = None, progress: Callable[[float], None] | None = None,
                 **overrides: Any) -> PileResult:
    """Locate piles, their top centres, radii and tilts, and every spacing.

    Stages: the points above a robust local seabed (:func:`elevated_points`), separated
    into piles (:func:`separate_piles`), each split into top and side
    (:func:`segment_piles`), measured by the centre or intersection method until the
    spacings settle (:func:`iterate`), judged (:func:`assess_pile`), candidates that
    cannot be standing piles set aside with their reasons (:func:`rejection_reasons`),
    matched to the design
    (:func:`apply_design`), and every spacing with its 1-sigma (:func:`spacings`).

    Parameters
    ----------
    data : PointCloud or ndarray, shape (N, 3)
        Soundings (m, z up); a cloud's ``intensity`` and ``ping`` fields are used.
    options : PileOptions, optional
        Every option (:class:`PileOptions`); ``radius`` is required.
    design : Design, optional
        Design positions or spacings for deviations and pass/fail.
    progress : callable, optional
        Called with the fraction done (0 to 1).
    **overrides
        Options by name, over ``options`` (``locate_piles(cloud, radius=0.75, count=4)``).

    Returns
    -------
    PileResult

    Raises
    ------
    ParameterError
        A bad option, named by its library name.
    DataError
        No point stands above the seabed, or no pile is found.

    Examples
    --------
    >>> from mbinspect.simulate import simulate
    >>> sim = simulate("jacket", seed=2, ping_spacing=0.25)
    >>> result = locate_piles(sim.cloud, count=4, radius=0.75)
    >>> len(result.piles), len(result.spacings)
    (4, 6)
    >>> 21.8 < result.spacings[0].distance < 22.2
    True
    """
    opts = PileOptions(**overrides) if options is None else options.replace(**overrides)
    opts = searched_tilt(opts, design)
    m = measure_piles(data, opts, progress=progress)
    if not m.piles:
        raise DataError(no_pile_found(m.rejected))
    parameters = {**opts.to_dict(), "design": design.source if design is not None else None,
                  "joint_radius": None if m.joint_radius is None else m.joint_radius.to_dict(),
                  "input": {"source": m.cloud.source, "n_points": len(m.cloud), "crs": m.cloud.crs},
                  "software": f"mbinspect {__version__}"}
    result = relate_piles(m.piles, m.covs, opts, design=design, parameters=parameters,
                          warnings=list(m.warnings), rejected=list(m.rejected), measured=m)
    if progress is not None:
        progress(1.0)
    return result


def measure_piles(data: PointCloud | np.ndarray, opts: PileOptions,
                  progress: Callable[[float], None] | None = None) -> MeasuredPiles:
    """The first stages of :func:`locate_piles`: every standing pile measured, numbered
    from 1 in stable order, each with its sources; candidates that are not piles or cannot
    be measured in ``rejected`` with the reasons. On one tile of a survey as on a whole one.

    Raises
    ------
    DataError
        Soundings too sparse for the radius, no point above the seabed, no candidate.
    """
    cloud, pts, notes = pipeline_input(data, crop=opts.crop)
    beam = opts.beam()
    m = _measure_points(cloud, pts, notes, opts, _share(progress, 0.0, 1.0 if beam is None else 0.4))
    if beam is None or not m.piles:
        return m
    return _through_beam(m, cloud, pts, notes, opts, beam, progress)


def _share(progress: Callable[[float], None] | None, start: float, stop: float
           ) -> Callable[[float], None] | None:
    """``progress`` over ``start`` to ``stop`` of the whole (one of several measurements)."""
    if progress is None or (start, stop) == (0.0, 1.0):
        return progress
    return lambda f: progress(start + (stop - start) * f)


#: Most measurements of the piles through the beam, and the largest centre move (m) between
#: two that stops them sooner.
BEAM_PASSES, BEAM_SETTLED = 4, 0.001


def _through_beam(m: MeasuredPiles, cloud: PointCloud, pts: np.ndarray, notes: list[str], opts: PileOptions,
                  beam: Beam, progress: Callable[[float], None] | None) -> MeasuredPiles:
    """The piles measured again from soundings corrected through the beam
    (:mod:`mbinspect.piles.beam`), each time from the soundings as read with the bias taken
    from the newer model, until no centre moves by :data:`BEAM_SETTLED`; what the last
    pass moved each centre is taken as what the beam's bias leaves in it (a geometric
    convergence leaves about as much as its last step), or half its beams' footprint where
    its wall has too few soundings (``min_side``) to fit, and joins its plan covariance."""
    ping, angle = cloud.fields.get("ping"), cloud.fields.get("beam_angle")
    if ping is None or angle is None:
        return replace(m, warnings=(*m.warnings, "beam_width_deg: the soundings carry no ping and beam angle "
                                    "to place their beams; the beam's bias was not corrected"))
    keys = ping_keys(dict(cloud.fields))
    contrast_db = opts.beam_contrast_db if opts.beam_contrast_db is not None else beam_contrast(
        cloud.fields.get("intensity") if opts.use_intensity else None, pts, m.piles)
    passes, settled = 0, False
    while not settled:
        passes += 1
        models = pile_models(m.piles, m.cylinders, pts)
        seen = through_beam(pts, keys, angle, models, beam, reach=opts.neighbourhood, contrast_db=contrast_db)
        before = np.array([[p.x, p.y] for p in m.piles])
        share = (1.0 - 0.4) / BEAM_PASSES
        m = _measure_points(cloud.subset(seen.keep), seen.points[seen.keep], notes, opts,
                            _share(progress, 0.4 + share * (passes - 1), 0.4 + share * passes), checked=True)
        moves = [float(np.hypot(*(before - [p.x, p.y]).T).min()) if len(before) else 0.0 for p in m.piles]
        settled = max(moves, default=0.0) < BEAM_SETTLED or passes == BEAM_PASSES
    m = _with_beam_sigma(m, moves, models, seen.half_footprints, opts.min_side, opts.max_sigma)
    m, tops = _tops_through_beam(m, pts, keys, angle, beam, opts, contrast_db)
    note = (f"seen through {opts.beam_width_deg:g}° beams ({opts.detection} detection, the steel's echo "
            f"{contrast_db:.0f} dB over the seabed's; {passes} passes, the last moving a centre by at most "
            f"{1000 * max(moves, default=0.0):.1f} mm, kept in its 1-sigma, as half a footprint for a pile "
            f"with too few wall soundings): {seen.moved:,} soundings moved back along their beams, "
            f"{seen.left_out:,} left out as the steel's echo heard beside the piles"
            + (f"; {tops} pile{'s' * (tops != 1)} with too few wall soundings centred on the top as "
               "the beams heard it" if tops else ""))
    return replace(m, warnings=(*m.warnings, note))


def _tops_through_beam(m: MeasuredPiles, pts: np.ndarray, keys: np.ndarray, angle: np.ndarray, beam: Beam,
                       opts: PileOptions, contrast_db: float) -> tuple[MeasuredPiles, int]:
    """Each pile whose wall has too few soundings to fit centred on its top as the beams
    heard it, wings and all (:func:`~mbinspect.piles.beam.top_through_beam`, from the
    soundings as read), with that fit's covariance; the others as they are."""
    piles, covs = [], dict(m.covs)
    for p, model in zip(m.piles, pile_models(m.piles, m.cylinders, pts), strict=True):
        fit = None if p.n_side >= opts.min_side else top_through_beam(
            pts, keys, angle, model, beam, reach=opts.neighbourhood, contrast_db=contrast_db)
        if fit is not None:
            covs[p.id] = fit[1]
            p = _flag_sigma(replace(p, x=float(fit[0][0]), y=float(fit[0][1]), sigma_xy=plan_sigma(fit[1])),
                            opts.max_sigma)
        piles.append(p)
    tops = sum(a is not b for a, b in zip(piles, m.piles, strict=True))
    return replace(m, piles=tuple(piles), covs=covs), tops


def _flag_sigma(p: PileFit, max_sigma: float) -> PileFit:
    """``p`` with its plan-uncertainty flag (:func:`~mbinspect.piles.assess.assess_pile`)
    said again for its present 1-sigma."""
    flags = [f for f in p.flags if not f.startswith(PLAN_FLAG)]
    if not p.sigma_xy <= max_sigma:
        flags.append(plan_flag(p.sigma_xy, max_sigma))
    return replace(p, flags=tuple(flags))


def _with_beam_sigma(m: MeasuredPiles, moves: list[float], models: list[Any],
                     half_footprints: tuple[float, ...], min_side: int, max_sigma: float) -> MeasuredPiles:
    """Each pile's plan covariance widened by what the beam's bias leaves in its centre: the
    last pass's move, and for a pile whose wall has too few soundings to fit (its centre from
    the top's edge, which the beam blurs however well the passes settle) at least half the
    footprint of the beams that reach it."""
    tops = np.array([mo.top[:2] for mo in models])
    left = [max(move, half_footprints[int(np.argmin(np.hypot(*(tops - [p.x, p.y]).T)))])
            if p.n_side < min_side else move for p, move in zip(m.piles, moves, strict=True)]
    covs = {p.id: m.covs[p.id] + s**2 * np.eye(2) for p, s in zip(m.piles, left, strict=True)}
    piles = tuple(_flag_sigma(replace(p, sigma_xy=math.sqrt(p.sigma_xy**2 + s**2)), max_sigma)
                  for p, s in zip(m.piles, left, strict=True))
    return replace(m, piles=piles, covs=covs)


def _measure_points(cloud: PointCloud, pts: np.ndarray, notes: list[str], opts: PileOptions,
                    progress: Callable[[float], None] | None, *, checked: bool = False) -> MeasuredPiles:
    """:func:`measure_piles` on the points given (``cloud`` holds their fields); their
    spacing checked unless ``checked`` (the passes through the beam measure the same
    soundings, a few left out)."""
    spacing = 0.0 if checked else sounding_spacing(pts, seed=opts.seed)
    if spacing > opts.radius:
        # no pile of this radius can hold enough soundings; the seabed grids would also
        # grow with the extent of so sparse a survey rather than with its soundings
        raise DataError(f"the soundings lie {spacing:.2f} m apart (median plan distance to the nearest): "
                        f"too sparse to measure piles of `radius` {opts.radius:g} m, which need soundings "
                        f"under {opts.radius:g} m apart")
    intensity = cloud.fields.get("intensity") if opts.use_intensity else None
    ping = cloud.fields.get("ping")
    line = cloud.fields.get("line")
    report = progress or (lambda f: None)
    elevated, seabed, height = elevated_points(pts, min_height=opts.min_height, seabed_cell=opts.seabed_cell,
                                               seabed_window=opts.opening_window)
    report(0.2)
    if not elevated.any():
        raise DataError(f"no points stand more than {opts.min_height} m above the seabed; no pile to "
                        "measure (check the min_height option and the crop)")
    eidx = np.flatnonzero(elevated)
    labels, found = separate_piles(pts[eidx], count=opts.count, radius=opts.radius, seed=opts.seed)
    warnings = notes + found
    if not (labels >= 0).any():
        raise DataError("no pile found among the points above the seabed")
    report(0.3)
    # each found pile's side down to the floor the seabed's noise sets, not only above min_height
    ground = np.abs(height) < GROUND_BAND
    eidx, labels, _ = pile_base(pts, height, eidx, labels, radius=opts.radius, min_height=opts.min_height,
                                ground=ground)
    thr, backscatter = pile_thresholds(intensity, pts, eidx, labels, ground,
                                       opts.radius, beam_angle=cloud.fields.get("beam_angle"), line=line)
    per_point = {name: None if f is None else f[eidx] for name, f in (
        ("ping", ping), ("line", line), ("beam_angle", cloud.fields.get("beam_angle")),
        ("sigma_h", cloud.fields.get("sigma_h")))}
    files = cloud.meta.get("files") or [cloud.source or "(array)"]

    def judged(o: PileOptions, measured: tuple[Any, ...] | None = None, radius_sigma: float = 0.0) -> _Judged:
        """Every candidate segmented, measured (or ``measured`` again), judged and kept or
        set aside, with ``o``; each centre's covariance takes ``radius_sigma`` through the
        way it moves with the radius."""
        if measured is None:
            segs, side_n, seg_info = segment_piles(pts[eidx], labels, o, intensity=backscatter,
                                                   intensity_threshold=thr, **per_point)
            fits, iterations, unmeasured = iterate(segs, side_n, o, report)
        else:
            segs, seg_info, fits, iterations, unmeasured = measured
        fits = {pid: with_radius_sigma(m, radius_sigma) for pid, m in fits.items()}
        piles = tuple(replace(assess_pile(pid, fits[pid], o), sources=sources(
            eidx[labels == pid], cloud.fields, files), top_lines=top_lines(
            segs[pid], fits[pid], radius=o.radius, threshold=o.threshold)) for pid in sorted(fits))
        return _Judged(segs, seg_info, fits, iterations, unmeasured, *_standing(piles, seabed, o))

    j, joint = _with_joint_radius(judged, judged(opts), opts, warnings)
    return _measured(j, thr, cloud, seabed, joint, warnings)


def _with_joint_radius(judged: Callable[..., _Judged], j: _Judged, opts: PileOptions, warnings: list[str]
                       ) -> tuple[_Judged, Any]:
    """The candidates judged again with the joint radius of those that stand as piles (a
    wall's radius is no pile's), every side counting by its own sigma: on a line that sees
    each pile over 30-60 deg only, those loose radii together still catch a prior 5 cm off
    (ets_all_a_y)."""
    joint = joint_radius({old: j.fits[old] for old in j.kept.values()}, opts.radius,
                         min_coverage_deg=0.0) if opts.radius_mode == "auto" else None
    if joint is not None and joint.rejects_prior:
        # the piles share a radius the prior is not: all of them measured again with it
        opts = opts.replace(radius=joint.radius, radius_mode="fixed")
        j = judged(opts, radius_sigma=joint.sigma)
        warnings.append(joint.note)
    elif joint is not None:
        # the prior stands, known as well as the data know the radius, or as far off as they put it
        j = judged(opts, j[:5], radius_sigma=max(joint.sigma, abs(joint.radius - joint.prior)))
    return j, joint


def _measured(j: _Judged, thr: dict[int, Any], cloud: PointCloud, seabed: Any, joint: Any,
              warnings: list[str]) -> MeasuredPiles:
    """The kept piles renumbered with their covariances, segments and cylinders; the
    candidates set aside (not measurable, not piles) listed with their reasons."""
    segs, seg_info, fits, iterations, unmeasured, piles, kept, rejected = j
    for pid, why in unmeasured.items():
        c = segs[pid].points.mean(axis=0)
        rejected.append(RejectedPile(float(c[0]), float(c[1]), float(segs[pid].points[:, 2].max()), None,
                                     None, None, (f"not measurable: {why.split(': ', 1)[-1]}",)))
    warnings += [f"{'candidate' if r.reasons[0].startswith('not measurable') else 'not a pile'} near "
                 f"({r.x:.1f}, {r.y:.1f}): {', '.join(r.reasons)}" for r in rejected]
    return MeasuredPiles(
        piles, {new: fits[old].cov for new, old in kept.items()}, tuple(rejected), tuple(warnings), cloud,
        {new: segs[old] for new, old in kept.items() if old in segs}, seabed,
        {new: fits[old].cylinder for new, old in kept.items() if fits[old].cylinder is not None},
        {"intensity_threshold": {new: thr.get(old) for new, old in kept.items()},
         "piles": {new: seg_info[old] for new, old in kept.items() if old in seg_info}},
        tuple(iterations), joint)


def no_pile_found(rejected: Sequence[RejectedPile]) -> str:
    """Why no pile is reported: each candidate set aside, with its reasons.

    Parameters
    ----------
    rejected : sequence of RejectedPile

    Returns
    -------
    str
    """
    if not rejected:
        return "no pile found among the points above the seabed"
    return "no pile found: " + "; ".join(
        f"the candidate near ({r.x:.1f}, {r.y:.1f}) is not a pile ({', '.join(r.reasons)})" for r in rejected)


class _Judged(NamedTuple):
    """What :func:`measure_piles` learns with one set of options."""

    segs: dict[int, Any]
    seg_info: dict[int, dict[str, Any]]
    fits: dict[int, Any]
    iterations: list[dict[str, Any]]
    unmeasured: dict[int, str]
    piles: tuple[PileFit, ...]
    kept: dict[int, int]
    rejected: list[RejectedPile]


def _standing(piles: tuple[PileFit, ...], seabed: Any, opts: PileOptions
              ) -> tuple[tuple[PileFit, ...], dict[int, int], list[RejectedPile]]:
    """The candidates that can be standing piles, renumbered from 1 in their order; the map
    new id -> old id; the others with their reasons."""
    kept: list[PileFit] = []
    old_of: dict[int, int] = {}
    rejected = []
    for p in piles:
        top = float(seabed.height_above(np.array([[p.x, p.y, p.z]]))[0])
        reasons = rejection_reasons(p, top, opts)
        if reasons:
            rejected.append(rejected_record(p, top, reasons))
            continue
        old_of[len(kept) + 1] = p.id
        kept.append(replace(p, id=len(kept) + 1))
    return tuple(kept), old_of, rejected
