"""A reef's top level read again for its settlement (issue 29): a tilted top's high edge, its
1-sigma against the error over many draws, and what cannot be read said."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mbinspect.change.tops import BAND_PLACE, ground_level, ground_sigma, sounding_noise, top_level
from mbinspect.reefs.results import Reef

SQUARE = ((-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0))


def _unit(outline=SQUARE) -> Reef:
    return Reef(1, 0.0, 0.0, -11.0, -10.0, 1.0, 4.0, 2.0, 2.0, 0.0, 4.0, 4.0, 600, outline=outline)


def _top(rng: np.random.Generator, tilt_deg: float, n: int = 500, noise: float = 0.02) -> np.ndarray:
    """A 2 m square top at -10 m at its high edge, leaning ``tilt_deg`` down to the east,
    sounded ``n`` times, with the seabed round it."""
    xy = rng.uniform(-1, 1, (n, 2))
    z = -10.0 - math.tan(math.radians(tilt_deg)) * (xy[:, 0] + 1.0) + rng.normal(0, noise, n)
    ground = np.column_stack([rng.uniform(-3, 3, (n, 2)), rng.normal(-11.0, noise, n)])
    ground = ground[np.max(np.abs(ground[:, :2]), axis=1) > 1.05]
    return np.vstack([np.column_stack([xy, z]), ground])


def test_the_top_level_is_its_high_edge_and_its_sigma_covers_the_error():
    rng = np.random.default_rng(3)
    z = []
    for tilt in (0.0, 0.3, 5.0, 10.0):
        for _ in range(40):
            pts = _top(rng, tilt)
            level, sigma, why = top_level(pts, _unit(), noise=0.02)
            assert not why
            z.append((level + 10.0) / sigma)
    z = np.abs(np.array(z))
    # the high edge is found to its 1-sigma: about 95 % within 2 sigma over level and leaning tops
    assert np.mean(z <= 2) >= 0.9, np.mean(z <= 2)


def test_the_soundings_noise_is_measured_and_a_sparse_top_is_said():
    rng = np.random.default_rng(4)
    pts = _top(rng, 0.0, n=4000, noise=0.03)
    assert 0.025 < sounding_noise(pts) < 0.035
    # ten soundings in a row: no cell holds four, no plane holds the top
    line = np.column_stack([np.linspace(-0.9, 0.9, 10), np.zeros(10), np.full(10, -10.0)])
    assert math.isnan(sounding_noise(line))
    level, sigma, why = top_level(line, _unit(), noise=math.nan)
    assert math.isnan(level) and math.isnan(sigma) and "too few soundings" in why
    assert top_level(pts, _unit(outline=()))[2] == "no footprint"


def test_exposed_height_change_is_read_from_the_least_depths() -> None:
    """A unit leaning after: its median top (the pipeline's height) drops 0.2 m, but its
    highest point, which its least depth gives, stays: the height change is the least
    depths' over each survey's seabed, not the median tops'."""
    from dataclasses import replace

    from mbinspect.change.measure import _levels
    from mbinspect.change.register import IDENTITY

    before = replace(_unit(), least={"least_depth": 10.0, "least_depth_tvu95_relative": 0.03})
    after = replace(before, z_top=-10.2, height=0.8,
                    least={"least_depth": 10.01, "least_depth_tvu95_relative": 0.03})
    out = _levels(before, after, IDENTITY, [])
    assert out["height_before"] == pytest.approx(1.0)
    assert out["height_after"] == pytest.approx(0.99)
    assert out["height_change"] == pytest.approx(-0.01)
    assert abs(out["height_change"]) < out["height_change_lod95"]  # no detectable change
    # the tops' levels, where both were read, as the settlement reads them
    tops = ((-10.0, 0.01, "", math.nan, 0.0), (-10.02, 0.01, "", math.nan, 0.0))
    read = _levels(before, after, IDENTITY, [], tops)
    assert read["height_change"] == pytest.approx(-0.02)
    assert read["settlement"] == pytest.approx(0.02)
    # without least depths or tops, the pipeline's heights are what is left
    bare = _levels(replace(before, least={}), replace(after, least={}), IDENTITY, [])
    assert bare["height_change"] == pytest.approx(-0.2)


def test_the_exposed_height_stands_on_the_seabed_round_the_unit_in_a_scour_pit() -> None:
    """A pit scoured round a unit that did not move: the seabed round it drops, and a
    quadratic through the pit's walls would bend on down under the unit. The plane through
    the band just beyond the outline gives the exposed height over the pit round it: up by
    the pit's depth there, not by what the bowl would reach at the centre."""
    from dataclasses import replace

    from mbinspect.change.measure import _levels
    from mbinspect.change.register import IDENTITY

    rng = np.random.default_rng(4)
    xy = rng.uniform(-4, 4, (60_000, 2))
    r = np.hypot(*xy.T)
    pit = 0.4 * np.clip(1 - r / 3.5, 0, 1)  # a cone 0.4 m deep at the centre, 3.5 m wide
    unit = np.abs(xy).max(axis=1) <= 1.0
    level = np.where(unit, -10.0, -11.0 - pit) + rng.normal(0, 0.01, len(r))
    pts = np.column_stack([xy, level])
    round_it = ground_level(pts, _unit())
    # the pit round the unit: no deeper than at its wall (1 m out), no shallower than half a
    # metre beyond its corners, and not the bowl's bottom (0.4 m) under it
    assert -11.0 - 0.4 * (1 - 1.0 / 3.5) < round_it < -11.0 - 0.4 * (1 - 1.45 * math.sqrt(2) / 3.5)
    # the change's exposed heights: the tops over each survey's seabed round the unit
    before = replace(_unit(), least={"least_depth": 10.0, "least_depth_tvu95_relative": 0.03})
    after = replace(before, z_seabed=-11.4)  # the pipeline's seabed, bent into the bowl
    flat = (-10.0, 0.01, "", -11.0, 0.0)
    out = _levels(before, after, IDENTITY, [], (flat, (-10.0, 0.01, "", round_it, 0.0)))
    assert out["height_change"] == pytest.approx(-11.0 - round_it)
    # the pit's wall (0.11 m a metre) across the band: where the band stands moves the level
    # it reads, by the slope over half the band's width, and the change's bound carries it
    wall = ground_sigma(pts, _unit())
    assert 0.8 * 0.114 * BAND_PLACE < wall < 1.2 * 0.114 * BAND_PLACE
    assert ground_sigma(_top(rng, 0.0, n=20_000), _unit()) < 0.003  # a level seabed owes nothing
    bound = _levels(before, after, IDENTITY, [], (flat, (-10.0, 0.01, "", round_it, wall)))
    assert bound["height_change_lod95"] == pytest.approx(math.hypot(0.03, 0.03, 1.96 * wall), rel=0.01)
    # a band with too few soundings round the unit reads nothing, and the pipeline's seabed is used
    assert math.isnan(ground_level(pts[unit], _unit()))
    lone = _levels(before, after, IDENTITY, [], (flat, (-10.0, 0.01, "", math.nan, 0.0)))
    assert lone["height_change"] == pytest.approx(0.4)


def test_told_the_beam_the_seabed_round_a_unit_is_read_beyond_its_bloom() -> None:
    """Through a cone, the seabed just beyond a unit's (unbloomed) outline is heard with the
    unit's wall in it: soundings within the cone's radius of the wall stand high. Told the
    beam (the unit carries its ``beam_footprint``), the band stands half a footprint farther
    out and reads the seabed; thin (no footprint), the band is where it was. In a scour pit
    the moved band's level is carried back down the pit's wall to where the band stood."""
    from dataclasses import replace

    rng = np.random.default_rng(7)
    xy = rng.uniform(-3, 3, (60_000, 2))
    gap = np.abs(xy).max(axis=1) - 1.0  # distance beyond the square's outline (near its sides)
    unit = gap <= 0
    bloom = (gap > 0) & (gap <= 0.3)  # a 0.6 m cone's radius: the wall heard 0.1 m up
    z = np.where(unit, -10.0, -11.0 + 0.1 * bloom) + rng.normal(0, 0.01, len(gap))
    pts = np.column_stack([xy, z])
    thin, told = _unit(), replace(_unit(), beam_footprint=0.6)
    assert ground_level(pts, thin) > -11.0 + 0.03  # the bloom lifts the band's seabed
    assert abs(ground_level(pts, told) + 11.0) < 0.005
    # a pit round the unit, 0.8 m deep at its centre and 3 m in radius: 0.27 m a metre
    r = np.hypot(*xy.T)
    pit = np.where(unit, -10.0, -11.0 - 0.8 * np.clip(1 - r / 3.0, 0, 1)) + rng.normal(0, 0.01, len(r))
    pts = np.column_stack([xy, pit])
    where_thin, moved = ground_level(pts, thin), ground_level(pts, told)
    assert abs(moved - where_thin) < 0.02
    with pytest.MonkeyPatch.context() as mp:  # not carried back: the moved band's own level
        mp.setattr("mbinspect.change.tops.PIT_SLOPE", math.inf)
        assert ground_level(pts, told) - where_thin > 0.06
