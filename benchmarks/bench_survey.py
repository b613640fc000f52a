"""Whole surveys: a simulated reef field written one LAZ per line, run in memory and in
tiles on a local Dask cluster; time, soundings per second, peak memory per worker and in
all, identity of the two runs, and every reef scored against the truth.

    python benchmarks/bench_survey.py simulate DIR --groups 16 --ping-spacing 0.1 --workers 2
    python benchmarks/bench_survey.py compare DIR            # in memory and tiled (2 workers)
    python benchmarks/bench_survey.py tiled DIR --workers 1  # tiled only (scaling, 100 M)

Each run is a fresh process, so that its peak resident memory is its own.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

KINDS = ("cross2", "cross1", "hollow", "triangle")


def simulate(out: Path, groups: int, ping_spacing: float, workers: int, seed: int) -> None:
    from mbinspect.simulate import simulate_lines

    t = time.perf_counter()
    truth = simulate_lines("reef-field", out, seed=seed, workers=workers, ping_spacing=ping_spacing,
                           groups=",".join(KINDS[g % len(KINDS)] for g in range(groups)))
    took = time.perf_counter() - t
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    size = sum(f.stat().st_size for f in out.glob("line_*.laz"))
    print(f"simulated {truth['n_soundings']:,} soundings, {len(truth['reefs'])} reefs, {len(truth['files'])} "
          f"lines ({size / 1e9:.2f} GB of LAZ) in {took:.0f} s with {workers} process(es); "
          f"peak RSS of the parent {rss:.0f} MiB")


def _score(result, truth) -> dict:
    ref = (np.array([[t["x"], t["y"]] for t in truth["reefs"]]), tuple(t["id"] for t in truth["reefs"]))
    from mbinspect.reefs.score import score_reefs

    ev, _ = score_reefs(list(result.reefs), ref, tolerance=1.5)
    return {"tp": ev.tp, "fp": ev.fp, "fn": ev.fn}


def one_run(folder: Path, mode: str, workers: int, tile_size: float | None, out: Path) -> None:
    """One run in this process; its figures as JSON in ``out``."""
    from mbinspect.reefs import ReefOptions
    from mbinspect.survey import expand_inputs
    from mbinspect.survey.run import SurveyOptions, run_survey

    files = expand_inputs([folder / "line_*.laz"])
    truth = json.loads((folder / "truth.json").read_text())
    survey = SurveyOptions(tiled=mode == "tiled", workers=workers, tile_size=tile_size)
    t = time.perf_counter()
    run = run_survey("reefs", files, ReefOptions(seabed="grid"), survey)
    took = time.perf_counter() - t
    n = run.info["soundings"]
    parent = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    peaks = run.info.get("worker_peak_rss", {})
    out.write_text(json.dumps({
        "mode": mode, "workers": workers, "soundings": n, "seconds": took, "per_s": n / took,
        "tiles": run.tiles, "tile_size": run.info.get("tile_size"),
        "largest_tile": max(run.info.get("tile_soundings", [n])),
        "read": sum(run.info.get("tile_soundings", [n])),
        "parent_peak": parent, "worker_peaks": list(peaks.values()),
        "score": _score(run.result, truth),
        "reefs": [[r.id, r.x, r.y, r.height, r.area] for r in run.result.reefs],
    }))


def _fresh(folder: Path, mode: str, workers: int, tile_size: float | None) -> dict:
    out = folder.parent / f".bench-{mode}-{workers}.json"
    cmd = [sys.executable, __file__, "_one", str(folder), mode, str(workers), str(tile_size or 0), str(out)]
    subprocess.run(cmd, check=True)
    return json.loads(out.read_text())


def _row(r: dict) -> str:
    w = max(r["worker_peaks"], default=0) / 2**30
    # with one worker the tiles run in this process: its peak is the run's
    alone = r["mode"] == "memory" or r["workers"] == 1
    total = (r["parent_peak"] + (0 if alone else sum(r["worker_peaks"]))) / 2**30
    s = r["score"]
    return (f"| {r['mode']} | {r['workers'] if r['mode'] == 'tiled' else '-'} | {r['soundings']:,} | "
            f"{r['tiles']} | {r['tile_size'] or '-'} | {r['largest_tile'] / 1e6:.2f} M | "
            f"{r['read'] / r['soundings']:.2f} | {r['seconds']:.0f} | {r['per_s'] / 1e3:,.0f} k | "
            f"{(w if w else r['parent_peak'] / 2**30):.2f} | {total:.2f} | {s['tp']}/{s['fp']}/{s['fn']} |")


HEADER = ("| run | workers | soundings | tiles | tile m | largest tile reads | read / held | s | soundings/s "
          "| peak GiB per worker | peak GiB in all | TP/FP/FN |\n"
          "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")


def compare(folder: Path, workers: int, tile_size: float | None) -> None:
    mem = _fresh(folder, "memory", 1, None)
    tiled = _fresh(folder, "tiled", workers, tile_size)
    print(HEADER)
    print(_row(mem))
    print(_row(tiled))
    a, b = np.array(mem["reefs"]), np.array(tiled["reefs"])
    same = a.shape == b.shape and (a[:, 0] == b[:, 0]).all()
    if same:
        d = np.abs(a[:, 1:] - b[:, 1:]).max(axis=0)
        print(f"\nsame {len(a)} reefs, same ids; largest differences: x {d[0] * 1000:.3g} mm, "
              f"y {d[1] * 1000:.3g} mm, height {d[2] * 1000:.3g} mm, area {d[3]:.3g} m²")
    else:
        print(f"\nDIFFERENT: {len(a)} reefs in memory, {len(b)} tiled")
    print(f"tiled / in memory throughput: {tiled['per_s'] / mem['per_s']:.2f}")


def tiled(folder: Path, workers: list[int], tile_size: float | None) -> None:
    print(HEADER)
    rows = [_fresh(folder, "tiled", w, tile_size) for w in workers]
    for r in rows:
        print(_row(r))
    if len(rows) == 2:
        few, many = sorted(rows, key=lambda r: r["workers"])
        print(f"\n{many['workers']} workers against {few['workers']}: "
              f"{few['seconds'] / many['seconds']:.2f}x faster")


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "_one":
        folder, mode, workers, tile, out = sys.argv[2:7]
        one_run(Path(folder), mode, int(workers), float(tile) or None, Path(out))
        return
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("simulate")
    s.add_argument("out", type=Path)
    s.add_argument("--groups", type=int, default=16)
    s.add_argument("--ping-spacing", type=float, default=0.1)
    s.add_argument("--workers", type=int, default=2)
    s.add_argument("--seed", type=int, default=1)
    c = sub.add_parser("compare")
    c.add_argument("folder", type=Path)
    c.add_argument("--workers", type=int, default=2)
    c.add_argument("--tile-size", type=float)
    t = sub.add_parser("tiled")
    t.add_argument("folder", type=Path)
    t.add_argument("--workers", default="1,2")
    t.add_argument("--tile-size", type=float)
    a = ap.parse_args()
    if a.cmd == "simulate":
        simulate(a.out, a.groups, a.ping_spacing, a.workers, a.seed)
    elif a.cmd == "compare":
        compare(a.folder, a.workers, a.tile_size)
    else:
        tiled(a.folder, [int(w) for w in a.workers.split(",")], a.tile_size)


if __name__ == "__main__":
    main()
