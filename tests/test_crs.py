"""Coordinates in metres, never guessed: geographic and foot-based files projected, --crs as
the target, CRSs that contradict the data refused; the same in memory and in tiles."""

from __future__ import annotations

import warnings
from pathlib import Path

import laspy
import numpy as np
import pytest
from pyproj import CRS, Transformer

from mbinspect.cli import main
from mbinspect.cloud import PointCloud
from mbinspect.crs import ScaleError, to_metres
from mbinspect.errors import InputError, ParameterError
from mbinspect.io import read, write
from mbinspect.piles import PileOptions
from mbinspect.simulate import simulate
from mbinspect.survey.run import SurveyOptions, run_survey

DATA = Path(__file__).parent / "data"
US_FT = 1200 / 3937


def _las(path: Path, crs: str, xyz: np.ndarray, scale: float) -> Path:
    header = laspy.LasHeader(point_format=3, version="1.2")
    header.add_crs(CRS.from_user_input(crs))
    header.offsets = np.floor(xyz.min(axis=0))
    header.scales = [scale, scale, 0.001]
    las = laspy.LasData(header)
    las.x, las.y, las.z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    las.point_source_id = np.ones(len(xyz), np.uint16)
    las.write(path)
    return path


@pytest.fixture(scope="module")
def jacket() -> tuple[PointCloud, dict]:
    """A sparse simulated jacket in UTM 17N (the origin moved to Florida's west coast)."""
    sim = simulate("jacket", seed=4, ping_spacing=0.5, origin_x=350000.0, origin_y=3070000.0)
    return sim.cloud, sim.truth


def _lonlat(xyz: np.ndarray, crs: str = "EPSG:32617") -> np.ndarray:
    lon, lat = Transformer.from_crs(crs, "EPSG:4326", always_xy=True).transform(xyz[:, 0], xyz[:, 1])
    return np.column_stack([lon, lat, xyz[:, 2]])


def test_a_las_in_degrees_is_projected_to_its_utm_zone(tmp_path, jacket):
    cloud, truth = jacket
    path = _las(tmp_path / "geo.las", "EPSG:4326", _lonlat(cloud.xyz), 1e-9)
    with pytest.warns(UserWarning, match="WGS 84 .degrees. projected to WGS 84 / UTM zone 17N"):
        back = read(path)
    assert CRS.from_user_input(back.crs).to_epsg() == 32617
    assert np.abs(back.xyz - cloud.xyz).max() < 0.002  # 1e-9 degree steps, millimetre heights
    result = run_survey("piles", [path], PileOptions(radius=0.75, count=4), SurveyOptions()).result
    xy = np.array([[p["x"], p["y"]] for p in truth["piles"]])
    assert len(result.piles) == 4
    assert max(np.hypot(*(xy - [p.x, p.y]).T).min() for p in result.piles) < 0.03


def test_feet_are_metres_after_reading_and_every_threshold_sees_metres(tmp_path, jacket):
    """A state-plane file in US survey feet (Florida West, EPSG:2237): plan and heights
    converted; the piles found and spaced as in metres."""
    cloud, truth = jacket
    x, y = Transformer.from_crs("EPSG:32617", "EPSG:2237", always_xy=True).transform(cloud.xyz[:, 0],
                                                                                      cloud.xyz[:, 1])
    ft = np.column_stack([x, y, cloud.xyz[:, 2] / US_FT])
    path = _las(tmp_path / "feet.las", "EPSG:2237", ft, 0.001)
    with pytest.warns(UserWarning, match=r"US survey feet.*heights converted from US survey feet"):
        back = read(path)
    assert np.abs(back.xyz[:, 2] - cloud.xyz[:, 2]).max() < 0.002
    # a grid distance in UTM 17N: the two grids' scales differ by under 1:2500
    d_in = np.hypot(*(cloud.xyz[100, :2] - cloud.xyz[200_00, :2]))
    d_out = np.hypot(*(back.xyz[100, :2] - back.xyz[200_00, :2]))
    assert abs(d_out - d_in) < 4e-4 * d_in + 0.003
    tiled = run_survey("piles", [path], PileOptions(radius=0.75, count=4),
                       SurveyOptions(tiled=True, tile_size=40.0, workers=1, chunk=50_000)).result
    whole = run_survey("piles", [path], PileOptions(radius=0.75, count=4), SurveyOptions()).result
    assert len(tiled.piles) == len(whole.piles) == 4
    for p, q in zip(whole.piles, tiled.piles, strict=True):
        assert abs(p.x - q.x) < 1e-3 and abs(p.y - q.y) < 1e-3
    true = {(s["a"], s["b"]): s["distance"] for s in truth["spacings"]}
    assert all(abs(s.distance - true[s.a, s.b]) < 0.03 for s in whole.spacings)


def test_crs_reprojects_and_a_crs_for_elsewhere_is_refused(tmp_path, jacket):
    cloud, _ = jacket
    path = tmp_path / "utm.las"
    write(PointCloud(cloud.xyz, crs="EPSG:32617"), path)
    moved = read(path, crs="EPSG:26917")  # NAD83 / UTM 17N: metres, the same zone
    assert CRS.from_user_input(moved.crs).to_epsg() == 26917
    with pytest.raises(ScaleError, match=r"'EPSG:32631' .* distorts distances .* \(EPSG:32617 here\)"):
        read(path, crs="EPSG:32631")
    with pytest.raises(ParameterError, match="is geographic; expected a projected CRS"):
        read(path, crs="EPSG:4326")
    with pytest.raises(ParameterError, match="is not in metres|projected"):
        read(path, crs="EPSG:5703")  # a vertical datum, not a plan CRS


def test_a_crs_that_contradicts_the_coordinates_is_refused(tmp_path, jacket):
    cloud, _ = jacket
    path = _las(tmp_path / "lying.las", "EPSG:4326", cloud.xyz[:1000], 0.001)  # metres labelled degrees
    with pytest.raises(InputError, match=r"lying.las: the file's CRS WGS 84 is geographic, but its "
                                         r"coordinates \(x = 3"):
        read(path)
    xyz = tmp_path / "metres.xyz"
    write(PointCloud(cloud.xyz[:1000]), xyz)
    with pytest.raises(ParameterError, match="'EPSG:4326' .WGS 84. is geographic, but the coordinates"):
        read(xyz, crs="EPSG:4326")


def test_degrees_under_explicit_columns_are_caught(tmp_path, jacket):
    cloud, _ = jacket
    ll = _lonlat(cloud.xyz[:2000])
    path = tmp_path / "lonlat.csv"
    path.write_text("".join(f"2015-07-08,{a:.9f},{b:.9f},{c:.3f},{i}\n" for i, (a, b, c) in enumerate(ll)))
    with pytest.warns(UserWarning, match="read as longitude and latitude"):
        back = read(path, columns="-,x,y,z,intensity")
    assert np.abs(back.xyz - cloud.xyz[:2000]).max() < 0.01


def test_files_of_one_survey_in_different_zones(tmp_path, capsys):
    """Two real sonar files 8,800 km apart are not one survey; two files of one place in
    different CRSs are brought to the first one's."""
    code = main(["info", str(DATA / "Belgica_0077.all"), str(DATA / "pdal_mbf_em300raw.mb56")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("mbinspect: error:") == 1 and "Traceback" not in err
    assert "pdal_mbf_em300raw.mb56: lies where the CRS of" in err and "EPSG:32617" in err
    line = read(DATA / "pdal_mbf_em300raw.mb56")
    a, b = tmp_path / "a.las", tmp_path / "b.las"
    write(PointCloud(line.xyz, crs=line.crs), a)
    x, y = Transformer.from_crs(line.crs, "EPSG:26917", always_xy=True).transform(*line.xyz[:, :2].T)
    write(PointCloud(np.column_stack([x, y, line.xyz[:, 2]]) + [0.0, 50.0, 0.0], crs="EPSG:26917"), b)
    from mbinspect.survey.inputs import read_survey

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        both = read_survey([a, b])
    assert any("b.las" in str(w.message) and "projected to WGS 84 / UTM zone 17N" in str(w.message)
               for w in caught)
    assert CRS.from_user_input(both.crs).to_epsg() == 32617
    shift = both.xyz[len(line):, :2] - line.xyz[:, :2]
    assert np.allclose(np.median(shift, axis=0), [0.0, 50.0], atol=2.0)  # NAD83 and WGS 84 agree to ~1 m


def test_to_metres_leaves_metres_alone():
    cloud = PointCloud(np.array([[500000.0, 5600000.0, -10.0]] * 3), crs="EPSG:32631")
    out, notes = to_metres(cloud)
    assert out is cloud and notes == []
