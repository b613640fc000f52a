""":func:`plan_survey`: the candidate layouts round a design, each surveyed a few times in the
simulator, and the one that meets the target in the least time on site."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError, ParameterError
from ..piles import Design, read_design
from ..reefs.plan import ReefPlan
from ..simulate import named_sonar
from ..version import __version__
from .layouts import (
    Layout,
    at_speed,
    candidates,
    offsets_for,
    structure_frame,
    with_both_ways,
    with_tops_both_ways,
)
from .options import KNOT, PlanOptions, ping_rate
from .pool import run_trials, ticker
from .predict import SECTORS, DesignPile, Setting, Trial, pairs_of, run_trial
from .reef_results import ReefPlanResult
from .reef_run import plan_reef_survey
from .results import SCATTER_FLOOR, PlanResult, PredictedSpacing, Prediction

__all__ = ["plan_survey", "plan_input", "design_piles", "ping_rate"]

#: A side with fewer soundings than this per survey counts as one no beam reaches.
SEEN_MIN = 5

#: Layouts with their lines over the tops sailed both ways, then with every line sailed both
#: ways, are tried for this many of the best one-way layouts when none of those meets the target.
BOTH_WAYS = 2


def design_piles(design: Design, options: PlanOptions) -> tuple[DesignPile, ...]:
    """The design's piles with their top levels (the design's ``top``, else the seabed plus
    ``height``)."""
    if not design.positions:
        raise InputError(f"{design.source or 'design'}: gives spacings only; expected pile positions "
                         "(id,x,y[,group][,top][,tilt_deg|rake,tilt_azimuth_deg]) to plan lines round")
    seabed = -options.depth
    piles = []
    for i, (x, y) in sorted(design.positions.items()):
        top = design.tops.get(i)
        if top is None:
            if options.height is None:
                raise ParameterError(f"height: missing; expected how far pile {i}'s top stands above the "
                                     "seabed (--height), as the design gives no top", option="height")
            top = seabed + options.height
        if top <= seabed + 0.2:
            raise ParameterError(f"depth: pile {i}'s top at {top:g} m is not above the seabed at "
                                 f"{seabed:g} m; expected tops above the seabed (depth is positive, down)",
                                 option="depth")
        tilt, azimuth = design.tilts.get(i, (0.0, 0.0))
        piles.append(DesignPile(int(i), float(x), float(y), float(top), int(design.groups.get(i, 1)),
                                float(tilt), float(azimuth)))
    return tuple(piles)


def _sonar(opts: PlanOptions) -> tuple[Any, dict[str, Any] | None]:
    """The named sonar, or measured from ``sonar_from``, its swath at most twice ``max_angle``."""
    sonar = named_sonar(opts.sonar)
    measured = None
    if opts.sonar_from is not None:
        from .sonar import sonar_from_file

        sonar, measured = sonar_from_file(opts.sonar_from, sonar, seed=opts.seed)
    return dataclasses.replace(sonar, swath_deg=min(sonar.swath_deg, 2.0 * opts.max_angle)), measured


def _options_with(opts: PlanOptions, measured: dict[str, Any] | None) -> PlanOptions:
    """The options with a measured ping rate as the sonar's highest and its swath's edge."""
    if measured is None:
        return opts
    angle = min(opts.max_angle, measured["swath_deg"] / 2)
    rate = measured["ping_rate_hz"] or opts.max_ping_rate
    return opts.replace(max_angle=angle, max_ping_rate=rate)


def _run_jobs(jobs: list[tuple[Layout, tuple[DesignPile, ...], Setting, int]], workers: int,
              progress: Callable[[float], None] | None, done: list[int], total: int) -> list[Trial]:
    """Every trial (:func:`~mbinspect.plan.pool.run_trials`), ``done[0]`` counting them over
    the search's ``total`` for the progress."""
    return run_trials(run_trial, jobs, workers, ticker(progress, total, done))


def _rms(values: Sequence[float]) -> float:
    v = np.asarray([x for x in values if math.isfinite(x)], float)
    return float(np.sqrt(np.mean(v**2))) if len(v) else math.nan


#: Pseudo-spacings whose errors are the size of their reported 1-sigma (the piles' run is
#: meant to report an honest 1-sigma) that temper the calibration a layout's few trials show.
PRIOR = 12


def _calibration(trials: Sequence[Trial]) -> float:
    """The factor from the 1-sigma the runs reported to their errors (the RMS of each error in
    its reported sigmas), tempered by :data:`PRIOR`."""
    z2 = [(s[2] / s[3]) ** 2 for t in trials for s in t.spacings if s[3] > 0 and math.isfinite(s[3])]
    return math.sqrt((sum(z2) + PRIOR) / (len(z2) + PRIOR))


def _per_spacing(trials: Sequence[Trial], pairs: list[tuple[int, int]], factor: float
                 ) -> dict[tuple[int, int], tuple[float, float, float, int]]:
    """Per spacing: its predicted 1-sigma (the RMS of the 1-sigma the runs reported, times
    ``factor``; inf when a run did not measure it), that RMS, the RMS error and how many runs
    measured it."""
    rows_of: dict[tuple[int, int], list[tuple[float, float]]] = {ab: [] for ab in pairs}
    for t in trials:
        for s in t.spacings:
            if (s[0], s[1]) in rows_of:
                rows_of[(s[0], s[1])].append((s[2], s[3]))
    out = {}
    for ab, rows in rows_of.items():
        reported, err = _rms([r[1] for r in rows]), _rms([r[0] for r in rows])
        whole = len(rows) == len(trials) and rows
        out[ab] = (reported * factor if whole else math.inf, reported, err, len(rows))
    return out


def _worst(trials: Sequence[Trial], pairs: list[tuple[int, int]]) -> float:
    """The worst spacing's predicted 1-sigma from ``trials`` (inf when one went unmeasured)."""
    return max((v[0] for v in _per_spacing(trials, pairs, _calibration(trials)).values()), default=0.0)


def _scatter(trials: list[Trial], piles: tuple[DesignPile, ...]) -> float:
    """The relative 1-sigma of the worst spacing's prediction as its surveys scatter it: the
    delete-one jackknife over the surveys (NaN from fewer than two, or any unmeasured)."""
    if len(trials) < 2:
        return math.nan
    pairs = pairs_of(piles)
    whole = _worst(trials, pairs)
    parts = np.array([_worst(trials[:k] + trials[k + 1:], pairs) for k in range(len(trials))])
    if not (math.isfinite(whole) and np.isfinite(parts).all()) or whole <= 0:
        return math.nan
    n = len(trials)
    return float(math.sqrt((n - 1) / n * np.sum((parts - parts.mean()) ** 2)) / whole)


def _predict(layout: Layout, trials: list[Trial], piles: tuple[DesignPile, ...], options: PlanOptions,
             speed: float) -> Prediction:
    """A layout's prediction from its trials: each spacing's 1-sigma is the RMS of the 1-sigma
    the runs reported, times the calibration its trials' errors against the truth show (the
    RMS of each error in its reported sigmas) tempered by :data:`PRIOR`: the spread of the
    errors a survey of these lines will make. A spacing some run did not measure is
    unmeasured (inf)."""
    by_id = {p.id: p for p in piles}
    factor = _calibration(trials)
    spacings = [PredictedSpacing(a, b, math.hypot(by_id[a].x - by_id[b].x, by_id[a].y - by_id[b].y), *v)
                for (a, b), v in _per_spacing(trials, pairs_of(piles), factor).items()]
    tops = []
    for p in piles:
        levels = [r for t in trials for r in t.tops if r[0] == p.id]
        whole = len(levels) == len(trials) and levels
        tops.append((p.id, _rms([r[2] for r in levels]) if whole else math.inf))
    unseen = []
    for p in piles:
        counts = np.sum([dict(t.sectors)[p.id] for t in trials], axis=0) / max(len(trials), 1)
        unseen.append((p.id, tuple(SECTORS[k] for k in range(8) if counts[k] < SEEN_MIN)))
    missed = tuple((p.id, sum(p.id in t.missed for t in trials) / len(trials)) for p in piles)
    made = Prediction(layout, layout.time_on_site(speed, options.turn_s), tuple(spacings), tuple(tops),
                      tuple(unseen), missed, False, len(trials), factor, _scatter(trials, piles))
    meets = bool(spacings) and len(trials) >= options.seeds and made.worst_upper <= options.target_sigma
    return dataclasses.replace(made, meets_target=meets)


#: A layout whose one-survey prediction is worse than this many times the target is not
#: surveyed again (one survey's 1-sigma is rough, but not by half).
SCREEN = 1.5


@dataclasses.dataclass
class _Search:
    """The trials run so far, by layout, and what every prediction shares."""

    piles: tuple[DesignPile, ...]
    setting: Setting
    options: PlanOptions
    progress: Callable[[float], None] | None
    total: int
    done: list[int] = dataclasses.field(default_factory=lambda: [0])
    layouts: dict[str, Layout] = dataclasses.field(default_factory=dict)
    trials: dict[str, list[Trial]] = dataclasses.field(default_factory=dict)

    shown: list[float] = dataclasses.field(default_factory=lambda: [0.0])

    def share(self, value: float) -> None:
        """The progress, never going back and below 1 until the plan is made (the search's
        length is known only at its end)."""
        if self.progress is not None and min(value, 0.99) > self.shown[0]:
            self.shown[0] = min(value, 0.99)
            self.progress(self.shown[0])

    def run(self, layouts: list[Layout], seeds: list[int]) -> None:
        jobs = [(lay, self.piles, self.setting, s) for lay in layouts for s in seeds]
        for lay in layouts:
            self.layouts[lay.name] = lay
            self.trials.setdefault(lay.name, [])
        self.total = max(self.total, self.done[0] + len(jobs) + self.options.seeds)
        for t in _run_jobs(jobs, self.options.workers, self.share, self.done, self.total):
            self.trials[t.layout].append(t)

    def seeds(self) -> list[int]:
        """The seeds of a layout's simulated surveys (the same for every layout), the first
        ``seeds`` of them always, the rest when the prediction is near the target."""
        return [self.options.seed * 1000 + k for k in range(self.options.max_seeds)]

    def firm(self, name: str) -> Prediction:
        """The layout surveyed in batches of ``workers`` surveys (no worker left idle), up to
        ``max_seeds``, until it meets the target (after ``seeds`` surveys at least: the target
        at or above the upper 1-sigma bound of its worst spacing's predicted 1-sigma,
        :attr:`~mbinspect.plan.results.Prediction.sigma_error`, the scatter its surveys show,
        not under 12 % from three surveys or 7 % from nine) or cannot: a spacing some survey
        did not measure, or (from two surveys on) the target at or below the lower bound held
        at the upper bound ``max_seeds`` surveys could give at best (were the estimate to
        fall that far, its bound would still miss the target), or (from ``seeds`` surveys on)
        the estimate itself held at that bound above the target."""
        seeds, first, step = self.seeds(), self.options.seeds, self.options.workers
        best = 1.0 + SCATTER_FLOOR / math.sqrt(len(seeds))
        while True:
            done = len(self.trials[name])
            if done:
                now = self.prediction(name)
                low, high = now.worst_sigma * (1 - now.sigma_error) * best, now.worst_upper
                target = self.options.target_sigma
                # once it has the surveys a layout needs to meet the target, an estimate that
                # could not be confirmed even at the best precision left (were it to hold) is set
                # aside: near the target, such layouts took every survey to the last in vain
                held = done >= first and now.worst_sigma * best > target
                hopeless = not math.isfinite(now.worst_sigma) or (done >= 2 and low >= target) or held
                if hopeless or done >= len(seeds) or (done >= first and high <= target):
                    return now
            self.run([self.layouts[name]], seeds[done:done + step])

    def prediction(self, name: str) -> Prediction:
        return _predict(self.layouts[name], self.trials[name], self.piles, self.options,
                        self.options.speed * KNOT)

    def screen_then_confirm(self, layouts: list[Layout]) -> Prediction | None:
        """Each layout surveyed once, and screened at the plan's speed and at each of the
        slower speeds (:meth:`~mbinspect.plan.options.PlanOptions.slower_speeds`, its 1-sigma
        taken as the square root of the speed, as the pings on a pile grow); those not far
        from the target, fastest first, surveyed ``seeds`` times in all (more near the target:
        :meth:`firm`) until one meets it (that one, else None)."""
        self.run(layouts, self.seeds()[:1])
        speed, hopeful = self.options.speed, []
        for lay in layouts:
            first = self.prediction(lay.name)
            variants = [(lay, 1.0)] + [(at_speed(lay, v), math.sqrt(v / speed))
                                       for v in self.options.slower_speeds() if lay.speed is None]
            hopeful += [(first.worst_sigma * f, v.time_on_site(speed * KNOT, self.options.turn_s), v)
                        for v, f in variants]
        hopeful = [h for h in hopeful if h[0] <= SCREEN * self.options.target_sigma]
        for _, _, lay in sorted(hopeful, key=lambda h: (h[1], h[2].name)):
            self.layouts.setdefault(lay.name, lay)
            self.trials.setdefault(lay.name, [])
            full = self.firm(lay.name)
            if full.meets_target:
                return full
        return None


def _choose(search: _Search, layouts: list[Layout], given: bool) -> Prediction | None:
    """The layout that meets the target in the least time: among ``layouts`` each surveyed
    ``seeds`` times when ``given``, else screened; if none does, the best two with their lines
    over the tops sailed both ways, and with all their lines sailed both ways, screened
    together (the fewer lines first)."""
    if given:
        search.run(layouts, search.seeds()[:search.options.seeds])
        meeting = [p for p in (search.firm(lay.name) for lay in layouts) if p.meets_target]
        return min(meeting, key=lambda p: (p.time_on_site_s, p.layout.name)) if meeting else None
    chosen = search.screen_then_confirm(layouts)
    if chosen is None:  # the best few sailed both ways
        now = [search.prediction(n) for n in search.layouts]
        best = sorted(now, key=lambda p: (p.worst_sigma, p.time_on_site_s))[:BOTH_WAYS]
        tops = [with_tops_both_ways(p.layout) for p in best]
        chosen = search.screen_then_confirm([t for t in tops if t is not None]
                                            + [with_both_ways(p.layout) for p in best])
    return chosen


#: Columns only a reef plan has, and only a pile design.
REEF_COLUMNS = frozenset({"kind", "bearing_deg"})
PILE_COLUMNS = frozenset({"top", "rake", "tilt_deg", "tilt_azimuth_deg"})


def plan_input(path: str | Path, options: PlanOptions) -> str:
    """Whether a CSV is a reef plan (``"reefs"``) or a pile design (``"piles"``): by its
    columns, else by the options given (``radius`` for piles, ``kind`` for reef units).

    Raises
    ------
    ParameterError
        An ``id,x,y`` file with both or neither of ``radius`` and ``kind``.
    """
    from ..checks import csv_rows

    columns, _ = csv_rows(Path(path), "design", "a pile design or a reef plan CSV with a header")
    head = {c.strip() for c in columns}
    if head & REEF_COLUMNS and not head & PILE_COLUMNS:
        return "reefs"
    if head & PILE_COLUMNS or (options.radius is not None and options.kind is None):
        return "piles"
    if options.kind is not None and options.radius is None:
        return "reefs"
    raise ParameterError(f"{path}: columns {','.join(columns)} could be a pile design or a reef plan; "
                         "expected --radius R (piles) or --kind DESIGN (reef units), not both",
                         option="radius")


def plan_survey(design: Design | ReefPlan | str | Path, options: PlanOptions | None = None, *,
                progress: Callable[[float], None] | None = None, layouts: Sequence[Layout] | None = None,
                **overrides: Any) -> PlanResult | ReefPlanResult:
    """Plan the survey lines round a pile design, or over a reef plan
    (:func:`~mbinspect.plan.reef_run.plan_reef_survey`; :func:`plan_input` tells which).

    Candidate layouts (:func:`~mbinspect.plan.layouts.candidates`) are each surveyed
    ``seeds`` times in the simulator with the sonar's beam and error model at the ping
    spacing the speed and ping rate give, and measured by
    :func:`~mbinspect.piles.locate_piles`; each spacing's predicted 1-sigma is the RMS of
    the 1-sigma those runs reported times the calibration their errors show. The layout
    chosen meets ``target_sigma`` for every spacing, at the upper 1-sigma bound of the
    estimate (:attr:`~mbinspect.plan.results.Prediction.worst_upper`), in the least time
    on site; when no one-way layout
    does, the best two are tried with their lines over the tops sailed both ways and with
    every line sailed both ways; when still none does, the one with the smallest worst
    spacing 1-sigma is chosen and a warning says so.

    Parameters
    ----------
    design : Design or path-like
        Pile positions (``id,x,y[,group][,top]``), read by :func:`~mbinspect.piles.read_design`.
    options : PlanOptions, optional
    progress : callable, optional
        Called with the fraction of simulated surveys done.
    layouts : sequence of Layout, optional
        Predict these layouts (each surveyed ``seeds`` times) instead of generating candidates:
        the lines a survey sailed, say.
    **overrides
        Options by name (``plan_survey("design.csv", radius=0.75, depth=21, height=5)``).

    Returns
    -------
    PlanResult or ReefPlanResult
    """
    opts = (options or PlanOptions.from_given(overrides)) if not (options and overrides) else \
        options.replace(**overrides)
    if isinstance(design, ReefPlan) or (isinstance(design, str | Path)
                                        and plan_input(design, opts) == "reefs"):
        sonar, measured = _sonar(opts)
        opts = _options_with(opts, measured)
        return plan_reef_survey(design, opts, progress=progress, sonar=sonar, measured=measured,
                                rate=ping_rate(opts), layouts=layouts)
    radius = opts.radius
    if radius is None:
        raise ParameterError("radius: missing; expected the piles' radius (--radius R) to plan lines round a "
                             "pile design", option="radius")
    if isinstance(design, ReefPlan):
        raise ParameterError("radius: given with a reef plan; expected a pile design", option="radius")
    if not isinstance(design, Design):
        design = read_design(design)
    piles = design_piles(design, opts)
    sonar, measured = _sonar(opts)
    opts = _options_with(opts, measured)
    rate = ping_rate(opts)
    speed = opts.speed * KNOT
    xy = np.array([[p.x, p.y] for p in piles])
    frame = structure_frame(xy, radius=radius, groups=[p.group for p in piles])
    top_depth = -float(np.mean([p.top for p in piles])) + sonar.draft
    offsets = opts.offset_values() or offsets_for(top_depth, opts.max_angle)
    tried = list(layouts) if layouts is not None else candidates(frame, offsets=offsets, margin=opts.margin)
    setting = Setting(sonar, speed / rate, speed, opts.depth, radius, opts.tilt_max, frame.centre)
    search = _Search(piles, setting, opts, progress, (len(tried) + BOTH_WAYS) * opts.seeds)
    chosen = _choose(search, tried, layouts is not None)
    predictions = [search.prediction(n) for n in search.layouts]
    if progress is not None:
        progress(1.0)
    predictions.sort(key=lambda p: (p.time_on_site_s, p.layout.name))
    warnings = [measured["warning"]] if measured and measured.get("warning") else []
    if chosen is None:
        full = [p for p in predictions if p.surveys >= opts.seeds] or predictions
        chosen = min(full, key=lambda p: (p.worst_sigma, p.time_on_site_s))
        warnings.append(f"no layout meets the target of {opts.target_sigma:g} m for every spacing; the best, "
                        f"{chosen.layout.name}, is predicted to reach {chosen.worst_sigma:.3f} m")
    params = {**opts.to_dict(), "design": design.source, "ping_rate_hz": rate, "ping_spacing": speed / rate,
              "speed_ms": speed, "offsets_used": list(offsets), "frame": dataclasses.asdict(frame),
              "sonar_model": dataclasses.asdict(sonar), "sonar_measured": measured, "version": __version__}
    return PlanResult(piles, tuple(predictions), chosen.layout.name, opts.target_sigma, params,
                      tuple(warnings))
