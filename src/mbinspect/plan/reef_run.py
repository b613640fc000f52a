""":func:`plan_reef_survey`: the survey lines over a reef plan that give every unit its soundings
and detect the S-44 order's features in the least time on site.

Candidate layouts cover the field's area (the units' frame, a unit's reach and
:data:`BUFFER` beyond) with parallel lines along it or across it, adjacent swaths overlapping
by each of the ``overlaps`` (a wider overlap keeps every unit nearer a line, in the middle of a
swath, where the beams are narrow on the seabed and see a unit from above), and the grid of
both at the least overlap. Each is surveyed
``seeds`` times in the simulator (:mod:`~mbinspect.plan.reef_trial`); it meets the targets
when, in every survey, every unit is found in its place with at least ``min_soundings``
soundings on it and every cube of the order's size gets ``feature_soundings``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError, ParameterError
from ..reef_designs import BUILTIN_DESIGNS, DesignBox
from ..reefs.plan import ReefPlan, read_plan
from ..simulate import named_sonar
from ..version import __version__
from .layouts import Frame, Layout, PlanLine, racetrack, structure_frame
from .options import KNOT, S44_FEATURE, PlanOptions, ping_rate
from .pool import run_trials, ticker
from .reef_results import ReefPlanResult, ReefPrediction, UnitPrediction
from .reef_trial import PlannedUnit, ReefSetting, ReefTrial, run_reef_trial

__all__ = ["plan_reef_survey", "planned_units", "coverage_layouts", "BUFFER", "CUBES"]

#: The area a reef plan's lines cover reaches this far (m) beyond the units' outlines.
BUFFER = 5.0

#: Cubes of the S-44 order's size laid in each simulated survey.
CUBES = 12


def planned_units(plan: ReefPlan, options: PlanOptions) -> tuple[PlannedUnit, ...]:
    """The plan's units with their designs (the plan's ``kind``, else ``options.kind``; a
    built-in design, which the simulator can build) and reach."""
    units = []
    for row in plan.rows:
        kind = row.get("kind") or options.kind
        if kind is None:
            raise ParameterError(f"kind: missing; expected the units' design (--kind cross2, say) as "
                                 f"{plan.source or 'the plan'} gives unit {row['id']} no kind", option="kind")
        if kind not in BUILTIN_DESIGNS:
            raise InputError(f"{plan.source}: unit {row['id']}: kind {kind!r}; expected one of the designs "
                             f"the simulator builds: {', '.join(BUILTIN_DESIGNS)}")
        corners = np.array([c for b in BUILTIN_DESIGNS[kind].boxes for c in _box_corners(b)])
        units.append(PlannedUnit(str(row["id"]), float(row["x"]), float(row["y"]), row.get("bearing_deg"),
                                 kind, float(np.hypot(*corners.T).max())))
    return tuple(units)


def _box_corners(b: DesignBox) -> list[tuple[float, float]]:
    """A design box's plan corners relative to the unit's centre at bearing 0."""
    u = np.array([math.sin(math.radians(b.bearing_deg)), math.cos(math.radians(b.bearing_deg))])
    v = np.array([u[1], -u[0]])
    return [(float(b.dx + su * b.length / 2 * u[0] + sv * b.width / 2 * v[0]),
             float(b.dy + su * b.length / 2 * u[1] + sv * b.width / 2 * v[1]))
            for su in (-1, 1) for sv in (-1, 1)]


def swath_width(options: PlanOptions, draft: float) -> float:
    """The swath's width on the seabed (m) at the plan's depth."""
    return 2.0 * max(options.depth - draft, 0.5) * math.tan(math.radians(options.max_angle))


def _family(f: Frame, across: bool, spacing: float, width: float, reach: float, margin: float
            ) -> list[PlanLine]:
    """Parallel lines ``spacing`` apart (adjacent swaths of ``width`` m overlap by ``width -
    spacing``), enough that every point of the frame and ``reach`` beyond it lies within
    ``spacing / 2`` of a line: the middle of a swath, which a wider overlap narrows; along
    ``u``, or along ``v`` when ``across``."""
    half_side = (f.half_u if across else f.half_v) + reach  # the extent the lines must cover
    half_run = (f.half_v if across else f.half_u) + reach + margin  # how far each line runs
    n = max(1, math.ceil(2 * half_side / spacing - 1e-9))
    at = [(-(n - 1) / 2 + k) * spacing for k in range(n)]
    if across:
        return [PlanLine(f.point(a, -half_run), f.point(a, half_run)) for a in at]
    return [PlanLine(f.point(-half_run, b), f.point(half_run, b)) for b in at]


def coverage_layouts(f: Frame, *, width: float, overlaps: tuple[float, ...], reach: float, margin: float
                     ) -> list[Layout]:
    """Lines along and across the field at each overlap, and the grid of both at the least; a
    layout whose lines another already has is left out (a narrow field needs one line
    whatever the overlap)."""
    out: list[Layout] = []
    seen: set[tuple[PlanLine, ...]] = set()

    def add(name: str, lines: list[PlanLine], what: str) -> None:
        ordered = racetrack(lines)
        if tuple(sorted(ordered, key=lambda ln: (ln.start, ln.end))) in seen:
            return
        seen.add(tuple(sorted(ordered, key=lambda ln: (ln.start, ln.end))))
        out.append(Layout(name, what, ordered))

    for o in overlaps:
        spacing = width * (1.0 - o)
        for name, across in (("along", False), ("across", True)):
            lines = _family(f, across, spacing, width, reach, margin)
            apart = f", {spacing:.1f} m apart ({round(100 * o)} % swath overlap)" if len(lines) > 1 else \
                f" (its {width:.0f} m swath covers the field)"
            add(f"{name}-{round(100 * o)}%", lines, f"{_count(lines)} {name} the field{apart}")
    o = overlaps[0]
    lines = (_family(f, False, width * (1 - o), width, reach, margin)
             + _family(f, True, width * (1 - o), width, reach, margin))
    add(f"grid-{round(100 * o)}%", lines, f"{_count(lines)} along and across the field "
        f"({round(100 * o)} % swath overlap)")
    return out


def _count(lines: list[PlanLine]) -> str:
    return f"{len(lines)} line" + ("s" if len(lines) > 1 else "")


def _rms(values: list[float]) -> float:
    v = np.asarray([x for x in values if math.isfinite(x)], float)
    return float(np.sqrt(np.mean(v**2))) if len(v) else math.nan


def _predict(layout: Layout, trials: list[ReefTrial], units: tuple[PlannedUnit, ...], options: PlanOptions,
             cube: float | None) -> ReefPrediction:
    rows = {u.id: [r for t in trials for r in t.units if r[0] == u.id] for u in units}
    preds = tuple(UnitPrediction(i, sum(r[1] for r in rs) / max(len(rs), 1),
                                 min((r[2] for r in rs), default=0),
                                 float(np.mean([r[2] for r in rs])) if rs else 0.0,
                                 _rms([r[3] for r in rs]), _rms([r[4] for r in rs]))
                  for i, rs in rows.items())
    counts = [c for t in trials for c in t.cubes]
    cubes = (sum(c >= options.feature_soundings for c in counts) / len(counts) if counts else 0.0) \
        if cube is not None else None
    every = [r for rs in rows.values() for r in rs]
    meets = (len(trials) >= options.seeds and all(p.found == 1.0 and p.min_soundings >= options.min_soundings
                                                    for p in preds) and (cubes is None or cubes == 1.0))
    return ReefPrediction(layout, layout.time_on_site(options.speed * KNOT, options.turn_s), preds, cubes,
                          _rms([r[3] for r in every]), _rms([r[4] for r in every]), meets, len(trials))


def _run(jobs: list[tuple[Layout, tuple[PlannedUnit, ...], ReefSetting, int]], workers: int,
         progress: Callable[[float], None] | None) -> list[ReefTrial]:
    """Every trial (:func:`~mbinspect.plan.pool.run_trials`), the progress as they come in."""
    return run_trials(run_reef_trial, jobs, workers, ticker(progress, len(jobs)))


def plan_reef_survey(plan: ReefPlan | str | Path, options: PlanOptions, *,
                     progress: Callable[[float], None] | None = None, sonar: Any = None,
                     measured: dict[str, Any] | None = None, rate: float | None = None,
                     layouts: Sequence[Layout] | None = None) -> ReefPlanResult:
    """Plan the survey lines over a reef plan (``id,x,y[,bearing_deg][,kind][,group]``).

    Every candidate (:func:`coverage_layouts`) is surveyed ``seeds`` times; the one chosen
    meets the targets in the least time on site, else (with a warning) the one that comes
    nearest: the most units found, then the most cubes detected, then the most soundings on
    the unit that got fewest. ``sonar``, ``measured`` and ``rate`` are the sonar, what was
    measured from ``sonar_from`` and the ping rate, which :func:`~mbinspect.plan.plan_survey`
    passes (by default the named sonar, its swath at most twice ``max_angle``, and
    :func:`~mbinspect.plan.options.ping_rate`: ``sonar_from`` is read by ``plan_survey``);
    ``layouts``, when given, are predicted instead of the candidates (the lines a survey
    sailed, say).
    """
    if not isinstance(plan, ReefPlan):
        plan = read_plan(plan)
    units = planned_units(plan, options)
    if sonar is None:
        sonar = named_sonar(options.sonar)
        sonar = dataclasses.replace(sonar, swath_deg=min(sonar.swath_deg, 2.0 * options.max_angle))
    rate = ping_rate(options) if rate is None else rate
    speed = options.speed * KNOT
    xy = np.array([[u.x, u.y] for u in units])
    reach = max(u.reach for u in units) + BUFFER
    frame = structure_frame(xy, radius=max(u.reach for u in units))
    width = swath_width(options, sonar.draft)
    tried = list(layouts) if layouts is not None else coverage_layouts(
        frame, width=width, overlaps=options.overlap_values(), reach=reach, margin=options.margin)
    ox, oy = frame.centre
    span = float(np.hypot(frame.half_u, frame.half_v)) + reach
    lo, hi = xy.min(axis=0) - reach, xy.max(axis=0) + reach  # the area the lines cover
    cube = S44_FEATURE[options.s44_order]
    setting = ReefSetting(sonar, speed / rate, speed, options.depth, frame.centre,
                          (float(lo[0] - ox), float(lo[1] - oy), float(hi[0] - ox), float(hi[1] - oy)),
                          cube, CUBES)
    seeds = [options.seed * 1000 + k for k in range(options.seeds)]
    trials = _run([(lay, units, setting, s) for lay in tried for s in seeds], options.workers, progress)
    predictions = sorted((_predict(lay, [t for t in trials if t.layout == lay.name], units, options, cube)
                          for lay in tried), key=lambda p: (p.time_on_site_s, p.layout.name))
    meeting = [p for p in predictions if p.meets_target]
    warnings = [measured["warning"]] if measured and measured.get("warning") else []
    if meeting:
        chosen = meeting[0]
    else:
        chosen = max(predictions, key=lambda p: (p.found, p.cubes_detected or 0.0, p.min_soundings,
                                                 -p.time_on_site_s))
        warnings.append(f"no layout meets the targets (every unit found with {options.min_soundings} "
                        f"soundings, S-44 order {options.s44_order} features detected) in every survey; the "
                        f"nearest, {chosen.layout.name}, finds {100 * chosen.found:.0f} % of the units, the "
                        f"fewest soundings on one {chosen.min_soundings}")
    params = {**options.to_dict(), "plan": plan.source, "ping_rate_hz": rate, "ping_spacing": speed / rate,
              "speed_ms": speed, "swath_width_m": width, "area_half_span_m": span, "cube_m": cube,
              "cubes_per_survey": CUBES if cube is not None else 0, "frame": dataclasses.asdict(frame),
              "sonar_model": dataclasses.asdict(sonar), "sonar_measured": measured, "version": __version__}
    return ReefPlanResult(units, tuple(predictions), chosen.layout.name, options.min_soundings,
                          options.s44_order, params, tuple(warnings))
