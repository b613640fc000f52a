"""A whole survey through a pipeline: :func:`run_survey`.

Small surveys are read whole and run in memory. A survey larger than ``memory_limit`` (or
with ``tiled``) is streamed file by file into blocks on disk
(:func:`~mbinspect.survey.bins.bin_file`), cut into the tiles that finish soonest within a
tile's memory (:func:`~mbinspect.survey.tiles.choose_plan`), each tile with its buffer is
run through the pipeline on its own (in this process or on Dask), each object is kept by
the tile holding its centre, and the kept objects are merged once: reefs numbered and
grouped, piles renumbered, grouped into jackets and spaced.
"""

from __future__ import annotations

import os
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import DataError, NotEnoughPointsError
from ..formats import format_of
from ..grid import BYTES_PER_CELL, extent_bytes, machine_memory, pack_cells
from ..options import Options, option
from ..pipeline import Pipeline, TilePart
from ..pipelines import pipeline_named
from ..strays import stray_cells
from ..version import __version__
from .bins import STRAY_CELL, FileBins, bin_file, block_counts
from .cluster import Progress, dask_client, map_tasks, scheduler_address
from .inputs import SurveyCRS, read_survey, survey_crs
from .tiles import TilePlan, choose_plan, load_tile, tile_slices

__all__ = ["SurveyOptions", "SurveyRun", "run_survey", "run_tile", "TileTask", "TileOutcome",
           "estimate_soundings", "BYTES_PER_SOUNDING"]

#: Peak memory of the in-memory pipelines per sounding (bytes): 1.69 GiB for 10 M soundings
#: from NPZ, 4.02 GiB from ASCII (benchmarks/RESULTS.md), with a margin.
BYTES_PER_SOUNDING = 400

#: A tile's peak memory on a worker: a fixed part (the interpreter, NumPy, SciPy, the
#: Dask worker) and bytes per sounding it reads; measured 0.09 GB and 150 B in one
#: process on a reef tile of 7.8 M soundings (benchmarks/RESULTS.md), with a margin.
TILE_BASE_BYTES = 250e6
TILE_BYTES_PER_SOUNDING = 160

#: A survey held in memory whose seabed grid over its extent would take more than its
#: soundings and more than this (bytes) runs in tiles instead (a line across a wide,
#: empty extent: :func:`~mbinspect.grid.extent_bytes`).
SPARSE_BYTES = 500e6


@dataclass(frozen=True)
class SurveyOptions(Options):
    """How a survey is run: in memory or in tiles, and where the tiles run."""

    tiled: bool = option(False, help="process in tiles even when the survey fits in memory")
    tile_size: float | None = option(None, unit="m", check="positive",
                                     help="tile side (none: the side that finishes soonest with every tile "
                                          "within `tile_memory`)")
    tile_memory: float | None = option(None, unit="GB", check="positive",
                                       help="peak memory a tile may take on a worker (none: 1.8, or the "
                                            "machine's memory shared by the workers if less)")
    memory_limit: float | None = option(None, unit="GB", check="positive",
                                        help="tile the survey when reading it whole would need more "
                                             "(none: half the machine's memory)")
    workers: int | None = option(None, check="count", help="local Dask workers (none: one per core)")
    scheduler: str | None = option(None, check=scheduler_address,
                                   help="a running Dask scheduler, tcp://HOST:PORT (none: a local cluster)")
    chunk: int = option(2_000_000, check="count", cli=False, help="soundings per chunk read")


@dataclass(frozen=True, eq=False)
class SurveyRun:
    """What :func:`run_survey` returns: the pipeline's result, the soundings for figures
    (all of them in memory; a thinned plan sample when tiled) and how it ran."""

    result: Any
    points: np.ndarray
    tiled: bool
    tiles: int = 1
    info: Mapping[str, Any] = field(default_factory=dict)


def estimate_soundings(paths: Sequence[Path], fmt: str | None = None) -> int:
    """Soundings in the files: exact where the format's header says (LAS/LAZ), from the
    size and the format's bytes per sounding otherwise."""
    total = 0
    for p in paths:
        row = format_of(p, fmt)
        if row.count is not None:
            total += row.count(Path(p))
        else:
            total += int(os.path.getsize(p) / row.bytes_per_sounding)
    return total


def run_survey(pipeline: str | Pipeline, paths: Sequence[str | os.PathLike[str]], options: Any,
               survey: SurveyOptions, *,
               read_options: Mapping[str, Any] | None = None, extra: Mapping[str, Any] | None = None,
               workdir: str | os.PathLike[str] | None = None, progress: Progress | None = None,
               note: Callable[[str], None] | None = None, tile_function: Callable[..., Any] | None = None,
               stage_progress: Callable[[str], Callable[[float], None]] | None = None) -> SurveyRun:
    """Run a pipeline over a survey of one or many files.

    Parameters
    ----------
    pipeline : str or Pipeline
        A name of :data:`mbinspect.pipelines.PIPELINES` (``"reefs"``, ``"piles"``) or a
        pipeline.
    paths : sequence of path-like
        The survey's files (:func:`~mbinspect.survey.inputs.expand_inputs`).
    options : ReefOptions or PileOptions
    survey : SurveyOptions
    read_options : mapping, optional
        For :func:`mbinspect.io.read`.
    extra : mapping, optional
        ``reference`` (reefs) or ``design`` (piles).
    workdir : path-like, optional
        Where tile parts go (a temporary folder, removed after, by default).
    progress : callable, optional
        ``(done, total, seconds_left)`` over files, then over tiles.
    note : callable, optional
        Told what the run does (a line of text).
    tile_function : callable, optional
        Runs one tile (default: the pipeline's own; tests use it to break a worker).
    stage_progress : callable, optional
        A survey run in one piece: given a label (``"reading"``, then the pipeline's name),
        returns the callback that is told the fraction of that step done.

    Returns
    -------
    SurveyRun
    """
    pipe = pipeline_named(pipeline)
    files = [Path(p) for p in paths]
    ropts = dict(read_options or {})
    extra = dict(extra or {})
    say = note or (lambda s: None)
    n_est = estimate_soundings(files, ropts.get("format"))
    limit = (survey.memory_limit * 1e9) if survey.memory_limit else machine_memory() / 2
    tiled = survey.tiled or n_est * BYTES_PER_SOUNDING > limit or survey.scheduler is not None
    if not tiled:
        def stage(label: str) -> Callable[[float], None] | None:
            return None if stage_progress is None else stage_progress(label)

        cloud = read_survey(files, progress=stage("reading"), **ropts)
        cell = pipe.grid_cell(options)
        grid = extent_bytes(cloud.xyz, cell)
        if grid > max(len(cloud) * BYTES_PER_SOUNDING, SPARSE_BYTES):
            tiled = True
            say(f"the soundings' extent would take a seabed grid of {grid / 1e9:.1f} GB in one piece "
                f"(`seabed_cell` {cell:g} m) for {len(cloud):,} soundings: run in tiles "
                "that follow the soundings")
        else:
            result = pipe.run(cloud, options, extra, stage(pipe.name))
            return SurveyRun(result, cloud.xyz, False, 1, {"soundings": len(cloud), "files": len(files)})
    buffer = pipe.buffer(options)
    block = TilePlan.block_for(buffer, survey.tile_size)
    say(f"{len(files)} file(s), about {n_est:,} soundings: binned in blocks of {block:g} m")
    with tempfile.TemporaryDirectory(prefix="mbinspect-tiles-", dir=workdir) as tmp:
        use_dask = survey.scheduler is not None or survey.workers != 1
        with _maybe_client(use_dask, survey) as client:
            bins = map_tasks(_bin_one, [(str(f), k) for k, f in enumerate(files)], client=client, block=block,
                             progress=progress, workdir=tmp, read_options=ropts, chunk=survey.chunk,
                             fields=pipe.tile_fields(options), target=_target(files, ropts))
            plan, sizing = _plan(bins, buffer, block, survey, _worker_count(client, survey),
                                 pipe.grid_cell(options))
            tile_opts, notes = pipe.tile_options(options, extra or {})
            if not sizing.get("within_budget", True):
                notes.append(f"tiled: the smallest tiles the buffer allows read {sizing['largest']:,} "
                             f"soundings, more than `tile_memory` holds")
            tasks = _tile_tasks(bins, plan, pipe, tile_opts, [str(f) for f in files], notes)
            say(f"{sum(b.n for b in bins):,} soundings in {len(tasks)} tiles of {plan.size:g} m with a "
                f"{plan.reach * plan.block:g} m buffer")
            fn = tile_function or run_tile
            outcomes = map_tasks(fn, tasks, client=client, progress=progress)
    result = _merge(pipe, outcomes, options, extra, files, bins, notes)
    pts = np.concatenate([o.sample for o in outcomes]) if outcomes else np.zeros((0, 3))
    peaks: dict[int, int] = {}
    for o in outcomes:
        if "pid" in o.stats:
            peaks[o.stats["pid"]] = max(peaks.get(o.stats["pid"], 0), o.stats["peak_rss"])
    return SurveyRun(result, pts, True, len(tasks),
                     {"soundings": sum(b.n for b in bins), "files": len(files), "tile_size": plan.size,
                      "tile_buffer": plan.reach * plan.block, "worker_peak_rss": peaks,
                      "tile_soundings": [o.n for o in outcomes],
                      "tile_seconds": [o.stats.get("seconds") for o in outcomes]})


def _target(files: list[Path], read_options: Mapping[str, Any]) -> SurveyCRS | None:
    """The CRS every file's chunks are brought to: needed where a survey has several files,
    or one read in chunks (a LAS file in degrees takes one UTM zone for all its chunks)."""
    if len(files) > 1 or format_of(files[0], read_options.get("format")).chunks is not None:
        return survey_crs(files, read_options)
    return None


def _bin_one(item: tuple[str, int], **kwargs: Any) -> FileBins:
    path, k = item
    return bin_file(path, k, **kwargs)


class _NoClient:
    """In place of a Dask client: the tasks run in this process."""

    def __enter__(self) -> None:
        return None

    def __exit__(self, *exc: Any) -> None:
        return None


def _maybe_client(use: bool, survey: SurveyOptions) -> Any:
    if not use:
        return _NoClient()
    return dask_client(scheduler=survey.scheduler, workers=survey.workers)


def _worker_count(client: Any, survey: SurveyOptions) -> int:
    if client is None:
        return 1
    if survey.scheduler is not None:
        return max(1, len(client.scheduler_info().get("workers", {})))
    return min(survey.workers or os.cpu_count() or 1, os.cpu_count() or 1)


def _plan(bins: Sequence[FileBins], buffer: float, block: float, survey: SurveyOptions,
          workers: int, cell: float) -> tuple[TilePlan, dict[str, Any]]:
    """The given tile size, or the one :func:`~mbinspect.survey.tiles.choose_plan` finds
    fastest within the memory of a tile."""
    if survey.tile_size is not None:
        return TilePlan(survey.tile_size, buffer, block), {}
    memory = survey.tile_memory * 1e9 if survey.tile_memory else min(1.8e9, machine_memory() * 0.8 / workers)
    budget = max(memory - TILE_BASE_BYTES, 0.0) / TILE_BYTES_PER_SOUNDING
    blocks, counts = block_counts(bins)
    u, _, is_stray = _strays(bins)
    if is_stray.any():  # stray soundings are left out: they do not stretch the tiles
        centre = np.floor((blocks + 0.5) * block / STRAY_CELL).astype(np.int64)
        keep = ~np.isin(pack_cells(centre[:, 0], centre[:, 1]), pack_cells(u[is_stray, 0], u[is_stray, 1]))
        blocks, counts = blocks[keep], counts[keep]
    return choose_plan(blocks, counts, buffer, block, budget=budget, workers=workers,
                       area_weight=BYTES_PER_CELL / cell**2 / TILE_BYTES_PER_SOUNDING)


@dataclass(frozen=True)
class TileTask:
    """One tile's work: where its parts are and what to run on them."""

    key: tuple[int, int]
    slices: tuple[tuple[str, tuple[tuple[int, int], ...]], ...]
    plan: TilePlan
    pipeline: Pipeline
    options: Any
    stray: np.ndarray
    line_offsets: Mapping[int, tuple[int, np.ndarray]]
    files: tuple[str, ...]
    crs: str | None


@dataclass(frozen=True)
class TileOutcome:
    """What a tile reports: the pipeline's part (its own objects, centre in its square, and
    what it saw) and how the tile ran."""

    key: tuple[int, int]
    part: TilePart
    n: int
    sample: np.ndarray
    stats: Mapping[str, Any]


def _strays(bins: Sequence[FileBins]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The survey's occupied stray-search cells, their soundings and which are stray."""
    cells = np.concatenate([b.cells for b in bins])
    counts = np.concatenate([b.cell_counts for b in bins])
    u, inv = np.unique(cells, axis=0, return_inverse=True)
    total = np.bincount(inv.ravel(), weights=counts)
    return u, total, stray_cells(u, total)


def _tile_tasks(bins: Sequence[FileBins], plan: TilePlan, pipe: Pipeline, options: Any,
                files: Sequence[str], notes: list[str]) -> list[TileTask]:
    """A task per tile; the survey's stray soundings (far from the rest) named in ``notes``."""
    u, total, is_stray = _strays(bins)
    stray = u[is_stray]
    if is_stray.any():
        gap = np.median(u[is_stray], axis=0) - np.median(u[~is_stray], axis=0)
        far = float(np.hypot(*gap)) * STRAY_CELL
        n = int(total[is_stray].sum())
        notes.append(f"{n:,} sounding{'s lie' if n > 1 else ' lies'} {far / 1000:.1f} km from the rest of "
                     "the survey (a navigation jump?) and were left out")
    offsets: dict[int, tuple[int, np.ndarray]] = {}
    first = 1
    for b in bins:
        offsets[b.file] = (first, b.lines)
        first += len(b.lines)
    reads, _ = tile_slices(plan, bins)
    crs = bins[0].crs
    return [TileTask(k, tuple(reads[k]), plan, pipe, options, stray, offsets, tuple(files), crs)
            for k in sorted(reads)]


def run_tile(task: TileTask) -> TileOutcome:
    """Run the pipeline on one tile and keep what it owns; ``stats`` records the worker's
    process, its peak resident memory so far (bytes) and the seconds the tile took."""
    import resource

    t0 = time.perf_counter()
    out = _run_tile(task)
    _give_back_memory()
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    return replace(out, stats={**out.stats, "pid": os.getpid(), "peak_rss": peak,
                               "seconds": time.perf_counter() - t0})


def _give_back_memory() -> None:
    """Return the heap a tile freed to the system (glibc's ``malloc_trim``), so that a worker's
    next tile does not grow its resident memory over freed gaps; nothing elsewhere."""
    import ctypes
    import ctypes.util

    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name) if name else None
        if libc is not None and hasattr(libc, "malloc_trim"):
            libc.malloc_trim(0)
    except OSError:
        pass


def _run_tile(task: TileTask) -> TileOutcome:
    cloud = load_tile(task.slices, line_offsets=task.line_offsets, stray=task.stray, files=task.files,
                      crs=task.crs)
    if len(cloud) == 0:  # a tile that held only stray soundings
        return TileOutcome(task.key, TilePart(stats={"n_own": 0}), 0, np.zeros((0, 3)), {})
    i, j = task.plan.home(cloud.xyz)
    own = (i == task.key[0]) & (j == task.key[1])
    sample = _thin(cloud.xyz[own])
    x0, y0, x1, y1 = task.plan.core(*task.key)

    def mine(x: float, y: float) -> bool:
        hi, hj = task.plan.home(np.array([[x, y]]))
        return bool(hi[0] == task.key[0] and hj[0] == task.key[1])

    try:
        part = task.pipeline.run_tile(cloud, task.options, mine)
    except (DataError, NotEnoughPointsError) as exc:
        where = f"tile {task.key[0]},{task.key[1]} ({x0:.0f}–{x1:.0f} E, {y0:.0f}–{y1:.0f} N)"
        part = TilePart(warnings=(f"{where}: {exc}",), stats={"refused": str(exc), "n_own": int(own.sum())})
    else:
        part = replace(part, stats={**part.stats, "n_own": int(own.sum())})
    return TileOutcome(task.key, part, len(cloud), sample, {})


def _thin(xyz: np.ndarray, cell: float = 0.5) -> np.ndarray:
    """The median sounding (by z) of each ``cell`` m plan cell: a plan sample for the maps
    of a tiled run, reefs kept and lone spikes left out."""
    if len(xyz) == 0:
        return np.zeros((0, 3))
    ij = np.floor(xyz[:, :2] / cell).astype(np.int64)
    ij -= ij.min(axis=0)
    key = ij[:, 0] * (int(ij[:, 1].max()) + 1) + ij[:, 1]
    order = np.lexsort((xyz[:, 2], key))
    k = key[order]
    starts = np.flatnonzero(np.r_[True, k[1:] != k[:-1]])
    ends = np.r_[starts[1:], len(k)]
    return xyz[order[(starts + ends - 1) // 2]]


def _merge(pipe: Pipeline, outcomes: Sequence[TileOutcome], options: Any, extra: Mapping[str, Any],
           files: Sequence[Path], bins: Sequence[FileBins], notes: Sequence[str]) -> Any:
    """The tiles' parts as one result, merged by the pipeline with the survey's parameters."""
    holding = [o for o in outcomes if o.part.stats.get("n_own", 0) > 0]  # tiles with soundings of their own
    refused = [o.part.stats["refused"] for o in holding if "refused" in o.part.stats]
    if refused and len(refused) == len(holding):
        # every tile with soundings of its own says the data cannot support an answer: the
        # answer a whole run gives
        raise DataError(f"{refused[0]} (so says every tile of the survey: {len(refused)})")
    # a warning every tile gives alike is said once
    warnings = list(dict.fromkeys([*notes, *(w for o in outcomes for w in o.part.warnings)]))
    parameters = {**options.to_dict(),
                  "input": {"source": f"{len(files)} files", "n_points": sum(b.n for b in bins),
                            "crs": bins[0].crs},
                  "software": f"mbinspect {__version__}", "tiles": len(outcomes)}
    return pipe.merge([o.part for o in outcomes], options, extra, parameters, warnings)
