"""Every real file of ``../shared/real/files`` through ``mbinspect reefs`` four ways: in memory,
tiled on two Dask workers, and written out as LAS and as ASCII then read back (in memory).

Run: ``python benchmarks/real_four_ways.py [--only NAME] [--command reefs] [--with FLAGS]``
(``--with`` adds flags to every run). Per file: the
exit status and the outcome line of each way (the summary, or the error or no-answer reason
up to its first ';'), whether the four agree, and any traceback. The files a reader refuses
give the same refusal each way they can be run (the exports need a read).
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import REAL, table  # noqa: E402


def _run(args: list[str]) -> tuple[int, str, bool]:
    """Exit status, the outcome line, and whether a traceback was printed."""
    p = subprocess.run([sys.executable, "-m", "mbinspect.cli", *args], capture_output=True, text=True)
    lines = [x for x in (p.stdout + p.stderr).splitlines() if x.strip()]
    outcome = next((x for x in lines if re.match(r"(\d+ reefs|\d+ piles|mbinspect: (error|no answer))", x)),
                   lines[-1] if lines else "")
    outcome = re.sub(r"^mbinspect: (error|no answer): ", "", outcome).split(";")[0]
    outcome = re.sub(r" \(so says every tile.*", "", outcome)
    return p.returncode, outcome[:80], "Traceback" in p.stderr


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--only", default="", help="only the files whose name holds this")
    ap.add_argument("--command", default="reefs", choices=["reefs", "piles"])
    ap.add_argument("--with", dest="more", default="",
                    help="more flags for every run, in one string (say '--design cross2 --beam-correction')")
    args = ap.parse_args()
    from mbinspect.errors import MBInspectError
    from mbinspect.io import read, write

    extra = (["--radius", "0.75"] if args.command == "piles" else []) + args.more.split()
    rows, agree = [], 0
    with tempfile.TemporaryDirectory() as tmp:
        for path in sorted((REAL / "files").iterdir()):
            if path.suffix == ".md" or args.only not in path.name:
                continue
            ways = {"memory": [str(path)], "tiled": [str(path), "--tiled", "--workers", "2"]}
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    cloud = read(path)
                for ext in (".las", ".xyz"):
                    out = Path(tmp) / f"{path.stem}{ext}"
                    write(cloud, out)
                    ways[ext[1:]] = [str(out)] + (["--crs", cloud.crs] if ext == ".xyz" and cloud.crs else [])
            except MBInspectError:
                pass
            got = {}
            for way, given in ways.items():
                got[way] = _run([args.command, *given, *extra, "--no-figures", "--out",
                                 str(Path(tmp) / f"out-{path.stem}-{way}")])
            same = len({(c, o) for c, o, _ in got.values()}) == 1
            agree += same
            rows.append([path.name[:32], *(f"{got[w][0]}: {got[w][1][:38]}" if w in got else "-"
                                           for w in ("memory", "tiled", "las", "xyz")),
                         "yes" if same else "NO", "YES" if any(t for _, _, t in got.values()) else "no"])
    print(table(["file", "in memory", "tiled, 2 workers", "as LAS", "as ASCII", "agree", "traceback"], rows))
    print(f"{agree} of {len(rows)} files give the same exit status and outcome every way")


if __name__ == "__main__":
    main()
