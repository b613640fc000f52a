"""How reef units rest (issue 30): overturned units told from upright ones, and the tilt of
each unit's top with its 1-sigma; on the simulator and on units injected into the real files.

Run: ``python benchmarks/study_rest.py [--seeds 4] [--configs mixed,...] [--workers 2]
[--real] [--placements 3]``.

Simulator rows: ``reef-field`` fields of 16 units a group (``mixed``: cross2, cross1, hollow
and triangle in turn; ``cross2``: double-layer crosses only, whose upside-down shows the
same plan as upright), six units a field overturned (on a side or upside down: each design's
distinct ways, :func:`mbinspect.design_solids.distinct_orientations`), every unit leaning
0-12° (``-level``: none; ``-beam``: cast through 1° cones; ``-told``: the reef chain told
the beam), four reef-sized rocks among
them. Columns: overturned units found as reefs, flagged overturned and left undecided (the
rest read upright); upright units found,
flagged overturned in error, left undecided; the top tilt's error against the true lean for
the units upright or upside down (RMS, max, within 2σ); reefs found where no unit is
(extra); ``extract_reefs`` seconds. The ``default`` row is the preset as it was (no unit
overturned or leaning): no unit may be flagged.

``--real``: four units injected into each real file that holds them (``study_inject.py``'s
square), two of them overturned, all leaning 0-8°.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import own_flags, run_study, table  # noqa: E402
from mbinspect.design_solids import distinct_orientations  # noqa: E402
from mbinspect.errors import MBInspectError  # noqa: E402
from mbinspect.reef_designs import BUILTIN_DESIGNS  # noqa: E402
from mbinspect.reefs import extract_reefs  # noqa: E402
from mbinspect.simulate import simulate  # noqa: E402

DESIGNS = "cross2,cross1,hollow,triangle"
FIELD = {"per_group": 16, "close_pairs": 0, "rocks": 4}
CONFIGS: dict[str, dict] = {
    "mixed": {"groups": "mixed", "overturned": 6, "tilt_max_deg": 12.0, **FIELD},
    "cross2": {"groups": "cross2", "overturned": 6, "tilt_max_deg": 12.0, **FIELD},
    "mixed-level": {"groups": "mixed", "overturned": 6, **FIELD},
    "mixed-beam": {"groups": "mixed", "overturned": 6, "tilt_max_deg": 12.0, "sonar": "shallow-beam",
                   **FIELD},
    "mixed-beam-told": {"groups": "mixed", "overturned": 6, "tilt_max_deg": 12.0, "sonar": "shallow-beam",
                        **FIELD},
    "cross2-beam-told": {"groups": "cross2", "overturned": 6, "tilt_max_deg": 12.0, "sonar": "shallow-beam",
                         **FIELD},
    "default": {},
}
TOLD = {"beam_correction": True, "beam_width_deg": 1.0}  # the shallow-beam sonar's 1° cones


def _score(truth: list[dict], reefs: list) -> dict:
    """Each true unit against the reef found within 1.5 m of it."""
    out = {"turned": [], "upright": [], "tilt": [], "extra": 0}
    used = set()
    for t in truth:
        f = min(reefs, key=lambda r: math.hypot(r.x - t["x"], r.y - t["y"]), default=None)
        if f is not None and math.hypot(f.x - t["x"], f.y - t["y"]) >= 1.5:
            f = None
        if f is not None:
            used.add(id(f))
        turned = t.get("orientation", "upright") != "upright"
        out["turned" if turned else "upright"].append(
            (f is not None, f is not None and f.overturned is True, f is not None and f.overturned is None))
        if f is not None and t.get("orientation", "upright") in ("upright", "upside down"):
            out["tilt"].append((f.top_tilt_deg - t.get("top_tilt_deg", 0.0), f.top_tilt_sigma_deg))
    out["extra"] = sum(id(r) not in used for r in reefs)
    return out


def run_one(args: tuple[str, int]) -> list[dict]:
    name, seed = args
    sim = simulate("reef-field", seed=seed, **CONFIGS[name])
    t = time.perf_counter()
    res = extract_reefs(sim.cloud, design=DESIGNS, **(TOLD if name.endswith("-told") else {}))
    seconds = time.perf_counter() - t
    return [{"config": name, "seconds": seconds, **_score(sim.truth["reefs"], list(res.reefs))}]


def _row(label: str, rs: list[dict]) -> list[str]:
    turned = np.array([x for r in rs for x in r["turned"]], bool).reshape(-1, 3)
    up = np.array([x for r in rs for x in r["upright"]], bool).reshape(-1, 3)
    tilt = np.array([x for r in rs for x in r["tilt"]], float).reshape(-1, 2)
    ok = np.isfinite(tilt).all(axis=1)
    e, s = tilt[ok, 0], tilt[ok, 1]
    return [label, f"{len(rs)}", f"{turned[:, 0].sum()}/{len(turned)}", f"{turned[:, 1].sum()}",
            f"{turned[:, 2].sum()}", f"{up[:, 0].sum()}/{len(up)}", f"{up[:, 1].sum()}", f"{up[:, 2].sum()}",
            f"{math.sqrt(np.mean(e ** 2)):.2f}" if ok.any() else "-",
            f"{np.abs(e).max():.2f}" if ok.any() else "-",
            f"{100 * np.mean(np.abs(e) <= 2 * s):.0f} %" if ok.any() else "-", f"{int((~ok).sum())}",
            f"{sum(r['extra'] for r in rs)}",
            f"{np.mean([r['seconds'] for r in rs]):.1f}" if rs and "seconds" in rs[0] else "-"]


HEAD = ["config", "seeds / placements", "overturned found", "flagged overturned", "overturned undecided",
        "upright found", "flagged overturned in error", "undecided", "tilt error RMS deg", "max deg",
        "within 2σ", "no tilt (top too small)", "extra reefs", "extract s"]


def _real(placements: int) -> None:
    from mbinspect.inject import InjectedReef, inject
    from mbinspect.io import PointCloud
    from study_inject import _files, _reef_square, site

    rows = []
    for name, cloud, layout in _files():
        if layout != "square":
            continue
        cx, cy, side = site(cloud)
        rs = []
        for k in range(placements):
            rng = np.random.default_rng(k)
            square = []
            for i, u in enumerate(_reef_square(cx, cy, side, rng)):
                ways = [w for w in distinct_orientations(BUILTIN_DESIGNS[u.kind]) if w != "upright"]
                way = ways[int(rng.integers(len(ways)))] if i % 2 == 0 and ways else "upright"
                square.append(InjectedReef(u.id, u.x, u.y, u.kind, u.bearing_deg, u.scale, group=u.group,
                                           orientation=way, tilt_deg=float(rng.uniform(0, 8)),
                                           tilt_bearing_deg=float(rng.uniform(0, 360))))
            try:
                inj = inject(cloud.xyz, cloud.fields, reefs=square)
                res = extract_reefs(PointCloud(inj.xyz, dict(cloud.fields)), design=DESIGNS,
                                    design_scale_tolerance=0.35)
            except MBInspectError:
                continue
            rs.append(_score(inj.truth["reefs"], list(res.reefs)))
        rows.append(_row(name[:38], rs))
    print(table(HEAD, rows))


def main() -> None:
    import argparse

    ap = argparse.ArgumentParser(add_help=False)
    ap.add_argument("--real", action="store_true")
    ap.add_argument("--placements", type=int, default=3)
    known = own_flags(ap)
    chosen, results = run_study(__doc__, list(CONFIGS), 4, run_one)
    print(table(HEAD, [_row(c, [r for r in results if r["config"] == c]) for c in chosen]))
    if known.real:
        print()
        _real(known.placements)


if __name__ == "__main__":
    main()
