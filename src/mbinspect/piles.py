"""Locate underwater piles and every pile spacing, after Xia & Zhang (2022) and past it.

Pipeline (each stage a function of its own):

1. :func:`elevated_points` - a robust local seabed and the points standing well above it,
   lone water-column returns removed.
2. :func:`separate_piles` - K-means with k-means++ seeding when the count is known (the
   paper), connected components otherwise; clusters that split or merge piles are fixed
   or reported.
3. :func:`split_top_side` - the joint threshold segmentation: the paper's sliding
   elevation window, local normals (top about vertical, side about horizontal) and, when
   the cloud has it, a backscatter threshold from the data (Otsu).
4. :func:`centre_method` - mean of the top points within r + k_s, iterated.
5. :func:`intersection_method` - MSAC cylinder of known radius on the side points
   (normals drive the sampling), refined by least squares on true orthogonal distances,
   a plane on the top, the centre where the axis meets it; tilt and its bearing.
6. :func:`locate_piles` - the whole, iterated as the paper does until every spacing
   changes by less than ``delta``; spacings, design comparison, quality flags.

Pile ids are stable: rows from south to north, and west to east within a row (a new row
starts where the northing jumps by more than half the smallest pile spacing); with a
design of positions, the design's ids are used instead (one-to-one nearest matching).

Examples
--------
>>> from mbinspect.simulate import simulate
>>> from mbinspect.piles import locate_piles
>>> sim = simulate("jacket", seed=2, ping_spacing=0.25)
>>> result = locate_piles(sim.cloud, count=4, radius=0.75)
>>> len(result.piles), len(result.spacings)
(4, 6)
>>> 21.8 < result.spacings[0].distance < 22.2
True
"""

from __future__ import annotations

import csv
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from .errors import DataError, FileAccessError, InputError, ParameterError
from .filters import radius_outlier
from .fit import Cylinder, Plane, cylinder_msac, fit_cylinder, msac
from .geometry import crop_mask
from .io import PointCloud, check_points, to_jsonable
from .seabed import GridSurface, grid_seabed
from .segment import components, elevation_window, kmeans, normals, otsu_threshold

__all__ = [
    "METHODS",
    "Design",
    "read_design",
    "PileSegment",
    "PileFit",
    "Spacing",
    "PileResult",
    "elevated_points",
    "separate_piles",
    "split_top_side",
    "centre_method",
    "intersection_method",
    "locate_piles",
    "stable_order",
]

#: Centre methods: the paper's two and both side by side.
METHODS = ("intersection", "centre", "both")


# ----------------------------------------------------------------------------- design


@dataclass(frozen=True)
class Design:
    """A design: pile positions (id -> x, y) or pile-pair spacings ((a, b) -> distance)."""

    positions: dict[int, tuple[float, float]] = field(default_factory=dict)
    spacings: dict[tuple[int, int], float] = field(default_factory=dict)
    source: str | None = None

    def spacing(self, a: int, b: int) -> float | None:
        if self.positions:
            if a in self.positions and b in self.positions:
                (xa, ya), (xb, yb) = self.positions[a], self.positions[b]
                return math.hypot(xa - xb, ya - yb)
            return None
        return self.spacings.get((min(a, b), max(a, b)))


def read_design(path: str | Path) -> Design:
    """Read a design CSV: ``id,x,y`` (positions) or ``a,b,distance`` (spacings).

    A header row is required; ``#`` lines and blank lines are skipped. A bad row raises
    :class:`InputError` naming the line.
    """
    p = Path(path)
    if not p.exists():
        raise FileAccessError(f"{p}: no such file")
    if p.is_dir():
        raise FileAccessError(f"{p}: is a directory, expected a design CSV")
    rows: list[tuple[int, list[str]]] = []
    with open(p, newline="", encoding="utf-8") as fh:
        for lineno, row in enumerate(csv.reader(fh), start=1):
            cells = [c.strip() for c in row]
            if not any(cells) or cells[0].startswith("#"):
                continue
            rows.append((lineno, cells))
    if not rows:
        raise InputError(f"{p}: the design file is empty")
    header = [h.lower() for h in rows[0][1]]
    body = rows[1:]
    if not body:
        raise InputError(f"{p}: the design file has a header but no rows")
    if {"id", "x", "y"} <= set(header):
        cols = [header.index(c) for c in ("id", "x", "y")]
        positions: dict[int, tuple[float, float]] = {}
        for lineno, cells in body:
            v = _design_row(p, lineno, cells, cols, header, n_ids=1)
            pid, x, y = int(v[0]), v[1], v[2]
            if pid in positions:
                raise InputError(f"{p}, line {lineno}: pile id {pid} appears twice")
            positions[pid] = (x, y)
        return Design(positions=positions, source=str(p))
    if {"a", "b", "distance"} <= set(header):
        cols = [header.index(c) for c in ("a", "b", "distance")]
        spacings: dict[tuple[int, int], float] = {}
        for lineno, cells in body:
            v = _design_row(p, lineno, cells, cols, header, n_ids=2)
            a, b, d = int(v[0]), int(v[1]), v[2]
            if a == b:
                raise InputError(f"{p}, line {lineno}: a spacing from pile {a} to itself")
            if not d > 0:
                raise InputError(f"{p}, line {lineno}: distance {d} must be positive")
            spacings[(min(a, b), max(a, b))] = float(d)
        return Design(spacings=spacings, source=str(p))
    raise InputError(
        f"{p}, line {rows[0][0]}: header {rows[0][1]} has neither id,x,y nor a,b,distance"
    )


def _design_row(p: Path, lineno: int, cells: list[str], cols: list[int], header: list[str],
                *, n_ids: int) -> list[float]:
    """The numbers of one design row; the first ``n_ids`` must be whole (pile ids)."""
    if len(cells) < len(header):
        raise InputError(f"{p}, line {lineno}: {len(cells)} values, expected {len(header)}")
    out: list[float] = []
    for k, c in enumerate(cols):
        text = cells[c]
        try:
            v = float(text)
        except ValueError:
            raise InputError(
                f"{p}, line {lineno}, column {c + 1} ({header[c]}): {text!r} is not a number"
            ) from None
        if not math.isfinite(v):
            raise InputError(f"{p}, line {lineno}, column {c + 1}: {text!r} is not finite")
        if k < n_ids and v != int(v):
            raise InputError(
                f"{p}, line {lineno}, column {c + 1} ({header[c]}): pile id {text!r} "
                "is not a whole number"
            )
        out.append(v)
    return out


# ----------------------------------------------------------------------------- results


@dataclass(frozen=True, eq=False)
class PileSegment:
    """The points of one pile: all, top face and side (arrays, not serialised)."""

    points: np.ndarray
    top: np.ndarray
    side: np.ndarray
    ping: np.ndarray | None = None


@dataclass(frozen=True)
class PileFit:
    """One pile: top centre (x, y, z), radius, tilt, quality and the reasons for doubt.

    ``x, y, z`` are the top centre by ``method``. With both methods the other method's
    centre is in ``alternatives``.
    """

    id: int
    x: float
    y: float
    z: float
    radius: float
    tilt_deg: float | None
    tilt_azimuth_deg: float | None
    method: str
    n_top: int
    n_side: int
    side_coverage_deg: float
    rms: float
    sigma_xy: float
    flags: tuple[str, ...] = ()
    radius_fitted: float | None = None
    top_coverage: float | None = None
    alternatives: dict[str, dict[str, float]] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {
            "id": self.id, "x": self.x, "y": self.y, "z": self.z, "radius": self.radius,
            "tilt_deg": self.tilt_deg, "tilt_azimuth_deg": self.tilt_azimuth_deg,
            "method": self.method, "n_top": self.n_top, "n_side": self.n_side,
            "side_coverage_deg": self.side_coverage_deg, "rms": self.rms,
            "sigma_xy": self.sigma_xy, "flags": list(self.flags),
            "radius_fitted": self.radius_fitted, "top_coverage": self.top_coverage,
        }
        if self.alternatives:
            d["methods"] = self.alternatives
        return to_jsonable(d)


@dataclass(frozen=True)
class Spacing:
    """The horizontal distance between two pile top centres, its 1-sigma and the design."""

    a: int
    b: int
    distance: float
    sigma: float
    design: float | None = None
    deviation: float | None = None
    passed: bool | None = None
    method: str = "intersection"

    def to_dict(self) -> dict[str, Any]:
        return to_jsonable({"a": self.a, "b": self.b, "distance": self.distance,
                            "sigma": self.sigma, "design": self.design,
                            "deviation": self.deviation, "pass": self.passed,
                            "method": self.method})


@dataclass(frozen=True, eq=False)
class PileResult:
    """Everything :func:`locate_piles` measured; ``to_dict()`` is ``piles.json``."""

    piles: tuple[PileFit, ...]
    spacings: tuple[Spacing, ...]
    iterations: tuple[dict[str, Any], ...]
    parameters: dict[str, Any]
    warnings: tuple[str, ...] = ()
    segments: dict[int, PileSegment] = field(default_factory=dict, repr=False)
    seabed: GridSurface | None = field(default=None, repr=False)
    cylinders: dict[int, Cylinder] = field(default_factory=dict, repr=False)
    other_spacings: tuple[Spacing, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        return {
            "piles": [p.to_dict() for p in self.piles],
            "spacings": [s.to_dict() for s in self.spacings + self.other_spacings],
            "iterations": to_jsonable(list(self.iterations)),
            "parameters": to_jsonable(self.parameters),
            "warnings": list(self.warnings),
            "seabed": self.seabed.to_dict() if self.seabed is not None else None,
        }

    @property
    def ok(self) -> bool:
        """True when no pile is flagged and there is no warning."""
        return not self.warnings and not any(p.flags for p in self.piles)


# ----------------------------------------------------------------------------- stages


def elevated_points(points: np.ndarray, *, min_height: float = 1.0, seabed_cell: float = 1.0,
                    seabed_window: float = 5.0, noise_radius: float = 1.0,
                    noise_neighbors: int = 3) -> tuple[np.ndarray, GridSurface, np.ndarray]:
    """Points standing more than ``min_height`` m above a robust local seabed.

    Lone returns among them (water-column noise, spikes) are dropped by the radius filter
    (``<= noise_neighbors`` others within ``noise_radius`` m).

    Returns
    -------
    mask : ndarray of bool, shape (N,)
    seabed : GridSurface
    height : ndarray, shape (N,)
        Height of every point above the seabed (m).
    """
    pts = check_points(points, minimum=10)
    if not min_height > 0:
        raise ParameterError(f"--min-height: {min_height} must be positive")
    seabed = grid_seabed(pts, cell=seabed_cell, window=seabed_window, percentile=10.0)
    height = seabed.height_above(pts)
    mask = height > min_height
    idx = np.flatnonzero(mask)
    if len(idx):
        mask[idx] = radius_outlier(pts[idx], radius=noise_radius, min_neighbors=noise_neighbors)
    return mask, seabed, height


def stable_order(xy: np.ndarray) -> np.ndarray:
    """Indices of pile centres in the documented order: rows south to north, then west to east."""
    xy = np.asarray(xy, np.float64)
    if len(xy) <= 1:
        return np.arange(len(xy))
    d = np.hypot(*(xy[:, None, :] - xy[None, :, :]).transpose(2, 0, 1))
    np.fill_diagonal(d, np.inf)
    gap = 0.5 * float(d.min())
    by_y = np.argsort(xy[:, 1], kind="stable")
    rows = np.cumsum(np.r_[0, np.diff(xy[by_y, 1]) > gap])
    row_of = np.empty(len(xy), dtype=np.int64)
    row_of[by_y] = rows
    return np.lexsort((xy[:, 0], row_of))


def separate_piles(points: np.ndarray, *, count: int | None = None, radius: float,
                   seed: int = 0, link: float = 0.4, min_points: int = 30
                   ) -> tuple[np.ndarray, list[str]]:
    """Split elevated points into piles.

    First the connected parts (points closer than ``link`` m in plan) that look like a
    pile (at least ``min_points``, no wider than ``2 r + 2`` m); lone clumps are left
    out. With ``count``, the paper's K-means (k-means++ seeding, seeded) runs on those
    points: a part that K-means splits into several large shares is touching piles and is
    split accordingly, while a K-means cluster can never take a neighbour's or stray
    points, because labels follow the parts. More parts than ``count``: the largest are
    kept; fewer: all are kept, with a warning.

    Returns
    -------
    labels : ndarray of int, shape (N,)
        0..K-1 in the stable order (:func:`stable_order`); -1 for points of no pile.
    warnings : list of str
    """
    pts = np.asarray(points, np.float64)
    warnings: list[str] = []
    if count is not None and count < 1:
        raise ParameterError(f"--count: {count} must be at least 1")
    labels = np.full(len(pts), -1, dtype=np.int64)
    if len(pts) == 0:
        return labels, ["no points stand above the seabed"]
    comp = components(pts[:, :2], eps=link, min_points=min_points)
    parts: list[np.ndarray] = []
    wide = 0
    for c in range(int(comp.max()) + 1 if (comp >= 0).any() else 0):
        idx = np.flatnonzero(comp == c)
        span = float(np.ptp(pts[idx, :2], axis=0).max())
        if span > 2 * radius + 2.0 and count is None:
            wide += 1
            continue
        parts.append(idx)
    if wide:
        warnings.append(f"{wide} structure(s) wider than a pile of radius {radius} m were left out")
    if count is not None and parts:
        sel = np.concatenate(parts)
        km, _ = kmeans(pts[sel, :2], min(count, len(sel)), seed=seed)
        km_of = np.full(len(pts), -1, dtype=np.int64)
        km_of[sel] = km
        split: list[np.ndarray] = []
        for idx in parts:
            shares = np.bincount(km_of[idx])
            big = np.flatnonzero(shares >= max(min_points, 0.25 * len(idx)))
            one_pile = float(np.ptp(pts[idx, :2], axis=0).max()) <= 2 * radius + 0.5
            if len(big) <= 1 or one_pile:
                split.append(idx)
            else:
                split += [idx[km_of[idx] == k] for k in big]
        parts = split
        if len(parts) > count:
            parts.sort(key=len, reverse=True)
            warnings.append(f"--count {count}: the data show {len(parts)} pile-like structures; "
                            f"the {count} largest were kept")
            parts = parts[:count]
        elif len(parts) < count:
            warnings.append(f"--count {count}: only {len(parts)} piles found in the data; "
                            f"results are given for those {len(parts)}")
    if not parts:
        return labels, warnings + ["no pile found among the points above the seabed"]
    centres = np.array([pts[idx, :2].mean(axis=0) for idx in parts])
    for new_id, k in enumerate(stable_order(centres)):
        labels[parts[k]] = new_id
    for k, idx in enumerate(parts):
        span = float(np.ptp(pts[idx, :2], axis=0).max())
        if span > 2 * radius + 1.5:
            warnings.append(f"a pile cluster near ({centres[k, 0]:.1f}, {centres[k, 1]:.1f}) spans "
                            f"{span:.1f} m in plan, more than a pile of radius {radius} m: "
                            "merged structures?")
    return labels, warnings


def split_top_side(points: np.ndarray, *, radius: float, window: float = 0.1,
                   step: float = 0.01, normal_k: int = 16, min_planarity: float = 0.3,
                   top_normal_deg: float = 30.0,
                   side_normal_deg: float = 40.0, edge_band: float = 0.15,
                   intensity: np.ndarray | None = None, intensity_threshold: float | None = None,
                   paper: bool = False, point_normals: tuple[np.ndarray, np.ndarray] | None = None,
                   ) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
    """The joint threshold segmentation of one pile's points into top face and side.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
    radius : float
        Prior radius (m); widens the top band for tilted tops.
    window, step : float
        The paper's elevation window (0.1 m) and its step (0.01 m).
    normal_k : int
        Neighbours for the PCA normals.
    min_planarity : float
        A normal is trusted where the neighbourhood's planarity reaches this (0-1).
    top_normal_deg, side_normal_deg : float
        A top point's normal is within ``top_normal_deg`` of vertical; a side point's is
        within ``side_normal_deg`` of horizontal.
    edge_band : float
        Side points start this far (m) below the top window: the rim mixes both.
    intensity : ndarray, optional
        Backscatter per point; with ``intensity_threshold`` points darker than it are
        dropped (the structure is brighter than sediment and water-column noise).
    paper : bool
        Exactly the paper's rule: top = the window's points, side = all the others below.
    point_normals : (normals, planarity), optional
        Normals already computed for these points (:func:`mbinspect.segment.normals`).

    Returns
    -------
    top, side : ndarray of bool, shape (N,)
    info : dict
        The window and how many points each criterion removed.
    """
    pts = np.asarray(points, np.float64)
    lo, hi, n_win = elevation_window(pts[:, 2], window=window, step=step)
    info: dict[str, Any] = {"window": [lo, hi], "n_window": n_win}
    if paper:
        top = (pts[:, 2] >= lo) & (pts[:, 2] <= hi)
        return top, pts[:, 2] < lo, info
    nrm, planarity = point_normals if point_normals is not None else normals(pts, k=normal_k)
    nz = np.abs(nrm[:, 2])
    # only a well-defined normal may veto a point: on a sparse survey a point's neighbours
    # can all lie on one ping's line, where PCA gives no normal at all
    defined = planarity >= min_planarity
    # a tilted top spans +-r sin(tilt) around the window: accept a band, then trust normals
    band = max(window, 2 * radius * math.sin(math.radians(8.0)))
    mid = (lo + hi) / 2
    top = (np.abs(pts[:, 2] - mid) <= band / 2 + 0.05) & (
        ~defined | (nz >= math.cos(math.radians(top_normal_deg))))
    side = (pts[:, 2] < mid - band / 2 - edge_band) & (
        ~defined | (nz <= math.sin(math.radians(side_normal_deg))))
    info["n_normal_undefined"] = int((~defined).sum())
    if intensity is not None and intensity_threshold is not None:
        dark = np.asarray(intensity) < intensity_threshold
        info["n_dark_removed"] = int((dark & (top | side)).sum())
        top &= ~dark
        side &= ~dark
    info["n_top"], info["n_side"] = int(top.sum()), int(side.sum())
    return top, side, info


def centre_method(top: np.ndarray, *, radius: float, ks: float = 0.1, start: np.ndarray | None = None,
                  max_iterations: int = 50, groups: np.ndarray | None = None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The paper's centre method: mean of the top points within ``r + k_s``, iterated.

    Returns
    -------
    centre : ndarray, shape (3,)
    used : ndarray of bool
        The top points in the final mean.
    cov : ndarray, shape (2, 2)
        Covariance of the plan centre (cluster-robust by ``groups`` when given).
    """
    t = np.asarray(top, np.float64)
    if len(t) == 0:
        raise DataError("centre method: no top points")
    c = t.mean(axis=0) if start is None else np.asarray(start, np.float64)
    used = np.ones(len(t), dtype=bool)
    for _ in range(max_iterations):
        used = np.hypot(*(t[:, :2] - c[:2]).T) <= radius + ks
        if not used.any():
            raise DataError(f"centre method: no top point within r + k_s = {radius + ks:.2f} m")
        new = t[used].mean(axis=0)
        if np.hypot(*(new[:2] - c[:2])) < 1e-5:
            c = new
            break
        c = new
    dev = t[used, :2] - c[:2]
    n = int(used.sum())
    if groups is not None:
        _, inv = np.unique(np.asarray(groups)[used], return_inverse=True)
        g = np.zeros((inv.max() + 1, 2))
        np.add.at(g, inv, dev)
        cov = g.T @ g / max(n, 1) ** 2
    else:
        cov = np.cov(dev.T) / max(n, 1) if n > 1 else np.full((2, 2), np.nan)
    return c, used, cov


def _side_coverage(cyl: Cylinder, pts: np.ndarray, bin_deg: float = 5.0) -> float:
    if len(pts) == 0:
        return 0.0
    ang = np.degrees(cyl.angles(pts))
    hist = np.bincount((ang // bin_deg).astype(np.int64) % int(360 / bin_deg),
                       minlength=int(360 / bin_deg))
    return float((hist > 0).sum() * bin_deg)


def _top_coverage(top: np.ndarray, centre: np.ndarray, radius: float, cell: float = 0.15) -> float:
    """Fraction of the top disc's cells that hold at least one top point."""
    g = np.arange(-radius + cell / 2, radius, cell)
    gx, gy = np.meshgrid(g, g)
    disc = np.hypot(gx, gy) <= radius - cell / 2
    if len(top) == 0 or not disc.any():
        return 0.0
    ij = np.floor((top[:, :2] - centre[:2] + radius) / cell).astype(np.int64)
    n = len(g)
    ok = (ij >= 0).all(axis=1) & (ij < n).all(axis=1)
    hit = np.zeros((n, n), dtype=bool)
    hit[ij[ok, 1], ij[ok, 0]] = True
    return float((hit & disc).sum() / disc.sum())


def intersection_method(side: np.ndarray, side_normals: np.ndarray, top: np.ndarray, *,
                        radius: float, threshold: float = 0.06, max_tilt_deg: float = 15.0,
                        seed: int = 0, groups: np.ndarray | None = None,
                        start: Cylinder | None = None, radius_mode: str = "auto",
                        min_free_coverage_deg: float = 150.0, max_free_sigma: float = 0.005,
                        ) -> tuple[Cylinder, Plane, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
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

    Returns
    -------
    cylinder, plane, centre (3,), side_inliers, top_inliers, cov (4, 4)
        ``cov`` is the cluster-robust covariance of (x, y, ax, ay) at the top.
    """
    if radius_mode not in ("auto", "fixed", "free"):
        raise ParameterError(f"--radius-mode: {radius_mode!r} is not auto, fixed or free")
    s = np.asarray(side, np.float64)
    t = np.asarray(top, np.float64)
    if len(t) < 3:
        raise DataError(f"intersection method: {len(t)} top points, at least 3 needed")
    if len(s) < 6:
        raise DataError(f"intersection method: {len(s)} side points, at least 6 needed")
    shift = np.r_[s[:, :2].mean(axis=0), 0.0]
    ls, lt = s - shift, t - shift
    pres = msac(lt, Plane.from_sample, lambda m, p: m.residuals(p), 3, threshold / 2,
                seed=seed, refine=lambda rows, _m: Plane.fit(rows))
    if pres.model is None:
        raise DataError("intersection method: no plane fits the top points")
    plane = pres.model
    if start is None:
        res = cylinder_msac(ls, side_normals, radius=radius, threshold=threshold,
                            max_tilt_deg=max_tilt_deg, seed=seed, free_radius=radius_mode != "fixed")
        if res.model is None:
            raise DataError("intersection method: no cylinder fits the side points")
        cyl0 = res.model
        inl = res.inliers
    else:
        cyl0 = Cylinder(start.point - shift, start.axis, start.radius)
        inl = np.abs(cyl0.residuals(ls)) <= threshold
    z_top = float(np.median(lt[pres.inliers, 2]))
    g = None if groups is None else np.asarray(groups)

    def refit(model: Cylinder, r: float | None) -> tuple[Cylinder, np.ndarray, np.ndarray]:
        # the inlier band follows the noise: 3 robust sigmas of the residuals, at least
        # ``threshold`` (a fixed band truncates noisier data and hides its spread)
        res0 = np.abs(model.residuals(ls))
        # a start far off (a wrong fixed radius) may leave no point in the band: widen it
        band = max(threshold, float(np.sort(res0)[min(5, len(res0) - 1)])) if len(res0) else threshold
        sel = res0 <= band
        for _ in range(3):
            model, cv = fit_cylinder(ls[sel], model, radius=r, z_ref=z_top, f_scale=band,
                                     groups=None if g is None else g[sel])
            res = model.residuals(ls)
            near = np.abs(res) <= 2.5 * band
            band = max(threshold, 3.0 * 1.4826 * float(np.median(np.abs(res[near])))) \
                if near.sum() > 10 else band
            if (np.abs(res) <= band).sum() < 6:
                break
            sel = np.abs(res) <= band
        return model, cv, sel

    cyl, cov, inl = refit(cyl0 if radius_mode != "fixed" else Cylinder(cyl0.point, cyl0.axis, radius),
                          None if radius_mode != "fixed" else radius)
    if radius_mode == "auto":
        # keep the prior unless the data reject it: a free radius costs precision
        r_sigma = math.sqrt(max(float(cov[4, 4]), 0.0)) if cov.shape[0] > 4 else math.inf
        rejected = abs(cyl.radius - radius) > max(3 * r_sigma, 0.005)
        if (_side_coverage(cyl, ls[inl]) < min_free_coverage_deg or not r_sigma <= max_free_sigma
                or not rejected):
            cyl, cov, inl = refit(Cylinder(cyl.point, cyl.axis, radius), radius)
    centre = cyl.intersect(plane)
    if centre is None:
        raise DataError("intersection method: the axis is parallel to the top plane")
    out_cyl = Cylinder(cyl.point + shift, cyl.axis, cyl.radius)
    out_plane = Plane(plane.point + shift, plane.normal)
    top_in = np.abs(plane.residuals(lt)) <= threshold / 2
    return out_cyl, out_plane, centre + shift, inl, top_in, cov


# ----------------------------------------------------------------------------- the whole


def _intensity_threshold(cloud_int: np.ndarray | None, elevated: np.ndarray, near_seabed: np.ndarray
                         ) -> float | None:
    if cloud_int is None or elevated.sum() < 20 or near_seabed.sum() < 20:
        return None
    both = np.r_[cloud_int[elevated], cloud_int[near_seabed]]
    try:
        thr = otsu_threshold(both)
    except Exception:
        return None
    # only a split between two clear classes is a threshold: structure brighter than seabed
    if np.median(cloud_int[elevated]) <= thr or np.median(cloud_int[near_seabed]) >= thr:
        return None
    return thr


def locate_piles(
    data: PointCloud | np.ndarray,
    *,
    radius: float,
    count: int | None = None,
    method: str = "intersection",
    design: Design | None = None,
    tolerance: float = 0.05,
    crop: tuple[float, float, float, float] | np.ndarray | None = None,
    min_height: float = 1.0,
    seabed_cell: float = 1.0,
    seabed_window: float | None = None,
    window: float = 0.1,
    step: float = 0.01,
    ks: float = 0.1,
    threshold: float = 0.06,
    use_intensity: bool = True,
    segmentation: str = "joint",
    radius_mode: str = "auto",
    delta: float = 0.01,
    max_iterations: int = 20,
    max_tilt_deg: float = 15.0,
    min_top: int = 20,
    min_side: int = 50,
    min_coverage_deg: float = 60.0,
    max_sigma: float = 0.005,
    seed: int = 0,
    progress: Callable[[float], None] | None = None,
) -> PileResult:
    """Locate piles, their top centres, tilts and every spacing.

    Parameters
    ----------
    data : PointCloud or ndarray (N, 3)
        Soundings; a cloud's ``intensity`` and ``ping`` fields are used when present.
    radius : float
        Prior pile radius r (m).
    count : int, optional
        Number of piles K (K-means); found from the data when None.
    method : {"intersection", "centre", "both"}
        Top-centre method; "both" computes both, reporting the intersection one.
    design : Design, optional
        Design positions or spacings for deviations and pass/fail.
    tolerance : float
        Pass/fail tolerance on spacing deviations (m); default 0.05.
    crop : (xmin, ymin, xmax, ymax) or ndarray (K, 2), optional
        Bounding box or polygon to keep.
    min_height : float
        Pile points stand more than this above the local seabed (m); default 1.0.
    seabed_cell, seabed_window : float
        Seabed grid cell and opening window (m); window default max(5, 4 r + 1).
    window, step : float
        The paper's top elevation window (0.1 m) stepped by 0.01 m.
    ks : float
        The paper's k_s for the centre method (m); default 0.1.
    threshold : float
        Inlier distance for cylinder and plane fits (m); default 0.06.
    use_intensity : bool
        Drop points darker than an Otsu threshold between structure and seabed.
    segmentation : {"joint", "paper"}
        Our joint window + normals + intensity split, or the paper's window alone.
    radius_mode : {"auto", "fixed", "free"}
        Keep the prior radius (the paper), fit it, or fit it where the side coverage
        supports it (default); see :func:`intersection_method`.
    delta : float
        Stop when every spacing changes by less than this between iterations (m); 0.01.
    max_iterations : int
    max_tilt_deg : float
        Largest tilt a cylinder hypothesis may have.
    min_top, min_side, min_coverage_deg, max_sigma : int, int, float, float
        Quality limits: fewer points, a narrower scanned arc of the side, or a larger
        1-sigma plan uncertainty (m) flags the pile.
    seed : int
    progress : callable, optional

    Returns
    -------
    PileResult
    """
    if method not in METHODS:
        raise ParameterError(f"--method: {method!r} is not one of {', '.join(METHODS)}")
    if radius_mode not in ("auto", "fixed", "free"):
        raise ParameterError(f"--radius-mode: {radius_mode!r} is not auto, fixed or free")
    if segmentation not in ("joint", "paper"):
        raise ParameterError(f"--segmentation: {segmentation!r} is not 'joint' or 'paper'")
    for name, v in (("--radius", radius), ("--tolerance", tolerance), ("--delta", delta),
                    ("--window", window), ("--step", step), ("--threshold", threshold)):
        if not (isinstance(v, (int, float)) and v > 0 and math.isfinite(v)):
            raise ParameterError(f"{name}: {v} must be a positive number")
    if ks < 0:
        raise ParameterError(f"--ks: {ks} must be >= 0")
    if count is not None and count < 1:
        raise ParameterError(f"--count: {count} must be at least 1")
    cloud = data if isinstance(data, PointCloud) else PointCloud(check_points(data))
    if crop is not None:
        cloud = cloud.subset(crop_mask(cloud.xyz, crop))
    pts = check_points(cloud.xyz, minimum=10, name="points")
    intensity = cloud.fields.get("intensity") if use_intensity else None
    ping = cloud.fields.get("ping")
    report = progress or (lambda f: None)
    params = {k: v for k, v in locals().items()
              if k in ("radius", "count", "method", "tolerance", "min_height", "seabed_cell",
                       "window", "step", "ks", "threshold", "use_intensity", "segmentation",
                       "radius_mode",
                       "delta", "max_iterations", "max_tilt_deg", "min_top", "min_side",
                       "min_coverage_deg", "max_sigma", "seed")}
    sw = seabed_window if seabed_window is not None else max(5.0, 4 * radius + 1)
    params["seabed_window"] = sw
    params["design"] = design.source if design is not None else None
    params["n_points"] = len(pts)
    elevated, seabed, height = elevated_points(pts, min_height=min_height, seabed_cell=seabed_cell,
                                       seabed_window=sw)
    report(0.2)
    if not elevated.any():
        raise DataError(f"no points stand more than {min_height} m above the seabed; "
                        "no pile to measure (check --min-height and the crop)")
    eidx = np.flatnonzero(elevated)
    labels, warnings = separate_piles(pts[eidx], count=count, radius=radius, seed=seed)
    ids = [int(c) for c in np.unique(labels) if c >= 0]
    if not ids:
        raise DataError("no pile found among the points above the seabed")
    report(0.3)
    near_seabed = np.abs(height) < 0.3
    thr = _intensity_threshold(intensity, elevated, near_seabed) if intensity is not None else None
    params["intensity_threshold"] = thr
    segs: dict[int, PileSegment] = {}
    side_n: dict[int, np.ndarray] = {}
    seg_info: dict[int, dict[str, Any]] = {}
    for c in ids:
        idx = eidx[labels == c]
        p = pts[idx]
        nrm, planarity = normals(p) if len(p) >= 3 else (np.zeros((len(p), 3)), np.zeros(len(p)))
        top, side, info = split_top_side(
            p, radius=radius, window=window, step=step,
            intensity=None if intensity is None else intensity[idx],
            intensity_threshold=thr, paper=(segmentation == "paper"),
            point_normals=(nrm, planarity))
        segs[c + 1] = PileSegment(p, top, side, None if ping is None else ping[idx])
        side_n[c + 1] = nrm[side]
        seg_info[c + 1] = info
    # iterate: fit every pile, compute spacings, drop points off the models, refit
    fits: dict[int, dict[str, Any]] = {}
    iterations: list[dict[str, Any]] = []
    active = {pid: (s.top.copy(), s.side.copy()) for pid, s in segs.items()}
    prev: dict[tuple[int, int], float] | None = None
    for it in range(1, max_iterations + 1):
        for pid, seg in segs.items():
            top_m, side_m = active[pid]
            fits[pid] = _fit_one(seg, top_m, side_m, side_n[pid][side_m[seg.side]]
                                 if side_m.any() else np.zeros((0, 3)),
                                 radius=radius, method=method, ks=ks, threshold=threshold,
                                 max_tilt_deg=max_tilt_deg, seed=seed + pid,
                                 previous=fits.get(pid), radius_mode=radius_mode)
        current = {(a, b): math.hypot(fits[a]["x"] - fits[b]["x"], fits[a]["y"] - fits[b]["y"])
                   for a, b in itertools.combinations(sorted(fits), 2)}
        iterations.append({
            "iteration": it,
            "centres": {str(pid): [f["x"], f["y"], f["z"]] for pid, f in fits.items()},
            "spacings": {f"{a}-{b}": d for (a, b), d in current.items()},
        })
        report(0.3 + 0.6 * it / max_iterations)
        change = max((abs(current[k] - prev[k]) for k in current), default=0.0) if prev else math.inf
        if it > 1 and change < delta:
            break
        prev = current
        for pid, seg in segs.items():  # the paper's step 5: drop points off the models
            active[pid] = _prune(seg, fits[pid], active[pid], radius=radius, ks=ks,
                                 threshold=threshold)
    piles, cylinders = [], {}
    for pid in sorted(fits):
        f = fits[pid]
        flags = list(f["flags"])
        if f["n_top"] < min_top:
            flags.append(f"few top points: {f['n_top']} < {min_top}")
        if f["method"] != "centre" and f["n_side"] < min_side:
            flags.append(f"few side points: {f['n_side']} < {min_side}")
        if f["method"] != "centre" and f["coverage"] < min_coverage_deg:
            flags.append(f"side scanned over {f['coverage']:.0f} deg < {min_coverage_deg:.0f} deg")
        if not (f["sigma_xy"] <= max_sigma):
            flags.append(f"plan uncertainty {1000 * f['sigma_xy']:.1f} mm (1 sigma) exceeds "
                         f"{1000 * max_sigma:.1f} mm: the data cannot support a centimetre answer")
        if f.get("radius_fitted") is not None and abs(f["radius_fitted"] - radius) > max(0.03, 0.05 * radius):
            flags.append(f"the points show a radius of {f['radius_fitted']:.3f} m, not the prior "
                         f"{radius:.3f} m")
        if f["method"] == "centre" and f["top_coverage"] is not None and f["top_coverage"] < 0.8:
            flags.append(f"top face only {100 * f['top_coverage']:.0f} % covered: the centre "
                         "method's mean is biased toward the scanned part")
        if f.get("cylinder") is not None:
            cylinders[pid] = f["cylinder"]
        piles.append(PileFit(
            id=pid, x=f["x"], y=f["y"], z=f["z"], radius=f.get("radius_used", radius),
            tilt_deg=f.get("tilt_deg"), tilt_azimuth_deg=f.get("tilt_azimuth_deg"),
            method=f["method"], n_top=f["n_top"], n_side=f["n_side"],
            side_coverage_deg=f["coverage"], rms=f["rms"], sigma_xy=f["sigma_xy"],
            flags=tuple(flags), radius_fitted=f.get("radius_fitted"),
            top_coverage=f.get("top_coverage"), alternatives=f.get("alternatives", {})))
    piles_t = tuple(piles)
    if design is not None and design.positions:
        piles_t, warn = _match_design(piles_t, design)
        warnings += warn
        remap = {old.id: new.id for old, new in zip(piles, piles_t, strict=True)}
        segs = {remap[k]: v for k, v in segs.items()}
        cylinders = {remap[k]: v for k, v in cylinders.items()}
        covs = {remap[k]: fits[k]["cov"] for k in fits}
        alt_xy = {remap[k]: fits[k].get("alternatives", {}) for k in fits}
    else:
        covs = {k: fits[k]["cov"] for k in fits}
        alt_xy = {k: fits[k].get("alternatives", {}) for k in fits}
    if design is not None and design.spacings:
        known = {p.id for p in piles_t}
        missing = sorted({i for ab in design.spacings for i in ab} - known)
        if missing:
            warnings.append(f"design {design.source}: pile id {missing[0]} does not exist "
                            f"(piles found: {', '.join(map(str, sorted(known)))})")
    spacings = _spacings(piles_t, covs, design, tolerance, method="intersection"
                         if method != "centre" else "centre")
    others: tuple[Spacing, ...] = ()
    if method == "both":
        alt = tuple(
            PileFit(id=p.id, x=alt_xy[p.id]["centre"]["x"], y=alt_xy[p.id]["centre"]["y"],
                    z=alt_xy[p.id]["centre"]["z"], radius=radius, tilt_deg=None,
                    tilt_azimuth_deg=None, method="centre", n_top=p.n_top, n_side=0,
                    side_coverage_deg=0.0, rms=0.0, sigma_xy=alt_xy[p.id]["centre"]["sigma_xy"])
            for p in piles_t if "centre" in alt_xy[p.id])
        alt_cov = {p.id: np.asarray(alt_xy[p.id]["centre"]["cov"]) for p in alt}
        others = _spacings(alt, alt_cov, design, tolerance, method="centre")
        piles_t = tuple(_strip_cov(p) for p in piles_t)
    report(1.0)
    params["segmentation_info"] = {str(k): v for k, v in seg_info.items()}
    return PileResult(piles_t, spacings, tuple(iterations), params, tuple(warnings), segs,
                      seabed, cylinders, others)


def _strip_cov(p: PileFit) -> PileFit:
    alts = {k: {kk: vv for kk, vv in v.items() if kk != "cov"} for k, v in p.alternatives.items()}
    return replace(p, alternatives=alts)


def _centre_result(top: np.ndarray, *, radius: float, ks: float, start: np.ndarray | None,
                   groups: np.ndarray | None) -> dict[str, Any]:
    """The centre method's answer as a fit record (centre, 1-sigma, covariance, top coverage)."""
    c, used, cov = centre_method(top, radius=radius, ks=ks, start=start, groups=groups)
    return {"x": float(c[0]), "y": float(c[1]), "z": float(c[2]),
            "sigma_xy": math.sqrt(max(float(np.trace(cov)) / 2, 0.0)), "cov": cov,
            "top_coverage": _top_coverage(top[used], c, radius)}


def _fit_one(seg: PileSegment, top_m: np.ndarray, side_m: np.ndarray, side_normals: np.ndarray, *,
             radius: float, method: str, ks: float, threshold: float, max_tilt_deg: float,
             seed: int, previous: dict[str, Any] | None, radius_mode: str = "auto") -> dict[str, Any]:
    top = seg.points[top_m]
    side = seg.points[side_m]
    gtop = None if seg.ping is None else seg.ping[top_m]
    gside = None if seg.ping is None else seg.ping[side_m]
    out: dict[str, Any] = {"flags": [], "n_top": int(len(top)), "n_side": int(len(side))}
    alternatives: dict[str, dict[str, Any]] = {}
    centre_result = None
    if method in ("centre", "both") or len(side) < 6:
        if len(top) == 0:
            raise DataError(f"pile at ({seg.points[:, 0].mean():.2f}, {seg.points[:, 1].mean():.2f}): "
                            "no top points and too few side points to measure it")
        start = None if previous is None else np.array([previous["x"], previous["y"], previous["z"]])
        centre_result = _centre_result(top, radius=radius, ks=ks, start=start, groups=gtop)
        alternatives["centre"] = centre_result
    if method in ("intersection", "both") and len(side) >= 6 and len(top) >= 3:
        start_cyl = previous.get("cylinder") if previous else None
        try:
            cyl, plane, centre, s_in, t_in, cov = intersection_method(
                side, side_normals, top, radius=radius, threshold=threshold,
                max_tilt_deg=max_tilt_deg, seed=seed, groups=gside, start=start_cyl,
                radius_mode=radius_mode)
        except DataError as exc:
            out["flags"].append(f"intersection method failed ({exc}); centre method used")
        else:
            r_res = cyl.residuals(side[s_in])
            try:
                free, _ = fit_cylinder(side[s_in], cyl, radius=None, z_ref=float(centre[2]),
                                       f_scale=threshold / 3)
                r_free: float | None = free.radius
            except Exception:
                r_free = None
            sig = math.sqrt(max(float(cov[0, 0] + cov[1, 1]) / 2, 0.0))
            alternatives["intersection"] = {"x": float(centre[0]), "y": float(centre[1]),
                                            "z": float(centre[2]), "sigma_xy": sig}
            out.update(x=float(centre[0]), y=float(centre[1]), z=float(centre[2]),
                       method="intersection", cov=cov[:2, :2], sigma_xy=sig,
                       rms=float(np.sqrt(np.mean(r_res**2))), cylinder=cyl, plane=plane,
                       tilt_deg=cyl.tilt_deg, tilt_azimuth_deg=cyl.tilt_bearing_deg,
                       coverage=_side_coverage(cyl, side[s_in]), radius_fitted=r_free,
                       radius_used=cyl.radius,
                       n_side=int(s_in.sum()), n_top=int(t_in.sum()), top_coverage=None)
    if "x" not in out:
        if centre_result is None:
            centre_result = _centre_result(top, radius=radius, ks=ks, start=None, groups=gtop)
        cr = centre_result
        dz = top[:, 2] - cr["z"]
        out.update(x=cr["x"], y=cr["y"], z=cr["z"], method="centre", cov=cr["cov"],
                   sigma_xy=cr["sigma_xy"], rms=float(np.sqrt(np.mean(dz**2))), coverage=0.0,
                   top_coverage=cr["top_coverage"], tilt_deg=None, tilt_azimuth_deg=None)
        if method != "centre" and not out["flags"]:
            out["flags"].append(f"only {len(side)} side points: centre method used")
    if method == "both":
        out["alternatives"] = alternatives
    return out


def _prune(seg: PileSegment, fit: dict[str, Any], active: tuple[np.ndarray, np.ndarray], *,
           radius: float, ks: float, threshold: float) -> tuple[np.ndarray, np.ndarray]:
    top_m, side_m = active
    cyl = fit.get("cylinder")
    plane = fit.get("plane")
    new_side = seg.side.copy()
    new_top = seg.top.copy()
    if cyl is not None:
        r = np.abs(cyl.residuals(seg.points))
        # the band follows the noise as in the fit (3 robust sigmas, at least ``threshold``):
        # a fixed band would truncate noisy data, shrink its spread and hide its errors
        near = seg.side & (r <= 5 * threshold)
        band = max(threshold, 3.0 * 1.4826 * float(np.median(r[near]))) if near.sum() > 10 else threshold
        sel = seg.side & (r <= band)
        if sel.sum() >= 6:
            new_side = sel
        axis_d = np.abs(cyl.residuals(seg.points) + cyl.radius)
        tsel = seg.top & (axis_d <= radius + ks)
        if plane is not None:
            tsel &= np.abs(plane.residuals(seg.points)) <= threshold
        if tsel.sum() >= 3:
            new_top = tsel
    else:
        c = np.array([fit["x"], fit["y"]])
        tsel = seg.top & (np.hypot(*(seg.points[:, :2] - c).T) <= radius + ks)
        if tsel.sum() >= 3:
            new_top = tsel
    return new_top, new_side


def _match_design(piles: tuple[PileFit, ...], design: Design) -> tuple[tuple[PileFit, ...], list[str]]:
    from scipy.optimize import linear_sum_assignment

    ids = sorted(design.positions)
    D = np.array([[math.hypot(p.x - design.positions[i][0], p.y - design.positions[i][1])
                   for i in ids] for p in piles])
    rows, cols = linear_sum_assignment(D)
    warnings = []
    new: dict[int, PileFit] = {}
    for r, c in zip(rows, cols, strict=True):
        p = piles[r]
        flags = p.flags
        if D[r, c] > 2.0:
            flags = flags + (f"{D[r, c]:.2f} m from design pile {ids[c]}",)
            warnings.append(f"pile {p.id} is {D[r, c]:.2f} m from its nearest design pile "
                            f"{ids[c]}: is the design in the same coordinate frame?")
        new[r] = replace(p, id=ids[c], flags=flags)
    unmatched_design = sorted(set(ids) - {ids[c] for c in cols})
    for i in unmatched_design:
        warnings.append(f"design pile {i} was not found in the data")
    next_id = max(ids) + 1
    out = []
    for r, p in enumerate(piles):
        if r in new:
            out.append(new[r])
        else:
            out.append(replace(p, id=next_id, flags=p.flags + ("not in the design",)))
            next_id += 1
    return tuple(out), warnings


def _spacings(piles: Sequence[PileFit], covs: dict[int, np.ndarray], design: Design | None,
              tolerance: float, *, method: str) -> tuple[Spacing, ...]:
    out = []
    for a, b in itertools.combinations(sorted(piles, key=lambda p: p.id), 2):
        d = np.array([b.x - a.x, b.y - a.y])
        dist = float(np.hypot(*d))
        u = d / max(dist, 1e-12)
        ca, cb = np.asarray(covs.get(a.id)), np.asarray(covs.get(b.id))
        var = float(u @ ca[:2, :2] @ u + u @ cb[:2, :2] @ u) if ca.ndim == 2 and cb.ndim == 2 else math.nan
        sigma = math.sqrt(var) if var >= 0 else math.nan
        ref = design.spacing(a.id, b.id) if design is not None else None
        dev = None if ref is None else dist - ref
        out.append(Spacing(a.id, b.id, dist, sigma, ref, dev,
                           None if dev is None else bool(abs(dev) <= tolerance), method))
    return tuple(out)
