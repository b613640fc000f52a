"""How reef units rest: boxes turned in space, designs in every orientation, the simulator's
overturned and leaning units, and the reef chain telling them apart with the top's tilt."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mbinspect.cli import main
from mbinspect.cloud import PointCloud
from mbinspect.design_solids import ORIENTATIONS, corners, design_solids, distinct_orientations
from mbinspect.errors import InputError, ParameterError
from mbinspect.inject import InjectedReef, inject, read_reef_file
from mbinspect.io import read, write
from mbinspect.reef_designs import BUILTIN_DESIGNS
from mbinspect.reefs import extract_reefs
from mbinspect.reefs.orient import rest_of
from mbinspect.reefs.results import Reef
from mbinspect.reefs.tilt import top_tilt
from mbinspect.simulate import simulate
from mbinspect.solids import ray_box, turn, upper_surface


def test_a_box_turned_on_its_side_stands_as_tall_as_it_was_wide():
    axes = turn((1.0, 0.0, 0.0), 90.0)  # rows: length, width, height directions
    base = np.zeros(3)
    size = (3.0, 0.8, 1.2)
    top = upper_surface([(base, axes, size)], np.array([[0.0, 0.0], [1.4, 0.0], [2.0, 0.0]]))
    # the width now points up: the top is 0.8 m above the base, the box 1.2 m across in y
    assert top[0] == pytest.approx(0.4) and top[1] == pytest.approx(0.4) and top[2] == -np.inf
    t, n = ray_box(base, axes, size, np.array([[0.0, -5.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
    assert t[0] == pytest.approx(5.0) and n[0] == pytest.approx([0.0, -1.0, 0.0])


def test_each_design_has_the_orientations_that_look_different():
    assert distinct_orientations(BUILTIN_DESIGNS["cube"]) == ("upright",)
    assert distinct_orientations(BUILTIN_DESIGNS["cross2"]) == ("upright", "upside down", "on its side")
    assert "upside down" not in distinct_orientations(BUILTIN_DESIGNS["cross1"])  # alike both ways up
    for name, d in BUILTIN_DESIGNS.items():
        for way in ORIENTATIONS:
            low = min(float(c[:, 2].min()) for c in corners(design_solids(d, way, z_base=-5.0)))
            assert low == pytest.approx(-5.0), (name, way)  # it rests on its lowest corner
    with pytest.raises(ParameterError, match="orientation 'sideways'"):
        design_solids(BUILTIN_DESIGNS["cube"], "sideways")


def test_a_leaning_unit_leans_by_its_tilt():
    d = BUILTIN_DESIGNS["cube"]
    c = np.concatenate(corners(design_solids(d, tilt_deg=10.0, tilt_bearing_deg=90.0)))
    top = c[np.argsort(c[:, 2])[-4:]]  # the top face's corners
    normal = np.cross(top[1] - top[0], top[2] - top[0])
    tilt = math.degrees(math.acos(abs(normal[2]) / np.linalg.norm(normal)))
    assert tilt == pytest.approx(10.0, abs=1e-6)
    assert c[:, 2].min() == pytest.approx(0.0)


def test_the_top_tilt_of_a_plane_within_its_two_sigma():
    errs = []
    for seed in range(20):
        rng = np.random.default_rng(seed)
        xy = rng.uniform(-1.0, 1.0, (300, 2))
        z = -15.0 + math.tan(math.radians(6.0)) * xy[:, 1] + rng.normal(0, 0.03, 300)
        tilt, sigma, note = top_tilt(np.column_stack([xy, z]), 0.03)
        assert note == ""
        errs.append(abs(tilt - 6.0) <= 2 * sigma)
    assert np.mean(errs) >= 0.85
    tilt, sigma, note = top_tilt(np.array([[0.0, 0.0, 1.0]] * 5), 0.03)
    assert math.isnan(tilt) and "too few" in note


@pytest.fixture(scope="module")
def turned_field():
    return simulate("reef-field", seed=2, groups="mixed", per_group=8, overturned=3, tilt_max_deg=10.0,
                    close_pairs=0, boulders=0, debris=0)


def test_the_simulator_says_how_each_unit_rests(turned_field):
    reefs = turned_field.truth["reefs"]
    turned = [r for r in reefs if r["overturned"]]
    assert len(turned) == 3 and all(r["orientation"] != "upright" for r in turned)
    assert all(0.0 <= r["top_tilt_deg"] <= 10.0 for r in reefs)
    # a cross1 on its side stands on a bar's end: 3 m, not 1.2 m
    side = [r for r in turned if r["kind"] == "cross1"]
    assert all(r["height"] > 2.5 for r in side)


def test_overturned_units_are_found_and_flagged_and_upright_ones_are_not(turned_field):
    res = extract_reefs(turned_field.cloud, design="cross2,cross1,hollow,triangle")
    for t in turned_field.truth["reefs"]:
        f = min(res.reefs, key=lambda r: math.hypot(r.x - t["x"], r.y - t["y"]))
        assert math.hypot(f.x - t["x"], f.y - t["y"]) < 1.5, t["id"]
        assert f.overturned is t["overturned"], (t["id"], t["kind"], t["orientation"], f.resting)
        if t["overturned"]:
            assert f.resting != "upright" and f.design
        else:
            assert abs(f.top_tilt_deg - t["top_tilt_deg"]) <= 3 * f.top_tilt_sigma_deg + 0.2, t["id"]
    row = res.reefs[0].to_dict()
    assert {"top_tilt_deg", "top_tilt_sigma_deg", "resting", "overturned", "resting_note"} <= set(row)


@pytest.mark.parametrize("seed", [3, 5])
def test_told_the_beam_units_on_their_side_are_found_and_upright_ones_not_flagged(seed):
    # through 1 deg cones (the study's mixed field) the bloom's soundings, heard on a unit
    # beyond its edge, stood where every orientation of the design puts the seabed: on seed 5
    # a cross on its side and a triangle on its other side were set aside or not flagged, and
    # an upright cross was flagged overturned; once the bloom is off they are not compared.
    # On seed 3 a cross on its side, which no upright design fits, was joined by design with
    # an upside-down cross 4.7 m away that the joint fit did not hold
    sim = simulate("reef-field", seed=seed, groups="mixed", overturned=6, tilt_max_deg=12.0,
                   sonar="shallow-beam",
                   per_group=16, close_pairs=0, rocks=4)
    res = extract_reefs(sim.cloud, design="cross2,cross1,hollow,triangle", beam_correction=True,
                        beam_width_deg=1.0)
    missed = 0
    for t in sim.truth["reefs"]:
        f = min(res.reefs, key=lambda r: math.hypot(r.x - t["x"], r.y - t["y"]))
        found = math.hypot(f.x - t["x"], f.y - t["y"]) < 1.5
        if t["overturned"]:
            assert found and f.overturned is True, (t["id"], t["kind"], t["orientation"], f.resting)
        else:
            missed += not found
            assert not found or f.overturned is not True, (t["id"], t["kind"], f.resting)
    assert missed <= 1  # seed 3: an upright triangle among 16 units is still lost to the beam


@pytest.mark.parametrize("seed", [1, 7])
def test_through_the_beam_an_upright_double_cross_is_not_taken_for_one_upside_down(seed):
    # a double-layer cross upright (its top bars 0.6 m wide) and upside down (0.8 m) differ
    # only by 0.1-0.2 m at the bars' edges: through 1 deg cones at 18 m the top bars heard
    # 0.16 m wider fitted the design upside down better, unless each orientation is compared
    # as the beam hears it (on these seeds one upright unit in 16 was flagged before)
    sim = simulate("reef-field", seed=seed, groups="cross2", per_group=16, close_pairs=0, boulders=0,
                   debris=0, beam_across_deg=1.0)
    res = extract_reefs(sim.cloud, design="cross2", beam_correction=True, beam_width_deg=1.0)
    assert len(res.reefs) == 16
    assert [r.resting for r in res.reefs if r.overturned] == []
    # where half the cells that tell them apart side with upside down, it is left undecided
    untold = [r for r in res.reefs if r.overturned is None]
    assert len(untold) <= 1 and all("cannot be told apart" in r.resting_note for r in untold)


def test_a_cube_cannot_tell_its_orientation():
    sim = simulate("reef-field", seed=1, groups="cube", per_group=2, tilt_max_deg=5.0, close_pairs=0,
                   boulders=0, debris=0)
    res = extract_reefs(sim.cloud, design="cube")
    assert len(res.reefs) == 2
    for r in res.reefs:
        assert r.overturned is None and "cannot be told" in r.resting_note


def test_units_injected_on_their_side_into_a_real_file_are_flagged():
    """The EM3000 line (.mb56, 4.5 m of water): a cross on its side and one upright, both leaning."""
    cloud = read(Path(__file__).parent / "data" / "pdal_mbf_em300raw.mb56")
    cx, cy = np.median(cloud.xyz[:, :2], axis=0)
    units = [InjectedReef(1, cx - 3.0, cy, "cross1", 20.0, orientation="on its side", tilt_deg=4.0),
             InjectedReef(2, cx + 3.0, cy, "cross1", 60.0, tilt_deg=5.0, tilt_bearing_deg=200.0)]
    inj = inject(cloud.xyz, cloud.fields, reefs=units)
    res = extract_reefs(PointCloud(inj.xyz, dict(cloud.fields)), design="cross1,cross2,hollow,triangle")
    got = {}
    for t in inj.truth["reefs"]:
        f = min(res.reefs, key=lambda r: math.hypot(r.x - t["x"], r.y - t["y"]))
        assert math.hypot(f.x - t["x"], f.y - t["y"]) < 1.5
        got[t["id"]] = f.overturned
    assert got == {1: True, 2: False}


def test_an_injection_file_names_a_bad_orientation(tmp_path):
    p = tmp_path / "reefs.csv"
    p.write_text("id,x,y,kind,orientation,tilt_deg\n1,0,0,cross1,on its side,5\n2,9,0,cross1,sideways,0\n")
    with pytest.raises(InputError, match=r"line 3, column orientation: 'sideways'; expected one of upright"):
        read_reef_file(p)
    p.write_text("id,x,y,kind,tilt_deg\n1,0,0,cross1,75\n")
    with pytest.raises(InputError, match=r"line 2, column tilt_deg: '75'; expected a lean from 0 to 60"):
        read_reef_file(p)


def test_the_cli_reports_overturned_units_in_tiles_as_in_memory(turned_field, tmp_path, capsys):
    field = tmp_path / "field.laz"
    write(PointCloud(turned_field.cloud.xyz, turned_field.cloud.fields, crs="EPSG:32650"), field)
    outs = {}
    for tiled in (False, True):
        out = tmp_path / f"out{tiled}"
        argv = ["reefs", str(field), "--design", "cross2,cross1,hollow,triangle", "--out", str(out)]
        assert main(argv + (["--tiled", "--tile-size", "110", "--workers", "1"] if tiled else [])) == 0
        printed = capsys.readouterr().out
        assert "3 overturned:" in printed
        d = json.loads((out / "reefs.json").read_text())
        outs[tiled] = sorted((round(r["x"], 1), r["overturned"]) for r in d["reefs"])
        assert "How the units rest (3 overturned)" in (out / "report.html").read_text()
        assert "resting" in (out / "reefs.csv").read_text().splitlines()[0]
    assert outs[True] == outs[False]


def test_rest_of_without_designs_gives_the_tilt_alone():
    rng = np.random.default_rng(0)
    xy = rng.uniform(-1.0, 1.0, (400, 2))
    h = np.where(np.abs(xy).max(axis=1) < 0.8, 1.0 + 0.05 * xy[:, 0], 0.0) + rng.normal(0, 0.01, 400)
    own = h > 0.5
    rest = rest_of(np.column_stack([xy, h - 10.0]), h, own, (), noise=0.01)
    assert rest.design == "" and rest.overturned is None
    assert rest.top_tilt_deg == pytest.approx(math.degrees(math.atan(0.05)), abs=0.5)


def test_through_the_beam_a_double_cross_upside_down_in_an_ascii_export_is_flagged(tmp_path):
    """The R2Sonic XTF with four units injected through 1 deg cones, written as three columns
    (pings and transducers then estimated from the soundings' order): spread by the cone, an
    upright double cross's top bars are the width of its lower ones, and the upside-down unit
    beat upright by 0.095 m, under the 0.10 m margin, until the margin followed how far the
    two spread surfaces lie apart."""
    from mbinspect.beam import Beam

    cloud = read(Path(__file__).parent / "data" / "R2Testing_0009.xtf")
    x0, y0 = 554824.64, 4179011.24  # the flat sand in the swath's middle
    units = [InjectedReef(1, x0 - 4.0, y0 - 4.0, "cross2", 20.0),
             InjectedReef(2, x0 + 4.0, y0 - 4.0, "cross1", 40.0, orientation="on its side"),
             InjectedReef(3, x0 - 4.0, y0 + 4.0, "cross2", 60.0, orientation="upside down"),
             InjectedReef(4, x0 + 4.0, y0 + 4.0, "hollow", 80.0)]
    inj = inject(cloud.xyz, cloud.fields, reefs=units, beam=Beam(beam_across_deg=1.0))
    write(PointCloud(inj.xyz, {}, crs=cloud.crs), tmp_path / "inj.xyz")
    bare = read(tmp_path / "inj.xyz", crs=cloud.crs)
    res = extract_reefs(bare, design="cross2,cross1,hollow,triangle", beam_correction=True,
                        beam_width_deg=1.0)
    got = {}
    for t in inj.truth["reefs"]:
        f = min(res.reefs, key=lambda r: math.hypot(r.x - t["x"], r.y - t["y"]))
        assert math.hypot(f.x - t["x"], f.y - t["y"]) < 1.5
        got[t["id"]] = (f.design, f.resting)
    assert got == {1: ("cross2", "upright"), 2: ("cross1", "on its side"),
                   3: ("cross2", "upside down"), 4: ("hollow", "upright")}


def test_a_unit_its_design_fit_found_on_its_side_stays_so_unless_the_free_form_fits_better():
    """A unit its upright design fit does not hold is compared again from its free-form
    measures at each design's own size; where that cannot tell, the orientation found at the
    design fit's pose and size is kept when it is overturned and fits better (through 1 deg
    cones double crosses on their side were lost among the rocks)."""
    from mbinspect.reefs.single import _free_rest

    designs = [BUILTIN_DESIGNS["cross2"]]
    free = Reef(0, 0.0, 0.0, -20.0, -18.0, 2.0, 8.0, 3.0, 3.0, 0.0, 10.0, 18.0, 200)
    posed = replace(free, design="cross2", resting="on its side", overturned=True, resting_misfit=0.41)
    upright = replace(free, resting="upright", overturned=False, resting_misfit=0.61)
    assert _free_rest(posed, free, lambda r: upright, designs) is upright  # it could tell
    untold = replace(upright, resting="", overturned=None)
    kept = _free_rest(posed, free, lambda r: untold, designs)
    assert (kept.resting, kept.overturned, kept.design) == ("on its side", True, "cross2")
    assert kept.resting_misfit == 0.41
    assert kept.area == free.area  # the free-form measures, not the upright design's outline
    better = replace(untold, resting_misfit=0.30)
    assert _free_rest(posed, free, lambda r: better, designs) is better
    # an overturned misfit beyond OVERTURNED_FIT of the height is no unit of the design
    loose = replace(posed, resting_misfit=0.9)
    assert _free_rest(loose, free, lambda r: untold, designs) is untold


def test_through_the_beam_a_double_cross_the_soundings_cannot_tell_is_left_undecided(tmp_path, capsys):
    """Nine double crosses at 17 m through 1 deg cones, four overturned: spread 0.2 m by the
    cone, an upside-down unit's 0.8 m top bars and an upright one's 0.6 m bars look alike;
    unit 6 (upside down, leaning 8.6 deg) was read upright, though 64 % of the cells where the
    two differ sided with upside down. It is now undecided, with the reason; no upright unit
    is flagged."""
    sim = simulate("reef-field", seed=2, groups="cross2", per_group=9, overturned=4, tilt_max_deg=12.0,
                   close_pairs=0, boulders=0, debris=0, sonar="shallow-beam")
    res = extract_reefs(sim.cloud, design="cross2,cross1,hollow,triangle", beam_correction=True,
                        beam_width_deg=1.0)
    got = {}
    for t in sim.truth["reefs"]:
        f = min(res.reefs, key=lambda r: math.hypot(r.x - t["x"], r.y - t["y"]))
        assert math.hypot(f.x - t["x"], f.y - t["y"]) < 0.3
        got[t["id"]] = (t["orientation"], f.overturned, f.resting_note)
    assert all(o is False for way, o, _ in got.values() if way == "upright")
    assert got[6][1] is None and "cannot be told apart through the beam" in got[6][2]
    assert [got[i][1] for i in (4, 7, 8)] == [True, True, True]
    # the command line says so, from a LAZ file, in memory and in tiles
    field = tmp_path / "field.laz"
    write(PointCloud(sim.cloud.xyz, sim.cloud.fields, crs="EPSG:32650"), field)
    t6 = next(t for t in sim.truth["reefs"] if t["id"] == 6)
    for tiled in (False, True):
        out = tmp_path / f"out{tiled}"
        argv = ["reefs", str(field), "--design", "cross2,cross1,hollow,triangle", "--beam-correction",
                "--beam-width-deg", "1", "--no-figures", "--out", str(out)]
        assert main(argv + (["--tiled", "--tile-size", "120", "--workers", "1"] if tiled else [])) == 0
        assert "1 whose orientation the beam leaves undecided" in capsys.readouterr().out
        d = json.loads((out / "reefs.json").read_text())
        r6 = min(d["reefs"], key=lambda r: math.hypot(r["x"] - t6["x"], r["y"] - t6["y"]))
        assert r6["overturned"] is None and "cannot be told apart" in r6["resting_note"]
