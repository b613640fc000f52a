"""ASCII exports (x y z and more columns): the cloud from :mod:`.ascii_parse`, longitude
and latitude projected, doubts about the sign of z said."""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..cloud import PointCloud
from ..crs import ScaleError, looks_geographic, project_lonlat
from ..errors import InputError, InputWarning, ParameterError
from .ascii_parse import DEPTH_NAMES, ELEVATION_NAMES, read_ascii
from .base import Format, ReadRequest

__all__ = ["FORMAT"]



def _read_ascii(p: Path, *, columns: str | Sequence[str] | None, delimiter: str | None, decimal: str | None,
                depth_positive: bool, z_up: bool, crs: str | None,
                progress: Callable[[float], None] | None = None) -> PointCloud:
    """An ASCII file as a cloud: geographic files projected, doubts about z said."""

    if decimal not in (None, ".", ","):
        raise ParameterError(f"decimal: {decimal!r}; expected '.' or ','", option="decimal")
    xyz, fields, table = read_ascii(p, columns=columns, delimiter=delimiter, decimal=decimal,
                                    progress=progress)
    meta: dict[str, Any] = {"format": "xyz", "z_name": table.z_name}
    geographic = table.geographic or (table.header is None and looks_geographic(xyz)) or (
        columns is not None and looks_geographic(xyz))
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
        try:
            x, y, out_crs, name = project_lonlat(xyz[:, 0], xyz[:, 1], crs)
        except ScaleError as exc:
            if crs is not None:
                raise
            raise InputError(f"{p}: {exc}") from None
        why = "the header names latitude and longitude" if table.geographic else \
            "x and y lie within degree ranges spanning under a degree"
        warnings.warn(f"{p}: read as longitude and latitude ({why}); projected to {name}", InputWarning,
                      stacklevel=3)
        xyz = np.column_stack([x, y, xyz[:, 2]])
        meta["geographic"] = True
    return PointCloud(xyz, fields, source=str(p), crs=out_crs, meta=meta)


def _field_format(name: str, values: np.ndarray) -> str:
    """Each field written as it reads back: whole numbers whole, times to the microsecond
    (``%.6g`` rounded a time to the 1000 s), other values to nine significant digits."""
    v = np.asarray(values)
    if v.dtype.kind in "iub" or (v.dtype.kind == "f" and np.isfinite(v).all() and np.all(v == np.round(v))
                                 and np.abs(v).max(initial=0) < 2**53):
        return "%d"
    return "%.6f" if name == "time" else "%.9g"


def _write_ascii(cloud: PointCloud, path: Path, precision: int) -> None:
    names = ["x", "y", "z"] + [k for k in cloud.fields]
    table = np.column_stack([cloud.xyz] + [np.asarray(v, np.float64) for v in cloud.fields.values()])
    delim = "," if path.suffix.lower() == ".csv" else " "
    fmt = [f"%.{precision}f"] * 3 + [_field_format(k, v) for k, v in cloud.fields.items()]
    np.savetxt(path, table, fmt=fmt, delimiter=delim, header=delim.join(names), comments="")



def _read(path: Path, request: ReadRequest) -> PointCloud:
    return _read_ascii(path, columns=request.columns, delimiter=request.delimiter, decimal=request.decimal,
                       depth_positive=request.depth_positive, z_up=request.z_up, crs=request.crs,
                       progress=request.progress)


FORMAT = Format("xyz", (".xyz", ".txt", ".csv", ".pts", ".asc"), _read, _write_ascii, 30.0,
                aliases=("ascii", "txt", "csv"), options=("columns", "delimiter", "decimal", "z_up"),
                fields="any named or mapped column")
