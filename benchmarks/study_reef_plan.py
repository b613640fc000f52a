"""Plan before you sail over a reef plan (issue 31): does the chosen layout give every unit its
soundings and find it in its place on surveys of the real scene, and is the predicted spread
of the reefs' heights and centres the spread those surveys show?

Run: ``python benchmarks/study_reef_plan.py [--seeds 20] [--configs group-17m,group-25m,xtf]``.

``xtf`` is the real background: a group of four units injected beside the R2Sonic XTF's own
line at four places through 1-degree cones, measured, against the plan's prediction for that
line with the sonar measured from the file (``sonar_from``).

For each configuration a ``reef-field`` group (16 units of one design at a planned bearing of
30 degrees) is planned from its deployment plan (the preset's ``plan`` rows: where the units
were meant to go) with :func:`mbinspect.plan.plan_survey` (the default sonar: 1-degree beams;
4 kn; S-44 order 1a; 50 soundings on every unit). The planning scene is the plan alone: the
units at their planned places on a rough seabed. The chosen layout's lines are then sailed over
the preset's own scene (each unit landed 0.8 m (1 sigma) from its place and turned 2 degrees,
a sloping seabed, boulders and debris) in ``--seeds`` independent simulated surveys, measured
by ``extract_reefs`` with the design, told the beam, and placed against the plan. Printed per
configuration: the layout, its lines and time on site, the share of units found in their place
and the fewest soundings on a unit (planned and on the surveys), the predicted 1-sigma of a
reef's height and centre against the RMS of the errors over the surveys, their ratios, whether
the targets held in every survey, and the plan's wall time.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import own_line, run_study, table  # noqa: E402
from mbinspect.plan import plan_survey  # noqa: E402
from mbinspect.reefs import extract_reefs  # noqa: E402
from mbinspect.reefs.plan import ReefPlan  # noqa: E402
from mbinspect.simulate import LABELS, simulate  # noqa: E402

#: name -> reef-field options (one group); the plan's depth is the seabed's
CONFIGS: dict[str, dict] = {
    "group-17m": {"groups": "cross2", "per_group": 16, "plan_bearing_deg": 30.0, "close_pairs": 0},
    "group-25m": {"groups": "cross2", "per_group": 16, "plan_bearing_deg": 30.0, "close_pairs": 0,
                  "seabed": -25.0},
}

#: config -> {"plan": ReefPlanResult, "units": ReefPlan, "seconds": float}
PLANS: dict[str, dict] = {}


def make_plan(name: str) -> None:
    opts = CONFIGS[name]
    truth = simulate("reef-field", seed=0, ping_spacing=5.0, **opts).truth
    units = ReefPlan(tuple({"id": str(u["id"]), "x": u["x"], "y": u["y"], "bearing_deg": u["bearing_deg"],
                            "kind": u["kind"], "group": None} for u in truth["plan"]), f"{name} plan")
    t = time.perf_counter()
    plan = plan_survey(units, depth=-opts.get("seabed", -17.3))
    seconds = time.perf_counter() - t
    PLANS[name] = {"plan": plan, "units": units, "seconds": seconds}
    best = plan.best
    print(f"{name}: planned in {seconds:.0f} s: {plan.chosen}, {best.time_on_site_s / 60:.0f} min, found "
          f"{100 * best.found:.0f} %, fewest soundings {best.min_soundings}, height sigma "
          f"{1000 * best.height_sigma:.0f} mm, centre {1000 * best.centre_sigma:.0f} mm; tried " + ", ".join(
              f"{p.layout.name} ({'meets' if p.meets_target else 'misses'})" for p in plan.predictions),
          flush=True)


def run_one(args: tuple[str, int]) -> list[dict]:
    name, seed = args
    made = PLANS[name]
    plan = made["plan"]
    lines = [(ln.start, ln.end) for ln in plan.best.layout.lines]
    sim = simulate("reef-field", seed=1000 + seed, ping_spacing=plan.parameters["ping_spacing"],
                   survey_speed=plan.parameters["speed_ms"],
                   sonar=plan.parameters["sonar"], survey_lines=lines, **CONFIGS[name])
    truth = {str(r["id"]): r for r in sim.truth["reefs"]}
    on = np.bincount(sim.ident[sim.labels == LABELS["reef"]], minlength=max(int(i) for i in truth) + 1)
    res = extract_reefs(sim.cloud, design="cross2", plan=made["units"], seed=seed, beam_width_deg=1.0,
                        beam_correction=True)
    placed = {str(r.plan.get("plan_id")): r for r in res.reefs if r.plan.get("plan_id") is not None}
    rows = []
    for i, t in truth.items():
        r = placed.get(i)
        rows.append({"config": name, "seed": seed, "id": i, "found": r is not None,
                     "soundings": int(on[int(i)]),
                     "dh": (r.height - t["height"]) if r is not None else math.nan,
                     "dc": math.hypot(r.x - t["x"], r.y - t["y"]) if r is not None else math.nan})
    return rows


def _rms(v: list[float]) -> float:
    a = np.asarray([x for x in v if math.isfinite(x)])
    return float(np.sqrt(np.mean(a**2))) if len(a) else math.nan


def _summary(name: str, rs: list[dict]) -> list:
    made = PLANS[name]
    plan, best = made["plan"], made["plan"].best
    seeds = sorted({r["seed"] for r in rs})
    found = np.mean([r["found"] for r in rs])
    fewest = min(r["soundings"] for r in rs)
    every = all(all(r["found"] and r["soundings"] >= plan.min_soundings for r in rs if r["seed"] == s)
                for s in seeds)
    dh, dc = _rms([r["dh"] for r in rs]), _rms([r["dc"] for r in rs])
    return [name, best.layout.name, len(best.layout.lines), f"{best.time_on_site_s / 60:.0f}",
            f"{100 * best.found:.0f} %", f"{100 * found:.1f} %", best.min_soundings, fewest,
            f"{1000 * best.height_sigma:.0f}", f"{1000 * dh:.0f}", f"{best.height_sigma / dh:.2f}",
            f"{1000 * best.centre_sigma:.0f}", f"{1000 * dc:.0f}", f"{best.centre_sigma / dc:.2f}",
            "yes" if every else "no", len(seeds), f"{made['seconds']:.0f}"]


#: The real background: the R2Sonic XTF (one line, 236 k soundings at 10 m), its boat at 1.2 kn
XTF = Path(__file__).parents[2] / "shared" / "real" / "files" / "R2Testing_0009.xtf"


def real_background() -> None:
    """Four cross2 units (2 x 2, 7 m apart, planned bearing 30 degrees) injected beside the XTF's
    own line at four places through 1-degree cones and measured with the plan, against the
    plan's prediction for that line with the sonar measured from the same file."""
    from mbinspect.inject import InjectedReef, inject
    from mbinspect.io import PointCloud
    from mbinspect.simulate import named_sonar

    cloud, layout, mid, d, n = own_line(XTF)
    rows, seconds = [], []
    for k, (side, along) in enumerate([(1, -9.0), (1, 9.0), (-1, -9.0), (-1, 9.0)]):
        centre = mid + along * d + side * 7.0 * n
        pos = [tuple(centre + u * 3.5 * d + v * 3.5 * n) for u, v in ((-1, -1), (1, -1), (-1, 1), (1, 1))]
        units = ReefPlan(tuple({"id": str(i + 1), "x": float(x), "y": float(y), "bearing_deg": 30.0,
                                "kind": "cross2", "group": None} for i, (x, y) in enumerate(pos)), "xtf")
        seabed = float(np.median(cloud.xyz[np.hypot(*(cloud.xyz[:, :2] - centre).T) < 8, 2]))
        t = time.perf_counter()
        plan = plan_survey(units, depth=-seabed, sonar_from=str(XTF), speed=1.2, seeds=5, s44_order="2",
                           layouts=[layout], min_soundings=20)
        seconds.append(time.perf_counter() - t)
        inj = inject(cloud.xyz, dict(cloud.fields), beam=named_sonar("shallow-beam"), reefs=[
            InjectedReef(i + 1, x, y, "cross2", bearing_deg=30.0) for i, (x, y) in enumerate(pos)])
        res = extract_reefs(PointCloud(inj.xyz, dict(cloud.fields)), design="cross2", plan=units, seed=k,
                            beam_width_deg=1.0, beam_correction=True)
        placed = {str(r.plan.get("plan_id")): r for r in res.reefs if r.plan.get("plan_id") is not None}
        pred = {u.id: u for u in plan.best.units}
        for t_ in inj.truth["reefs"]:
            i, r = str(t_["id"]), placed.get(str(t_["id"]))
            rows.append({"found": r is not None, "soundings": inj.truth["counts"]["per_reef"][i],
                         "planned": pred[i].min_soundings, "found_planned": pred[i].found,
                         "dh": (r.height - t_["height"]) if r is not None else math.nan,
                         "dc": math.hypot(r.x - t_["x"], r.y - t_["y"]) if r is not None else math.nan,
                         "h_sigma": plan.best.height_sigma, "c_sigma": plan.best.centre_sigma})
    dh, dc = _rms([r["dh"] for r in rows]), _rms([r["dc"] for r in rows])
    hs = math.sqrt(np.mean([r["h_sigma"] ** 2 for r in rows]))
    cs = math.sqrt(np.mean([r["c_sigma"] ** 2 for r in rows]))
    found_planned = np.mean([r["found_planned"] for r in rows])
    out = [["xtf, 4 placements of 4 units", len(rows), f"{100 * found_planned:.0f} %",
            f"{100 * np.mean([r['found'] for r in rows]):.0f} %", min(r["planned"] for r in rows),
            min(r["soundings"] for r in rows), f"{1000 * hs:.0f}", f"{1000 * dh:.0f}", f"{hs / dh:.2f}",
            f"{1000 * cs:.0f}", f"{1000 * dc:.0f}", f"{cs / dc:.2f}", f"{np.mean(seconds):.0f}"]]
    print(table(["real background", "units", "found (planned)", "found (injected)",
                 "fewest soundings (planned)", "fewest (injected)", "height sigma mm (predicted)",
                 "height error RMS mm", "predicted/error", "centre sigma mm (predicted)",
                 "centre error RMS mm", "predicted/error", "plan s"], out))


def main() -> None:
    given = "--configs" in sys.argv
    chosen = sys.argv[sys.argv.index("--configs") + 1].split(",") if given else [*CONFIGS, "xtf"]
    if "xtf" in chosen:
        real_background()
        chosen.remove("xtf")
        if not chosen:
            return
        if given:
            sys.argv[sys.argv.index("--configs") + 1] = ",".join(chosen)
    for name in chosen:
        make_plan(name)
    chosen, results = run_study(__doc__, list(CONFIGS), 20, run_one)
    out = [_summary(n, [r for r in results if r["config"] == n]) for n in chosen]
    print(table(["config", "layout", "lines", "min on site", "found (planned)", "found (surveys)",
                 "fewest soundings (planned)", "fewest (surveys)", "height sigma mm (predicted)",
                 "height spread mm", "predicted/spread", "centre sigma mm (predicted)", "centre spread mm",
                 "predicted/spread", "targets held in every survey", "surveys", "plan s"], out))


if __name__ == "__main__":
    main()
