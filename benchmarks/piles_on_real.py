"""``locate_piles`` on every real file of ``../shared/real/files`` (none holds a pile).

Run: ``python benchmarks/piles_on_real.py [--radius 0.75,0.5]``. Per readable file and prior
radius (default options, the count found from the data): soundings, the piles reported
(each a false pile: no public file shows one), the candidates set aside, and the message
the run stopped with or the first reason a candidate was set aside, and the time. The
target of issue 12: nothing that is not a pile reported as one, no traceback.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import real_clouds, table  # noqa: E402
from mbinspect.errors import MBInspectError  # noqa: E402
from mbinspect.piles import locate_piles  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--radius", default="0.75,0.5", help="prior radii (m), comma separated")
    args = ap.parse_args()
    radii = [float(r) for r in args.radius.split(",")]
    rows, reported = [], 0
    for name, cloud in real_clouds():
        for radius in radii:
            t = time.perf_counter()
            try:
                res = locate_piles(cloud, radius=radius)
            except MBInspectError as exc:
                rows.append([name[:30], f"{len(cloud):,}", f"{radius:g}", "-", "-",
                             "stopped: " + str(exc)[:90], f"{time.perf_counter() - t:.1f}"])
                continue
            reported += len(res.piles)
            why = res.rejected[0].reasons[0][:90] if res.rejected else ""
            rows.append([name[:30], f"{len(cloud):,}", f"{radius:g}", f"{len(res.piles)}",
                         f"{len(res.rejected)}", why, f"{time.perf_counter() - t:.1f}"])
    print(table(["file", "soundings", "radius m", "piles", "set aside", "stop or first reason", "s"], rows))
    print(f"\npiles reported on files that hold none: {reported}")


if __name__ == "__main__":
    main()
