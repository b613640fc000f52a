"""Every real file of ``../shared/real/files`` read by mbinspect, against its independent decode.

Run: ``python benchmarks/readers_vs_reference.py``. Per file: soundings read (all / valid)
beside the reference's, whether the valid flags agree sounding by sounding, the largest
depth difference, and the largest plan difference, raw and with the reference put right:
the reference adds the along/across offsets of .all and GSF soundings in the UTM plane as
if grid north were true north, while mbinspect turns them by the true heading on the
ellipsoid; turning the reference's offsets by the grid convergence and scaling them by the
UTM scale factor removes that difference (KMALL positions are per sounding in the file: no
correction). Files a reader refuses are listed with the reason. The XTF file has no decode
in ``../shared/real/reference``: it is decoded here by ``tools/xtf_reference.py`` (pyxtf's
framing, its own BTH0 parse, pyproj's geodesic) when pyxtf is installed; its positions are
per sounding (no correction).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from pyproj import Proj, Transformer

sys.path.insert(0, str(Path(__file__).parent))
from _common import table  # noqa: E402
from mbinspect.errors import MBInspectError  # noqa: E402
from mbinspect.io import format_from_path  # noqa: E402
from mbinspect.sonar import read_sonar, to_cloud, utm_crs  # noqa: E402

REAL = Path(__file__).resolve().parents[2] / "shared" / "real"


def put_right(ref: dict[str, np.ndarray], crs: str) -> np.ndarray:
    """The reference positions with their offsets turned by the convergence and scaled."""
    lon, lat = Transformer.from_crs(crs, "EPSG:4326", always_xy=True).transform(ref["sx"], ref["sy"])
    f = Proj(crs).get_factors(lon, lat)
    g, k = np.radians(np.asarray(f.meridian_convergence)), np.asarray(f.meridional_scale)
    ox, oy = ref["xyz"][:, 0] - ref["sx"], ref["xyz"][:, 1] - ref["sy"]
    return np.column_stack([ref["sx"] + k * (ox * np.cos(g) - oy * np.sin(g)),
                            ref["sy"] + k * (ox * np.sin(g) + oy * np.cos(g))])


def _xtf_reference(path: Path) -> dict[str, np.ndarray] | None:
    """The XTF file decoded by tools/xtf_reference.py (None without pyxtf)."""
    try:
        sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))
        from xtf_reference import decode
    except ImportError:
        return None
    return decode(str(path))


def main() -> None:
    rows = []
    for path in sorted((REAL / "files").iterdir()):
        if path.suffix == ".md":
            continue
        fmt = format_from_path(path)
        try:
            s = read_sonar(path, fmt)
        except MBInspectError as exc:
            why = str(exc).split(": ", 1)[1][:60]
            rows.append([path.name[:34], fmt, "refused", "-", "-", "-", "-", "-", why])
            continue
        ref_path = REAL / "reference" / f"{path.stem}.npz"
        ref = _xtf_reference(path) if fmt == "xtf" else None
        if ref is None and not ref_path.exists():
            rows.append([path.name[:34], fmt, f"{len(s)} / {int(s.fields['valid'].sum())}", "no decode",
                         "-", "-", "-", "-", ""])
            continue
        ref = ref if ref is not None else dict(np.load(ref_path))
        valid = s.fields["valid"]
        agree = len(s) == len(ref["xyz"]) and bool((valid == ref["valid"].astype(bool)).all())
        c = to_cloud(s, keep_rejected=True)
        crs = utm_crs(float(np.median(s.lat)), float(np.median(s.lon)))
        v = valid & ref["valid"].astype(bool)
        dz = np.abs(c.xyz[v, 2] - ref["xyz"][v, 2]).max()
        raw = np.hypot(*(c.xyz[v, :2] - ref["xyz"][v, :2]).T).max()
        right = raw if fmt in ("kmall", "xtf") else np.hypot(*(c.xyz[v, :2] - put_right(ref, crs)[v]).T).max()
        rows.append([path.name[:34], fmt, f"{len(s)} / {int(valid.sum())}",
                     f"{len(ref['xyz'])} / {int(ref['valid'].sum())}", "yes" if agree else "NO",
                     f"{100 * dz:.2f}", f"{raw:.2f}", f"{right:.3f}", ""])
    print(table(["file", "format", "ours all / valid", "reference", "flags agree", "depth max cm",
                 "plan max m (raw)", "plan max m (put right)", "refused because"], rows))


if __name__ == "__main__":
    main()
