"""Stage 3: one pile's points split into top face and side (the joint threshold segmentation)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..segment import elevation_window, normals
from .options import PileOptions
from .results import PileSegment

__all__ = ["split_top_side", "segment_piles"]


#: Height (m) above the top band beyond which soundings are not the top's (noise, a tilted
#: top's rim); with at least :data:`ABOVE_MIN` of them, and :data:`ABOVE_SHARE` of the
#: window's count, the densest band was a band of the side and the top band is moved to
#: the pile's highest soundings. (A tenth was too few: a real survey's outliers, moved up
#: their beams by up to a metre, are that many above a well sounded top, ``ets_kmall_eg``.)
TOP_CLEARANCE = 0.1
ABOVE_MIN = 5
ABOVE_SHARE = 0.25


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

    Examples
    --------
    >>> a = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    >>> side = np.column_stack([0.75 * np.cos(a), 0.75 * np.sin(a), np.linspace(-19, -16.4, 200)])
    >>> top = np.column_stack([0.5 * np.cos(a), 0.5 * np.sin(a), np.full(200, -16.0)])
    >>> t, s, info = split_top_side(np.vstack([side, top]), radius=0.75, paper=True)
    >>> int(t.sum()), int(s.sum())
    (200, 200)
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
    # a pile sounded mostly on its side can hold more points in a band of its side than on
    # its top: soundings well above the densest band mean that band is not the top
    above = int((pts[:, 2] > mid + band / 2 + TOP_CLEARANCE).sum())
    if above >= max(ABOVE_MIN, ABOVE_SHARE * n_win):
        z_high = float(np.sort(pts[:, 2])[-min(ABOVE_MIN, len(pts))])
        mid = z_high + TOP_CLEARANCE / 2 - band / 2
        info["window_on_side"] = {"moved_from": [lo, hi], "soundings_above": above}
        info["window"] = [mid - band / 2, mid + band / 2]
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


def segment_piles(points: np.ndarray, labels: np.ndarray, options: PileOptions, *,
                  intensity: np.ndarray | None = None,
                  intensity_threshold: float | dict[int, float | None] | None = None,
                  ping: np.ndarray | None = None, line: np.ndarray | None = None,
                  beam_angle: np.ndarray | None = None, sigma_h: np.ndarray | None = None
                  ) -> tuple[dict[int, PileSegment], dict[int, np.ndarray], dict[int, dict[str, Any]]]:
    """Every pile's points split into top and side (:func:`split_top_side`).

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        The points that ``labels`` label (m).
    labels : ndarray of int, shape (N,)
        Pile 0..K-1 of each point, -1 for none (:func:`~mbinspect.piles.separate_piles`).
    options : PileOptions
        ``radius``, ``window``, ``step`` and ``segmentation``.
    intensity, ping, line, beam_angle, sigma_h : ndarray (N,), optional
        Backscatter, ping number, survey line, beam angle (deg) and the file's horizontal
        uncertainty (m) of each point.
    intensity_threshold : float or dict, optional
        Points darker than this (one value, or pile id -> value) are dropped (the joint
        segmentation only).

    Examples
    --------
    >>> from mbinspect.simulate import simulate
    >>> sim = simulate("jacket", seed=2, ping_spacing=0.5)
    >>> from mbinspect.piles import PileOptions, elevated_points, separate_piles
    >>> up, _, _ = elevated_points(sim.cloud.xyz)
    >>> labels, _ = separate_piles(sim.cloud.xyz[up], count=4, radius=0.75)
    >>> segs, normals, info = segment_piles(sim.cloud.xyz[up], labels, PileOptions(radius=0.75))
    >>> sorted(segs), all(s.top.sum() > 20 and s.side.sum() > 50 for s in segs.values())
    ([1, 2, 3, 4], True)

    Returns
    -------
    segments : dict
        Pile id (label + 1) -> PileSegment.
    side_normals : dict
        Pile id -> normals of its side points.
    info : dict
        Pile id -> what the split did (window, counts).
    """
    segs: dict[int, PileSegment] = {}
    side_n: dict[int, np.ndarray] = {}
    info: dict[int, dict[str, Any]] = {}
    for c in [int(c) for c in np.unique(labels) if c >= 0]:
        idx = np.flatnonzero(labels == c)
        p = points[idx]
        nrm, planarity = normals(p) if len(p) >= 3 else (np.zeros((len(p), 3)), np.zeros(len(p)))
        top, side, info[c + 1] = split_top_side(
            p, radius=options.radius, window=options.window, step=options.step,
            intensity=None if intensity is None else intensity[idx],
            intensity_threshold=intensity_threshold.get(c + 1) if isinstance(intensity_threshold, dict)
            else intensity_threshold, paper=(options.segmentation == "paper"),
            point_normals=(nrm, planarity))
        segs[c + 1] = PileSegment(p, top, side, *(None if f is None else f[idx]
                                                  for f in (ping, line, beam_angle, sigma_h)))
        side_n[c + 1] = nrm[side]
    return segs, side_n, info
