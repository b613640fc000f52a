"""The beam's bloom taken off reef footprints (issue 28, item 4): against simulator truth."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mbinspect.beam import Beam
from mbinspect.reefs import extract_reefs
from mbinspect.reefs.beam import reach, structure
from mbinspect.simulate import simulate


def test_reach_follows_the_footprint():
    r = reach(Beam(beam_across_deg=1.0), 20.0, 1.0, 1.5, 20.0, directions=4)
    # at nadir, every edge blooms by about the footprint (20 m x tan 1 deg = 0.35 m)
    assert np.all(np.abs(r - 20 * math.tan(math.radians(1.0))) < 0.06)
    oblique = reach(Beam(beam_across_deg=1.0), 20.0, 0.6, 1.5, 20.0, directions=4)
    assert oblique[2] < 0.05 < oblique[0]  # the near side (a lit wall) hardly blooms; the far side does
    half = reach(Beam(beam_across_deg=0.5), 20.0, 1.0, 1.5, 20.0, directions=4)
    assert np.all(half < 0.6 * r)
    weak = reach(Beam(beam_across_deg=1.0), 20.0, 1.0, 1.5, 3.0, directions=4)
    assert np.all(weak < 0.6 * r)  # a reef hardly brighter than the seabed blooms less


def test_structure_seen_from_both_sides_is_symmetric():
    reaches = np.array([0.3, 0.2, 0.4, 0.2, 0.0, 0.2, 0.4, 0.2])
    one = structure(reaches, (1.0, 0.0), True, 0.05)
    both = structure(reaches, (1.0, 0.0), False, 0.05)
    n = one.shape[0] // 2
    assert one[n, n + 5] and not one[n, n - 5]  # out past the far side only
    assert both[n, n + 5] and both[n, n - 5]


@pytest.fixture(scope="module")
def field():
    sim = simulate("reef-field", seed=3, per_group=4, groups="cube,cross2", beam_across_deg=1.0,
                   close_pairs=0, touching_pairs=0, boulders=0, debris=0)
    truth = sim.truth["reefs"]
    ref = (np.array([[t["x"], t["y"]] for t in truth]), tuple(t["id"] for t in truth))
    return sim, truth, ref


def _area_errors(res, truth):
    ev = res.evaluation
    return ev, np.array([res.reefs[i].area / truth[j]["area"] - 1 for i, j, _ in ev.matches])


def test_told_the_beam_the_footprints_lose_their_bloom(field):
    sim, truth, ref = field
    ev, raw = _area_errors(extract_reefs(sim.cloud, reference=ref), truth)
    ev_told, told = _area_errors(extract_reefs(sim.cloud, reference=ref, beam_correction=True,
                                               beam_width_deg=1.0), truth)
    assert raw.mean() > 0.2  # the bloom: every footprint too large
    assert ev_told.tp == len(truth) and abs(told.mean()) < 0.1
    assert np.mean(np.abs(told) < 0.2) >= 0.75


def test_told_the_beam_rocks_stay_rocks():
    # at 25 m a 1 deg cone is 0.44 m: taking the bloom off a rock leaves a core too thin to
    # show its dome, which passed as a reef (2 of the 10 rocks of this scene before the
    # footprint as heard was judged too)
    # (the vessel's motion at the phase the case was found with; at others a rock of ten can
    # still pass: issue 28)
    sim = simulate("reef-field", seed=1, per_group=4, groups="cube,cross2", seabed=-25.0, rocks=10,
                   beam_across_deg=1.0, close_pairs=0, touching_pairs=0, boulders=0, debris=0,
                   motion_phase="fixed")
    truth = sim.truth["reefs"]
    ref = (np.array([[t["x"], t["y"]] for t in truth]), tuple(t["id"] for t in truth))
    res = extract_reefs(sim.cloud, reference=ref, beam_correction=True, beam_width_deg=1.0)
    rocks = np.array([[d["x"], d["y"]] for d in sim.truth["distractors"] if d["kind"] == "rock"])
    assert res.evaluation.tp == len(truth)
    assert not any(np.hypot(*(rocks - [r.x, r.y]).T).min() < 1.0 for r in res.reefs)
    as_heard = [o for o in res.others if "as heard through the beam" in o.reason]
    assert as_heard and all(np.hypot(*(rocks - [o.x, o.y]).T).min() < 1.0 for o in as_heard)


def test_told_the_beam_debris_stays_small_and_flat_tops_stay_level():
    # through 1 deg cones at 17 m, debris blooms past `min_area` and was kept as reefs once its
    # bloom was taken off (3 of 12 here); outer beams sound a cross's flat top up to 0.4 m high,
    # which lifted its top (0.43 m too tall)
    sim = simulate("reef-field", seed=1, per_group=9, groups="cross1", beam_across_deg=1.0, close_pairs=0,
                   touching_pairs=0, boulders=0, debris=12)
    truth = sim.truth["reefs"]
    ref = (np.array([[t["x"], t["y"]] for t in truth]), tuple(t["id"] for t in truth))
    res = extract_reefs(sim.cloud, reference=ref, beam_correction=True, beam_width_deg=1.0)
    assert res.evaluation.tp == len(truth) and res.evaluation.fp == 0
    debris = np.array([[d["x"], d["y"]] for d in sim.truth["distractors"] if d["kind"] == "debris"])
    small = [o for o in res.others if o.reason.startswith("smaller than `min_area`")
             and np.hypot(*(debris - [o.x, o.y]).T).min() < 1.0]
    assert len(small) >= 8  # the others too low to stand out of the seabed
    errors = np.array([res.reefs[i].height - truth[j]["height"] for i, j, _ in res.evaluation.matches])
    assert np.abs(errors).max() < 0.1


def _rocks_among_cubes_told(seed: int):
    """The study's rocks among cubes at 25 m through 1 deg cones, and the reefs told the beam."""
    sim = simulate("reef-field", seed=seed, groups="cross2,cube,hollow", seabed=-25.0, rocks=20,
                   burial_max=0.5, beam_across_deg=1.0)
    truth = sim.truth["reefs"]
    ref = (np.array([[t["x"], t["y"]] for t in truth]), tuple(t["id"] for t in truth))
    return sim, truth, extract_reefs(sim.cloud, reference=ref, beam_correction=True, beam_width_deg=1.0)


def test_told_the_beam_a_dense_field_at_25_m_is_neither_rough_ground_nor_rocks():
    # the mixed echoes on a cross group's flanks made it "rough terrain" (18 reefs lost), and
    # outer beams sounding flat tops high made 23 cubes, crosses and hollow squares look
    # rounded; 20 rocks must stay rocks
    sim, truth, res = _rocks_among_cubes_told(0)
    assert res.filters["rough_terrain"]["excluded_area"] == 0
    assert res.evaluation.tp >= len(truth) - 1 and res.evaluation.fp <= 1
    rocks = np.array([[d["x"], d["y"]] for d in sim.truth["distractors"] if d["kind"] == "rock"])
    assert not any(np.hypot(*(rocks - [r.x, r.y]).T).min() < 1.0 for r in res.reefs)


def test_reefs_the_bloom_joined_come_apart_once_it_is_off():
    from mbinspect.reefs.single import _apart

    nx = 100
    grid = np.zeros((40, nx), bool)
    grid[5:25, 10:30] = True  # one reef's core
    grid[5:25, 34:54] = True  # its neighbour's, 0.4 m away once the bloom is off
    grid[30:32, 10:14] = True  # a sliver cut off the first
    cells = np.flatnonzero(grid.ravel())
    pieces = _apart(cells, nx, least=100)
    assert len(pieces) == 2 and sum(len(p) for p in pieces) == len(cells)
    assert sorted(len(p) for p in pieces) == [400, 408]  # the sliver goes with the nearer core
    assert len(_apart(cells, nx, least=500)) == 1  # pieces smaller than a reef: one part


def test_reefs_joined_at_a_neck_or_round_two_interiors_come_apart():
    from mbinspect.reefs.single import _apart

    nx = 100
    grid = np.zeros((40, nx), bool)
    grid[5:25, 10:30] = True  # two solid reefs' cores
    grid[5:25, 33:53] = True
    grid[13:16, 30:33] = True  # a neck 0.3 m wide the bloom left between them
    cells = np.flatnonzero(grid.ravel())
    assert len(_apart(cells, nx, least=300)) == 1  # connected: one part without a neck's erosion
    pieces = _apart(cells, nx, least=300, neck=2)
    assert len(pieces) == 2 and sum(len(p) for p in pieces) == len(cells)
    assert all(400 <= len(p) <= 409 for p in pieces)  # the neck's cells go with the nearer core
    # one hollow square (an interior of 1.6 x 1.6 m) with one wall thin: an erosion cuts it
    # into two arcs that enclose nothing; it stays whole
    ring = np.zeros((40, nx), bool)
    ring[2:30, 10:38] = True
    ring[8:24, 16:36] = False
    assert len(_apart(np.flatnonzero(ring.ravel()), nx, least=150, neck=2)) == 1
    # two hollow squares sharing a thick wall: no neck, two interiors of over a square metre
    pair = np.zeros((40, nx), bool)
    pair[2:32, 10:70] = True
    pair[8:26, 16:34] = False
    pair[8:26, 46:64] = False
    pieces = _apart(np.flatnonzero(pair.ravel()), nx, least=300, neck=2, hollow=100)
    assert len(pieces) == 2 and sorted(len(p) for p in pieces) == [576, 576]
    assert len(_apart(np.flatnonzero(pair.ravel()), nx, least=300, neck=2, hollow=400)) == 1


def test_told_the_beam_hollow_squares_heard_as_pairs_come_apart():
    # at 25 m the blooms of neighbouring hollow squares join: on this seed 12 of them were
    # heard as pairs (63 of 75 found); taking the bloom off parted 8 of them again, and the
    # last two pairs (one joined at a neck, one round a shared wall) part at the neck and
    # round their interiors
    _, truth, res = _rocks_among_cubes_told(5)
    assert res.evaluation.tp == len(truth) and res.evaluation.fp <= 1


def test_told_the_beam_without_pings_the_result_says_so(field):
    sim, _, _ = field
    told = {"beam_correction": True, "beam_width_deg": 1.0}
    assert not [w for w in extract_reefs(sim.cloud, **told).warnings if "carry no" in w]
    bare = extract_reefs(sim.cloud.xyz, **told).warnings  # x, y, z alone: an ASCII export
    assert any("carry no ping or beam_angle" in w for w in bare)
    assert not [w for w in extract_reefs(sim.cloud.xyz).warnings if "carry no" in w]
