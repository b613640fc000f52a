"""Reef accuracy study against simulator truth: ours beside the paper's plain method.

Run: ``python benchmarks/study_reefs.py [--seeds 10] [--configs default,...]``. Prints per
configuration and method: TP, FP, FN summed over seeds, correctness, completeness, how many
close (< 1 m) or touching pairs had both reefs found separately, the height and centre error
max, and the footprint area error (mean, share of reefs within 10 %, max).

Methods: ``ours`` (free-form footprints), ``ours + design`` (the same, with each reef fitted
by the deployed designs, named as a surveyor would: the kinds of the simulated groups, at
scale 1 even where the reefs were built larger) and ``paper`` (radius filter, one plane,
Euclidean clusters).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import run_study, table  # noqa: E402
from mbinspect.reefs import extract_reefs  # noqa: E402
from mbinspect.simulate import simulate  # noqa: E402

CONFIGS: dict[str, dict] = {
    # the default sonar is `shallow`, calibrated against the real files (benchmarks/real_noise.py)
    "default": {},
    # the idealised sonar of the first studies, kept for comparison
    "classic": {"sonar": "classic"},
    "slope+sand-waves": {"slope_deg": 2.0, "sand_wave_amplitude": 0.4, "sand_wave_length": 25.0},
    "single+hollow": {"groups": "cross1,hollow,cross1,hollow"},
    "touching": {"touching_pairs": 6, "close_pairs": 6},
    "distractors": {"boulders": 25, "debris": 12},
    "noise-x2": {"noise_scale": 2.0},
    "rough-shore": {"shore_width": 30.0},
    "dense-pings": {"ping_spacing": 0.2},
    "as-built+8%": {"reef_scale": 1.08},
    # issue 13: 20 rounded rocks of reef size among 75 reefs at 25 m, reefs sunk 0-0.5 m
    "rocky": {"groups": "cross2,hollow,triangle", "seabed": -25.0, "rocks": 20, "burial_max": 0.5},
    # the same with solid 2 m cubes: flat tops and vertical walls that no shape test may take for rocks
    "rocky+cubes": {"groups": "cross2,cube,hollow", "seabed": -25.0, "rocks": 20, "burial_max": 0.5},
    "buried": {"burial_max": 0.6},
    "sand-waves-2m": {"sand_wave_amplitude": 1.0, "sand_wave_length": 40.0},
    "strips+-5cm": {"line_offset_sigma": 0.05, "refraction_sigma_deg": 0.05},
    # issue 28: the beam as a cone, the makers' detection (amplitude near nadir, phase outside)
    "beam-0.5": {"beam_across_deg": 0.5},
    "beam-1": {"beam_across_deg": 1.0},
    "beam-2": {"beam_across_deg": 2.0},
    "beam-1-leading-edge": {"beam_across_deg": 1.0, "detection": "leading-edge"},
    # the same surveys, the reef chain told the beam (`beam_correction`: the bloom taken off)
    "beam-0.5-told": {"beam_across_deg": 0.5},
    "beam-1-told": {"beam_across_deg": 1.0},
    "beam-2-told": {"beam_across_deg": 2.0},
    "beam-1-leading-edge-told": {"beam_across_deg": 1.0, "detection": "leading-edge"},
    # touching and close pairs, and rocks among cubes, through 1° cones (issue 28, item 4)
    "touching-beam-1": {"touching_pairs": 6, "close_pairs": 6, "beam_across_deg": 1.0},
    "touching-beam-1-told": {"touching_pairs": 6, "close_pairs": 6, "beam_across_deg": 1.0},
    "rocky+cubes-beam-1": {"groups": "cross2,cube,hollow", "seabed": -25.0, "rocks": 20, "burial_max": 0.5,
                           "beam_across_deg": 1.0},
    "rocky+cubes-beam-1-told": {"groups": "cross2,cube,hollow", "seabed": -25.0, "rocks": 20,
                                "burial_max": 0.5, "beam_across_deg": 1.0},
}
METHODS = (("local", None), ("local", "design"), ("paper", None))
NAMES = {("local", None): "ours", ("local", "design"): "ours + design", ("paper", None): "paper"}


def run_one(args: tuple[str, int]) -> list[dict]:
    name, seed = args
    sim = simulate("reef-field", seed=seed, **CONFIGS[name])
    told = {"beam_correction": True, "beam_width_deg": CONFIGS[name]["beam_across_deg"],
            "detection": CONFIGS[name].get("detection", "auto")} if name.endswith("-told") else {}
    truth = sim.truth["reefs"]
    ref = (np.array([[r["x"], r["y"]] for r in truth]), tuple(r["id"] for r in truth))
    kinds = CONFIGS[name].get("groups", "cross2,cross2,cross2,cross1").split(",")
    design = ",".join(sorted(set(kinds)))
    rows = []
    for method, use in METHODS:
        res = extract_reefs(sim.cloud, method=method, reference=ref, seed=seed,
                            design=design if use else None, **(told if method == "local" else {}))
        ev = res.evaluation
        assert ev is not None
        found = {truth[j]["id"]: i for i, j, _ in ev.matches}
        pairs = sim.truth["close_pairs"]
        both = sum(p["a"] in found and p["b"] in found for p in pairs)
        hs = [res.reefs[i].height - truth[j]["height"] for i, j, _ in ev.matches]
        h = [abs(x) for x in hs]
        a = [res.reefs[i].area / truth[j]["area"] - 1 for i, j, _ in ev.matches]
        rows.append({"config": name, "method": NAMES[method, use], "tp": ev.tp, "fp": ev.fp, "fn": ev.fn,
                     "pairs": len(pairs), "both": both, "h": h, "hs": hs, "c": list(ev.position_errors()),
                     "a": a})
    return rows


def main() -> None:
    chosen, results = run_study(__doc__, list(CONFIGS), 10, run_one)
    out = []
    for c in chosen:
        for m in NAMES.values():
            rs = [r for r in results if r["config"] == c and r["method"] == m]
            tp, fp, fn = (sum(r[k] for r in rs) for k in ("tp", "fp", "fn"))
            h = np.concatenate([r["h"] for r in rs])
            hs = np.concatenate([r["hs"] for r in rs])
            ce = np.concatenate([r["c"] for r in rs])
            a = np.concatenate([r["a"] for r in rs])
            out.append([c, m, len(rs), tp, fp, fn,
                        f"{100 * tp / max(tp + fp, 1):.2f}", f"{100 * tp / max(tp + fn, 1):.2f}",
                        f"{sum(r['both'] for r in rs)}/{sum(r['pairs'] for r in rs)}",
                        f"{1000 * hs.mean():+.0f}", f"{h.max():.3f}", f"{ce.max():.2f}",
                        f"{int(np.sum(ce <= 0.3))}/{len(ce)}",
                        f"{100 * a.mean():+.1f} %", f"{int(np.sum(np.abs(a) <= 0.1))}/{len(a)}",
                        f"{100 * np.abs(a).max():.0f} %"])
    print(table(["config", "method", "seeds", "TP", "FP", "FN", "correct %", "complete %",
                 "close pairs both found", "height err mean mm", "height err max m", "centre err max m",
                 "centre within 0.3 m",
                 "area err mean",
                 "area within 10 %", "area err max"], out))


if __name__ == "__main__":
    main()
