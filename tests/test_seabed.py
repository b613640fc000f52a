"""Seabed surfaces: the paper's RANSAC plane and the robust grid surface."""

from __future__ import annotations

import numpy as np
import pytest

from mbinspect.errors import ParameterError
from mbinspect.seabed import grid_seabed, ransac_plane
from mbinspect.simulate import LABELS


def test_grid_surface_sees_through_piles_and_follows_the_seabed(jacket_small):
    sim = jacket_small
    surf = grid_seabed(sim.cloud.xyz, cell=1.0, window=5.0)
    for p in sim.truth["piles"]:
        assert float(surf.elevation(p["x"], p["y"])) == pytest.approx(p["seabed_z"], abs=0.1)
    sea = sim.labels == LABELS["seabed"]
    h = surf.height_above(sim.cloud.xyz[sea])
    assert np.median(np.abs(h)) < 0.05


def test_grid_surface_follows_sand_waves():
    rng = np.random.default_rng(0)
    xy = rng.uniform(0, 60, (60000, 2))
    z = -17 + 0.4 * np.sin(2 * np.pi * xy[:, 0] / 20) + rng.normal(0, 0.02, len(xy))
    surf = grid_seabed(np.column_stack([xy, z]), cell=0.5, window=4.0)
    x = np.linspace(5, 55, 50)
    truth = -17 + 0.4 * np.sin(2 * np.pi * x / 20)
    assert np.abs(surf.elevation(x, np.full(50, 30.0)) - truth).max() < 0.12


def test_ransac_plane_reports_p_and_n():
    rng = np.random.default_rng(1)
    xy = rng.uniform(0, 50, (5000, 2))
    z = -17.3 + 0.01 * xy[:, 0] + rng.normal(0, 0.05, len(xy))
    z[:1000] += rng.uniform(1, 3, 1000)
    res = ransac_plane(np.column_stack([xy, z]), threshold=0.5, seed=0)
    assert res.inlier_ratio == pytest.approx(0.8, abs=0.02)
    assert res.inliers[1000:].mean() > 0.99
    assert res.trials_needed == int(np.ceil(np.log(0.01) / np.log(1 - res.inlier_ratio**3)))
    assert res.to_dict()["plane"]["slope_deg"] == pytest.approx(np.degrees(np.arctan(0.01)), abs=0.05)
    with pytest.raises(ParameterError, match="threshold"):
        ransac_plane(np.column_stack([xy, z]), threshold=0)
