"""PLY, ASCII and binary: every vertex property kept as a field."""

from __future__ import annotations

from pathlib import Path
from typing import BinaryIO

import numpy as np

from ..cloud import PointCloud
from ..errors import InputError
from .base import Format, ReadRequest

__all__ = ["FORMAT"]



_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}


def _read_ply(path: Path) -> PointCloud:
    with open(path, "rb") as fh:
        fmt, elements = _ply_header(fh, path)
        if not elements or elements[0][0] != "vertex":
            raise InputError(f"{path}: expected the first PLY element to be 'vertex'")
        _, count, props = elements[0]
        if any(t == "list" for _, t in props):
            raise InputError(f"{path}: list properties on vertices are not supported")
        names = [n for n, _ in props]
        for axis in "xyz":
            if axis not in names:
                raise InputError(f"{path}: the vertex element has no {axis!r} property")
        if fmt == "ascii":
            data = _ply_ascii(fh, path, count, names, more=len(elements) > 1)
        elif fmt in ("binary_little_endian", "binary_big_endian"):
            order = "<" if fmt == "binary_little_endian" else ">"
            dtype = np.dtype([(n, order + t) for n, t in props])
            buf = fh.read(dtype.itemsize * count)
            if len(buf) < dtype.itemsize * count:
                raise InputError(
                    f"{path}: truncated: {count} vertices announced, "
                    f"{len(buf) // dtype.itemsize} present"
                )
            rec = np.frombuffer(buf, dtype=dtype, count=count)
            if len(elements) == 1 and fh.read(1):
                raise InputError(f"{path}: the header announces {count} vertices but more data follow; "
                                 "expected the count of every vertex")
            data = {n: rec[n] for n in names}
        else:
            raise InputError(f"{path}: unknown PLY format {fmt!r}")
    xyz = np.column_stack([data.pop("x"), data.pop("y"), data.pop("z")]).astype(np.float64)
    fields = {
        ("intensity" if k in ("scalar_intensity", "intensity") else k): np.asarray(v).copy()
        for k, v in data.items()
    }
    return PointCloud(xyz, fields, source=str(path))


def _write_ply(cloud: PointCloud, path: Path, precision: int) -> None:
    props = [("x", "<f8"), ("y", "<f8"), ("z", "<f8")]
    for name, values in cloud.fields.items():
        kind = np.asarray(values).dtype
        props.append((name, "<f8" if kind.kind == "f" else "<i4"))
    rec = np.empty(len(cloud), dtype=np.dtype(props))
    rec["x"], rec["y"], rec["z"] = cloud.xyz.T
    for name, values in cloud.fields.items():
        rec[name] = values
    inverse = {"<f8": "double", "<i4": "int"}
    lines = ["ply", "format binary_little_endian 1.0", "comment written by mbinspect",
             f"element vertex {len(cloud)}"]
    lines += [f"property {inverse[t]} {n}" for n, t in props]
    lines.append("end_header")
    with open(path, "wb") as fh:
        fh.write(("\n".join(lines) + "\n").encode("ascii"))
        fh.write(rec.tobytes())



def _read(path: Path, request: ReadRequest) -> PointCloud:
    return _read_ply(path)


FORMAT = Format("ply", (".ply",), _read, _write_ply, 28.0, fields="every vertex property")


def _ply_header(fh: BinaryIO, path: Path) -> tuple[str | None, list[tuple[str, int, list[tuple[str, str]]]]]:
    """The PLY header: its format and its elements (name, count, properties)."""
    magic = fh.readline().strip()
    if magic != b"ply":
        raise InputError(f"{path}, line 1: expected 'ply', got {magic[:20]!r}")
    fmt = None
    elements: list[tuple[str, int, list[tuple[str, str]]]] = []
    lineno = 1
    while True:
        raw = fh.readline()
        lineno += 1
        if not raw:
            raise InputError(f"{path}: the PLY header has no end_header line")
        words = raw.decode("ascii", errors="replace").split()
        if not words or words[0] in ("comment", "obj_info"):
            continue
        if words[0] == "format":
            fmt = words[1] if len(words) > 1 else ""
        elif words[0] == "element" and len(words) == 3:
            if not words[2].isdigit():
                raise InputError(f"{path}, line {lineno}: element {words[1]!r} count {words[2]!r}; "
                                 "expected a whole number >= 0")
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property":
            if not elements:
                raise InputError(f"{path}, line {lineno}: property before any element")
            if words[1] == "list":
                elements[-1][2].append((words[-1], "list"))
            elif len(words) == 3 and words[1] in _PLY_TYPES:
                elements[-1][2].append((words[2], _PLY_TYPES[words[1]]))
            else:
                raise InputError(f"{path}, line {lineno}: unknown property {raw!r}")
        elif words[0] == "end_header":
            return fmt, elements


def _ply_ascii(fh: BinaryIO, path: Path, count: int, names: list[str], *, more: bool
               ) -> dict[str, np.ndarray]:
    """The vertices of an ASCII PLY, each property a column."""
    table = np.loadtxt(fh, dtype=np.float64, max_rows=count, ndmin=2)
    if table.shape[0] != count or table.shape[1] != len(names):
        raise InputError(
            f"{path}: expected {count} vertices of {len(names)} values, "
            f"got {table.shape[0]} of {table.shape[1] if table.size else 0}"
        )
    if not more and fh.read(4096).strip():
        raise InputError(f"{path}: the header announces {count} vertices but more data follow; "
                         "expected the count of every vertex")
    return {n: table[:, i] for i, n in enumerate(names)}
