"""Generation time of the simulator presets (the jacket preset must take under 20 s).

Run: ``python benchmarks/bench_simulate.py``.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import table  # noqa: E402
from mbinspect.simulate import simulate  # noqa: E402


def main() -> None:
    rows = []
    for preset in ("jacket", "reef-field"):
        t = time.perf_counter()
        sim = simulate(preset, seed=0)
        dt = time.perf_counter() - t
        rows.append([preset, f"{len(sim.cloud):,}", dt, f"{len(sim.cloud) / dt / 1e3:.0f} k/s"])
    print(table(["preset", "soundings", "seconds", "rate"], rows))


if __name__ == "__main__":
    main()
