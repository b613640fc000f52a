"""Small robust least squares: the problem :func:`scipy.optimize.least_squares` solves with
``loss="soft_l1"``, for the few parameters of a pile's cylinder fitted thousands of times.

SciPy's trust-region solver spends about 3 ms of Python on each such fit, whatever the
soundings (an SVD, norms and wrappers per step): a survey's piles are fitted some 1,200
times (the line jackknife, the passes through the beam), and a plan fits them for every
simulated survey. Here the same cost (soft L1 of the residuals at ``f_scale``) is
minimised by Levenberg-Marquardt on the normal equations, residuals and Jacobian computed
together, with the loss folded into them as SciPy folds it (Triggs' correction), so that
the Jacobian returned is the one whose ``J.T @ J`` approximates the cost's Hessian at the
solution, as SciPy's ``jac`` is; its stopping tests are SciPy's (``ftol``, ``xtol``,
``gtol``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["RobustSolution", "soft_l1_least_squares"]

#: Smallest weight a residual's slope may take after the loss is folded in (SciPy's floor).
_EPS = np.finfo(float).eps


@dataclass(frozen=True)
class RobustSolution:
    """The parameters found, the residuals there, the Jacobian with the loss folded in, the
    cost (half the summed loss) and the residual evaluations spent."""

    x: np.ndarray
    fun: np.ndarray
    jac: np.ndarray
    cost: float
    nfev: int


def _soft_l1(f: np.ndarray, f_scale: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The loss, its first and second derivatives with respect to ``f**2`` (SciPy's ``rho``)."""
    t = 1.0 + (f / f_scale) ** 2
    s = np.sqrt(t)
    return 2.0 * f_scale**2 * (s - 1.0), 1.0 / s, -0.5 / (t * s * f_scale**2)


def _folded(f: np.ndarray, J: np.ndarray, f_scale: float | None) -> tuple[float, np.ndarray, np.ndarray]:
    """The cost, and the residuals and Jacobian with the loss folded in (none: ``f_scale`` None)."""
    if f_scale is None:
        return 0.5 * float(f @ f), f, J
    rho0, rho1, rho2 = _soft_l1(f, f_scale)
    w = np.sqrt(np.maximum(rho1 + 2.0 * rho2 * f**2, _EPS))
    return 0.5 * float(rho0.sum()), f * (rho1 / w), J * w[:, None]


def soft_l1_least_squares(fun: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]], x0: np.ndarray, *,
                          f_scale: float | None, x_scale: float = 1.0, ftol: float = 1e-8, xtol: float = 1e-8,
                          gtol: float = 1e-8, max_nfev: int | None = None) -> RobustSolution:
    """Minimise ``0.5 * sum(rho(f(x)**2))``, ``rho`` the soft L1 loss at ``f_scale``.

    Parameters
    ----------
    fun : callable
        ``fun(x) -> (f, J)``: the residuals (m,) and their Jacobian (m, n) at ``x``.
    x0 : ndarray, shape (n,)
    f_scale : float or None
        Residuals below it count as in least squares, above it about linearly; None: plain
        least squares (SciPy's ``loss="linear"``).
    x_scale : float
        The parameters' characteristic size (the damping's units).
    ftol, xtol, gtol : float
        Stop when a step lowers the cost by less than ``ftol`` of it, moves the parameters by
        less than ``xtol`` of their size, or the gradient's largest component is under ``gtol``.
    max_nfev : int, optional
        Most residual evaluations (default 100 per parameter).

    Returns
    -------
    RobustSolution

    Examples
    --------
    >>> x = np.linspace(0, 1, 50); y = 2 * x + 1; y[7] += 5  # one outlier
    >>> sol = soft_l1_least_squares(lambda q: (q[0] * x + q[1] - y, np.column_stack([x, np.ones(50)])),
    ...                             np.zeros(2), f_scale=0.1)
    >>> np.round(sol.x, 2).tolist()  # the outlier pulls by about f_scale / 50, not by 5 / 50
    [1.99, 1.01]
    """
    x = np.asarray(x0, np.float64).copy()
    n = len(x)
    max_nfev = 100 * n if max_nfev is None else max_nfev
    f_true, J_true = fun(x)
    nfev = 1
    cost, f, J = _folded(f_true, J_true, f_scale)
    lam = None
    nu = 2.0
    while nfev < max_nfev:
        g = J.T @ f
        if np.max(np.abs(g), initial=0.0) < gtol:
            break
        A = J.T @ J
        if lam is None:  # Nielsen's start: a thousandth of the largest curvature, in x_scale units
            lam = 1e-3 * float(np.max(np.diag(A))) * x_scale**2 or 1e-3
        step = _damped_step(A, g, lam / x_scale**2)
        if step is None:
            break
        predicted = -(g @ step + 0.5 * step @ A @ step)
        f_new, J_new = fun(x + step)
        nfev += 1
        if not np.all(np.isfinite(f_new)):
            lam *= nu
            nu *= 2.0
            continue
        cost_new, f_fold, J_fold = _folded(f_new, J_new, f_scale)
        reduction = cost - cost_new
        small_step = math.sqrt(step @ step) < xtol * (xtol + math.sqrt(x @ x))
        if reduction > 0:
            ratio = reduction / predicted if predicted > 0 else 1.0
            x = x + step
            f_true, cost, f, J = f_new, cost_new, f_fold, J_fold
            lam *= max(1.0 / 3.0, 1.0 - (2.0 * ratio - 1.0) ** 3)
            nu = 2.0
            if (reduction < ftol * (cost + reduction) and ratio > 0.25) or small_step:
                break
        else:
            if small_step:
                break
            lam *= nu
            nu *= 2.0
    return RobustSolution(x, f_true, J, cost, nfev)


def _damped_step(A: np.ndarray, g: np.ndarray, lam: float) -> np.ndarray | None:
    """The Levenberg-Marquardt step ``-(A + lam I)^-1 g``, or None when it cannot be taken."""
    try:
        step = np.linalg.solve(A + lam * np.eye(len(g)), -g)
    except np.linalg.LinAlgError:
        return None
    return step if np.all(np.isfinite(step)) else None
