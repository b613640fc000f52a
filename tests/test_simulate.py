"""The simulator's truth itself: geometry, occlusion, noise, backscatter, seeds."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mbinspect.errors import ParameterError
from mbinspect.simulate import LABELS, Box, Reef, Seabed, reef_boxes, reef_truth, simulate


def _pile_frame(sim, pile):
    t, b = math.radians(pile["tilt_deg"]), math.radians(pile["tilt_azimuth_deg"])
    axis = np.array([math.sin(t) * math.sin(b), math.sin(t) * math.cos(b), math.cos(t)])
    m = (sim.labels == LABELS["pile"]) & (sim.ident == pile["id"])
    q = sim.cloud.xyz[m] - [pile["x"], pile["y"], pile["z"]]
    s = q @ axis
    radial = q - np.outer(s, axis)
    return s, np.linalg.norm(radial, axis=1), radial


def test_same_seed_same_survey_other_seed_other_survey():
    a = simulate("jacket", seed=2, ping_spacing=1.0)
    b = simulate("jacket", seed=2, ping_spacing=1.0)
    c = simulate("jacket", seed=3, ping_spacing=1.0)
    np.testing.assert_array_equal(a.cloud.xyz, b.cloud.xyz)
    assert a.truth == b.truth
    assert a.truth["piles"] != c.truth["piles"]


def test_noise_free_soundings_lie_exactly_on_the_surfaces(jacket_exact):
    sim = jacket_exact
    assert sim.truth["counts"]["outlier"] == 0
    sea = sim.labels == LABELS["seabed"]
    local = sim.cloud.xyz[sea] - [*sim.scene.origin, 0.0]
    z = sim.scene.seabed.elevation(local[:, 0], local[:, 1])
    assert np.abs(local[:, 2] - z).max() < 1e-5
    for pile in sim.truth["piles"]:
        s, r, _ = _pile_frame(sim, pile)
        on_cap = np.abs(s) < 1e-6
        assert on_cap.sum() > 20 and (r[on_cap] <= pile["radius"] + 1e-6).all()
        assert np.abs(r[~on_cap] - pile["radius"]).max() < 1e-5
        assert (s <= 1e-6).all()


def test_faces_hidden_from_every_line_get_no_points():
    sim = simulate("jacket", seed=4, lines="west", ping_spacing=0.4, noise_scale=0.0)
    for pile in sim.truth["piles"]:
        s, _, radial = _pile_frame(sim, pile)
        side = s < -0.01
        if pile["id"] in (1, 3):  # the west column: its west faces are seen ...
            assert side.sum() > 30
        assert (radial[side, 0] < 0.05).all()  # ... no east face ever is


def test_pile_points_on_cylinder_within_noise(jacket_small):
    # per-ping position errors are common to a whole ping, so a sparse survey sees them
    # as a bias of a few mm; without them, only unbiased per-beam noise remains.
    per_beam = simulate("jacket", seed=11, ping_spacing=0.3, position_sigma=0.0,
                        vertical_sigma=0.0, attitude_sigma_deg=0.0)
    # (per-beam noise alone: each pile's median within 6 mm, 2-3 standard errors of a median
    # of 200-400 soundings, and their mean within 4 mm; seeds 11-13 gave -4.9..+2.1 mm each,
    # means -3.1..-0.7 mm)
    for sim, bias, mean_bias in ((jacket_small, 0.012, 0.012), (per_beam, 0.006, 0.004)):
        medians = []
        for pile in sim.truth["piles"]:
            s, r, _ = _pile_frame(sim, pile)
            side = s < -0.2
            resid = r[side] - pile["radius"]
            medians.append(np.median(resid))
            assert abs(medians[-1]) < bias
            assert 0.01 < resid.std() < 0.05
        assert abs(np.mean(medians)) < mean_bias
    sim = jacket_small
    for pile in sim.truth["piles"]:
        s, r, _ = _pile_frame(sim, pile)
        top = np.abs(s) < 0.1
        assert top.sum() > 50


def test_noise_grows_with_beam_angle(jacket_small):
    sim = jacket_small
    sea = sim.labels == LABELS["seabed"]
    local = sim.cloud.xyz[sea] - [*sim.scene.origin, 0.0]
    resid = local[:, 2] - sim.scene.seabed.elevation(local[:, 0], local[:, 1])
    angle = np.abs(sim.cloud.fields["beam_angle"][sea])
    inner = resid[angle < 15].std()
    outer = resid[angle > 50].std()
    assert outer > 1.25 * inner
    doubled = simulate("jacket", seed=11, ping_spacing=0.6, noise_scale=2.0)
    sea2 = doubled.labels == LABELS["seabed"]
    loc2 = doubled.cloud.xyz[sea2] - [*doubled.scene.origin, 0.0]
    r2 = loc2[:, 2] - doubled.scene.seabed.elevation(loc2[:, 0], loc2[:, 1])
    a2 = np.abs(doubled.cloud.fields["beam_angle"][sea2])
    assert r2[a2 < 15].std() == pytest.approx(2 * inner, rel=0.2)


def test_outliers_and_backscatter(jacket_small):
    sim = jacket_small
    n = len(sim.cloud)
    assert 0.0005 * n < sim.truth["counts"]["outlier"] < 0.003 * n
    inten = sim.cloud.fields["intensity"]
    pile, seabed = sim.labels == LABELS["pile"], sim.labels == LABELS["seabed"]
    assert inten[pile].mean() > inten[seabed].mean() + 8


def test_truth_spacings_match_positions(jacket_small):
    t = jacket_small.truth
    assert len(t["spacings"]) == 6
    sides = sorted(s["distance"] for s in t["spacings"])
    assert sides[:4] == pytest.approx([22] * 4, abs=0.2)
    assert sides[4:] == pytest.approx([22 * math.sqrt(2)] * 2, abs=0.2)
    assert [p["id"] for p in t["design"]] == [1, 2, 3, 4]


def test_reef_truth_measures_known_shapes():
    flat = Seabed(z0=-17.0, roughness=0.0)
    # the minimum-area rectangle of a cross is turned 45 degrees: side (1.5 + 0.4) * sqrt 2
    cases = (("cross1", 2 * 3.0 * 0.8 - 0.8**2, 1.9 * math.sqrt(2)),
             ("hollow", 3.0 * 3.0 - 2.4 * 2.4, 3.0))
    for kind, area, length in cases:
        reef = Reef(1, kind, 0.0, 0.0, 30.0, reef_boxes(kind, 0.0, 0.0, 30.0, -17.1))
        t = reef_truth(reef, flat, (0.0, 0.0))
        assert t["area"] == pytest.approx(area, rel=0.01)
        assert (t["x"], t["y"]) == pytest.approx((0.0, 0.0), abs=0.01)
        assert t["height"] == pytest.approx({"cross1": 1.1, "hollow": 1.4}[kind])
        assert t["length"] == pytest.approx(length, abs=0.01)
    box = Box(0, 0, -17.0, 2.0, 1.0, 1.0, 0.0)
    t = reef_truth(Reef(2, "box", 0, 0, 0, (box,)), flat, (0.0, 0.0))
    assert t["volume"] == pytest.approx(2.0, rel=0.01)
    assert min(t["orientation_deg"], 180 - t["orientation_deg"]) == pytest.approx(0, abs=0.01)


def test_reef_field_has_close_and_touching_pairs(reef_small):
    t = reef_small.truth
    assert len(t["reefs"]) == 50 and len(t["groups"]) == 2
    gaps = sorted(p["gap"] for p in t["close_pairs"])
    assert gaps[0] < 0.01  # a touching pair
    assert sum(0.25 < g < 0.95 for g in gaps) >= 3
    hit = {int(i) for i in np.unique(reef_small.ident[reef_small.labels == LABELS["reef"]])}
    assert hit == {r["id"] for r in t["reefs"]}
    heights = {r["kind"]: r["height"] for r in t["reefs"]}
    assert heights["cross2"] == pytest.approx(1.9, abs=0.15)
    assert heights["cross1"] == pytest.approx(1.1, abs=0.15)


def test_bad_options_are_named():
    with pytest.raises(ParameterError, match="bogus: not an option of the jacket preset"):
        simulate("jacket", bogus=1)
    with pytest.raises(ParameterError, match="preset: 'pier'; expected one of"):
        simulate("pier")
    with pytest.raises(ParameterError, match="lines: 'up'"):
        simulate("jacket", lines="up")
    with pytest.raises(ParameterError, match="radius: 0.0; expected a positive finite number"):
        simulate("jacket", radius=0.0)


def test_lines_given_are_sailed_at_the_speed_given():
    lines = [((512270.0, 3456680.0), (512330.0, 3456680.0))]
    kw = {"seed": 3, "ping_spacing": 0.5, "survey_lines": lines}
    default, same, slow = (simulate("jacket", **kw), simulate("jacket", survey_speed=2.0, **kw),
                           simulate("jacket", survey_speed=1.0, **kw))
    # the lines' own 2 m/s by default; at another speed the same pings meet the vessel's roll,
    # pitch and heave in another phase, so the soundings move, not their number
    assert np.array_equal(default.cloud.xyz, same.cloud.xyz)
    assert len(slow.cloud) == len(default.cloud) and not np.allclose(slow.cloud.xyz, default.cloud.xyz)
    with pytest.raises(ParameterError, match="survey_speed"):
        simulate("jacket", survey_speed=-1.0, **kw)


def test_the_vessel_motion_starts_each_line_at_a_phase_of_its_seed():
    from mbinspect.simulate.sonar import Sonar
    from mbinspect.simulate.survey import _motion_phase

    one, again, other = (_motion_phase(Sonar(), 4, s) for s in (5, 5, 6))
    assert one.shape == (4, 3) and np.array_equal(one, again) and not np.allclose(one, other)
    assert len(np.unique(one[:, 0])) == 4  # each line its own phase
    fixed = _motion_phase(Sonar(motion_phase="fixed"), 2, 5)
    assert fixed.tolist() == [[0.3, 1.1, 0.0]] * 2
    # the phase steers the beams: the same seed's soundings land elsewhere
    a = simulate("jacket", seed=3, ping_spacing=1.0, noise_scale=0.0)
    b = simulate("jacket", seed=3, ping_spacing=1.0, noise_scale=0.0, motion_phase="fixed")
    assert len(a.cloud) != len(b.cloud) or not np.allclose(a.cloud.xyz, b.cloud.xyz)
