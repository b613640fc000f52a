"""Every path on every format: one small survey written in each export layout, and the real
sonar files, through ``info``, ``reefs``, ``inject`` and ``piles``, in memory and in tiles;
the answers agree across formats and between the two runs."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from pyproj import Transformer

from mbinspect.cli import main
from mbinspect.cloud import PointCloud
from mbinspect.errors import MBInspectError
from mbinspect.inject import InjectedPile, inject
from mbinspect.io import read, write
from mbinspect.piles import PileOptions
from mbinspect.reefs import ReefOptions
from mbinspect.simulate import simulate
from mbinspect.survey.run import SurveyOptions, run_survey

#: 40 s in all: in the full run (CI), not the quick one
pytestmark = pytest.mark.slow

DATA = Path(__file__).parent / "data"
CRS = "EPSG:32617"
EXPORTS = ["xyz-header", "xyz-bare", "decimal-comma", "lonlat", "las", "laz", "ply", "npz"]
SONAR = ["Belgica_0077.all", "pdal_mbf_em300raw.mb56", "ets_kmall_OS03_-4033476991022010987.kmall",
         "gsf_EX1502L2_0175.gsf", "R2Testing_0009_first40.xtf"]
#: Lines dense enough to measure two piles of 0.5 m (the EM3000 line: 67 pings at 4.5 m; the R2Sonic
#: strip: 40 pings at 10.5 m);
#: the others (9 pings; a narrow strip) stop with the reason, alike in memory and tiles.
FINDS_PILES = {"pdal_mbf_em300raw.mb56", "R2Testing_0009_first40.xtf"}
#: Deep files take no pile (1.5 km of water): info and reefs only.
DEEP = {"gsf_EX1502L2_0175.gsf"}


@pytest.fixture(scope="module")
def reference(field: PointCloud, tmp_path_factory: pytest.TempPathFactory) -> list[tuple[float, float]]:
    """The reefs of the survey at full precision (an NPZ keeps every bit)."""
    path = tmp_path_factory.mktemp("reference") / "field.npz"
    write(field, path)
    return _reefs([path], {"crs": CRS}, tiled=False)


@pytest.fixture(scope="module")
def field() -> PointCloud:
    sim = simulate("reef-field", seed=4, groups="cross1", per_group=4, ping_spacing=0.8, close_pairs=0,
                   boulders=0, debris=0)
    return PointCloud(sim.cloud.xyz, sim.cloud.fields, crs=CRS)


def _export(cloud: PointCloud, kind: str, folder: Path) -> tuple[Path, dict]:
    """The survey in one export layout, and the reading options it needs."""
    xyz = cloud.xyz
    if kind in ("las", "laz", "ply", "npz"):
        path = folder / f"field.{kind}"
        write(cloud, path)
        return path, {"crs": CRS} if kind in ("ply", "npz") else {}
    path = folder / ("field.txt" if kind != "decimal-comma" else "field.csv")
    if kind == "xyz-header":
        text = "Easting (m),Northing (m),Elevation (m)\n" + "".join(f"{a:.3f},{b:.3f},{c:.3f}\n"
                                                                     for a, b, c in xyz)
    elif kind == "xyz-bare":
        text = "".join(f"{a:.3f} {b:.3f} {c:.3f}\n" for a, b, c in xyz)
    elif kind == "decimal-comma":
        text = "X;Y;Z\n" + "".join(f"{a:.3f};{b:.3f};{c:.3f}\n".replace(".", ",") for a, b, c in xyz)
    else:  # longitude and latitude, to a tenth of a millimetre
        lon, lat = Transformer.from_crs(CRS, "EPSG:4326", always_xy=True).transform(xyz[:, 0], xyz[:, 1])
        rows = zip(lon, lat, xyz[:, 2], strict=True)
        text = "lon,lat,elevation\n" + "".join(f"{a:.10f},{b:.10f},{c:.3f}\n" for a, b, c in rows)
        path.write_text(text)
        return path, {}
    path.write_text(text)
    return path, {"crs": CRS, "z_up": True} if kind != "xyz-header" else {"crs": CRS}


def _reefs(paths: list[Path], read_options: dict, tiled: bool) -> list[tuple[float, float]]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        survey = SurveyOptions(tiled=tiled, tile_size=110.0, workers=1)
        run = run_survey("reefs", paths, ReefOptions(seabed="grid"), survey, read_options=read_options)
    return sorted((round(r.x, 2), round(r.y, 2)) for r in run.result.reefs)


@pytest.mark.parametrize("kind", EXPORTS)
def test_every_export_layout_gives_the_same_reefs_in_memory_and_in_tiles(field, reference, kind, tmp_path,
                                                                         capsys):
    path, opts = _export(field, kind, tmp_path)
    flags = [f"--{k.replace('_', '-')}" if v is True else f"--{k}={v}" for k, v in opts.items()]
    assert main(["info", str(path), *flags]) == 0
    capsys.readouterr()
    want = _reefs([path], opts, tiled=False)
    assert len(want) == 4
    assert _reefs([path], opts, tiled=True) == want
    for (x, y), (u, v) in zip(want, reference, strict=True):
        # the layouts round to a millimetre, which moves a footprint's 0.1 m cells' ties: a
        # centre may move by up to a cell
        assert abs(x - u) <= 0.1 and abs(y - v) <= 0.1


@pytest.mark.parametrize("name", SONAR)
def test_every_sonar_format_through_info_inject_and_piles(name, tmp_path, capsys):
    """The real lines hold no object: two piles are put in, and found alike in memory and
    in tiles; reefs either find the same or stop with the same reason."""
    path = DATA / name
    assert main(["info", str(path)]) == 0
    capsys.readouterr()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cloud = read(path)
    outcomes = []
    for tiled in (False, True):
        try:
            outcomes.append(_reefs([path], {}, tiled))
        except MBInspectError as exc:
            outcomes.append(str(exc).split(";")[0])
    assert outcomes[0] == outcomes[1]
    if name in DEEP:
        return
    xy = cloud.xyz[:, :2]
    a = xy[np.argmin(np.hypot(*(xy - np.median(xy, axis=0)).T))]
    b = xy[np.argmin(np.abs(np.hypot(*(xy - a).T) - 4.0))]  # a sounding 4 m away
    piles = [InjectedPile(1, *a, 0.5, height=2.0), InjectedPile(2, *b, 0.5, height=2.0)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        injected = inject(cloud.xyz, cloud.fields, piles=piles)
    line = tmp_path / "injected.npz"
    write(PointCloud(injected.xyz, dict(cloud.fields), crs=cloud.crs), line)
    found: list[object] = []
    for tiled in (False, True):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                run = run_survey("piles", [line], PileOptions(radius=0.5, count=2),
                                 SurveyOptions(tiled=tiled, tile_size=40.0, workers=1))
            found.append([(round(p.x, 3), round(p.y, 3)) for p in run.result.piles])
        except MBInspectError as exc:  # a line too sparse to show a pile says so, alike in both
            found.append(str(exc))
    assert found[0] == found[1]
    if name in FINDS_PILES:
        true = np.array([[p.x, p.y] for p in piles])
        assert len(found[0]) == 2 and all(np.hypot(*(true - xy).T).min() < 0.15 for xy in found[0])
