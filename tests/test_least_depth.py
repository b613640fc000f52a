"""Least depths (issue 30): the shoalest depth the soundings support, with its TVU and THU,
the S-44 order met and the clearance verdict, for reefs, other objects and pile tops."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from mbinspect.cli.main import main
from mbinspect.io import PointCloud
from mbinspect.least_depth import clearance, least_depth, s44_order
from mbinspect.reefs import ReefResult, extract_reefs


def _flat_top(n_ping: int = 20, per_ping: int = 20, z: float = -10.0, seed: int = 3
              ) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.linspace(0, 2, per_ping), np.linspace(0, 2, n_ping))
    pts = np.column_stack([x.ravel(), y.ravel(), z + rng.normal(0, 0.01, x.size)])
    return pts, np.repeat(np.arange(n_ping), per_ping)


def test_a_flier_is_left_out_and_a_mast_seen_by_two_pings_is_kept() -> None:
    pts, ping = _flat_top()
    flier = np.vstack([pts, [[1.0, 1.0, -8.0]]])
    ld = least_depth(flier, ping=np.r_[ping, 99])
    assert abs(ld.z + 10.0) < 0.02 and ld.fliers >= 1 and ld.tvu95 < 0.05  # (a noise tail may join it)
    # a mast: one sounding on each of two pings, 0.1 m apart, 1.5 m over the top
    mast = np.vstack([pts, [[1.0, 1.0, -8.5], [1.0, 1.1, -8.51]]])
    ld = least_depth(mast, ping=np.r_[ping, 5, 6], noise=0.01)
    assert abs(ld.z + 8.505) < 0.01 and ld.fliers == 0 and abs(ld.x - 1.0) < 0.01
    # the same two soundings on one ping confirm nothing
    same = least_depth(mast, ping=np.r_[ping, 5, 5], noise=0.01)
    assert abs(same.z + 10.0) < 0.02 and same.fliers >= 2


def test_an_unknown_line_level_leaves_the_tvu_unknown_and_the_order_unmet() -> None:
    pts, ping = _flat_top()
    ld = least_depth(pts, ping=ping, level_sigma=math.nan)
    assert math.isnan(ld.tvu95) and ld.order is None and "one line" in ld.note
    f = ld.fields(min_clearance=9.0)
    assert f["least_depth_clearance"] == "undecided" and abs(f["least_depth"] - 10.0) < 0.02


def test_orders_and_clearance() -> None:
    assert s44_order(10.0, 0.16, 0.9) == "exclusive" and s44_order(10.0, 0.16, 1.5) == "special"
    assert s44_order(40.0, 0.6, 6.0) == "1a" and s44_order(40.0, 1.2, 10.0) == "2"
    assert clearance(10.0, 0.1, 9.5) == "pass" and clearance(10.0, 0.1, 10.05) == "undecided"
    assert clearance(10.0, 0.1, 10.2) == "fail" and clearance(10.0, math.nan, 10.2) == "fail"


def test_reef_least_depths_against_truth_and_a_flier_above_a_reef(reef_small) -> None:
    sim = reef_small
    truth = sim.truth["reefs"]
    r = extract_reefs(sim.cloud, min_clearance=15.0)
    errs = []
    for f in r.reefs:
        t = min(truth, key=lambda t, f=f: math.hypot(t["x"] - f.x, t["y"] - f.y))
        errs.append((-f.least["least_depth"] - t["z_top"], f.least["least_depth_tvu95"]))
        assert f.least["least_depth_clearance"] in ("pass", "undecided", "fail")
    e = np.array(errs)
    assert np.mean(np.abs(e[:, 0]) <= e[:, 1]) >= 0.9  # within the 95 % TVU
    assert np.all(-e[:, 0] <= e[:, 1] + 0.01)  # never deeper than the truth beyond the bound
    # a flier 1 m over the first reef's top: its least depth does not move
    f0 = r.reefs[0]
    xyz = np.vstack([sim.cloud.xyz, [[f0.least["least_depth_x"], f0.least["least_depth_y"], f0.z_top + 1.0]]])
    fields = {k: np.r_[v, v[-1] + 1 if k == "ping" else v[-1]] for k, v in sim.cloud.fields.items()}
    again = extract_reefs(PointCloud(xyz, fields))
    g = min(again.reefs, key=lambda g: math.hypot(g.x - f0.x, g.y - f0.y))
    assert abs(g.least["least_depth"] - f0.least["least_depth"]) < 0.02
    # and the least depths read back
    back = ReefResult.from_dict(r.to_dict())
    assert back.reefs[0].least == r.reefs[0].least


@pytest.mark.slow
def test_pile_tops_clearance_on_a_stated_datum(jacket_small, tmp_path: Path) -> None:
    from mbinspect.io import write

    laz = tmp_path / "j.laz"
    write(jacket_small.cloud, laz)
    out = tmp_path / "o"
    # tops at -16 m: a clearance of 15 m passes, of 17 m fails
    for need, verdict in ((15.0, "pass"), (17.0, "fail")):
        code = main(["piles", str(laz), "--radius", "0.75", "--count", "4", "--datum-offset", "0",
                     "--min-clearance", str(need), "--out", str(out), "--overwrite", "--no-figures"])
        assert code in (0, 3)
        d = json.loads((out / "piles.json").read_text())
        assert all(p["least_depth_clearance"] == verdict for p in d["piles"])
        truth = jacket_small.truth["piles"]
        for p in d["piles"]:
            t = min(truth, key=lambda t, p=p: math.hypot(t["x"] - p["x"], t["y"] - p["y"]))
            high = t["z"] + t["radius"] * math.tan(math.radians(t["tilt_deg"]))
            assert abs(-p["least_depth"] - high) < max(p["least_depth_tvu95"], 0.01)
    assert "Least depths" in (out / "report.html").read_text()
    assert "least_depth_clearance" in (out / "piles.csv").read_text().splitlines()[0]


def test_a_narrow_top_that_one_line_crossed_is_confirmed_by_its_next_ping() -> None:
    """Two lines' pings interleave over a unit (0.1 m apart in all), but over its narrow top
    only one line's pings passed, 0.33 m apart: every top sounding is confirmed by the next
    ping of that line, farther off than the unit's median ping gap. A flier up there is still
    left out."""
    rng = np.random.default_rng(5)
    rows = []
    for k, x in enumerate(np.arange(-1.5, 1.5, 0.1)):  # the unit's flank: pings 0.1 m apart
        y = np.arange(-1.5, 1.5, 0.06)
        y = y[(np.abs(x) > 0.5) | (np.abs(y) > 0.6)]
        rows += [(x, v, -11.0 + rng.normal(0, 0.01), k) for v in y]
    for k, x in enumerate((-0.33, 0.0, 0.33)):  # the top, 0.9 m by 1 m, by one line only
        rows += [(x, v, -10.0 + rng.normal(0, 0.01), 100 + k) for v in np.arange(-0.5, 0.5, 0.06)]
    pts, ping = np.array([r[:3] for r in rows]), np.array([r[3] for r in rows])
    ld = least_depth(pts, ping=ping, noise=0.01)
    assert abs(ld.z + 10.0) < 0.02 and ld.fliers == 0
    flier = least_depth(np.vstack([pts, [[0.1, 0.2, -9.6]]]), ping=np.r_[ping, 7], noise=0.01)
    assert abs(flier.z + 10.0) < 0.02 and flier.fliers == 1
    # told the beam: cones that may have lifted the top's soundings 0.2 m confirm nothing that far
    lifted = least_depth(pts, ping=ping, noise=0.01, lift=np.where(pts[:, 2] > -10.5, 0.2, 0.0))
    assert abs(lifted.z + 11.0) < 0.02
