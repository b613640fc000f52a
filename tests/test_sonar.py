"""The sonar readers (GSF, KMALL, .all) against an independent decode of real files."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from pyproj import Proj, Transformer

from mbinspect.cli import main
from mbinspect.errors import InputError, ParameterError
from mbinspect.io import read
from mbinspect.sonar import read_sonar, to_cloud, utm_crs

DATA = Path(__file__).parent / "data"
FILES = ["Belgica_0077.all", "pdal_mbf_em300raw.mb56", "ets_kmall_OS03_-4033476991022010987.kmall",
         "gsf_EX1502L2_0175.gsf"]


def _reference(name: str) -> dict[str, np.ndarray]:
    ref = np.load(DATA / f"{name.rsplit('.', 1)[0]}.reference.npz")
    return {k: ref[k] for k in ref.files}


def _reference_put_right(ref: dict[str, np.ndarray], crs: str) -> np.ndarray:
    """The reference's positions with the offsets turned by the grid convergence and scaled.

    The reference adds the along/across offsets in the UTM plane as if grid north were true
    north; the readers turn them by the true heading on the ellipsoid. On a 3 km swath the
    grid convergence alone moves an outer beam by metres."""
    t = Transformer.from_crs(crs, "EPSG:4326", always_xy=True)
    lon, lat = t.transform(ref["sx"], ref["sy"])
    f = Proj(crs).get_factors(lon, lat)
    g, k = np.radians(np.asarray(f.meridian_convergence)), np.asarray(f.meridional_scale)
    ox, oy = ref["xyz"][:, 0] - ref["sx"], ref["xyz"][:, 1] - ref["sy"]
    return np.column_stack([ref["sx"] + k * (ox * np.cos(g) - oy * np.sin(g)),
                            ref["sy"] + k * (ox * np.sin(g) + oy * np.cos(g))])


@pytest.mark.parametrize("name", FILES)
def test_readers_agree_with_an_independent_decode(name):
    ref = _reference(name)
    fmt = {"all": "all", "mb56": "all", "kmall": "kmall", "gsf": "gsf"}[name.split(".")[-1]]
    s = read_sonar(DATA / name, fmt)
    assert len(s) == len(ref["xyz"])
    np.testing.assert_array_equal(s.fields["valid"], ref["valid"].astype(bool))
    valid = s.fields["valid"]
    cloud = to_cloud(s, keep_rejected=True)
    crs = utm_crs(float(np.median(s.lat)), float(np.median(s.lon)))
    assert cloud.meta["crs_name"].endswith(crs[-2:] + "N") or cloud.meta["crs_name"].endswith(crs[-2:] + "S")
    dz = np.abs(cloud.xyz[valid, 2] - ref["xyz"][valid, 2])
    assert dz.max() < 0.02  # depths within 2 cm
    right = _reference_put_right(ref, crs)
    dxy = np.hypot(*(cloud.xyz[valid, :2] - right[valid]).T)
    assert dxy.max() < (0.05 if name.endswith(".kmall") else 0.5)
    if name.endswith(".kmall"):  # per-sounding positions in the file: the same to the millimetre
        assert np.abs(cloud.xyz[:, :2] - ref["xyz"][:, :2]).max() < 0.001
    np.testing.assert_allclose(s.fields["intensity"][valid], ref["intensity"][valid], atol=0.01)
    read_valid = read(DATA / name)
    assert len(read_valid) == int(valid.sum()) and read_valid.crs is not None
    assert set(read_valid.fields) >= {"ping", "beam", "beam_angle", "intensity", "time"}


def test_big_endian_old_depth_datagrams():
    s = read_sonar(DATA / "pdal_mbf_em300raw.mb56", "all")
    assert s.meta["byte_order"] == "big-endian" and s.meta["sonar"] == "EM3000"
    assert s.meta["pings"] == 67 and len(np.unique(s.fields["ping"])) == 67


def test_kmall_keeps_the_sonar_uncertainty_and_extra_detections():
    s = read_sonar(DATA / "ets_kmall_OS03_-4033476991022010987.kmall", "kmall")
    assert (s.fields["sigma_v"] > 0).all() and (s.fields["sigma_v"] < 0.5).all()
    assert "extra_detection" in s.fields


def test_unplaceable_truncated_and_crs_errors(tmp_path, capsys):
    with pytest.raises(InputError, match="no across-track distances: the soundings cannot be placed"):
        read(DATA / "GSF3_09_test_file.gsf")
    cut = tmp_path / "cut.kmall"
    data = (DATA / "ets_kmall_OS03_-4033476991022010987.kmall").read_bytes()
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(InputError, match=r"cut.kmall, byte \d+: a record of \d+ bytes"):
        read(cut)
    with pytest.raises(ParameterError, match="crs: 'EPSG:4326' .WGS 84. is geographic; expected a projected"):
        read(DATA / "Belgica_0077.all", crs="EPSG:4326")
    moved = read(DATA / "Belgica_0077.all", crs="EPSG:25831")  # ETRS89 / UTM 31N
    assert "ETRS89 / UTM zone 31N" in moved.meta["crs_name"]
    # the next zone east stretches distances here by 1:609 (3.6 cm on a 22 m spacing): refused
    with pytest.raises(ParameterError, match=r"'EPSG:32632' .* distorts distances over these data by 1:609"):
        read(DATA / "Belgica_0077.all", crs="EPSG:32632")
    assert main(["info", str(DATA / "GSF3_09_test_file.gsf")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("mbinspect: error: ") and "not georeferenceable" in err and err.count("\n") == 1


def test_format_flag_and_rejected_soundings(tmp_path, capsys):
    odd = tmp_path / "survey.bin"
    shutil.copy(DATA / "gsf_EX1502L2_0175.gsf", odd)
    assert main(["info", str(odd), "--format", "gsf", "--keep-rejected", "--json"]) == 0
    assert '"n_points": 1728' in capsys.readouterr().out
    assert main(["info", str(odd), "--format", "gsf", "--depth-positive"]) == 2
    assert "--depth-positive: given for the gsf file" in capsys.readouterr().err


def test_the_crs_reaches_every_output(tmp_path, capsys):
    import json

    from mbinspect.io import write

    cloud = read(DATA / "Belgica_0077.all")
    las = tmp_path / "belgica.laz"
    write(cloud, las)
    back = read(las)
    from pyproj import CRS

    assert CRS.from_user_input(back.crs).to_epsg() == 32631
    out = tmp_path / "reefs"
    assert main(["reefs", str(DATA / "Belgica_0077.all"), "--out", str(out), "--no-figures"]) == 0
    d = json.loads((out / "reefs.json").read_text())
    assert CRS.from_user_input(d["parameters"]["input"]["crs"]).to_epsg() == 32631
    assert "WGS 84 / UTM zone 31N (EPSG:32631)" in (out / "report.html").read_text()
    geo = json.loads((out / "reefs.geojson").read_text())
    assert "crs_note" not in geo
    projected = json.loads((out / "reefs_projected.geojson").read_text())
    assert CRS.from_user_input(projected["crs"]["properties"]["name"]).to_epsg() == 32631
    capsys.readouterr()


@pytest.mark.slow
def test_piles_geojson_is_longitude_latitude_with_a_crs(tmp_path, jacket_small):
    import json

    from mbinspect.io import write

    src = tmp_path / "jacket.xyz"
    write(jacket_small.cloud, src)
    out = tmp_path / "piles"
    code = main(["piles", str(src), "--radius", "0.75", "--count", "4", "--crs", "EPSG:32650",
                 "--out", str(out), "--no-figures"])
    assert code in (0, 3)
    geo = json.loads((out / "piles.geojson").read_text())
    lon, lat = geo["features"][0]["geometry"]["coordinates"]
    assert 114 < lon < 120 and 30 < lat < 32  # zone 50N, northing 3.46 Mm
    # the projected layer, read back: the CRS it names and the coordinates of piles.json
    from pyproj import CRS, Transformer

    projected = json.loads((out / "piles_projected.geojson").read_text())
    crs = CRS.from_user_input(projected["crs"]["properties"]["name"])
    assert crs.to_epsg() == 32650
    d = json.loads((out / "piles.json").read_text())
    x, y = projected["features"][0]["geometry"]["coordinates"]
    assert (x, y) == (d["piles"][0]["x"], d["piles"][0]["y"])
    back = Transformer.from_crs(crs, "EPSG:4326", always_xy=True).transform(x, y)
    assert abs(back[0] - lon) < 1e-9 and abs(back[1] - lat) < 1e-9
    bare = tmp_path / "bare"
    code = main(["piles", str(src), "--radius", "0.75", "--count", "4", "--out", str(bare), "--no-figures"])
    assert code in (0, 3)
    geo = json.loads((bare / "piles.geojson").read_text())
    assert "crs_note" in geo and geo["features"][0]["geometry"]["coordinates"][0] > 500_000


@pytest.mark.parametrize(("name", "pattern"), [
    ("Belgica_0077.all", r"cut.all, byte \d+: a datagram of \d+ bytes; expected one that fits the file"),
    ("gsf_EX1502L2_0175.gsf", r"cut.gsf, byte \d+: a GSF record of \d+ bytes runs past the end of the file"),
])
def test_truncated_files_name_the_record_and_byte(tmp_path, name, pattern):
    data = (DATA / name).read_bytes()
    cut = tmp_path / f"cut.{name.split('.')[-1]}"
    cut.write_bytes(data[: int(len(data) * 0.6)])
    with pytest.raises(InputError, match=pattern):
        read(cut)
    assert read(DATA / name).fields["line"].max() == 0


def test_reefs_on_a_narrow_real_strip_and_on_identical_points(tmp_path, capsys):
    # a 1-2 m wide KMALL strip of Ostend harbour: the terrain screen once crashed on it
    out = tmp_path / "strip"
    assert main(["reefs", str(DATA / "ets_kmall_OS03_-4033476991022010987.kmall"), "--out", str(out),
                 "--no-figures"]) == 0
    assert "0 reefs" in capsys.readouterr().out
    same = tmp_path / "same.xyz"
    same.write_text("1 2 -10\n" * 10)
    code = main(["reefs", str(same), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 5 and err.startswith("mbinspect: no answer: ") and err.count("\n") == 1
