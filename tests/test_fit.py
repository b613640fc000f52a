"""Geometric models and the robust loop: property tests with outliers at known indices."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mbinspect.fit import Circle, Cylinder, Plane, cylinder_msac, fit_cylinder, msac, ransac_trials


def _cylinder_points(rng, centre, axis, radius, n, arc_deg, noise, height=4.0):
    axis = axis / np.linalg.norm(axis)
    e1 = np.cross(axis, [1.0, 0, 0]) if abs(axis[0]) < 0.9 else np.cross(axis, [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    ang = rng.uniform(0, math.radians(arc_deg), n)
    s = rng.uniform(-height, 0, n)
    radial = np.outer(np.cos(ang), e1) + np.outer(np.sin(ang), e2)
    pts = centre + np.outer(s, axis) + radius * radial
    nrm = radial + rng.normal(0, 0.05, (n, 3))
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    return pts + rng.normal(0, noise, (n, 3)), nrm


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), tilt=st.floats(0, 8), bearing=st.floats(0, 360),
       radius=st.floats(0.3, 2.0), arc=st.floats(100, 360))
def test_msac_and_least_squares_recover_a_cylinder_with_outliers(seed, tilt, bearing, radius, arc):
    rng = np.random.default_rng(seed)
    t, b = math.radians(tilt), math.radians(bearing)
    axis = np.array([math.sin(t) * math.sin(b), math.sin(t) * math.cos(b), math.cos(t)])
    centre = np.array([3.0, -2.0, -16.0])
    pts, nrm = _cylinder_points(rng, centre, axis, radius, 600, arc, 0.005)
    bad = rng.choice(600, 60, replace=False)  # outliers at known indices
    pts[bad] += rng.normal(0, 1.0, (60, 3)) + np.sign(rng.normal(size=(60, 1))) * 0.3
    res = cylinder_msac(pts, nrm, radius=radius, threshold=0.03, seed=seed)
    assert res.model is not None
    cyl, cov = fit_cylinder(pts[res.inliers], res.model, radius=radius, z_ref=-16.0, f_scale=0.02)
    assert np.hypot(*(cyl.point[:2] - centre[:2])) < 0.01
    assert cyl.tilt_deg == pytest.approx(tilt, abs=0.3)
    good = np.setdiff1d(np.arange(600), bad)
    far = bad[np.abs(Cylinder(centre, axis, radius).residuals(pts[bad])) > 0.1]
    assert res.inliers[good].mean() > 0.95
    assert not res.inliers[far].any()
    assert np.all(np.isfinite(cov))


def test_orthogonal_fit_is_unbiased_on_a_one_sided_arc():
    # multibeam sees a pile from one side: a 90-degree arc with noise
    rng = np.random.default_rng(4)
    centre = np.array([0.0, 0.0, -16.0])
    pts, _ = _cylinder_points(rng, centre, np.array([0, 0, 1.0]), 0.75, 3000, 90, 0.02)
    start = Cylinder(np.array([0.05, -0.05, -16.0]), np.array([0, 0, 1.0]), 0.75)
    cyl, _ = fit_cylinder(pts, start, radius=None, z_ref=-16.0, loss="linear")
    assert np.hypot(*cyl.point[:2]) < 0.01
    assert cyl.radius == pytest.approx(0.75, abs=0.01)
    # an algebraic (Kasa) circle fit on the same arc is pulled inwards, by more than 4 cm
    p = pts[:, :2]
    sol, *_ = np.linalg.lstsq(np.column_stack([2 * p, np.ones(len(p))]), (p**2).sum(axis=1), rcond=None)
    kasa_radius = float(np.sqrt(sol[2] + sol[:2] @ sol[:2]))
    assert kasa_radius < 0.75 - 0.04
    assert abs(cyl.radius - 0.75) < 0.25 * abs(kasa_radius - 0.75)
    # the geometric circle fit agrees with the orthogonal cylinder fit
    circle = Circle.fit(pts, radius=None)
    assert circle is not None and abs(circle.radius - cyl.radius) < 0.005


def _pinged_pile(rng, centre, radius=0.75, sigma_ping=0.01, sigma_point=0.03):
    """Side soundings as multibeam gives them: each ping a vertical line at one azimuth,
    some pings with many soundings (close, near nadir), most with few, every ping shifted
    by its own position error."""
    pts, ping = [], []
    for g, az in enumerate(rng.uniform(0, 2 * np.pi, 60)):
        n = 300 if g % 10 == 0 else 8
        radial = np.array([np.cos(az), np.sin(az), 0.0])
        z = rng.uniform(-4, 0, n)
        p = centre + radius * radial + np.outer(z, [0, 0, 1.0])
        p += rng.normal(0, sigma_point, (n, 3)) + np.r_[rng.normal(0, sigma_ping, 2), 0.0]
        pts.append(p)
        ping.append(np.full(n, g))
    return np.vstack(pts), np.concatenate(ping)


def test_random_effects_by_ping_beat_ordinary_least_squares():
    # a ping's soundings share its position error: weighting them as independent lets the
    # pings with many soundings dominate; the random-effects refinement must do better
    centre = np.array([0.0, 0.0, -16.0])
    start = Cylinder(centre + [0.02, -0.02, 0], np.array([0, 0, 1.0]), 0.75)
    err_ols, err_re, in_ols, in_re = [], [], [], []
    for seed in range(40):
        rng = np.random.default_rng(seed)
        pts, ping = _pinged_pile(rng, centre)
        for groups, err, inside in ((None, err_ols, in_ols), (ping, err_re, in_re)):
            fit, cov = fit_cylinder(pts, start, radius=0.75, z_ref=-16.0, loss="linear", groups=groups)
            e = fit.point[:2] - centre[:2]
            err.append(np.hypot(*e))
            inside.append(float(e @ np.linalg.solve(cov[:2, :2], e)) <= 5.99)  # 95 % in 2-D
    rms = lambda v: float(np.sqrt(np.mean(np.square(v))))  # noqa: E731
    assert rms(err_re) < 0.92 * rms(err_ols)  # 0.85 here, 0.88 over 200 seeds
    # the covariance that ignores pings is badly overconfident; the cluster-robust one is
    # much closer to honest, though few dominant pings still leave it short of 95 %
    # (here 80 % against 50 %; over 200 seeds 72 % against 33 %; 98 % on the simulated
    # jacket, benchmarks/RESULTS.md)
    assert np.mean(in_re) >= 0.7 and np.mean(in_re) > np.mean(in_ols) + 0.2


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), gx=st.floats(-0.5, 0.5), gy=st.floats(-0.5, 0.5))
def test_plane_recovered_with_outliers(seed, gx, gy):
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-10, 10, (400, 2))
    pts = np.column_stack([xy, -17 + gx * xy[:, 0] + gy * xy[:, 1] + rng.normal(0, 0.01, 400)])
    pts[:80, 2] += rng.uniform(0.5, 3.0, 80)  # reef-like points at known indices
    res = msac(pts, Plane.from_sample, lambda m, p: m.residuals(p), 3, 0.05, seed=seed,
               refine=lambda rows, _m: Plane.fit(rows))
    assert res.model is not None
    assert res.inliers[80:].mean() > 0.97 and not res.inliers[:80].any()
    assert float(res.model.z_at(0.0, 0.0)) == pytest.approx(-17, abs=0.01)


def test_circle_fit_fixed_and_free_radius():
    rng = np.random.default_rng(0)
    a = rng.uniform(0, 2 * np.pi, 200)
    p = np.column_stack([5 + 2 * np.cos(a), -3 + 2 * np.sin(a)]) + rng.normal(0, 0.01, (200, 2))
    free = Circle.fit(p)
    fixed = Circle.fit(p, radius=2.0)
    assert free is not None and fixed is not None
    assert free.radius == pytest.approx(2.0, abs=0.005)
    np.testing.assert_allclose(fixed.centre, [5, -3], atol=0.005)


def test_degenerate_samples_give_no_model_not_an_error():
    line = np.column_stack([np.arange(10.0), np.zeros(10), np.zeros(10)])
    assert Plane.from_sample(line[:3]) is None
    res = msac(line, Plane.from_sample, lambda m, p: m.residuals(p), 3, 0.1, max_trials=50)
    assert res.model is None and not res.inliers.any()
    assert msac(line[:2], Plane.from_sample, lambda m, p: m.residuals(p), 3, 0.1).model is None


def test_trial_count_formula():
    # N = ln(1 - q) / ln(1 - P^K): P = 0.5, K = 3, q = 0.99 -> 34.5 -> 35
    assert ransac_trials(0.5, 3, 0.99) == 35
    assert ransac_trials(1.0, 3) == 1
    assert ransac_trials(0.9, 3, 0.99) < ransac_trials(0.5, 3, 0.99)


def test_models_compare_by_value_and_meet_the_protocol():
    from mbinspect.fit import GeometricModel

    up = np.array([0.0, 0.0, 1.0])
    a, b = Plane(np.zeros(3), up.copy()), Plane(np.zeros(3), up.copy())
    assert a == b and hash(a) == hash(b) and len({a, b}) == 1
    assert a != Plane(np.array([0.0, 0.0, 1.0]), up)
    c1, c2 = Cylinder(np.zeros(3), up, 0.75), Cylinder(np.zeros(3), up, 0.76)
    assert c1 != c2 and c1 == Cylinder(np.zeros(3), up.copy(), 0.75)
    assert Circle(np.zeros(2), 1.0) != Cylinder(np.zeros(3), up, 1.0)
    for model in (a, c1, Circle(np.array([1.0, 2.0]), 3.0)):
        assert isinstance(model, GeometricModel)
        json.dumps(model.to_dict())
    pts = np.array([[1.75, 0.0, -3.0], [0.0, 0.5, 2.0]])
    np.testing.assert_allclose(c1.residuals(pts), [1.0, -0.25])
    np.testing.assert_allclose(a.residuals(pts), [-3.0, 2.0])
