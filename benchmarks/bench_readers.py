"""Sonar reader speed: mbinspect's readers beside the PyPI readers a user would pick.

Run: ``python benchmarks/bench_readers.py [--mb 50]``. Builds files of about 50 MB by
repeating a real file's depth records (``../shared/real/files``: KMALL ``ets_kmall_eg``,
.all ``ets_all_a_y``, GSF ``GSF3_08``), then times, in the same run: mbinspect's reader
alone (soundings with geographic positions), mbinspect's ``read`` (projected to UTM, the
rejected dropped), pykmall 1.1.1 (``extractLonLatZ``) and gsfu 0.5.1 (``iter_records`` over
the ping records); Kongsberg .all has no maintained PyPI reader (``pyall`` on PyPI is an
unrelated package). Prints seconds, million soundings per second and the ratio to the peer,
and the peak resident memory of each run (a fresh process each).
"""

from __future__ import annotations

import argparse
import json
import struct
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import table  # noqa: E402

REAL = Path(__file__).resolve().parents[2] / "shared" / "real" / "files"
SOURCES = {"kmall": "ets_kmall_eg_-7360358516350552537.kmall",
           "all": "ets_all_a_y_-1333931979274893952.all", "gsf": "GSF3_08_test_file.gsf"}


def _records(data: bytes, fmt: str) -> list[tuple[int, int, bool]]:
    """(offset, length, is_depth_record) of every record of a file."""
    out, off = [], 0
    order = "<" if fmt != "gsf" else ">"
    if fmt == "all" and data[4] != 2:
        order = ">"
    while off + 8 <= len(data):
        size, = struct.unpack_from(order + "I", data, off)
        if fmt == "kmall":
            length, depth = size, data[off + 4:off + 8] == b"#MRZ"
        elif fmt == "all":
            length, depth = size + 4, data[off + 5] in (0x58, 0x44)
        else:
            ident, = struct.unpack_from(">I", data, off + 4)
            length, depth = size + 8 + (4 if ident & 0x80000000 else 0), (ident & 0x3FFFFF) == 2
            length = size + 8
        out.append((off, length, depth))
        off += length
    return out


def build(fmt: str, mb: float, folder: Path) -> Path:
    """A file of about ``mb`` MB: the real file's other records once, its depth records repeated."""
    data = (REAL / SOURCES[fmt]).read_bytes()
    recs = _records(data, fmt)
    head = b"".join(data[o:o + n] for o, n, d in recs if not d)
    depth = b"".join(data[o:o + n] for o, n, d in recs if d)
    copies = max(1, int(mb * 2**20 // max(len(depth), 1)))
    path = folder / f"big{Path(SOURCES[fmt]).suffix}"
    path.write_bytes(head + depth * copies)
    return path


_CHILD = r"""
import json, resource, sys, time
fmt, how, path = sys.argv[1:4]
import pyproj  # noqa: F401  (imports are not timed)
from mbinspect.io import read
from mbinspect.sonar import read_sonar
if how == "pykmall":
    from KMALL.kmall import kmall
if how == "gsfu":
    from GSFU.gsfu import gsf, RecordType
t = time.perf_counter()
if how == "ours-raw":
    n = len(read_sonar(path, fmt))
elif how == "ours-read":
    n = len(read(path, keep_rejected=True))
elif how == "pykmall":
    k = kmall(path); k.index_file(); lon, lat, z = k.extractLonLatZ(); n = len(z)
else:
    n = sum(1 for _ in gsf(path).iter_records(record_type=RecordType.GSF_RECORD_SWATH_BATHYMETRY_PING))
s = time.perf_counter() - t
print(json.dumps({"s": s, "n": n, "rss": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def run(fmt: str, how: str, path: Path) -> dict:
    out = subprocess.run([sys.executable, "-c", _CHILD, fmt, how, str(path)], capture_output=True,
                         text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--mb", type=float, default=50.0)
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for fmt, peer in (("kmall", "pykmall"), ("all", None), ("gsf", "gsfu")):
            path = build(fmt, args.mb, Path(tmp))
            size = path.stat().st_size / 2**20
            ours = min((run(fmt, "ours-raw", path) for _ in range(3)), key=lambda r: r["s"])
            full = min((run(fmt, "ours-read", path) for _ in range(2)), key=lambda r: r["s"])
            other = run(fmt, peer, path) if peer else None
            n = ours["n"]
            rows.append([fmt, f"{size:.0f} MB", f"{n / 1e6:.2f} M",
                         f"{ours['s']:.2f} s ({n / ours['s'] / 1e6:.1f} M/s)",
                         f"{full['s']:.2f} s ({full['n'] / full['s'] / 1e6:.1f} M/s)",
                         f"{peer}: {other['s']:.2f} s" if other else "no PyPI reader",
                         f"{other['s'] / ours['s']:.1f}x" if other else "-",
                         f"{ours['rss']:.0f} / {full['rss']:.0f}"
                         + (f" / {other['rss']:.0f}" if other else "")])
    print(table(["format", "file", "soundings", "ours (geographic)", "ours read() (UTM)", "peer",
                 "peer / ours", "peak RSS MiB (ours / read / peer)"], rows))


if __name__ == "__main__":
    main()
