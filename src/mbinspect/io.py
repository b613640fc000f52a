"""Point clouds in and out: a small container, readers and writers.

Points are ``(N, 3)`` float64 in metres, x east, y north, z elevation (up, so
depths are negative). Readers never guess the sign of z: exports that write depth
positive down are read with ``depth_positive=True``.

Formats, chosen by extension or ``format=``:

========  =====================================  ==================================
format    extensions                             per-point fields kept
========  =====================================  ==================================
xyz       .xyz .txt .csv .pts .asc               any named or mapped column
las       .las .laz                              intensity, classification, line
                                                 (point source id), beam_angle
                                                 (scan angle), any extra bytes
ply       .ply (ascii and binary)                every vertex property
npz       .npz                                   every array of length N
========  =====================================  ==================================

Examples
--------
>>> import numpy as np, tempfile, pathlib
>>> from mbinspect.io import PointCloud, read, write
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> cloud = PointCloud(np.array([[0.0, 0.0, -20.0], [1.0, 0.0, -20.5]]))
>>> write(cloud, d / "two.xyz")
>>> len(read(d / "two.xyz"))
2
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from .ascii import DELIMITERS, DEPTH_NAMES, ELEVATION_NAMES, parse_columns, read_ascii
from .cloud import PointCloud, crs_name, pipeline_input
from .errors import FileAccessError, InputError, InputWarning, ParameterError
from .outputs import atomic_path, dataclasses_asdict

__all__ = [
    "PointCloud",
    "FORMATS",
    "read",
    "write",
    "format_from_path",
    "parse_columns",
    "check_read_options",
    "pipeline_input",
    "CloudSummary",
    "crs_name",
    "describe",
]



#: Recognised formats and the extensions that select them.
FORMATS: dict[str, tuple[str, ...]] = {
    "xyz": (".xyz", ".txt", ".csv", ".pts", ".asc"),
    "las": (".las", ".laz"),
    "ply": (".ply",),
    "npz": (".npz",),
    "gsf": (".gsf", ".mb121"),
    "kmall": (".kmall",),
    "all": (".all", ".mb56"),
}

#: The sonar makers' formats, read by :mod:`mbinspect.sonar` and projected on reading.
SONAR_FORMATS = ("gsf", "kmall", "all")

#: Other names a format may be given by (``--format laz`` reads LAZ through the LAS reader).
FORMAT_ALIASES: dict[str, str] = {"laz": "las", "ascii": "xyz", "txt": "xyz", "csv": "xyz"}

#: Every name ``format=`` accepts.
FORMAT_NAMES: tuple[str, ...] = ("xyz", "las", "laz", "ply", "npz", "gsf", "kmall", "all")




def format_from_path(path: str | os.PathLike[str], format: str | None = None) -> str:
    """The format name for ``path`` (or the explicit ``format``).

    Parameters
    ----------
    path : path-like
    format : str, optional
        An explicit format name or alias (``laz`` is read by the LAS reader).

    Returns
    -------
    str
        ``xyz``, ``las``, ``ply`` or ``npz``.

    Raises
    ------
    ParameterError
        An unknown ``format`` (``option="format"``).
    InputError
        An extension that names no format.

    Examples
    --------
    >>> format_from_path("survey.LAZ"), format_from_path("a.dat", "csv")
    ('las', 'xyz')
    """
    if format is not None:
        fmt = FORMAT_ALIASES.get(format.lower(), format.lower())
        if fmt not in FORMATS:
            raise ParameterError(
                f"format: {format!r}; expected one of {', '.join(FORMAT_NAMES)}", option="format"
            )
        return fmt
    suffix = Path(path).suffix.lower()
    for fmt, exts in FORMATS.items():
        if suffix in exts:
            return fmt
    known = " ".join(e for exts in FORMATS.values() for e in exts)
    raise InputError(
        f"{path}: unknown extension {suffix or '(none)'!r}; expected one of {known} "
        "or an explicit `format`"
    )


# --------------------------------------------------------------------------- reading


def check_read_options(path: str | os.PathLike[str], *, format: str | None = None,
                       columns: str | Sequence[str] | None = None, delimiter: str | None = None) -> str:
    """Check the reading options of :func:`read` without reading; return the format.

    Parameters
    ----------
    path : path-like
        The file (its extension decides the format unless ``format`` is given).
    format, columns, delimiter
        As :func:`read`.

    Returns
    -------
    str
        The format name (``xyz``, ``las``, ``ply`` or ``npz``).

    Raises
    ------
    ParameterError
        Naming the option: an unknown format or delimiter, a column map without one x, y
        and z, a column map for a file that is not ASCII.
    InputError
        An extension that names no format.

    Examples
    --------
    >>> check_read_options("survey.laz"), check_read_options("a.txt", format="laz")
    ('las', 'las')
    """
    fmt = format_from_path(path, format)
    if delimiter is not None and delimiter.lower() not in DELIMITERS:
        raise ParameterError(f"delimiter: {delimiter!r}; expected one of ',' ';' tab space",
                             option="delimiter")
    if columns is not None:
        if fmt != "xyz":
            raise ParameterError(f"columns: {columns!r} given for the {fmt} file {path}; expected it "
                                 "for ASCII files only", option="columns")
        parse_columns(columns)
    return fmt


def read(
    path: str | os.PathLike[str],
    *,
    format: str | None = None,
    columns: str | Sequence[str] | None = None,
    depth_positive: bool = False,
    delimiter: str | None = None,
    crs: str | None = None,
    keep_rejected: bool = False,
    decimal: str | None = None,
    z_up: bool = False,
    progress: Callable[[float], None] | None = None,
) -> PointCloud:
    """Read a point cloud file.

    Parameters
    ----------
    path : path-like
        The file to read.
    format : {"xyz", "las", "laz", "ply", "npz"}, optional
        Overrides the format inferred from the extension.
    columns : str or sequence of str, optional
        ASCII only: what each column holds, e.g. ``"x,y,z,intensity"`` or
        ``"x,y,-,z"`` (``-`` skips a column). Default: the header names when there
        is a header; else 3 columns are x y z and 4 are x y z intensity.
    depth_positive : bool
        The file stores depth positive down: z is negated so that it is elevation.
        Never guessed; default False.
    delimiter : {",", ";", "tab", "space"}, optional
        ASCII only: the column delimiter. Default: sniffed from the first data
        line (comma, semicolon, tab or whitespace).
    crs : str, optional
        Sonar formats (GSF, KMALL, .all): the projected CRS to put the soundings in
        (default: the UTM zone of the data). Other formats: the CRS of the file's
        coordinates when the file does not say it.
    keep_rejected : bool
        Sonar formats: keep the soundings the sonar or the file rejected (the ``valid``
        field says which); default False.
    decimal : {".", ","}, optional
        ASCII only: the decimal mark; default sniffed (``554845,028;...`` has commas).
    z_up : bool
        The file's z is elevation, positive up. With neither this nor ``depth_positive``, a
        file whose z is mostly positive under a header that does not say which (``z``, or
        none) is read as given but marked doubtful (``meta["z_doubt"]``); the pipelines
        refuse such a cloud.
    progress : callable, optional
        ASCII only: called with the fraction of the file parsed.

    Returns
    -------
    PointCloud

    Raises
    ------
    FileAccessError
        Missing file, a directory, unreadable.
    InputError
        Malformed content; the message names the line and column.
    """
    p = Path(path)
    if not p.exists():
        raise FileAccessError(f"{p}: no such file")
    if p.is_dir():
        raise FileAccessError(f"{p}: is a directory, expected a point cloud file")
    fmt = check_read_options(p, format=format, columns=columns, delimiter=delimiter)
    try:
        if p.stat().st_size == 0:
            raise InputError(f"{p}: the file is empty")
        if fmt in SONAR_FORMATS:
            if depth_positive:
                raise ParameterError(f"depth_positive: given for the {fmt} file {p}; expected it only "
                                     "for exports (a sonar file says what its heights are)",
                                     option="depth_positive")
            from .sonar import read_sonar, to_cloud

            return to_cloud(read_sonar(p, fmt), crs=crs, keep_rejected=keep_rejected)
        if fmt == "xyz":
            cloud = _read_ascii(p, columns=columns, delimiter=delimiter, decimal=decimal,
                                depth_positive=depth_positive, z_up=z_up, crs=crs, progress=progress)
            crs = None if cloud.meta.get("geographic") else crs
        elif fmt == "las":
            cloud = _read_las(p)
        elif fmt == "ply":
            cloud = _read_ply(p)
        else:
            cloud = _read_npz(p)
    except PermissionError as exc:
        raise FileAccessError(f"{p}: cannot be read ({exc.strerror})") from None
    if len(cloud) == 0:
        raise InputError(f"{p}: the file holds no points")
    bad = ~np.isfinite(cloud.xyz).all(axis=1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(
            f"{p}: point {i + 1} has a non-finite coordinate {cloud.xyz[i].tolist()}; "
            "expected finite numbers"
        )
    if depth_positive:
        xyz = cloud.xyz.copy()
        xyz[:, 2] *= -1.0
        cloud = replace(cloud, xyz=xyz, z_convention="depth")
    if crs is not None:
        cloud = _declare_crs(cloud, crs)
    return cloud




def _looks_geographic(xyz: np.ndarray) -> bool:
    """Longitude and latitude without a header: degree ranges spanning under a degree."""
    if len(xyz) < 3:
        return False
    x, y = xyz[:, 0], xyz[:, 1]
    return bool(np.abs(x).max() <= 180 and np.abs(y).max() <= 90 and np.ptp(x) < 1 and np.ptp(y) < 1
                and (np.ptp(x) > 0 or np.ptp(y) > 0))


def _read_ascii(p: Path, *, columns: str | Sequence[str] | None, delimiter: str | None, decimal: str | None,
                depth_positive: bool, z_up: bool, crs: str | None,
                progress: Callable[[float], None] | None = None) -> PointCloud:
    """An ASCII file as a cloud: geographic files projected, doubts about z said."""
    import warnings

    if decimal not in (None, ".", ","):
        raise ParameterError(f"decimal: {decimal!r}; expected '.' or ','", option="decimal")
    xyz, fields, table = read_ascii(p, columns=columns, delimiter=delimiter, decimal=decimal,
                                    progress=progress)
    meta: dict[str, Any] = {"format": "xyz", "z_name": table.z_name}
    geographic = table.geographic or (table.header is None and columns is None and _looks_geographic(xyz))
    if table.z_name in DEPTH_NAMES and not (depth_positive or z_up):
        # the header says depth: still never flip silently, but say so once.
        warnings.warn(f"{p}: the header names a depth column; z is read as given, as elevation (give "
                      "`depth_positive` if it is positive down)", InputWarning, stacklevel=3)
    settled = depth_positive or z_up or table.z_name in ELEVATION_NAMES | DEPTH_NAMES
    if not settled and np.mean(xyz[:, 2] > 0) > 0.5:
        meta["z_doubt"] = (f"{p}: most z values are positive and nothing says whether they are depths or "
                           "elevations; give `depth_positive` for depths (positive down) or `z_up` for "
                           "elevations")
        warnings.warn(meta["z_doubt"], InputWarning, stacklevel=3)
    out_crs = None
    if geographic:
        from .sonar.common import project_lonlat

        x, y, out_crs, name = project_lonlat(xyz[:, 0], xyz[:, 1], crs)
        why = "the header names latitude and longitude" if table.geographic else \
            "x and y lie within degree ranges spanning under a degree"
        warnings.warn(f"{p}: read as longitude and latitude ({why}); projected to {name}", InputWarning,
                      stacklevel=3)
        xyz = np.column_stack([x, y, xyz[:, 2]])
        meta["geographic"] = True
    return PointCloud(xyz, fields, source=str(p), crs=out_crs, meta=meta)


def _declare_crs(cloud: PointCloud, crs: str) -> PointCloud:
    """The cloud with ``crs`` as the CRS of its coordinates (checked by pyproj)."""
    from pyproj import CRS
    from pyproj.exceptions import CRSError

    try:
        given = CRS.from_user_input(crs)
    except CRSError:
        raise ParameterError(f"crs: {crs!r}; expected a CRS such as EPSG:32631", option="crs") from None
    if cloud.crs is not None and not CRS.from_user_input(cloud.crs).equals(given):
        raise ParameterError(f"crs: {crs!r}, but {cloud.source} says {CRS.from_user_input(cloud.crs).name}; "
                             "expected no crs for a file that has one (reprojection is not done here)",
                             option="crs")
    return replace(cloud, crs=given.to_wkt())


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


_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}


def _read_ply(path: Path) -> PointCloud:
    with open(path, "rb") as fh:
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
                break
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
            table = np.loadtxt(fh, dtype=np.float64, max_rows=count, ndmin=2)
            if table.shape[0] != count or table.shape[1] != len(props):
                raise InputError(
                    f"{path}: expected {count} vertices of {len(props)} values, "
                    f"got {table.shape[0]} of {table.shape[1] if table.size else 0}"
                )
            data = {n: table[:, i] for i, n in enumerate(names)}
            if len(elements) == 1 and fh.read(4096).strip():
                raise InputError(f"{path}: the header announces {count} vertices but more data follow; "
                                 "expected the count of every vertex")
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


def _read_npz(path: Path) -> PointCloud:
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except Exception as exc:
        raise InputError(f"{path}: not a readable NPZ file ({exc})") from None
    meta: dict[str, Any] = {}
    if "__meta__" in arrays:
        meta = json.loads(str(arrays.pop("__meta__")))
    if "xyz" in arrays:
        xyz = arrays.pop("xyz")
    elif {"x", "y", "z"} <= set(arrays):
        xyz = np.column_stack([arrays.pop("x"), arrays.pop("y"), arrays.pop("z")])
    else:
        raise InputError(f"{path}: expected an 'xyz' array or 'x', 'y', 'z' arrays")
    if xyz.ndim != 2 or xyz.shape[1] != 3:
        raise InputError(f"{path}: 'xyz' has shape {xyz.shape}, expected (N, 3)")
    n = xyz.shape[0]
    fields = {k: v for k, v in arrays.items() if v.shape == (n,)}
    return PointCloud(
        xyz.astype(np.float64), fields, source=str(path), crs=meta.get("crs")
    )


# --------------------------------------------------------------------------- writing


def write(
    cloud: PointCloud,
    path: str | os.PathLike[str],
    *,
    format: str | None = None,
    precision: int = 3,
) -> None:
    """Write ``cloud`` to ``path`` atomically (a crash never leaves half a file).

    Parameters
    ----------
    cloud : PointCloud
    path : path-like
    format : {"xyz", "las", "laz", "ply", "npz"}, optional
        Default from the extension (``.laz`` writes compressed LAS).
    precision : int
        Decimals for ASCII output and the LAS scale (3 = millimetres).
    """
    fmt = format_from_path(path, format)
    writers: dict[str, Callable[[PointCloud, Path, int], None]] = {
        "xyz": _write_ascii, "las": _write_las, "ply": _write_ply, "npz": _write_npz,
    }
    with atomic_path(path) as tmp:  # the temporary keeps the suffix (.laz compresses)
        writers[fmt](cloud, tmp, precision)


def _write_ascii(cloud: PointCloud, path: Path, precision: int) -> None:
    names = ["x", "y", "z"] + [k for k in cloud.fields]
    table = np.column_stack([cloud.xyz] + [np.asarray(v, np.float64) for v in cloud.fields.values()])
    delim = "," if path.suffix.lower() == ".csv" else " "
    fmt = [f"%.{precision}f"] * 3 + ["%.6g"] * len(cloud.fields)
    np.savetxt(path, table, fmt=fmt, delimiter=delim, header=delim.join(names), comments="")


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


def _write_npz(cloud: PointCloud, path: Path, precision: int) -> None:
    meta = json.dumps({"crs": cloud.crs, "source": cloud.source})
    with open(path, "wb") as fh:
        arrays: dict[str, Any] = {"xyz": cloud.xyz, "__meta__": np.array(meta), **cloud.fields}
        np.savez_compressed(fh, **arrays)


@dataclass(frozen=True)
class CloudSummary:
    """What ``mbinspect info`` prints: counts, extent, fields, density and what the file says.

    Attributes
    ----------
    n_points : int
    bounds_min, bounds_max : tuple of float
        Corners (x, y, z) in metres.
    fields : tuple of str
    area : float
        Covered area (m^2): occupied cells of a ``cell`` m grid.
    density : float
        Mean points per covered m^2.
    spacing : float
        Median plan distance to the nearest other point (m), the neighbours searched among
        all the points (a sample of up to 200 000 points is measured).
    cell : float
        The grid cell of ``area`` (m): given, or chosen from the spacing.
    crs, crs_name : str or None
        The CRS (WKT) and its name.
    sonar : dict
        For sonar files: format, sonar, pings, beam-angle range (deg), time span (UTC).
    """

    source: str | None
    n_points: int
    bounds_min: tuple[float, float, float]
    bounds_max: tuple[float, float, float]
    fields: tuple[str, ...]
    area: float
    density: float
    spacing: float
    cell: float
    crs: str | None
    z_convention: str
    crs_name: str | None = None
    sonar: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The summary as JSON-ready values (``mbinspect info --json``)."""
        d = dataclasses_asdict(self)
        d["z_range"] = [self.bounds_min[2], self.bounds_max[2]]
        return d


def _nice_cell(spacing: float) -> float:
    """A round grid cell (m) about three sounding spacings wide, at least 0.1 m."""
    if not math.isfinite(spacing) or spacing <= 0:
        return 1.0
    target = max(0.1, 3.0 * spacing)
    steps = np.array([1.0, 2.0, 5.0, 10.0])
    base = 10.0 ** math.floor(math.log10(target))
    return float(base * steps[np.searchsorted(steps, target / base - 1e-9)])


def _sonar_summary(cloud: PointCloud) -> dict[str, Any]:
    meta = dict(cloud.meta)
    if meta.get("format") not in SONAR_FORMATS:
        return {}
    keys = ("format", "sonar", "version", "pings", "lines", "level")
    out: dict[str, Any] = {k: meta.get(k) for k in keys if k in meta}
    if "beam_angle" in cloud.fields and len(cloud):
        a = cloud.fields["beam_angle"]
        out["beam_angle_range_deg"] = [float(np.nanmin(a)), float(np.nanmax(a))]
    if "time" in cloud.fields and len(cloud):
        import datetime as dt

        t = cloud.fields["time"]
        out["time_span"] = [dt.datetime.fromtimestamp(float(v), dt.UTC).isoformat(timespec="seconds")
                            for v in (np.nanmin(t), np.nanmax(t))]
    return out


def describe(cloud: PointCloud, *, cell: float | None = None, seed: int = 0) -> CloudSummary:
    """Summarise a cloud like ``pdal info`` or ``lasinfo`` do.

    Parameters
    ----------
    cloud : PointCloud
    cell : float, optional
        Grid cell (m) used to measure the covered area; default about three sounding
        spacings, rounded (so sparse deep data and dense shallow data both read right).
    seed : int
        Seed of the sample of points whose nearest neighbour is measured.

    Returns
    -------
    CloudSummary

    Examples
    --------
    >>> g = np.arange(0.0, 10.0, 0.1)
    >>> c = PointCloud(np.column_stack([np.repeat(g, 100), np.tile(g, 100), np.full(10_000, -20.0)]))
    >>> s = describe(c)
    >>> round(s.spacing, 3), s.cell, round(s.area), round(s.density)
    (0.1, 0.5, 100, 100)
    """
    from .checks import positive
    from .grid import sounding_spacing

    if cell is not None:
        positive("cell", cell)
    lo, hi = cloud.bounds()
    xy = cloud.xyz[:, :2] - lo[:2]
    # the neighbours are searched among all points: a subsample's own neighbours lie
    # several spacings apart and would overstate the spacing
    spacing = sounding_spacing(xy, sample=200_000, seed=seed)
    used = cell if cell is not None else _nice_cell(spacing)
    ij = np.floor(xy / used).astype(np.int64)
    keys = ij[:, 0] * (int((hi[1] - lo[1]) / used) + 2) + ij[:, 1]
    area = float(len(np.unique(keys))) * used * used
    return CloudSummary(
        source=cloud.source, n_points=len(cloud),
        bounds_min=tuple(float(v) for v in lo), bounds_max=tuple(float(v) for v in hi),  # type: ignore[arg-type]
        fields=tuple(cloud.fields), area=area, density=len(cloud) / area, spacing=spacing,
        cell=used, crs=cloud.crs, z_convention=cloud.z_convention,
        crs_name=crs_name(cloud.crs, epsg=False) if cloud.crs else None,
        sonar=_sonar_summary(cloud),
    )


