"""Pile accuracy study against simulator truth: both methods, many seeds, hard variants.

Run: ``python benchmarks/study_piles.py [--seeds 20] [--configs default,tilt5,...]``.
Prints, per configuration and method, the spacing error RMS and max, the centre error max
(plan), the tilt error max, the share of spacings within their 2-sigma, and the number of
flagged piles. Each seed simulates the full ``jacket`` preset (about 2.2 M soundings).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import run_study, table  # noqa: E402
from mbinspect.piles import locate_piles  # noqa: E402
from mbinspect.simulate import simulate  # noqa: E402

#: name -> (simulator overrides, locate_piles overrides)
CONFIGS: dict[str, tuple[dict, dict]] = {
    "default": ({}, {}),
    "tilt5": ({"tilt_max_deg": 5.0}, {}),
    "no-top-lines": ({"lines": "west,east,south,north"}, {}),
    "one-side-unscanned": ({"lines": "west,south,tops"}, {}),
    "noise-x2": ({"noise_scale": 2.0}, {}),
    "radius+2cm": ({}, {"radius": 0.77}),
}


#: method rows of the table -> locate_piles options
VARIANTS: dict[str, dict] = {
    "intersection": {"method": "intersection"},
    "paper intersection": {"method": "intersection", "radius_mode": "fixed", "segmentation": "paper",
                           "use_intensity": False},
    "paper centre": {"method": "centre", "segmentation": "paper", "use_intensity": False},
}


def run_one(args: tuple[str, int]) -> list[dict]:
    name, seed = args
    sim_kw, loc_kw = CONFIGS[name]
    sim = simulate("jacket", seed=seed, **sim_kw)
    truth = {p["id"]: p for p in sim.truth["piles"]}
    tsp = {(s["a"], s["b"]): s["distance"] for s in sim.truth["spacings"]}
    rows = []
    for method, extra in VARIANTS.items():
        kw = {"count": 4, "radius": 0.75, "seed": seed, **extra, **loc_kw}
        res = locate_piles(sim.cloud, **kw)
        piles = {p.id: p for p in res.piles}
        sp_err = [s.distance - tsp[(s.a, s.b)] for s in res.spacings if (s.a, s.b) in tsp]
        z_in = [abs(s.distance - tsp[(s.a, s.b)]) <= 2 * s.sigma for s in res.spacings
                if (s.a, s.b) in tsp and math.isfinite(s.sigma)]
        c_err = [math.hypot(p.x - truth[i]["x"], p.y - truth[i]["y"]) for i, p in piles.items()
                 if i in truth]
        t_err = [abs(p.tilt_deg - truth[i]["tilt_deg"]) for i, p in piles.items()
                 if i in truth and p.tilt_deg is not None]
        rows.append({"config": name, "seed": seed, "method": method, "sp_err": sp_err,
                     "c_err": c_err, "t_err": t_err, "z_in": z_in, "n_found": len(piles),
                     "flagged": sum(bool(p.flags) for p in piles.values()),
                     "methods_used": sorted({p.method for p in piles.values()})})
    return rows


def main() -> None:
    chosen, results = run_study(__doc__, list(CONFIGS), 20, run_one)
    out = []
    for c in chosen:
        for m in VARIANTS:
            rs = [r for r in results if r["config"] == c and r["method"] == m]
            sp = np.concatenate([r["sp_err"] for r in rs]) * 100
            ce = np.concatenate([r["c_err"] for r in rs]) * 100
            te = np.concatenate([r["t_err"] for r in rs]) if any(r["t_err"] for r in rs) else np.array([])
            zi = np.concatenate([r["z_in"] for r in rs]) if rs else np.array([])
            out.append([c, m, len(rs), f"{np.sqrt(np.mean(sp**2)):.2f}", f"{np.abs(sp).max():.2f}",
                        f"{ce.max():.2f}", f"{te.max():.3f}" if len(te) else "-",
                        f"{100 * zi.mean():.0f} %" if len(zi) else "-",
                        sum(r["flagged"] for r in rs), sum(4 - r["n_found"] for r in rs)])
    print(table(["config", "method", "seeds", "spacing RMS cm", "spacing max cm", "centre max cm",
                 "tilt max deg", "within 2 sigma", "piles flagged", "piles missed"], out))


if __name__ == "__main__":
    main()
