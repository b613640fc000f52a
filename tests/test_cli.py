"""The command line: main([...]) in-process, and the installed command once."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest

from mbinspect.cli import main
from mbinspect.io import PointCloud, write


@pytest.fixture()
def small_file(tmp_path):
    rng = np.random.default_rng(0)
    xyz = np.column_stack([rng.uniform(0, 10, 500), rng.uniform(0, 10, 500), rng.uniform(-21, -20, 500)])
    p = tmp_path / "s.xyz"
    write(PointCloud(xyz), p)
    return p


def test_info_text_and_json(small_file, capsys):
    assert main(["info", str(small_file)]) == 0
    out = capsys.readouterr().out
    assert "points      500" in out and "density" in out
    assert main(["info", str(small_file), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["n_points"] == 500 and d["z_range"][0] >= -21


@pytest.mark.parametrize(
    ("argv", "pattern"),
    [
        (["info", "missing.xyz"], "missing.xyz: no such file"),
        (["info", "{bad}"], "line 2, column 3: 'oops' is not a number"),
        (["info", "{bad}", "--columns", "x,y"], "expected exactly one 'z' column"),
        (["info"], "the following arguments are required: input"),
        (["simulate", "jacket", "--radius", "abc"], "--radius: 'abc' is not a number"),
        (["simulate", "jacket", "--per-group", "3"], "not an option of the jacket preset"),
        (["frobnicate"], "invalid choice: 'frobnicate'"),
    ],
)
def test_user_errors_are_one_line_without_traceback(tmp_path, capsys, argv, pattern):
    bad = tmp_path / "bad.xyz"
    bad.write_text("1 2 3\n4 5 oops\n")
    argv = [a.replace("{bad}", str(bad)) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert pattern in err
    assert err.count("\n") == 1 and "Traceback" not in err


def test_simulate_writes_files_and_refuses_to_overwrite(tmp_path, capsys):
    out = tmp_path / "sim"
    argv = ["simulate", "jacket", "--seed", "2", "--out", str(out), "--ping-spacing", "1.0",
            "--format", "laz"]
    assert main(argv) == 0
    names = sorted(p.name for p in out.iterdir())
    assert names == ["design.csv", "labels.npz", "soundings.laz", "truth.json"]
    truth = json.loads((out / "truth.json").read_text())
    assert len(truth["piles"]) == 4
    assert main(argv) == 2
    assert "or --overwrite to replace it" in capsys.readouterr().err
    assert main([*argv, "--overwrite", "--tilt-max-deg", "4"]) == 0
    assert json.loads((out / "truth.json").read_text())["options"]["tilt_max_deg"] == 4.0
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_show_options_lists_every_override(capsys):
    assert main(["simulate", "reef-field", "--show-options"]) == 0
    out = capsys.readouterr().out
    assert "--touching-pairs" in out and "--noise-scale" in out


def test_installed_command_end_to_end(tmp_path):
    exe = shutil.which("mbinspect") or str(
        __import__("pathlib").Path(sys.executable).with_name("mbinspect"))
    out = tmp_path / "reefs"
    run = subprocess.run([exe, "-q", "simulate", "reef-field", "--groups", "cross1",
                          "--ping-spacing", "1.0", "--out", str(out)],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    info = subprocess.run([exe, "info", str(out / "soundings.xyz"), "--json"],
                          capture_output=True, text=True, timeout=300)
    assert info.returncode == 0, info.stderr
    assert json.loads(info.stdout)["n_points"] > 10_000
    ref = (out / "reference.csv").read_text().splitlines()
    assert ref[0] == "x,y,id" and len(ref) == 26
