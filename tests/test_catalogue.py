"""Bad and odd inputs, as a new user brings them (issue 27's catalogue): each read right or
refused in one line, never a traceback, never silently wrong."""

from __future__ import annotations

import dataclasses
import json
import multiprocessing as mp
import struct
import warnings
from pathlib import Path

import laspy
import numpy as np
import pytest

from mbinspect.cli import main
from mbinspect.errors import InputError, ParameterError
from mbinspect.io import read, sha256_of
from mbinspect.outputs import MARKER
from mbinspect.reefs import extract_reefs
from mbinspect.report import write_reef_outputs
from mbinspect.survey.run import SurveyOptions

DATA = Path(__file__).parent / "data"
KMALL_EG = DATA / "ets_kmall_eg_-7360358516350552537.kmall"


def _one_line(capsys: pytest.CaptureFixture[str], code: int, pattern: str) -> str:
    err = capsys.readouterr().err
    assert code == 2, err
    assert pattern in err and "Traceback" not in err
    errors = [line for line in err.splitlines() if line.startswith("mbinspect: error:")]
    assert errors == [err.splitlines()[-1]]
    return err


def _las(path: Path, n: int = 1000, **dims: np.ndarray) -> Path:
    header = laspy.LasHeader(point_format=3, version="1.2")
    header.offsets, header.scales = [500000.0, 5000000.0, 0.0], [0.001] * 3
    las = laspy.LasData(header)
    rng = np.random.default_rng(0)
    las.x, las.y = 500000 + rng.uniform(0, 100, n), 5000000 + rng.uniform(0, 100, n)
    las.z = -10 + rng.normal(0, 0.1, n)
    for name, values in dims.items():
        setattr(las, name, values)
    las.write(path)
    return path


def test_withheld_and_noise_points_are_left_out_and_counted(tmp_path):
    """PDAL's wontcompress3.las flags 895 of 1,000 points withheld; LAS classes 7 and 18 are
    noise. Both are left out with a note, in a whole read and in chunks, and kept on request."""
    withheld = np.zeros(1000, np.uint8)
    withheld[:895] = 1
    cls = np.full(1000, 2, np.uint8)
    cls[900:905] = 7
    path = _las(tmp_path / "flags.las", withheld=withheld, classification=cls)
    with pytest.warns(UserWarning, match="895 flagged withheld and 5 classed noise .7, 18. of 1,000 points"):
        cloud = read(path)
    assert len(cloud) == 100 and "withheld" not in cloud.fields
    kept = read(path, keep_rejected=True)
    assert len(kept) == 1000 and int(kept.fields["withheld"].sum()) == 895
    from mbinspect.formats.las import iter_las

    with pytest.warns(UserWarning, match="895 flagged withheld"):
        chunks = list(iter_las(path, 300))
    assert sum(len(c) for c in chunks) == 100


def test_a_header_that_cannot_fit_is_refused_at_once(tmp_path):
    """A 14.6 KB LAS whose header claims 1,069,128,089 VLRs took 183 s and 7.8 GB to fail."""
    path = _las(tmp_path / "ok.las")
    data = bytearray(path.read_bytes())
    struct.pack_into("<I", data, 100, 1_069_128_089)
    bad = tmp_path / "vlrs.las"
    bad.write_bytes(bytes(data))
    with pytest.raises(InputError, match="1,069,128,089 variable-length records cannot fit"):
        read(bad)
    struct.pack_into("<I", data, 100, 0)
    struct.pack_into("<I", data, 107, 50_000_000)  # the legacy point count
    (tmp_path / "count.las").write_bytes(bytes(data))
    with pytest.raises(InputError, match="50,000,000 points of 34 bytes need"):
        read(tmp_path / "count.las")


def test_array_extra_bytes_are_fields(tmp_path):
    """laspy's extrabytes.las holds a 3-element colour: read as three fields."""
    header = laspy.LasHeader(point_format=3, version="1.4")
    header.offsets, header.scales = [0.0, 0.0, 0.0], [0.001] * 3
    header.add_extra_dim(laspy.ExtraBytesParams(name="Colors", type="3u2"))
    las = laspy.LasData(header)
    las.x, las.y, las.z = np.arange(10.0), np.arange(10.0), -np.ones(10)
    las.Colors = np.arange(30, dtype=np.uint16).reshape(10, 3)
    las.write(tmp_path / "extra.las")
    cloud = read(tmp_path / "extra.las", z_up=True)
    assert cloud.fields["Colors_2"].tolist() == list(range(2, 30, 3))


def test_kmall_extra_detections_are_not_seabed():
    with pytest.warns(UserWarning, match="753 extra detections .* left out with the 2,958 soundings"):
        cloud = read(KMALL_EG)
    assert len(cloud) == 11_473
    every = read(KMALL_EG, keep_rejected=True)
    assert len(every) == 15_184 and int(every.fields["extra_detection"].sum()) == 753


def test_options_are_matched_whole(capsys):
    """argparse's abbreviations took `--plan` for `--plane-threshold` (`--plan` is now the reef plan)."""
    _one_line(capsys, main(["reefs", str(KMALL_EG), "--plane-thr", "0.1"]),
              "unrecognized arguments: --plane-thr")


@pytest.mark.parametrize("address", ["nonsense", "http://host:8786", "tcp://host"])
def test_a_bad_scheduler_address_is_one_line(capsys, address):
    _one_line(capsys, main(["reefs", str(KMALL_EG), "--scheduler", address, "--out", "never"]),
              f"--scheduler: '{address}'; expected the address of a running Dask scheduler")
    with pytest.raises(ParameterError):
        SurveyOptions(scheduler=address)


def test_workers_are_capped_at_the_cores(monkeypatch):
    import os

    import dask.distributed as dd

    from mbinspect.survey.cluster import dask_client

    seen = {}

    class FakeCluster:
        def __init__(self, n_workers, **kw):
            seen["n"] = n_workers

        def close(self):
            pass

    class FakeClient:
        def __init__(self, cluster):
            pass

        def close(self):
            pass

    monkeypatch.setattr(dd, "LocalCluster", FakeCluster)
    monkeypatch.setattr(dd, "Client", FakeClient)
    with pytest.warns(UserWarning, match=f"workers: 64 asked on a machine of {os.cpu_count()} cores"):
        with dask_client(workers=64):
            pass
    assert seen["n"] == os.cpu_count()


def test_overwrite_replaces_a_result_never_a_users_folder(tmp_path, capsys):
    mine = tmp_path / "exists2"
    mine.mkdir()
    (mine / "keep.txt").write_text("a user's own file")
    code = main(["simulate", "jacket", "--ping-spacing", "1.5", "--out", str(mine), "--overwrite"])
    _one_line(capsys, code, f"holds files mbinspect did not write (no {MARKER})")
    assert (mine / "keep.txt").read_text() == "a user's own file"
    out = tmp_path / "sim"
    assert main(["simulate", "jacket", "--ping-spacing", "1.5", "--out", str(out)]) == 0
    assert (out / MARKER).is_file()
    assert main(["simulate", "jacket", "--ping-spacing", "1.5", "--seed", "2", "--out", str(out),
                 "--overwrite"]) == 0


def _read_in_a_daemon(path: str, queue: mp.Queue) -> None:
    try:
        queue.put(len(read(path, z_up=True)))
    except BaseException as exc:  # reported to the test
        queue.put(repr(exc))


def test_ascii_is_read_inside_a_daemonic_worker(tmp_path, monkeypatch):
    """A Dask worker is a daemonic process, which may not start children: the ASCII parser
    started its pool there (`daemonic processes are not allowed to have children`)."""
    from mbinspect.formats import ascii_parse

    monkeypatch.setattr(ascii_parse, "CHUNK_BYTES", 2**18)
    path = tmp_path / "big.xyz"
    rng = np.random.default_rng(1)
    xyz = np.column_stack([rng.uniform(0, 500, 100_000), rng.uniform(0, 500, 100_000),
                           rng.normal(-10, 1, 100_000)])
    np.savetxt(path, xyz, fmt="%.3f")
    assert path.stat().st_size > 4 * ascii_parse.CHUNK_BYTES  # several chunks: the parallel path
    ctx = mp.get_context("fork")
    queue = ctx.Queue()
    proc = ctx.Process(target=_read_in_a_daemon, args=(str(path), queue), daemon=True)
    proc.start()
    got = queue.get(timeout=120)
    proc.join(30)
    assert got == 100_000


def test_the_reef_report_takes_absent_values(tmp_path):
    """Deep real files gave a seabed without a residual RMS: the report writer ended in
    `unsupported format string passed to NoneType.__format__`."""
    from mbinspect.simulate import simulate

    sim = simulate("reef-field", seed=2, groups="cross1", per_group=4, ping_spacing=0.8, close_pairs=0)
    result = extract_reefs(sim.cloud)
    hollow = dataclasses.replace(result, seabed={**result.seabed, "residual_rms": None})
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no silent NaN formatting either
        written = write_reef_outputs(hollow, sim.cloud.xyz, tmp_path, figures=False)
    assert "report.html" in written
    assert "seabed residual RMS (m)</td><td>–" in (tmp_path / "report.html").read_text()


@pytest.mark.parametrize(("name", "text", "columns_kw"), [
    # a header over decimal-comma rows: the header shows no decimal mark, the rows do
    ("dc.csv", "X;Y;Z\n554845,028;4179000,717;-10,983\n554846,028;4179001,717;-10,883\n"
               "554847,028;4179000,217;-10,783\n", {}),
    # a header that names a date and a time of day before the coordinates
    ("dt.txt", "Date Time Easting Northing Elevation\n"
               "2015-07-08 23:52:15.000000 554845.028 4179000.717 -10.983\n"
               "2015-07-08 23:52:16.500000 554846.028 4179001.717 -10.883\n"
               "2015-07-08 23:52:17.000000 554847.028 4179000.217 -10.783\n", {}),
    # Leica PTS: a count line, then x y z intensity red green blue
    ("scan.pts", "3\n554845.028 4179000.717 -10.983 -1200 10 20 30\n"
                 "554846.028 4179001.717 -10.883 -1100 11 21 31\n"
                 "554847.028 4179000.217 -10.783 -1000 12 22 32\n", {}),
])
def test_layouts_the_header_or_the_format_names(tmp_path, name, text, columns_kw):
    path = tmp_path / name
    path.write_text(text)
    cloud = read(path, **columns_kw)
    assert np.allclose(cloud.xyz[0], [554845.028, 4179000.717, -10.983])
    if name == "dt.txt":
        from datetime import UTC, datetime

        t0 = datetime(2015, 7, 8, 23, 52, 15, tzinfo=UTC).timestamp()
        assert np.allclose(cloud.fields["time"], [t0, t0 + 1.5, t0 + 2.0])
    if name == "scan.pts":
        assert cloud.fields["blue"].tolist() == [30, 31, 32]


@pytest.mark.parametrize("suffix", [".mb57", ".mb58", ".mb59"])
def test_mb_system_names_of_kongsberg_files(tmp_path, suffix):
    path = tmp_path / f"belgica{suffix}"
    path.write_bytes((DATA / "Belgica_0077.all").read_bytes())
    assert len(read(path)) == 2304


def test_a_survey_given_twice_counts_once(reef_small, jacket_exact):
    """Duplicated soundings changed the reef count and shrank every pile's 1σ by √2."""
    from mbinspect.cloud import PointCloud
    from mbinspect.piles import locate_piles

    cloud = reef_small.cloud
    twice = PointCloud(np.vstack([cloud.xyz, cloud.xyz]),
                       {k: np.concatenate([v, v]) for k, v in cloud.fields.items()}, crs=cloud.crs)
    once, doubled = extract_reefs(cloud), extract_reefs(twice)
    assert len(doubled.reefs) == len(once.reefs)
    assert any(f"{len(cloud):,} soundings are exact copies" in w for w in doubled.warnings)
    jac = jacket_exact.cloud
    jac2 = PointCloud(np.vstack([jac.xyz, jac.xyz]),
                      {k: np.concatenate([v, v]) for k, v in jac.fields.items()})
    a, b = locate_piles(jac, count=4, radius=0.75), locate_piles(jac2, count=4, radius=0.75)
    assert [round(p.sigma_xy, 6) for p in a.piles] == [round(p.sigma_xy, 6) for p in b.piles]


def test_soundings_refuses_a_file_changed_since_and_a_json_not_ours(tmp_path, capsys, reef_small):
    """`soundings reefs.json 3` after a line file was replaced gave the new file's soundings."""
    from mbinspect.io import write

    line = tmp_path / "line.laz"
    write(reef_small.cloud, line)
    out = tmp_path / "out"
    assert main(["reefs", str(line), "--out", str(out), "--no-figures"]) == 0
    capsys.readouterr()
    assert main(["soundings", str(out / "reefs.json"), "1", "--out", str(tmp_path / "r1.csv")]) == 0
    assert len((tmp_path / "r1.csv").read_text().splitlines()) > 20
    other = dataclasses.replace(reef_small.cloud, xyz=reef_small.cloud.xyz + [0.0, 0.0, 0.5])
    write(other, line)  # another survey under the same name
    _one_line(capsys, main(["soundings", str(out / "reefs.json"), "1"]),
              "not the file the result was made from (its sha256 differs")
    (tmp_path / "foreign.json").write_text('{"reefs": 3, "type": "FeatureCollection"}')
    _one_line(capsys, main(["soundings", str(tmp_path / "foreign.json"), "1"]), "neither a reefs.json nor")
    (tmp_path / "list.json").write_text("[1, 2]")
    _one_line(capsys, main(["soundings", str(tmp_path / "list.json"), "1"]), "neither a reefs.json nor")


def test_coordinates_no_survey_can_have_are_refused(tmp_path, capsys):
    """Coordinates of 1e308 ran every grid away (the run did not end)."""
    path = tmp_path / "big.xyz"
    path.write_text("1e308 2 -3\n" + "".join(f"{k}.5 {k}.2 -10.{k}\n" for k in range(1, 30)))
    _one_line(capsys, main(["reefs", str(path), "--out", str(tmp_path / "o")]),
              "point 1 is [1e+308, 2.0, -3.0]; expected metres in a projected CRS")


def test_meaningless_settings_are_refused_before_any_work(tmp_path, capsys):
    """A seabed above the water, a pile id twice, a margin below zero were all accepted."""
    _one_line(capsys, main(["simulate", "jacket", "--seabed", "3", "--out", str(tmp_path / "s")]),
              "--seabed: 3.0; expected a seabed elevation below -1 m")
    piles = tmp_path / "piles.csv"
    piles.write_text("id,x,y,radius,height\n1,0,0,0.5,2\n2,5,0,0.5,2\n1,9,0,0.5,2\n")
    _one_line(capsys, main(["inject", str(DATA / "pdal_mbf_em300raw.mb56"), "--piles", str(piles),
                            "--out", str(tmp_path / "i")]), "line 4, column id: 1 again (line 2)")
    for bad in ("-1", "nan"):
        _one_line(capsys, main(["soundings", str(tmp_path / "r.json"), "1", "--margin", bad]), "--margin")


@pytest.mark.slow
def test_a_users_mistake_inside_a_tiled_run_is_one_line(tmp_path, capfd):
    """An empty file among a tiled run's inputs printed Dask's "Compute Failed" block and a
    remote traceback, and was retried like a dead worker."""
    good = tmp_path / "a.las"
    good.write_bytes((DATA / "outside" / "laspy_simple.las").read_bytes())
    (tmp_path / "empty.xyz").write_text("")
    code = main(["reefs", str(good), str(tmp_path / "empty.xyz"), "--tiled", "--workers", "2",
                 "--out", str(tmp_path / "o")])
    err = capfd.readouterr().err
    assert code == 2, err
    assert "empty.xyz: the file is empty" in err
    assert "Traceback" not in err and "Compute Failed" not in err and err.count("mbinspect: error:") == 1


def test_the_report_counts_specks_and_lists_the_rest_with_their_reasons(tmp_path):
    """101 of a report's 109 "other objects" were single-sounding spikes, listed one by one."""
    from mbinspect.reefs.results import OtherObject
    from mbinspect.simulate import simulate

    sim = simulate("reef-field", seed=2, groups="cross1", per_group=4, ping_spacing=0.8, close_pairs=0)
    result = extract_reefs(sim.cloud)
    specks = tuple(OtherObject(1.0 * k, 0.0, 0.5, 0.01, -16.8, 1, "smaller than `min_area` 1 m²")
                   for k in range(40))
    rock = OtherObject(5.0, 5.0, 0.9, 2.5, -16.4, 150, "a dome: a rock, not a reef")
    busy = dataclasses.replace(result, others=specks + (rock,))
    write_reef_outputs(busy, sim.cloud.xyz, tmp_path, figures=False)
    page = (tmp_path / "report.html").read_text()
    assert "40 specks of 2 soundings or fewer" in page
    assert page.count("smaller than `min_area`") == 0 and "a dome: a rock, not a reef" in page


def test_all_pings_outside_the_navigation_are_said(recwarn):
    """Two of the Belgica line's nine pings lie 2 s past its last position fix: placed at the
    nearest fix as before, now with a warning."""
    read(DATA / "Belgica_0077.all")
    said = [str(w.message) for w in recwarn if "outside the navigation's time span" in str(w.message)]
    assert said and "2 of 9 pings lie up to 2.0 s outside" in said[0]


def test_all_datagrams_that_fail_their_checksum_are_left_out(tmp_path):
    """A corrupt .all record that still parsed put soundings kilometres away or 650 m deep
    without a word: the checksum every datagram carries is now checked."""
    data = bytearray((DATA / "Belgica_0077.all").read_bytes())
    at = data.find(b"\x02X")  # the first XYZ88 datagram: flip a byte of its first beam's depth
    data[at + 40] ^= 0x5A
    path = tmp_path / "flipped.all"
    path.write_bytes(bytes(data))
    with pytest.warns(UserWarning, match="1 depth or position datagrams fail their checksum"):
        cloud = read(path)
    assert 0 < len(cloud) < 2304


def test_a_reef_no_given_design_fits_keeps_its_free_form_measures():
    """A candidate that none of the designs given fits is judged by its shape, not set aside
    for the want of a design (the README's promise: a partial --design list hides no reef)."""
    from mbinspect.reefs.options import ReefOptions
    from mbinspect.reefs.reject import Candidate, Context, why_not_a_reef
    from mbinspect.reefs.results import Reef

    reef = Reef(1, 0.0, 0.0, -17.3, -16.1, 1.2, 4.2, 3.0, 3.0, 0.0, 4.0, 10.8, 500, design="")
    assert why_not_a_reef(Candidate(reef, np.arange(9)), Context(np.zeros((0, 3))),
                          ReefOptions(design="cross2")) is None


@pytest.mark.parametrize("suffix", [".xyz", ".csv", ".las"])
@pytest.mark.parametrize("name", ["Belgica_0077.all", "gsf_EX1502L2_0175.gsf"])
def test_a_sonar_file_written_out_reads_back_whole(tmp_path, suffix, name):
    """Written as ASCII, a sonar line's times came back as '1.668e+09', which its own reader
    refused ("is not a time"), its beam numbers as beam angles; as LAS, a beam without
    backscatter was cast from NaN, and read back as ASCII its NaN was refused."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        line = read(DATA / name)
    line.fields["intensity"][:10] = np.nan  # beams without backscatter, as GSF3_08 has
    path = tmp_path / f"line{suffix}"
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        from mbinspect.io import write

        write(line, path)
    back = read(path, z_up=True) if suffix != ".las" else read(path)
    assert np.abs(back.xyz - line.xyz).max() <= 5e-4
    if suffix != ".las":
        assert sorted(back.fields) == sorted(line.fields)
        for k, v in line.fields.items():
            assert np.allclose(np.asarray(v, float), back.fields[k], atol=1e-6, equal_nan=True), k


def test_data_that_cannot_support_an_answer_say_so_alike_in_memory_and_in_tiles(tmp_path, capsys):
    """A deep line (an EM710 at 109 m: a 1° beam lights a 1.9 m footprint) stopped with the
    reason in memory, but ended with no reef and exit 0 in tiles, each tile's refusal a warning."""
    line = DATA / "ets_all_he_-3092155654265012286.all"
    errors = []
    for extra in ([], ["--tiled", "--workers", "1"]):
        out = tmp_path / f"o{len(extra)}"
        code = main(["reefs", str(line), "--no-figures", "--out", str(out), *extra])
        err = capsys.readouterr().err
        assert code == 5 and "Traceback" not in err  # the data cannot support an answer: not a mistake
        assert err.splitlines()[-1].startswith("mbinspect: no answer: ")
        written = json.loads((out / "no_answer.json").read_text())
        assert "too coarse to resolve objects" in written["reason"] and written["answer"] is None
        assert written["input"][0]["sha256"] == sha256_of(line)
        errors.append(written["reason"].split(" (so says")[0])
    assert errors[0] == errors[1]


def test_binary_data_and_endless_lines_are_refused_at_once(tmp_path, capsys):
    """A 1 GB all-zero .xyz took 44 s and 9.9 GB to be told it held no data lines (one
    line of a billion NULs); a NUL or a line over 1 MB is now refused before it is read."""
    zeros = tmp_path / "zeros.xyz"
    zeros.write_bytes(bytes(3 * 2**20))
    _one_line(capsys, main(["info", str(zeros)]), "zeros.xyz, byte 0: a NUL byte (binary data)")
    late = tmp_path / "late.xyz"
    late.write_bytes(b"1 2 -3\n" * 1000 + b"\0" * 10)
    _one_line(capsys, main(["info", str(late)]), "late.xyz, byte 7000: a NUL byte")
    endless = tmp_path / "endless.xyz"
    endless.write_bytes(b"7" * (2 * 2**20))
    _one_line(capsys, main(["info", str(endless)]), "endless.xyz, line 1: over 1 MB without a line end")


def test_soundings_far_below_or_far_away_are_named_in_memory_and_in_tiles(tmp_path, capsys):
    """A sounding 640 m under a 10 m seabed passed without a word; in a tiled run a sounding
    91 km away made a tile of its own ("0 points") and was never named."""
    rng = np.random.default_rng(0)
    g = np.arange(0.0, 30.0, 0.3)
    x, y = np.meshgrid(g, g)
    pts = np.column_stack([x.ravel() + 500_000, y.ravel() + 4_100_000, -10 + rng.normal(0, 0.02, x.size)])
    pts[5, 2] = -650.0
    pts[7, :2] = [512_000, 4_190_000]
    path = tmp_path / "outliers.xyz"
    np.savetxt(path, pts, fmt="%.3f")
    for extra in ([], ["--tiled", "--workers", "1"]):
        assert main(["reefs", str(path), "--crs", "EPSG:32617", "--no-figures",
                     "--out", str(tmp_path / f"o{len(extra)}"), *extra]) == 0
        err = capsys.readouterr().err
        assert "1 sounding far below the seabed of the survey, down to -650.0 m (median -10.0 m)" in err
        assert "km from the rest of the survey (a navigation jump?) and were left out" in err
        assert "0 points" not in err and "Traceback" not in err


def test_a_tiled_run_of_one_sounding_and_a_bad_file_among_good_ones(tmp_path, capsys):
    """A tiled run with one sounding ended in np.gradient's traceback; one unreadable file
    among many inputs in a LaspyException."""
    one = tmp_path / "one.xyz"
    one.write_text("554845.0 4179000.0 -10.0\n")
    code = main(["reefs", str(one), "--crs", "EPSG:32610", "--tiled", "--workers", "1",
                 "--out", str(tmp_path / "o1")])
    err = capsys.readouterr().err
    assert code == 5 and "Traceback" not in err and "expected at least 10" in err.splitlines()[-1]
    good = tmp_path / "good.xyz"
    good.write_text("".join(f"{554845 + k % 20}.0 {4179000 + k // 20}.0 -10.0\n" for k in range(400)))
    bad = tmp_path / "bad.las"
    bad.write_bytes(b"LASF" + bytes(300))
    for extra in ([], ["--tiled", "--workers", "1"]):
        _one_line(capsys, main(["reefs", str(good), str(bad), "--crs", "EPSG:32610", *extra,
                                "--out", str(tmp_path / f"o{len(extra)}")]), "bad.las")
