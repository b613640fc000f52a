"""Survey after survey (issue 29): two simulated surveys of one reef field, the second with
units moved and turned, settled, tilted, overturned, removed, scoured round, and one new,
sailed on other lines with other noise and a datum and position offset; each survey's reefs
extracted, then compared (:func:`mbinspect.change.compare_surveys`) against the true change.

Run: ``python benchmarks/study_change.py [--seeds 10] [--configs default,...] [--workers 2]``;
``--real [--placements 3] [--ring 6] [--beam DEG]``: reefs injected into the real files instead
(:func:`_real`; ``--ring``: unchanged units round the four changed ones, where the file covers
them; ``--beam``: injected through cones that wide, both reef chains told the beam).

Rows per configuration: the registration's error against the offset applied in plan and,
in height, against the offset the two surveys realise (the one applied plus the difference
of the surveys' own datums: each line keeps its vertical offset, and a survey's seabed
soundings sit at their mix over the true seabed), with the share within 2 sigma; how the units were matched,
and per kind of change how many were found (the right measure detected) and how many
unchanged units were called changed (a change their truth does not bear out: a
neighbour's pit reaching a unit's rings is its scour too); the errors of the measures
against the truth and the
share of measures within their 95 % level of detection.
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

DESIGNS = "cross2,cross1,hollow,triangle"
from mbinspect.reefs import extract_reefs  # noqa: E402
from mbinspect.simulate import simulate  # noqa: E402
from mbinspect.simulate.resurvey import random_changes, resurvey  # noqa: E402

#: configuration -> (simulate keywords, shift scale: plan m, vertical m, compare_surveys options)
CONFIGS: dict[str, tuple[dict, tuple[float, float], dict]] = {
    "default": ({}, (0.5, 0.3), {}),
    "no-offset": ({}, (0.0, 0.0), {}),
    "classic": ({"sonar": "classic"}, (0.5, 0.3), {}),
    "seabed-only": ({}, (0.5, 0.3), {"tie_objects": False}),
    # both surveys through 1° cones (issue 28), the reef chain told the beam
    "beam-1-told": ({"beam_across_deg": 1.0}, (0.5, 0.3), {}),
    # the same with pings 0.25 m apart, closer than a cone is wide at 17 m (0.30 m): every
    # seabed point heard by some ping (issue 30's placement limit at the preset's 0.55 m)
    "beam-1-told-0.25": ({"beam_across_deg": 1.0, "ping_spacing": 0.25}, (0.5, 0.3), {}),
}

#: What each kind of change must show to count as found.
#: A true scour shallower than this (m) beyond its unit is "faint": not counted as one to find.
FAINT = 0.1

SHOWN = {"faint scour": "scour_depth", "move": "displacement", "settle": "settlement",
         "tilt": "tilt_change_deg", "overturn": "overturned", "scour": "scour_depth"}


def run_one(args: tuple[str, int]) -> list[dict]:
    name, seed = args
    kw, (plan_shift, vert_shift), change_kw = CONFIGS[name]
    before = simulate("reef-field", seed=seed, **kw)
    rng = np.random.default_rng(1000 + seed)
    shift = (rng.uniform(-plan_shift, plan_shift), rng.uniform(-plan_shift, plan_shift),
             rng.uniform(-vert_shift, vert_shift))
    changes = random_changes(before.truth, seed=seed, share=0.3)
    after = resurvey(before.truth, changes, seed=seed + 500, shift=shift)
    designs = ",".join(sorted({r["kind"] for r in before.truth["reefs"]}))
    width = kw.get("beam_across_deg")
    told = {"beam_correction": True, "beam_width_deg": width} if width else {}
    rb = extract_reefs(before.cloud, design=designs, seed=seed, **told)
    ra = extract_reefs(after.cloud, design=designs, seed=seed, **told)
    res = compare_surveys(rb, ra, before.cloud.xyz, after.cloud.xyz, before_fields=before.cloud.fields,
                          after_fields=after.cloud.fields, **change_kw)
    kinds = {c.id: _kind(c) for c in changes}
    # a pit mostly under its unit leaves a faint scour beyond it: counted apart
    true = {o["id"]: o for o in after.truth["change"]["objects"]}
    kinds = {i: ("faint scour" if k == "scour" and true[i].get("scour_depth", 0) < FAINT else k)
             for i, k in kinds.items()}
    out = _score(name, seed, res, before.truth, after.truth, shift, kinds)
    out["realised_dz"] = shift[2] + _datum(after, shift) - _datum(before, (0.0, 0.0, 0.0))
    return [out]


def _datum(sim, shift) -> float:
    """The vertical offset a survey's lines realise: the median of its seabed soundings'
    heights over the true seabed (each line keeps its own offset; their mix is the survey's
    datum), away from the scour pits, on the beams the registration reads (within
    ``inner_angle_deg`` of nadir: a line's sound-speed error bends its outer beams up or down,
    and a datum taken on every beam carried their mix, 2.8 mm RMS from the registration's
    with 80 % within its 2 sigma where the inner beams' gave 2.0 mm and 100 %, 10 seeds)."""
    from mbinspect.change.options import ChangeOptions

    ox, oy = sim.scene.origin
    sea = (sim.labels == 0) & (np.abs(np.asarray(sim.cloud.fields["beam_angle"], np.float64))
                               <= ChangeOptions().inner_angle_deg)
    xyz = sim.cloud.xyz[sea] - np.asarray(shift)
    x, y = xyz[:, 0] - ox, xyz[:, 1] - oy
    far = np.ones(len(x), bool)
    for px, py, _, r in sim.scene.seabed.pits:
        far &= np.hypot(x - px, y - py) > r
    return float(np.median(xyz[far, 2] - sim.scene.seabed.elevation(x[far], y[far])))


def _kind(c) -> str:
    if c.status == "removed":
        return "remove"
    if c.status == "new":
        return "new"
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
    reg = np.array([[*r["reg"], *r["shift"][:2], r["realised_dz"]] for r in rs])
    err = reg[:, :3] - reg[:, 6:9]
    sig = reg[:, 3:6]
    within = np.abs(err) <= 2 * sig
    found: Counter[str] = Counter()
    total: Counter[str] = Counter()
    false_calls, unchanged, right, wrong = 0, 0, 0, 0
    why: Counter[str] = Counter()
    measures = ("displacement", "settlement", "height_change", "scour_depth", "rotation_deg",
                "tilt_change_deg")
    errs: dict[str, list[tuple[float, float]]] = {k: [] for k in measures}
    for r in rs:
        for k in r["kinds"].values():
            total[k] += 1
        seen = {row["ib"] for row in r["rows"] if row["status"] == "removed"}
        seen_new = {row["ia"] for row in r["rows"] if row["status"] == "new"}
        for rid, k in r["kinds"].items():
            found["remove"] += k == "remove" and rid in seen
            found["new"] += k == "new" and rid in seen_new
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
                wrong_calls = unborne(row["detected"], row["values"], t)
                false_calls += bool(wrong_calls)
                why.update(wrong_calls)
            elif k in SHOWN and SHOWN[k] in row["detected"]:
                found[k] += 1
            for m in errs:
                v, lod = row["values"].get(m), row["values"].get(m + "_lod95")
                tilt = t.get("tilt_after", 0) - t.get("tilt_before", 0)
                tv = t.get(m, 0.0 if m != "tilt_change_deg" else tilt)
                if m == "height_change":
                    tv = t.get("height_after", math.nan) - t.get("height_before", math.nan)
                if m == "scour_depth" and k not in (None, "scour", "faint scour"):
                    continue
                if None not in (v, lod, tv) and math.isfinite(v) and math.isfinite(lod) and math.isfinite(tv):
                    errs[m].append((v - tv, lod))
    reg_row = [name, str(len(rs)), *(f"{1000 * math.sqrt(np.mean(err[:, k] ** 2)):.0f}" for k in range(3)),
               *(f"{100 * within[:, k].mean():.0f} %" for k in range(3)),
               *(f"{1000 * np.median(sig[:, k]):.0f}" for k in range(3))]
    det_row = [name, f"{right}", f"{wrong}", *(f"{found[k]}/{total[k]}" for k in
                                                ("move", "settle", "tilt", "overturn", "scour",
                                                 "faint scour", "remove", "new")),
               f"{false_calls}/{unchanged}", ", ".join(f"{k} {v}" for k, v in why.most_common())]
    err_rows = []
    for m, e in errs.items():
        if e:
            a = np.array(e)
            err_rows.append([name, m, str(len(a)), f"{math.sqrt(np.mean(a[:, 0] ** 2)):.3f}",
                             f"{np.abs(a[:, 0]).max():.3f}",
                             f"{100 * np.mean(np.abs(a[:, 0]) <= a[:, 1]):.0f} %",
                             f"{np.median(a[:, 1]):.3f}"])
    return reg_row, det_row, err_rows


def _height_by_kind(name: str, rs: list[dict]) -> list[list[str]]:
    """The exposed height change's errors per kind of change (the unchanged have no truth of it)."""
    errs: dict[str, list[tuple[float, float]]] = {}
    for r in rs:
        for row in r["rows"]:
            if row["ib"] is None or row["ib"] != row["ia"]:
                continue
            t, v = r["true"].get(row["ib"], {}), row["values"]
            tv = t.get("height_after", math.nan) - t.get("height_before", math.nan)
            val, lod = v.get("height_change"), v.get("height_change_lod95")
            if None not in (val, lod) and all(map(math.isfinite, (val, lod, tv))):
                errs.setdefault(r["kinds"].get(row["ib"]) or "none", []).append((val - tv, lod))
    return [[name, k, str(len(e)), f"{math.sqrt(np.mean(np.square(np.array(e)[:, 0]))):.3f}",
             f"{np.abs(np.array(e)[:, 0]).max():.3f}",
             f"{100 * np.mean(np.abs(np.array(e)[:, 0]) <= np.array(e)[:, 1]):.0f} %"]
            for k, e in sorted(errs.items())]


def _height_cell(heights: list[tuple[float, float]]) -> str:
    """The height change's errors: RMS and max (mm) and the share within the LoD95."""
    if not heights:
        return "-"
    e = np.array(heights)
    return (f"{1000 * math.sqrt(np.mean(e[:, 0] ** 2)):.0f} / {1000 * np.abs(e[:, 0]).max():.0f}, "
            f"{100 * np.mean(np.abs(e[:, 0]) <= e[:, 1]):.0f} %")


#: The changes made to the injected square on a real background: unit index -> (what, InjectedReef fields).
REAL_CHANGES = {0: ("move", {"dx": 0.8, "turn": 15.0}), 1: ("settle", {"burial": 0.25}),
                2: ("overturn", {"orientation": "on its side"}), 3: ("none", {})}


def _ring(cloud, square: list, n: int, rng: np.random.Generator) -> list:
    """``n`` more units, unchanged, on a ring round the square (radius 2.2 times its half
    diagonal, at least 8 m), those whose place the soundings cover (within the 2-98 %
    extents): enough units that stay for the registration to be refined on them."""
    from mbinspect.inject import InjectedReef
    from study_inject import REEFS

    if n == 0 or len(square) < 4:
        return []
    centre = np.mean([[u.x, u.y] for u in square], axis=0)
    radius = max(8.0, 2.2 * max(math.hypot(u.x - centre[0], u.y - centre[1]) for u in square))
    lo, hi = np.percentile(cloud.xyz[:, :2], [2, 98], axis=0)
    turn = rng.uniform(0, 2 * math.pi)
    out = []
    for j in range(n):
        a = turn + 2 * math.pi * j / n
        x, y = centre[0] + radius * math.sin(a), centre[1] + radius * math.cos(a)
        if lo[0] + 2 < x < hi[0] - 2 and lo[1] + 2 < y < hi[1] - 2:
            kind, scale = REEFS[j % len(REEFS)]
            out.append(InjectedReef(len(square) + len(out) + 1, x, y, kind,
                                    bearing_deg=float(rng.uniform(0, 360)), scale=scale))
    return out


def _real(placements: int, ring: int = 6, beam_deg: float = 0.0) -> None:
    """Reefs injected into each real file that holds a square of them, the file's pings
    split in two (even and odd): two surveys of one place with the real seabed and the real
    noise, each epoch's noise from other pings of the same lines. No public pair of real
    surveys of one place holds objects; this is the file against itself with its noise
    resampled by the pings. The second epoch's units changed as :data:`REAL_CHANGES` says,
    and its soundings offset by (0.2, -0.1, 0.08) m; ``ring`` more units round them, unchanged
    (:func:`_ring`, where the file covers them). With ``beam_deg``, every unit is injected
    through cones that wide and both epochs' reef chains are told the beam."""
    from dataclasses import replace

    from mbinspect.beam import Beam
    from mbinspect.inject import inject
    from mbinspect.io import PointCloud
    from study_inject import CONTRAST_DB, _reef_square, compared, paired_halves

    beam = Beam(beam_across_deg=beam_deg, detection="auto") if beam_deg > 0 else None
    told = {"beam_correction": True, "beam_width_deg": beam_deg, "detection": "auto",
            "beam_contrast_db": CONTRAST_DB} if beam else {}

    shift = np.array([0.2, -0.1, 0.08])
    rows = []
    for name, cloud, (cx, cy, side), halves in paired_halves():
        tally: Counter[str] = Counter()
        regs, errs, heights = [], [], []
        for k in range(placements):
            square = _reef_square(cx, cy, side, np.random.default_rng(k))
            square += _ring(cloud, square, ring, np.random.default_rng(100 + k))
            changed = []
            for i, u in enumerate(square):
                what, how = REAL_CHANGES.get(i, ("none", {}))
                if what == "move":
                    a = np.random.default_rng(k).uniform(0, 2 * math.pi)
                    u2 = replace(u, x=u.x + how["dx"] * math.sin(a), y=u.y + how["dx"] * math.cos(a),
                                 bearing_deg=u.bearing_deg + how["turn"])
                elif what == "settle":
                    u2 = replace(u, burial=u.burial + how["burial"])
                elif what == "overturn":
                    u2 = replace(u, orientation=how["orientation"])
                else:
                    u2 = u
                changed.append(u2)
            def step(square=square, changed=changed, halves=halves) -> tuple:
                ib = inject(halves[0].xyz, halves[0].fields, reefs=square, beam=beam)
                ia = inject(halves[1].xyz, halves[1].fields, reefs=changed, beam=beam)
                a_xyz = ia.xyz + shift
                rb = extract_reefs(PointCloud(ib.xyz, dict(halves[0].fields)), design=DESIGNS,
                                   design_scale_tolerance=0.35, **told)
                ra = extract_reefs(PointCloud(a_xyz, dict(halves[1].fields)), design=DESIGNS,
                                   design_scale_tolerance=0.35, **told)
                return ib, compare_surveys(rb, ra, ib.xyz, a_xyz, before_fields=halves[0].fields,
                                           after_fields=halves[1].fields)

            if (done := compared(tally, step)) is None:
                continue
            ib, res = done
            g = res.registration
            regs.append((g.dx - shift[0], g.dy - shift[1], g.dz - shift[2], g.sigma_dx, g.sigma_dz,
                         g.sigma_dy, g.ties))
            truth_b = ib.truth["reefs"]
            for i in range(len(square)):
                what = REAL_CHANGES.get(i, ("none", {}))[0]
                tally["units"] += 1
                tx, ty = truth_b[i]["x"], truth_b[i]["y"]
                o = next((o for o in res.objects if o.id_before is not None
                          and math.hypot(o.x_before - tx, o.y_before - ty) < 1.0), None)
                if o is None:
                    tally["not found before"] += 1
                    continue
                shown = {"move": "displacement", "settle": "settlement", "overturn": "overturned"}.get(what)
                if what == "none":
                    tally["unchanged called changed"] += o.status == "changed"
                    tally["unchanged"] += 1
                elif o.status in ("removed", "new"):
                    tally[f"{what}: not matched"] += 1
                else:
                    tally[f"{what}: found"] += shown in o.detected
                    tally[f"{what}: n"] += 1
                if what == "move" and o.status == "changed":
                    errs.append(o.values["displacement"] - 0.8)
                if what in ("none", "settle") and o.status in ("changed", "unchanged"):
                    true_change = -REAL_CHANGES[1][1]["burial"] if what == "settle" else 0.0
                    heights.append((o.values["height_change"] - true_change, o.values["height_change_lod95"]))
        r = np.array(regs).reshape(-1, 7)
        rows.append([name[:34], f"{len(regs)}/{placements} ({len(cloud.xyz) // 1000} k)",
                     f"{tally['move: found']}/{tally['move: n']}",
                     f"{tally['settle: found']}/{tally['settle: n']}",
                     f"{tally['overturn: found']}/{tally['overturn: n']}",
                     f"{tally['unchanged called changed']}/{tally['unchanged']}",
                     f"{1000 * math.sqrt(np.mean(r[:, 0] ** 2 + r[:, 1] ** 2)):.0f}" if len(r) else "-",
                     f"{1000 * math.sqrt(np.mean(r[:, 2] ** 2)):.0f}" if len(r) else "-",
                     f"{100 * np.mean((abs(r[:, 0]) <= 2 * r[:, 3]) & (abs(r[:, 1]) <= 2 * r[:, 5])):.0f} %"
                     if len(r) else "-",
                     f"{1000 * np.median(r[:, 3]):.0f}" if len(r) else "-",
                     f"{1000 * np.median(r[:, 4]):.0f}" if len(r) else "-",
                     f"{1000 * math.sqrt(np.mean(np.square(errs))):.0f}" if errs else "-",
                     _height_cell(heights),
                     f"{np.median(r[:, 6]):.0f} of {tally['units'] / max(len(r), 1):.0f}" if len(r) else "-",
                     "; ".join(f"{k} ×{v}" for k, v in tally.items()
                               if k.startswith(("stopped", "not registered", "not found")))])
    print(table(["file (pings split even/odd)", "placements run", "moved 0.8 m found", "settled 0.25 m",
                 "overturned", "unchanged called changed", "plan reg err RMS mm", "dz err RMS mm",
                 "dx, dy within 2σ", "median σ dx mm", "median σ dz mm", "displacement err RMS mm",
                 "height change err RMS / max mm, within LoD95 (unchanged, settled)",
                 "units the shift was refined on", "left out"], rows))


def main() -> None:
    import argparse

    from _common import own_flags

    ap = argparse.ArgumentParser(add_help=False)
    ap.add_argument("--real", action="store_true")
    ap.add_argument("--placements", type=int, default=3)
    ap.add_argument("--ring", type=int, default=6)
    ap.add_argument("--beam", type=float, default=0.0)
    known = own_flags(ap)
    if known.real:
        _real(known.placements, known.ring, known.beam)
        return
    chosen, results = run_study(__doc__, list(CONFIGS), 10, run_one)
    regs, dets, errs, heights = [], [], [], []
    for name in chosen:
        rs = [r for r in results if r["config"] == name]
        a, b, c = _summary(name, rs)
        regs.append(a)
        dets.append(b)
        errs += c
        heights += _height_by_kind(name, rs)
    print(table(["config", "seeds", "dx err RMS mm", "dy", "dz", "dx within 2σ", "dy", "dz", "median σ dx mm",
                 "dy", "dz"], regs))
    print()
    print(table(["config", "matched right", "matched wrong", "moved found", "settled", "tilted", "overturned",
                 "scoured", "faint scour (< 0.1 m)", "removed", "new", "unchanged called changed", "by"],
                dets))
    print()
    print(table(["config", "measure", "n", "error RMS", "max", "within LoD95", "median LoD95"], errs))
    print()
    print(table(["config", "height change by kind", "n", "error RMS", "max", "within LoD95"], heights))


if __name__ == "__main__":
    main()
