"""Time and peak memory of ``reefs`` and ``piles`` when one ping jumps kilometres away.

Run: ``python benchmarks/bench_jump.py``. The real EM3000 line (``pdal_mbf_em300raw``,
7,537 soundings, 67 pings) with two reefs, or two piles, injected; then the same
with one ping's soundings moved 5 km and 14 km east (a navigation jump), and the deep EM710
line (``ets_all_g``, 4,000 soundings over 450 m) spread over 5.8 km. Each case runs in its
own process so that its peak RSS is its own. Before issue 13's sparse handling the 5 km jump
took ``reefs`` from 0.7 s / 136 MB to 18 s / 4.9 GB, and 14 km ended in a MemoryError.
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import table  # noqa: E402

HERE = Path(__file__).parent
REAL = HERE.parent.parent / "shared" / "real" / "files"
CASES = [("reefs", 0.0), ("reefs", 5000.0), ("reefs", 14000.0), ("piles", 0.0), ("piles", 5000.0),
         ("piles", 14000.0), ("piles-deep", 0.0)]


def _case(what: str, jump: float) -> str:

    from mbinspect.errors import MBInspectError
    from mbinspect.inject import InjectedPile, InjectedReef, inject
    from mbinspect.io import PointCloud, read
    from mbinspect.piles import locate_piles
    from mbinspect.reefs import extract_reefs

    if what == "piles-deep":
        cloud = read(REAL / "ets_all_g_-7041029013895133878.all")
        xyz = cloud.xyz.copy()
        c = xyz[:, :2].mean(axis=0)
        xyz[:, :2] = c + (xyz[:, :2] - c) * 13.0  # 450 m -> 5.8 km
        t = time.perf_counter()
        try:
            out = f"{len(locate_piles(PointCloud(xyz), radius=0.5).piles)} piles"
        except MBInspectError as exc:
            out = "stopped: " + str(exc)[:60]
        return f"{time.perf_counter() - t:.2f}|{out}"
    cloud = read(HERE.parent / "tests" / "data" / "pdal_mbf_em300raw.mb56")
    cx, cy = cloud.xyz[:, :2].mean(axis=0)
    if what == "reefs":
        inj = inject(cloud.xyz, cloud.fields, reefs=[InjectedReef(1, cx - 3.0, cy, "cross1", bearing_deg=20),
                                                     InjectedReef(2, cx + 2.5, cy, "hollow", bearing_deg=50,
                                                                  scale=0.8)])
    else:
        inj = inject(cloud.xyz, cloud.fields, piles=[InjectedPile(1, cx - 2.5, cy, 0.5, height=2.0),
                                                     InjectedPile(2, cx + 2.5, cy, 0.5, height=2.0)])
    xyz = inj.xyz.copy()
    ping = cloud.fields["ping"]
    xyz[ping == ping.min() + 3, 0] += jump
    pc = PointCloud(xyz, dict(cloud.fields))
    t = time.perf_counter()
    try:
        if what == "reefs":
            out = f"{len(extract_reefs(pc).reefs)} reefs"
        else:
            out = f"{len(locate_piles(pc, radius=0.5).piles)} piles"
    except MBInspectError as exc:
        out = "stopped: " + str(exc)[:60]
    return f"{time.perf_counter() - t:.2f}|{out}"


def main() -> None:
    if len(sys.argv) == 3:
        import resource

        secs, result = _case(sys.argv[1], float(sys.argv[2])).split("|", 1)
        print(f"{secs}|{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f}|{result}")
        return
    rows = []
    for what, jump in CASES:
        run = subprocess.run([sys.executable, __file__, what, str(jump)], capture_output=True, text=True)
        lines = run.stdout.strip().splitlines()
        secs, rss, result = lines[-1].split("|", 2) if run.returncode == 0 and lines else \
            ("-", "-", "crashed: " + (run.stderr.strip().splitlines() or ["?"])[-1][:60])
        rows.append([what, f"{jump / 1000:g} km" if what != "piles-deep" else "spread to 5.8 km", secs, rss,
                     result])
    print(table(["run", "jump", "s", "peak MB", "result"], rows))


if __name__ == "__main__":
    main()
