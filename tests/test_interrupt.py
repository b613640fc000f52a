"""Ctrl-C, SIGTERM and SIGKILL of the installed command, with real signals.

A 40 MB ASCII file is read (by parser threads; a file the compiled parser cannot read, by
worker processes); the command is signalled while it reads. It must exit at once with 130
(Ctrl-C) or 143 (SIGTERM), print no traceback, leave no worker alive and no partial
output; after a SIGKILL the next run clears the staging folder left behind.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from mbinspect.cli import main

pytestmark = [pytest.mark.skipif(sys.platform != "linux", reason="signals and /proc as on Linux"),
              pytest.mark.slow]


@pytest.fixture(scope="module")
def big_ascii(tmp_path_factory):
    """About 40 MB of x y z intensity lines (above the parallel-read size)."""
    rng = np.random.default_rng(0)
    block = rng.uniform(0, 100, (25_000, 4))
    block[:, 2] -= 120
    text = "".join(f"{a:.3f} {b:.3f} {c:.3f} {d:.1f}\n" for a, b, c, d in block)
    p = tmp_path_factory.mktemp("big") / "survey-for-signals.xyz"
    with open(p, "w") as fh:
        for _ in range(40_000_000 // len(text) + 1):
            fh.write(text)
    return p


def _exe() -> str:
    return shutil.which("mbinspect") or str(Path(sys.executable).with_name("mbinspect"))


def _processes_reading(path: Path) -> list[int]:
    """Processes whose command line names ``path`` (the command and its forked workers)."""
    found = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                cmd = (d / "cmdline").read_bytes()
                state = (d / "stat").read_text().split()[2]
            except OSError:
                continue
            if str(path).encode() in cmd and state != "Z":
                found.append(int(d.name))
    return found


def _has_open(pid: int, path: Path) -> bool:
    try:
        return any(os.readlink(f) == str(path) for f in Path(f"/proc/{pid}/fd").iterdir())
    except OSError:
        return False


def _reading(pid: int, path: Path) -> bool:
    """The command, or one of its forked readers, has ``path`` open."""
    if _has_open(pid, path):
        return True
    try:
        kids = (Path(f"/proc/{pid}/task/{pid}/children")).read_text().split()
    except OSError:
        return False
    return any(_has_open(int(k), path) for k in kids)


def _start(big: Path, out: Path) -> subprocess.Popen[str]:
    p = subprocess.Popen([_exe(), "piles", str(big), "--radius", "0.75", "--out", str(out)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 30
    seen = False
    while not seen and p.poll() is None and time.monotonic() < deadline:
        seen = _reading(p.pid, big)
        time.sleep(0.002)
    assert seen, f"the read did not start (exit status {p.poll()})"
    return p


@pytest.mark.parametrize(("signals", "status"), [((signal.SIGINT,), 130), ((signal.SIGTERM,), 143),
                                                 ((signal.SIGINT, signal.SIGINT), 130)])
def test_interrupt_exits_at_once_and_leaves_nothing(big_ascii, tmp_path, signals, status):
    out = tmp_path / "out"
    p = _start(big_ascii, out)
    t = time.monotonic()
    for s in signals:
        p.send_signal(s)
        time.sleep(0.05)
    _, err = p.communicate(timeout=10)
    took = time.monotonic() - t
    assert p.returncode == status, err
    assert took < 1.5, f"took {took:.2f} s"
    assert "Traceback" not in err and err.strip().endswith("mbinspect: interrupted")
    time.sleep(0.3)
    assert _processes_reading(big_ascii) == []
    assert list(tmp_path.iterdir()) == []  # no output, no staging folder


def test_sigkill_takes_the_workers_and_the_next_run_clears_the_staging_folder(big_ascii, tmp_path,
                                                                              capsys):
    out = tmp_path / "out"
    p = _start(big_ascii, out)
    p.kill()
    p.wait(timeout=10)
    deadline = time.monotonic() + 5
    while _processes_reading(big_ascii) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert _processes_reading(big_ascii) == []
    stale = [q.name for q in tmp_path.iterdir()]
    assert len(stale) == 1 and stale[0].startswith(".out.mbinspect-")
    small = tmp_path.parent / f"{tmp_path.name}-small.xyz"
    small.write_text("0 0 -20\n1 0 -20\n")
    assert main(["piles", str(small), "--radius", "0.75", "--out", str(out)]) == 5  # 2 points: no answer
    assert "at least 10" in capsys.readouterr().err
    assert [q.name for q in tmp_path.iterdir()] == ["out"]  # the stale staging folder cleared
    assert sorted(q.name for q in out.iterdir()) == [".mbinspect-result", "no_answer.json"]
    os.unlink(small)
