"""Piles between surveys (issue 29): a simulated jacket or wharf surveyed twice, the second
time with about half its piles changed one way each (settled 2-10 cm, leaning 1-4° more,
scoured round 0.3-1.0 m deep), on other lines, with other noise and a datum and position
offset; each survey's piles located, then compared
(:func:`mbinspect.change.compare_surveys`) against the true change.

Run: ``python benchmarks/study_change_piles.py [--seeds 10] [--configs jacket,...] [--workers 2]``;
``--real [--placements 3]``: four piles injected into the real files instead (:func:`_real`).

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
    # both surveys through 1° cones (issue 28), the piles located told the beam
    "jacket-beam-1": ("jacket", {"beam_across_deg": 1.0}, 4, (0.3, 0.2)),
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
    # the design's rakes as a design file gives them (the wharf's raked rows)
    tilts = {r["id"]: (r["tilt_deg"], r["tilt_azimuth_deg"]) for r in before.truth.get("design", [])
             if r.get("tilt_deg")}
    design = Design(positions={p["id"]: (p["x"], p["y"]) for p in piles},
                    groups={p["id"]: p.get("group", 1) for p in piles}, tilts=tilts)
    n = count or len(piles)
    radius = float(piles[0]["radius"])
    told = {"beam_width_deg": kw["beam_across_deg"]} if "beam_across_deg" in kw else {}
    pb = locate_piles(before.cloud, radius=radius, count=n, design=design, seed=seed, **told)
    pa = locate_piles(after.cloud, radius=radius, count=n, design=design, seed=seed, **told)
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


#: The real study's second epoch: pile 1 settled (m), a pit dug round pile 2 (depth, radius m),
#: piles 3 and 4 as they were; and the offset of its soundings (m).
REAL_SETTLE, REAL_PIT, REAL_SHIFT = 0.06, (0.5, 3.0), (0.2, -0.1, 0.08)


def _real(placements: int, only: str = "") -> None:
    """Four piles (a jacket's square, as ``study_inject`` places them) injected into each real
    file that holds a square, its pings split in two (even and odd): two surveys of one place
    with the real seabed and the real noise. The second epoch has pile 1 settled
    :data:`REAL_SETTLE`, a scour pit (``inject``'s ``pits``) dug round pile 2 into the real
    seabed, and its soundings offset by :data:`REAL_SHIFT`. Scored: the registration against
    the offset (the halves share their lines, so the offset put in is the one they realise),
    the settlement and the scour depth against the truth (:func:`mbinspect.scour.pit_scour` on
    the injected circles), each within its LoD95, and the unchanged piles called changed."""
    from dataclasses import replace

    from mbinspect.inject import inject
    from mbinspect.io import PointCloud
    from mbinspect.scour import pit_scour
    from study_inject import RADIUS, _jacket, compared, paired_halves

    shift = np.asarray(REAL_SHIFT)
    t = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    rows = []
    for name, cloud, (cx, cy, side), halves in paired_halves(only):
        tally: Counter[str] = Counter()
        by: Counter[str] = Counter()
        regs, errs = [], {"settlement": [], "scour_depth": [], "scour (unchanged)": []}
        for k in range(placements):
            piles = _jacket(cx, cy, side, np.random.default_rng(k))
            pit = (piles[1].x, piles[1].y, *REAL_PIT)
            design = Design(positions={p.id: (p.x, p.y) for p in piles}, groups={p.id: 1 for p in piles})
            def step(piles=piles, pit=pit, design=design, halves=halves) -> tuple:
                ib = inject(halves[0].xyz, halves[0].fields, piles=piles)
                # the same tops in both epochs (a height would stand on each half's own seabed)
                top = {p["id"]: p["z"] for p in ib.truth["piles"]}
                after = [replace(p, top=top[p.id] - (REAL_SETTLE if p.id == 1 else 0.0), height=None)
                         for p in piles]
                ia = inject(halves[1].xyz, halves[1].fields, piles=after, pits=[pit])
                a_xyz = ia.xyz + shift
                pb = locate_piles(PointCloud(ib.xyz, dict(halves[0].fields)), radius=RADIUS, count=4,
                                  design=design)
                pa = locate_piles(PointCloud(a_xyz, dict(halves[1].fields)), radius=RADIUS, count=4,
                                  design=Design(positions={i: (x + shift[0], y + shift[1])
                                                           for i, (x, y) in design.positions.items()},
                                                groups=design.groups))
                return ib, ia, compare_surveys(pb, pa, ib.xyz, a_xyz, before_fields=halves[0].fields,
                                               after_fields=halves[1].fields)

            if (done := compared(tally, step)) is None:
                continue
            ib, ia, res = done
            g = res.registration
            regs.append((g.dx - shift[0], g.dy - shift[1], g.dz - shift[2], g.sigma_dx, g.sigma_dy,
                         g.sigma_dz))
            circles = {p.id: np.column_stack([p.x + RADIUS * np.sin(t), p.y + RADIUS * np.cos(t)])
                       for p in piles}
            tops_b = {p["id"]: p["z"] for p in ib.truth["piles"]}
            tops_a = {p["id"]: p["z"] for p in ia.truth["piles"]}
            for o in res.objects:
                if o.id_before is None or o.id_before != o.id_after:
                    tally["not matched"] += 1
                    continue
                i, v = o.id_before, o.values
                p = next(q for q in piles if q.id == i)
                scour = pit_scour([pit], circles[i], (p.x, p.y),
                                  others=[c for j, c in circles.items() if j != i])["scour_depth"]
                errs["settlement"].append((v["settlement"] - (tops_b[i] - tops_a[i]), v["settlement_lod95"]))
                errs["scour_depth" if i == 2 else "scour (unchanged)"].append(
                    (v["scour_depth"] - scour, v["scour_depth_lod95"]))
                if i == 1:
                    tally["settled found"] += "settlement" in o.detected
                elif i == 2:
                    tally["scoured found"] += "scour_depth" in o.detected
                else:
                    tally["unchanged"] += 1
                    lod = v["scour_depth_lod95"]
                    wrong = [m for m in o.detected if m != "scour_depth" or scour < lod / 2]
                    tally["unchanged called changed"] += bool(wrong)
                    by.update(wrong)
        r = np.array(regs).reshape(-1, 6)
        run = len(regs)

        def cell(m: str, errs: dict = errs) -> str:
            e = np.array(errs[m]).reshape(-1, 2)
            e = e[np.isfinite(e).all(axis=1)]
            if not len(e):
                return "-"
            return (f"{1000 * math.sqrt(np.mean(e[:, 0] ** 2)):.0f} / {1000 * np.abs(e[:, 0]).max():.0f}, "
                    f"{100 * np.mean(np.abs(e[:, 0]) <= e[:, 1]):.0f} % "
                    f"(LoD95 {1000 * np.median(e[:, 1]):.0f})")

        rows.append([name[:34], f"{run}/{placements} ({len(cloud.xyz) // 1000} k)",
                     f"{1000 * math.sqrt(np.mean(r[:, 0] ** 2 + r[:, 1] ** 2)):.0f}" if run else "-",
                     f"{1000 * math.sqrt(np.mean(r[:, 2] ** 2)):.0f}" if run else "-",
                     f"{100 * np.mean((abs(r[:, 0]) <= 2 * r[:, 3]) & (abs(r[:, 1]) <= 2 * r[:, 4])):.0f} %"
                     if run else "-",
                     f"{100 * np.mean(abs(r[:, 2]) <= 2 * r[:, 5]):.0f} %" if run else "-",
                     f"{tally['settled found']}/{run}", cell("settlement"),
                     f"{tally['scoured found']}/{run}", cell("scour_depth"), cell("scour (unchanged)"),
                     f"{tally['unchanged called changed']}/{tally['unchanged']}",
                     ", ".join(f"{k} {v}" for k, v in by.most_common()),
                     "; ".join(f"{k} ×{v}" for k, v in tally.items() if k.startswith(("stopped", "not")))])
    print(table(["file (pings split even/odd)", "placements run", "plan reg err RMS mm", "dz err RMS mm",
                 "dx, dy within 2σ", "dz within 2σ", f"settled {REAL_SETTLE} m found",
                 "settlement err RMS / max mm, within LoD95 (median)", f"scoured {REAL_PIT[0]} m found",
                 "scour depth err RMS / max mm, within LoD95 (median)", "scour on the unchanged: the same",
                 "unchanged called changed", "by", "left out"], rows))


def main() -> None:
    import argparse

    from _common import own_flags

    ap = argparse.ArgumentParser(add_help=False)
    ap.add_argument("--real", action="store_true")
    ap.add_argument("--placements", type=int, default=3)
    ap.add_argument("--only", default="", help="the real files whose name holds this")
    known = own_flags(ap)
    if known.real:
        _real(known.placements, known.only)
        return
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
