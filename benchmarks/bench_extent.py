"""Time and peak memory when a survey's soundings lie along a line across a wide, empty extent.

Run: ``python benchmarks/bench_extent.py``. The real EM3000 line (``pdal_mbf_em300raw``,
7,537 soundings) copied 10 and 30 times, 300 m apart east and north (a line 2.7 km and
8.7 km across on the diagonal), and the ten real KMALL strips ``ets_kmall_OS0*`` (up to
2.2 km apart) as one survey. Each is run two ways, each in its own process so that its
peak RSS is its own: ``extract_reefs`` on the whole cloud in memory, and the survey runner
(what ``mbinspect reefs`` does), which sees the extent before any grid is made and runs in
tiles that follow the soundings. Before, ``mbinspect reefs`` ran the first in memory (2.4 GB)
and the second died of a MemoryError.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import table  # noqa: E402

HERE = Path(__file__).parent
REAL = HERE.parent.parent / "shared" / "real" / "files"
CASES = [("line x10", "memory"), ("line x10", "runner"), ("line x30", "memory"), ("line x30", "runner"),
         ("OS strips", "memory"), ("OS strips", "runner")]


def _paths(case: str, tmp: Path) -> list[Path]:
    import numpy as np

    from mbinspect.io import PointCloud, read, write

    if case == "OS strips":
        return sorted(REAL.glob("ets_kmall_OS0*.kmall"))
    n = int(case.split("x")[1])
    cloud = read(HERE.parent / "tests" / "data" / "pdal_mbf_em300raw.mb56")
    xyz = np.concatenate([cloud.xyz + [k * 300.0, k * 300.0, 0.0] for k in range(n)])
    fields = {k: np.concatenate([v] * n) for k, v in cloud.fields.items()}
    write(PointCloud(xyz, fields, crs=cloud.crs), tmp / "line.laz")
    return [tmp / "line.laz"]


def _case(case: str, how: str) -> str:
    from mbinspect.errors import MBInspectError
    from mbinspect.reefs import ReefOptions, extract_reefs
    from mbinspect.survey import read_survey
    from mbinspect.survey.run import SurveyOptions, run_survey

    with tempfile.TemporaryDirectory() as tmp:
        paths = _paths(case, Path(tmp))
        cloud = read_survey(paths)
        t = time.perf_counter()
        try:
            if how == "memory":
                res = extract_reefs(cloud)
                out = f"{len(res.reefs)} reefs, {len(res.others)} others"
            else:
                run = run_survey("reefs", paths, ReefOptions(), SurveyOptions(workers=1))
                out = (f"{len(run.result.reefs)} reefs, {len(run.result.others)} others"
                       + (f"; {run.tiles} tiles" if run.tiled else "; in memory"))
        except MBInspectError as exc:
            out = "stopped: " + str(exc)[:70]
        return f"{len(cloud)}|{time.perf_counter() - t:.2f}|{out}"


def main() -> None:
    if len(sys.argv) == 3:
        import resource

        n, secs, result = _case(sys.argv[1], sys.argv[2]).split("|", 2)
        print(f"{n}|{secs}|{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f}|{result}")
        return
    rows = []
    for case, how in CASES:
        run = subprocess.run([sys.executable, __file__, case, how], capture_output=True, text=True)
        lines = run.stdout.strip().splitlines()
        n, secs, rss, result = lines[-1].split("|", 3) if run.returncode == 0 and lines else \
            ("-", "-", "-", "crashed: " + (run.stderr.strip().splitlines() or ["?"])[-1][:70])
        rows.append([case, how, n, secs, rss, result])
    print(table(["survey", "run", "soundings", "s", "peak MB", "result"], rows))


if __name__ == "__main__":
    main()
