"""Plan before you sail over a reef plan (issue 31): lines covering the field, trials against
the truth (units found, soundings on each, S-44 cubes), the choice and the command's files."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from mbinspect.cli.main import main
from mbinspect.errors import InputError, ParameterError
from mbinspect.plan import PlanOptions, ReefPlanResult, plan_input, structure_frame
from mbinspect.plan.layouts import PlanLine
from mbinspect.plan.reef_run import coverage_layouts, planned_units
from mbinspect.plan.reef_trial import CLEAR, ReefSetting, _cubes, run_reef_trial
from mbinspect.reefs.plan import ReefPlan, read_plan
from mbinspect.simulate import named_sonar

UNITS = "id,x,y,bearing_deg,kind\nA,500000,4000000,30,cross2\nB,500010,4000000,,cross2\n" \
        "C,500000,4000010,30,cube\nD,500010,4000010,,cross2\n"


def _plan(tmp_path: Path, text: str = UNITS) -> Path:
    path = tmp_path / "units.csv"
    path.write_text(text)
    return path


def _off_line(points: np.ndarray, ln: PlanLine) -> np.ndarray:
    """Each point's distance from the line through ``ln``."""
    (x0, y0), (x1, y1) = ln.start, ln.end
    return np.abs((x1 - x0) * (points[:, 1] - y0) - (y1 - y0) * (points[:, 0] - x0)) / ln.length


def test_the_lines_cover_the_field_turned_any_way_and_more_overlap_brings_them_closer():
    turn = math.radians(30.0)
    rot = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
    xy = np.array([(i * 20.0, j * 12.0) for i in range(6) for j in range(4)]) @ rot.T
    f = structure_frame(xy, radius=2.0)
    width, reach = 40.0, 6.0
    lays = {c.name: c for c in coverage_layouts(f, width=width, overlaps=(0.0, 0.5), reach=reach,
                                                margin=10.0)}
    assert {"along-0%", "across-0%", "along-50%", "across-50%", "grid-0%"} <= set(lays)
    # points over the field and ``reach`` beyond: each within half a spacing of a line
    grid = np.array([f.point(a, b) for a in np.linspace(-f.half_u - reach, f.half_u + reach, 25)
                     for b in np.linspace(-f.half_v - reach, f.half_v + reach, 25)])
    for name, o in (("along-0%", 0.0), ("along-50%", 0.5), ("across-50%", 0.5)):
        lines = lays[name].lines
        d = np.min([_off_line(grid, ln) for ln in lines], axis=0)
        assert d.max() <= width * (1 - o) / 2 + 1e-6, name
    assert len(lays["along-50%"].lines) > len(lays["along-0%"].lines)
    assert len(lays["grid-0%"].lines) == len(lays["along-0%"].lines) + len(lays["across-0%"].lines)
    # a field one swath covers at every overlap: one layout per heading, not one per overlap
    small = structure_frame(np.array([(0.0, 0.0), (8.0, 0.0)]), radius=2.0)
    names = [c.name for c in coverage_layouts(small, width=60.0, overlaps=(0.0, 0.25), reach=6.0,
                                              margin=10.0)]
    assert names == ["along-0%", "across-0%", "grid-0%"]


def test_a_plan_is_told_from_a_pile_design_and_bad_units_are_named(tmp_path):
    opts = PlanOptions(depth=15.0)
    assert plan_input(_plan(tmp_path), opts) == "reefs"
    bare = _plan(tmp_path, "id,x,y\n1,0,0\n2,10,0\n")
    with pytest.raises(ParameterError, match="--radius R .piles. or --kind"):
        plan_input(bare, opts)
    assert plan_input(bare, opts.replace(radius=0.75)) == "piles"
    assert plan_input(bare, opts.replace(kind="cross2")) == "reefs"
    no_kind = _plan(tmp_path, "id,x,y,bearing_deg\n1,0,0,30\n")
    with pytest.raises(ParameterError, match="kind: missing"):
        planned_units(read_plan(no_kind), opts)
    with pytest.raises(InputError, match="unit 1: kind 'pyramid'"):
        planned_units(read_plan(_plan(tmp_path, "id,x,y,kind\n1,0,0,pyramid\n")), opts)
    with pytest.raises(ParameterError, match="overlaps"):
        PlanOptions(depth=15.0, overlaps="0,1.5")
    units = planned_units(read_plan(_plan(tmp_path)), opts)
    assert [u.kind for u in units] == ["cross2", "cross2", "cube", "cross2"]
    assert units[1].bearing_deg is None and units[2].reach == pytest.approx(math.sqrt(2.0))


def test_a_trial_finds_every_unit_counts_its_soundings_and_tries_the_cubes(tmp_path):
    units = planned_units(read_plan(_plan(tmp_path)), PlanOptions(depth=15.0))
    xy = np.array([[u.x, u.y] for u in units])
    f = structure_frame(xy, radius=2.0)
    ox, oy = f.centre
    area = (-25.0, -25.0, 25.0, 25.0)
    setting = ReefSetting(named_sonar("shallow"), 0.25, 2.0, 15.0, f.centre, area, 1.0, 6)
    lays = coverage_layouts(f, width=40.0, overlaps=(0.0,), reach=8.0, margin=10.0)
    trial = run_reef_trial(lays[0], units, setting, 3)
    assert [r[0] for r in trial.units] == ["A", "B", "C", "D"]
    assert all(found and n > 50 for _, found, n, _, _ in trial.units)
    assert all(abs(dh) < 0.1 and dc < 0.3 for _, _, _, dh, dc in trial.units)
    assert len(trial.cubes) == 6 and min(trial.cubes) >= 3
    # the cubes lie in the area, clear of one another
    cubes = np.array(_cubes(setting, np.random.default_rng(0)))
    assert len(cubes) == 6 and np.all((cubes >= -25.0) & (cubes <= 25.0))
    gap = np.hypot(*(cubes[:, None, :] - cubes[None]).transpose(2, 0, 1)) + np.eye(6) * 99
    assert gap.min() > math.sqrt(2.0) + CLEAR
    # a cube far beyond the swath gets no soundings, and the trial says so
    far = ReefSetting(named_sonar("shallow"), 0.25, 2.0, 15.0, f.centre, (200.0, 200.0, 210.0, 210.0), 1.0, 2)
    assert run_reef_trial(lays[0], units, far, 3).cubes == (0, 0)


@pytest.fixture(scope="module")
def reef_planned(tmp_path_factory):
    root = tmp_path_factory.mktemp("reefplan")
    path = _plan(root)
    code = main(["plan", str(path), "--depth", "15", "--sonar", "shallow", "--overlaps", "0", "--seeds", "1",
                 "--workers", "1", "--speed", "6", "--min-soundings", "40", "--s44-order", "special",
                 "--crs", "EPSG:32650", "--out", str(root / "out")])
    return root, code


def test_the_reef_plan_chooses_the_fastest_layout_that_meets_its_targets(reef_planned):
    root, code = reef_planned
    assert code == 0
    doc = json.loads((root / "out" / "plan.json").read_text())
    result = ReefPlanResult.from_dict(doc)
    assert result.to_dict() == doc and doc["kind"] == "reef-plan"
    best = result.best
    assert best is not None and best.meets_target and best.found == 1.0
    assert best.min_soundings >= 40 and best.cubes_detected == 1.0
    assert not any(p.meets_target for p in result.predictions if p.time_on_site_s < best.time_on_site_s)
    assert doc["min_soundings_reached"] == best.min_soundings and len(doc["units"]) == 4
    with open(root / "out" / "lines.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0]) == ["line", "x_start", "y_start", "x_end", "y_end", "heading", "speed_kn"]
    assert len(rows) == len(best.layout.lines)
    units = json.loads((root / "out" / "plan.geojson").read_text())["features"]
    assert [u["properties"]["id"] for u in units] == ["A", "B", "C", "D"]
    assert (root / "out" / "report.html").read_text().count("<table") >= 3
    assert (root / "out" / "plan.png").stat().st_size > 10_000


def test_a_reef_plan_is_not_taken_for_a_pile_plan_by_check(reef_planned, capsys):
    root, _ = reef_planned
    assert main(["plan", str(root / "out"), "--check", str(root / "units.csv"), "--out",
                 str(root / "chk")]) == 2
    err = capsys.readouterr().err
    assert "a plan over a reef plan" in err and len(err.strip().splitlines()) == 1
    assert not (root / "chk").exists()


def test_the_library_plans_a_reef_plan_given_as_rows():
    plan = ReefPlan(({"id": "1", "x": 0.0, "y": 0.0, "bearing_deg": 0.0, "kind": "cube", "group": None},),
                    "one unit")
    from mbinspect.plan import plan_survey

    r = plan_survey(plan, depth=12.0, sonar="shallow", overlaps="0", seeds=1, workers=1, s44_order="2",
                    min_soundings=10)
    assert isinstance(r, ReefPlanResult) and r.best is not None and r.best.meets_target
    assert r.best.cubes_detected is None and r.parameters["cubes_per_survey"] == 0
    # called directly, the planner takes the named sonar and the ping rate the options give
    from mbinspect.plan import plan_reef_survey
    from mbinspect.plan.options import ping_rate

    opts = PlanOptions(depth=12.0, sonar="shallow", overlaps="0", seeds=1, workers=1, s44_order="2",
                       min_soundings=10)
    direct = plan_reef_survey(plan, opts)
    assert direct.parameters["ping_rate_hz"] == ping_rate(opts)
    assert [p.layout.name for p in direct.predictions] == [p.layout.name for p in r.predictions]
