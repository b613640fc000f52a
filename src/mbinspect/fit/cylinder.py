"""Cylinders: a candidate from two points and their normals, the least-squares fit (random
effects by ping, a cluster-robust covariance) and MSAC with a known radius."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .lsq import soft_l1_least_squares
from .models import Cylinder
from .robust import RobustResult, msac

__all__ = ["cylinder_from_normals", "fit_cylinder", "cylinder_msac"]


def cylinder_from_normals(sample: np.ndarray, *, radius: float,
                          max_tilt_deg: float = 15.0) -> list[Cylinder]:
    """Candidate cylinders of known ``radius`` through two points with their normals.

    ``sample`` is (2, 6): x, y, z, nx, ny, nz. The axis is the cross product of the two
    normals when they are far enough apart, else vertical; the axis point follows from
    each point moved by ``radius`` against its normal, and also from the two circles of
    that radius through both projected points (normals from a few noisy soundings are
    rough, so both are offered). Candidates tilted more than ``max_tilt_deg`` are dropped.

    Parameters
    ----------
    sample : ndarray, shape (2, 6)
    radius : float
        Prior radius (m).
    max_tilt_deg : float
        Hypotheses tilted more are refused (deg).

    Returns
    -------
    list of Cylinder
    """
    p, n = sample[:, :3], sample[:, 3:6]
    axis = np.cross(n[0], n[1])
    norm = np.linalg.norm(axis)
    if norm < math.sin(math.radians(25.0)):
        axis = np.array([0.0, 0.0, 1.0])
    else:
        axis = axis / norm
        if axis[2] < 0:
            axis = -axis
    if math.degrees(math.acos(min(1.0, axis[2]))) > max_tilt_deg:
        axis = np.array([0.0, 0.0, 1.0])
    out = []
    # the two circles of the given radius through the projected points
    q = p - np.outer(p @ axis, axis)
    e1 = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    uv = np.column_stack([q @ e1, q @ e2])
    d = uv[1] - uv[0]
    dist = float(np.hypot(*d))
    if 1e-6 < dist <= 2 * radius:
        mid = (uv[0] + uv[1]) / 2
        h = math.sqrt(max(radius**2 - (dist / 2) ** 2, 0.0))
        perp = np.array([-d[1], d[0]]) / dist
        for sgn in (1.0, -1.0):
            c = mid + sgn * h * perp
            out.append(Cylinder(c[0] * e1 + c[1] * e2, axis, radius))
    # the point moved inwards along its (horizontal part of the) normal
    nh = n - np.outer(n @ axis, axis)
    nn = np.linalg.norm(nh, axis=1)
    if np.all(nn > 0.5):
        c = (p - radius * nh / nn[:, None]).mean(axis=0)
        out.append(Cylinder(c - (c @ axis) * axis, axis, radius))
    return out


def _axis_from_params(ax: float, ay: float) -> np.ndarray:
    n = math.sqrt(ax * ax + ay * ay + 1.0)
    return np.array([ax / n, ay / n, 1.0 / n])


#: Residual evaluations a cylinder fit may spend per parameter. A pile's fit converges in under
#: 20 in all (every fit of two plan trials through the beam); one that has not by 20 per
#: parameter is walking its axis toward the horizontal and its point hundreds of metres off (a
#: wall seen from above only), where SciPy's default of 100 per parameter spent a plan's trial
#: 16 s for nothing. The regression cases come out the same.
MAX_NFEV_PER_PARAMETER = 20


def fit_cylinder(points: np.ndarray, start: Cylinder, *, radius: float | None = None,
                 z_ref: float | None = None, loss: str = "soft_l1", f_scale: float = 0.03,
                 groups: np.ndarray | None = None, sigma: np.ndarray | None = None,
                 plumb: bool = False, random_effects: bool = True) -> tuple[Cylinder, np.ndarray]:
    """Least squares on true orthogonal point-to-cylinder distances.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
    start : Cylinder
        Initial model (axis not horizontal).
    radius : float, optional
        Keep the radius fixed at this value (the prior); free when None.
    z_ref : float, optional
        Elevation at which the axis point is parameterised (e.g. the top); default the
        mean z of the points. The returned ``point`` lies on the axis at ``z_ref``.
    loss, f_scale : str, float
        Robust loss and its scale (m): ``"soft_l1"`` or ``"linear"`` (none), as
        :func:`scipy.optimize.least_squares` names them
        (:func:`~mbinspect.fit.lsq.soft_l1_least_squares` minimises them).
    groups : ndarray of int, optional
        Cluster labels (ping numbers). Errors common to a ping are not independent: the
        fit is then refined as a random-effects (GLS) fit, which stops a ping with many
        soundings from counting as many independent ones, and its covariance is
        cluster-robust (a plain covariance would be far too small).
    sigma : ndarray (N,), optional
        Each point's noise (m): residuals are weighted by ``median(sigma) / sigma``, so
        that noisier points count less while the residuals keep their metres (for
        ``f_scale``). The covariance stays a sandwich of the weighted residuals, right
        whether the weights are or not.
    plumb : bool
        Hold the axis vertical (the slopes' rows and columns of the covariance are 0).
    random_effects : bool
        With ``groups``, refine as the random-effects fit (False: the plain robust fit,
        its covariance still cluster-robust). A ping meets a pile's side along one vertical
        line, so the part of its residuals common to the ping is where the radius shows:
        the random-effects fit takes part of it away and can leave a free radius centimetres
        off (0.44 m for 0.50 m on the real KMALL strip).

    Returns
    -------
    cylinder : Cylinder
    covariance : ndarray, shape (P, P)
        Covariance of (x, y, ax, ay[, r]): axis point at ``z_ref`` and axis slopes.
    """
    pts = np.asarray(points, np.float64)
    zr = float(pts[:, 2].mean()) if z_ref is None else float(z_ref)
    a0 = start.axis if start.axis[2] > 0 else -start.axis
    t0 = (zr - start.point[2]) / a0[2]
    p0 = start.point + t0 * a0
    centre = pts.mean(axis=0)
    fixed_r = radius is not None

    n_ax = 0 if plumb else 2

    def unpack(q: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        r = float(radius) if radius is not None else float(q[2 + n_ax])
        a = np.array([0.0, 0.0, 1.0]) if plumb else _axis_from_params(q[2], q[3])
        return np.array([q[0], q[1], zr]), a, r

    shift = np.array([centre[0], centre[1], 0.0])
    rel = pts - shift  # local coordinates keep the normal equations well conditioned
    w = 1.0 if sigma is None else float(np.median(sigma)) / np.asarray(sigma, np.float64)

    def fun(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return _residuals(rel, q, unpack, w, plumb=plumb, fixed_r=fixed_r)

    x0 = [p0[0] - centre[0], p0[1] - centre[1]] + ([] if plumb else [a0[0] / a0[2], a0[1] / a0[2]])
    if not fixed_r:
        x0.append(start.radius)
    if loss not in ("soft_l1", "linear"):
        raise ValueError(f"loss {loss!r}: 'soft_l1' or 'linear' expected")
    scale = f_scale if loss == "soft_l1" else None
    budget = MAX_NFEV_PER_PARAMETER * len(x0)
    sol = soft_l1_least_squares(fun, np.array(x0), f_scale=scale, x_scale=0.01, max_nfev=budget)
    shrink = _random_effects(sol.fun, groups) if groups is not None and random_effects else None
    if shrink is not None:
        inv, c_g = shrink
        n_g = np.bincount(inv)

        def fun_gls(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            both = np.column_stack(fun(q))
            means = np.stack([np.bincount(inv, weights=col) for col in both.T], axis=1) / n_g[:, None]
            both -= c_g[inv, None] * means[inv]
            return both[:, 0], both[:, 1:]

        sol = soft_l1_least_squares(fun_gls, sol.x, f_scale=scale, x_scale=0.01, max_nfev=budget)
    c, a, r = unpack(sol.x)
    cov = _sandwich(sol.jac, sol.fun, groups)
    if plumb:  # the layout of a free axis, its slopes held
        keep = [0, 1] + ([] if fixed_r else [4])
        full = np.zeros((4 + (not fixed_r),) * 2)
        full[np.ix_(keep, keep)] = cov
        cov = full
    return Cylinder(c + shift, a, r), cov


def _residuals(rel: np.ndarray, q: np.ndarray, unpack: Any, w: Any, *, plumb: bool, fixed_r: bool
               ) -> tuple[np.ndarray, np.ndarray]:
    """The weighted point-to-cylinder distances less the radius, and their derivatives with
    respect to (x, y[, ax, ay][, r])."""
    c, a, r = unpack(q)
    # by coordinate, into one Jacobian: a fit makes thousands of these calls on a few
    # hundred soundings, where each temporary array costs more than its arithmetic
    dx, dy, dz = rel[:, 0] - c[0], rel[:, 1] - c[1], rel[:, 2] - c[2]
    s = dx * a[0] + dy * a[1] + dz * a[2]
    dist = np.sqrt(np.maximum(dx * dx + dy * dy + dz * dz - s * s, 0.0))
    inv = 1.0 / np.maximum(dist, 1e-12)
    ex, ey = (s * a[0] - dx) * inv, (s * a[1] - dy) * inv  # minus the unit radial, x and y
    jac = np.empty((len(dx), 2 + (0 if plumb else 2) + (0 if fixed_r else 1)))
    jac[:, 0], jac[:, 1] = ex, ey
    if not plumb:
        norm = math.sqrt(q[2] ** 2 + q[3] ** 2 + 1.0)
        jac[:, 2], jac[:, 3] = s * ex / norm, s * ey / norm
    if not fixed_r:
        jac[:, -1] = -1.0
    f = dist - r
    if np.ndim(w) or w != 1.0:
        f *= w
        jac *= np.reshape(w, (-1, 1))
    return f, jac


def _random_effects(res: np.ndarray, groups: np.ndarray, discount: float = 0.25
                    ) -> tuple[np.ndarray, np.ndarray] | None:
    """Per-cluster shrink factors of a random-effects (GLS) fit, from first-pass residuals.

    Errors common to a ping (position, heave, roll) make its soundings equicorrelated:
    ``var = s_e^2 I + s_p^2 11'``. Subtracting ``c_g`` times the ping mean from each
    residual, ``c_g = 1 - sqrt(s_e^2 / (s_e^2 + n_g s_p^2))``, whitens them, so that a ping
    with many soundings no longer counts as many independent ones. The ping variance
    enters at ``discount`` times its estimate: full GLS leans hard on the few-sounding
    pings (far, grazing, noisy) and on the shape within each ping, which noise biases. A
    quarter (20 seeds of the jacket preset, against none, a half and all of it) gave the
    smallest spacing errors at default and at double noise, with calibrated sigmas. None
    when there are too few pings or no common part to remove.
    """
    _, inv = np.unique(groups, return_inverse=True)
    n_g = np.bincount(inv).astype(np.float64)
    n_groups, n = len(n_g), len(res)
    if n_groups < 5 or n - n_groups < 5:
        return None
    mean_g = np.bincount(inv, weights=res) / n_g
    s_e2 = float(np.sum((res - mean_g[inv]) ** 2)) / (n - n_groups)
    s_p2 = float(np.mean(mean_g**2)) - s_e2 * float(np.mean(1.0 / n_g))
    if not (s_e2 > 0 and s_p2 > 0):
        return None
    return inv, 1.0 - np.sqrt(s_e2 / (s_e2 + discount * n_g * s_p2))


def _sandwich(J: np.ndarray, res: np.ndarray, groups: np.ndarray | None) -> np.ndarray:
    """Covariance of least-squares parameters, cluster-robust when ``groups`` is given."""
    n, k = J.shape
    try:
        bread = np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        return np.full((k, k), np.nan)
    if groups is None:
        s2 = float(res @ res) / max(n - k, 1)
        return bread * s2
    score = J * res[:, None]
    _, inv = np.unique(groups, return_inverse=True)
    g = np.zeros((inv.max() + 1, k))
    np.add.at(g, inv, score)
    ng = g.shape[0]
    meat = g.T @ g
    adj = ng / max(ng - 1, 1) * (n - 1) / max(n - k, 1)
    return adj * bread @ meat @ bread


def cylinder_msac(points: np.ndarray, normals: np.ndarray, *, radius: float, threshold: float,
                  max_tilt_deg: float = 15.0, seed: int | np.random.Generator | None = 0,
                  max_trials: int = 500, free_radius: bool = False) -> RobustResult[Cylinder]:
    """MSAC for a cylinder of prior ``radius``, with least-squares local optimisation.

    Two points and their normals propose an axis (:func:`cylinder_from_normals`) with the
    prior radius; the best hypothesis is refined by :func:`fit_cylinder` on its inliers
    (kept while it scores better), so a rough proposal from noisy normals still ends on
    the right model. With ``free_radius`` the refinement also fits the radius, so a prior
    a few centimetres off (design tolerance, marine growth) is corrected by the data.

    Parameters
    ----------
    points, normals : ndarray, shape (N, 3)
        Side points (m) and their unit normals.
    radius : float
        Prior radius (m).
    threshold : float
        Inlier distance (m).
    max_tilt_deg : float
        Largest tilt of a hypothesis (deg).
    seed : int
    max_trials : int
    free_radius : bool
        Let the local optimisation fit the radius.

    Returns
    -------
    RobustResult
    """
    data = np.hstack([np.asarray(points, np.float64)[:, :3], np.asarray(normals, np.float64)])

    def refine(rows: np.ndarray, model: Cylinder) -> Cylinder | None:
        if len(rows) < 6:
            return None
        try:
            return fit_cylinder(rows[:, :3], model, radius=None if free_radius else radius,
                                f_scale=threshold)[0]
        except (ValueError, np.linalg.LinAlgError):
            return None

    return msac(data, lambda rows: cylinder_from_normals(rows, radius=radius, max_tilt_deg=max_tilt_deg),
                lambda m, rows: m.residuals(rows), 2, threshold, seed=seed, max_trials=max_trials,
                refine=refine)
