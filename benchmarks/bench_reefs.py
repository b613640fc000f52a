"""Reef extraction speed beside an Open3D pipeline doing the paper's steps, and peak memory.

Run: ``python benchmarks/bench_reefs.py [--sizes 0.3,3] [--memory-10m]``, or
``--profile [--sizes 1,3.7,10] [--read-formats npz,xyz]`` for the stage budget (each stage's
seconds and peak resident memory, the whole field and one 120 m tile of it, beside the
library's read of the same soundings from those formats).

For each size (millions of soundings) a ``reef-field`` survey is simulated at the density
needed, then timed in the same run:

* ours: :func:`mbinspect.reefs.extract_reefs` (filters, terrain, seabed, reefs, measures);
* ours + design: the same with ``design="cross2,cross1"`` (each reef fitted by its design);
* ours (paper method): the same library with ``method="paper"``;
* Open3D (if installed, ``pip install -e .[bench]``): ``remove_radius_outlier`` (r 0.5 m,
  noise if <= 3 neighbours), ``segment_plane`` (0.5 m, 3 points, 1000 iterations) and
  ``cluster_dbscan`` (eps 0.5 m, 10 points) on the points off the plane: the paper's steps,
  as a user would chain them.

``--end-to-end`` writes the ``--sizes`` field (default 3.7 M) as a three-column ASCII file
and runs, in turn and ``--repeat`` times each, ``mbinspect -v reefs FILE --crs EPSG:32617``
(figures on, as a user runs it), the same with ``--no-figures``, and
``benchmarks/open3d_steps.py FILE`` (Open3D reads the file itself, then the paper's steps):
each one's wall and CPU seconds and peak resident memory, and the ratio to Open3D's wall.

``--memory-10m`` writes the 10 M-sounding field as each of ``--memory-formats`` and, in a
fresh process each, reads it and extracts the reefs: the seconds, the main process's peak
resident memory (``ru_maxrss``) and the peak of the main process and its ASCII parsers
together (their proportional set sizes summed, sampled every 50 ms), after the read and
at the end.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import TreeMemory, best_of, table  # noqa: E402
from mbinspect.filters import radius_outlier  # noqa: E402
from mbinspect.io import write  # noqa: E402
from mbinspect.reefs import extract_reefs  # noqa: E402
from mbinspect.simulate import simulate  # noqa: E402

#: ping spacing giving about this many million soundings (256 beams, preset field)
SPACING = {0.3: 0.75, 1.0: 0.24, 3.0: 0.081, 3.7: 0.066, 10.0: 0.0243}


def open3d_pipeline(xyz: np.ndarray) -> int:
    import open3d as o3d

    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(xyz - xyz.mean(axis=0)))
    pcd, _ = pcd.remove_radius_outlier(nb_points=4, radius=0.5)
    _, inliers = pcd.segment_plane(distance_threshold=0.5, ransac_n=3, num_iterations=1000)
    reef = pcd.select_by_index(inliers, invert=True)
    labels = np.asarray(reef.cluster_dbscan(eps=0.5, min_points=10))
    return int(labels.max() + 1) if len(labels) else 0


def memory_run(path: str) -> None:
    from mbinspect.io import read

    t = time.perf_counter()
    with TreeMemory() as whole:
        cloud = read(path)
        read_s = time.perf_counter() - t
        read_peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20  # KiB -> GiB
        read_whole = whole.peak / 2**30
        res = extract_reefs(cloud)
    dt = time.perf_counter() - t
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
    worker = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 2**20  # the ASCII parsers
    print(json.dumps({"points": len(cloud), "reefs": len(res.reefs), "seconds": dt, "peak_gib": peak,
                      "worker_gib": worker, "whole_gib": whole.peak / 2**30, "read_s": read_s,
                      "read_peak_gib": read_peak, "read_whole_gib": read_whole}))


def _run_measured(name: str, cmd: list[str], folder: Path) -> tuple[float, float, float, str]:
    """Run ``cmd``: its wall and CPU seconds (it and the children it waited for), its peak
    resident GiB and the line it printed with the count of reefs or clusters."""
    import os

    with open(folder / "stdout", "w+") as out, open(folder / "stderr", "w+") as err:
        t = time.perf_counter()
        proc = subprocess.Popen(cmd, stdout=out, stderr=err)
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - t
        proc.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        text = out.read() + err.read()
    if proc.returncode != 0:
        raise SystemExit(f"{name} failed ({proc.returncode}): {text.strip()[-300:]}")
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    counted = [ln for ln in lines if " reefs in " in ln or "clusters" in ln]
    said = (counted or lines or [""])[-1]
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 2**20, said


def end_to_end(size: float, repeat: int) -> None:
    """The dense field end to end as a user runs it, beside Open3D's steps on the same file."""
    sim = simulate("reef-field", seed=0, ping_spacing=SPACING.get(size, 0.75 * 0.3 / size))
    n_true = len(sim.truth["reefs"])
    rows: dict[str, list[tuple[float, float, float, str]]] = {}
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "field.xyz"
        write(sim.cloud, path)
        del sim
        ours = [str(Path(sys.executable).parent / "mbinspect"), "-v", "reefs", str(path),
                "--crs", "EPSG:32617", "--out", f"{d}/out", "--overwrite"]
        runs = {
            "mbinspect reefs (figures on)": ours,
            "mbinspect reefs --no-figures": ours + ["--no-figures"],
            "Open3D (open3d_steps.py)": [sys.executable, str(Path(__file__).parent / "open3d_steps.py"),
                                         str(path)],
        }
        for _ in range(repeat):
            for name, cmd in runs.items():
                rows.setdefault(name, []).append(_run_measured(name, cmd, Path(d)))
    o3d_wall = min(w for w, _, _, _ in rows["Open3D (open3d_steps.py)"])
    table_rows = []
    for name, runs_of in rows.items():
        wall, cpu, _, said = min(runs_of)
        table_rows.append([name, f"{wall:.2f}", ", ".join(f"{w:.2f}" for w, _, _, _ in runs_of), f"{cpu:.2f}",
                           f"{max(m for _, _, m, _ in runs_of):.2f}", f"{wall / o3d_wall:.2f}x", said[:90]])
    print(f"{size:g} M soundings field, {n_true} reefs in the truth")
    print(table(["run", "best wall s", "every wall s", "CPU s (best)", "peak resident GiB",
                 "/ Open3D wall", "last line said"], table_rows))


def profile(sizes: list[float], tile: float = 120.0, formats: tuple[str, ...] = ("npz",)) -> None:
    """The stage budget: each stage's seconds and peak resident memory, the whole field in
    memory and one tile of ``tile`` m from its middle (what a worker of a tiled run does),
    with the library's read of the same soundings from each of ``formats`` for scale and
    the ratio of the extraction to the fastest read."""
    from mbinspect.io import read
    from mbinspect.timing import StageTimes

    rows = []
    # the compiled searches loaded once, before any time is taken
    extract_reefs(simulate("reef-field", seed=0, ping_spacing=0.75).cloud)
    for size in sizes:
        sim = simulate("reef-field", seed=0, ping_spacing=SPACING.get(size, 0.75 * 0.3 / size))
        xyz = sim.cloud.xyz
        centre = np.median(xyz[:, :2], axis=0)
        part = np.all(np.abs(xyz[:, :2] - centre) <= tile / 2, axis=1)
        reads = {}
        with tempfile.TemporaryDirectory() as d:
            for fmt in formats:
                path = Path(d) / f"field.{fmt}"
                write(sim.cloud, path)
                t = time.perf_counter()
                cloud = read(path)
                reads[fmt] = time.perf_counter() - t
        for where, pts in (("in memory", cloud.xyz), (f"one {tile:g} m tile", xyz[part])):
            times = StageTimes(memory=True)
            res = extract_reefs(pts, times=times)
            times.stop()
            label = f"{len(pts) / 1e6:.2f} M, {where}"
            rows += [[label, name, f"{sec:.2f}", f"{peak / 2**30:.2f}"] for name, sec, peak in times.rows()]
            read_s = ", ".join(f"{fmt} {sec:.2f} s" for fmt, sec in reads.items())
            rows.append([label, f"all ({len(res.reefs)} reefs; {len(pts) / times.total() / 1e6:.2f} M/s; "
                         f"the read of the file: {read_s}; extraction / fastest read "
                         f"{times.total() / min(reads.values()) * len(xyz) / len(pts):.1f}x per sounding)",
                         f"{times.total():.2f}", ""])
    print(table(["soundings", "stage", "seconds", "peak resident GiB"], rows))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--profile", action="store_true",
                    help="print the stage budget at --sizes (default then 1,3.7,10) and stop")
    ap.add_argument("--sizes", default="0.3,3")
    ap.add_argument("--memory-10m", action="store_true")
    ap.add_argument("--end-to-end", action="store_true",
                    help="time the command line and Open3D's steps on the field as an ASCII file and stop")
    ap.add_argument("--memory-formats", default="npz,xyz", help="file formats the 10 M run reads")
    ap.add_argument("--read-formats", default="npz", help="file formats whose read --profile times")
    ap.add_argument("--repeat", type=int, default=2)
    args = ap.parse_args()
    if args.profile:
        profile([float(v) for v in (args.sizes if args.sizes != "0.3,3" else "1,3.7,10").split(",")],
                formats=tuple(args.read_formats.split(",")))
        return
    if args.end_to_end:
        end_to_end(float(args.sizes) if args.sizes != "0.3,3" else 3.7, args.repeat)
        return
    rows = []
    filter_rows = []
    for size in [float(s) for s in args.sizes.split(",")]:
        sim = simulate("reef-field", seed=0, ping_spacing=SPACING.get(size, 0.75 * 0.3 / size))
        xyz = sim.cloud.xyz
        n_true = len(sim.truth["reefs"])
        ours, res = best_of(lambda c=sim.cloud: extract_reefs(c), args.repeat)
        paper, res_p = best_of(lambda c=sim.cloud: extract_reefs(c, method="paper"), args.repeat)
        designed, res_d = best_of(lambda c=sim.cloud: extract_reefs(c, design="cross2,cross1"), args.repeat)
        area = float(np.prod(np.ptp(xyz[:, :2], axis=0)))
        row = [f"{len(xyz) / 1e6:.2f} M ({len(xyz) / area:.0f} pts/m^2)", ours, f"{len(res.reefs)}/{n_true}",
               designed, paper, f"{len(res_p.reefs)}/{n_true}"]
        try:
            o3d_t, n_o3d = best_of(lambda p=xyz: open3d_pipeline(p), args.repeat)
            row += [o3d_t, f"{n_o3d}/{n_true}", f"{o3d_t / ours:.1f}x"]
        except ImportError:
            row += ["n/a", "", ""]
        rows.append(row)
        # the radius filter alone (r 0.5 m, noise if <= 3 neighbours), same points
        t_f, keep = best_of(lambda p=xyz: radius_outlier(p, radius=0.5, min_neighbors=3), args.repeat)
        frow = [f"{len(xyz) / 1e6:.2f} M", t_f, f"{(~keep).sum():,}"]
        try:
            import open3d as o3d

            pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(xyz - xyz.mean(axis=0)))
            t_o, (_, kept_idx) = best_of(lambda c=pcd: c.remove_radius_outlier(nb_points=4, radius=0.5), 1)
            frow += [t_o, f"{len(xyz) - len(kept_idx):,}", f"{t_o / t_f:.1f}x"]
        except ImportError:
            frow += ["n/a", "", ""]
        filter_rows.append(frow)
    print(table(["soundings", "ours s", "reefs", "ours + design s", "ours (paper method) s", "reefs",
                 "Open3D s", "clusters", "Open3D / ours"], rows))
    print(table(["radius filter", "ours s", "removed", "Open3D s", "removed", "Open3D / ours"],
                filter_rows))
    if args.memory_10m:
        mem_rows = []
        with tempfile.TemporaryDirectory() as d:
            sim = simulate("reef-field", seed=0, ping_spacing=SPACING[10.0])
            paths = []
            for fmt in args.memory_formats.split(","):
                paths.append(Path(d) / f"ten.{fmt}")
                write(sim.cloud, paths[-1])
            del sim
            for path in paths:
                out = subprocess.run([sys.executable, __file__, "--_memory", str(path)],
                                     capture_output=True, text=True, check=True)
                m = json.loads(out.stdout.strip().splitlines()[-1])
                mem_rows.append([f"read {path.suffix} ({path.stat().st_size / 2**20:,.0f} MiB) + extract",
                                 f"{m['points']:,}", m["reefs"], f"{m['read_s']:.1f}", f"{m['seconds']:.1f}",
                                 f"{m['read_whole_gib']:.2f}", f"{m['peak_gib']:.2f}",
                                 f"{m['whole_gib']:.2f}", f"{m['worker_gib']:.2f}"])
        print(table(["10 M run", "points", "reefs", "read s", "read + extract s", "read: all processes GiB",
                     "peak main GiB", "peak all processes GiB", "largest parser GiB"], mem_rows))


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--_memory":
        memory_run(sys.argv[2])
    else:
        main()
