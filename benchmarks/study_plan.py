"""Plan before you sail (issue 31): is the predicted 1-sigma of a planned layout the spread of
its spacing errors, and does the chosen layout meet the target in no more time than the '#'?

Run: ``python benchmarks/study_plan.py [--seeds 20] [--configs jacket,wharf,jacket-15mm,xtf]
[--layout NAME] [--hash NAME]``.

``--layout NAME`` (one configuration) skips the search and plans that layout alone (say, what
an earlier search chose: ``hash-4.5+topsx2``, ``hash-8.5@2kn``, ``hash-14.5+tops2way@2kn``):
the same seeds give the same trials, so its prediction is the search's, and its surveys take
minutes where the wharf's search takes an hour. The plan's seconds are then that layout's
alone. ``--hash NAME`` sails another variant of the paper's '#' beside it
(``hash-12.5+topsx2``, ``hash-12.5+tops@2kn``): the '#' that meets a target, where the '#'
with tops alone does not.

``xtf`` is the real background: a small jacket injected beside the R2Sonic XTF's own line at
four places, against the plan's prediction for that line with the sonar measured from the file.

For each configuration the design of a simulator preset (its ``design`` rows: the piles
where they were meant to stand) is planned with :func:`mbinspect.plan.plan_survey` (the
default sonar: 1-degree beams, amplitude and phase detection; speed 4 kn), and the chosen
layout's lines, and the pile paper's '#' with lines over the tops at the preset's own offset,
are then sailed over the preset's scene (as-built scatter, lean or rake, a sloping seabed,
boulders) in ``--seeds`` independent simulated surveys and measured by ``locate_piles`` told
the beam. Printed per layout: its lines and time on site, the predicted 1-sigma (RMS over
the spacings), the spread of the spacing errors over the surveys (RMS, bias included), their
ratio pooled and the range of the per-spacing ratios, the share of spacings within 2 sigma
of the truth (the sigma each run reported, and the predicted one), whether the target was met
(the spread no larger than the target; and the worst spacing's spread, as the target holds for
every spacing), and the plan's wall time.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import own_line, run_study, table  # noqa: E402
from mbinspect.piles import Design, locate_piles  # noqa: E402
from mbinspect.plan import plan_survey, structure_frame  # noqa: E402
from mbinspect.plan.layouts import (  # noqa: E402
    Layout,
    at_speed,
    candidates,
    with_both_ways,
    with_tops_both_ways,
)
from mbinspect.plan.options import PlanOptions  # noqa: E402
from mbinspect.plan.run import design_piles  # noqa: E402
from mbinspect.simulate import simulate  # noqa: E402

#: name -> (preset, plan options, the preset's '#' offset from its piles)
CONFIGS: dict[str, tuple[str, dict, float]] = {
    "jacket": ("jacket", {"radius": 0.75, "depth": 21.0, "target_sigma": 0.01}, 12.5),
    "jacket-15mm": ("jacket", {"radius": 0.75, "depth": 21.0, "target_sigma": 0.015}, 12.5),
    "wharf": ("wharf", {"radius": 0.6, "depth": 14.0, "target_sigma": 0.015}, 10.0),
}

#: config -> {"plan": PlanResult, "hash": Layout, "seconds": float}, made before the pool starts
PLANS: dict[str, dict] = {}


def _design(preset: str) -> Design:
    rows = simulate(preset, seed=0, ping_spacing=5.0).truth["design"]
    groups = {r["id"]: r.get("group", 1) for r in rows}
    tilts = {r["id"]: (r["tilt_deg"], r["tilt_azimuth_deg"]) for r in rows if r.get("tilt_deg")}
    return Design(positions={r["id"]: (r["x"], r["y"]) for r in rows}, tops={r["id"]: r["top"] for r in rows},
                  groups=groups if len(set(groups.values())) > 1 else {}, tilts=tilts,
                  source=f"{preset} preset")


def named_layout(frame: Any, name: str) -> Layout:
    """The candidate layout called ``name`` (``hash-4.5+tops``, with ``x2`` for both ways,
    ``2way`` for the lines over the tops both ways, and ``@2kn`` for a slower speed)."""
    base, _, pace = name.partition("@")
    both, tops_both = base.endswith("x2"), base.endswith("2way")
    base = base.removesuffix("x2").removesuffix("2way")
    offset = float(base.split("-")[1].split("+")[0]) if "-" in base else 10.0
    found = {c.name: c for c in candidates(frame, offsets=(offset,), margin=20.0)}
    if base not in found:
        sys.exit(f"--layout: {name!r} is not a candidate; expected one of {', '.join(sorted(found))}")
    layout = with_both_ways(found[base]) if both else found[base]
    if tops_both:
        layout = with_tops_both_ways(found[base]) or sys.exit(f"--layout: {base!r} has no line over the tops")
    return at_speed(layout, float(pace.removesuffix("kn"))) if pace else layout


def make_plan(name: str, layout: str | None = None, hash_name: str | None = None) -> None:
    preset, opts, offset = CONFIGS[name]
    design = _design(preset)
    t = time.perf_counter()
    if layout is not None:
        piles = design_piles(design, PlanOptions(**opts))
        frame = structure_frame(np.array([[p.x, p.y] for p in piles]), radius=opts["radius"],
                                groups=[p.group for p in piles])
        plan = plan_survey(design, **opts, layouts=[named_layout(frame, layout)])
    else:
        plan = plan_survey(design, **opts)
    seconds = time.perf_counter() - t
    xy = np.array([[p.x, p.y] for p in plan.piles])
    frame = structure_frame(xy, radius=opts["radius"], groups=[p.group for p in plan.piles])
    hash_ = named_layout(frame, hash_name) if hash_name else next(
        c for c in candidates(frame, offsets=(offset,), margin=20.0) if c.name.endswith("+tops"))
    PLANS[name] = {"plan": plan, "hash": hash_, "seconds": seconds, "design": design}
    print(f"{name}: planned in {seconds:.0f} s: {plan.chosen}, {plan.best.time_on_site_s / 60:.0f} min, "
          f"worst {1000 * plan.best.worst_sigma:.1f} mm; tried " + ", ".join(
              f"{p.layout.name} ({1000 * p.worst_sigma:.1f} mm, {p.surveys})" for p in plan.predictions),
          flush=True)


def run_one(args: tuple[str, int]) -> list[dict]:
    name, seed = args
    preset, opts, _ = CONFIGS[name]
    made = PLANS[name]
    plan = made["plan"]
    rows = []
    for which, layout in (("chosen", plan.best.layout), ("'#' + tops", made["hash"])):
        lines = [(ln.start, ln.end) for ln in layout.lines]
        # sailed at the layout's speed (the vessel's motion runs in time), its pings as much closer
        speed = layout.speed or plan.parameters["speed_ms"]
        sim = simulate(preset, seed=1000 + seed, sonar=plan.parameters["sonar"], survey_lines=lines,
                       ping_spacing=plan.parameters["ping_spacing"] * speed / plan.parameters["speed_ms"],
                       survey_speed=speed)
        truth = {p["id"]: p for p in sim.truth["piles"]}
        res = locate_piles(sim.cloud, radius=opts["radius"], count=len(truth), design=made["design"],
                           seed=seed, beam_width_deg=1.0)
        errs = {}
        for s in res.spacings:
            if s.a in truth and s.b in truth:
                d = math.hypot(truth[s.a]["x"] - truth[s.b]["x"], truth[s.a]["y"] - truth[s.b]["y"])
                errs[(min(s.a, s.b), max(s.a, s.b))] = (s.distance - d, s.sigma)
        rows.append({"config": name, "seed": seed, "which": which, "errs": errs})
    return rows


def _summary(name: str, which: str, rs: list[dict]) -> list:
    made = PLANS[name]
    plan = made["plan"]
    target = plan.target_sigma
    layout = plan.best.layout if which == "chosen" else made["hash"]
    predicted = {(s.a, s.b): s.sigma for s in plan.best.spacings} if which == "chosen" else {}
    pairs = sorted({k for r in rs for k in r["errs"]})
    err = {k: np.array([r["errs"][k][0] for r in rs if k in r["errs"]]) for k in pairs}
    rep = {k: np.array([r["errs"][k][1] for r in rs if k in r["errs"]]) for k in pairs}
    spread = {k: float(np.sqrt(np.mean(v**2))) for k, v in err.items()}
    pooled = math.sqrt(np.mean([v**2 for v in spread.values()]))
    expected = sum(1 for a in plan.piles for b in plan.piles if a.id < b.id and a.group == b.group)
    measured = sum(len(r["errs"]) for r in rs)
    within_rep = np.mean(np.concatenate([np.abs(err[k]) <= 2 * rep[k] for k in pairs]))
    if predicted:
        pred = math.sqrt(np.mean([predicted[k] ** 2 for k in pairs]))
        ratios = [predicted[k] / spread[k] for k in pairs]
        within_pred = np.mean(np.concatenate([np.abs(err[k]) <= 2 * predicted[k] for k in pairs]))
        pr = [f"{1000 * pred:.1f}", f"{pred / pooled:.2f}", f"{min(ratios):.2f}-{max(ratios):.2f}",
              f"{100 * within_pred:.0f} %"]
    else:
        pr = ["-", "-", "-", "-"]
    minutes = layout.time_on_site(plan.parameters["speed_ms"], plan.parameters["turn_s"]) / 60
    worst = max(spread.values())
    return [name, which, layout.name, len(layout.lines), f"{minutes:.0f}", pr[0], f"{1000 * pooled:.1f}",
            f"{1000 * worst:.1f}", pr[1], pr[2], f"{100 * within_rep:.0f} %", pr[3],
            f"{measured}/{expected * len(rs)}", "yes" if pooled <= target else "no",
            "yes" if worst <= target else "no", f"{1000 * target:g}",
            f"{made['seconds']:.0f}" if which == "chosen" else "-"]


#: The real background: the R2Sonic XTF (one line, 236 k soundings at 10 m), its boat at 1.2 kn
XTF = Path(__file__).parents[2] / "shared" / "real" / "files" / "R2Testing_0009.xtf"


def real_background() -> None:
    """A small jacket (4 piles of r 0.5 m, 5 m apart, 2.5 m proud) injected beside the XTF's own
    line at four places through 1-degree beams, measured, against the plan's prediction for
    that line with the sonar measured from the same file (``sonar_from``)."""
    from mbinspect.inject import InjectedPile, inject
    from mbinspect.io import PointCloud
    from mbinspect.simulate import named_sonar

    cloud, layout, mid, d, n = own_line(XTF)
    rows = []
    for k, (side, along) in enumerate([(1, -5.0), (1, 5.0), (-1, -5.0), (-1, 5.0)]):
        centre = mid + along * d + side * 6.5 * n
        pos = {i + 1: tuple(centre + u * 2.5 * d + v * 2.5 * n) for i, (u, v) in enumerate(
            [(-1, -1), (1, -1), (-1, 1), (1, 1)])}
        near = np.hypot(*(cloud.xyz[:, :2] - centre).T) < 6
        seabed = float(np.median(cloud.xyz[near, 2]))
        design = Design(positions=pos, tops={i: seabed + 2.5 for i in pos}, source="xtf")
        t = time.perf_counter()
        plan = plan_survey(design, radius=0.5, depth=-seabed, sonar_from=str(XTF), speed=1.2, seeds=5,
                           target_sigma=0.05, layouts=[layout])
        seconds = time.perf_counter() - t
        inj = inject(cloud.xyz, dict(cloud.fields), beam=named_sonar("shallow-beam"), piles=[
            InjectedPile(i, x, y, radius=0.5, height=2.5) for i, (x, y) in pos.items()])
        res = locate_piles(PointCloud(inj.xyz, dict(cloud.fields)), radius=0.5, count=4, design=design,
                           seed=k, beam_width_deg=1.0)
        truth = {p["id"]: p for p in inj.truth["piles"]}
        pred = {(s.a, s.b): s.sigma for s in plan.best.spacings}
        for s in res.spacings:
            tr = math.hypot(truth[s.a]["x"] - truth[s.b]["x"], truth[s.a]["y"] - truth[s.b]["y"])
            rows.append((k, s.distance - tr, s.sigma, pred[(min(s.a, s.b), max(s.a, s.b))], seconds))
    err, rep, pred = (np.array([r[i] for r in rows]) for i in (1, 2, 3))
    out = [["xtf, 4 placements", len(rows), f"{1000 * math.sqrt(np.mean(pred**2)):.1f}",
            f"{1000 * math.sqrt(np.mean(err**2)):.1f}", f"{1000 * math.sqrt(np.mean(rep**2)):.1f}",
            f"{math.sqrt(np.mean(pred**2)) / math.sqrt(np.mean(err**2)):.2f}",
            f"{100 * np.mean(np.abs(err) <= 2 * pred):.0f} %",
            f"{100 * np.mean(np.abs(err) <= 2 * rep):.0f} %",
            f"{np.mean([r[4] for r in rows]):.0f}"]]
    print(table(["real background", "spacings", "predicted sigma mm", "error RMS mm", "reported sigma mm",
                 "predicted/error", "within 2 predicted sigma", "within 2 reported sigma", "plan s"], out))


def main() -> None:
    chosen = [c for c in (sys.argv[sys.argv.index("--configs") + 1].split(",") if "--configs" in sys.argv
                          else [*CONFIGS, "xtf"])]
    if "xtf" in chosen:
        real_background()
        chosen.remove("xtf")
        if not chosen:
            return
        if "--configs" in sys.argv:
            sys.argv[sys.argv.index("--configs") + 1] = ",".join(chosen)
        else:
            sys.argv += ["--configs", ",".join(chosen)]
    named = {}
    for flag in ("--layout", "--hash"):
        if flag in sys.argv:
            if len(chosen) != 1:
                sys.exit(f"{flag}: names one layout; expected one configuration in --configs")
            named[flag] = sys.argv[sys.argv.index(flag) + 1]
            del sys.argv[sys.argv.index(flag):sys.argv.index(flag) + 2]
    for name in chosen:
        make_plan(name, named.get("--layout"), named.get("--hash"))
    chosen, results = run_study(__doc__, list(CONFIGS), 20, run_one)
    out = []
    for name in chosen:
        for which in ("chosen", "'#' + tops"):
            rs = [r for r in results if r["config"] == name and r["which"] == which]
            if rs:
                out.append(_summary(name, which, rs))
    print(table(["config", "layout", "name", "lines", "min on site", "predicted sigma mm", "spread mm",
                 "worst spacing's spread mm", "predicted/spread", "per spacing", "within 2 sigma (reported)",
                 "within 2 sigma (predicted)", "spacings measured", "target met", "every spacing met",
                 "target mm", "plan s"], out))


if __name__ == "__main__":
    main()
