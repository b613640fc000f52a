"""Segmentation helpers."""

from __future__ import annotations

import numpy as np
import pytest

from mbinspect.errors import NotEnoughPointsError
from mbinspect.segment import components, elevation_window, kmeans, normals, otsu_threshold


def test_elevation_window_finds_the_densest_band():
    rng = np.random.default_rng(0)
    z = np.r_[rng.normal(-16.0, 0.02, 300), rng.uniform(-21, -16.2, 500)]
    lo, hi, n = elevation_window(z, window=0.1, step=0.01)
    assert hi - lo == pytest.approx(0.1)
    assert lo < -16.0 < hi and n > 250


def test_normals_of_a_plane_and_a_wall():
    g = np.stack(np.meshgrid(np.arange(10.0), np.arange(10.0)), -1).reshape(-1, 2) * 0.1
    flat = np.column_stack([g, np.zeros(len(g))])
    wall = np.column_stack([g[:, 0], np.zeros(len(g)), g[:, 1]])
    nf, _ = normals(flat, k=8)
    nw, _ = normals(wall, k=8)
    assert np.allclose(np.abs(nf[:, 2]), 1.0)
    assert np.allclose(np.abs(nw[:, 1]), 1.0, atol=1e-9)


def test_kmeans_is_seeded_and_finds_separated_groups():
    rng = np.random.default_rng(0)
    c = np.array([[0, 0], [22, 0], [0, 22], [22, 22.0]])
    pts = np.vstack([cc + rng.normal(0, 0.5, (100, 2)) for cc in c])
    l1, c1 = kmeans(pts, 4, seed=3)
    l2, _ = kmeans(pts, 4, seed=3)
    np.testing.assert_array_equal(l1, l2)
    assert len({tuple(np.round(x)) for x in c1}) == 4
    for k in range(4):
        assert len(np.unique(l1[k * 100:(k + 1) * 100])) == 1


def test_components_and_otsu():
    pts = np.array([[0, 0], [0.1, 0], [5, 5], [5.1, 5], [5.2, 5], [9, 9.0]])
    lab = components(pts, eps=0.2, min_points=2)
    assert lab.tolist() == [1, 1, 0, 0, 0, -1]
    v = np.r_[np.full(100, 60.0), np.full(50, 85.0)]
    assert 60 < otsu_threshold(v) < 85
    with pytest.raises(NotEnoughPointsError):
        otsu_threshold(np.ones(5))
