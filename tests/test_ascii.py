"""ASCII exports as survey software writes them: each layout reads right or is refused
with a line that says what to give."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from mbinspect.cli import main
from mbinspect.errors import InputError, InputWarning
from mbinspect.io import read

ROWS = [(554845.028, 4179000.717, -10.983), (554846.112, 4179001.305, -11.024),
        (554847.390, 4179002.011, -11.101)]


def _write(tmp_path, name, text, mode="w"):
    p = tmp_path / name
    if mode == "wb":
        p.write_bytes(text)
    else:
        p.write_text(text)
    return p


def _quiet_read(p, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # none of these layouts may need a warning
        return read(p, **kw)


def test_text_columns_are_never_parsed_when_skipped(tmp_path):
    iso = _write(tmp_path, "iso.txt", "".join(f"2015-07-08T23:52:{15 + k}+00:00 {x} {y} {z}\n"
                                              for k, (x, y, z) in enumerate(ROWS)))
    np.testing.assert_allclose(_quiet_read(iso, columns="-,x,y,z").xyz, ROWS)
    kept = _quiet_read(iso, columns="time,x,y,z")
    assert kept.fields["time"][1] - kept.fields["time"][0] == 1.0
    split = _write(tmp_path, "split.csv", "Date,Time,Easting,Northing,Elevation\n" + "".join(
        f"2015-07-08,23:52:15,{x},{y},{z}\n" for x, y, z in ROWS))
    np.testing.assert_allclose(_quiet_read(split, columns="-,-,x,y,z").xyz, ROWS)
    dms = _write(tmp_path, "dms.txt", "".join(f"37-45-24.033N 122-25-10.000W {x} {y} {z}\n"
                                              for x, y, z in ROWS))
    np.testing.assert_allclose(_quiet_read(dms, columns="-,-,x,y,z").xyz, ROWS)
    with pytest.raises(InputError, match=r"line 1: 5 columns and no header; give `columns`"):
        read(dms)
    four = _write(tmp_path, "dms4.txt", "".join(f"37-45-24.033N {x} {y} {z}\n" for x, y, z in ROWS))
    with pytest.raises(InputError, match=r"column 1: '37-45-24.033N' is not a number; give `columns`"):
        read(four)


def test_mb_system_time_and_geographic_columns(tmp_path):
    mb = _write(tmp_path, "mb.txt", "2015/07/08/23/52/15.000000 2.9220 51.2449 8.87\n"
                                    "2015/07/08/23/52/15.500000 2.9221 51.2450 8.90\n"
                                    "2015/07/08/23/52/16.000000 2.9222 51.2451 8.93\n")
    with pytest.warns(InputWarning, match="read as longitude and latitude"):
        c = read(mb, columns="time,lon,lat,z", depth_positive=True)
    assert c.fields["time"][2] - c.fields["time"][0] == 1.0
    assert 494000 < c.xyz[0, 0] < 495000 and 5677000 < c.xyz[0, 1] < 5678000  # UTM 31N
    assert "UTM zone 31N" in c.crs and c.xyz[0, 2] == pytest.approx(-8.87)


@pytest.mark.parametrize("header", ["Latitude,Longitude,Depth", "Lon,Lat,Z", None])
def test_geographic_coordinates_are_projected_with_a_note(tmp_path, capsys, header):
    rng = np.random.default_rng(0)
    lon, lat = 2.92 + rng.uniform(0, 0.001, 400), 51.244 + rng.uniform(0, 0.001, 400)
    depth = 8 + rng.normal(0, 0.05, 400)
    if header == "Latitude,Longitude,Depth":
        rows = np.column_stack([lat, lon, depth])
    else:
        rows = np.column_stack([lon, lat, depth])
    body = "\n".join(",".join(f"{v:.7f}" for v in r) for r in rows) + "\n"
    p = _write(tmp_path, "geo.csv", (header + "\n" if header else "") + body)
    with pytest.warns(InputWarning, match="projected to WGS 84 / UTM zone 31N"):
        c = read(p, depth_positive=True)
    assert np.ptp(c.xyz[:, 0]) == pytest.approx(0.001 * 111_320 * np.cos(np.radians(51.244)), rel=0.05)
    assert main(["info", str(p), "--depth-positive", "--json"]) == 0
    out = capsys.readouterr()
    d = json.loads(out.out)
    assert 3000 < d["area"] < 9000 and d["crs_name"] == "WGS 84 / UTM zone 31N"
    assert "mbinspect: warning:" in out.err and "longitude and latitude" in out.err


def test_columns_flag_may_start_with_a_dash(tmp_path, capsys):
    p = _write(tmp_path, "a.txt", "".join(f"7 {x} {y} {z}\n" for x, y, z in ROWS))
    assert main(["info", str(p), "--columns", "-,x,y,z", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["n_points"] == 3


def test_decimal_commas(tmp_path, capsys):
    semi = _write(tmp_path, "eu.csv", "".join(f"{x};{y};{z}\n".replace(".", ",") for x, y, z in ROWS))
    np.testing.assert_allclose(_quiet_read(semi).xyz, ROWS)
    spaced = _write(tmp_path, "eu.txt", "".join(f"{x} {y} {z}\n".replace(".", ",") for x, y, z in ROWS))
    np.testing.assert_allclose(_quiet_read(spaced).xyz, ROWS)
    np.testing.assert_allclose(_quiet_read(spaced, decimal=",").xyz, ROWS)
    tabbed = _write(tmp_path, "eu.tsv.txt", "X\tY\tZ\n" + "".join(f"{x}\t{y}\t{z}\n".replace(".", ",")
                                                               for x, y, z in ROWS))
    assert main(["info", str(tabbed), "--decimal", ",", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["n_points"] == 3


@pytest.mark.parametrize("header", ["Easting (m),Northing (m),Elevation (m)", "X [m],Y [m],Z [m]",
                                    '"Easting","Northing","Height"'])
def test_headers_with_units_and_quotes(tmp_path, header):
    p = _write(tmp_path, "u.csv", header + "\n" + "".join(f'"{x}","{y}","{z}"\n' for x, y, z in ROWS))
    np.testing.assert_allclose(read(p).xyz, ROWS)


def test_cr_only_line_ends_and_leica_pts(tmp_path):
    cr = _write(tmp_path, "mac.xyz", "".join(f"{x} {y} {z}\r" for x, y, z in ROWS).encode(), "wb")
    np.testing.assert_allclose(_quiet_read(cr).xyz, ROWS)
    pts = _write(tmp_path, "scan.pts", "3\n" + "".join(f"{x} {y} {z} 120\n" for x, y, z in ROWS))
    c = _quiet_read(pts)
    np.testing.assert_allclose(c.xyz, ROWS)
    assert c.fields["intensity"].tolist() == [120, 120, 120]
    short = _write(tmp_path, "short.pts", "5\n" + "".join(f"{x} {y} {z} 120\n" for x, y, z in ROWS))
    with pytest.raises(InputError, match="the file says 5 points but holds 3"):
        read(short)


def test_a_hash_inside_a_number_is_an_error_not_a_comment(tmp_path):
    p = _write(tmp_path, "h.xyz", "# a comment line\n1 2 -18.5\n1 3 -1#8.671\n")
    with pytest.raises(InputError, match=r"line 3, column 3: '-1#8.671' is not a number"):
        read(p)


@pytest.mark.parametrize(("count", "pattern"), [("2", "announces 2 vertices but more data follow"),
                                                ("-3", "count '-3'; expected a whole number"),
                                                ("many", "count 'many'; expected a whole number")])
def test_ply_vertex_counts_are_checked(tmp_path, count, pattern):
    body = "".join(f"{x} {y} {z}\n" for x, y, z in ROWS)
    p = _write(tmp_path, "c.ply", f"ply\nformat ascii 1.0\nelement vertex {count}\nproperty double x\n"
                                  f"property double y\nproperty double z\nend_header\n{body}")
    with pytest.raises(InputError, match=pattern):
        read(p)


def test_positive_z_without_a_word_stops_the_pipelines(tmp_path, capsys, jacket_small):
    from mbinspect.piles import locate_piles

    xyz = jacket_small.cloud.xyz.copy()
    xyz[:, 2] *= -1  # depths, positive down, under a plain x y z header
    p = tmp_path / "depths.csv"
    np.savetxt(p, xyz[::3], fmt="%.3f", delimiter=",", header="x,y,z", comments="")
    with pytest.warns(InputWarning, match="most z values are positive"):
        cloud = read(p)
    with pytest.raises(InputError, match="give `depth_positive` for depths"):
        locate_piles(cloud, radius=0.75, count=4)
    code = main(["piles", str(p), "--radius", "0.75", "--count", "4", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 2 and "give --depth-positive for depths (positive down) or --z-up for elevations" in err
    assert main(["piles", str(p), "--radius", "0.75", "--count", "4", "--depth-positive", "--no-figures",
                 "--out", str(tmp_path / "o")]) in (0, 3)
    assert len(json.loads((tmp_path / "o" / "piles.json").read_text())["piles"]) == 4


def test_excel_csv_with_a_byte_order_mark_and_reference_names(tmp_path):
    from mbinspect.evaluate import read_reference
    from mbinspect.piles import read_design

    ref = _write(tmp_path, "ref.csv", "\ufeffEasting,Northing,Name\n10.5,20.5,R1\n30,40,R2\n".encode(), "wb")
    xy, ids = read_reference(ref)
    assert xy.tolist() == [[10.5, 20.5], [30.0, 40.0]] and ids == ("R1", "R2")
    design = _write(tmp_path, "design.csv", "\ufeffid,x,y\n1,0,0\n2,22,0\n".encode(), "wb")
    assert read_design(design).spacing(1, 2) == 22.0
