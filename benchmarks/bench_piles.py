"""The jacket preset from file to report: seconds per stage and in total (target < 10 s).

Run: ``python benchmarks/bench_piles.py``. Writes the simulated survey as LAZ and as ASCII
(x y z intensity ping), then times ``mbinspect piles`` end to end on each, in process. When
scikit-learn is installed (the ``bench`` extra) its KMeans is timed beside ours on the
same elevated points, the one stage where a user would otherwise reach for a library.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import best_of, table  # noqa: E402
from mbinspect.cli import main as cli  # noqa: E402
from mbinspect.io import PointCloud, read, write  # noqa: E402
from mbinspect.piles import elevated_points, locate_piles  # noqa: E402
from mbinspect.report import write_pile_outputs  # noqa: E402
from mbinspect.segment import kmeans  # noqa: E402
from mbinspect.simulate import simulate  # noqa: E402


def main() -> None:
    sim = simulate("jacket", seed=0)
    rows = []
    with tempfile.TemporaryDirectory() as d:
        laz = Path(d) / "jacket.laz"
        xyz = Path(d) / "jacket.xyz"
        write(sim.cloud, laz)
        f = sim.cloud.fields
        write(PointCloud(sim.cloud.xyz, {"intensity": f["intensity"], "ping": f["ping"]}), xyz)
        for path in (laz, xyz):
            t_read, cloud = best_of(lambda p=path: read(p), 1)
            t_loc, res = best_of(lambda c=cloud: locate_piles(c, count=4, radius=0.75), 1)
            t_out, _ = best_of(lambda r=res, c=cloud: write_pile_outputs(r, c.xyz, Path(d) / "o"), 1)
            t0 = time.perf_counter()
            code = cli(["-q", "piles", str(path), "--count", "4", "--radius", "0.75",
                        "--out", str(Path(d) / f"cli-{path.suffix[1:]}")])
            t_cli = time.perf_counter() - t0
            assert code in (0, 3)
            rows.append([f"{path.suffix} {len(cloud):,} pts", t_read, t_loc, t_out, t_cli])
        print(table(["input", "read s", "locate s", "outputs+figures s", "CLI end to end s"], rows))
        mask, _, _ = elevated_points(sim.cloud.xyz)
        xy = sim.cloud.xyz[mask, :2]
        ours, _ = best_of(lambda: kmeans(xy, 4, seed=0), 3)
        try:
            from sklearn.cluster import KMeans

            peer, _ = best_of(lambda: KMeans(4, n_init=10, random_state=0).fit(xy - xy.mean(axis=0)), 3)
            print(table(["K-means on elevated points", "ours s", "scikit-learn s", "ratio"],
                        [[f"{len(xy):,} pts, k=4, 10 inits", ours, peer, f"{peer / ours:.2f}x"]]))
        except ImportError:
            print(f"K-means on {len(xy):,} elevated points: ours {ours:.3f} s (scikit-learn not installed)")


if __name__ == "__main__":
    main()
