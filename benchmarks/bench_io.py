"""Read speed of ASCII XYZ files: mbinspect.io.read beside numpy.loadtxt (and pandas if present).

Run: ``python benchmarks/bench_io.py [--points 2000000]``. Prints a table of seconds and
the ratio to the peer measured in the same run.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import best_of, table  # noqa: E402
from mbinspect.io import read  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--points", type=int, default=2_000_000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    n = args.points
    rows = []
    with tempfile.TemporaryDirectory() as d:
        for ncols, ext in ((3, "xyz"), (4, "xyz"), (3, "csv")):
            data = np.column_stack([512000 + rng.uniform(0, 100, n), 3456000 + rng.uniform(0, 100, n),
                                    rng.uniform(-22, -15, n), rng.uniform(50, 90, n)])[:, :ncols]
            path = Path(d) / f"p{ncols}.{ext}"
            delim = "," if ext == "csv" else " "
            np.savetxt(path, data, fmt=["%.3f"] * 3 + ["%.1f"] * (ncols - 3), delimiter=delim)
            ours, cloud = best_of(lambda p=path: read(p), args.repeat)
            assert len(cloud) == n
            peer, _ = best_of(lambda p=path, dl=delim: np.loadtxt(p, delimiter=None if dl == " " else dl),
                              args.repeat)
            row = [f"{n:,} pts, {ncols} cols .{ext}", f"{path.stat().st_size / 2**20:.0f} MiB",
                   ours, peer, f"{peer / ours:.2f}x"]
            try:
                import pandas as pd

                pdt, _ = best_of(lambda p=path, dl=delim: pd.read_csv(p, sep=r"\s+" if dl == " " else dl,
                                                                      header=None).to_numpy(), 1)
                row.append(pdt)
            except ImportError:
                row.append("n/a")
            rows.append(row)
    print(table(["file", "size", "mbinspect s", "numpy.loadtxt s", "speed-up", "pandas s"], rows))


if __name__ == "__main__":
    main()
