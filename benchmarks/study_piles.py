"""Pile accuracy study against simulator truth: both methods, many seeds, hard variants.

Run: ``python benchmarks/study_piles.py [--seeds 20] [--configs default,tilt5,...] [--ablation]``.
``--ablation`` adds our method without the side weights and without the joint radius. A
configuration whose survey has beams of a width (``beam-*``, issue 28) adds our method told that
width and the detection (``beam_width_deg``).
Prints, per configuration and method, the spacing error RMS and max, the centre error max
(plan), the median radius error (each pile's own fitted radius where it has one), the tilt
error max, the share of spacings within their 2 and 3 sigma, and the number of
flagged piles. Each seed simulates the full ``jacket`` preset (about 2.2 M soundings).
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import own_flags, run_study, table  # noqa: E402
from mbinspect.piles import locate_piles  # noqa: E402
from mbinspect.simulate import simulate  # noqa: E402

#: name -> (simulator overrides, locate_piles overrides)
CONFIGS: dict[str, tuple[dict, dict]] = {
    # the default sonar is `shallow`, calibrated against the real files (benchmarks/real_noise.py)
    "default": ({}, {}),
    # the idealised sonar of the first studies, kept for comparison
    "classic": ({"sonar": "classic"}, {}),
    "tilt5": ({"tilt_max_deg": 5.0}, {}),
    "no-top-lines": ({"lines": "west,east,south,north"}, {}),
    "one-side-unscanned": ({"lines": "west,south,tops"}, {}),
    "noise-x2": ({"noise_scale": 2.0}, {}),
    "radius+2cm": ({}, {"radius": 0.77}),
    "radius+5cm": ({}, {"radius": 0.80}),
    # a prior 5 cm off where one side is never scanned: few piles can show their own radius
    "one-side+radius+5cm": ({"lines": "west,south,tops"}, {"radius": 0.80}),
    # three jackets of 0.6 m piles (vertical, battered 1:6 and 1:4), no count given: the
    # jackets are found from the spacing and the spacings taken within each
    "wharf": ({"preset": "wharf"}, {"radius": 0.6, "count": None}),
    # issue 28: the beam as a cone (sub-rays, the makers' detection: amplitude near nadir,
    # phase outside), 0.5, 1 and 2 degrees; a leading-edge pick; and 1 degree without noise
    # (the beam's bias alone)
    "beam-0.5": ({"beam_across_deg": 0.5}, {}),
    "beam-1": ({"beam_across_deg": 1.0}, {}),
    "beam-2": ({"beam_across_deg": 2.0}, {}),
    "beam-1-leading-edge": ({"beam_across_deg": 1.0, "detection": "leading-edge"}, {}),
    "beam-1-noise-off": ({"beam_across_deg": 1.0, "noise_scale": 0.0}, {}),
    "beam-off-noise-off": ({"noise_scale": 0.0}, {}),
}


#: method rows of the table -> locate_piles options
VARIANTS: dict[str, dict] = {
    "intersection": {"method": "intersection"},
    "paper intersection": {"method": "intersection", "radius_mode": "fixed", "segmentation": "paper",
                           "use_intensity": False, "axis_mode": "free"},
    "paper centre": {"method": "centre", "segmentation": "paper", "use_intensity": False},
}

ABLATION_ENV = "MBINSPECT_STUDY_ABLATION"

#: the row of ours told the simulated survey's beam width and detection (``beam_width_deg``)
BEAM_VARIANT = "intersection, beam modelled"

#: ``--ablation``: our method without one of its parts
ABLATION: dict[str, dict] = {
    "intersection, unweighted": {"method": "intersection", "weights": "none"},
    "intersection, no joint radius": {"method": "intersection", "radius_mode": "each"},
}


def run_one(args: tuple[str, int]) -> list[dict]:
    name, seed = args
    sim_kw, loc_kw = dict(CONFIGS[name][0]), CONFIGS[name][1]
    sim = simulate(sim_kw.pop("preset", "jacket"), seed=seed, **sim_kw)
    truth = {p["id"]: p for p in sim.truth["piles"]}
    tsp = {(s["a"], s["b"]): s["distance"] for s in sim.truth["spacings"]}
    rows = []
    variants = {**VARIANTS, **ABLATION} if os.environ.get(ABLATION_ENV) else dict(VARIANTS)
    if sim_kw.get("beam_across_deg"):  # ours told the survey's beam (issue 28)
        variants[BEAM_VARIANT] = {"method": "intersection", "beam_width_deg": sim_kw["beam_across_deg"],
                                  "detection": sim_kw.get("detection", "auto")}
    for method, extra in variants.items():
        kw = {"count": 4, "radius": 0.75, "seed": seed, **extra, **loc_kw}
        if kw["count"] is None:
            kw.pop("count")
        res = locate_piles(sim.cloud, **kw)
        piles = {p.id: p for p in res.piles}
        # measured piles matched to the nearest true pile (ids of a found wharf need not agree)
        near = {p.id: min(truth, key=lambda i, p=p: math.hypot(p.x - truth[i]["x"], p.y - truth[i]["y"]))
                for p in piles.values()}
        pair = {(s.a, s.b): (min(near[s.a], near[s.b]), max(near[s.a], near[s.b])) for s in res.spacings}
        sp_err = [s.distance - tsp[pair[s.a, s.b]] for s in res.spacings if pair[s.a, s.b] in tsp]
        # each spacing's error in its own reported sigmas
        z_in = [abs(s.distance - tsp[pair[s.a, s.b]]) / s.sigma for s in res.spacings
                if pair[s.a, s.b] in tsp and math.isfinite(s.sigma) and s.sigma > 0]
        c_err = [math.hypot(p.x - truth[near[i]]["x"], p.y - truth[near[i]]["y"]) for i, p in piles.items()]
        r_err = [(p.radius_fitted if p.radius_fitted is not None else p.radius) - truth[near[i]]["radius"]
                 for i, p in piles.items()]
        t_err = [abs(p.tilt_deg - truth[near[i]]["tilt_deg"]) for i, p in piles.items()
                 if p.tilt_deg is not None]
        groups_right = all(p.group == truth[near[i]].get("group", 1) for i, p in piles.items())
        rows.append({"config": name, "seed": seed, "method": method, "sp_err": sp_err,
                     "c_err": c_err, "r_err": r_err, "t_err": t_err, "z_in": z_in, "n_found": len(piles),
                     "flagged": sum(bool(p.flags) for p in piles.values()), "groups_right": groups_right,
                     "n_true": len(truth),
                     "methods_used": sorted({p.method for p in piles.values()})})
    return rows


def main() -> None:
    import argparse

    ap = argparse.ArgumentParser(add_help=False)
    ap.add_argument("--ablation", action="store_true")
    known = own_flags(ap)
    if known.ablation:  # the environment reaches the pool's workers however they start
        os.environ[ABLATION_ENV] = "1"
        VARIANTS.update(ABLATION)
    chosen, results = run_study(__doc__, list(CONFIGS), 20, run_one)
    out = []
    for c in chosen:
        for m in [*VARIANTS, BEAM_VARIANT]:
            rs = [r for r in results if r["config"] == c and r["method"] == m]
            if not rs:
                continue
            sp = np.concatenate([r["sp_err"] for r in rs]) * 100
            ce = np.concatenate([r["c_err"] for r in rs]) * 100
            re = np.concatenate([r["r_err"] for r in rs]) * 1000
            te = np.concatenate([r["t_err"] for r in rs]) if any(r["t_err"] for r in rs) else np.array([])
            zi = np.concatenate([r["z_in"] for r in rs]) if rs else np.array([])
            out.append([c, m, len(rs), f"{np.sqrt(np.mean(sp**2)):.2f}", f"{np.abs(sp).max():.2f}",
                        f"{ce.max():.2f}", f"{np.median(re):+.0f}", f"{te.max():.3f}" if len(te) else "-",
                        f"{100 * np.mean(zi <= 2):.0f} %" if len(zi) else "-",
                        f"{100 * np.mean(zi <= 3):.0f} %" if len(zi) else "-",
                        sum(r["flagged"] for r in rs), sum(r["n_true"] - r["n_found"] for r in rs),
                        f"{sum(r['groups_right'] for r in rs)}/{len(rs)}"])
    print(table(["config", "method", "seeds", "spacing RMS cm", "spacing max cm", "centre max cm",
                 "radius err median mm", "tilt max deg", "within 2 sigma", "within 3 sigma", "piles flagged",
                 "piles missed", "jackets right"], out))


if __name__ == "__main__":
    main()
