"""Piles between surveys (issue 29): a simulated jacket or wharf surveyed twice, the second
time with about half its piles changed one way each (settled 2-10 cm, leaning 1-4° more,
scoured round 0.3-1.0 m deep), on other lines, with other noise and a datum and position
offset; each survey's piles located, then compared
(:func:`mbinspect.change.compare_surveys`) against the true change.

Run: ``python benchmarks/study_change_piles.py [--seeds 10] [--configs jacket,...] [--workers 2]``.

Rows per configuration: the registration's error (plan against the offset applied; the
vertical error is not scored here, each survey's lines realising their own datum); per kind
of change how many were found (its measure detected) and how many unchanged piles were
called changed; the errors of the measures against the truth and the share within their
95 % level of detection.
"""

from __future__ import annotations

import math
import sys
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import run_study, table, unborne  # noqa: E402
from mbinspect.change import compare_surveys  # noqa: E402
from mbinspect.piles import locate_piles  # noqa: E402
from mbinspect.piles.design import Design  # noqa: E402
from mbinspect.simulate import simulate  # noqa: E402
from mbinspect.simulate.resurvey import random_pile_changes, resurvey  # noqa: E402

#: configuration -> (preset, simulate keywords, pile count, shift scale: plan m, vertical m)
CONFIGS: dict[str, tuple[str, dict, int, tuple[float, float]]] = {
    "jacket": ("jacket", {}, 4, (0.3, 0.2)),
    "jacket-classic": ("jacket", {"sonar": "classic"}, 4, (0.3, 0.2)),
    "wharf": ("wharf", {}, 0, (0.3, 0.2)),
}

#: What each kind of change must show to count as found.
SHOWN = {"settle": "settlement", "tilt": "tilt_change_deg", "scour": "scour_depth"}
MEASURES = ("displacement", "settlement", "tilt_change_deg", "scour_depth")


def _kind(c) -> str:
    return "settle" if c.settlement else ("tilt" if c.tilt_deg is not None else "scour")


def run_one(args: tuple[str, int]) -> list[dict]:
    name, seed = args
    preset, kw, count, (ps, vs) = CONFIGS[name]
    before = simulate(preset, seed=seed, **kw)
    rng = np.random.default_rng(2000 + seed)
    shift = (rng.uniform(-ps, ps), rng.uniform(-ps, ps), rng.uniform(-vs, vs))
    changes = random_pile_changes(before.truth, seed=seed)
    after = resurvey(before.truth, changes, seed=seed + 700, shift=shift)
    piles = before.truth["piles"]
    design = Design(positions={p["id"]: (p["x"], p["y"]) for p in piles},
                    groups={p["id"]: p.get("group", 1) for p in piles})
    n = count or len(piles)
    radius = float(piles[0]["radius"])
    pb = locate_piles(before.cloud, radius=radius, count=n, design=design, seed=seed)
    pa = locate_piles(after.cloud, radius=radius, count=n, design=design, seed=seed)
    res = compare_surveys(pb, pa, before.cloud.xyz, after.cloud.xyz, before_fields=before.cloud.fields,
                          after_fields=after.cloud.fields)
    true = {o["id"]: o for o in after.truth["change"]["objects"]}
    kinds = {c.id: _kind(c) for c in changes}
    rows = [{"id": o.id_before, "status": o.status, "detected": o.detected, "values": o.values,
             "right": o.id_before is not None and o.id_before == o.id_after}
            for o in res.objects]
    g = res.registration
    return [{"config": name, "seed": seed, "reg": (g.dx - shift[0], g.dy - shift[1], g.sigma_dx, g.sigma_dy),
             "rows": rows, "true": true, "kinds": kinds}]


def _summary(name: str, rs: list[dict]) -> tuple[list[str], list[list[str]]]:
    reg = np.array([r["reg"] for r in rs])
    found: Counter[str] = Counter()
    total: Counter[str] = Counter()
    false_calls, unchanged, lost = 0, 0, 0
    why: Counter[str] = Counter()
    errs: dict[str, list[tuple[float, float]]] = {m: [] for m in MEASURES}
    for r in rs:
        for row in r["rows"]:
            if not row["right"]:
                lost += 1
                continue
            k, t = r["kinds"].get(row["id"]), r["true"][row["id"]]
            if k == "scour" and t["scour_depth"] < 0.1:
                k = "faint scour"
            if k is None:
                unchanged += 1
                wrong_calls = unborne(row["detected"], row["values"], t)
                false_calls += bool(wrong_calls)
                why.update(wrong_calls)
            else:
                total[k] += 1
                found[k] += SHOWN.get(k, "scour_depth") in row["detected"]
            for m in MEASURES:
                v, lod = row["values"].get(m), row["values"].get(m + "_lod95")
                if None not in (v, lod) and math.isfinite(v) and math.isfinite(lod):
                    errs[m].append((v - t[m], lod))
    det = [name, str(len(rs)), f"{1000 * math.sqrt(np.mean(reg[:, 0] ** 2 + reg[:, 1] ** 2)):.0f}",
           f"{100 * np.mean((abs(reg[:, 0]) <= 2 * reg[:, 2]) & (abs(reg[:, 1]) <= 2 * reg[:, 3])):.0f} %",
           str(lost), *(f"{found[k]}/{total[k]}" for k in ("settle", "tilt", "scour", "faint scour")),
           f"{false_calls}/{unchanged}", ", ".join(f"{k} {v}" for k, v in why.most_common())]
    rows = []
    for m, e in errs.items():
        if e:
            a = np.array(e)
            rows.append([name, m, str(len(a)), f"{math.sqrt(np.mean(a[:, 0] ** 2)):.3f}",
                         f"{np.abs(a[:, 0]).max():.3f}", f"{100 * np.mean(np.abs(a[:, 0]) <= a[:, 1]):.0f} %",
                         f"{np.median(a[:, 1]):.3f}"])
    return det, rows


def main() -> None:
    chosen, results = run_study(__doc__, list(CONFIGS), 10, run_one)
    dets, errs = [], []
    for name in chosen:
        a, b = _summary(name, [r for r in results if r["config"] == name])
        dets.append(a)
        errs += b
    print(table(["config", "seeds", "plan reg err RMS mm", "dx, dy within 2σ", "piles unmatched",
                 "settled found", "leaning found", "scoured found", "faint scour (< 0.1 m)",
                 "unchanged called changed", "by"],
                dets))
    print()
    print(table(["config", "measure", "n", "error RMS", "max", "within LoD95", "median LoD95"], errs))


if __name__ == "__main__":
    main()
