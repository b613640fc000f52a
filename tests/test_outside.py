"""Other projects' own test files (laspy, PDAL), read as their own decoders read them or
refused in one line with the reason (``tests/data/outside/MANIFEST.csv``)."""

from __future__ import annotations

import csv
import warnings
from pathlib import Path

import laspy
import numpy as np
import pytest
from pyproj import CRS, Transformer

from mbinspect.cli import main
from mbinspect.formats.las import NOISE_CLASSES
from mbinspect.io import read

OUTSIDE = Path(__file__).parent / "data" / "outside"
ROWS = list(csv.DictReader((OUTSIDE / "MANIFEST.csv").open()))


def test_the_gauntlet_holds_at_least_forty_files_with_their_sources():
    assert len(ROWS) >= 40
    assert all((OUTSIDE / r["file"]).is_file() and "@" in r["source"] and r["licence"] for r in ROWS)
    assert {r["file"] for r in ROWS} == {p.name for p in OUTSIDE.iterdir() if p.suffix not in (".csv", ".md")}


def _peer(path: Path) -> tuple[np.ndarray, CRS | None]:
    """laspy's decode: the points a survey keeps (neither withheld nor noise), the file's CRS."""
    las = laspy.read(path)
    keep = ~(np.asarray(las.withheld, bool) | np.isin(np.asarray(las.classification), NOISE_CLASSES))
    xyz = np.column_stack([las.x, las.y, las.z])[keep]
    try:
        crs = las.header.parse_crs()
    except Exception:  # a broken GeoTIFF key: laspy cannot say
        crs = None
    return xyz, crs


def _in(crs: CRS | None, out: str | None, xyz: np.ndarray) -> np.ndarray:
    """The peer's points where mbinspect should put them: into its CRS, heights in metres."""
    if crs is None or out is None or CRS.from_user_input(out).equals(crs):
        return xyz
    plan = next((s for s in crs.sub_crs_list if not s.is_vertical), crs) if crs.is_compound else crs
    vertical = next((s for s in crs.sub_crs_list if s.is_vertical), None) if crs.is_compound else None
    x, y = Transformer.from_crs(plan, CRS.from_user_input(out), always_xy=True).transform(*xyz[:, :2].T)
    unit = vertical.axis_info[0] if vertical is not None else plan.axis_info[0] if plan.is_projected else None
    z = xyz[:, 2] * (unit.unit_conversion_factor if unit is not None else 1.0)
    return np.column_stack([x, y, z])


LAS = [r for r in ROWS if r["expect"] == "read" and r["file"].endswith((".las", ".laz"))]
PLY = [r for r in ROWS if r["file"].endswith(".ply") and r["expect"].startswith("read")]
REFUSED = [r for r in ROWS if r["expect"].startswith("refused")]
SONAR = [r for r in ROWS if r["file"].endswith((".gsf", ".all", ".kmall")) and r["expect"].startswith("read")]


@pytest.mark.parametrize("row", LAS, ids=lambda r: r["file"])
def test_las_files_read_as_laspy_reads_them(row):
    path = OUTSIDE / row["file"]
    expected, crs = _peer(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cloud = read(path)
    assert len(cloud) == len(expected)
    want = _in(crs, cloud.crs, expected)
    assert np.allclose(cloud.xyz.min(axis=0), want.min(axis=0), atol=1e-3)
    assert np.allclose(cloud.xyz.max(axis=0), want.max(axis=0), atol=1e-3)
    if crs is not None:
        out = CRS.from_user_input(cloud.crs)
        assert out.is_projected and out.axis_info[0].unit_conversion_factor == 1.0  # metres, always


@pytest.mark.parametrize("row", PLY, ids=lambda r: r["file"])
def test_ply_files_read_with_the_vertex_count_of_their_header(row):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cloud = read(OUTSIDE / row["file"])
    assert len(cloud) == int(row["expect"].split()[1])


@pytest.mark.parametrize("row", SONAR, ids=lambda r: r["file"])
def test_sonar_files_read_with_their_peers_counts(row):
    """NOAA's EM302 GSF writes its intensity series one byte past each ping record: read, as
    libgsf and gsfu read it, with one warning."""
    with pytest.warns(UserWarning, match="runs up to 1 byte past its record"):
        cloud = read(OUTSIDE / row["file"])
    assert len(cloud) == int(row["expect"].split()[1])


@pytest.mark.parametrize("row", REFUSED, ids=lambda r: r["file"])
def test_broken_files_are_refused_in_one_line(row, capsys):
    code = main(["info", str(OUTSIDE / row["file"])])
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.startswith("mbinspect: error: ") and err.count("\n") == 1 and "Traceback" not in err
    assert row["file"] in err and row["expect"].split(": ", 1)[1] in err
