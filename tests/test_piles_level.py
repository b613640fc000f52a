"""Pile tops at their level (issue 30): each top's level with the lines' offsets fitted out,
its 1-sigma, the level differences within a jacket, the design's tops and the shims."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from mbinspect.errors import InputError
from mbinspect.piles import PileFit, PileResult, locate_piles, read_design
from mbinspect.piles.frame import leg_shims
from mbinspect.piles.level import adjust_levels, pile_levels


def _pile(pid: int, z: float, rows: list[tuple[int, float]], sigma: float = 0.003) -> PileFit:
    return PileFit(pid, 10.0 * pid, 0.0, z, 0.75, None, None, "intersection", 80, 200, 360.0, 0.01, 0.003,
                   top_lines=tuple({"line": ln, "offset": o, "n": 80, "sigma": sigma} for ln, o in rows))


def test_line_offsets_are_fitted_out_of_the_level_differences() -> None:
    rng = np.random.default_rng(4)
    true_top = {1: -16.00, 2: -16.03, 3: -15.98}
    z_fit = {1: -16.01, 2: -16.02, 3: -15.99}  # what each pile's plane said at its centre
    line_dz = {1: 0.05, 2: -0.04, 3: 0.02, 4: -0.03}
    piles = []
    for pid in (1, 2, 3):
        rows = [(ln, true_top[pid] + dz - z_fit[pid] + rng.normal(0, 0.002)) for ln, dz in line_dz.items()
                if not (pid == 3 and ln == 1)]
        piles.append(_pile(pid, z_fit[pid], rows))
    lv = adjust_levels(piles)
    for a, b in ((1, 2), (1, 3), (2, 3)):
        diff = lv.top_z[b] - lv.top_z[a]
        assert abs(diff - (true_top[b] - true_top[a])) < 3 * lv.relative[(a, b)] + 1e-4
        assert lv.relative[(a, b)] < 0.01
    # the absolute level keeps the lines' unknown mean offset (here 0): its sigma shows their spread
    mean_dz = float(np.mean(list(line_dz.values())))
    for pid in (1, 2, 3):
        assert abs(lv.top_z[pid] - (true_top[pid] + mean_dz)) < 0.01
        assert lv.sigma[pid] > lv.relative[(1, 2)] / 2 and lv.sigma[pid] > 0.015
    assert not lv.notes and not lv.lower_bound


def test_a_top_read_by_one_line_has_no_known_sigma_and_an_unsounded_top_is_a_lower_bound() -> None:
    lv = adjust_levels([_pile(1, -16.0, [(7, 0.01)]), _pile(2, -16.2, [])])
    assert math.isnan(lv.sigma[1]) and "one line" in lv.notes[0]
    assert lv.lower_bound == {2} and lv.top_z[2] == -16.2 and "lower bound" in lv.notes[-1]
    piles, levels, _ = pile_levels([_pile(1, -16.0, [(7, 0.01)]), _pile(2, -16.2, [])], {1: -16.0, 2: -16.0},
                                   tolerance=0.02)
    assert piles[1].top_z_lower_bound and piles[1].top_verdict == "undecided"  # at least -16.2: could be -16
    assert levels[0].lower_bound and levels[0].verdict == "undecided"


def test_design_tops_give_deviations_verdicts_and_shims() -> None:
    rows = [(1, 0.002), (2, -0.002), (3, 0.0)]  # lines that agree: a level known to a few mm
    piles = [_pile(1, -16.00, rows), _pile(2, -16.05, rows), _pile(3, -16.01, rows)]
    out, levels, _ = pile_levels(piles, {1: -16.0, 2: -16.0, 3: -16.0}, tolerance=0.02)
    verdicts = {p.id: p.top_verdict for p in out}
    assert verdicts[2] == "fail" and abs(out[1].top_deviation + 0.05) < 1e-9
    assert {(lv.a, lv.b): lv.verdict for lv in levels}[(1, 2)] == "fail"
    shims = leg_shims(out, levels)
    assert shims[1] == (0.0, 0.0) and abs(shims[2][0] - 0.05) < 1e-9 and shims[2][1] > 0


def test_jacket_levels_against_truth_and_a_top_no_beam_reached(jacket_small) -> None:
    sim = jacket_small
    truth = {t["id"]: t for t in sim.truth["piles"]}
    # no beam reaches pile 1's top: its soundings above 15 cm under the top are taken away
    t1 = truth[1]
    pts = sim.cloud.xyz
    hidden = (np.hypot(pts[:, 0] - t1["x"], pts[:, 1] - t1["y"]) < 1.0) & (pts[:, 2] > t1["z"] - 0.15)
    cloud = sim.cloud.subset(np.flatnonzero(~hidden))
    r = locate_piles(cloud, count=4, radius=0.75)
    by_truth = {min(truth, key=lambda k: math.hypot(truth[k]["x"] - p.x, truth[k]["y"] - p.y)): p
                for p in r.piles}
    low = by_truth[1]
    assert low.top_z_lower_bound and low.top_z < t1["z"] and not low.top_lines
    sounded = [2, 3, 4]
    for k in sounded:
        p = by_truth[k]
        assert not p.top_z_lower_bound and len(p.top_lines) >= 3
        assert abs(p.top_z - truth[k]["z"]) < max(3 * p.top_z_sigma, 0.01)
    pairs = {(v.a, v.b): v for v in r.levels}
    for a in sounded:
        for b in sounded:
            pa, pb = by_truth[a], by_truth[b]
            if pa.id < pb.id:
                v = pairs[(pa.id, pb.id)]
                err = v.difference - (truth[b]["z"] - truth[a]["z"])
                assert abs(err) < max(3 * v.sigma, 0.005) and v.sigma < 0.015
    assert all(v.lower_bound == (low.id in (v.a, v.b)) for v in r.levels)
    # and the levels read back
    again = PileResult.from_dict(r.to_dict())
    assert again.to_dict()["levels"] == r.to_dict()["levels"]
    assert again.piles[0].top_lines == r.piles[0].top_lines


def test_design_top_column(tmp_path: Path) -> None:
    f = tmp_path / "design.csv"
    f.write_text("id,x,y,cutoff\n1,0,0,-16.0\n2,22,0,-16.05\n")
    assert read_design(f).tops == {1: -16.0, 2: -16.05}
    f.write_text("id,x,y,top\n1,0,0,-16.0\n2,22,0,high\n")
    with pytest.raises(InputError, match=r"line 3, column 4 \(top\): 'high' is not a number"):
        read_design(f)


def test_why_a_level_is_unknown_is_a_warning_only_where_levels_were_asked_for() -> None:
    from mbinspect.piles import PileOptions
    from mbinspect.piles.relate import relate_piles

    piles = [_pile(1, -16.0, [(3, 0.01)]), _pile(2, -16.1, [(3, 0.02)])]  # one line reads both tops
    covs = {1: np.eye(2) * 1e-6, 2: np.eye(2) * 1e-6}
    plain = relate_piles(piles, covs, PileOptions(radius=0.75), design=None, parameters={}, warnings=[],
                         rejected=[])
    assert not plain.warnings and math.isnan(plain.piles[0].top_z_sigma)
    assert "one line" in plain.piles[0].least["least_depth_note"]
    asked = relate_piles(piles, covs, PileOptions(radius=0.75, min_clearance=10.0), design=None,
                         parameters={}, warnings=[], rejected=[])
    assert any("one line" in w for w in asked.warnings)
    assert {p.least["least_depth_clearance"] for p in asked.piles} == {"undecided"}
