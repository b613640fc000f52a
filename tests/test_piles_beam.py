"""Piles seen through the beam (issue 28): the correction of each sounding and the pipeline with it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mbinspect.beam import Beam
from mbinspect.errors import ParameterError
from mbinspect.piles import PileOptions, locate_piles
from mbinspect.piles.beam import PileModel, through_beam
from mbinspect.simulate import LABELS, simulate


@pytest.fixture(scope="module")
def wide_jacket():
    """The jacket through 1° beams, noise off: what is left is the beam's own bias."""
    return simulate("jacket", seed=1, ping_spacing=0.15, noise_scale=0.0, beam_across_deg=1.0)


def _axis(pile):
    t, b = math.radians(pile["tilt_deg"]), math.radians(pile["tilt_azimuth_deg"])
    return np.array([math.sin(t) * math.sin(b), math.sin(t) * math.cos(b), math.cos(t)])


def _wall_offsets(xyz, pile):
    """Distance from the pile's (tilted) wall, + outside."""
    a = _axis(pile)
    q = xyz - [pile["x"], pile["y"], pile["z"]]
    return np.linalg.norm(q - np.outer(q @ a, a), axis=1) - pile["radius"]


def test_the_true_piles_seen_through_the_beam_put_their_soundings_back_on_the_steel(wide_jacket):
    sim = wide_jacket
    xyz, f = sim.cloud.xyz, sim.cloud.fields
    models = [PileModel(np.array([p["x"], p["y"], p["z"]]), _axis(p), p["radius"], p["seabed_z"])
              for p in sim.truth["piles"]]
    seen = through_beam(xyz, f["ping"], f["beam_angle"], models, Beam(beam_across_deg=1.0),
                        reach=PileOptions(radius=0.75).neighbourhood)
    assert seen.moved > 1000 and seen.left_out > 500
    for p in sim.truth["piles"]:
        wall = (sim.labels == LABELS["pile"]) & (sim.ident == p["id"]) & (xyz[:, 2] < p["z"] - 0.3)
        before = _wall_offsets(xyz[wall], p)
        after = _wall_offsets(seen.points[wall & seen.keep], p)
        # the beam spreads the wall over centimetres (and blooms beside it); corrected, the
        # soundings kept lie on the steel within millimetres
        assert np.quantile(np.abs(before), 0.9) > 0.05
        assert abs(np.median(after)) < 0.002 and np.quantile(np.abs(after), 0.9) < 0.01


def test_locate_piles_told_the_beam_loses_its_bias(wide_jacket):
    truth = {(s["a"], s["b"]): s["distance"] for s in wide_jacket.truth["spacings"]}

    def spacing_errors(**kw):
        res = locate_piles(wide_jacket.cloud, count=4, radius=0.75, **kw)
        xy = {p.id: (p.x, p.y) for p in res.piles}
        near = {i: min(wide_jacket.truth["piles"], key=lambda t, i=i: math.hypot(xy[i][0] - t["x"],
                                                                                xy[i][1] - t["y"]))["id"]
                for i in xy}
        return res, np.array([s.distance - truth[tuple(sorted((near[s.a], near[s.b])))]
                              for s in res.spacings])

    _, thin = spacing_errors()
    res, wide = spacing_errors(beam_width_deg=1.0)
    assert np.sqrt(np.mean(thin**2)) > 0.008  # the beam's bias, a centimetre, unseen by the jackknife
    assert np.sqrt(np.mean(wide**2)) < 0.5 * np.sqrt(np.mean(thin**2)) and np.abs(wide).max() < 0.01
    assert any("seen through 1° beams" in w for w in res.warnings)
    assert res.parameters["beam_width_deg"] == 1.0


def test_without_pings_the_beam_is_not_corrected_and_says_so(wide_jacket):
    res = locate_piles(wide_jacket.cloud.xyz, count=4, radius=0.75, beam_width_deg=1.0)
    assert any("the beam's bias was not corrected" in w for w in res.warnings)


def test_a_beam_too_wide_is_named():
    with pytest.raises(ParameterError, match="beam_width_deg: 12"):
        PileOptions(radius=0.75, beam_width_deg=12.0)


def test_piles_command_through_the_beam(tmp_path, capsys):
    import json

    from mbinspect.cli import main
    from mbinspect.io import write

    sim = simulate("jacket", seed=2, ping_spacing=0.4, beam_across_deg=1.0)
    write(sim.cloud, tmp_path / "s.npz")
    out = tmp_path / "out"
    code = main(["piles", str(tmp_path / "s.npz"), "--radius", "0.75", "--count", "4",
                 "--beam-width-deg", "1", "--beam-contrast-db", "20", "--out", str(out)])
    assert code in (0, 3)  # 3: a pile flagged on this sparse survey
    got = json.loads((out / "piles.json").read_text())
    assert got["parameters"]["beam_width_deg"] == 1.0 and got["parameters"]["beam_contrast_db"] == 20.0
    assert any("seen through 1° beams" in w and "20 dB" in w for w in got["warnings"])
    assert main(["piles", str(tmp_path / "s.npz"), "--radius", "0.75", "--beam-width-deg", "12",
                 "--out", str(tmp_path / "bad")]) == 2
    assert "--beam-width-deg: 12" in capsys.readouterr().err


def _one_line(seed=0):
    """A line of pings over a flat seabed 10 m down: 121 pings 0.1 m apart along y, 101 beams
    to ±60° across, 5 mm of noise."""
    rng = np.random.default_rng(seed)
    ang = np.linspace(-60.0, 60.0, 101)
    pings = np.repeat(np.arange(121), len(ang))
    beam = np.tile(ang, 121)
    x = 500.0 + 10.0 * np.tan(np.radians(beam))
    y = 2000.0 + 0.1 * pings
    z = -10.0 + rng.normal(0.0, 0.005, len(x))
    return np.column_stack([x, y, z]), {"ping": pings, "beam_angle": beam}


def test_a_top_no_wall_sounding_shows_is_centred_as_the_beams_heard_it():
    from mbinspect.inject import InjectedPile, inject
    from mbinspect.piles.beam import top_through_beam

    xyz, fields = _one_line()
    beam = Beam(beam_across_deg=1.0)
    inj = inject(xyz, fields, piles=[InjectedPile(1, 500.9, 2006.0, 0.5, height=2.0)], beam=beam)
    t = inj.truth["piles"][0]
    top = inj.xyz[:, 2] > t["z"] - 0.15
    # the cones hear the top well beyond its edge: its soundings reach 5 cm and more past the rim
    assert np.hypot(inj.xyz[top, 0] - t["x"], inj.xyz[top, 1] - t["y"]).max() > t["radius"] + 0.05
    start = PileModel(np.array([t["x"] + 0.04, t["y"] - 0.03, t["z"]]), np.array([0.0, 0.0, 1.0]), 0.5,
                      t["seabed_z"])
    fit = top_through_beam(inj.xyz, fields["ping"], fields["beam_angle"], start, beam, reach=3.0,
                           contrast_db=18.0)
    assert fit is not None
    err = fit[0] - [t["x"], t["y"]]
    sigma = np.sqrt(np.diag(fit[1]))
    assert np.hypot(*err) < 0.008
    assert np.all(np.abs(err) <= 3 * sigma) and np.all(sigma < 0.015)


def test_a_pings_transducer_is_placed_from_its_seabed_not_from_a_pile_under_it():
    from mbinspect.pings import ping_geometry

    xyz, fields = _one_line()
    lifted = xyz.copy()
    under = (fields["ping"] == 60) & (np.abs(fields["beam_angle"]) < 5)
    lifted[under, 2] += 2.0  # a pile's top under the nadir beams of one ping
    o, _, _ = ping_geometry(lifted, fields["ping"], fields["beam_angle"])
    ping60 = fields["ping"] == 60
    assert abs(o[ping60, 2].mean()) > 1.0  # the top lifts the transducer
    o, _, ok = ping_geometry(lifted, fields["ping"], fields["beam_angle"], fit=~under)
    assert ok.all() and np.abs(o[ping60, 2]).max() < 0.05 and np.abs(o[ping60, 0] - 500.0).max() < 0.05
