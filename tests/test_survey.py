"""Whole surveys: many inputs, tiles, Dask, the merge and traceability, against the
in-memory run and the simulator's truth."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from mbinspect.cli import main
from mbinspect.errors import FileAccessError, InputError, ParameterError
from mbinspect.io import PointCloud, write
from mbinspect.piles import PileOptions
from mbinspect.reefs import ReefOptions
from mbinspect.simulate import simulate_lines
from mbinspect.survey import expand_inputs, read_survey
from mbinspect.survey.bins import bin_file, block_counts
from mbinspect.survey.run import SurveyOptions, run_survey, run_tile
from mbinspect.survey.tiles import TilePlan, choose_plan, load_tile, tile_slices

# four groups of nine reefs; tiles of 126 m or more (over twice the 62 m buffer): four
# tiles, reefs on their borders
REEF_SCENE = {"groups": "cross2,cross1,cross1,cross2", "per_group": 9, "ping_spacing": 0.8, "close_pairs": 1}
REEFS = ReefOptions(seabed="grid")


@pytest.fixture(scope="module")
def reef_lines(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict]:
    folder = tmp_path_factory.mktemp("reef-lines")
    truth = simulate_lines("reef-field", folder, seed=5, **REEF_SCENE)
    return folder, truth


@pytest.fixture(scope="module")
def in_memory(reef_lines: tuple[Path, dict]):
    folder, _ = reef_lines
    return run_survey("reefs", expand_inputs([folder]), REEFS, SurveyOptions())


def _same_reefs(a, b) -> None:
    assert len(a.reefs) == len(b.reefs)
    for p, q in zip(a.reefs, b.reefs, strict=True):
        assert p.id == q.id
        assert abs(p.x - q.x) < 1e-3 and abs(p.y - q.y) < 1e-3
        assert abs(p.height - q.height) < 1e-3 and abs(p.area - q.area) < 1e-6
        assert p.beam_footprint == pytest.approx(q.beam_footprint, abs=1e-3, nan_ok=True)
        assert p.sources == q.sources


def test_expand_inputs_files_folders_globs(tmp_path: Path) -> None:
    for name in ("a.laz", "b.xyz", "notes.md"):
        (tmp_path / name).write_text("")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "c.gsf").write_text("")
    got = expand_inputs([tmp_path / "b.xyz", tmp_path, str(tmp_path / "*.laz")])
    assert [p.name for p in got] == ["b.xyz", "a.laz", "c.gsf"]  # each once, in order
    with pytest.raises(FileAccessError, match="no such file"):
        expand_inputs([tmp_path / "missing.laz"])
    with pytest.raises(FileAccessError, match="matches no file"):
        expand_inputs([str(tmp_path / "*.kmall")])


def test_read_survey_keeps_file_line_and_ping(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    for k in range(2):
        xyz = rng.uniform(0, 10, (50, 3)) + [100 * k, 0, -20]
        write(PointCloud(xyz, {"ping": np.arange(50), "line": np.repeat([1, 2], 25)}), tmp_path / f"l{k}.npz")
    cloud = read_survey(sorted(tmp_path.glob("*.npz")))
    assert len(cloud) == 100
    assert cloud.fields["file"].tolist() == [0] * 50 + [1] * 50
    assert cloud.fields["line"].tolist() == [1] * 25 + [2] * 25 + [3] * 25 + [4] * 25
    assert cloud.fields["ping"][50] == 0
    write(PointCloud(rng.uniform(0, 10, (50, 3)), crs="EPSG:32631"), tmp_path / "other.npz")
    with pytest.raises(InputError, match=r"other.npz: its CRS \(WGS 84 / UTM zone 31N \(EPSG:32631\)\) "
                                         r"differs from .*l0.npz's \(none\)"):
        read_survey([tmp_path / "l0.npz", tmp_path / "other.npz"])


def test_binning_puts_every_sounding_home_once_and_buffers_the_edges(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    xyz = np.column_stack([rng.uniform(0, 300, 5000), rng.uniform(0, 300, 5000), np.full(5000, -10.0)])
    write(PointCloud(xyz[:4000], {"ping": np.arange(4000)}), tmp_path / "a.laz")
    xyz[4000:, 0] = rng.uniform(1, 2, 1000)  # a line along one column of blocks: one range of rows
    write(PointCloud(xyz[4000:], {"ping": np.arange(4000, 5000)}), tmp_path / "b.laz")
    plan = TilePlan(100.0, 20.0, TilePlan.block_for(20.0, 100.0))
    (tmp_path / "tiles").mkdir()
    bins = [bin_file(tmp_path / f"{name}.laz", k, plan.block, tmp_path / "tiles", chunk=1200)
            for k, name in enumerate("ab")]
    reads, owns = tile_slices(plan, bins)
    assert sum(owns.values()) == 5000 and [b.n for b in bins] == [4000, 1000]
    assert [len(b.chunks) for b in bins] == [4, 1]
    reach = plan.reach * plan.block
    assert 20.0 <= reach < 20.0 + plan.block
    got = 0
    for key, slices in reads.items():
        tile = load_tile(slices, line_offsets={0: (1, bins[0].lines), 1: (2, bins[1].lines)})
        i, j = plan.home(tile.xyz)
        home = (i == key[0]) & (j == key[1])
        got += int(home.sum())
        x0, y0, x1, y1 = plan.core(*key)
        # every sounding within the buffer of the tile's square is in the tile, in the files' order
        want = ((xyz[:, 0] >= x0 - reach) & (xyz[:, 0] < x1 + reach)
                & (xyz[:, 1] >= y0 - reach) & (xyz[:, 1] < y1 + reach))
        assert tile.fields["ping"].tolist() == np.flatnonzero(want).tolist()
        assert tile.fields["line"].tolist() == [1 + int(p >= 4000) for p in np.flatnonzero(want)]
    assert got == 5000
    # the tiles chosen from the block counts: none over the budget, the fastest on 2 workers
    blocks, counts = block_counts(bins)
    assert counts.sum() == 5000
    chosen, info = choose_plan(blocks, counts, 20.0, plan.block, budget=3000, workers=2)
    assert info["within_budget"] and info["largest"] <= 3000 and info["tiles"] >= 2
    one, info1 = choose_plan(blocks, counts, 20.0, plan.block, budget=1e9, workers=1)
    assert info1["tiles"] == 1 and info1["read"] == 5000  # one worker, no memory limit: one tile
    with pytest.raises(ParameterError, match="tile_buffer"):
        TilePlan(30.0, 20.0, 10.0)


def test_line_files_carry_the_truth(reef_lines: tuple[Path, dict]) -> None:
    folder, truth = reef_lines
    files = sorted(folder.glob("line_*.laz"))
    assert len(files) == len(truth["files"]) >= 3
    assert sum(truth["counts"].values()) == truth["n_soundings"]
    assert len(truth["reefs"]) == 36


def test_in_memory_survey_finds_every_reef_with_its_sources(reef_lines, in_memory) -> None:
    folder, truth = reef_lines
    reefs = in_memory.result.reefs
    xy = np.array([[t["x"], t["y"]] for t in truth["reefs"]])
    d = np.array([np.hypot(*(xy - [r.x, r.y]).T).min() for r in reefs])
    assert len(reefs) == 36 and d.max() < 0.5
    for r in reefs:  # every reef names the line files and pings behind it
        assert r.sources and all(Path(s["file"]).name.startswith("line_") and s["pings"] for s in r.sources)
        assert sum(s["soundings"] for s in r.sources) > 20


def _straddles(reef, size: float) -> bool:
    xy = np.asarray(reef.outline)
    return bool((np.floor(xy.min(axis=0) / size) != np.floor(xy.max(axis=0) / size)).any())


def _border_tile_size(result) -> float:
    """A tile size (over twice the buffer) whose tile borders cut through a reef."""
    for size in np.arange(126.0, 200.0, 0.5):
        if any(_straddles(r, size) for r in result.reefs):
            return float(size)
    raise AssertionError("no tile size puts a reef across a border")


@pytest.mark.slow
def test_tiled_on_two_local_workers_gives_the_in_memory_result(reef_lines, in_memory) -> None:
    folder, _ = reef_lines
    size = _border_tile_size(in_memory.result)
    tiled = run_survey("reefs", expand_inputs([folder]), REEFS, SurveyOptions(tiled=True, tile_size=size,
                                                                               workers=2))
    assert tiled.tiled and tiled.tiles >= 4
    _same_reefs(in_memory.result, tiled.result)
    # a reef across a tile border is read by both tiles and reported once, by the tile
    # holding its centre
    assert any(_straddles(r, size) for r in tiled.result.reefs)


@pytest.mark.slow
def test_a_killed_worker_is_replaced_and_the_result_does_not_change(reef_lines, in_memory, tmp_path) -> None:
    folder, _ = reef_lines
    marker = tmp_path / "killed"

    def dies_once(task):
        if not marker.exists():
            marker.write_text(str(os.getpid()))
            os._exit(1)  # the worker process dies mid-task
        return run_tile(task)

    tiled = run_survey("reefs", expand_inputs([folder]), REEFS,
                       SurveyOptions(tiled=True, tile_size=130.0, workers=2), tile_function=dies_once)
    assert marker.exists()
    _same_reefs(in_memory.result, tiled.result)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.mark.slow
def test_cli_runs_on_a_real_scheduler_on_loopback(reef_lines, in_memory, tmp_path) -> None:
    folder, _ = reef_lines
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = {**os.environ, "DASK_DISTRIBUTED__LOGGING__DISTRIBUTED": "error"}
    procs = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                               "--port", str(port), "--no-dashboard"], env=env,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        for _ in range(2):
            procs.append(subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address,
                                           "--nthreads", "1", "--no-dashboard", "--memory-limit", "2GB"],
                                          env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        from dask.distributed import Client

        deadline = time.time() + 60
        while True:
            try:
                with Client(address, timeout="5s") as c:
                    c.wait_for_workers(2, timeout=60)
                break
            except OSError:
                if time.time() > deadline:
                    raise
                time.sleep(0.5)
        out = tmp_path / "out"
        code = main(["reefs", str(folder / "*.laz"), "--seabed", "grid", "--scheduler", address,
                     "--tile-size", "130", "--out", str(out), "--no-figures"])
        assert code == 0
        got = json.loads((out / "reefs.json").read_text())
        want = in_memory.result.to_dict()["reefs"]
        assert [(r["id"], round(r["x"], 3), round(r["y"], 3)) for r in got["reefs"]] == \
            [(r["id"], round(r["x"], 3), round(r["y"], 3)) for r in want]
        assert len(got["parameters"]["input"]["files"]) == len(list(folder.glob("*.laz")))
        # the soundings of one reef, with their file and ping
        csv = tmp_path / "reef1.csv"
        assert main(["soundings", str(out / "reefs.json"), "1", "--out", str(csv)]) == 0
        rows = csv.read_text().splitlines()
        assert rows[0].startswith("x,y,z,file,ping") and len(rows) > 20
        r1 = got["reefs"][0]
        ping_sets = {s["file"]: s["pings"] for s in r1["sources"]}
        for line in rows[1:]:
            f, ping = line.split(",")[3], int(line.split(",")[4])
            assert any(a <= ping <= b for a, b in ping_sets[f])
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            p.wait(timeout=20)


@pytest.mark.slow
def test_tiled_reefs_told_the_beam_are_the_in_memory_reefs(tmp_path: Path) -> None:
    """Each tile keeps the beam angles and intensities the beam correction needs (a tile
    that kept only the pings placed every transducer at the surface over its sounding: tops
    0.33 m off, areas 13 % off); the designs fitted as heard, each sounding's bloom from its
    own transducer, are the same in each tile as in one cloud."""
    simulate_lines("reef-field", tmp_path, seed=5, beam_across_deg=1.0, **REEF_SCENE)
    files = expand_inputs([tmp_path])
    opts = ReefOptions(seabed="grid", beam_correction=True, beam_width_deg=1.0, design="cross2,cross1")
    whole = run_survey("reefs", files, opts, SurveyOptions()).result
    tiled = run_survey("reefs", files, opts, SurveyOptions(tiled=True, tile_size=130.0, workers=1))
    assert tiled.tiles >= 4
    _same_reefs(whole, tiled.result)
    assert sum(bool(r.design) for r in tiled.result.reefs) >= 0.7 * len(tiled.result.reefs)  # 28 of 36
    scales = [r.design_scale for r in tiled.result.reefs]
    assert [r.design_scale for r in whole.reefs] == pytest.approx(scales, abs=1e-3, nan_ok=True)
    assert all(0.2 < r.beam_footprint < 0.6 for r in tiled.result.reefs)  # 1° at 17 m, 1-2 depths away


@pytest.mark.slow
@pytest.mark.parametrize("beam", [0.0, 1.0])
def test_tiled_piles_are_the_in_memory_piles(tmp_path: Path, beam: float) -> None:
    """Thin beams, and 1° beams with each tile's piles seen through them (issue 28)."""
    truth = simulate_lines("jacket", tmp_path, seed=3, ping_spacing=0.5, beam_across_deg=beam)
    files = expand_inputs([tmp_path / "*.laz"])
    opts = PileOptions(radius=truth["piles"][0]["radius"], beam_width_deg=beam)
    whole = run_survey("piles", files, opts, SurveyOptions()).result
    tiled = run_survey("piles", files, opts, SurveyOptions(tiled=True, tile_size=40.0, workers=1)).result
    assert len(whole.piles) == len(tiled.piles) == 4
    for p, q in zip(whole.piles, tiled.piles, strict=True):
        assert (p.id, p.group) == (q.id, q.group)
        assert abs(p.x - q.x) < 1e-3 and abs(p.y - q.y) < 1e-3 and abs(p.sigma_xy - q.sigma_xy) < 1e-6
    assert [round(s.distance, 4) for s in whole.spacings] == [round(s.distance, 4) for s in tiled.spacings]
    # the top levels are fitted with the lines' offsets across the tiles' piles, as in one cloud
    assert all(len(p.top_lines) >= 2 for p in tiled.piles)
    assert [round(p.top_z, 5) for p in whole.piles] == [round(p.top_z, 5) for p in tiled.piles]
    assert [round(v.sigma, 5) for v in whole.levels] == [round(v.sigma, 5) for v in tiled.levels]
    xy = np.array([[t["x"], t["y"]] for t in truth["piles"]])
    assert max(np.hypot(*(xy - [p.x, p.y]).T).min() for p in tiled.piles) < 0.05
    assert tiled.piles[0].sources[0]["file"].endswith(".laz")
    assert any("seen through 1° beams" in w for w in tiled.warnings) == (beam > 0)


def test_bad_inputs_are_one_line_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["reefs", str(tmp_path / "*.laz"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "matches no file" in err
    assert main(["reefs", str(tmp_path), "--tile-size", "-5", "--out", str(tmp_path / "o")]) == 2
    assert "--tile-size" in capsys.readouterr().err


def _children(pid: int) -> list[int]:
    """Live processes descending from ``pid`` (Linux /proc)."""
    parent: dict[int, int] = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                fields = (d / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if fields[0] != "Z":
                parent[int(d.name)] = int(fields[1])
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        kids = [c for c, pp in parent.items() if pp == p]
        out += kids
        todo += kids
    return out


@pytest.mark.slow
@pytest.mark.skipif(sys.platform != "linux", reason="signals and /proc as on Linux")
def test_ctrl_c_stops_the_cluster_and_leaves_nothing(reef_lines, tmp_path) -> None:
    import shutil
    import signal

    folder, _ = reef_lines
    exe = shutil.which("mbinspect") or str(Path(sys.executable).with_name("mbinspect"))
    work = tmp_path / "w"
    work.mkdir()
    p = subprocess.Popen([exe, "reefs", str(folder), "--tiled", "--workers", "2", "--tile-size", "130",
                          "--out", str(work / "out")],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.monotonic() + 60
    while len(_children(p.pid)) < 2 and time.monotonic() < deadline:  # the cluster's worker processes
        time.sleep(0.1)
    assert len(_children(p.pid)) >= 2, "the local cluster did not start"
    kids = _children(p.pid)
    t = time.monotonic()
    # to the whole process group, as a terminal's Ctrl-C: the workers took it too and printed
    # a KeyboardInterrupt traceback each (4 of 16 runs)
    os.killpg(p.pid, signal.SIGINT)
    _, err = p.communicate(timeout=20)
    assert p.returncode == 130, err
    assert time.monotonic() - t < 5
    assert "Traceback" not in err
    time.sleep(0.5)
    alive = [k for k in kids if Path(f"/proc/{k}").exists() and
             (Path(f"/proc/{k}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z")]
    assert alive == []
    assert list(work.iterdir()) == []  # no output, no staging folder, no tile parts


@pytest.mark.slow
@pytest.mark.skipif(sys.platform != "linux", reason="signal masks and a fork server as on Linux")
def test_a_local_cluster_leaves_ctrl_c_to_the_watcher() -> None:
    # Python's multiprocessing unblocks SIGINT in the thread that starts its resource tracker:
    # a Ctrl-C then reached the main thread, past the watcher that silences the libraries
    script = ("import signal\n"
              "from mbinspect import interrupt\n"
              "interrupt.install()\n"
              "from mbinspect.survey.cluster import dask_client\n"
              "with dask_client(workers=2):\n"
              "    print(signal.SIGINT in signal.pthread_sigmask(signal.SIG_BLOCK, set()))\n")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "True"
