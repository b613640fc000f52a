"""Stage 4b: the paper's intersection method (cylinder axis met with the top plane)."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ..checks import one_of
from ..errors import DataError
from ..fit import Cylinder, Plane, cylinder_msac, fit_cylinder, msac
from ..options import CHOICES

__all__ = ["intersection_method", "side_coverage", "refit_cylinder"]


def side_coverage(cyl: Cylinder, pts: np.ndarray, bin_deg: float = 5.0) -> float:
    """The arc of a cylinder's side (deg) holding points: occupied ``bin_deg`` sectors.

    Parameters
    ----------
    cyl : Cylinder
    pts : ndarray, shape (N, 3)
        Side points (m).
    bin_deg : float
        Sector width (deg).

    Returns
    -------
    float
        0 to 360 deg.

    Examples
    --------
    >>> cyl = Cylinder(np.zeros(3), np.array([0.0, 0.0, 1.0]), 0.75)
    >>> a = np.radians(np.arange(0, 90, 1.0))
    >>> side_coverage(cyl, np.column_stack([np.cos(a), np.sin(a), np.zeros_like(a)]))
    90.0
    """
    if len(pts) == 0:
        return 0.0
    ang = np.degrees(cyl.angles(pts))
    hist = np.bincount((ang // bin_deg).astype(np.int64) % int(360 / bin_deg),
                       minlength=int(360 / bin_deg))
    return float((hist > 0).sum() * bin_deg)


#: With ``axis_mode="auto"``, a tilt whose slopes lie within this chi-square (2 degrees of
#: freedom, 99.9 %) of vertical, by their own covariance, and whose 1-sigma exceeds
#: :data:`PLUMB_MIN_SIGMA_DEG`, is not shown by the data: the axis is held plumb. A tilt
#: known to a fraction of a degree is kept even when small: a pile leaning 0.2 deg moves
#: its top 0.8 cm from its mid-height in 2.5 m (on the simulator every tilt is known to
#: 0.1-0.3 deg and none is held). On a real line the fit's own covariance of a tilt is too
#: small: plumb piles injected into the EM3000 line showed tilts of 1.1-3.1 deg at 2.9-3.1
#: of their 1-sigmas of 0.7-1.2 deg, carried 2-4 cm up to the top (at 95 % and 1 deg the
#: worst spacing there was 3.4 cm, now 2.3 cm; the KMALL strip and the simulator unchanged).
PLUMB_CHI2 = 13.8
PLUMB_MIN_SIGMA_DEG = 0.6

#: Degrees beyond ``max_tilt_deg`` that a top plane may lean (a top is level or square to
#: its pile) before :func:`intersection_method` takes it square to the axis instead.
TOP_LEAN_MARGIN_DEG = 5.0


def intersection_method(side: np.ndarray, side_normals: np.ndarray, top: np.ndarray, *,
                        radius: float, threshold: float = 0.06, max_tilt_deg: float = 15.0,
                        seed: int = 0, groups: np.ndarray | None = None,
                        start: Cylinder | None = None, radius_mode: str = "auto",
                        min_free_coverage_deg: float = 150.0, max_free_sigma: float = 0.005,
                        side_sigma: np.ndarray | None = None, axis_mode: str = "auto",
                        ) -> tuple[Cylinder, Plane, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                   list[str], bool]:
    """The paper's intersection method, made robust and unbiased.

    A cylinder by MSAC on the side points (two points with their normals propose an axis
    of the prior ``radius``), refined by least squares on true orthogonal distances with
    a robust loss; a plane fitted (MSAC, then least squares) to the top; the centre is
    where the axis meets that plane.

    ``radius_mode`` "fixed" keeps the prior radius (the paper); "free" fits it; "auto"
    (default) fits it when the side is scanned over at least ``min_free_coverage_deg``,
    the fitted radius has a 1-sigma of at most ``max_free_sigma`` m and it differs from
    the prior by more than 3 sigma and 5 mm (the data reject the prior); else the prior
    is kept, which is more precise. A wrong fixed radius shifts the centre toward the
    scanned side.

    A top that no beam reached (fewer than 3 top points: a pile sounded on its side only)
    is taken square to the axis at the one or two top soundings, or at the side's highest
    three: the centre is where the axis reaches them, the top stands at least that high,
    and a note says so (before, such a pile fell back to the centre method on those few
    soundings, 30-40 cm off).

    A top plane that leans more than :data:`TOP_LEAN_MARGIN_DEG` beyond ``max_tilt_deg``
    cannot be a pile's top (a few top soundings along one ping let a plane turn about
    their line, and the axis then meets it metres away): the top is taken square to the
    axis through the top points' median instead, and a note says so.

    Parameters
    ----------
    side : ndarray, shape (N, 3)
        Side points (m).
    side_normals : ndarray, shape (N, 3)
        Their unit normals (:func:`mbinspect.segment.normals`).
    top : ndarray, shape (M, 3)
        Top-face points (m).
    radius : float
        Prior radius (m).
    threshold : float
        Inlier distance (m); the top plane's is half of it.
    max_tilt_deg : float
        Largest tilt of a cylinder hypothesis (deg).
    seed : int
        MSAC seed.
    groups : ndarray (N,), optional
        Ping of each side point.
    start : Cylinder, optional
        A cylinder from the previous iteration (skips MSAC).
    radius_mode : {"auto", "each", "fixed", "free"}
        "each" is "auto" here (it differs only in :func:`~mbinspect.piles.locate_piles`,
        which then takes no joint radius).
    min_free_coverage_deg, max_free_sigma : float
        When ``auto`` may fit the radius (deg, m).
    side_sigma : ndarray (N,), optional
        Each side point's noise (m): the least-squares cylinder weighs the points by it.
    axis_mode : {"auto", "free"}
        "free" always fits the tilt (the paper); "auto" holds the axis plumb where the
        fitted tilt is within :data:`PLUMB_CHI2` of vertical by its own covariance and
        known no better than :data:`PLUMB_MIN_SIGMA_DEG`, if it leans within
        ``max_tilt_deg`` (beyond, the fit says it is no pile). A
        tilt the data do not show, carried from the side's mid-height to a top found
        low (a few top soundings, the band on the side), shifts the centre by the height
        times its tangent: 8 cm on the real EM3000 line. The plan covariance then adds
        that height squared times the slopes' covariance, the tilt the data allow.

    Returns
    -------
    cylinder, plane, centre (3,), side_inliers, top_inliers, cov (4, 4), notes, tilt_held
        ``cov`` is the cluster-robust covariance of (x, y, ax, ay) at the top; ``notes``
        what was done where the data did not allow the plain method (list of str);
        ``tilt_held`` whether the axis was held plumb (``axis_mode`` "auto").

    Raises
    ------
    DataError
        Too few side points, or no model fits.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> a, z = rng.uniform(0, 2 * np.pi, 800), rng.uniform(-19, -16.3, 800)
    >>> side = np.column_stack([0.75 * np.cos(a) + 3, 0.75 * np.sin(a) + 4, z])
    >>> nrm = np.column_stack([np.cos(a), np.sin(a), np.zeros_like(a)])
    >>> r, t = 0.6 * np.sqrt(rng.uniform(0, 1, 300)), rng.uniform(0, 2 * np.pi, 300)
    >>> top = np.column_stack([r * np.cos(t) + 3, r * np.sin(t) + 4, np.full(300, -16.0)])
    >>> cyl, plane, centre, *_ = intersection_method(side, nrm, top, radius=0.75)
    >>> np.round(centre, 3).tolist()
    [3.0, 4.0, -16.0]

    The same side with no top sounded: the plan centre holds, the top is a lower bound.

    >>> cyl, plane, centre, s_in, t_in, cov, notes, held = intersection_method(
    ...     side, nrm, top[:0], radius=0.75)
    >>> np.round(centre[:2], 3).tolist(), bool(centre[2] < -16.0), notes[0][:15]
    ([3.0, 4.0], True, 'top not sounded')
    """
    one_of("radius_mode", radius_mode, CHOICES["radius_mode"])
    if radius_mode == "each":  # the piles' joint radius is not this stage's: per pile, it is auto
        radius_mode = "auto"
    s = np.asarray(side, np.float64)
    t = np.asarray(top, np.float64).reshape(-1, 3)
    if len(s) < 6:
        raise DataError(f"intersection method: {len(s)} side points, at least 6 needed")
    shift = np.r_[s[:, :2].mean(axis=0), 0.0]
    ls, lt = s - shift, t - shift
    sounded = len(t) >= 3
    plane, level, lean, lt, z_top = _top_plane(ls, lt, sounded, threshold=threshold, seed=seed,
                                               max_tilt_deg=max_tilt_deg)
    if start is None:
        res = cylinder_msac(ls, side_normals, radius=radius, threshold=threshold,
                            max_tilt_deg=max_tilt_deg, seed=seed, free_radius=radius_mode != "fixed")
        if res.model is None:
            raise DataError("intersection method: no cylinder fits the side points")
        cyl0 = res.model
    else:
        cyl0 = Cylinder(start.point - shift, start.axis, start.radius)
    g = None if groups is None else np.asarray(groups)

    def refit(model: Cylinder, r: float | None, plumb: bool = False
              ) -> tuple[Cylinder, np.ndarray, np.ndarray]:
        return refit_cylinder(ls, model, r, threshold=threshold, z_top=z_top, groups=g, sigma=side_sigma,
                              plumb=plumb)

    cyl, cov, inl = refit(cyl0 if radius_mode != "fixed" else Cylinder(cyl0.point, cyl0.axis, radius),
                          None if radius_mode != "fixed" else radius)
    if radius_mode == "auto" and _keeps_prior(cyl, cov, ls[inl], radius, min_free_coverage_deg,
                                              max_free_sigma):
        cyl, cov, inl = refit(Cylinder(cyl.point, cyl.axis, radius), radius)
    notes = [] if sounded else [f"top not sounded ({len(t)} top points): the centre is where the axis "
                                "reaches the highest soundings, the top stands at least that high"]
    plumb = _held_plumb(cyl, cov, refit, ls, z_top, max_tilt_deg,
                        None if radius_mode == "free" or cyl.radius != radius else radius) \
        if axis_mode == "auto" else None
    held = plumb is not None
    if plumb is not None:
        cyl, cov, inl = plumb
    if not level or not sounded:
        plane = Plane(np.median(lt, axis=0), cyl.axis if cyl.axis[2] >= 0 else -cyl.axis)
    if not level:
        notes.append(f"the top points' plane leans {lean:.0f} deg: top taken square to the axis")
    centre = cyl.intersect(plane)
    if centre is None:
        raise DataError("intersection method: the axis is parallel to the top plane")
    out_cyl = Cylinder(cyl.point + shift, cyl.axis, cyl.radius)
    out_plane = Plane(plane.point + shift, plane.normal)
    top_in = np.abs(plane.residuals(t - shift)) <= threshold / 2
    return out_cyl, out_plane, centre + shift, inl, top_in, cov, notes, held


def _keeps_prior(cyl: Cylinder, cov: np.ndarray, inliers: np.ndarray, radius: float, min_coverage_deg: float,
                 max_sigma: float) -> bool:
    """Whether the prior radius stands against the free fit: a free radius costs precision,
    so the prior is kept unless the data reject it, seen over enough of the side and known
    well enough."""
    r_sigma = math.sqrt(max(float(cov[4, 4]), 0.0)) if cov.shape[0] > 4 else math.inf
    rejected = abs(cyl.radius - radius) > max(3 * r_sigma, 0.005)
    return side_coverage(cyl, inliers) < min_coverage_deg or not r_sigma <= max_sigma or not rejected


def _top_plane(ls: np.ndarray, lt: np.ndarray, sounded: bool, *, threshold: float, seed: int,
               max_tilt_deg: float) -> tuple[Plane, bool, float, np.ndarray, float]:
    """The top's plane (MSAC on the top points), whether it is level enough to be the top,
    its lean (deg), the top points (the highest side soundings when no beam reached the
    top) and the top's elevation."""
    lean = 0.0
    if sounded:
        pres = msac(lt, Plane.from_sample, lambda m, p: m.residuals(p), 3, threshold / 2,
                    seed=seed, refine=lambda rows, _m: Plane.fit(rows))
        if pres.model is None:
            raise DataError("intersection method: no plane fits the top points")
        plane = pres.model
        lean = math.degrees(math.acos(min(1.0, abs(float(plane.normal[2])))))
        level = lean <= max_tilt_deg + TOP_LEAN_MARGIN_DEG
    else:
        # a top no beam reached: the axis is read where the side's soundings end (or at the
        # one or two top soundings); the top stands at least that high
        if len(lt) == 0:
            lt = ls[np.argsort(ls[:, 2])[-min(3, len(ls)):]]
        plane, level = Plane(np.median(lt, axis=0), np.array([0.0, 0.0, 1.0])), True
    z_top = float(np.median(lt[pres.inliers, 2] if sounded and level else lt[:, 2]))
    return plane, level, lean, lt, z_top


def _held_plumb(cyl: Cylinder, cov: np.ndarray, refit: Callable[..., tuple[Cylinder, np.ndarray, np.ndarray]],
                ls: np.ndarray, z_top: float, max_tilt_deg: float, radius: float | None
                ) -> tuple[Cylinder, np.ndarray, np.ndarray] | None:
    """The cylinder refitted with its axis plumb, when the fitted tilt is not shown by the
    data (:data:`PLUMB_CHI2`, :data:`PLUMB_MIN_SIGMA_DEG`, within ``max_tilt_deg``: past
    it the fit says the candidate is no pile); its plan covariance adds the height from
    the side's middle to the top squared times the slopes' covariance. None otherwise."""
    slopes = cyl.axis[:2] / cyl.axis[2]
    c_s = cov[2:4, 2:4]
    try:
        d2 = float(slopes @ np.linalg.solve(c_s, slopes))
    except np.linalg.LinAlgError:
        return None
    loose = math.degrees(math.sqrt(max(float(np.linalg.eigvalsh(c_s)[-1]), 0.0))) > PLUMB_MIN_SIGMA_DEG
    if not (d2 < PLUMB_CHI2 and loose and cyl.tilt_deg <= max_tilt_deg):
        return None
    p_cyl, p_cov, p_inl = refit(Cylinder(cyl.point, np.array([0.0, 0.0, 1.0]), cyl.radius), radius,
                                plumb=True)
    if p_inl.sum() < 6:
        return None
    dz = z_top - float(np.mean(ls[p_inl, 2]))
    p_cov[:2, :2] += dz**2 * c_s
    p_cov[2:4, 2:4] = c_s
    return p_cyl, p_cov, p_inl


def refit_cylinder(ls: np.ndarray, model: Cylinder, r: float | None, *, threshold: float, z_top: float,
                   groups: np.ndarray | None, sigma: np.ndarray | None = None, plumb: bool = False
                   ) -> tuple[Cylinder, np.ndarray, np.ndarray]:
    """Least-squares cylinder on the side points within a band that follows the noise.

    The band is 3 robust sigmas of the residuals, at least ``threshold`` (a fixed band
    truncates noisier data and hides its spread); three rounds of fit and re-selection.

    Parameters
    ----------
    ls : ndarray, shape (N, 3)
        Side points in the fit's local frame (m).
    model : Cylinder
        The start.
    r : float or None
        Fixed radius (m), or None to fit it.
    threshold : float
        Smallest band (m).
    z_top : float
        Height (m, local frame) at which the axis position is parametrised.
    groups : ndarray (N,), optional
        Ping of each point (random-effects refinement, cluster-robust covariance).
    sigma : ndarray (N,), optional
        Each point's noise (m), the weights of the fit.
    plumb : bool
        Hold the axis vertical.

    Returns
    -------
    cylinder, covariance, inliers
    """
    g = groups
    res0 = np.abs(model.residuals(ls))
    # a start far off (a wrong fixed radius) may leave no point in the band: widen it
    band = max(threshold, float(np.sort(res0)[min(5, len(res0) - 1)])) if len(res0) else threshold
    sel = res0 <= band
    for _ in range(3):
        model, cv = fit_cylinder(ls[sel], model, radius=r, z_ref=z_top, f_scale=band,
                                 groups=None if g is None else g[sel],
                                 sigma=None if sigma is None else sigma[sel], plumb=plumb)
        res = model.residuals(ls)
        near = np.abs(res) <= 2.5 * band
        band = max(threshold, 3.0 * 1.4826 * float(np.median(np.abs(res[near])))) \
            if near.sum() > 10 else band
        if (np.abs(res) <= band).sum() < 6:
            break
        sel = np.abs(res) <= band
    return model, cv, sel
