"""Generation time of the simulator presets (the jacket preset must take under 20 s), with the
beam off (thin rays) and as 1° cones (issue 28: within 2× of the thin rays), and the time of
``inject`` into the densest real shallow file (the R2Sonic XTF) both ways.

Run: ``python benchmarks/bench_simulate.py [--repeat 2]`` (the best of the repeats is shown).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import table  # noqa: E402
from mbinspect.beam import Beam  # noqa: E402
from mbinspect.inject import InjectedPile, inject  # noqa: E402
from mbinspect.io import read  # noqa: E402
from mbinspect.simulate import simulate  # noqa: E402

XTF = Path(__file__).resolve().parents[2] / "shared" / "real" / "files" / "R2Testing_0009.xtf"
BEAMS = (("off", {}), ("1 deg", {"beam_across_deg": 1.0}), ("2 deg", {"beam_across_deg": 2.0}))


def _best(fn, repeat: int) -> tuple[float, object]:
    best, out = np.inf, None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=2)
    args = ap.parse_args()
    rows = []
    for preset in ("jacket", "reef-field"):
        base = None
        for name, kw in BEAMS:
            dt, sim = _best(lambda p=preset, k=kw: simulate(p, seed=0, **k), args.repeat)
            base = base or dt
            rows.append([preset, name, f"{len(sim.cloud):,}", dt, f"{dt / base:.2f}",
                         f"{len(sim.cloud) / dt / 1e3:.0f} k/s"])
    if XTF.exists():
        cloud = read(XTF)
        cx, cy = np.median(cloud.xyz[:, :2], axis=0)
        piles = [InjectedPile(k + 1, cx + dx, cy + dy, 0.5, height=2.0)
                 for k, (dx, dy) in enumerate([(-3, -3), (3, -3), (-3, 3), (3, 3)])]
        base = None
        for name, kw in BEAMS:
            beam = Beam(**kw) if kw else None
            dt, _ = _best(lambda b=beam: inject(cloud.xyz, cloud.fields, piles=piles, beam=b), args.repeat)
            base = base or dt
            rows.append([f"inject {XTF.name}, 4 piles", name, f"{len(cloud):,}", dt, f"{dt / base:.2f}",
                         f"{len(cloud) / dt / 1e3:.0f} k/s"])
    print(table(["what", "beam", "soundings", "seconds", "x thin", "rate"], rows))


if __name__ == "__main__":
    main()
