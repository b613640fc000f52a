"""The small robust least squares against SciPy's, on the problems it replaces SciPy in."""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from mbinspect.fit import Cylinder
from mbinspect.fit.cylinder import fit_cylinder
from mbinspect.fit.lsq import soft_l1_least_squares


def test_the_same_minimum_and_jacobian_as_scipy():
    rng = np.random.default_rng(4)
    x = rng.uniform(-1, 1, (200, 2))
    truth = np.array([0.3, -1.2, 2.0])
    y = truth[0] * np.exp(truth[1] * x[:, 0]) + truth[2] * x[:, 1] + rng.normal(0, 0.02, 200)
    y[:15] += rng.normal(0, 1.0, 15)  # outliers

    def f(q):
        return q[0] * np.exp(q[1] * x[:, 0]) + q[2] * x[:, 1] - y

    def j(q):
        e = np.exp(q[1] * x[:, 0])
        return np.column_stack([e, q[0] * x[:, 0] * e, x[:, 1]])

    ref = least_squares(f, np.ones(3), jac=j, loss="soft_l1", f_scale=0.05, x_scale=0.1)
    ours = soft_l1_least_squares(lambda q: (f(q), j(q)), np.ones(3), f_scale=0.05, x_scale=0.1)
    assert np.allclose(ours.x, ref.x, atol=1e-6)
    assert np.allclose(ours.fun, ref.fun, atol=1e-6)
    assert np.allclose(ours.jac, ref.jac, rtol=1e-4, atol=1e-6)
    assert abs(ours.cost - ref.cost) < 1e-9 and np.allclose(ours.x, truth, atol=0.02)


def test_a_cylinder_fit_as_scipy_fits_it():
    rng = np.random.default_rng(1)
    n = 600
    ang = rng.uniform(0, np.pi, n)  # one side seen
    z = rng.uniform(-20, -17, n)
    axis = np.array([0.02, -0.01, 1.0]) / np.linalg.norm([0.02, -0.01, 1.0])
    e1 = np.cross(axis, [1.0, 0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    centre = np.array([5.0, 3.0, 0.0])
    pts = centre + np.outer(z, axis) + 0.75 * (np.outer(np.cos(ang), e1) + np.outer(np.sin(ang), e2))
    pts += rng.normal(0, 0.02, pts.shape)
    pings = np.repeat(np.arange(60), 10)
    start = Cylinder(np.array([5.05, 2.95, 0.0]), np.array([0.0, 0.0, 1.0]), 0.75)
    cyl, cov = fit_cylinder(pts, start, groups=pings, z_ref=-17.0)
    top = centre + (-17.0 / axis[2]) * axis
    assert np.hypot(*(cyl.point[:2] - top[:2])) < 3 * np.sqrt(cov[0, 0] + cov[1, 1]) + 0.005
    assert abs(cyl.radius - 0.75) < 0.01 and cov.shape == (5, 5) and np.all(np.diag(cov) > 0)
