"""Two surveys of one place brought onto one frame: the vertical offset, the plan shift and
a small rotation that best lay the after survey's seabed on the before survey's, estimated
from the seabed both share away from the objects, with their uncertainty.

The after survey's cell medians ``a(p)`` are compared with the before survey's seabed ``b``
sampled where the registration carries each cell: ``q = p - d - theta * perp(p - c)``
(``d`` the plan shift, ``theta`` the rotation about the shared seabed's centre ``c``),
``a(p) = b(q) + dz``. Gauss-Newton on every usable cell, cells that disagree by more than
three robust sigmas left out (seabed that changed: sand waves, dumped rock, scour). The
residuals of neighbouring cells share their survey lines' errors, so the covariance is
the cluster-robust one over blocks of the seabed, widened by Student's quantile for the
few blocks: a 95 % bound of 1.96 sigma holds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.special import stdtrit

from .grid import Grid

__all__ = ["Registration", "register", "IDENTITY"]


@dataclass(frozen=True)
class Registration:
    """The after survey's offset from the before survey (after minus before).

    Attributes
    ----------
    dx, dy, dz : float
        Plan shift and vertical offset (m).
    rotation_deg : float
        Rotation (deg, clockwise seen from above, about ``centre``); 0 when not estimated.
    sigma_dx, sigma_dy, sigma_dz, sigma_rotation_deg : float
        Their 1-sigma (NaN: not estimated).
    centre : (x, y)
        The point the rotation turns about (the shared seabed's centre, m).
    area : float
        The seabed used (m²), and ``cells`` its cells.
    residual_rms : float
        The cells' robust residual spread after registration (m): the noise of the
        difference map.
    blocks : int
        The clusters the covariance was estimated over.
    note : str
        Why a part could not be estimated, or empty.
    cov : ndarray
        The covariance of ``(dx, dy, dz, theta_rad)``.
    ties : int
        The objects that kept their place on which the plan shift was refined
        (:func:`~mbinspect.change.tie.tie_to_objects`); 0: the seabed's alone.
    """

    dx: float
    dy: float
    dz: float
    rotation_deg: float
    sigma_dx: float
    sigma_dy: float
    sigma_dz: float
    sigma_rotation_deg: float
    centre: tuple[float, float]
    area: float
    cells: int
    residual_rms: float
    blocks: int
    note: str = ""
    cov: np.ndarray = field(default_factory=lambda: np.full((4, 4), np.nan), repr=False, compare=False)
    ties: int = 0

    def to_before(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Plan positions of the after survey carried into the before survey's frame."""
        th = math.radians(-self.rotation_deg)  # clockwise positive in the record
        rx, ry = np.asarray(x) - self.centre[0], np.asarray(y) - self.centre[1]
        return x - self.dx - th * (-ry), y - self.dy - th * rx

    def plan_cov(self, x: float, y: float) -> np.ndarray:
        """The 2x2 covariance (m²) the registration adds to a position carried to the before
        frame at ``(x, y)``."""
        if not np.all(np.isfinite(self.cov[[0, 1, 3]][:, [0, 1, 3]])):
            return np.diag([self.sigma_dx**2, self.sigma_dy**2]) if math.isfinite(self.sigma_dx) \
                else np.zeros((2, 2))
        rx, ry = x - self.centre[0], y - self.centre[1]
        a = np.array([[1.0, 0.0, 0.0, -ry], [0.0, 1.0, 0.0, rx]])
        return a @ self.cov @ a.T

    def to_dict(self) -> dict[str, Any]:
        from ..outputs import to_jsonable

        return to_jsonable({"dx": self.dx, "dy": self.dy, "dz": self.dz, "rotation_deg": self.rotation_deg,
                "sigma_dx": self.sigma_dx, "sigma_dy": self.sigma_dy, "sigma_dz": self.sigma_dz,
                "sigma_rotation_deg": self.sigma_rotation_deg, "centre": list(self.centre),
                "area": self.area, "cells": self.cells, "residual_rms": self.residual_rms,
                "blocks": self.blocks, "note": self.note, "ties": self.ties,
                "cov": [[float(v) for v in row] for row in self.cov]})

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Registration:
        def num(k: str) -> float:
            return math.nan if d.get(k) is None else float(d[k])

        cov = np.array([[math.nan if v is None else v for v in row] for row in d["cov"]], np.float64)
        return cls(num("dx"), num("dy"), num("dz"), num("rotation_deg"), num("sigma_dx"), num("sigma_dy"),
                   num("sigma_dz"), num("sigma_rotation_deg"), (float(d["centre"][0]), float(d["centre"][1])),
                   num("area"), int(d["cells"]), num("residual_rms"), int(d["blocks"]),
                   str(d.get("note", "")), cov, int(d.get("ties", 0)))


#: No offset, nothing known: what a comparison uses when no seabed is shared.
IDENTITY = Registration(0.0, 0.0, 0.0, 0.0, math.nan, math.nan, math.nan, math.nan, (0.0, 0.0), 0.0, 0,
                        math.nan, 0, "no seabed shared away from the objects: the surveys are compared as "
                        "they are")

#: The finer mean of :func:`texture` (cells).
FINE = 1.0

#: Fewest usable cells for a registration; fewest blocks for its covariance.
MIN_CELLS, MIN_BLOCKS = 50, 6

#: A rotation is estimated only when the seabed holds it: its 1-sigma (deg) below this.
ROTATION_HELD_DEG = 0.05


def register(before: Grid, after: Grid, usable: np.ndarray, *, rotation: bool = True,
             iterations: int = 10, smooth: float = 3.0) -> Registration:
    """The offset of the after survey's seabed from the before survey's.

    Parameters
    ----------
    before, after : Grid
        Cell medians of each survey's soundings (the same cell; any extent).
    usable : ndarray of bool
        Shaped like both grids (one lattice): the cells that may be used (away from the
        objects).
    rotation : bool
        Estimate a rotation too (kept only when the seabed holds it).
    iterations : int
    smooth : float
        The scale (m) of the relief removed before the plan is fitted (:func:`texture`).

    Returns
    -------
    Registration
    """
    x, y = after.centres()
    ok = usable & np.isfinite(after.z)
    px, py, a = x[ok], y[ok], after.z[ok]
    if len(a) < MIN_CELLS:
        return IDENTITY
    c = (float(px.mean()), float(py.mean()))
    # the plan from the seabed's texture: a vertical error that varies smoothly (a line's
    # offset, a refraction smile) would otherwise pass for a shift along the regional slope
    away = Grid(before.x0, before.y0, before.cell, np.where(usable, before.z, np.nan), before.n)
    tb = texture(away, smooth)
    ta = texture(Grid(after.x0, after.y0, after.cell, np.where(usable, after.z, np.nan), after.n), smooth)
    fit = _solve(tb, px, py, ta.z[ok], c, rotation, iterations)
    if fit is not None and rotation and math.degrees(math.sqrt(max(fit[1][3, 3], 0.0))) > ROTATION_HELD_DEG:
        fit = _solve(tb, px, py, ta.z[ok], c, False, iterations)
        note = "the seabed does not hold a rotation: none estimated"
    else:
        note = "" if rotation else "no rotation estimated (not asked)"
    if fit is None:
        return IDENTITY
    p, cov, rms, used, blocks = fit
    jack = _jackknife(tb, px, py, ta.z[ok], c, bool(cov[3, 3] > 0), iterations)
    if jack is not None:  # each parameter's larger variance, the sandwich's correlations
        sd, wide = np.sqrt(np.maximum(np.diag(cov), 0.0)), np.sqrt(np.maximum(np.diag(jack), np.diag(cov)))
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = np.where(np.outer(sd, sd) > 0, cov / np.outer(sd, sd), 0.0)
        cov = corr * np.outer(wide, wide)
    # the vertical offset from the whole seabed, carried by the plan fit
    vert = _vertical(before, px, py, a, c, p)
    if vert is None:
        return IDENTITY
    p[2], cov[2, 2], rms = vert[0], vert[1], vert[2]
    cov[2, :2] = cov[:2, 2] = cov[2, 3] = cov[3, 2] = 0.0
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    return Registration(float(p[0]), float(p[1]), float(p[2]), -math.degrees(p[3]), float(sd[0]),
                        float(sd[1]), float(sd[2]), math.degrees(sd[3]) if cov[3, 3] > 0 else math.nan, c,
                        used * after.cell**2, used, rms, blocks, note, cov)


def texture(g: Grid, scale: float) -> Grid:
    """The grid's relief between one cell and ``scale`` m: a Gaussian mean over a cell minus
    one over ``scale`` (empty cells left out of both). The finer mean keeps the cells'
    own noise from favouring a shift of half a cell (between cells, a bilinear sample
    averages that noise away, and a fit would chase the smaller residuals there)."""
    have = np.isfinite(g.z)
    fine, cover = _mean(g.z, have, FINE)
    coarse, _ = _mean(g.z, have, scale / g.cell)
    return Grid(g.x0, g.y0, g.cell, np.where(have & (cover > 0.5), fine - coarse, np.nan), g.n)


def _mean(z: np.ndarray, have: np.ndarray, sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """A Gaussian mean of the filled cells (``sigma`` in cells), and the share filled."""
    from scipy.ndimage import gaussian_filter

    num = gaussian_filter(np.where(have, z, 0.0), sigma, mode="nearest")
    den = gaussian_filter(have.astype(np.float64), sigma, mode="nearest")
    with np.errstate(invalid="ignore", divide="ignore"):
        return num / den, den


def _vertical(before: Grid, px: np.ndarray, py: np.ndarray, a: np.ndarray, c: tuple[float, float],
              p: np.ndarray) -> tuple[float, float, float] | None:
    """The vertical offset with the plan fitted: the robust mean of after minus before over
    the shared seabed, its variance (blocks as clusters) and the cells' residual spread."""
    rx, ry = px - c[0], py - c[1]
    b, _, _ = before.sample(px - p[0] + p[3] * ry, py - p[1] - p[3] * rx)
    e = a - b
    good = np.isfinite(e)
    if good.sum() < MIN_CELLS:
        return None
    med = float(np.median(e[good]))
    mad = 1.4826 * float(np.median(np.abs(e[good] - med)))
    use = good & (np.abs(e - med) <= max(3 * mad, 1e-6))
    dz = float(e[use].mean())
    cov, _ = _cluster_cov(-np.ones((int(use.sum()), 1)), e[use] - dz, px[use], py[use])
    if cov is None:
        return None
    return dz, float(cov[0, 0]), mad


def _solve(before: Grid, px: np.ndarray, py: np.ndarray, a: np.ndarray, c: tuple[float, float],
           rotation: bool, iterations: int) -> tuple[np.ndarray, np.ndarray, float, int, int] | None:
    """Gauss-Newton with robust trimming; the parameters, their covariance, the residual
    spread, the cells used and the blocks."""
    p = np.zeros(4)
    rx, ry = px - c[0], py - c[1]
    keep = np.ones(len(a), bool)
    for it in range(iterations):
        qx, qy = px - p[0] + p[3] * ry, py - p[1] - p[3] * rx
        b, gx, gy = before.sample(qx, qy)
        e = a - b - p[2]
        good = np.isfinite(e) & np.isfinite(gx) & np.isfinite(gy)
        if good.sum() < MIN_CELLS:
            return None
        if it > 0:
            med = float(np.median(e[good & keep]))
            mad = 1.4826 * float(np.median(np.abs(e[good & keep] - med)))
            keep = np.abs(e - med) <= max(3 * mad, 1e-6)
        use = good & keep
        jac = np.column_stack([gx, gy, -np.ones_like(gx), gx * -ry + gy * rx])[use]
        if not rotation:
            jac[:, 3] = 0.0
        step = np.linalg.lstsq(jac[:, :4] if rotation else jac[:, :3], -e[use], rcond=None)[0]
        p[: len(step)] += step
        if np.all(np.abs(step[:2]) < 1e-4) and abs(step[2]) < 1e-5 and it > 1:
            break
    qx, qy = px - p[0] + p[3] * ry, py - p[1] - p[3] * rx
    b, gx, gy = before.sample(qx, qy)
    e = a - b - p[2]
    use = np.isfinite(e) & np.isfinite(gx) & np.isfinite(gy) & keep
    k = 4 if rotation else 3
    jac = np.column_stack([gx, gy, -np.ones_like(gx), gx * -ry + gy * rx])[use][:, :k]
    cov_k, blocks = _cluster_cov(jac, e[use], px[use], py[use])
    if cov_k is None:
        return None
    cov = np.zeros((4, 4))
    cov[:k, :k] = cov_k
    rms = 1.4826 * float(np.median(np.abs(e[use] - np.median(e[use]))))
    return p, cov, rms, int(use.sum()), blocks


def _jackknife(before: Grid, px: np.ndarray, py: np.ndarray, a: np.ndarray, c: tuple[float, float],
               rotation: bool, iterations: int) -> np.ndarray | None:
    """The plan's covariance from the fit again without each block of the seabed in turn (a
    delete-one jackknife, widened by Student's quantile): where the seabed's relief is faint
    beside its noise, the gradients the fit leans on are noisy too, and the sandwich alone
    is too sure of itself."""
    span = max(float(np.ptp(px)), float(np.ptp(py)), 1.0)
    side = max(span / 5.0, 10.0)
    _, inv = np.unique(np.floor((px - px.min()) / side) * 1e6 + np.floor((py - py.min()) / side),
                       return_inverse=True)
    g = int(inv.max()) + 1
    if g < MIN_BLOCKS:
        return None
    est = []
    for k in range(g):
        m = inv != k
        fit = _solve(before, px[m], py[m], a[m], c, rotation, iterations)
        if fit is None:
            return None
        est.append(fit[0])
    d = np.asarray(est) - np.mean(est, axis=0)
    widen = (float(stdtrit(g - 1, 0.975)) / 1.959963984540054) ** 2
    return d.T @ d * (g - 1) / g * widen


def _cluster_cov(jac: np.ndarray, e: np.ndarray, x: np.ndarray, y: np.ndarray
                 ) -> tuple[np.ndarray | None, int]:
    """The sandwich covariance of a least-squares step with parts of the seabed as clusters,
    each widened by Student's quantile for their number: square blocks (about 25), and
    strips east-west and north-south (a survey line's error runs the length of the line);
    of the three, the one with the largest variance of the parameters."""
    span = max(float(np.ptp(x)), float(np.ptp(y)), 1.0)
    side = max(span / 5.0, 10.0)
    strip = max(span / 10.0, 10.0)
    i, j = np.floor((x - x.min()) / side), np.floor((y - y.min()) / side)
    ways = (i * 1e6 + j, np.floor((x - x.min()) / strip), np.floor((y - y.min()) / strip))
    bread = np.linalg.pinv(jac.T @ jac)
    best, blocks = None, 0
    for groups in ways:
        _, inv = np.unique(groups, return_inverse=True)
        g = int(inv.max()) + 1
        if g < MIN_BLOCKS:
            continue
        sums = np.zeros((g, jac.shape[1]))
        np.add.at(sums, inv, jac * e[:, None])
        widen = (float(stdtrit(g - 1, 0.975)) / 1.959963984540054) ** 2
        cov = bread @ (sums.T @ sums * g / (g - 1)) @ bread * widen
        if best is None or np.trace(cov) > np.trace(best):
            best, blocks = cov, g
    return best, blocks
