"""Survey after survey (issue 29): two simulated surveys of one reef field, the second with
units moved and turned, settled, tilted, overturned, removed, scoured round, and one new,
sailed on other lines with other noise and a datum and position offset; each survey's reefs
extracted, then compared (:func:`mbinspect.change.compare_surveys`) against the true change.

Run: ``python benchmarks/study_change.py [--seeds 10] [--configs default,...] [--workers 2]``.

Rows per configuration: the registration's error against the offset applied (and the share
within 2 sigma; the applied offset is not the whole truth: each survey's lines carry their
own vertical offsets, whose mean differs from survey to survey), how the units were matched,
and per kind of change how many were found (the right measure detected) and how many
unchanged units were called changed; the errors of the measures against the truth and the
share of measures within their 95 % level of detection.
"""

from __future__ import annotations

import math
import sys
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import run_study, table  # noqa: E402
from mbinspect.change import compare_surveys  # noqa: E402
from mbinspect.reefs import extract_reefs  # noqa: E402
from mbinspect.simulate import simulate  # noqa: E402
from mbinspect.simulate.resurvey import random_changes, resurvey  # noqa: E402

#: configuration -> (simulate keywords, shift scale: plan m, vertical m)
CONFIGS: dict[str, tuple[dict, tuple[float, float]]] = {
    "default": ({}, (0.5, 0.3)),
    "no-offset": ({}, (0.0, 0.0)),
    "classic": ({"sonar": "classic"}, (0.5, 0.3)),
}

#: What each kind of change must show to count as found.
SHOWN = {"move": "displacement", "settle": "settlement", "tilt": "tilt_change_deg", "overturn": "overturned",
         "scour": "scour_depth"}


def run_one(args: tuple[str, int]) -> list[dict]:
    name, seed = args
    kw, (plan_shift, vert_shift) = CONFIGS[name]
    before = simulate("reef-field", seed=seed, **kw)
    rng = np.random.default_rng(1000 + seed)
    shift = (rng.uniform(-plan_shift, plan_shift), rng.uniform(-plan_shift, plan_shift),
             rng.uniform(-vert_shift, vert_shift))
    changes = random_changes(before.truth, seed=seed, share=0.3)
    after = resurvey(before.truth, changes, seed=seed + 500, shift=shift)
    designs = ",".join(sorted({r["kind"] for r in before.truth["reefs"]}))
    rb = extract_reefs(before.cloud, design=designs, seed=seed)
    ra = extract_reefs(after.cloud, design=designs, seed=seed)
    res = compare_surveys(rb, ra, before.cloud.xyz, after.cloud.xyz)
    kinds = {c.id: _kind(c) for c in changes}
    return [_score(name, seed, res, before.truth, after.truth, shift, kinds)]


def _kind(c) -> str:
    if c.status == "removed":
        return "remove"
    if c.dx or c.dy:
        return "move"
    if c.settlement:
        return "settle"
    if c.orientation:
        return "overturn"
    if c.tilt_deg is not None:
        return "tilt"
    return "scour" if c.scour_depth else "other"


def _nearest(x: float, y: float, reefs: list[dict], reach: float = 1.5) -> int | None:
    d = [(math.hypot(r["x"] - x, r["y"] - y), r["id"]) for r in reefs]
    best = min(d, default=(math.inf, None))
    return best[1] if best[0] <= reach else None


def _score(name, seed, res, tb, ta, shift, kinds) -> dict:
    reg = res.registration
    true = {o["id"]: o for o in ta["change"]["objects"]}
    rows = []
    for o in res.objects:
        ib = None if o.id_before is None else _nearest(o.x_before, o.y_before, tb["reefs"])
        # the after reef's place, carried back by the registration, against the scene's truth
        ia = None if o.id_after is None else _nearest(o.x_after, o.y_after, ta["reefs"])
        rows.append({"status": o.status, "ib": ib, "ia": ia, "detected": o.detected, "values": o.values})
    return {"config": name, "seed": seed, "shift": shift,
            "reg": (reg.dx, reg.dy, reg.dz, reg.sigma_dx, reg.sigma_dy, reg.sigma_dz),
            "rows": rows, "true": true, "kinds": kinds}


def _summary(name: str, rs: list[dict]) -> tuple[list[str], list[str], list[list[str]]]:
    reg = np.array([[*r["reg"], *r["shift"]] for r in rs])
    err = reg[:, :3] - reg[:, 6:9]
    sig = reg[:, 3:6]
    within = np.abs(err) <= 2 * sig
    found: Counter[str] = Counter()
    total: Counter[str] = Counter()
    false_calls, unchanged, right, wrong = 0, 0, 0, 0
    errs: dict[str, list[tuple[float, float]]] = {k: [] for k in ("displacement", "settlement", "scour_depth",
                                                                   "rotation_deg", "tilt_change_deg")}
    for r in rs:
        for k in r["kinds"].values():
            total[k] += 1
        seen_removed = {row["ib"] for row in r["rows"] if row["status"] == "removed"}
        for rid, k in r["kinds"].items():
            if k == "remove" and rid in seen_removed:
                found["remove"] += 1
        for row in r["rows"]:
            if row["ib"] is None or row["ia"] is None:
                continue
            if row["ib"] != row["ia"]:
                wrong += 1
                continue
            right += 1
            t = r["true"].get(row["ib"], {})
            k = r["kinds"].get(row["ib"])
            if k is None:
                unchanged += 1
                false_calls += bool(row["detected"])
            elif k in SHOWN and SHOWN[k] in row["detected"]:
                found[k] += 1
            for m in errs:
                v, lod = row["values"].get(m), row["values"].get(m + "_lod95")
                tilt = t.get("tilt_after", 0) - t.get("tilt_before", 0)
                tv = t.get(m, 0.0 if m != "tilt_change_deg" else tilt)
                if m == "scour_depth" and k not in (None, "scour"):
                    continue
                if None not in (v, lod, tv) and math.isfinite(v) and math.isfinite(lod):
                    errs[m].append((v - tv, lod))
    reg_row = [name, str(len(rs)), *(f"{1000 * math.sqrt(np.mean(err[:, k] ** 2)):.0f}" for k in range(3)),
               *(f"{100 * within[:, k].mean():.0f} %" for k in range(3)),
               *(f"{1000 * np.median(sig[:, k]):.0f}" for k in range(3))]
    det_row = [name, f"{right}", f"{wrong}", *(f"{found[k]}/{total[k]}" for k in
                                                ("move", "settle", "tilt", "overturn", "scour", "remove")),
               f"{false_calls}/{unchanged}"]
    err_rows = []
    for m, e in errs.items():
        if e:
            a = np.array(e)
            err_rows.append([name, m, str(len(a)), f"{math.sqrt(np.mean(a[:, 0] ** 2)):.3f}",
                             f"{np.abs(a[:, 0]).max():.3f}",
                             f"{100 * np.mean(np.abs(a[:, 0]) <= a[:, 1]):.0f} %",
                             f"{np.median(a[:, 1]):.3f}"])
    return reg_row, det_row, err_rows


def main() -> None:
    chosen, results = run_study(__doc__, list(CONFIGS), 10, run_one)
    regs, dets, errs = [], [], []
    for name in chosen:
        rs = [r for r in results if r["config"] == name]
        a, b, c = _summary(name, rs)
        regs.append(a)
        dets.append(b)
        errs += c
    print(table(["config", "seeds", "dx err RMS mm", "dy", "dz", "dx within 2σ", "dy", "dz", "median σ dx mm",
                 "dy", "dz"], regs))
    print()
    print(table(["config", "matched right", "matched wrong", "moved found", "settled", "tilted", "overturned",
                 "scoured", "removed", "unchanged called changed"], dets))
    print()
    print(table(["config", "measure", "n", "error RMS", "max", "within LoD95", "median LoD95"], errs))


if __name__ == "__main__":
    main()
