"""Piles injected into real surveys: on the cylinder, with the survey's noise, shadows, and the CLI."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mbinspect.cli import main
from mbinspect.errors import InputError
from mbinspect.inject import InjectedPile, InjectedReef, inject, ping_origins, read_reef_file
from mbinspect.io import read
from mbinspect.noise import seabed_residuals

DATA = Path(__file__).parent / "data"
SURVEY = DATA / "pdal_mbf_em300raw.mb56"  # EM3000, 4.5 m, 67 pings, flat


def test_ping_origins_on_a_sloping_rough_swath():
    rng = np.random.default_rng(2)
    ang = np.linspace(-65, 65, 101)
    pts, pings, angles, truth = [], [], [], []
    for k in range(20):
        o = np.array([10.0 + 0.3 * k, 5.0 + 2.0 * k, 0.5])
        across = np.array([np.cos(0.3), -np.sin(0.3)])
        # the seabed sloping 2 % across, with 3 cm of noise
        h = 18.0 + 0.02 * 18.0 * np.tan(np.radians(ang))
        xy = o[:2] + np.outer(h * np.tan(np.radians(ang)), across)
        pts.append(np.column_stack([xy, o[2] - h + rng.normal(0, 0.03, len(ang))]))
        pings.append(np.full(len(ang), k))
        angles.append(ang)
        truth.append(np.tile(o, (len(ang), 1)))
    est, ok = ping_origins(np.concatenate(pts), np.concatenate(pings), np.concatenate(angles))
    assert ok.all()
    err = np.abs(est - np.concatenate(truth))
    assert err[:, :2].max() < 0.4 and err[:, 2].max() < 0.5  # 2 % of 18 m: within a degree of angle


def _piles(cloud, height=2.0):
    cx, cy = cloud.xyz[:, :2].mean(axis=0)
    return [InjectedPile(1, cx - 2.5, cy, 0.5, height=height),
            InjectedPile(2, cx + 2.5, cy, 0.5, height=height)]


def test_injected_piles_carry_the_surveys_noise_and_shadows():
    cloud = read(SURVEY)
    piles = _piles(cloud)
    inj = inject(cloud.xyz, cloud.fields, piles=piles)
    resid = seabed_residuals(cloud.xyz, ping=cloud.fields["ping"])
    moved = inj.labels > 0
    assert not np.array_equal(cloud.xyz, inj.xyz) and np.array_equal(cloud.xyz[~moved], inj.xyz[~moved])
    for p in inj.truth["piles"]:
        on = inj.ident == p["id"]
        assert on.sum() > 40
        q = inj.xyz[on]
        radial = np.hypot(q[:, 0] - p["x"], q[:, 1] - p["y"])
        side = q[:, 2] < p["z"] - 0.1
        top = ~side
        # side soundings on the cylinder, top soundings on the top face, each off by its own residual
        assert np.median(np.abs(radial[side] - p["radius"])) < 3 * np.median(np.abs(resid)) + 0.01
        if top.any():
            assert abs(np.median(q[top, 2]) - p["z"]) < 0.03
            # an oblique beam's residual moves it sideways too: the bulk stays on the face
            assert np.quantile(radial[top], 0.9) < p["radius"] + 0.05
        assert p["z"] == pytest.approx(p["seabed_z"] + 2.0)
    # shadows: no seabed sounding is left inside a pile's footprint
    for p in inj.truth["piles"]:
        inside = np.hypot(inj.xyz[:, 0] - p["x"], inj.xyz[:, 1] - p["y"]) < p["radius"] - 0.05
        assert (inj.labels[inside] > 0).all()
    assert inj.truth["counts"]["on_piles"] == int(moved.sum())
    assert inj.truth["spacings"][0]["distance"] == pytest.approx(5.0)


def test_inject_refuses_what_it_cannot_do():
    cloud = read(SURVEY)
    shuffled = cloud.xyz[np.random.default_rng(0).permutation(len(cloud))]
    with pytest.raises(InputError, match="order shows no pings"):
        inject(shuffled, {}, piles=_piles(cloud))
    cx, cy = cloud.xyz[:, :2].mean(axis=0)
    with pytest.raises(InputError, match="overlap"):
        inject(cloud.xyz, cloud.fields, piles=[InjectedPile(1, cx, cy, 0.5, height=1),
                                               InjectedPile(2, cx + 0.8, cy, 0.5, height=1)])
    with pytest.raises(InputError, match="expected a pile inside the survey"):
        inject(cloud.xyz, cloud.fields, piles=[InjectedPile(1, cx + 500, cy, 0.5, height=1)])


def _write_piles(path, cloud):
    rows = ["id,x,y,radius,height"] + [f"{p.id},{p.x:.3f},{p.y:.3f},{p.radius},{p.height}"
                                       for p in _piles(cloud)]
    path.write_text("\n".join(rows) + "\n")


def test_inject_command(tmp_path, capsys):
    cloud = read(SURVEY)
    _write_piles(tmp_path / "piles.csv", cloud)
    out = tmp_path / "inj"
    assert main(["inject", str(SURVEY), "--piles", str(tmp_path / "piles.csv"), "--out", str(out)]) == 0
    truth = json.loads((out / "truth.json").read_text())
    assert [p["id"] for p in truth["piles"]] == [1, 2] and truth["survey"]["sha256"]
    back = read(out / "soundings.npz")
    assert len(back) == len(cloud) and "ping" in back.fields
    labels = np.load(out / "labels.npz")["label"]
    assert (labels > 0).sum() == truth["counts"]["on_piles"]
    assert (out / "design.csv").read_text().startswith("group,id,x,y")
    # bad pile files: one line naming the file, line and column
    (tmp_path / "bad.csv").write_text("id,x,y,radius,top\n1,2,3,abc,-1\n")
    bad = ["inject", str(SURVEY), "--piles", str(tmp_path / "bad.csv"), "--out", str(tmp_path / "b")]
    assert main(bad) == 2
    err = capsys.readouterr().err
    assert "bad.csv: line 2, column radius: 'abc'; expected a number" in err
    assert not (tmp_path / "b").exists()


def _reefs(cloud):
    cx, cy = cloud.xyz[:, :2].mean(axis=0)
    return [InjectedReef(1, cx - 3.0, cy, "cross1", bearing_deg=20, burial=0.3),
            InjectedReef(2, cx + 2.5, cy, "hollow", bearing_deg=50, scale=0.8)]


def test_injected_reefs_are_found_with_their_exposed_height():
    """Reefs put into the real EM3000 line carry its noise; the reef method finds both, at
    their exposed height (the cross sunk 0.3 m), and nothing else."""
    from mbinspect.io import PointCloud
    from mbinspect.reefs import extract_reefs

    cloud = read(SURVEY)
    inj = inject(cloud.xyz, cloud.fields, reefs=_reefs(cloud))
    truth = inj.truth["reefs"]
    assert [r["kind"] for r in truth] == ["cross1", "hollow"]
    assert truth[0]["height"] == pytest.approx(1.2 - 0.3)
    assert truth[1]["height"] == pytest.approx(1.5 * 0.8 - 0.1)
    assert min(inj.truth["counts"]["per_reef"].values()) > 300
    moved = inj.labels > 0
    assert np.array_equal(cloud.xyz[~moved], inj.xyz[~moved]) and (inj.labels[moved] == 2).all()
    ref = (np.array([[r["x"], r["y"]] for r in truth]), (1, 2))
    # the hollow square is built at 0.8 of its design: a tolerance that admits it
    res = extract_reefs(PointCloud(inj.xyz, dict(cloud.fields), crs=cloud.crs), reference=ref,
                        design="cross1,hollow", design_scale_tolerance=0.25)
    ev = res.evaluation
    assert (ev.tp, ev.fp, ev.fn) == (2, 0, 0) and not res.others
    for i, j, dist in ev.matches:
        # the hollow square lies 0.157 m off (0.14 m while the footprint raster ended at the
        # reef soundings' extent: its edge cells then took a reef sounding as their nearest)
        assert dist < 0.2
        assert res.reefs[i].height == pytest.approx(truth[j]["height"], abs=0.05)
        assert res.reefs[i].design == truth[j]["kind"]


def test_inject_reefs_command(tmp_path, capsys):
    cloud = read(SURVEY)
    rows = ["id,x,y,kind,bearing_deg,scale,burial"] + [
        f"{r.id},{r.x:.3f},{r.y:.3f},{r.kind},{r.bearing_deg},{r.scale},{r.burial}" for r in _reefs(cloud)]
    (tmp_path / "reefs.csv").write_text("\n".join(rows) + "\n")
    out = tmp_path / "inj"
    assert main(["inject", str(SURVEY), "--reefs", str(tmp_path / "reefs.csv"), "--out", str(out)]) == 0
    truth = json.loads((out / "truth.json").read_text())
    assert [r["id"] for r in truth["reefs"]] == [1, 2] and not truth["piles"]
    assert (out / "reference.csv").read_text().startswith("x,y,id") and not (out / "design.csv").exists()
    assert read_reef_file(tmp_path / "reefs.csv")[1].kind == "hollow"
    (tmp_path / "bad.csv").write_text("id,x,y,kind\n1,2,3,pyramid\n")
    bad = ["inject", str(SURVEY), "--reefs", str(tmp_path / "bad.csv"), "--out", str(tmp_path / "b")]
    assert main(bad) == 2
    assert "bad.csv: line 2, column kind: 'pyramid'; expected one of cross1" in capsys.readouterr().err
    assert main(["inject", str(SURVEY), "--out", str(tmp_path / "c")]) == 2
    assert "give --piles, --reefs or --pit" in capsys.readouterr().err


def test_inject_into_an_export_without_pings_estimates_them():
    """An XYZ export keeps the soundings in ping order but not the ping or the beam angle:
    the pings are found again from the order, the angles follow the real ones (this EM3000
    swath is lopsided, -70 to +15 deg, so the assumed middle of the swath misplaces its
    nadir), and the injection runs with a warning that says what was assumed."""
    from mbinspect.inject import estimate_pings

    cloud = read(SURVEY)
    ping, angle = estimate_pings(cloud.xyz)
    assert ping.max() + 1 == len(np.unique(cloud.fields["ping"]))
    assert np.corrcoef(angle, cloud.fields["beam_angle"])[0, 1] > 0.8
    bare = inject(cloud.xyz, {}, piles=_piles(cloud))
    assert bare.truth["warnings"] and "taken from the soundings' order" in bare.truth["warnings"][0]
    assert min(bare.truth["counts"]["per_pile"].values()) > 50


def test_extra_detections_stay_where_they_are():
    """KMALL's extra detections are targets in the water column, not bottom detections: a
    pile put where their beams pass leaves them untouched (their "seabed residual" is a
    metre or two, which would scatter them above the pile's top)."""
    path = Path(__file__).parent / "data" / "ets_kmall_eg_-7360358516350552537.kmall"
    cloud = read(path, keep_rejected=True)  # the extra detections kept
    cloud = cloud.subset(cloud.fields["valid"].astype(bool) | cloud.fields["extra_detection"].astype(bool))
    extra = cloud.fields["extra_detection"].astype(bool)
    assert extra.sum() == 753
    centre = np.median(cloud.xyz[:, :2], axis=0)
    inj = inject(cloud.xyz, cloud.fields, piles=[InjectedPile(1, *centre, 0.5, height=1.6)])
    assert inj.truth["counts"]["per_pile"]["1"] > 500
    np.testing.assert_array_equal(inj.xyz[extra], cloud.xyz[extra])
    assert not inj.labels[extra].any()


def _wall_offsets(thin, wide, pile):
    """The same beams' plan distance from the pile's axis, through the beam less thin."""
    wall = (thin.labels == 1) & (thin.xyz[:, 2] < pile["z"] - 0.2)
    radial = [np.hypot(x.xyz[wall, 0] - pile["x"], x.xyz[wall, 1] - pile["y"]) for x in (thin, wide)]
    return radial[1] - radial[0]


def test_piles_injected_through_a_beam_bloom_and_leave_the_far_seabed_alone():
    from mbinspect.beam import Beam
    from mbinspect.simulate import simulate

    sim = simulate("jacket", seed=3, ping_spacing=0.6, noise_scale=0.0)
    piles = [InjectedPile(1, *sim.scene.origin, 0.75, height=3.0)]  # the jacket's empty centre
    thin = inject(sim.cloud.xyz, sim.cloud.fields, piles=piles)
    np.testing.assert_array_equal(thin.xyz, inject(sim.cloud.xyz, sim.cloud.fields, piles=piles,
                                                   beam=Beam()).xyz)
    p = thin.truth["piles"][0]
    plan = np.hypot(sim.cloud.xyz[:, 0] - p["x"], sim.cloud.xyz[:, 1] - p["y"])
    for detection in ("auto", "leading-edge"):
        wide = inject(sim.cloud.xyz, sim.cloud.fields, piles=piles,
                      beam=Beam(beam_across_deg=1.0, detection=detection))
        assert wide.truth["beam"]["detection"] == detection
        np.testing.assert_array_equal(wide.xyz[plan > 12], sim.cloud.xyz[plan > 12])
        q = wide.xyz - [p["x"], p["y"], 0.0]
        r = np.hypot(q[:, 0], q[:, 1])
        water = (r > 0.9) & (r < 3.25) & (q[:, 2] < p["z"]) & (q[:, 2] > p["seabed_z"] + 0.3)
        assert water.sum() > 20 and wide.truth["counts"]["on_piles"] > thin.truth["counts"]["on_piles"]
        offset = _wall_offsets(thin, wide, p)
        if detection == "leading-edge":  # the first echo: the pile looks centimetres larger
            assert np.median(offset) > 0.02
        else:  # centroid near nadir, zero crossing outside: millimetres
            assert abs(np.median(offset)) < 0.01


@pytest.mark.parametrize("name", ["pdal_mbf_em300raw.mb56", "Belgica_0077.all",
                                  "ets_kmall_OS01_-6133896825737735245.kmall", "R2Testing_0009_first40.xtf"])
def test_piles_injected_through_a_beam_into_every_sonar_format(name):
    """Every maker's format gives what the cone needs (ping, beam angle, the swath's axis): the
    pile is seen by more beams than thin rays see it, its spacing truth is unchanged, and
    soundings whose cones cannot reach it stay as they were. (The one GSF kept here is 1,446
    soundings over 5 km at 1,500 m: no pile fits in it; benchmarks/study_inject.py injects
    into the shallow GSF files.)"""
    from mbinspect.beam import Beam

    cloud = read(DATA / name)
    middle = np.median(cloud.xyz[:, :2], axis=0)
    cx, cy = cloud.xyz[np.argmin(np.hypot(*(cloud.xyz[:, :2] - middle).T)), :2]  # on the seabed
    depth = -float(np.median(cloud.xyz[:, 2]))
    piles = [InjectedPile(1, cx, cy, 0.5, height=min(2.0, 0.3 * depth))]
    thin = inject(cloud.xyz, cloud.fields, piles=piles)
    wide = inject(cloud.xyz, cloud.fields, piles=piles, beam=Beam(beam_across_deg=2.0))
    assert wide.truth["counts"]["on_piles"] >= thin.truth["counts"]["on_piles"] > 10
    plan = np.hypot(cloud.xyz[:, 0] - cx, cloud.xyz[:, 1] - cy)
    far = plan > 0.5 + 4 * depth  # beyond any cone of the swath that passes near the pile
    np.testing.assert_array_equal(wide.xyz[far], cloud.xyz[far])
    assert np.isfinite(wide.xyz).all()


def test_inject_command_with_a_beam(tmp_path, capsys):
    cloud = read(SURVEY)
    _write_piles(tmp_path / "piles.csv", cloud)
    out = tmp_path / "inj"
    args = ["inject", str(SURVEY), "--piles", str(tmp_path / "piles.csv"), "--out", str(out)]
    assert main([*args, "--beam-across-deg", "1.5", "--detection", "phase"]) == 0
    truth = json.loads((out / "truth.json").read_text())
    assert truth["beam"]["beam_across_deg"] == 1.5 and truth["beam"]["detection"] == "phase"
    assert main([*args, "--overwrite", "--sub-rays", "4"]) == 2
    assert "--sub-rays: 4; expected an odd whole number of at least 3" in capsys.readouterr().err


def test_a_pit_dug_into_a_real_seabed_lowers_each_sounding_along_its_ray(tmp_path, capsys):
    cloud = read(SURVEY)
    cx, cy = cloud.xyz[:, :2].mean(axis=0)
    inj = inject(cloud.xyz, cloud.fields, pits=[(cx, cy, 0.4, 2.0)])
    moved = inj.xyz - cloud.xyz
    r = np.hypot(cloud.xyz[:, 0] - cx, cloud.xyz[:, 1] - cy)
    near, far = r < 0.3, r > 2.2
    assert near.sum() >= 5 and np.allclose(moved[far], 0.0)
    # each sounding goes on along its own ray (outward, down) to where the bell has lowered the seabed
    rn = np.hypot(inj.xyz[:, 0] - cx, inj.xyz[:, 1] - cy)
    bell = np.where(rn < 2.0, 0.4 * (1 + np.cos(np.pi * np.minimum(rn / 2.0, 1.0))) / 2, 0.0)
    dug = r < 2.0
    assert np.abs(moved[dug, 2] + bell[dug]).max() < 1e-3
    assert np.median(moved[near, 2]) < -0.3 and np.hypot(moved[dug, 0], moved[dug, 1]).max() < 0.7
    assert inj.truth["pits"] == [{"x": cx, "y": cy, "depth": 0.4, "radius": 2.0}]
    out = tmp_path / "pit"
    assert main(["inject", str(SURVEY), "--pit", f"{cx:.3f},{cy:.3f},0.4,2", "--out", str(out)]) == 0
    back = read(out / "soundings.npz")
    assert np.allclose(back.xyz, inj.xyz, atol=2e-3)
    assert main(["inject", str(SURVEY), "--pit", "1,2,deep,3", "--out", str(tmp_path / "b")]) == 2
    err = capsys.readouterr().err
    assert "--pit: '1,2,deep,3'; expected X,Y,DEPTH,RADIUS in metres (four numbers)" in err
    assert not (tmp_path / "b").exists()
