"""Pile tops at their level (issue 30): each top's level and the level differences within a
jacket against the truth, on the simulator and on piles injected into the real files.

Run: ``python benchmarks/study_levels.py [--seeds 10] [--configs jacket,...] [--workers 2]
[--real] [--placements 3]``.

Simulator rows (``jacket``: the pile paper's '#' lines and two over the tops, the default
``shallow`` sonar whose lines disagree by 3 cm in height and 0.03° in refraction;
``jacket-no-tops``: the '#' lines only; ``jacket-beam-1``: 1° cones, the piles told the
beam; ``wharf``: three jackets of four piles, two raked; ``jacket-classic``: the idealised
sonar, no line errors): per configuration the tops sounded, the absolute level's error
(``top_z``: RMS, max, share within its reported 2σ, median σ), the same for the plain
centre elevation ``z`` the pipeline reported before (no σ), and the level differences of
every pair of a jacket (RMS, max, within 2σ, median σ); the tops' least depths (the high edge
of the top) within their 95 % TVU.

``--real``: a jacket (or a row of two piles) injected into each real file as
``study_inject.py`` does; the rows say how many tops were sounded, by how many lines, the
level difference errors, and how many levels have no σ (a top sounded by one line: its
vertical offset unknown, said in a note).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import own_flags, run_study, table  # noqa: E402
from mbinspect.errors import MBInspectError  # noqa: E402
from mbinspect.piles import locate_piles  # noqa: E402
from mbinspect.simulate import simulate  # noqa: E402

#: configuration -> (simulate keywords, locate_piles keywords)
CONFIGS: dict[str, tuple[dict, dict]] = {
    "jacket": ({}, {}),
    "jacket-no-tops": ({"lines": "west,east,south,north"}, {}),
    "jacket-beam-1": ({"sonar": "shallow-beam"}, {"beam_width_deg": 1.0}),
    "wharf": ({"preset": "wharf"}, {"count": None, "radius": 0.6}),
    "jacket-classic": ({"sonar": "classic"}, {}),
}


def run_one(args: tuple[str, int]) -> list[dict]:
    name, seed = args
    sim_kw, loc_kw = dict(CONFIGS[name][0]), CONFIGS[name][1]
    sim = simulate(sim_kw.pop("preset", "jacket"), seed=seed, **sim_kw)
    truth = {p["id"]: p for p in sim.truth["piles"]}
    kw = {"count": 4, "radius": 0.75, "seed": seed, **loc_kw}
    if kw["count"] is None:
        kw.pop("count")
    res = locate_piles(sim.cloud, **kw)
    return [_errors(name, seed, res, truth)]


def _errors(name: str, seed: int, res, truth: dict) -> dict:
    """One run's level errors against the truth (piles matched to the nearest true pile)."""
    near = {p.id: min(truth, key=lambda i, p=p: math.hypot(p.x - truth[i]["x"], p.y - truth[i]["y"]))
            for p in res.piles}
    by_id = {p.id: p for p in res.piles}
    top = [(p.top_z - truth[near[p.id]]["z"], p.top_z_sigma, p.z - truth[near[p.id]]["z"])
           for p in res.piles if not p.top_z_lower_bound]
    pairs = [(v.difference - (truth[near[v.b]]["z"] - truth[near[v.a]]["z"]), v.sigma)
             for v in res.levels if not v.lower_bound]
    # the least depth: the top's high edge (its level plus the radius up its tilt)
    least = [(-p.least["least_depth"] - (truth[near[p.id]]["z"] + truth[near[p.id]]["radius"] * math.tan(
        math.radians(truth[near[p.id]]["tilt_deg"]))), p.least["least_depth_tvu95"])
        for p in res.piles if not p.top_z_lower_bound]
    lines = [len(p.top_lines) for p in res.piles]
    return {"config": name, "seed": seed, "top": top, "pairs": pairs, "least": least, "n": len(res.piles),
            "sounded": len(top), "lines": lines,
            "no_sigma": sum(not math.isfinite(p.top_z_sigma) for p in by_id.values())}


def _summary(rs: list[dict]) -> list[str]:
    top = np.array([t for r in rs for t in r["top"]]).reshape(-1, 3)
    pairs = np.array([t for r in rs for t in r["pairs"]]).reshape(-1, 2)

    def stats(err: np.ndarray, sig: np.ndarray | None) -> list[str]:
        if not len(err):
            return ["-"] * (2 if sig is None else 4)
        out = [f"{1000 * math.sqrt(np.mean(err**2)):.1f}", f"{1000 * np.abs(err).max():.1f}"]
        if sig is not None:
            ok = np.isfinite(sig)
            out += [f"{100 * np.mean(np.abs(err[ok]) <= 2 * sig[ok]):.0f} %" if ok.any() else "-",
                    f"{1000 * np.median(sig[ok]):.1f}" if ok.any() else "-"]
        return out

    least = np.array([t for r in rs for t in r["least"]]).reshape(-1, 2)
    ok = np.isfinite(least[:, 1])
    within = f"{100 * np.mean(np.abs(least[ok, 0]) <= least[ok, 1]):.0f} %" if ok.any() else "-"
    return ([f"{sum(r['sounded'] for r in rs)}/{sum(r['n'] for r in rs)}",
             f"{np.median([x for r in rs for x in r['lines']]):.0f}"]
            + stats(top[:, 0], top[:, 1]) + stats(top[:, 2], None) + stats(pairs[:, 0], pairs[:, 1])
            + [f"{sum(r['no_sigma'] for r in rs)}", within])


HEAD = ["tops sounded", "lines per top", "top_z RMS mm", "max mm", "within 2σ", "median σ mm",
        "z (before) RMS mm", "max mm", "differences RMS mm", "max mm", "within 2σ", "median σ mm",
        "levels without σ", "least depth within TVU"]


def _real(placements: int) -> None:
    """Piles injected into the real files (``study_inject.py``'s layouts)."""
    from mbinspect.inject import inject
    from mbinspect.io import PointCloud
    from study_inject import RADIUS, SIDE, _files, _jacket, _row, site

    rows = []
    for name, cloud, layout in _files():
        cx, cy, side = site(cloud, SIDE)
        runs = []
        for k in range(placements):
            piles = _row(cloud, np.random.default_rng(k))[0] if layout == "row" else \
                _jacket(cx, cy, side, np.random.default_rng(k))
            try:
                inj = inject(cloud.xyz, cloud.fields, piles=piles)
                res = locate_piles(PointCloud(inj.xyz, dict(cloud.fields)), count=len(piles), radius=RADIUS,
                                   seed=k)
            except MBInspectError:
                continue
            runs.append(_errors(name, k, res, {p["id"]: p for p in inj.truth["piles"]}))
        if runs:
            rows.append([name[:38], f"{len(runs)}", *_summary(runs)])
    print(table(["file", "placements", *HEAD], rows))


def main() -> None:
    import argparse

    ap = argparse.ArgumentParser(add_help=False)
    ap.add_argument("--real", action="store_true")
    ap.add_argument("--placements", type=int, default=3)
    known = own_flags(ap)
    chosen, results = run_study(__doc__, list(CONFIGS), 10, run_one)
    rows = [[c, f"{len([r for r in results if r['config'] == c])}",
             *_summary([r for r in results if r["config"] == c])] for c in chosen]
    print(table(["config", "seeds", *HEAD], rows))
    if known.real:
        print()
        _real(known.placements)


if __name__ == "__main__":
    main()
