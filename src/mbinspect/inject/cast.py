"""Known piles and reefs put into a real survey, carrying the survey's own noise and shadows.

Each sounding is a ray from its ping's transducer. A sounding whose ray meets an injected
pile or reef before its own seabed point is moved to the hit point, then along its beam by its own
seabed residual (the survey's real noise for that beam: :func:`mbinspect.noise.seabed_residuals`,
turned from a vertical offset into a range offset), so the pile carries the sonar's real
errors and the seabed behind it is shadowed as the real geometry shadows it. Soundings
whose ray misses every object are left exactly as they were. Piles and reefs are the
simulator's own scene types, so their truth has the form :func:`mbinspect.simulate.simulate`
writes.

The transducer of each ping is estimated from the ping's own soundings: across a ping the
plan offset from nadir grows as ``h tan(angle)`` (``h`` the height above the seabed), so a
line fitted to the soundings' positions against the tangent of their beam angles gives the
nadir point (intercept) and ``h`` (slope). A sloping seabed across the swath tilts this
estimate slightly; the rays keep their real angles within a degree or so.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..beam import Beam
from ..errors import InputError
from ..noise import seabed_residuals
from ..pings import estimate_pings, ping_geometry
from ..reef_designs import BUILTIN_DESIGNS
from ..scour import pit_lowering
from ..simulate import LABELS, Pile, Reef, Scene, Seabed, hit_objects, reef_boxes, reef_truth, truth_spacings
from ..simulate.beam import cast_cones
from ..simulate.raycast import rays_near, targets
from .objects import InjectedPile, InjectedReef, Injection

__all__ = ["inject"]


def _seabed_at(xyz: np.ndarray, x: float, y: float, radius: float, what: str = "pile") -> float:
    d = np.hypot(xyz[:, 0] - x, xyz[:, 1] - y)
    for r in (radius + 1.0, radius + 3.0, radius + 10.0):
        near = xyz[d < r, 2]
        if len(near) >= 5:
            return float(np.median(near))
    raise InputError(f"{what} at ({x:.2f}, {y:.2f}): no soundings within {radius + 10:.0f} m; "
                     f"expected a {what} inside the survey")


def _scene_piles(pts: np.ndarray, origin: np.ndarray, piles: Sequence[InjectedPile]
                 ) -> tuple[list[Pile], list[dict[str, Any]]]:
    """The simulator's piles (local frame) and their truth records (survey frame)."""
    scene, truth = [], []
    for p in piles:
        seabed = _seabed_at(pts, p.x, p.y, p.radius)
        top = p.top if p.top is not None else seabed + float(p.height or 0.0)
        if not top > seabed:
            raise InputError(f"pile {p.id}: top {top:.2f} m is not above the seabed ({seabed:.2f} m)")
        scene.append(Pile(p.x - origin[0], p.y - origin[1], top, p.radius, p.tilt_deg,
                          p.tilt_azimuth_deg, bottom_z=seabed - 5.0))
        truth.append({"id": p.id, "x": p.x, "y": p.y, "z": top, "radius": p.radius,
                      "tilt_deg": p.tilt_deg, "tilt_azimuth_deg": p.tilt_azimuth_deg % 360.0,
                      "group": p.group, "seabed_z": seabed})
    return scene, truth


def _scene_reefs(pts: np.ndarray, origin: np.ndarray, reefs: Sequence[InjectedReef]
                 ) -> tuple[list[Reef], list[dict[str, Any]]]:
    """The simulator's reefs (local frame) and their truth records (survey frame): the
    seabed under each is the survey's median level around it, so heights are exposed heights."""
    scene, truth = [], []
    for r in reefs:
        size = BUILTIN_DESIGNS[r.kind].radius * r.scale
        level = _seabed_at(pts, r.x, r.y, size, what="reef")
        x, y = r.x - origin[0], r.y - origin[1]
        reef = Reef(r.id, r.kind, x, y, r.bearing_deg,
                    reef_boxes(r.kind, x, y, r.bearing_deg, level - r.burial, r.scale, r.orientation,
                               r.tilt_deg, r.tilt_bearing_deg), group=r.group,
                    orientation=r.orientation, tilt_deg=r.tilt_deg, tilt_bearing_deg=r.tilt_bearing_deg)
        record = reef_truth(reef, Seabed(z0=level, roughness=0.0), (float(origin[0]), float(origin[1])))
        if not record["height"] > 0:
            raise InputError(f"reef {r.id}: buried {r.burial} m, deeper than its own height; "
                             "expected part of it above the seabed")
        scene.append(reef)
        truth.append(record)
    return scene, truth


def inject(xyz: np.ndarray, fields: dict[str, np.ndarray], *, piles: Sequence[InjectedPile] = (),
           reefs: Sequence[InjectedReef] = (), beam: Beam | None = None,
           pits: Sequence[tuple[float, float, float, float]] = ()) -> Injection:
    """Put ``piles`` and ``reefs`` into a survey's soundings (see the module's notes).

    Parameters
    ----------
    xyz : ndarray, shape (N, 3)
        The survey (m, z up), with its ``fields``.
    fields : dict of ndarray (N,)
        ``ping`` and ``beam_angle`` (native sonar formats give them); without them they
        are estimated from the soundings' order (:func:`estimate_pings`), with a warning
        in ``truth["warnings"]``. Soundings marked ``extra_detection`` (KMALL's targets
        in the water column) are not bottom detections: they stay where they are.
    piles : sequence of InjectedPile
    reefs : sequence of InjectedReef
    beam : Beam, optional
        The survey's beam width and bottom detection: the objects are seen through cones
        (:mod:`mbinspect.simulate.beam`); thin rays when not given.
    pits : sequence of (x, y, depth, radius)
        Scour pits dug into the survey's own seabed first (m; each a cosine bell ``depth`` m
        deep at its centre and ``radius`` m wide, as the simulator digs them): each sounding
        whose seabed point lies in one goes on along its own ray to the lowered seabed, its
        real noise with it (:func:`dig_pits`).

    Returns
    -------
    Injection

    Raises
    ------
    InputError
        No ping structure to estimate, an object outside the survey, objects that
        overlap, a reef kind that is not a built-in design or buried deeper than its height.
    """
    if not piles and not reefs and not pits:
        raise InputError("nothing to inject; expected piles, reefs or pits")
    for pit in pits:
        if len(pit) != 4 or not all(math.isfinite(v) for v in pit) or pit[2] < 0 or pit[3] <= 0:
            raise InputError(f"pit {tuple(pit)}: expected (x, y, depth, radius), depth at least 0, "
                             "radius above 0")
    pts = np.asarray(xyz, float)
    warnings = []
    if "ping" in fields and "beam_angle" in fields:
        ping = np.asarray(fields["ping"], np.int64)
        angle = np.asarray(fields["beam_angle"], float)
    else:
        ping, angle = estimate_pings(pts)
        warnings.append(f"the survey has no ping and beam angle per sounding: {ping.max() + 1:,} pings taken "
                        "from the soundings' order, each transducer above the middle of its swath at z = 0; "
                        "the shadows and the beams' incidence are approximate")
    origin = pts[:, :2].mean(axis=0)  # a local frame
    local = pts - [origin[0], origin[1], 0.0]
    o, axes, ok = ping_geometry(local, ping, angle)
    for r in reefs:
        if r.kind not in BUILTIN_DESIGNS:
            raise InputError(f"reef {r.id}: kind {r.kind!r}; expected one of {', '.join(BUILTIN_DESIGNS)}")
    _check_apart(piles, reefs)
    scene_piles, truth_piles = _scene_piles(pts, origin, piles)
    scene_reefs, truth_reefs = _scene_reefs(pts, origin, reefs)
    if "extra_detection" in fields:
        ok = ok & ~np.asarray(fields["extra_detection"], bool)
    scene = Scene(Seabed(z0=float(np.median(pts[:, 2]))), piles=tuple(scene_piles), reefs=tuple(scene_reefs))
    start, dug = pts, local
    if pits:  # the soundings a pit moved, and only they, leave their recorded place
        dug = dig_pits(local, o, ok, [(x - origin[0], y - origin[1], d, r) for x, y, d, r in pits])
        start = np.where(np.any(dug != local, axis=1)[:, None], dug + [origin[0], origin[1], 0.0], pts)
    out, labels, ident = _moved(pts, start, dug, origin, ping, angle, o, axes, ok, scene, beam)
    counts = {"soundings": int(len(pts)), "on_piles": int((labels == LABELS["pile"]).sum()),
              "on_reefs": int((labels == LABELS["reef"]).sum()),
              "per_pile": {str(p["id"]): int(((labels == LABELS["pile"]) & (ident == p["id"])).sum())
                           for p in truth_piles},
              "per_reef": {str(r["id"]): int(((labels == LABELS["reef"]) & (ident == r["id"])).sum())
                           for r in truth_reefs},
              "without_ping_geometry": int((~ok).sum())}
    truth = {"preset": "inject", "piles": truth_piles, "spacings": truth_spacings(truth_piles),
             "counts": counts, "warnings": warnings,
             "design": [{"group": p["group"], "id": p["id"], "x": p["x"], "y": p["y"]} for p in truth_piles],
             "reefs": truth_reefs,
             "pits": [{"x": float(x), "y": float(y), "depth": float(d), "radius": float(r)}
                      for x, y, d, r in pits]}
    if beam is not None:
        truth["beam"] = beam.to_dict()
    return Injection(out, labels, ident, truth)


def _moved(pts: np.ndarray, start: np.ndarray, local: np.ndarray, origin: np.ndarray, ping: np.ndarray,
           angle: np.ndarray, o: np.ndarray, axes: np.ndarray, ok: np.ndarray, scene: Scene, beam: Beam | None
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The soundings moved by the objects, with what each now shows (label, id): ``pts`` as
    recorded (their residuals), ``start`` where they stand before the objects (a pit dug) and
    ``local`` the same in the local frame.

    A thin beam: a sounding whose ray meets an object first moves to the hit, then along its
    beam by its own seabed residual. A beam with a width: every beam whose cone may meet an
    object is cast as sub-rays over the plane of its smoothed seabed (:func:`cast_cones`);
    where an object's echo is the strongest, the sounding moves to the detected range plus
    its own residual; where the seabed's still is, by what the objects change in the range
    detected, so the real footprint on the seabed stays as it was.
    """
    labels = np.zeros(len(pts), np.int8)
    ident = np.zeros(len(pts), np.int32)
    out = start.copy()
    rows = np.flatnonzero(ok)
    if not len(rows):
        return out, labels, ident
    ray = local[rows] - o[rows]
    length = np.linalg.norm(ray, axis=1)
    d = ray / length[:, None]
    if beam is None or beam.thin:
        t, lab, idn = hit_objects(scene, o[rows], d, length)
        hit = np.flatnonzero(lab != LABELS["seabed"])
        if len(hit):
            resid = seabed_residuals(pts, ping=ping)[rows[hit]]
            dz = np.minimum(d[hit, 2], -0.1)  # a vertical offset as a range offset along the beam
            new_range = t[hit] + resid / dz
    else:
        objects = targets(scene)
        hit = np.flatnonzero(rays_near(objects, o[rows], d, length, beam.spread()))
        if len(hit):
            resid = seabed_residuals(pts, ping=ping)[rows[hit]]
            offset = resid / np.minimum(d[hit, 2], -0.1)
            up = np.tile([0.0, 0.0, 1.0], (len(hit), 1))
            plane = o[rows[hit]] + (length[hit] - offset)[:, None] * d[hit]
            cones = cast_cones(beam, objects, o[rows[hit]], d[hit], axes[rows[hit]], plane, up,
                               beam.modes(np.radians(angle[rows[hit]])))
            moved = np.isfinite(cones.range) & np.isfinite(cones.plane_range)
            hit, cones_range, plane_range = hit[moved], cones.range[moved], cones.plane_range[moved]
            lab, idn = np.zeros(len(rows), np.int8), np.zeros(len(rows), np.int32)
            lab[hit], idn[hit] = cones.label[moved], cones.ident[moved]
            # an object's echo carries the sounding's own residual; a seabed echo that the
            # objects only nudge keeps the real detection and moves by what they change
            new_range = np.where(lab[hit] != LABELS["seabed"], cones_range + offset[moved],
                                 length[hit] + (cones_range - plane_range))
    if len(hit):
        moved_xyz = o[rows[hit]] + new_range[:, None] * d[hit]
        out[rows[hit]] = moved_xyz + [origin[0], origin[1], 0.0]
        labels[rows[hit]] = lab[hit]
        ident[rows[hit]] = idn[hit]
    return out, labels, ident


def dig_pits(local: np.ndarray, o: np.ndarray, ok: np.ndarray,
             pits: Sequence[tuple[float, float, float, float]], steps: int = 24) -> np.ndarray:
    """The soundings with scour pits dug into their seabed: each whose point lies in a pit
    goes on along its ray (from its transducer ``o``) to the first place the ray meets the
    seabed lowered there, the seabed about the sounding taken as level (m, one frame).

    Examples
    --------
    >>> pts = np.array([[0.0, 0.0, -10.0], [5.0, 0.0, -10.0], [9.0, 0.0, -10.0]])
    >>> o = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    >>> dug = dig_pits(pts, o, np.ones(3, bool), [(0.0, 0.0, 0.5, 4.0)])
    >>> [round(float(v), 3) for v in dug[:, 2]]
    [-10.5, -10.0, -10.0]
    """
    out = np.array(local, np.float64, copy=True)
    if not pits:
        return out

    rows = np.flatnonzero(ok)
    rows = rows[pit_lowering(pits, out[rows, 0], out[rows, 1]) > 0]
    if not len(rows):
        return out
    p0 = out[rows]
    d = p0 - o[rows]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    down = np.maximum(-d[:, 2], 0.05)  # metres down per metre along the ray

    def below(s: np.ndarray) -> np.ndarray:  # > 0 once the ray is under the lowered seabed
        return s * down - pit_lowering(pits, p0[:, 0] + s * d[:, 0], p0[:, 1] + s * d[:, 1])

    # the first crossing: march to it, then halve the bracket
    reach = sum(p[2] for p in pits) / down
    grid = reach[:, None] * np.linspace(0.0, 1.0, steps + 1)[None, :]
    f = np.column_stack([below(grid[:, k]) for k in range(steps + 1)])
    first = np.argmax(f >= 0, axis=1)
    hi = grid[np.arange(len(rows)), np.maximum(first, 1)]
    lo = grid[np.arange(len(rows)), np.maximum(first - 1, 0)]
    for _ in range(30):
        mid = (lo + hi) / 2
        under = below(mid) >= 0
        hi, lo = np.where(under, mid, hi), np.where(under, lo, mid)
    out[rows] = p0 + hi[:, None] * d
    return out


def _check_apart(piles: Sequence[InjectedPile], reefs: Sequence[InjectedReef]) -> None:
    """Objects must not overlap (a reef's reach is half its design's length times its scale)."""
    reach = [(f"pile {p.id}", p.x, p.y, p.radius) for p in piles] + [
        (f"reef {r.id}", r.x, r.y, BUILTIN_DESIGNS[r.kind].radius * r.scale) for r in reefs]
    for a, b in itertools.combinations(reach, 2):
        if math.hypot(a[1] - b[1], a[2] - b[2]) < a[3] + b[3] + 0.2:
            raise InputError(f"{a[0]} and {b[0]} overlap; expected objects apart")
