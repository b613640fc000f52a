"""LAS and LAZ (laspy with lazrs): intensity, classification, line (point source id),
beam angle (scan angle) and every extra-bytes field."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from ..cloud import PointCloud
from ..errors import InputError
from .base import Format, ReadRequest

__all__ = ["FORMAT", "iter_las"]



def _read_las(path: Path) -> PointCloud:
    import laspy

    try:
        las = laspy.read(path)
    except Exception as exc:  # laspy raises many types for a broken file
        raise InputError(f"{path}: not a readable LAS/LAZ file ({exc})") from None
    if len(las.points) == 0:
        raise InputError(f"{path}: the LAS file holds no points")
    return _las_cloud(las, las.header, path)


def iter_las(path: str | os.PathLike[str], chunk: int = 2_000_000) -> Iterator[PointCloud]:
    """A LAS/LAZ file's points in clouds of at most ``chunk`` points, read as they are
    needed: memory follows the chunk, not the file.

    Raises
    ------
    InputError
        A file laspy cannot read, named with the reason.
    """
    import laspy

    p = Path(path)
    try:
        with laspy.open(p) as reader:
            header = reader.header
            for points in reader.chunk_iterator(chunk):
                yield _las_cloud(points, header, p)
    except InputError:
        raise
    except Exception as exc:  # laspy raises many types for a broken file
        raise InputError(f"{p}: not a readable LAS/LAZ file ({exc})") from None


def _las_cloud(las: Any, header: Any, path: Path) -> PointCloud:
    """A cloud from laspy points (a whole file or a chunk of one) and the file's header."""
    xyz = np.column_stack([np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)])
    dims = set(las.point_format.dimension_names)
    fields: dict[str, np.ndarray] = {}
    if "intensity" in dims and np.any(las.intensity):
        fields["intensity"] = np.asarray(las.intensity, dtype=np.float64)
    if "classification" in dims and np.any(las.classification):
        fields["classification"] = np.asarray(las.classification, dtype=np.int32)
    if "point_source_id" in dims and np.any(las.point_source_id):
        fields["line"] = np.asarray(las.point_source_id, dtype=np.int32)
    for angle in ("scan_angle", "scan_angle_rank"):
        if angle in dims and np.any(las[angle]):
            scale = 0.006 if angle == "scan_angle" else 1.0
            fields["beam_angle"] = np.asarray(las[angle], dtype=np.float64) * scale
            break
    for extra in las.point_format.extra_dimension_names:
        fields[extra] = np.asarray(las[extra])
    if "intensity_db" in fields:  # written by us: exact float intensity
        fields["intensity"] = np.asarray(fields.pop("intensity_db"), dtype=np.float64)
    crs = None
    try:
        parsed = header.parse_crs()
        crs = parsed.to_wkt() if parsed is not None else None
    except Exception:  # pyproj missing or no CRS: not an error
        crs = None
    return PointCloud(xyz, fields, source=str(path), crs=crs)


def _write_las(cloud: PointCloud, path: Path, precision: int) -> None:
    import laspy

    header = laspy.LasHeader(point_format=6, version="1.4")
    lo = cloud.xyz.min(axis=0) if len(cloud) else np.zeros(3)
    header.offsets = np.floor(lo)
    header.scales = np.full(3, 10.0**-precision)
    extra = {k: v for k, v in cloud.fields.items()
             if k not in ("intensity", "classification", "line", "beam_angle")}
    if "intensity" in cloud.fields:
        extra["intensity_db"] = cloud.fields["intensity"]
    for name, values in extra.items():
        kind = np.float64 if np.asarray(values).dtype.kind == "f" else np.int32
        header.add_extra_dim(laspy.ExtraBytesParams(name=name, type=kind))
    if cloud.crs:
        from pyproj import CRS

        header.add_crs(CRS.from_user_input(cloud.crs))
    las = laspy.LasData(header)
    las.x, las.y, las.z = cloud.xyz[:, 0], cloud.xyz[:, 1], cloud.xyz[:, 2]
    if "intensity" in cloud.fields:
        las.intensity = np.clip(np.round(cloud.fields["intensity"]), 0, 65535).astype(np.uint16)
    if "classification" in cloud.fields:
        las.classification = np.clip(cloud.fields["classification"], 0, 255).astype(np.uint8)
    if "line" in cloud.fields:
        las.point_source_id = np.clip(cloud.fields["line"], 0, 65535).astype(np.uint16)
    if "beam_angle" in cloud.fields:
        las.scan_angle = np.clip(np.round(cloud.fields["beam_angle"] / 0.006), -30000, 30000)
    for name, values in extra.items():
        las[name] = values
    compressed = str(path).lower().endswith(".laz")
    with open(path, "wb") as fh:
        las.write(fh, do_compress=compressed)



def _read(path: Path, request: ReadRequest) -> PointCloud:
    return _read_las(path)


def _count(path: Path) -> int:
    import laspy

    with laspy.open(path) as r:
        return int(r.header.point_count)


FORMAT = Format("las", (".las", ".laz"), _read, _write_las, 30.0, aliases=("laz",), count=_count,
                writes=(".las", ".laz"),
                chunks=iter_las,
                fields="intensity, classification, line (point source id), beam_angle (scan angle), "
                       "any extra bytes")
