"""Acceptance against the plan (issue 30): reef placement against a deployment plan, least
depths against the truth, the tide applied by time; on the simulator and on reefs injected
into the real files.

Run: ``python benchmarks/study_acceptance.py [--seeds 10] [--configs reef-field,...]
[--workers 2] [--real] [--placements 3]``.

Simulator rows: the ``reef-field`` preset (four groups of 25, jitter 0.8 m, six close pairs
brought 0.3-0.9 m apart, each reef turned 2° (1σ) from a planned bearing of 30°) measured
with its designs and placed against its plan (the nominal grid): units matched to the
right reef, missing (reported), extra; the offset vector's error against the true offset
(RMS, max, share within 0.1 m), the offset magnitude's error within 2σ; the bearing error's
error (RMS, max, within 3°, within 2σ). Least depths of the matched reefs: error against the
true top (+ shoal), within the 95 % TVU, deeper than the truth beyond it, median TVU. Configs:
``reef-field`` (the shallow sonar), ``reef-field-tide`` (a 2.4 m tide: heights from the water
level at each ping, put back on chart datum with the simulated gauge's ``tide.csv``),
``reef-field-beam`` (1° cones; ``-told``: the reef chain told the beam; ``-0.5-told`` and
``-2-told`` the same sonar with 0.5° and 2° cones),
``reef-field-classic`` (the idealised sonar).

``--real``: four reefs injected into each real file (``study_inject.py``'s square): least
depth error against the injected tops (the files are one line each: their TVU is unknown,
and counted as such).
"""

from __future__ import annotations

import math
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import own_flags, run_study, table  # noqa: E402
from mbinspect.datum import vertical_reference  # noqa: E402
from mbinspect.errors import MBInspectError  # noqa: E402
from mbinspect.io import on_reference  # noqa: E402
from mbinspect.reefs import extract_reefs  # noqa: E402
from mbinspect.reefs.plan import ReefPlan  # noqa: E402
from mbinspect.simulate import simulate, write_bundle  # noqa: E402

PLAN_BEARING = 30.0
TOLD = {"beam_correction": True, "beam_width_deg": 1.0}  # the shallow-beam sonar's 1° cones
CONFIGS: dict[str, dict] = {
    "reef-field": {},
    "reef-field-tide": {"tide_range": 2.4, "tide_mean": 1.2},
    "reef-field-beam": {"sonar": "shallow-beam"},
    "reef-field-beam-told": {"sonar": "shallow-beam"},
    # the same sonar with narrower and wider cones, told the beam: the bearing's 1-sigma carries
    # what each footprint leaves (calibrated at 1°)
    "reef-field-beam-0.5-told": {"sonar": "shallow-beam", "beam_across_deg": 0.5},
    "reef-field-beam-2-told": {"sonar": "shallow-beam", "beam_across_deg": 2.0},
    "reef-field-classic": {"sonar": "classic"},
}


def run_one(args: tuple[str, int]) -> list[dict]:
    name, seed = args
    sim = simulate("reef-field", seed=seed, plan_bearing_deg=PLAN_BEARING, **CONFIGS[name])
    cloud = sim.cloud
    if sim.truth.get("tide"):
        with tempfile.TemporaryDirectory() as tmp:
            write_bundle(Path(tmp), {"tide": sim.truth["tide"]})
            cloud = on_reference(cloud, vertical_reference(Path(tmp) / "tide.csv"), "simulated")
    plan = ReefPlan(tuple({**u, "id": str(u["id"])} for u in sim.truth["plan"]), "simulated plan")
    width = CONFIGS[name].get("beam_across_deg", 1.0)
    told = {**TOLD, "beam_width_deg": width} if name.endswith("-told") else {}
    res = extract_reefs(cloud, design="cross2,cross1", plan=plan, **told)
    truth = {str(t["id"]): t for t in sim.truth["reefs"]}
    units = {str(u["id"]): u for u in sim.truth["plan"]}
    row = {"config": name, "seed": seed, "right": 0, "wrong": 0, "extra": 0,
           "missing": len(res.plan_missing or ()), "off": [], "bear": [], "least": []}
    for f in res.reefs:
        p = f.plan
        if p.get("plan_id") is None:
            row["extra"] += 1
            continue
        t, u = truth[p["plan_id"]], units[p["plan_id"]]
        if math.hypot(t["x"] - f.x, t["y"] - f.y) > 1.0:
            row["wrong"] += 1
            continue
        row["right"] += 1
        tdx, tdy = t["x"] - u["x"], t["y"] - u["y"]
        row["off"].append((math.hypot(p["plan_dx"] - tdx, p["plan_dy"] - tdy),
                           abs(p["plan_offset"] - math.hypot(tdx, tdy)), p["plan_offset_sigma"]))
        if p.get("bearing_error_deg") is not None:
            turn = (t["bearing_deg"] - PLAN_BEARING + 45) % 90 - 45
            row["bear"].append((p["bearing_error_deg"] - turn, p["bearing_error_sigma_deg"]))
        row["least"].append((-f.least["least_depth"] - t["z_top"], f.least["least_depth_tvu95"]))
    return [row]


def _least(rows: list[tuple[float, float]]) -> list[str]:
    a = np.array(rows, float).reshape(-1, 2)
    if not len(a):
        return ["-"] * 6
    ok = np.isfinite(a[:, 1])
    return [f"{1000 * a[:, 0].mean():+.1f}", f"{1000 * math.sqrt(np.mean(a[:, 0] ** 2)):.1f}",
            f"{100 * np.mean(np.abs(a[ok, 0]) <= a[ok, 1]):.0f} %" if ok.any() else "-",
            f"{100 * np.mean(-a[ok, 0] > a[ok, 1]):.0f} %" if ok.any() else "-",
            f"{1000 * np.median(a[ok, 1]):.0f}" if ok.any() else "-", f"{int((~ok).sum())}"]


def _real(placements: int) -> None:
    from mbinspect.inject import inject
    from mbinspect.io import PointCloud
    from study_inject import _files, _reef_square, site

    rows = []
    for name, cloud, layout in _files():
        if layout != "square":
            continue
        cx, cy, side = site(cloud)
        least, found, n = [], 0, 0
        for k in range(placements):
            try:
                square = _reef_square(cx, cy, side, np.random.default_rng(k))
                inj = inject(cloud.xyz, cloud.fields, reefs=square)
                res = extract_reefs(PointCloud(inj.xyz, dict(cloud.fields)),
                                    design="cross1,cross2,hollow,triangle", design_scale_tolerance=0.35)
            except MBInspectError:
                continue
            n += len(inj.truth["reefs"])
            for t in inj.truth["reefs"]:
                f = min(res.reefs, key=lambda f: math.hypot(f.x - t["x"], f.y - t["y"]), default=None)
                if f is not None and math.hypot(f.x - t["x"], f.y - t["y"]) < 1.0:
                    found += 1
                    least.append((-f.least["least_depth"] - t["z_top"], f.least["least_depth_tvu95"]))
        rows.append([name[:38], f"{found}/{n}", *_least(least)])
    print(table(["file", "reefs found", "least depth error mean mm (+ shoal)", "RMS mm", "within TVU",
                 "deeper than truth beyond TVU", "median TVU mm", "TVU unknown (one line)"], rows))


def main() -> None:
    import argparse

    ap = argparse.ArgumentParser(add_help=False)
    ap.add_argument("--real", action="store_true")
    ap.add_argument("--placements", type=int, default=3)
    known = own_flags(ap)
    chosen, results = run_study(__doc__, list(CONFIGS), 10, run_one)
    rows, least_rows = [], []
    for c in chosen:
        rs = [r for r in results if r["config"] == c]
        off = np.array([x for r in rs for x in r["off"]], float).reshape(-1, 3)
        bear = np.array([x for r in rs for x in r["bear"]], float).reshape(-1, 2)
        rows.append([c, f"{len(rs)}", f"{sum(r['right'] for r in rs)}", f"{sum(r['wrong'] for r in rs)}",
                     f"{sum(r['missing'] for r in rs)}", f"{sum(r['extra'] for r in rs)}",
                     f"{1000 * math.sqrt(np.mean(off[:, 0] ** 2)):.1f}", f"{1000 * off[:, 0].max():.0f}",
                     f"{100 * np.mean(off[:, 0] <= 0.1):.0f} %",
                     f"{100 * np.mean(off[:, 1] <= 2 * off[:, 2]):.0f} %",
                     f"{math.sqrt(np.mean(bear[:, 0] ** 2)):.2f}", f"{np.abs(bear[:, 0]).max():.2f}",
                     f"{100 * np.mean(np.abs(bear[:, 0]) <= 3):.0f} %",
                     f"{100 * np.mean(np.abs(bear[:, 0]) <= 2 * bear[:, 1]):.0f} %"])
        least_rows.append([c, *_least([x for r in rs for x in r["least"]])])
    print(table(["config", "seeds", "matched right", "wrong unit", "missing", "extra", "offset error RMS mm",
                 "max mm", "within 0.1 m", "within 2σ", "bearing error RMS deg", "max deg", "within 3°",
                 "within 2σ"], rows))
    print()
    print(table(["config", "least depth error mean mm (+ shoal)", "RMS mm", "within TVU",
                 "deeper than truth beyond TVU", "median TVU mm", "TVU unknown"], least_rows))
    if known.real:
        print()
        _real(known.placements)


if __name__ == "__main__":
    main()
