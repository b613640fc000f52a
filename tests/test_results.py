"""Results read back: every result type's ``to_dict()`` after :func:`read_result` equals
the JSON written, and what is no result of ours is one clear error."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mbinspect.errors import FileAccessError, InputError
from mbinspect.piles import Design, PileResult, locate_piles
from mbinspect.reefs import ReefResult, extract_reefs
from mbinspect.results import read_result, result_from_dict
from mbinspect.simulate import LABELS, simulate


def _round_trip(result, tmp_path: Path, name: str):
    written = json.loads(json.dumps(result.to_dict()))
    path = tmp_path / name
    path.write_text(json.dumps(written))
    back = read_result(path)
    assert type(back) is type(result)
    assert json.loads(json.dumps(back.to_dict())) == written
    assert read_result(tmp_path).to_dict() == back.to_dict()  # the folder holding it
    return back


@pytest.fixture(scope="module")
def jacket():
    return simulate("jacket", seed=1, ping_spacing=0.3)


def test_piles_both_methods_design_frames_and_rejected_read_back(jacket, tmp_path: Path) -> None:
    sim = jacket
    truth = {p["id"]: p for p in sim.truth["piles"]}
    on = (sim.labels == LABELS["pile"]) & (sim.ident == 1)
    top = on & (sim.cloud.xyz[:, 2] > truth[1]["z"] - 0.1)
    drop = np.zeros(len(on), bool)
    drop[np.flatnonzero(top)[1:]] = True
    drop[np.flatnonzero(on & ~top)[40:]] = True
    design = Design(positions={d["id"]: (d["x"], d["y"]) for d in sim.truth["design"]}, source="design")
    res = locate_piles(sim.cloud.subset(~drop), count=4, radius=0.75, method="both", design=design)
    assert res.rejected and res.other_piles and res.other_spacings and res.frames
    back = _round_trip(res, tmp_path, "piles.json")
    assert isinstance(back, PileResult)
    assert [p.id for p in back.piles] == [p.id for p in res.piles]
    assert back.rejected[0].reasons == res.rejected[0].reasons
    assert len(back.spacings) == len(res.spacings) and len(back.other_spacings) == len(res.other_spacings)
    s, t = back.spacings[0], res.spacings[0]
    assert (s.a, s.b, s.distance, s.sigma, s.verdict) == (t.a, t.b, t.distance, t.sigma, t.verdict)


def test_reefs_with_a_reference_and_other_objects_read_back(tmp_path: Path) -> None:
    sim = simulate("reef-field", seed=3, groups="cross2,cross1", close_pairs=3, touching_pairs=1,
                   ping_spacing=0.6, rocks=4)
    truth = sim.truth["reefs"]
    ref = (np.array([[r["x"], r["y"]] for r in truth[1:]]), tuple(r["id"] for r in truth[1:]))
    res = extract_reefs(sim.cloud, reference=ref)
    assert res.others and res.evaluation is not None and res.evaluation.fp >= 1
    back = _round_trip(res, tmp_path, "reefs.json")
    assert isinstance(back, ReefResult)
    assert back.evaluation is not None and (back.evaluation.tp, back.evaluation.fp) == (
        res.evaluation.tp, res.evaluation.fp)
    assert back.others[0].reason == res.others[0].reason
    (tmp_path / "paper").mkdir()
    paper = extract_reefs(sim.cloud, method="paper")
    assert paper.others
    _round_trip(paper, tmp_path / "paper", "reefs.json")


def test_what_is_no_result_is_one_clear_error(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not an mbinspect result"):
        result_from_dict({"type": "FeatureCollection"}, source="x.json")
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(InputError, match="bad.json: not JSON"):
        read_result(tmp_path / "bad.json")
    with pytest.raises(InputError, match="cannot be read back"):
        result_from_dict({"piles": [{"id": 1}]}, source="p.json")
    with pytest.raises(FileAccessError, match="holds no piles.json or reefs.json"):
        read_result(tmp_path)
