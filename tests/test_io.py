"""Readers, writers and bad input for mbinspect.io."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from mbinspect.checks import check_points
from mbinspect.errors import FileAccessError, InputError, NotEnoughPointsError, ParameterError
from mbinspect.formats import ascii_parse as mascii
from mbinspect.io import InputWarning, PointCloud, describe, read, write


def _cloud(n: int = 50, seed: int = 0) -> PointCloud:
    rng = np.random.default_rng(seed)
    xyz = np.column_stack([512000 + rng.uniform(0, 30, n), 3456000 + rng.uniform(0, 30, n),
                           rng.uniform(-22, -15, n)])
    return PointCloud(xyz, {"intensity": rng.uniform(60, 90, n).round(1),
                            "line": rng.integers(1, 5, n).astype(np.int32)})


@pytest.mark.parametrize("name", ["c.xyz", "c.csv", "c.las", "c.laz", "c.ply", "c.npz"])
def test_round_trip_keeps_points_and_fields(tmp_path, name):
    cloud = _cloud()
    write(cloud, tmp_path / name)
    back = read(tmp_path / name)
    assert len(back) == len(cloud)
    np.testing.assert_allclose(back.xyz, cloud.xyz, atol=6e-4)  # mm precision by default
    np.testing.assert_allclose(back.fields["intensity"], cloud.fields["intensity"], atol=1e-6)
    np.testing.assert_array_equal(back.fields["line"].astype(int), cloud.fields["line"])


def test_write_is_atomic_and_leaves_no_temporary(tmp_path):
    write(_cloud(), tmp_path / "a.xyz")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.xyz"]


@pytest.mark.parametrize(
    "text",
    [
        "1 2 -3\n4 5 -6\n",
        "1,2,-3\n4,5,-6\n",
        "1;2;-3\n4;5;-6\n",
        "1\t2\t-3\n4\t5\t-6\n",
        "# comment\n\n1 2 -3\n\n# another\n4 5 -6\n",
        "1,2,-3,\n4,5,-6,\n",
        "x,y,z\n1,2,-3\n4,5,-6\n",
        "  1   2  -3  \n4 5 -6",
    ],
)
def test_ascii_dialects(tmp_path, text):
    p = tmp_path / "a.txt"
    p.write_text(text)
    cloud = read(p)
    np.testing.assert_array_equal(cloud.xyz, [[1, 2, -3], [4, 5, -6]])


def test_ascii_four_columns_are_xyz_intensity(tmp_path):
    p = tmp_path / "a.xyz"
    p.write_text("1 2 -3 70\n4 5 -6 80\n")
    assert read(p).fields["intensity"].tolist() == [70, 80]


def test_header_names_and_depth_flag(tmp_path):
    p = tmp_path / "a.csv"
    p.write_text("Easting,Northing,Depth,Backscatter\n1,2,3,70\n4,5,6,80\n")
    with pytest.warns(UserWarning, match="depth"):
        as_given = read(p)
    assert as_given.xyz[:, 2].tolist() == [3, 6]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the user said what z is: no warning any more
        flipped = read(p, depth_positive=True)
    assert flipped.xyz[:, 2].tolist() == [-3, -6]
    assert flipped.z_convention == "depth"
    assert flipped.fields["intensity"].tolist() == [70, 80]


def test_columns_map_skips_and_reorders(tmp_path):
    p = tmp_path / "a.txt"
    p.write_text("7 1 2 9 3\n7 4 5 9 6\n")
    cloud = read(p, columns="line,x,y,-,z")
    np.testing.assert_array_equal(cloud.xyz, [[1, 2, 3], [4, 5, 6]])
    assert cloud.fields["line"].tolist() == [7, 7]


def test_parallel_chunks_give_the_same_answer_and_locate_errors(tmp_path, monkeypatch):
    rng = np.random.default_rng(1)
    table = rng.uniform(-20, 20, (3000, 5)).round(3)
    p = tmp_path / "big.xyz"
    np.savetxt(p, table, fmt="%.3f", header="ping x y z intensity", comments="")
    monkeypatch.setattr(mascii, "CHUNK_BYTES", 1000)  # about 100 chunks, in worker processes
    seen: list[float] = []
    cloud = read(p, progress=seen.append)
    np.testing.assert_allclose(cloud.xyz, table[:, 1:4])
    np.testing.assert_allclose(cloud.fields["ping"], table[:, 0])
    np.testing.assert_allclose(cloud.fields["intensity"], table[:, 4])
    assert len(seen) > 50 and seen == sorted(seen) and seen[-1] == 1.0
    lines = p.read_text().splitlines()
    good = list(lines)
    lines[2500] = "1.0 2.0 abc 2.0 3.0"
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"line 2501, column 3: 'abc' is not a number"):
        read(p)
    good[2700] = "1.0 2.0 3.0 nan 3.0"  # the row count of the chunks before it locates it
    p.write_text("\n".join(good) + "\n")
    with pytest.raises(InputError, match=r"line 2701, column 4: 'nan' is not a finite number"):
        read(p)


@pytest.mark.parametrize(
    ("text", "pattern"),
    [
        ("1 2 3\n4 x 6\n", r"line 2, column 2: 'x' is not a number"),
        ("# c\n1 2 3\n\n4 5\n", r"line 4: 2 columns, expected 3"),
        ("1 2 3\n4 5 6 7\n", r"line 2: 4 columns, expected 3"),
        ("1 2 3\n4 nan 6\n", r"line 2, column 2: 'nan' is not a finite number"),
        ("1 2 3\n4 5 inf\n", r"line 2, column 3: 'inf' is not a finite number"),
        ("1 2\n3 4\n", r"line 1: 2 columns; expected at least 3"),
        ("1 2 3 4 5\n", r"5 columns and no header; give `columns`"),
        ("a,b,c\n1,2,3\n", r"header: no column for x, y, z"),
        ("# only a comment\n\n", r"no data lines"),
        ("", r"the file is empty"),
    ],
)
def test_bad_ascii_names_the_place(tmp_path, text, pattern):
    p = tmp_path / "bad.xyz"
    p.write_text(text)
    with pytest.raises(InputError, match=pattern) as info:
        read(p)
    assert str(p) in str(info.value)
    assert "\n" not in str(info.value)


def test_missing_file_directory_and_extension(tmp_path):
    with pytest.raises(FileAccessError, match="no such file"):
        read(tmp_path / "nope.xyz")
    with pytest.raises(FileAccessError, match="is a directory"):
        read(tmp_path)
    (tmp_path / "a.foo").write_text("1 2 3\n")
    with pytest.raises(InputError, match="unknown extension '.foo'"):
        read(tmp_path / "a.foo")
    assert len(read(tmp_path / "a.foo", format="xyz")) == 1
    with pytest.raises(ParameterError, match="format: 'e57'; expected one of xyz, las, laz, ply, npz, gsf"):
        read(tmp_path / "a.foo", format="e57")
    with pytest.raises(InputError, match="a.foo: no GSF header record; expected a GSF file"):
        read(tmp_path / "a.foo", format="gsf")


def test_las_with_no_points(tmp_path):
    import laspy

    las = laspy.LasData(laspy.LasHeader(point_format=6, version="1.4"))
    las.write(tmp_path / "empty.las")
    with pytest.raises(InputError, match="holds no points"):
        read(tmp_path / "empty.las")


def test_broken_binary_files(tmp_path):
    (tmp_path / "x.las").write_bytes(b"not a las file at all")
    with pytest.raises(InputError, match="not a readable LAS|not a LAS/LAZ file"):
        read(tmp_path / "x.las")
    (tmp_path / "x.ply").write_bytes(b"ply\nformat binary_little_endian 1.0\n"
                                     b"element vertex 10\nproperty double x\nproperty double y\n"
                                     b"property double z\nend_header\n" + b"\0" * 48)
    with pytest.raises(InputError, match="truncated"):
        read(tmp_path / "x.ply")


def test_ascii_ply(tmp_path):
    p = tmp_path / "a.ply"
    p.write_text("ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                 "property float z\nproperty float scalar_intensity\nend_header\n"
                 "1 2 -3 50\n4 5 -6 60\n")
    cloud = read(p)
    np.testing.assert_array_equal(cloud.xyz, [[1, 2, -3], [4, 5, -6]])
    assert cloud.fields["intensity"].tolist() == [50, 60]


def test_inputs_are_never_modified(tmp_path):
    p = tmp_path / "a.csv"
    p.write_text("x,y,depth\n1,2,3\n")
    before = p.read_bytes()
    with pytest.warns(InputWarning, match="depth"):
        read(p)
    read(p, depth_positive=True)
    assert p.read_bytes() == before


def test_describe_density_and_spacing():
    g = np.arange(0.05, 10, 0.1)
    x, y = np.meshgrid(g, g)
    cloud = PointCloud(np.column_stack([x.ravel(), y.ravel(), np.full(x.size, -20.0)]))
    s = describe(cloud)
    assert s.n_points == 10_000
    assert s.area == pytest.approx(100.0)
    assert s.density == pytest.approx(100.0)
    assert s.spacing == pytest.approx(0.1, rel=1e-6)
    assert s.to_dict()["z_range"] == [-20.0, -20.0]


def test_check_points_rejects_bad_arrays():
    with pytest.raises(ParameterError, match=r"\(N, 3\)"):
        check_points(np.zeros((4, 2)))
    with pytest.raises(NotEnoughPointsError, match="at least 5"):
        check_points(np.zeros((4, 3)), minimum=5)
