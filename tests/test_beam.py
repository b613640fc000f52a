"""The beam as a cone: its closed forms, what it does to walls and edges, and its options."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mbinspect.beam import AMPLITUDE, LEADING_EDGE, PHASE, Beam, frame, plane_range
from mbinspect.errors import ParameterError
from mbinspect.simulate import LABELS, simulate
from mbinspect.simulate.beam import cast_cones
from mbinspect.simulate.raycast import targets
from mbinspect.simulate.scene import Pile, Scene, Seabed

MODES = (AMPLITUDE, PHASE, LEADING_EDGE)


def _swath(angles_deg, depth=20.0):
    ang = np.radians(np.asarray(angles_deg, float))
    d = np.column_stack([np.sin(ang), np.zeros_like(ang), -np.cos(ang)])
    across = np.column_stack([np.cos(ang), np.zeros_like(ang), np.sin(ang)])
    point = np.column_stack([depth * np.tan(ang), np.zeros_like(ang), np.full(len(ang), -depth)])
    return np.zeros_like(d), d, across, point, np.tile([0.0, 0.0, 1.0], (len(ang), 1)), depth / np.cos(ang)


@pytest.mark.parametrize("mode", MODES)
def test_closed_form_over_a_plane_is_what_the_sub_rays_detect(mode):
    beam = Beam(beam_across_deg=1.5, beam_along_deg=1.0, sub_rays=7)
    o, d, across, point, up, r0 = _swath([0, 5, 20, 40, 60, 65])
    modes = np.full(len(d), mode)
    cones = cast_cones(beam, [], o, d, across, point, up, modes)
    a, b = frame(d, across)
    closed = plane_range(beam, r0, d, a, b, up, modes)
    np.testing.assert_allclose(cones.range, closed, atol=5e-5)
    np.testing.assert_allclose(cones.plane_range, cones.range)
    if mode == LEADING_EDGE:  # the nearest -3 dB sub-ray: metres early at 65 degrees
        assert (cones.range <= r0 + 1e-9).all() and r0[-1] - cones.range[-1] > 0.3
    else:  # centroid and zero crossing stay within a few mm of the axis's range on a plane
        assert (cones.range >= r0).all() and (cones.range - r0).max() < 0.005


def _wall_beam(mode, distance=20.0, radius=0.75):
    """One beam 10 degrees down onto the middle of a pile's wall ``distance`` m away."""
    dip = math.radians(10.0)
    scene = Scene(Seabed(z0=-30.0), piles=(Pile(distance, 0.0, -15.0, radius, bottom_z=-30.0),))
    d = np.array([[math.cos(dip), 0.0, -math.sin(dip)]])
    o = np.array([[0.0, 0.0, -17.0 + (distance - radius) * math.tan(dip)]])
    across = np.array([[-math.sin(dip), 0.0, -math.cos(dip)]])
    cones = cast_cones(Beam(beam_across_deg=1.0, sub_rays=7), targets(scene), o, d, across,
                       o + 40 * d, np.array([[0.0, 0.0, 1.0]]), np.array([mode]))
    return cones, (distance - radius) / math.cos(dip)


def test_a_pile_wall_through_a_beam_moves_its_soundings_along_the_beam():
    beam = Beam(beam_across_deg=1.0, sub_rays=7)
    _, v, w = beam.grid()
    sv2 = float((w * v * v).sum() / w.sum())
    expected = 0.5 * 20.0**2 * sv2 / 0.75  # the circle's curvature across the cone, at normal incidence
    for mode in (AMPLITUDE, PHASE):  # both read the curved wall behind its face (inside the steel)
        cones, r0 = _wall_beam(mode)
        assert cones.label[0] == LABELS["pile"]
        assert 0.6 * expected < cones.range[0] - r0 < 1.4 * expected
    cones, r0 = _wall_beam(LEADING_EDGE)  # the first echo comes from in front of the axis's hit
    assert cones.range[0] < r0 - 0.005


def test_a_cone_that_grazes_a_pile_top_reports_the_top_beside_the_pile():
    scene = Scene(Seabed(z0=-20.0), piles=(Pile(0.0, 0.0, -17.5, 0.75, bottom_z=-20.0),))
    # nadir beams whose axes pass 5 cm and 25 cm outside the top's edge
    x = np.array([0.80, 1.00])
    o = np.column_stack([x, np.zeros(2), np.zeros(2)])
    d = np.tile([0.0, 0.0, -1.0], (2, 1))
    across = np.tile([1.0, 0.0, 0.0], (2, 1))
    point = np.column_stack([x, np.zeros(2), np.full(2, -20.0)])
    for mode in (AMPLITUDE, PHASE):
        cones = cast_cones(Beam(beam_across_deg=1.0, sub_rays=7), targets(scene), o, d, across, point,
                           np.tile([0.0, 0.0, 1.0], (2, 1)), np.full(2, mode))
        # the axes meet the seabed at 20 m, yet the steel's echo wins: the soundings float
        # beside the pile near its top (the "wings" of a real survey)
        assert (cones.label == LABELS["pile"]).all()
        assert (np.abs(cones.range - 17.5) < 0.1).all()


def test_a_survey_with_beams_blooms_beside_the_walls_and_keeps_its_seed():
    kw = {"seed": 3, "ping_spacing": 0.6, "noise_scale": 0.0}
    thin = simulate("jacket", **kw)
    wide = simulate("jacket", beam_across_deg=1.0, **kw)
    again = simulate("jacket", beam_across_deg=1.0, **kw)
    np.testing.assert_array_equal(wide.cloud.xyz, again.cloud.xyz)

    def outside(sim):  # soundings 0.15-2.5 m out from a wall, above the seabed
        n = 0
        for p in sim.truth["piles"]:
            q = sim.cloud.xyz - [p["x"], p["y"], 0.0]
            r = np.hypot(q[:, 0], q[:, 1])
            n += int(((r > p["radius"] + 0.15) & (r < p["radius"] + 2.5)
                      & (q[:, 2] < p["z"]) & (q[:, 2] > p["seabed_z"] + 0.3)).sum())
        return n

    assert outside(thin) == 0 and outside(wide) > 20
    # the seabed far from objects moves by the closed form only: millimetres
    sea = (thin.labels == LABELS["seabed"])
    assert abs(float(np.median(wide.cloud.xyz[wide.labels == LABELS["seabed"], 2]))
               - float(np.median(thin.cloud.xyz[sea, 2]))) < 0.005


@pytest.mark.parametrize(("field", "value"), [("sub_rays", 4), ("sub_rays", 1), ("beam_across_deg", -1.0),
                                              ("beam_along_deg", 12.0), ("detection", "peak")])
def test_bad_beam_options_are_named(field, value):
    with pytest.raises(ParameterError, match=field):
        Beam(**{field: value})
