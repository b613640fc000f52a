"""``extract_reefs`` on every real file of ``../shared/real/files`` (none holds a reef).

Run: ``python benchmarks/reefs_on_real.py``. Per readable file (valid soundings, default
options): depth, soundings, the share the noise radius filter removes, the reefs and other
objects reported (each is a false reef: no public file shows one), the first warning, or
the message the run stopped with, and the time. The target of issue 13: no reef, no
traceback, at most 1 % of the valid soundings removed by the filter.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import real_clouds, table  # noqa: E402
from mbinspect.errors import MBInspectError  # noqa: E402
from mbinspect.reefs import ReefOptions, denoise, extract_reefs  # noqa: E402


def main() -> None:
    rows = []
    for name, cloud in real_clouds():
        depth = f"{-np.median(cloud.xyz[:, 2]):.0f}"
        # the filter's share, measured alone (a run may stop after it)
        opts = ReefOptions()
        keep, _ = denoise(cloud.xyz, radius=opts.noise_radius, min_neighbors=opts.noise_neighbors,
                          spacing_factor=opts.noise_spacing)
        removed = f"{100 * (1 - keep.mean()):.1f}"
        t = time.perf_counter()
        try:
            res = extract_reefs(cloud)
        except MBInspectError as exc:
            rows.append([name[:30], depth, f"{len(cloud):,}", removed, "-", "-",
                         "stopped: " + str(exc)[:90], f"{time.perf_counter() - t:.1f}"])
            continue
        note = res.warnings[0][:90] if res.warnings else ""
        rows.append([name[:30], depth, f"{len(cloud):,}", removed, f"{len(res.reefs)}",
                     f"{len(res.others)}", note, f"{time.perf_counter() - t:.1f}"])
    print(table(["file", "depth m", "soundings", "removed by filter %", "reefs", "others",
                 "warning or stop", "s"], rows))


if __name__ == "__main__":
    main()
