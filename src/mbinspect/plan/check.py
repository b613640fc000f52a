"""Closing the loop: a survey actually run, compared with its plan.

The lines sailed are found from the soundings (each ping's transducer from its own soundings,
:func:`~mbinspect.pings.ping_origins`; a new line where the ``line`` field changes, the track
turns by more than 45 degrees or jumps), each planned line matched to the sailed one nearest
it in offset and heading; the piles are measured from the survey as ``mbinspect piles`` would
(:func:`~mbinspect.piles.locate_piles`, told the beam the plan assumed); each spacing's 1-sigma
the run reports is set beside the one predicted, and each pile's sides beside those the plan
expected to reach.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import DataError, InputError
from ..geometry import bearing_to_vector
from ..io import PointCloud
from ..outputs import to_jsonable
from ..piles import Design, locate_piles
from ..pings import ping_origins
from .predict import SECTORS, sector_counts
from .results import PlanResult

__all__ = ["PlanCheck", "sailed_lines", "check_survey"]

#: A planned line counts as sailed when a sailed one runs within this many metres of it and
#: within :data:`HEADING_TOL` degrees of its heading (or the reciprocal).
OFFSET_TOL, HEADING_TOL = 5.0, 20.0


@dataclass(frozen=True)
class PlanCheck:
    """A survey against its plan: per planned line what was sailed (``lines``), per spacing the
    reported against the predicted 1-sigma (``spacings``), per pile the sides reached
    (``piles``), and the notes."""

    lines: tuple[dict[str, Any], ...]
    spacings: tuple[dict[str, Any], ...]
    piles: tuple[dict[str, Any], ...]
    sailed: tuple[dict[str, Any], ...]
    notes: tuple[str, ...] = ()
    parameters: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return to_jsonable({"kind": "plan-check", "lines": list(self.lines), "spacings": list(self.spacings),
                            "piles": list(self.piles), "sailed": list(self.sailed), "notes": list(self.notes),
                            "parameters": self.parameters})


def _straight_runs(track: np.ndarray) -> list[np.ndarray]:
    """Indices of each straight run of one line's track: a cut where it jumps or turns by
    more than 45 degrees over a few pings."""
    n = len(track)
    if n < 2:
        return [np.arange(n)]
    step = np.hypot(*np.diff(track, axis=0).T)
    typical = float(np.median(step[step > 0])) if (step > 0).any() else 1.0
    k = max(5, min(50, n // 20))
    idx = np.arange(n)
    ahead = track[np.minimum(idx + k, n - 1)] - track[np.maximum(idx - k, 0)]
    heading = np.degrees(np.arctan2(ahead[:, 0], ahead[:, 1]))
    turn = np.abs((np.diff(heading) + 180.0) % 360.0 - 180.0)
    return np.split(idx, np.flatnonzero((step > 20 * typical) | (turn > 45.0)) + 1)


def _segments(track: np.ndarray, line: np.ndarray | None) -> list[np.ndarray]:
    """Indices (in ping order) of each straight run of the transducer track, within each line."""
    groups = [np.arange(len(track))] if line is None else [np.flatnonzero(line == v) for v in np.unique(line)]
    return [g[run] for g in groups for run in _straight_runs(track[g]) if len(run) >= 10]


def sailed_lines(cloud: PointCloud) -> list[dict[str, Any]]:
    """The straight lines the survey sailed: start, end (x, y) and heading of each.

    Raises
    ------
    InputError
        The soundings carry no ping numbers and beam angles.
    """
    ping, angle = cloud.fields.get("ping"), cloud.fields.get("beam_angle")
    if ping is None or angle is None:
        raise InputError("the survey's soundings carry no ping numbers and beam angles; expected a sonar "
                         "file (GSF, KMALL, .all, XTF) or LAS with them, to find the lines sailed")
    origins, ok = ping_origins(cloud.xyz, np.asarray(ping), np.asarray(angle))
    line_f = cloud.fields.get("line")
    key = np.asarray(ping, np.int64) + (np.asarray(line_f, np.int64) << 32 if line_f is not None else 0)
    _, first = np.unique(key[ok], return_index=True)
    o = origins[ok][first]
    lines = (np.asarray(line_f)[ok][first] if line_f is not None else None)
    out = []
    for seg in _segments(o[:, :2], lines):
        p = o[seg, :2]
        c = p.mean(axis=0)
        axis = np.linalg.svd(p - c, full_matrices=False)[2][0]
        s = (p - c) @ axis
        if s[-1] < s[0]:
            axis, s = -axis, -s
        start, end = c + s.min() * axis, c + s.max() * axis
        out.append({"start": [float(start[0]), float(start[1])], "end": [float(end[0]), float(end[1])],
                    "heading": float(np.degrees(np.arctan2(axis[0], axis[1])) % 360.0),
                    "length": float(s.max() - s.min()), "pings": int(len(seg))})
    return out


def _matches(planned: Any, sailed: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Each planned line's sailed line, one to one, nearest first (offset in m, a reciprocal
    heading counting as 2 m more): its number, offset, heading difference (deg) and the share
    of the planned line it covers."""
    pairs = []
    for i, ln in enumerate(planned):
        a = np.asarray(ln.start)
        d = (np.asarray(ln.end) - a) / max(ln.length, 1e-9)
        for k, s in enumerate(sailed):
            p, q = np.asarray(s["start"]), np.asarray(s["end"])
            m = (p + q) / 2 - a
            offset = abs(float(d[0] * m[1] - d[1] * m[0]))
            diff = abs((s["heading"] - ln.heading + 180.0) % 360.0 - 180.0)
            along = sorted([float((p - a) @ d), float((q - a) @ d)])
            covered = max(0.0, min(along[1], ln.length) - max(along[0], 0.0)) / max(ln.length, 1e-9)
            if min(diff, 180 - diff) <= HEADING_TOL and offset <= OFFSET_TOL and covered > 0:
                pairs.append((offset + (2.0 if diff > 90 else 0.0) - covered, i, k, offset, diff, covered))
    out: list[dict[str, Any]] = [{"sailed": None, "offset": None, "heading_diff": None, "covered": 0.0}
                                 for _ in planned]
    used: set[int] = set()
    for _, i, k, offset, diff, covered in sorted(pairs):
        if out[i]["sailed"] is None and k not in used:
            out[i] = {"sailed": k + 1, "offset": offset, "heading_diff": diff, "covered": covered}
            used.add(k)
    return out


def _sides(cloud: PointCloud, piles: Any, radius: float) -> dict[int, tuple[int, ...]]:
    """Soundings on each measured pile's side (within 0.3 m of its wall, 0.2 m below its top) by
    sector, round its axis as measured (a raked pile's wall moves with depth)."""
    out = {}
    xyz = cloud.xyz
    for p in piles:
        below = p.z - xyz[:, 2]
        run = np.zeros(2)
        if p.tilt_deg and p.tilt_azimuth_deg is not None:
            run = math.tan(math.radians(p.tilt_deg)) * bearing_to_vector(p.tilt_azimuth_deg)
        ex, ny = xyz[:, 0] - p.x + below * run[0], xyz[:, 1] - p.y + below * run[1]
        r = np.hypot(ex, ny)
        m = (np.abs(r - p.radius) < 0.3) & (below > 0.2) & (below < 30.0)
        out[p.id] = sector_counts(ex[m], ny[m])
    return out


def check_survey(plan: PlanResult, cloud: PointCloud, *, seed: int = 0) -> PlanCheck:
    """Compare the survey ``cloud`` with ``plan`` (see the module's notes)."""
    best = plan.best
    if best is None:
        raise InputError("the plan chose no layout; expected a plan.json written by 'mbinspect plan'")
    sailed = sailed_lines(cloud)
    lines = tuple({"line": k + 1, "heading": ln.heading, **m}
                  for k, (ln, m) in enumerate(zip(best.layout.lines, _matches(best.layout.lines, sailed),
                                                  strict=True)))
    radius = float(plan.parameters["radius"])
    jackets = {p.id: p.group for p in plan.piles}
    design = Design(positions={p.id: (p.x, p.y) for p in plan.piles},
                    groups=jackets if len(set(jackets.values())) > 1 else {})
    beam = float((plan.parameters.get("sonar_model") or {}).get("beam_across_deg") or 0.0)
    notes = [f"{sum(1 for ln in lines if ln['sailed'] is None)} of {len(lines)} planned lines not sailed"]
    try:
        kw: dict[str, Any] = {"beam_width_deg": beam} if beam > 0 else {}
        res = locate_piles(cloud, radius=radius, count=len(plan.piles), design=design, seed=seed, **kw)
    except DataError as e:
        return PlanCheck(lines, (), (), tuple(sailed), (*notes, f"no pile measured: {e}"))
    predicted = {(s.a, s.b): s.sigma for s in best.spacings}
    spacings: tuple[dict[str, Any], ...] = tuple({"a": s.a, "b": s.b, "distance": s.distance,
                                                  "sigma": s.sigma,
                      "predicted_sigma": predicted.get((min(s.a, s.b), max(s.a, s.b))),
                      "ratio": s.sigma / predicted[(min(s.a, s.b), max(s.a, s.b))]
                      if predicted.get((min(s.a, s.b), max(s.a, s.b))) else None,
                      "meets_target": bool(s.sigma <= plan.target_sigma)} for s in res.spacings)
    expected = dict(best.unseen)
    sides = _sides(cloud, res.piles, radius)
    piles = tuple({"id": p.id, "sides": dict(zip(SECTORS, sides[p.id], strict=True)),
                   "unseen": [SECTORS[k] for k in range(8) if sides[p.id][k] < 5],
                   "unseen_planned": list(expected.get(p.id, ())), "found": True} for p in res.piles)
    missing = [p.id for p in plan.piles if p.id not in {q.id for q in res.piles}]
    piles += tuple({"id": i, "found": False} for i in missing)
    if missing:
        notes.append(f"piles {', '.join(map(str, missing))} not found in the survey")
    worse = [s for s in spacings if s["ratio"] is not None and s["ratio"] > 1.25]
    if worse:
        notes.append(f"{len(worse)} spacings' 1-sigma more than 25 % over the prediction")
    met = sum(s["meets_target"] for s in spacings)
    notes.append(f"{met} of {len(spacings)} spacings within the target of {plan.target_sigma:g} m (1-sigma)")
    if not all(math.isfinite(s["sigma"]) for s in spacings):
        notes.append("some spacings have no 1-sigma the data can show")
    return PlanCheck(lines, spacings, piles, tuple(sailed), tuple(notes),
                     {"radius": radius, "beam_width_deg": beam, "seed": seed})
