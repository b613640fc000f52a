"""The seabed-noise measurement: known noise recovered from simulated swaths and read from real files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mbinspect.errors import InputError, ParameterError
from mbinspect.noise import noise_profile, seabed_residuals
from mbinspect.sonar import read_sonar, to_cloud

DATA = Path(__file__).parent / "data"


def swath(rng, *, pings=120, beams=128, depth=20.0, sigma_at=lambda a: 0.03 + 0.0 * a, ping_sd=0.0,
          tails=None, ping_gap=0.4):
    """Pings ``ping_gap`` m apart, beams over ±60°, a sloping rippled seabed; noise by beam angle."""
    ang = np.linspace(-60, 60, beams)
    across = depth * np.tan(np.radians(ang))
    p, b = np.meshgrid(np.arange(pings), np.arange(beams), indexing="ij")
    x = across[b] + rng.uniform(-0.05, 0.05, p.shape)
    y = ping_gap * p + 0.01 * across[b] + rng.uniform(-0.05, 0.05, p.shape)
    seabed = -depth + 0.02 * x + 0.2 * np.sin(y / 7.0)
    noise = rng.normal(0, 1, p.shape) if tails is None else rng.standard_t(tails, p.shape)
    z = seabed + sigma_at(np.abs(ang[b])) * noise + ping_sd * rng.normal(0, 1, pings)[:, None]
    fields = {"ping": p.ravel(), "beam": b.ravel(), "beam_angle": ang[b].ravel()}
    return np.column_stack([x.ravel(), y.ravel(), z.ravel()]), fields


def test_known_noise_by_beam_angle_is_recovered():
    rng = np.random.default_rng(4)
    pts, f = swath(rng, sigma_at=lambda a: 0.02 + 0.04 * (a / 60) ** 2)
    prof = noise_profile(pts, f)
    for row in prof.by_angle:
        mid = np.mean(row["angles"])
        lo, hi = row["angles"]
        # the true sigma spans the bin: compare with its RMS over the bin's beams
        a = np.abs(f["beam_angle"])
        a = a[(a >= lo) & (a < hi)]
        truth = np.sqrt(np.mean((0.02 + 0.04 * (a / 60) ** 2) ** 2))
        assert row["sigma"] == pytest.approx(truth, rel=0.12), mid
        assert abs(row["bias"]) < 0.004
    assert 2.3 < prof.p99_ratio < 4.0  # normals of different widths: a little heavier than one
    assert abs(prof.beam_correlation) < 0.15
    # a ping's residuals are taken against its neighbour pings' planes and theirs against its:
    # independent noise shows a small negative correlation from ping to ping (-0.10 to -0.15)
    assert -0.25 < prof.ping_correlation < 0.05


def test_heavy_tails_and_ping_wide_errors_are_seen():
    rng = np.random.default_rng(5)
    pts, f = swath(rng, tails=3)
    assert noise_profile(pts, f).p99_ratio > 4.5  # Student t, 3 degrees of freedom (5.2 expected)
    pts, f = swath(rng, ping_sd=0.03)  # heave: 3 cm per ping beside 3 cm per sounding
    prof = noise_profile(pts, f)
    assert prof.sigma == pytest.approx(np.hypot(0.03, 0.03), rel=0.2)  # 120 pings' heave: a noisy sample
    assert prof.ping_share == pytest.approx(0.5, abs=0.2)
    assert prof.beam_correlation > 0.3
    # beams far closer than pings (shallow water): without the ping numbers the neighbours
    # are the ping's own beams and the heave cancels out of the residuals
    pts, f = swath(rng, pings=40, beams=512, ping_gap=1.5, ping_sd=0.03)
    with_pings = noise_profile(pts, f)
    assert with_pings.ping_share == pytest.approx(0.5, abs=0.2)
    assert seabed_residuals(pts).std() < 0.8 * with_pings.std


def test_origin_does_not_matter_and_bad_input_is_refused():
    rng = np.random.default_rng(6)
    pts, f = swath(rng, pings=30, beams=40)
    shifted = pts + [500_000.0, 5_700_000.0, 0.0]
    np.testing.assert_allclose(seabed_residuals(shifted, ping=f["ping"]),
                               seabed_residuals(pts, ping=f["ping"]), atol=1e-6)
    with pytest.raises(InputError, match="expected at least 17"):
        seabed_residuals(pts[:10])
    with pytest.raises(ParameterError, match="k"):
        seabed_residuals(pts, k=2)


@pytest.mark.parametrize(("name", "sigma_cm"), [("Belgica_0077.all", (1.5, 4.0)),
                                                ("pdal_mbf_em300raw.mb56", (1.5, 4.0))])
def test_real_shallow_files(name, sigma_cm):
    """Flat shallow seabeds: centimetre noise with tails heavier than normal (RESULTS.md)."""
    fmt = "all"
    cloud = to_cloud(read_sonar(DATA / name, fmt))
    prof = noise_profile(cloud.xyz, cloud.fields)
    assert sigma_cm[0] < 100 * prof.sigma < sigma_cm[1]
    assert prof.p99_ratio > 3.0
    assert len(prof.by_angle) >= 3
    # backscatter falls away from nadir on both flat files
    med = [b["intensity_median"] for b in prof.by_angle]
    assert med[0] > min(med[1:])


@pytest.mark.slow
def test_simulator_heavy_tails_option():
    """``tail_dof`` gives the simulator the heavy tails real files show, at the same robust sigma."""
    from mbinspect.simulate import simulate

    profiles = []
    for dof in (0, 2.5):
        sim = simulate("reef-field", seed=0, tail_dof=dof, per_group=4)
        keep = (sim.labels == 0) & (sim.cloud.fields["line"] == 1)
        fields = {k: v[keep] for k, v in sim.cloud.fields.items()}
        profiles.append(noise_profile(sim.cloud.xyz[keep], fields))
    normal, heavy = profiles
    assert normal.p99_ratio < 3.0 < 3.5 < heavy.p99_ratio
    assert heavy.sigma == pytest.approx(normal.sigma, rel=0.15)
    with pytest.raises(ParameterError, match="tail_dof"):
        simulate("reef-field", tail_dof=1.5)


def test_info_noise(capsys):
    """``info --noise`` adds the profile to the text and to the JSON (the same numbers)."""
    import json

    from mbinspect.cli import main

    path = str(DATA / "pdal_mbf_em300raw.mb56")
    assert main(["info", path, "--noise", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    cloud = to_cloud(read_sonar(DATA / "pdal_mbf_em300raw.mb56", "all"))
    direct = noise_profile(cloud.xyz, cloud.fields).to_dict()
    assert d["noise"]["sigma"] == pytest.approx(direct["sigma"])
    assert d["noise"]["p99_ratio"] == pytest.approx(direct["p99_ratio"])
    by_angle = [b["sigma"] for b in direct["by_angle"]]
    assert [b["sigma"] for b in d["noise"]["by_angle"]] == pytest.approx(by_angle)
    assert main(["info", path, "--noise"]) == 0
    out = capsys.readouterr().out
    assert f"noise       sigma {100 * d['noise']['sigma']:.1f} cm (robust)" in out
    assert out.count(" deg  sigma ") == len(d["noise"]["by_angle"]) >= 4


def _strip_offsets(sim) -> np.ndarray:
    """Median height difference of neighbouring lines over the 1 m cells both see (seabed only)."""
    xyz, line = sim.cloud.xyz, sim.cloud.fields["line"]
    seabed = sim.labels == 0
    cells = {}
    for k in np.unique(line):
        m = seabed & (line == k)
        key = np.floor(xyz[m, :2]).astype(np.int64)
        uniq, inv = np.unique(key, axis=0, return_inverse=True)
        z = np.bincount(inv.ravel(), xyz[m, 2]) / np.bincount(inv.ravel())
        cells[int(k)] = dict(zip(map(tuple, uniq), z, strict=True))
    out = []
    for a, b in zip(sorted(cells)[:-1], sorted(cells)[1:], strict=True):
        both = cells[a].keys() & cells[b].keys()
        out.append(np.median([cells[a][c] - cells[b][c] for c in both]))
    return np.abs(np.array(out))


@pytest.mark.slow
def test_named_sonars_and_strip_offsets():
    """The shallow sonar (the default) has the real files' growth with angle and tails; its
    lines disagree in height as real strips do, the classic sonar's do not."""
    from mbinspect.simulate import simulate

    sim = simulate("reef-field", seed=0, per_group=4)
    assert sim.truth["sonar"]["name"] == "shallow"
    keep = (sim.labels == 0) & (sim.cloud.fields["line"] == 1)
    prof = noise_profile(sim.cloud.xyz[keep], {k: v[keep] for k, v in sim.cloud.fields.items()})
    sig = [b["sigma"] for b in prof.by_angle]
    # real shallow files (benchmarks/real_noise.py): 3.1 cm at 0-20 deg, 4.6 at 55-65, p99/sigma 3.8
    assert 0.024 < sig[0] < 0.040 and 0.036 < sig[-1] < 0.060 and sig[-1] > 1.2 * sig[0]
    assert 3.82 / 1.3 < prof.p99_ratio < 3.82 * 1.3
    quiet = {"per_group": 4, "roughness": 0.0, "range_sigma": 0.0, "range_sigma_rel": 0.0,
             "angle_sigma_deg": 0.0}
    flat = _strip_offsets(simulate("reef-field", seed=0, sonar="classic", **quiet))
    shifted = _strip_offsets(simulate("reef-field", seed=0, sonar="classic", line_offset_sigma=0.1, **quiet))
    assert flat.max() < 0.005 and shifted.max() > 0.05
    with pytest.raises(ParameterError, match="sonar: 'sidescan'"):
        simulate("jacket", sonar="sidescan")


def test_pings_of_one_parity_fit_among_themselves():
    """Every other ping kept (a file split in two, or thinned): no ping of the other parity
    to fit against, so each sounding's seabed comes from its own pings."""
    rng = np.random.default_rng(3)
    xy = rng.uniform(0, 20, (3000, 2))
    z = 0.05 * xy[:, 1] + rng.normal(0, 0.04, 3000)
    r = seabed_residuals(np.column_stack([xy, z]), ping=np.full(3000, 6))
    assert 0.036 < r.std() < 0.044
