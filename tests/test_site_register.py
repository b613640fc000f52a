"""The site register (issue 29): three surveys of one reef field added in order to a
GeoPackage, each unit followed through them (two neighbours that moved towards each other
keep their own ids), read back by GDAL's own reader; ``--history`` and bad registers."""

from __future__ import annotations

import json
import math
import sqlite3
import struct

import numpy as np
import pytest

from mbinspect.change.site import history
from mbinspect.cli import main

#: Truth ids 3 and 4 stand 4.6 m apart in a row; both move 2.5 m east, so that 3 lands 2.1 m
#: from where 4 stood (nearer than 4's own new place): a nearest-neighbour match confuses them.
MOVES = "id,dx,dy\n3,2.5,0\n4,2.5,0\n"
#: The third survey: the same moves, unit 1 taken away and a new unit set down.
THIRD = ("id,status,dx,dy,kind,x,y,bearing_deg\n3,changed,2.5,0,,,,\n4,changed,2.5,0,,,,\n"
         "1,removed,,,,,,\n100,new,,,cross2,402510,3372790,30\n")


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    root = tmp_path_factory.mktemp("site")
    assert main(["simulate", "reef-field", "--groups", "cross2", "--per-group", "4", "--close-pairs", "0",
                 "--boulders", "0", "--out", str(root / "a")]) == 0
    for name, text, seed, shift in (("b", MOVES, "3", "0.1,0,0.05"), ("c", THIRD, "4", "-0.1,0.1,0.02")):
        (root / f"{name}.csv").write_text(text)
        assert main(["simulate", "reef-field", "--resurvey", str(root / "a" / "truth.json"), "--changes",
                     str(root / f"{name}.csv"), "--seed", seed, "--shift", shift,
                     "--out", str(root / name)]) == 0
    for name in "abc":
        assert main(["reefs", str(root / name / "soundings.xyz"), "--crs", "EPSG:32617", "--design", "cross2",
                     "--out", str(root / f"r{name}"), "--no-figures"]) == 0
    gpkg = root / "site.gpkg"
    for one, two in ("ab", "bc"):
        assert main(["change", str(root / f"r{one}"), str(root / f"r{two}"), "--register", str(gpkg),
                     "--out", str(root / f"ch{one}{two}"), "--no-figures"]) == 0
    return root


def _truth(root, name):
    return {r["id"]: r for r in json.loads((root / name / "truth.json").read_text())["reefs"]}


def _unit_at(gpkg, x, y):
    con = sqlite3.connect(gpkg)
    rows = con.execute("SELECT object, x, y FROM observations WHERE survey = 1").fetchall()
    con.close()
    return min(rows, key=lambda r: math.hypot(r[1] - x, r[2] - y))[0]


def test_each_unit_keeps_its_id_through_three_surveys(site):
    gpkg, a, c = site / "site.gpkg", _truth(site, "a"), _truth(site, "c")
    for tid in (3, 4):
        life = history(gpkg, _unit_at(gpkg, a[tid]["x"], a[tid]["y"]))
        assert [o["survey"] for o in life["observations"]] == [1, 2, 3] and life["status"] == "present"
        last = life["observations"][-1]
        assert math.hypot(last["x"] - c[tid]["x"], last["y"] - c[tid]["y"]) < 0.4  # its own new place
        first, second = life["changes"]
        assert first["status"] == "changed"
        assert abs(first["displacement"] - 2.5) <= first["displacement_lod95"]
        assert second["status"] == "unchanged"
    gone = history(gpkg, _unit_at(gpkg, a[1]["x"], a[1]["y"]))
    assert gone["status"] == "removed" and gone["changes"][-1]["status"] == "removed"
    con = sqlite3.connect(gpkg)
    assert con.execute("SELECT count(*) FROM surveys").fetchone()[0] == 3
    new = con.execute("SELECT x, y FROM objects WHERE first_survey = 3").fetchall()
    con.close()
    assert len(new) == 1 and math.hypot(new[0][0] - 402510, new[0][1] - 3372790) < 0.4


def test_gdal_reads_the_register(site):
    pyogrio = pytest.importorskip("pyogrio")
    from pyogrio.raw import read

    gpkg = site / "site.gpkg"
    layers = {name: kind for name, kind in pyogrio.list_layers(gpkg)}
    assert layers == {"surveys": None, "objects": "Point", "observations": "Point", "changes": "LineString"}
    info = pyogrio.read_info(gpkg, layer="objects")
    assert info["crs"] == "EPSG:32617" and info["features"] == 5
    meta, _, geometry, fields = read(gpkg, layer="objects")
    x = fields[list(meta["fields"]).index("x")]
    points = np.array([struct.unpack("<dd", g[5:21]) for g in geometry])
    assert np.allclose(points[:, 0], x)
    meta, _, geometry, _ = read(gpkg, layer="changes")
    assert len(geometry) == 8  # four units from a to b, four from b to c (one of them removed)
    assert pyogrio.read_info(gpkg, layer="surveys")["features"] == 3


def test_the_register_alone_compares_its_last_two_surveys(site, capsys):
    capsys.readouterr()
    assert main(["change", str(site / "site.gpkg"), "--out", str(site / "last"), "--no-figures"]) == 0
    again = json.loads((site / "last" / "change.json").read_text())
    first = json.loads((site / "chbc" / "change.json").read_text())
    assert again["counts"] == first["counts"] and again["counts"]["new"] == 1
    assert main(["change", str(site / "site.gpkg"), "--history", "1"]) == 0
    printed = capsys.readouterr().out
    assert "unit 1 (cross2): surveys 1..3" in printed and "survey 3:" in printed


def test_a_register_refuses_surveys_out_of_order_and_is_left_as_it_was(site, capsys):
    gpkg = site / "site.gpkg"
    before = gpkg.read_bytes()
    capsys.readouterr()
    assert main(["change", str(site / "ra"), str(site / "rb"), "--register", str(gpkg),
                 "--out", str(site / "again"), "--no-figures"]) == 2
    err = capsys.readouterr().err
    assert "expected the before survey" in err and "(surveys are added in order)" in err
    assert gpkg.read_bytes() == before and not (site / "again").exists()


def test_a_register_names_what_is_wrong_with_it(site, tmp_path, capsys):
    text = tmp_path / "notes.gpkg"
    text.write_text("not a database\n")
    assert main(["change", str(text), "--history", "1"]) == 2
    assert main(["change", str(site / "site.gpkg"), "--history", "99"]) == 2
    err = capsys.readouterr().err
    assert "not a GeoPackage" in err and "no unit 99; expected one of 1..5" in err and "Traceback" not in err
