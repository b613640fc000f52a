"""NumPy ``.npz``: an ``xyz`` array (or ``x``, ``y``, ``z``), every array of length N as a
field, the CRS in ``__meta__``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from ..cloud import PointCloud
from ..errors import InputError
from .base import Format, ReadRequest

__all__ = ["FORMAT"]



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


def _write_npz(cloud: PointCloud, path: Path, precision: int) -> None:
    meta = json.dumps({"crs": cloud.crs, "source": cloud.source})
    with open(path, "wb") as fh:
        arrays: dict[str, Any] = {"xyz": cloud.xyz, "__meta__": np.array(meta), **cloud.fields}
        np.savez_compressed(fh, **arrays)



def _read(path: Path, request: ReadRequest) -> PointCloud:
    return _read_npz(path)


FORMAT = Format("npz", (".npz",), _read, _write_npz, 28.0, fields="every array of length N")
