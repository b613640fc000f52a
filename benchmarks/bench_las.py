"""LAS/LAZ reading: mbinspect's ``read`` beside laspy's own, on the same 10 M points.

Run: ``python benchmarks/bench_las.py [--points 10000000]``. Writes a survey-like LAS 1.4
(point format 6: x, y, z at millimetres, intensity, classification, point source id as the
line, scan angle) and its LAZ, in a projected metre CRS, then reads each in fresh processes,
best of three: laspy (``laspy.read`` and the (N, 3) float64 array a user builds from it) and
``mbinspect.io.read`` (the same array, its fields, the withheld and noise check, the CRS
check), and ``mbinspect info`` as a user runs it (the read, then bounds, covered area and
sounding spacing). Prints seconds, peak resident memory and the ratios to laspy's read.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import table  # noqa: E402

PEER = """
import json, resource, sys, time
import numpy as np, laspy
t = time.perf_counter()
las = laspy.read(sys.argv[1])
xyz = np.column_stack([las.x, las.y, las.z])
fields = {"intensity": np.asarray(las.intensity), "classification": np.asarray(las.classification),
          "line": np.asarray(las.point_source_id), "scan_angle": np.asarray(las.scan_angle)}
took = time.perf_counter() - t
print(json.dumps({"s": took, "rss": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
                  "n": len(xyz)}))
"""

OURS = """
import json, resource, sys, time, warnings
from mbinspect.io import read
t = time.perf_counter()
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    cloud = read(sys.argv[1])
took = time.perf_counter() - t
print(json.dumps({"s": took, "rss": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
                  "n": len(cloud)}))
"""


INFO = """
import contextlib, io, json, resource, sys, time, warnings
from mbinspect.cli import main
t = time.perf_counter()
with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
    warnings.simplefilter("ignore")
    main(["info", sys.argv[1]])
took = time.perf_counter() - t
print(json.dumps({"s": took, "rss": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
                  "n": 0}))
"""


def _write(folder: Path, n: int) -> dict[str, Path]:
    import laspy
    import numpy as np
    from pyproj import CRS

    rng = np.random.default_rng(0)
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.offsets, header.scales = [500000.0, 4100000.0, 0.0], [0.001, 0.001, 0.001]
    header.add_crs(CRS.from_epsg(32617))
    las = laspy.LasData(header)
    las.x = 500000.0 + rng.uniform(0, 3000, n)
    las.y = 4100000.0 + np.sort(rng.uniform(0, 3000, n))
    las.z = -17.0 + rng.normal(0, 0.3, n)
    las.intensity = rng.integers(0, 4000, n).astype(np.uint16)
    las.classification = np.full(n, 2, np.uint8)
    las.point_source_id = (np.arange(n) // 200_000).astype(np.uint16)
    las.scan_angle = rng.integers(-10000, 10000, n).astype(np.int16)
    out = {}
    for ext in (".las", ".laz"):
        path = folder / f"survey{ext}"
        las.write(path)
        out[ext[1:]] = path
    return out


def _best(code: str, path: Path, runs: int = 3) -> dict[str, float]:
    best: dict[str, float] | None = None
    for _ in range(runs):
        got = json.loads(subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True,
                                        text=True, check=True).stdout)
        if best is None or got["s"] < best["s"]:
            best = got
    assert best is not None
    return best


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--points", type=int, default=10_000_000)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        files = _write(Path(tmp), args.points)
        rows = []
        for kind, path in files.items():
            peer, ours = _best(PEER, path), _best(OURS, path)
            assert peer["n"] == ours["n"] == args.points
            info = _best(INFO, path)
            for what, got in (("read", ours), ("info", info)):
                rows.append([kind, what, f"{path.stat().st_size / 1e6:.0f} MB", f"{peer['s']:.2f}",
                             f"{got['s']:.2f}", f"{got['s'] / peer['s']:.2f}", f"{peer['rss'] / 1e9:.2f}",
                             f"{got['rss'] / 1e9:.2f}", f"{got['rss'] / peer['rss']:.2f}"])
    print(f"{args.points:,} points, best of 3 fresh processes each")
    print(table(["file", "mbinspect", "size", "laspy s", "mbinspect s", "time ratio", "laspy GB",
                 "mbinspect GB", "memory ratio"], rows))


if __name__ == "__main__":
    main()
