"""Outlier filters against brute force and known noise."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree
from scipy.spatial.distance import cdist

from mbinspect.errors import ParameterError
from mbinspect.filters import radius_outlier, statistical_outlier


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_radius_filter_matches_brute_force(seed):
    rng = np.random.default_rng(seed)
    dense = rng.normal(0, 0.3, (800, 3))
    sparse = rng.uniform(-5, 5, (200, 3))
    pts = np.vstack([dense, sparse])
    keep = radius_outlier(pts, radius=0.4, min_neighbors=3)
    neighbours = (cdist(pts, pts) <= 0.4).sum(axis=1) - 1
    np.testing.assert_array_equal(keep, neighbours > 3)


@pytest.mark.parametrize("spread", [0.0, 2000.0])
def test_radius_filter_matches_brute_force_on_a_survey_like_surface(spread):
    # a wavy 2.5-D seabed where the voxel shortcut settles most points, plus water-column
    # returns; ``spread`` scatters some far away so the voxel grid cannot be dense
    rng = np.random.default_rng(7)
    xy = rng.uniform(0, 12, (6000, 2))
    z = 0.3 * np.sin(xy[:, 0]) + rng.normal(0, 0.03, len(xy))
    far = rng.uniform(-spread - 1, spread + 1, (40, 3)) + [6, 6, 3]
    pts = np.vstack([np.column_stack([xy, z]), far])
    keep = radius_outlier(pts, radius=0.5, min_neighbors=3)
    neighbours = np.array([len(n) for n in cKDTree(pts).query_ball_point(pts, 0.5)]) - 1
    np.testing.assert_array_equal(keep, neighbours > 3)
    assert keep[:6000].mean() > 0.99


def test_radius_filter_removes_lone_points_and_rejects_bad_options():
    g = np.stack(np.meshgrid(np.arange(30.0), np.arange(30.0)), -1).reshape(-1, 2) * 0.2
    seabed = np.column_stack([g, np.zeros(len(g))])
    lone = np.array([[3.0, 3.0, 4.0], [1.0, 5.0, -3.0]])
    keep = radius_outlier(np.vstack([seabed, lone]), radius=0.5, min_neighbors=2)
    assert keep[: len(seabed)].all() and not keep[len(seabed):].any()
    with pytest.raises(ParameterError, match="radius: -1"):
        radius_outlier(seabed, radius=-1)
    with pytest.raises(ParameterError, match="min_neighbors"):
        radius_outlier(seabed, min_neighbors=-2)


def test_statistical_filter_removes_far_points():
    rng = np.random.default_rng(0)
    pts = np.vstack([rng.normal(0, 0.2, (1000, 3)), rng.uniform(5, 9, (10, 3))])
    keep = statistical_outlier(pts, k=8, std_ratio=2.0)
    assert not keep[1000:].any() and keep[:1000].mean() > 0.95
