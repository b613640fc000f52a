"""Helpers shared by the benchmark scripts: timing and a plain-text table."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

#: The real survey files and their independent decodes (``../shared/real``).
REAL = Path(__file__).resolve().parents[2] / "shared" / "real"


def real_clouds() -> Iterator[tuple[str, Any]]:
    """Every real file mbinspect reads, as (file name, cloud of its valid soundings in UTM);
    the files a reader refuses are left out."""
    from mbinspect.errors import MBInspectError
    from mbinspect.io import format_from_path
    from mbinspect.sonar import read_sonar, to_cloud

    for path in sorted((REAL / "files").iterdir()):
        if path.suffix == ".md":
            continue
        try:
            yield path.name, to_cloud(read_sonar(path, format_from_path(path)))
        except MBInspectError:
            continue


def own_line(path: Path) -> tuple[Any, Any, Any, Any, Any]:
    """A real one-line file, its own line as a plan layout, the line's middle, and unit vectors
    along it and to its right: (cloud, layout, middle, along, right), for objects injected
    beside the line and planned on it."""
    import numpy as np

    from mbinspect.io import read
    from mbinspect.plan import Layout, PlanLine
    from mbinspect.plan.check import sailed_lines

    cloud = read(path)
    line = sailed_lines(cloud)[0]
    layout = Layout("xtf-line", "the file's own line", (PlanLine(tuple(line["start"]), tuple(line["end"])),))
    a, b = np.array(line["start"]), np.array(line["end"])
    d = (b - a) / np.linalg.norm(b - a)
    return cloud, layout, (a + b) / 2, d, np.array([d[1], -d[0]])


class TreeMemory:
    """The peak memory of this process and its children together, sampled every
    ``interval`` seconds in a thread: the sum of each process's proportional set size (PSS,
    from ``/proc/PID/smaps_rollup``), so pages a forked worker shares with its parent count
    once. Linux only; ``peak`` stays 0 elsewhere. Use as a context manager."""

    def __init__(self, interval: float = 0.05) -> None:
        import threading

        self.interval = interval
        self.peak = 0  # bytes
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    @staticmethod
    def _pids(pid: int) -> list[int]:
        out = [pid]
        for task in Path(f"/proc/{pid}/task").glob("*/children"):
            try:
                for child in task.read_text().split():
                    out += TreeMemory._pids(int(child))
            except OSError:
                continue
        return out

    @staticmethod
    def _pss(pid: int) -> int:
        try:
            for line in Path(f"/proc/{pid}/smaps_rollup").read_text().splitlines():
                if line.startswith("Pss:"):
                    return int(line.split()[1]) * 1024
        except OSError:
            pass
        return 0

    def _run(self) -> None:
        import os

        while not self._stop.is_set():
            self.peak = max(self.peak, sum(self._pss(p) for p in self._pids(os.getpid())))
            self._stop.wait(self.interval)

    def __enter__(self) -> TreeMemory:
        if Path("/proc/self/smaps_rollup").exists():
            self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join()


def best_of(fn: Callable[[], Any], repeat: int = 3) -> tuple[float, Any]:
    """Smallest wall time of ``repeat`` runs (the machine is shared) and the last result."""
    best, result = float("inf"), None
    for _ in range(repeat):
        t = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - t)
    return best, result


def table(headers: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    """Format rows as an aligned plain-text (Markdown-compatible) table."""
    cells = [[f"{c:.3f}" if isinstance(c, float) else str(c) for c in row] for row in rows]
    widths = [max([len(h), *(len(r[i]) for r in cells)]) for i, h in enumerate(headers)]
    line = "| " + " | ".join(h.ljust(w) for h, w in zip(headers, widths, strict=True)) + " |"
    sep = "|" + "|".join("-" * (w + 2) for w in widths) + "|"
    body = ["| " + " | ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)) + " |" for r in cells]
    return "\n".join([line, sep, *body])


def own_flags(parser: Any) -> Any:
    """A study's own flags (``parser``, an ``argparse.ArgumentParser(add_help=False)`` the
    study filled), parsed; the rest left in ``sys.argv`` for :func:`run_study`."""
    import sys

    known, rest = parser.parse_known_args()
    sys.argv = [sys.argv[0], *rest]
    return known


def run_study(description: str | None, configs: Sequence[str], default_seeds: int,
              run_one: Callable[[tuple[str, int]], list[dict]]) -> tuple[list[str], list[dict]]:
    """Parse ``--seeds --configs --workers``, run ``run_one((config, seed))`` for every pair
    in a process pool, and return the configurations asked for with all result rows."""
    import argparse
    from concurrent.futures import ProcessPoolExecutor

    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--seeds", type=int, default=default_seeds)
    ap.add_argument("--configs", default=",".join(configs))
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    chosen = args.configs.split(",")
    jobs = [(c, s) for c in chosen for s in range(args.seeds)]
    with ProcessPoolExecutor(args.workers) as pool:
        results = [r for rows in pool.map(run_one, jobs) for r in rows]
    return chosen, results


def unborne(detected, values, truth) -> list[str]:
    """The changes detected on a unit that its truth does not bear out: the true value of
    the measure (a neighbour's scour pit reaching its rings counts as its own) within half
    the measure's level of detection of nothing; a turn over when it rests as it did."""
    out = []
    for m in detected:
        if m == "overturned":
            if bool(truth.get("overturned_before")) == bool(truth.get("overturned_after")):
                out.append(m)
            continue
        if m == "tilt_change_deg":
            tv = truth.get("tilt_change_deg", truth.get("tilt_after", 0.0) - truth.get("tilt_before", 0.0))
        elif m == "height_change":
            tv = truth.get("height_after", 0.0) - truth.get("height_before", 0.0)
        else:
            tv = truth.get(m, 0.0)
        lod = values.get(m + "_lod95")
        if lod is None or not abs(tv) >= 0.5 * lod:
            out.append(m)
    return out
