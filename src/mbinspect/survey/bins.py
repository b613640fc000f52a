"""A survey file streamed once into square blocks on disk: each chunk sorted by block and
written as a NumPy ``.npy`` file of one structured array (x, y, z as float64 and every
field at its own type), with the offsets of its blocks; the survey's block counts."""

from __future__ import annotations

import os
import warnings
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..checks import EARTH_BOUND_TEXT, beyond_the_earth
from ..cloud import PointCloud
from ..datum import vertical_reference
from ..errors import InputError
from ..formats import format_of
from ..grid import bounds, pack_cells, unpack_cells
from ..io import in_metres, on_reference, read
from .inputs import SurveyCRS, conform

__all__ = ["FileBins", "BinnedChunk", "bin_file", "block_counts", "STRAY_CELL", "ROW"]

#: Plan cell (m) of the survey-wide search for stray soundings (:func:`mbinspect.strays.stray_cells`).
STRAY_CELL = 25.0

#: Blocks across a tile's buffer: finer blocks fit the buffer closer and cost more slices.
BLOCKS_PER_BUFFER = 4

#: A sounding's place in its chunk, kept in the parts to restore the file's order in a tile.
ROW = "chunk_row"


@dataclass(frozen=True)
class BinnedChunk:
    """One chunk of a file on disk, sorted by block: ``keys`` the blocks it holds (packed,
    ascending) and ``starts`` their first rows (one more entry: the chunk's length)."""

    path: str
    keys: np.ndarray
    starts: np.ndarray


@dataclass(frozen=True)
class FileBins:
    """What streaming one file into blocks found: its chunks on disk, the occupied
    stray-search cells, its own line numbers and fields."""

    file: int
    path: str
    n: int
    chunks: tuple[BinnedChunk, ...]
    cells: np.ndarray  # (M, 2) int: occupied STRAY_CELL cells
    cell_counts: np.ndarray  # (M,)
    lines: np.ndarray  # the file's own line numbers, sorted
    fields: tuple[str, ...]
    crs: str | None
    bounds: tuple[float, float, float, float]
    meta: Mapping[str, Any] = field(default_factory=dict)


def _chunks(path: Path, chunk: int, read_options: Mapping[str, Any], target: SurveyCRS | None
            ) -> Iterator[PointCloud]:
    """A file's soundings in clouds: LAS/LAZ in chunks as read, other formats whole (one
    survey line: memory follows the largest line file, not the survey); each in the
    survey's CRS (``target``), LAS chunks put in metres like a whole file."""
    row = format_of(path, read_options.get("format"))
    opts = dict(read_options)
    if target is not None and row.sonar and opts.get("crs") is None:
        opts["crs"] = target.crs
    keep = bool(opts.get("keep_rejected"))
    clouds = row.chunks(path, chunk, keep_rejected=keep) if row.chunks is not None \
        else iter([read(path, **opts)])
    for k, cloud in enumerate(clouds):
        with warnings.catch_warnings():
            if k:  # a conversion is said once per file, not once per chunk
                warnings.simplefilter("ignore")
            if row.chunks is not None:  # read() puts a whole file on its vertical reference
                ref = vertical_reference(opts.get("tide"), opts.get("datum_offset"))
                cloud = on_reference(in_metres(cloud, opts.get("crs")), ref, str(path))
            if target is not None:
                cloud = conform(cloud, target.crs, target.first)
        far = beyond_the_earth(cloud.xyz)
        if far is not None:
            raise InputError(f"{path}: point {far + 1} of its chunk {k + 1} is {cloud.xyz[far].tolist()}; "
                             f"{EARTH_BOUND_TEXT}")
        yield cloud


def bin_file(path: str | os.PathLike[str], file_index: int, block: float, workdir: str | os.PathLike[str],
             read_options: Mapping[str, Any] | None = None, chunk: int = 2_000_000,
             fields: Sequence[str] | None = None, target: SurveyCRS | None = None) -> FileBins:
    """Stream one file into block-sorted chunks under ``workdir``.

    Parameters
    ----------
    path : path-like
    file_index : int
        The file's place in the survey (stored with every sounding as ``file``).
    block : float
        Block side (m), from (0, 0): :attr:`mbinspect.survey.tiles.TilePlan.block`.
    workdir : path-like
        Chunks go to ``workdir/f<file>_c<chunk>.npy``.
    read_options : mapping, optional
        For :func:`mbinspect.io.read`.
    chunk : int
        Soundings per chunk of a LAS/LAZ file.
    fields : sequence of str, optional
        The fields kept beside x, y, z, file and line (default: every field): what the
        pipeline uses, so that the parts hold no bytes it never reads.
    target : SurveyCRS, optional
        The survey's CRS (:func:`mbinspect.survey.inputs.survey_crs`), every chunk brought
        to it; None: the file's own.

    Returns
    -------
    FileBins
    """
    p = Path(path)
    opts = dict(read_options or {})
    chunks: list[BinnedChunk] = []
    cells, lines = [], []
    n, crs, names = 0, None, None
    lo = np.full(2, np.inf)
    hi = np.full(2, -np.inf)
    meta: dict[str, Any] = {}
    for c, cloud in enumerate(_chunks(p, chunk, opts, target)):
        if c == 0:
            crs, meta = cloud.crs, dict(cloud.meta)
            names = tuple(sorted(cloud.fields))
        if cloud.meta.get("z_doubt"):
            raise InputError(str(cloud.meta["z_doubt"]))
        if len(cloud) == 0:
            continue
        n += len(cloud)
        xy = cloud.xyz[:, :2]
        lo_c, hi_c = bounds(xy)
        lo = np.minimum(lo, lo_c)
        hi = np.maximum(hi, hi_c)
        table = _table(cloud, file_index, fields)
        lines.append(np.unique(table["file_line"]))
        cells.append(pack_cells(np.floor(xy[:, 0] / STRAY_CELL), np.floor(xy[:, 1] / STRAY_CELL)))
        key = pack_cells(np.floor(xy[:, 0] / block), np.floor(xy[:, 1] / block))
        order = np.argsort(key, kind="stable")
        key = key[order]
        starts = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
        out = Path(workdir) / f"f{file_index:05d}_c{c:05d}.npy"
        np.save(out, table[order], allow_pickle=False)
        chunks.append(BinnedChunk(str(out), key[starts], np.r_[starts, len(key)].astype(np.int64)))
    if n == 0:
        raise InputError(f"{p}: the file holds no points")
    u, k = np.unique(np.concatenate(cells), return_counts=True)
    return FileBins(file_index, str(p), n, tuple(chunks), unpack_cells(u), k.astype(np.int64),
                    np.unique(np.concatenate(lines)), names or (), crs,
                    (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])), meta)


def _table(cloud: PointCloud, file_index: int, keep: Sequence[str] | None = None) -> np.ndarray:
    """A chunk as one structured array: x, y, z, file, file_line, its row and the other
    fields (those in ``keep`` when given)."""
    skip = {"line", "file"}
    fields = {k: np.asarray(v) for k, v in sorted(cloud.fields.items())
              if k not in skip and (keep is None or k in keep)}
    dtype = [("x", "f8"), ("y", "f8"), ("z", "f8"), ("file", "i4"), ("file_line", "i8"), (ROW, "u4")]
    dtype += [(k, v.dtype.str) for k, v in fields.items()]
    t = np.empty(len(cloud), dtype=dtype)
    t["x"], t["y"], t["z"] = cloud.xyz[:, 0], cloud.xyz[:, 1], cloud.xyz[:, 2]
    t["file"] = file_index
    t["file_line"] = np.asarray(cloud.fields.get("line", np.zeros(len(cloud))), np.int64)
    t[ROW] = np.arange(len(cloud), dtype=np.uint32)
    for k, v in fields.items():
        t[k] = v
    return t


def block_counts(bins: Sequence[FileBins]) -> tuple[np.ndarray, np.ndarray]:
    """The survey's occupied blocks (M, 2) and the soundings in each."""
    keys = np.concatenate([c.keys for b in bins for c in b.chunks])
    counts = np.concatenate([np.diff(c.starts) for b in bins for c in b.chunks])
    u, inv = np.unique(keys, return_inverse=True)
    return unpack_cells(u), np.bincount(inv.ravel(), weights=counts).astype(np.int64)
