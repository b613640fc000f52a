"""Record, then compare, the pile and reef results of fixed seeds (for refactors that must
not change a result).

Run: ``python benchmarks/regression.py record DIR`` before a change and
``python benchmarks/regression.py compare DIR`` after it. Each case simulates a preset (or a
study variant) with a fixed seed, runs the pipeline through the library and stores the
result's ``to_dict()`` without ``parameters`` (which records options, not results). The
comparison prints, per case, the largest difference of any number (m for positions) and any
key, string or length that differs, and exits 1 when a number moved by 0.5 mm or more.
"""

from __future__ import annotations

import json
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from mbinspect.piles import Design, locate_piles
from mbinspect.reefs import extract_reefs
from mbinspect.simulate import simulate

#: case name -> (preset, simulator overrides, pipeline overrides)
CASES: dict[str, tuple[str, dict, dict]] = {
    "jacket": ("jacket", {}, {"method": "both"}),
    "jacket-tilt5": ("jacket", {"tilt_max_deg": 5.0}, {}),
    "jacket-noise-x2": ("jacket", {"noise_scale": 2.0}, {"method": "centre"}),
    "jacket-beam": ("jacket", {"sonar": "shallow-beam"}, {"beam_width_deg": 1.0}),
    "reef-field": ("reef-field", {}, {}),
    "reef-single+hollow": ("reef-field", {"groups": "cross1,hollow,cross1,hollow"},
                           {"design": "cross1,hollow"}),
    "reef-touching": ("reef-field", {"touching_pairs": 6, "close_pairs": 6}, {"design": "cross2,cross1"}),
}
SEEDS = (1, 2, 3)
TOLERANCE = 5e-4
#: cases run once (seed 1): a tiled reef survey on two local workers and piles injected
#: into a real EM3000 line
ONCE = ("tiled-reefs", "injected-piles")
DATA = Path(__file__).resolve().parents[1] / "tests" / "data"


def _tiled_reefs(seed: int) -> dict[str, Any]:
    import tempfile

    from mbinspect.reefs import ReefOptions
    from mbinspect.simulate import simulate_lines
    from mbinspect.survey import expand_inputs
    from mbinspect.survey.run import SurveyOptions, run_survey

    with tempfile.TemporaryDirectory() as tmp:
        simulate_lines("reef-field", tmp, seed=seed, groups="cross2,cross1,cross1,cross2", per_group=9,
                       ping_spacing=0.8, close_pairs=1)
        run = run_survey("reefs", expand_inputs([tmp]), ReefOptions(seabed="grid"),
                         SurveyOptions(tiled=True, tile_size=130.0, workers=1))
    d = run.result.to_dict()
    for r in d["reefs"]:  # temporary file names
        r.pop("sources", None)
    return d


def _injected_piles(seed: int) -> dict[str, Any]:
    from mbinspect.inject import InjectedPile, inject
    from mbinspect.io import PointCloud, read

    cloud = read(DATA / "pdal_mbf_em300raw.mb56")
    cx, cy = cloud.xyz[:, :2].mean(axis=0)
    piles = [InjectedPile(1, cx - 2.5, cy, 0.5, height=2.0), InjectedPile(2, cx + 2.5, cy, 0.5, height=2.0)]
    inj = inject(cloud.xyz, cloud.fields, piles=piles)
    fields = {k: v for k, v in cloud.fields.items()}
    out = PointCloud(inj.xyz, fields, crs=cloud.crs)
    return locate_piles(out, count=2, radius=0.5, seed=seed).to_dict()


def run_case(job: tuple[str, int]) -> tuple[str, dict[str, Any]]:
    name, seed = job
    if name in ONCE:
        d = _tiled_reefs(seed) if name == "tiled-reefs" else _injected_piles(seed)
        d.pop("parameters", None)
        return f"{name}-{seed}", json.loads(json.dumps(d))
    preset, sim_kw, kw = CASES[name]
    sim = simulate(preset, seed=seed, **sim_kw)
    if preset == "jacket":
        design = Design(positions={d["id"]: (d["x"], d["y"]) for d in sim.truth["design"]},
                        source="design")
        d = locate_piles(sim.cloud, count=4, radius=0.75, design=design, seed=seed, **kw).to_dict()
    else:
        truth = sim.truth["reefs"]
        ref = ([[r["x"], r["y"]] for r in truth], tuple(r["id"] for r in truth))
        import numpy as np

        d = extract_reefs(sim.cloud, reference=(np.array(ref[0]), ref[1]), seed=seed, **kw).to_dict()
    d.pop("parameters", None)
    return f"{name}-{seed}", json.loads(json.dumps(d))


def diff(a: Any, b: Any, path: str, out: list[str]) -> float:
    """Largest numeric difference between a and b; structural differences appended to out."""
    if isinstance(a, dict) and isinstance(b, dict):
        worst = 0.0
        for k in a:
            if k not in b:
                out.append(f"{path}.{k}: missing after")
                continue
            worst = max(worst, diff(a[k], b[k], f"{path}.{k}", out))
        return worst
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out.append(f"{path}: length {len(a)} -> {len(b)}")
            return 0.0
        return max([diff(x, y, f"{path}[{i}]", out) for i, (x, y) in enumerate(zip(a, b, strict=True))],
                   default=0.0)
    if isinstance(a, bool) or isinstance(b, bool) or not isinstance(a, (int, float)):
        if a != b:
            out.append(f"{path}: {a!r} -> {b!r}")
        return 0.0
    if not isinstance(b, (int, float)):
        out.append(f"{path}: {a!r} -> {b!r}")
        return 0.0
    if a != a and b != b:  # both NaN
        return 0.0
    return abs(float(a) - float(b))


def main(argv: list[str]) -> int:
    if len(argv) != 2 or argv[0] not in ("record", "compare"):
        print(__doc__)
        return 2
    folder = Path(argv[1])
    jobs = [(c, s) for c in CASES for s in SEEDS] + [(c, 1) for c in ONCE]
    with ProcessPoolExecutor(2) as pool:
        results = dict(pool.map(run_case, jobs))
    if argv[0] == "record":
        folder.mkdir(parents=True, exist_ok=True)
        for key, d in results.items():
            (folder / f"{key}.json").write_text(json.dumps(d, indent=1))
        print(f"recorded {len(results)} cases in {folder}")
        return 0
    bad = 0
    print("| case | largest numeric difference | other differences |")
    print("|---|---|---|")
    for key, d in results.items():
        before = json.loads((folder / f"{key}.json").read_text())
        notes: list[str] = []
        worst = diff(before, d, "", notes)
        bad += worst >= TOLERANCE or bool(notes)
        print(f"| {key} | {worst:.2e} | {'; '.join(notes[:3]) or '-'} |")
    print(f"{bad} of {len(results)} cases differ" if bad else f"all {len(results)} cases identical")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
