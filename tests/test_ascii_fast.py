"""The compiled ASCII parser gives NumPy's doubles to the bit, or gives up and NumPy parses."""

from __future__ import annotations

import io

import numpy as np
import pytest

from mbinspect.errors import InputError
from mbinspect.formats import ascii_parse
from mbinspect.formats.ascii_fast import parse_numbers
from mbinspect.io import read


def _fast(data: bytes, delimiter: str | None, ncols: int) -> np.ndarray | None:
    rows = data.count(b"\n") + 1
    xyz, fields = np.full((rows, 3), np.nan), np.full((max(ncols - 3, 0), rows), np.nan)
    got = parse_numbers(data, delimiter, np.arange(ncols), xyz, fields, 0)
    return None if got is None else np.column_stack([xyz[:got], fields[:, :got].T])


def _numpy(data: bytes, delimiter: str | None) -> np.ndarray:
    return np.loadtxt(io.BytesIO(data), delimiter=delimiter, comments=None, ndmin=2, encoding="utf-8")


def test_numbers_written_every_common_way_parse_to_the_same_bits():
    rng = np.random.default_rng(3)
    values = np.concatenate([rng.uniform(-1e6, 1e7, 3000), rng.normal(0, 1, 3000),
                             rng.uniform(-90, 90, 3000) * 10.0 ** rng.integers(-8, 8, 3000)])
    for fmt in ("{:.3f}", "{:.9f}", "{!r}", "{:.6e}", "{:.15g}", "{:+.2f}", "{:E}"):
        text = [fmt.format(v) for v in values.tolist()]
        data = "".join(f"{a} {b} {c}\n" for a, b, c in zip(text[0::3], text[1::3], text[2::3],
                                                          strict=True)).encode()
        want = _numpy(data, None)
        got = _fast(data, None, 3)
        if got is None:  # 16 or 17 significant digits, or 1e-24 written out, need NumPy's parser
            assert fmt in ("{!r}", "{:.9f}", "{:.15g}")
            continue
        assert got.view(np.int64).tolist() == want.view(np.int64).tolist(), fmt


@pytest.mark.parametrize("text, delimiter", [
    (b"1 2 3\r\n\r\n -4.5\t5. .6 \r\n", None),
    (b"1,2,3\n4 , 5,\t6\n\n", ","),
    (b"1;-0;+3e2\n", ";"),
    (b"1\t2\t3", "\t"),
    (b"0e999 1e-22 1e22\n", None),
])
def test_layouts_it_reads_match_numpy(text, delimiter):
    got = _fast(text, delimiter, 3)
    assert got is not None
    assert got.view(np.int64).tolist() == _numpy(text, delimiter).view(np.int64).tolist()


@pytest.mark.parametrize("text, delimiter", [
    (b"1 2 3\n4 5\n", None),  # another column count
    (b"1 2 nan\n", None),
    (b"1 2 1_0\n", None),
    (b"1 2 3x\n", None),
    (b"1,,3\n", ","),
    (b"1,2,3,\n", ","),
    (b"1,2,3\n   \n", ","),  # NumPy refuses a line of blanks between delimiters
    (b"1 2 3\r4 5 6\n", None),
    (b"1 2 1.00000000000000000001\n", None),
    (b"1 2 1e23\n", None),
    (b"1 2\x1c3\n", None),
])
def test_anything_else_is_left_to_numpy(text, delimiter):
    assert _fast(text, delimiter, 3) is None


def test_a_file_reads_the_same_with_and_without_the_compiled_parser(tmp_path, monkeypatch):
    rng = np.random.default_rng(0)
    lines = ["# easting northing depth backscatter"]
    for k in range(4000):
        x, y, z, b = rng.uniform(4e5, 5e5), rng.uniform(6e6, 7e6), rng.uniform(-60, -5), rng.normal(-30, 3)
        lines.append(f"{x:.3f}, {y:.3f},{z:.2f} ,{b:.1f}")
        if k % 997 == 0:
            lines += ["", "# a comment line"]
    lines.append("400000.5,6000000.25,-7,nan")  # a field may be NaN
    path = tmp_path / "survey.csv"
    path.write_text("\r\n".join(lines))
    monkeypatch.setattr(ascii_parse, "CHUNK_BYTES", 20_000)  # many chunks, each with its gaps
    fast = read(path, columns="x,y,z,intensity")
    monkeypatch.setattr(ascii_parse, "_fast", lambda table: False)
    slow = read(path, columns="x,y,z,intensity")
    assert len(fast.xyz) == 4001
    assert fast.xyz.tobytes() == slow.xyz.tobytes()
    assert np.array_equal(fast.fields["intensity"], slow.fields["intensity"], equal_nan=True)


def test_a_bad_value_is_named_by_its_line_either_way(tmp_path, monkeypatch):
    rows = [f"{500000 + k}.5 {6000000 + k}.25 -{10 + k % 7}.5" for k in range(3000)]
    rows[2500] = "500000.5 6000000.25 -1O.5"
    path = tmp_path / "bad.xyz"
    path.write_text("\n".join(rows) + "\n")
    monkeypatch.setattr(ascii_parse, "CHUNK_BYTES", 10_000)
    with pytest.raises(InputError, match=r"line 2501.*-1O\.5"):
        read(path, crs="EPSG:32631")
