"""Reef designs: geometry, files, and the pose-and-size fit against known truth."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from mbinspect.errors import InputError, ParameterError
from mbinspect.geometry import polygon_area
from mbinspect.reef_designs import (
    BUILTIN_DESIGNS,
    DesignBox,
    Grow,
    ReefDesign,
    box_distances,
    parse_designs,
    read_design,
)
from mbinspect.reefs.pose import fit_design
from mbinspect.simulate import Reef, Seabed, reef_boxes, reef_truth


@pytest.mark.parametrize("name", sorted(BUILTIN_DESIGNS))
def test_area_and_outline_match_the_simulators_truth(name):
    d = BUILTIN_DESIGNS[name]
    reef = Reef(1, name, 0.0, 0.0, 30.0, reef_boxes(name, 0.0, 0.0, 30.0, -10.0))
    truth = reef_truth(reef, Seabed(z0=-10.0, roughness=0.0), (0.0, 0.0), cell=0.01)
    assert d.area == pytest.approx(truth["area"], rel=0.01)
    assert np.hypot(*(d.centroid - [truth["x"], truth["y"]])) < 0.01
    if name.startswith("cross"):  # the outline is the outer boundary: the hollow and triangle enclose a hole
        assert abs(polygon_area(d.outline(0.0, 0.0, 30.0))) == pytest.approx(d.area, rel=0.01)
    assert d.height == pytest.approx(max(b.z0 + b.height for b in reef.boxes) + 10.0)


def test_signed_distance_of_one_box():
    d = ReefDesign("slab", (DesignBox(0, 0, 0, 4.0, 2.0, 1.0, 90.0),))  # 4 m east-west, 2 m north-south
    pts = np.array([[0.0, 0.0], [3.0, 0.0], [0.0, 1.5], [3.0, 2.0], [1.9, 0.0]])
    assert d.signed_distance(pts, 0.0, 0.0, 0.0) == pytest.approx([-1.0, 1.0, 0.5, math.sqrt(2), -0.1])
    # turned 90 degrees it runs north-south; doubled in size
    assert d.signed_distance(np.array([[0.0, 3.0]]), 0.0, 0.0, 90.0, 2.0)[0] == pytest.approx(-1.0)


@pytest.mark.parametrize("name,scale", [("cross1", 1.0), ("cross2", 1.07), ("hollow", 0.95),
                                        ("triangle", 1.0)])
def test_fit_recovers_pose_and_size_from_inside_and_outside_soundings(name, scale):
    d = BUILTIN_DESIGNS[name]
    rng = np.random.default_rng(7)
    pts = rng.uniform(-3.2, 3.2, (3000, 2)) + [100.0, 200.0]
    x, y, b = 100.3, 199.8, 17.0
    inside = d.signed_distance(pts, x, y, b, scale) < 0
    f = fit_design(pts, inside, ~inside, d, x0=100.0, y0=200.0)
    assert np.hypot(f.x - x, f.y - y) < 0.03  # the built-in designs' centroid is their origin
    period = 360.0 / d.symmetry
    err = (f.bearing_deg - b) % period
    assert min(err, period - err) < 1.0
    assert f.scale == pytest.approx(scale, abs=0.01)
    assert f.area == pytest.approx(d.area * scale**2, rel=0.02)
    assert f.misfit < 0.02


def test_side_wall_soundings_pin_the_edge_where_no_seabed_is_seen():
    # soundings on the reef only (as if the seabed around were in shadow), some on the walls:
    # the fit must not drift outward, and heights tell a side wall from a top
    d = BUILTIN_DESIGNS["cross1"]
    rng = np.random.default_rng(3)
    top = rng.uniform(-1.6, 1.6, (1500, 2))
    top = top[d.signed_distance(top, 0.0, 0.0, 0.0) < -0.02]
    t = rng.uniform(-1.5, 1.5, 400)
    side = rng.integers(0, 2, 400) * 2 - 1
    walls = np.concatenate([np.column_stack([t, side * 0.4]), np.column_stack([side * 0.4, t])])
    walls = walls[np.abs(d.signed_distance(walls, 0.0, 0.0, 0.0)) < 1e-9]
    ground = rng.uniform(-3, 3, (300, 2))
    ground = ground[d.signed_distance(ground, 0.0, 0.0, 0.0) > 1.0]  # far: no help near the edges
    pts = np.vstack([top, walls, ground])
    h = np.concatenate([np.full(len(top), 1.1), rng.uniform(0.2, 0.8, len(walls)), np.zeros(len(ground))])
    inside = np.arange(len(pts)) < len(top) + len(walls)
    f = fit_design(pts, inside, ~inside, d, x0=0.1, y0=-0.1, height=h)
    assert f.scale == pytest.approx(1.0, abs=0.01)
    assert np.hypot(f.x, f.y) < 0.02


def test_design_files_and_names(tmp_path):
    path = tmp_path / "cube.json"
    path.write_text(json.dumps({"name": "cube3", "symmetry": 4,
                                "boxes": [{"length": 3, "width": 3, "height": 3}]}))
    d = read_design(path)
    assert (d.name, d.symmetry, d.area) == ("cube3", 4, pytest.approx(9.0, rel=0.01))
    assert [x.name for x in parse_designs(f"cross2, {path}")] == ["cross2", "cube3"]
    assert parse_designs(None) == ()
    with pytest.raises(ParameterError, match="design: 'cross3'; expected a built-in design"):
        parse_designs("cross3")
    bad = tmp_path / "bad.json"
    bad.write_text('{"boxes": [{"length": 3, "width": -1, "height": 1}]}')
    with pytest.raises(InputError, match=r"bad.json: design 'bad', box 1: .* must be > 0"):
        read_design(bad)
    bad.write_text('{"boxes": [{"length": 3}]}')
    with pytest.raises(InputError, match=r"bad.json: box 1: expected numbers length, width, height"):
        read_design(bad)
    bad.write_text("not json")
    with pytest.raises(InputError, match="not a JSON design file"):
        read_design(bad)


def test_hollow_square_has_its_hole_and_its_outer_walls():
    d = BUILTIN_DESIGNS["hollow"]
    # the centre lies in the hole, 1.2 m from the inner faces; a corner of the 3 x 3 m square
    # lies on the outer edge whatever the bearing
    assert d.signed_distance(np.array([[7.0, 8.0]]), 7.0, 8.0, 25.0)[0] == pytest.approx(1.2)
    corner = np.array([7.0, 8.0]) + 1.5 * math.sqrt(2) * np.array([math.sin(math.radians(70.0)),
                                                                  math.cos(math.radians(70.0))])
    assert d.signed_distance(corner[None], 7.0, 8.0, 25.0)[0] == pytest.approx(0.0, abs=1e-9)


def test_a_design_fitted_as_the_beam_heard_it_keeps_its_size_and_place():
    # soundings as a wide beam hears them: the reef reaches past every edge by the bloom, farther
    # along the track (x) than across it and farther on the side away from each sounding's sonar
    # (half of them heard from the north, half from the south)
    d = BUILTIN_DESIGNS["cross2"]
    rng = np.random.default_rng(11)
    pts = rng.uniform(-3.5, 3.5, (5000, 2)) + [50.0, -20.0]
    x, y, b = 50.2, -19.9, 28.0
    reaches = np.array([0.25, 0.28, 0.3, 0.3, 0.3, 0.15, 0.05, 0.02,
                        0.02, 0.02, 0.05, 0.15, 0.3, 0.3, 0.3, 0.28])
    north = rng.random(len(pts)) < 0.5
    outward = np.where(north[:, None], [0.0, -1.0], [0.0, 1.0])  # away from the sonar across the track
    grow = Grow(reaches, outward, np.ones(len(pts)))
    heard = np.min(box_distances(d, pts, x, y, b, 1.0, grow=grow)[0], axis=1) < 0
    blind = fit_design(pts, heard, ~heard, d, x0=50.0, y0=-20.0)
    told = fit_design(pts, heard, ~heard, d, x0=50.0, y0=-20.0, grow=grow)
    assert blind.scale > 1.08  # fitted as a needle would have drawn it: the bloom taken for concrete
    assert told.scale == pytest.approx(1.0, abs=0.02)
    assert np.hypot(told.x - x, told.y - y) < 0.03
    period = 360.0 / d.symmetry
    err = (told.bearing_deg - b) % period
    assert min(err, period - err) < 1.5


def test_each_sounding_is_grown_from_its_own_side():
    reaches = np.array([0.3, 0.2, 0.1, 0.2])  # away from the sonar, along, toward it, along
    g = Grow(reaches, np.array([[1.0, 0.0], [-1.0, 0.0]]), np.array([1.0, 2.0]))
    east = g(np.array([[1.0, 0.0], [0.0, 1.0]]))
    assert east[0] == pytest.approx([0.3, 0.2])  # the east edge faces away from the first sounding's sonar
    assert east[1] == pytest.approx([0.2, 0.4])  # toward the second's, heard at twice the range
    assert g.subset(np.array([1]))(np.array([[-1.0, 0.0]]))[0, 0] == pytest.approx(0.6)


def test_a_ridge_far_longer_than_a_design_is_not_held_by_it():
    # a ridge 8 m long and 0.6 m wide (a crest, a pipe, a ping's artefact): a cross 2.6 m across
    # can sit with its edges among the ridge's soundings, but the ridge's soundings metres beyond
    # its arms are the fit's worst misfits and count against it; the cross itself still fits
    d = BUILTIN_DESIGNS["cross1"]
    rng = np.random.default_rng(3)
    pts = rng.uniform(-5.0, 5.0, (4000, 2))
    along = np.array([math.cos(math.radians(30.0)), math.sin(math.radians(30.0))])
    u, v = pts @ along, pts @ np.array([-along[1], along[0]])
    ridge = (np.abs(u) < 4.0) & (np.abs(v) < 0.3)
    f = fit_design(pts, ridge, ~ridge, d, x0=0.0, y0=0.0)
    assert f.misfit > 0.2  # more than fit_reef_design's max_misfit: no design
    cross = d.signed_distance(pts, 0.2, -0.1, 40.0, 1.0) < 0
    assert fit_design(pts, cross, ~cross, d, x0=0.0, y0=0.0).misfit < 0.05
