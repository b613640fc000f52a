"""Render the pile and reef reports in headless Chromium and save screenshots to look at.

Run: ``python benchmarks/render_reports.py OUTDIR`` (needs Debian's ``chromium``:
``apt-get install chromium``). Simulates a wharf and a reef field, runs ``mbinspect piles``
and ``mbinspect reefs`` on them with their design and reference, and saves a full-page
screenshot of each ``report.html`` as ``OUTDIR/piles.png`` and ``OUTDIR/reefs.png``, and the
page text Chromium laid out (``--dump-dom``) beside it, so that what a client sees is checked,
not only the HTML we wrote.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

from mbinspect.cli import main as mbinspect


def render(html: Path, png: Path, height: int) -> None:
    exe = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
    if exe is None:
        sys.exit("chromium not found: apt-get install chromium")
    args = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
            f"--window-size=1200,{height}", f"--screenshot={png}", html.as_uri()]
    subprocess.run(args, check=True, capture_output=True, timeout=120)
    dom = subprocess.run([exe, "--headless", "--no-sandbox", "--disable-gpu", "--dump-dom", html.as_uri()],
                         check=True, capture_output=True, text=True, timeout=120).stdout
    png.with_suffix(".dom.html").write_text(dom)
    print(f"{png}: {png.stat().st_size:,} bytes; {len(dom):,} characters laid out")


def main() -> None:
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "report-screenshots").resolve()
    out.mkdir(parents=True, exist_ok=True)
    work = out / "work"
    shutil.rmtree(work, ignore_errors=True)
    mbinspect(["-q", "simulate", "wharf", "--seed", "2", "--out", str(work / "wharf")])
    mbinspect(["-q", "piles", str(work / "wharf" / "soundings.xyz"), "--radius", "0.6", "--design",
               str(work / "wharf" / "design.csv"), "--crs", "EPSG:32617", "--out", str(work / "piles")])
    mbinspect(["-q", "simulate", "reef-field", "--seed", "1", "--out", str(work / "field")])
    mbinspect(["-q", "reefs", str(work / "field" / "soundings.xyz"), "--reference",
               str(work / "field" / "reference.csv"), "--design", "cross2,cross1", "--crs", "EPSG:32650",
               "--out", str(work / "reefs")])
    render(work / "piles" / "report.html", out / "piles.png", 9000)
    render(work / "reefs" / "report.html", out / "reefs.png", 9000)


if __name__ == "__main__":
    main()
