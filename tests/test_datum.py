"""The vertical reference (issue 30): a tide series applied by each sounding's time and a
datum offset, on every input path, refused with the reason when it cannot be applied."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mbinspect.cli.main import main
from mbinspect.datum import read_tide, vertical_reference
from mbinspect.errors import FileAccessError, InputError
from mbinspect.io import PointCloud, on_reference, read, write
from mbinspect.simulate import simulate, write_bundle

REAL = Path(__file__).resolve().parents[2] / "shared" / "real" / "files"


@pytest.fixture(scope="module")
def tidal(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object, object]:
    """The same sparse jacket survey with a 2.4 m tide (heights from the water level at each
    ping, as a sonar gives them) and without, and its tide gauge's CSV."""
    kw = {"seed": 6, "ping_spacing": 0.6}
    with_tide = simulate("jacket", tide_range=2.4, tide_mean=1.3, **kw)
    still = simulate("jacket", **kw)
    folder = tmp_path_factory.mktemp("tide")
    write_bundle(folder, with_tide.truth, cloud=with_tide.cloud, cloud_name="soundings.laz")
    return folder, with_tide, still


def test_the_tide_by_time_gives_back_the_heights_on_chart_datum(tidal) -> None:
    folder, with_tide, still = tidal
    assert (folder / "tide.csv").read_text().startswith("time,height\n2026-06-01T")
    moved = with_tide.cloud.xyz[:, 2] - still.cloud.xyz[:, 2]
    assert moved.min() < -2.0  # the water stood 1.3 m +- 1.2 m over chart datum
    for ext in ("laz", "xyz", "npz"):  # every reader keeps the times
        path = folder / f"soundings.{ext}"
        if not path.exists():
            write(with_tide.cloud, path)
        c = read(path, tide=folder / "tide.csv")
        # a 10-minute gauge interpolated linearly (0.9 mm at most off the cosine), heights kept to
        # the millimetre in LAS
        assert np.abs(c.xyz[:, 2] - still.cloud.xyz[:, 2]).max() < 0.002
        ref = c.meta["vertical_reference"]
        assert ref["stated"] and "chart datum" in ref["text"]
    off = read(folder / "soundings.laz", tide=folder / "tide.csv", datum_offset=-0.25)
    assert np.abs(off.xyz[:, 2] - still.cloud.xyz[:, 2] + 0.25).max() < 0.002


def test_a_tide_that_cannot_be_applied_is_refused_with_the_reason(tidal, tmp_path: Path) -> None:
    folder, with_tide, _ = tidal
    no_time = PointCloud(with_tide.cloud.xyz[:100], {})
    with pytest.raises(InputError, match=r"x.laz: the soundings carry no time; the tide .* by each sounding"):
        on_reference(no_time, vertical_reference(folder / "tide.csv"), "x.laz")
    short = tmp_path / "short.csv"
    short.write_text("time,height\n2026-06-01T08:00:00Z,1.0\n2026-06-01T08:05:00Z,1.1\n")
    with pytest.raises(InputError, match=r"soundings from 2026-06-01T08:00:00Z to .*; the tide .*short.csv "
                                         r"covers 2026-06-01T08:00:00Z to 2026-06-01T08:05:00Z"):
        read(folder / "soundings.laz", tide=short)


@pytest.mark.parametrize(("text", "message"), [
    ("when,height\n1,2\n", r"line 1: header .*; expected columns time and height"),
    ("time,height\n2026-06-01T08:00:00Z,1.0\nsoon,1.1\n", r"line 3, column 1 \(time\): 'soon' is not a time"),
    ("time,height\n2026-06-01T08:00:00Z,1.0\n2026-06-01T09:00:00Z,high\n",
     r"line 3, column 2 \(height\): 'high' is not a height"),
    ("time,height\n2026-06-01T09:00:00Z,1.0\n2026-06-01T08:00:00Z,1.1\n",
     r"line 3, column 1 \(time\): '2026-06-01T08:00:00Z' does not follow the row before"),
    ("# gauge\ntime,height\n2026-06-01T09:00:00Z,1.0\n", r"1 tide row\(s\); expected at least two"),
])
def test_bad_tide_files_name_the_line_and_column(tmp_path: Path, text: str, message: str) -> None:
    f = tmp_path / f"tide{abs(hash(text))}.csv"
    f.write_text(text)
    with pytest.raises(InputError, match=message):
        read_tide(f)
    with pytest.raises(FileAccessError, match="no such tide file"):
        read_tide(tmp_path / "none.csv")


def test_every_sonar_format_takes_a_tide(tmp_path: Path) -> None:
    tide = tmp_path / "flat.csv"
    tide.write_text("time,height\n1990-01-01T00:00:00Z,0.75\n2030-01-01T00:00:00Z,0.75\n")
    names = ["GSF3_08_test_file.gsf", "ets_kmall_OS01_-1927233285749584930.kmall", "Belgica_0077.all",
             "R2Testing_0009.xtf", "pdal_mbf_em300raw.mb56"]
    for name in names:
        if not (REAL / name).exists():
            pytest.skip(f"{name} is not here")
        with pytest.warns() if name.endswith(".all") else _nothing():
            a = read(REAL / name)
            b = read(REAL / name, tide=tide, datum_offset=0.1)
        assert np.allclose(b.xyz[:, 2] - a.xyz[:, 2], 0.85), name


class _nothing:
    def __enter__(self) -> None:
        return None

    def __exit__(self, *exc: object) -> None:
        return None


@pytest.mark.slow
def test_the_command_line_and_a_tiled_run_put_the_piles_on_chart_datum(
        tidal, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder, with_tide, still = tidal
    truth = with_tide.truth["piles"]
    tops = {}
    for tiled in ([], ["--tiled", "--tile-size", "40"]):
        out = tmp_path / f"o{len(tiled)}"
        code = main(["piles", str(folder / "soundings.laz"), "--radius", "0.75", "--count", "4", "--tide",
                     str(folder / "tide.csv"), "--out", str(out), "--no-figures", *tiled])
        assert code in (0, 1, 3), capsys.readouterr().err
        d = json.loads((out / "piles.json").read_text())
        assert d["parameters"]["vertical_reference"]["tide"] == str(folder / "tide.csv")
        assert "chart datum" in (out / "report.html").read_text()
        tops[len(tiled)] = [p["top_z"] for p in d["piles"]]
        for p in d["piles"]:  # on chart datum, as the truth is: within the lines' offsets
            t = min(truth, key=lambda t, p=p: np.hypot(t["x"] - p["x"], t["y"] - p["y"]))
            assert abs(p["top_z"] - t["z"]) < max(3 * p["top_z_sigma"], 0.01)
    assert np.allclose(tops[0], tops[max(tops)], atol=1e-6)
    # without the tide the tops stand as far below as the water stood over chart datum
    assert main(["piles", str(folder / "soundings.laz"), "--radius", "0.75", "--count", "4", "--out",
                 str(tmp_path / "raw"), "--no-figures"]) in (0, 1, 3)
    raw = json.loads((tmp_path / "raw" / "piles.json").read_text())
    assert all(p["top_z"] < -17.0 for p in raw["piles"])
    assert not raw["parameters"]["vertical_reference"]["stated"]
    # a file that carries no time: one line naming it, exit 2
    plain = tmp_path / "plain.xyz"
    plain.write_text("x y z\n" + "\n".join(f"{i} {i % 7} -20" for i in range(50)) + "\n")
    capsys.readouterr()
    assert main(["piles", str(plain), "--radius", "0.75", "--tide", str(folder / "tide.csv"), "--z-up",
                 "--out", str(tmp_path / "p")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "plain.xyz: the soundings carry no time" in err
