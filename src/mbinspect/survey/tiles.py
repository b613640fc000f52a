"""A survey cut into square tiles with a buffer, streamed from its files into tile parts on
disk, and a tile read back as one cloud.

Tile parts are NumPy ``.npy`` files of one structured array (x, y, z as float64 and every
field of the chunk at its own type), one part per (tile, file, chunk): written once, read
once by the worker of that tile, exact to the bit, with no dependency beyond NumPy.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError, ParameterError
from ..io import PointCloud, format_from_path, iter_las, read

__all__ = ["TilePlan", "FileBins", "bin_file", "load_tile", "STRAY_CELL"]

#: Plan cell (m) of the survey-wide search for stray soundings (:func:`mbinspect.grid.stray_cells`).
STRAY_CELL = 25.0


@dataclass(frozen=True)
class TilePlan:
    """Square tiles of ``size`` m counted from (0, 0), each read with ``buffer`` m around it.

    A sounding belongs to the tile whose square holds it (its home) and is also read by
    every tile whose buffered square holds it, so that each stage of a tile sees what it
    needs near the tile's edge; an object is reported by its centre's home tile only.

    Examples
    --------
    >>> plan = TilePlan(100.0, 10.0)
    >>> ti, tj, rows = plan.assign(np.array([[50.0, 50.0], [95.0, 50.0]]))
    >>> sorted(zip(ti.tolist(), tj.tolist(), rows.tolist()))
    [(0, 0, 0), (0, 0, 1), (1, 0, 1)]
    """

    size: float
    buffer: float

    def __post_init__(self) -> None:
        if not (self.size > 0 and math.isfinite(self.size)):
            raise ParameterError(f"tile_size: {self.size}; expected a positive number of metres",
                                 option="tile_size")
        if not (0 <= self.buffer < self.size / 2):
            raise ParameterError(f"tile_buffer: {self.buffer:g} m; expected at least 0 and under half the "
                                 f"tile size ({self.size / 2:g} m): give a larger tile_size",
                                 option="tile_size")

    def home(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The home tile (column, row) of each point."""
        xy = np.asarray(xy, np.float64)
        return (np.floor(xy[:, 0] / self.size).astype(np.int64),
                np.floor(xy[:, 1] / self.size).astype(np.int64))

    def core(self, i: int, j: int) -> tuple[float, float, float, float]:
        """A tile's own square: ``(x0, y0, x1, y1)``."""
        return (i * self.size, j * self.size, (i + 1) * self.size, (j + 1) * self.size)

    def assign(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every (tile, point) pair: the tiles' columns and rows, and the points' rows."""
        i, j = self.home(xy)
        fx = np.asarray(xy)[:, 0] - i * self.size
        fy = np.asarray(xy)[:, 1] - j * self.size
        near = {-1: (fx < self.buffer, fy < self.buffer), 0: (None, None),
                1: (fx >= self.size - self.buffer, fy >= self.size - self.buffer)}
        ti, tj, rows = [], [], []
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                mx, my = near[di][0], near[dj][1]
                m = np.ones(len(i), bool) if mx is None else mx
                if my is not None:
                    m = m & my
                r = np.flatnonzero(m)
                ti.append(i[r] + di)
                tj.append(j[r] + dj)
                rows.append(r)
        return np.concatenate(ti), np.concatenate(tj), np.concatenate(rows)


@dataclass(frozen=True)
class FileBins:
    """What streaming one file into tiles found: its tile parts and counts, the occupied
    stray-search cells, its own line numbers and fields."""

    file: int
    path: str
    n: int
    parts: Mapping[tuple[int, int], tuple[str, ...]]
    home_counts: Mapping[tuple[int, int], int]
    cells: np.ndarray  # (M, 2) int: occupied STRAY_CELL cells
    cell_counts: np.ndarray  # (M,)
    lines: np.ndarray  # the file's own line numbers, sorted
    fields: tuple[str, ...]
    crs: str | None
    bounds: tuple[float, float, float, float]
    meta: Mapping[str, Any] = field(default_factory=dict)


def _chunks(path: Path, chunk: int, read_options: Mapping[str, Any]) -> Iterator[PointCloud]:
    """A file's soundings in clouds: LAS/LAZ in chunks as read, other formats whole (one
    survey line: memory follows the largest line file, not the survey)."""
    if format_from_path(path, read_options.get("format")) == "las":
        yield from iter_las(path, chunk)
    else:
        yield read(path, **read_options)


def bin_file(path: str | os.PathLike[str], file_index: int, plan: TilePlan, workdir: str | os.PathLike[str],
             read_options: Mapping[str, Any] | None = None, chunk: int = 2_000_000,
             fields: Sequence[str] | None = None) -> FileBins:
    """Stream one file into tile parts under ``workdir``.

    Parameters
    ----------
    path : path-like
    file_index : int
        The file's place in the survey (stored with every sounding as ``file``).
    plan : TilePlan
    workdir : path-like
        Parts go to ``workdir/<i>_<j>/f<file>_c<chunk>.npy``.
    read_options : mapping, optional
        For :func:`mbinspect.io.read`.
    chunk : int
        Soundings per chunk of a LAS/LAZ file.
    fields : sequence of str, optional
        The fields kept beside x, y, z, file and line (default: every field): what the
        pipeline uses, so that the parts hold no bytes it never reads.

    Returns
    -------
    FileBins
    """
    p = Path(path)
    opts = dict(read_options or {})
    parts: dict[tuple[int, int], list[str]] = {}
    home: dict[tuple[int, int], int] = {}
    cells, counts, lines = [], [], []
    n, crs, names = 0, None, None
    lo = np.full(2, np.inf)
    hi = np.full(2, -np.inf)
    meta: dict[str, Any] = {}
    for c, cloud in enumerate(_chunks(p, chunk, opts)):
        if c == 0:
            crs, meta = cloud.crs, dict(cloud.meta)
            names = tuple(sorted(cloud.fields))
        if cloud.meta.get("z_doubt"):
            raise InputError(str(cloud.meta["z_doubt"]))
        n += len(cloud)
        lo = np.minimum(lo, cloud.xyz[:, :2].min(axis=0))
        hi = np.maximum(hi, cloud.xyz[:, :2].max(axis=0))
        table = _table(cloud, file_index, fields)
        lines.append(np.unique(table["file_line"]))
        ij = np.floor(cloud.xyz[:, :2] / STRAY_CELL).astype(np.int64)
        u, k = np.unique(ij, axis=0, return_counts=True)
        cells.append(u)
        counts.append(k)
        hi_, hj_ = plan.home(cloud.xyz)
        hk, hn = np.unique(np.column_stack([hi_, hj_]), axis=0, return_counts=True)
        for (a, b), m in zip(hk.tolist(), hn.tolist(), strict=True):
            home[(a, b)] = home.get((a, b), 0) + m
        ti, tj, rows = plan.assign(cloud.xyz)
        packed = _pack(ti, tj)
        order = np.argsort(packed, kind="stable")
        packed, ti, tj, rows = packed[order], ti[order], tj[order], rows[order]
        starts = np.flatnonzero(np.r_[True, packed[1:] != packed[:-1]])
        ends = np.r_[starts[1:], len(packed)]
        for s, e in zip(starts, ends, strict=True):
            key = (int(ti[s]), int(tj[s]))
            folder = Path(workdir) / f"{key[0]}_{key[1]}"
            folder.mkdir(parents=True, exist_ok=True)
            out = folder / f"f{file_index:05d}_c{c:05d}.npy"
            np.save(out, table[np.sort(rows[s:e])], allow_pickle=False)
            parts.setdefault(key, []).append(str(out))
    if n == 0:
        raise InputError(f"{p}: the file holds no points")
    allc = np.concatenate(cells)
    allk = np.concatenate(counts)
    u, inv = np.unique(allc, axis=0, return_inverse=True)
    return FileBins(file_index, str(p), n, {k: tuple(v) for k, v in parts.items()}, home, u,
                    np.bincount(inv.ravel(), weights=allk).astype(np.int64),
                    np.unique(np.concatenate(lines)), names or (), crs,
                    (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])), meta)


def _pack(i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Two cell indices as one int64 (each within ±2³⁰)."""
    return (np.asarray(i, np.int64) + (1 << 30)) * (1 << 31) + (np.asarray(j, np.int64) + (1 << 30))


def _table(cloud: PointCloud, file_index: int, keep: Sequence[str] | None = None) -> np.ndarray:
    """A chunk as one structured array: x, y, z, file, file_line and the other fields
    (those in ``keep`` when given)."""
    skip = {"line", "file"}
    fields = {k: np.asarray(v) for k, v in sorted(cloud.fields.items())
              if k not in skip and (keep is None or k in keep)}
    dtype = [("x", "f8"), ("y", "f8"), ("z", "f8"), ("file", "i4"), ("file_line", "i8")]
    dtype += [(k, v.dtype.str) for k, v in fields.items()]
    t = np.empty(len(cloud), dtype=dtype)
    t["x"], t["y"], t["z"] = cloud.xyz[:, 0], cloud.xyz[:, 1], cloud.xyz[:, 2]
    t["file"] = file_index
    t["file_line"] = np.asarray(cloud.fields.get("line", np.zeros(len(cloud))), np.int64)
    for k, v in fields.items():
        t[k] = v
    return t


def load_tile(parts: Sequence[str], *, line_offsets: Mapping[int, tuple[int, np.ndarray]],
              stray: np.ndarray | None = None, files: Sequence[str] = (), crs: str | None = None
              ) -> PointCloud:
    """A tile's parts read back as one cloud, in file and chunk order.

    Parameters
    ----------
    parts : sequence of str
        The tile's part files.
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
        Fields ``file``, ``line`` and those every part holds; ``meta["strays_removed"]``.
    """
    tables = [np.load(f, allow_pickle=False) for f in sorted(parts)]
    common = set(tables[0].dtype.names or ())
    for t in tables[1:]:
        common &= set(t.dtype.names or ())
    cols = {k: np.concatenate([t[k] for t in tables]) for k in sorted(common)}
    xyz = np.column_stack([cols.pop("x"), cols.pop("y"), cols.pop("z")])
    file_index = cols["file"]
    own = cols.pop("file_line")
    line = np.zeros(len(xyz), np.int32)
    for f in np.unique(file_index):
        rows = file_index == f
        first, known = line_offsets[int(f)]
        line[rows] = first + np.searchsorted(known, own[rows])
    cols["line"] = line
    if stray is not None and len(stray):
        ij = np.floor(xyz[:, :2] / STRAY_CELL).astype(np.int64)
        stray = np.asarray(stray, np.int64)
        bad = np.isin(_pack(ij[:, 0], ij[:, 1]), _pack(stray[:, 0], stray[:, 1]))
        xyz = xyz[~bad]
        cols = {k: v[~bad] for k, v in cols.items()}
    meta = {"files": list(files), "strays_removed": True, "format": "tile"}
    return PointCloud(xyz, cols, source="tile", crs=crs, meta=meta)
