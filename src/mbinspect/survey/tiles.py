"""A survey binned once into square blocks on disk, cut into square tiles of whole blocks
with a buffer, and a tile read back as one cloud.

Each file is streamed in chunks; each chunk is sorted by block and written once as a NumPy
``.npy`` file of one structured array (x, y, z as float64 and every field of the chunk at
its own type), with the offsets of its blocks. A tile reads the slices of its blocks and
of those within its buffer through a memory map: a sounding is written once, whatever the
tiles, and the tiles are chosen after binning from the exact count in every block
(:func:`choose_plan`), so that no tile outgrows a worker's memory. Exact to the bit, with no
dependency beyond NumPy.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..cloud import PointCloud
from ..errors import ParameterError
from ..grid import pack_cells, unpack_cells
from .bins import ROW, STRAY_CELL, FileBins

__all__ = ["TilePlan", "choose_plan", "tile_slices", "load_tile", "BLOCKS_PER_BUFFER"]

#: Blocks across a tile's buffer: finer blocks fit the buffer closer and cost more slices.
BLOCKS_PER_BUFFER = 4


@dataclass(frozen=True)
class TilePlan:
    """Square tiles of ``size`` m, each a whole number of ``block`` m blocks (blocks from
    (0, 0), tiles from the block ``origin``), read with the whole blocks within ``buffer`` m
    around it.

    A sounding belongs to the tile whose square holds it (its home) and is also read by
    every tile whose buffer holds its block, so that each stage of a tile sees what it needs
    near the tile's edge; an object is reported by its centre's home tile only.

    Examples
    --------
    >>> plan = TilePlan(100.0, 10.0, 10.0)
    >>> ti, tj, rows = plan.tiles_of_blocks(np.array([5, 9]), np.array([5, 5]))
    >>> sorted(zip(ti.tolist(), tj.tolist(), rows.tolist()))
    [(0, 0, 0), (0, 0, 1), (1, 0, 1)]
    """

    size: float
    buffer: float
    block: float
    origin: tuple[int, int] = (0, 0)

    def __post_init__(self) -> None:
        if not (self.size > 0 and math.isfinite(self.size)):
            raise ParameterError(f"tile_size: {self.size}; expected a positive number of metres",
                                 option="tile_size")
        if not (0 <= self.buffer < self.size / 2):
            raise ParameterError(f"tile_buffer: {self.buffer:g} m; expected at least 0 and under half the "
                                 f"tile size ({self.size / 2:g} m): give a larger tile_size",
                                 option="tile_size")
        if not (self.block > 0 and abs(self.size / self.block - round(self.size / self.block)) < 1e-9):
            raise ParameterError(f"tile block: {self.block:g} m; expected a whole fraction of the tile size "
                                 f"{self.size:g} m", option="tile_size")

    @staticmethod
    def block_for(buffer: float, size: float | None = None) -> float:
        """The binning block for a buffer: :data:`BLOCKS_PER_BUFFER` across it, made a whole
        fraction of ``size`` when the tile size is given."""
        target = buffer / BLOCKS_PER_BUFFER if buffer > 0 else (size or 50.0)
        if size is None:
            return float(target)
        return float(size / max(1, math.ceil(size / target - 1e-9)))

    @property
    def blocks(self) -> int:
        """Blocks along a tile's side."""
        return int(round(self.size / self.block))

    @property
    def reach(self) -> int:
        """Blocks read beyond a tile's square on each side."""
        return int(math.ceil(self.buffer / self.block - 1e-9))

    def block_of(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The block (column, row) of each point."""
        xy = np.asarray(xy, np.float64)
        return (np.floor(xy[:, 0] / self.block).astype(np.int64),
                np.floor(xy[:, 1] / self.block).astype(np.int64))

    def home(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The home tile (column, row) of each point: the tile of its block."""
        bi, bj = self.block_of(xy)
        return (bi - self.origin[0]) // self.blocks, (bj - self.origin[1]) // self.blocks

    def core(self, i: int, j: int) -> tuple[float, float, float, float]:
        """A tile's own square: ``(x0, y0, x1, y1)``."""
        x0, y0 = self.origin[0] * self.block, self.origin[1] * self.block
        return (x0 + i * self.size, y0 + j * self.size, x0 + (i + 1) * self.size, y0 + (j + 1) * self.size)

    def tiles_of_blocks(self, bi: np.ndarray, bj: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every (tile, block) pair where the tile reads the block: the tiles' columns and
        rows, and the blocks' rows in ``bi``, ``bj``."""
        k, b = self.blocks, self.reach
        bi, bj = np.asarray(bi) - self.origin[0], np.asarray(bj) - self.origin[1]
        lo_i, hi_i = (bi - b) // k, (bi + b) // k
        lo_j, hi_j = (bj - b) // k, (bj + b) // k
        span = (2 * b) // k + 1
        ti, tj, rows = [], [], []
        for di in range(span + 1):
            for dj in range(span + 1):
                r = np.flatnonzero((lo_i + di <= hi_i) & (lo_j + dj <= hi_j))
                ti.append(lo_i[r] + di)
                tj.append(lo_j[r] + dj)
                rows.append(r)
        return np.concatenate(ti), np.concatenate(tj), np.concatenate(rows)


def _tile_loads(plan: TilePlan, blocks: np.ndarray, counts: np.ndarray, area_weight: float = 0.0
                ) -> np.ndarray:
    """Soundings each tile reads (its blocks and buffer), for the tiles that hold any of
    their own; plus ``area_weight`` soundings' worth per m² of the rectangle its read
    blocks span (its seabed grids span that, however few soundings it holds)."""
    ti, tj, rows = plan.tiles_of_blocks(blocks[:, 0], blocks[:, 1])
    key = pack_cells(ti, tj)
    u, inv = np.unique(key, return_inverse=True)
    inv = inv.ravel()
    reads = np.bincount(inv, weights=counts[rows])
    if area_weight:
        span = []
        for axis in (0, 1):
            b = blocks[rows, axis]
            lo = np.full(len(u), np.iinfo(np.int64).max)
            hi = np.full(len(u), np.iinfo(np.int64).min)
            np.minimum.at(lo, inv, b)
            np.maximum.at(hi, inv, b)
            span.append(hi - lo + 1)
        reads = reads + area_weight * (span[0] * span[1]).astype(np.float64) * plan.block**2
    homes = pack_cells((blocks[:, 0] - plan.origin[0]) // plan.blocks,
                  (blocks[:, 1] - plan.origin[1]) // plan.blocks)
    owns = np.bincount(np.searchsorted(u, homes), weights=counts, minlength=len(u))
    return reads[owns > 0]


def _makespan(loads: np.ndarray, workers: int, overhead: float) -> float:
    """The longest worker's load when the largest tiles go first to the least loaded."""
    heap = [0.0] * max(1, workers)
    for w in np.sort(loads)[::-1]:
        heapq.heappush(heap, heapq.heappop(heap) + float(w) + overhead)
    return max(heap)


def _sides(first: int, last: int, every: int = 64, growth: float = 1.1) -> list[int]:
    """The tile sides (in blocks) :func:`choose_plan` tries: each from ``first`` for
    ``every`` sides, then ``growth`` times larger each, to ``last`` (two lines 90 km apart
    asked for 240,000 plans, 49 s, where a tenth more a step loses nothing of note).

    Examples
    --------
    >>> _sides(5, 8), len(_sides(5, 6700))
    ([5, 6, 7, 8], 114)
    """
    sides = list(range(first, min(last, first + every - 1) + 1))
    while sides[-1] < last:
        sides.append(min(last, max(sides[-1] + 1, int(sides[-1] * growth))))
    return sides


def choose_plan(blocks: np.ndarray, counts: np.ndarray, buffer: float, block: float, *, budget: float,
                workers: int, overhead: float = 2e5, origins: int = 6, area_weight: float = 0.0
                ) -> tuple[TilePlan, dict[str, Any]]:
    """The tiles (a side of whole blocks and where the lattice starts) that finish soonest
    on ``workers`` with no tile reading more than ``budget`` soundings.

    Every side from the smallest the buffer allows to one tile over the whole survey is
    tried, each from up to ``origins`` × ``origins`` starting blocks, on the exact block
    counts: the tiles' reads (own soundings and buffer) are scheduled largest first, each
    with ``overhead`` soundings' worth of start-up, and ``area_weight`` soundings' worth per
    m² its read blocks span (:func:`_tile_loads`: so that a line across a wide, empty
    extent is cut into tiles that follow it). Where no plan keeps every tile within the
    budget, the one with the smallest largest tile.

    Returns
    -------
    plan : TilePlan
    info : dict
        ``tiles``, ``largest`` (soundings read by the largest tile), ``read`` (in all),
        ``within_budget``.
    """
    reach = math.ceil(buffer / block - 1e-9)
    lo = blocks.min(axis=0) if len(blocks) else np.zeros(2, np.int64)
    span = int((blocks.max(axis=0) - lo).max()) + 1 if len(blocks) else 1
    best: tuple[Any, ...] = ((True, math.inf),)
    for k in _sides(2 * reach + 1, max(2 * reach + 1, span + 1)):
        smallest = math.inf
        steps = range(0, k, max(1, math.ceil(k / origins)))
        for oi in steps:
            for oj in steps:
                plan = TilePlan(k * block, buffer, block, (int(lo[0]) - oi, int(lo[1]) - oj))
                reads = _tile_loads(plan, blocks, counts, area_weight)
                largest = float(reads.max())
                smallest = min(smallest, largest)
                fits = largest <= budget
                score = (not fits, _makespan(reads, workers, overhead) if fits else largest)
                if score < best[0]:
                    best = (score, plan, {"tiles": len(reads), "largest": int(largest),
                                          "read": int(reads.sum()), "within_budget": fits})
        if smallest > 2 * budget and not best[0][0]:
            break  # larger tiles only grow further past the budget
        if best[2]["tiles"] == 1 and not best[0][0]:
            break  # one tile within the budget holds the survey: larger tiles read the same
    return best[1], best[2]


def tile_slices(plan: TilePlan, bins: Sequence[FileBins]
                ) -> tuple[dict[tuple[int, int], list[tuple[str, tuple[tuple[int, int], ...]]]],
                           dict[tuple[int, int], int]]:
    """For every tile that holds soundings: the row ranges it reads from each chunk (in
    file and chunk order), and the soundings it holds."""
    reads: dict[tuple[int, int], list[tuple[str, tuple[tuple[int, int], ...]]]] = {}
    owns: dict[tuple[int, int], int] = {}
    for b in bins:
        for c in b.chunks:
            ij = unpack_cells(c.keys)
            sizes = np.diff(c.starts)
            hk, hn = np.unique(pack_cells((ij[:, 0] - plan.origin[0]) // plan.blocks,
                                     (ij[:, 1] - plan.origin[1]) // plan.blocks), return_inverse=True)
            for key, m in zip(unpack_cells(hk).tolist(), np.bincount(hn.ravel(), weights=sizes).tolist(),
                              strict=True):
                owns[(key[0], key[1])] = owns.get((key[0], key[1]), 0) + int(m)
            ti, tj, rows = plan.tiles_of_blocks(ij[:, 0], ij[:, 1])
            order = np.lexsort((rows, tj, ti))
            ti, tj, rows = ti[order], tj[order], rows[order]
            cut = np.flatnonzero(np.r_[True, (ti[1:] != ti[:-1]) | (tj[1:] != tj[:-1]), True])
            for s, e in zip(cut[:-1], cut[1:], strict=True):
                r = rows[s:e]
                # consecutive blocks are one range of rows
                first = np.flatnonzero(np.r_[True, r[1:] != r[:-1] + 1])
                last = np.r_[first[1:], len(r)] - 1
                ranges = tuple((int(c.starts[r[a]]), int(c.starts[r[z] + 1])) for a, z in zip(first, last,
                                                                                               strict=True))
                reads.setdefault((int(ti[s]), int(tj[s])), []).append((c.path, ranges))
    return {k: v for k, v in reads.items() if k in owns}, owns


def _npy_header(path: str) -> tuple[np.dtype[Any], int]:
    """The record type of a ``.npy`` file and where its data start."""
    with open(path, "rb") as f:
        major, _ = np.lib.format.read_magic(f)
        read = np.lib.format.read_array_header_1_0 if major == 1 else np.lib.format.read_array_header_2_0
        _, _, dtype = read(f)
        return np.dtype(dtype), f.tell()


def load_tile(slices: Sequence[tuple[str, Sequence[tuple[int, int]]]], *,
              line_offsets: Mapping[int, tuple[int, np.ndarray]], stray: np.ndarray | None = None,
              files: Sequence[str] = (), crs: str | None = None) -> PointCloud:
    """A tile's soundings read back as one cloud, in the order of the survey's files.

    Parameters
    ----------
    slices : sequence of (str, sequence of (int, int))
        Each chunk file the tile reads and the row ranges it reads there
        (:func:`tile_slices`).
    line_offsets : mapping
        For each file index, ``(first survey line, the file's own lines sorted)``: a
        sounding's ``line`` is the survey line of its (file, own line), numbered as
        :func:`mbinspect.survey.inputs.read_survey` numbers them.
    stray : ndarray (M, 2), optional
        :data:`STRAY_CELL` cells whose soundings are left out (found over the whole survey).
    files : sequence of str
        The survey's files (``meta["files"]``).
    crs : str, optional

    Returns
    -------
    PointCloud
        Fields ``file``, ``line`` and those every chunk holds; ``meta["strays_removed"]``.
    """
    heads = [_npy_header(path) for path, _ in sorted(slices)]
    ranges = [r for _, r in sorted(slices)]
    dtypes = [dt for dt, _ in heads]
    common = set(dtypes[0].names or ()) - {ROW, "file_line"}
    for dt in dtypes[1:]:
        common &= set(dt.names or ())
    n = sum(b - a for rs in ranges for a, b in rs)
    xyz = np.empty((n, 3))
    cols = {k: np.empty(n, np.result_type(*(dt[k] for dt in dtypes)))
            for k in sorted(common - {"x", "y", "z"})}
    line = np.empty(n, np.int32)
    at = 0
    for (path, _), (dt, offset), rs in zip(sorted(slices), heads, ranges, strict=True):
        # plain reads, not a memory map: only the rows read count in the worker's memory
        with open(path, "rb") as f:
            pieces = []
            for a, b in rs:
                f.seek(offset + a * dt.itemsize)
                pieces.append(np.fromfile(f, dtype=dt, count=b - a))
        part = np.concatenate(pieces) if len(pieces) > 1 else pieces[0]
        if (np.diff(part[ROW].astype(np.int64)) < 0).any():  # blocks back in the file's order
            part = part[np.argsort(part[ROW], kind="stable")]
        end = at + len(part)
        xyz[at:end, 0], xyz[at:end, 1], xyz[at:end, 2] = part["x"], part["y"], part["z"]
        for k, v in cols.items():
            v[at:end] = part[k]
        first, known = line_offsets[int(part["file"][0])]
        line[at:end] = first + np.searchsorted(known, part["file_line"])
        at = end
    cols["line"] = line
    if stray is not None and len(stray):
        stray = np.asarray(stray, np.int64)
        bad = np.isin(pack_cells(np.floor(xyz[:, 0] / STRAY_CELL), np.floor(xyz[:, 1] / STRAY_CELL)),
                      pack_cells(stray[:, 0], stray[:, 1]))
        if bad.any():
            xyz = xyz[~bad]
            cols = {k: v[~bad] for k, v in cols.items()}
    meta = {"files": list(files), "strays_removed": True, "format": "tile"}
    return PointCloud(xyz, cols, source="tile", crs=crs, meta=meta)
