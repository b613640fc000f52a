"""LAS and LAZ (laspy with lazrs): intensity, classification, line (point source id),
beam angle (scan angle) and every extra-bytes field."""

from __future__ import annotations

import os
import struct
import sys
import tempfile
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from ..cloud import PointCloud
from ..errors import InputError, InputWarning
from ..grid import bounds
from .base import Format, ReadRequest

__all__ = ["FORMAT", "iter_las", "check_header", "rejected_left_out", "NOISE_CLASSES"]



def _read_las(path: Path, keep_rejected: bool = False) -> PointCloud:
    import laspy

    check_header(path)
    try:
        with native_stderr_held():
            header, points = _mapped(path)
            if points is None:
                las = laspy.read(path)
                header, points = las.header, las.points
    except (KeyboardInterrupt, SystemExit, GeneratorExit):
        raise
    except BaseException as exc:  # laspy raises many types, lazrs a Rust panic (a BaseException)
        raise InputError(f"{path}: not a readable LAS/LAZ file ({_reason(exc)})") from None
    if len(points) == 0:
        raise InputError(f"{path}: the LAS file holds no points")
    return rejected_left_out(_las_cloud(points, header, path), keep_rejected)


def _mapped(path: Path) -> tuple[Any, Any]:
    """An uncompressed LAS file's header and its points mapped from the file, not read into a
    buffer first (10 M points: 0.23 s against laspy.read's 1.0 s, warm); None for the points
    of a LAZ file or one whose records are not laid out as its point format says."""
    import laspy

    with laspy.open(path) as reader:
        header = reader.header
    dtype = header.point_format.dtype()
    if header.are_points_compressed or dtype.itemsize != header.point_format.size or \
            header.offset_to_point_data + dtype.itemsize * header.point_count > path.stat().st_size:
        return header, None
    raw = np.memmap(path, dtype, mode="r", offset=header.offset_to_point_data, shape=(header.point_count,))
    return header, laspy.ScaleAwarePointRecord(raw, header.point_format, header.scales, header.offsets)


def iter_las(path: str | os.PathLike[str], chunk: int = 2_000_000, keep_rejected: bool = False
             ) -> Iterator[PointCloud]:
    """A LAS/LAZ file's points in clouds of at most ``chunk`` points, read as they are
    needed: memory follows the chunk, not the file. Points flagged withheld or classed noise
    are left out (one warning counts them, once the file is read) unless ``keep_rejected``.

    Raises
    ------
    InputError
        A file laspy cannot read, named with the reason.
    """
    import laspy

    p = Path(path)
    check_header(p)
    counts = np.zeros(3, np.int64)  # withheld, noise only, all
    try:
        with laspy.open(p) as reader:
            header = reader.header
            chunks = reader.chunk_iterator(chunk)
            while True:
                with native_stderr_held():  # never held across a yield
                    points = next(chunks, None)
                if points is None:
                    break
                cloud = _las_cloud(points, header, p)
                if not keep_rejected:
                    cloud, left = _without_rejected(cloud)
                    counts += left
                yield cloud
    except (InputError, KeyboardInterrupt, SystemExit, GeneratorExit):
        raise
    except BaseException as exc:  # laspy raises many types, lazrs a Rust panic (a BaseException)
        raise InputError(f"{p}: not a readable LAS/LAZ file ({_reason(exc)})") from None
    if counts[:2].any():
        _say_left_out(str(p), counts)


@contextmanager
def native_stderr_held() -> Iterator[None]:
    """Hold what compiled code writes to the process's stderr (a Rust panic's message from
    lazrs) while it runs: given back as written when the block ends well, dropped when it
    raises, so that a broken file is the one line the caller makes of the exception.

    Examples
    --------
    >>> with native_stderr_held():
    ...     pass
    """
    try:
        fd = sys.stderr.fileno()
    except (AttributeError, ValueError, OSError):  # no real stderr (captured): nothing to hold
        yield
        return
    sys.stderr.flush()
    saved = os.dup(fd)
    with tempfile.TemporaryFile() as held:
        os.dup2(held.fileno(), fd)
        ok = False
        try:
            yield
            ok = True
        finally:
            sys.stderr.flush()
            os.dup2(saved, fd)
            os.close(saved)
            if ok:
                held.seek(0)
                written = held.read()
                if written:
                    os.write(fd, written)


def _reason(exc: BaseException) -> str:
    text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    return text[:200]


#: The classes LAS gives noise: 7 (low point, noise) and, from LAS 1.4, 18 (high noise).
NOISE_CLASSES = (7, 18)


def rejected_left_out(cloud: PointCloud, keep: bool = False) -> PointCloud:
    """A LAS cloud without the points the file rejects (flagged withheld, classed noise),
    counted in a warning; with ``keep`` they stay, their flags as fields.

    Parameters
    ----------
    cloud : PointCloud
        As read, with ``withheld`` and ``classification`` fields where the file has them.
    keep : bool
        Keep them (``--keep-rejected``).

    Returns
    -------
    PointCloud
    """
    if keep:
        return cloud
    out, counts = _without_rejected(cloud)
    if counts[:2].any():
        _say_left_out(cloud.source, counts)
    return out


def _without_rejected(cloud: PointCloud) -> tuple[PointCloud, np.ndarray]:
    """The cloud without withheld and noise points, and their counts (withheld, noise only,
    all points)."""
    n = len(cloud)
    withheld = cloud.fields.get("withheld")
    cls = cloud.fields.get("classification")
    noise = np.zeros(n, bool)
    if cls is not None:
        for k in NOISE_CLASSES:
            noise |= cls == k
    if withheld is None and not noise.any():  # nothing rejected: the cloud as it is
        return cloud, np.array([0, 0, n], np.int64)
    withheld = np.zeros(n, bool) if withheld is None else np.asarray(withheld, bool)
    bad = withheld | noise
    counts = np.array([withheld.sum(), (noise & ~withheld).sum(), n], np.int64)
    fields = {k: np.asarray(v)[~bad] for k, v in cloud.fields.items() if k != "withheld"}
    return replace(cloud, xyz=cloud.xyz[~bad], fields=fields), counts


def _say_left_out(source: str | None, counts: np.ndarray) -> None:
    parts = [f"{counts[0]:,} flagged withheld"] if counts[0] else []
    parts += [f"{counts[1]:,} classed noise (7, 18)"] if counts[1] else []
    warnings.warn(f"{source}: {' and '.join(parts)} of {counts[2]:,} points left out (`keep_rejected` "
                  "keeps them)", InputWarning, stacklevel=4)


def _chunk_table_problems(path: Path, size: int, header_size: int, offset: int, n_vlr: int,
                          count: int) -> list[str]:
    """What is wrong with a LAZ file's chunk table (its count read plainly before lazrs
    reads it: a garbage count made it ask for 48 GB and abort the process)."""
    with open(path, "rb") as fh:
        fh.seek(header_size)
        vlrs = fh.read(max(0, offset - header_size))
        fh.seek(offset)
        table = fh.read(8)
    chunk_size, p = None, 0
    for _ in range(n_vlr):
        if p + 54 > len(vlrs):
            break
        user, record, length = vlrs[p + 2:p + 18], *struct.unpack_from("<HH", vlrs, p + 18)
        if user.rstrip(b"\0") == b"laszip encoded" and record == 22204 and length >= 16:
            chunk_size = struct.unpack_from("<I", vlrs, p + 54 + 12)[0]
        p += 54 + length
    if chunk_size is None or len(table) < 8:
        return []
    at = struct.unpack_from("<q", table)[0]
    if at == -1 or at == 0:  # no table written: lazrs says so itself
        return []
    if not offset + 8 <= at <= size - 8:
        return [f"its LAZ chunk table offset ({at:,}) lies outside the file (LASzip before 2.0 wrote "
                "none, which the LAZ decoder here needs)"]
    with open(path, "rb") as fh:
        fh.seek(at)
        version, chunks = struct.unpack("<II", fh.read(8))
    most = count if chunk_size == 0xFFFFFFFF else -(-count // max(chunk_size, 1)) + 1
    if version != 0 or chunks > max(most, 1):
        return [f"its LAZ chunk table (version {version}, {chunks:,} chunks) cannot hold {count:,} points"]
    return []


def check_header(path: Path) -> None:
    """Refuse at once a LAS header whose counts cannot fit in the file (a header claiming a
    billion records of a 15 KB file took minutes and gigabytes to fail in laspy).

    Parameters
    ----------
    path : Path

    Raises
    ------
    InputError
        Not a LAS file, or a count, size or offset beyond the file, named.
    """
    size = path.stat().st_size
    with open(path, "rb") as fh:
        head = fh.read(375)
    if len(head) < 227 or head[:4] != b"LASF":
        raise InputError(f"{path}: not a LAS/LAZ file (no LASF signature in a {len(head)}-byte header)")
    header_size, offset, n_vlr = struct.unpack_from("<HII", head, 94)
    fmt, rec_len, legacy = struct.unpack_from("<BHI", head, 104)
    count = legacy
    if head[25] >= 4 and len(head) >= 255:
        count = max(count, struct.unpack_from("<Q", head, 247)[0])
    problems = []
    if header_size < 227 or offset < header_size:
        problems.append(f"its header claims {header_size} bytes and its points start at byte {offset} "
                        "(a LAS header holds at least 227 bytes, the points follow it)")
    elif header_size > size or offset > size:
        problems.append(f"its header ({header_size} bytes) or point data offset ({offset:,}) lies past "
                        "its end")
    elif header_size + 54 * n_vlr > offset:
        problems.append(f"{n_vlr:,} variable-length records cannot fit in the {offset - header_size:,} bytes "
                        "before the points")
    compressed = bool(fmt & 0x80)
    if not compressed and offset + count * rec_len > size:
        problems.append(f"{count:,} points of {rec_len} bytes need {offset + count * rec_len:,} bytes")
    if compressed and not problems:
        problems += _chunk_table_problems(path, size, header_size, offset, n_vlr, count)
    if problems:
        raise InputError(f"{path}: a LAS header that cannot fit in the file's {size:,} bytes: "
                         f"{'; '.join(problems)}; expected counts and offsets within the file")


def _las_cloud(las: Any, header: Any, path: Path) -> PointCloud:
    """A cloud from laspy points (a whole file or a chunk of one) and the file's header."""
    points = las.points if hasattr(las, "points") else las
    xyz = np.empty((len(points), 3))
    raw, scales, offsets = points.array, points.scales, points.offsets
    for k, axis in enumerate("XYZ"):  # scaled into place: no copies stacked again
        np.multiply(raw[axis], scales[k], out=xyz[:, k])
        xyz[:, k] += offsets[k]
    dims = set(las.point_format.dimension_names)
    fields: dict[str, np.ndarray] = {}
    for name, field, kind in (("intensity", "intensity", np.float64), ("withheld", "withheld", bool),
                              ("classification", "classification", np.int32),
                              ("point_source_id", "line", np.int32)):
        if name in dims:
            values = np.asarray(las[name])
            if _any(values):
                fields[field] = values.astype(kind)
    for angle in ("scan_angle", "scan_angle_rank"):
        if angle in dims:
            values = np.asarray(las[angle])
            if _any(values):
                fields["beam_angle"] = values.astype(np.float64) * (0.006 if angle == "scan_angle" else 1.0)
                break
    for extra in las.point_format.extra_dimension_names:
        values = np.asarray(las[extra])
        if values.ndim == 2:  # an array of values per point (a colour triple): one field each
            fields.update({f"{extra}_{k}": np.array(values[:, k]) for k in range(values.shape[1])})
        else:
            fields[extra] = np.array(values)  # a copy: nothing refers to a mapped file
    if "intensity_db" in fields:  # written by us: exact float intensity
        fields["intensity"] = np.asarray(fields.pop("intensity_db"), dtype=np.float64)
    crs = None
    try:
        parsed = header.parse_crs()
        crs = parsed.to_wkt() if parsed is not None else None
    except Exception:  # pyproj missing or no CRS: not an error
        crs = None
    return PointCloud(xyz, fields, source=str(path), crs=crs)


def _any(values: np.ndarray) -> bool:
    """Whether any value is non-zero: a sample first, the whole array only if that is all zero."""
    return bool(values[:: max(1, len(values) // 4096)].any() or values.any())


def _write_las(cloud: PointCloud, path: Path, precision: int) -> None:
    import laspy

    header = laspy.LasHeader(point_format=6, version="1.4")
    lo = bounds(cloud.xyz, 3)[0] if len(cloud) else np.zeros(3)
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
        # NaN (a beam without backscatter) as 0 in the integer field; intensity_db keeps it exactly
        level = np.nan_to_num(np.round(cloud.fields["intensity"]))
        las.intensity = np.clip(level, 0, 65535).astype(np.uint16)
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
    return _read_las(path, request.keep_rejected)


def _count(path: Path) -> int:
    import laspy

    check_header(path)
    try:
        with laspy.open(path) as r:
            return int(r.header.point_count)
    except (KeyboardInterrupt, SystemExit, GeneratorExit):
        raise
    except BaseException as exc:  # as in a read: laspy raises many types
        raise InputError(f"{path}: not a readable LAS/LAZ file ({_reason(exc)})") from None


FORMAT = Format("las", (".las", ".laz"), _read, _write_las, 30.0, aliases=("laz",), count=_count,
                writes=(".las", ".laz"), options=("keep_rejected",),
                chunks=iter_las,
                fields="intensity, classification, line (point source id), beam_angle (scan angle), "
                       "any extra bytes")
