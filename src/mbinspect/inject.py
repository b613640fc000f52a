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

import csv
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .errors import InputError
from .noise import seabed_residuals
from .reef_designs import BUILTIN_DESIGNS
from .simulate import LABELS, Pile, Reef, Scene, Seabed, hit_objects, reef_boxes, reef_truth, truth_spacings

__all__ = ["InjectedPile", "InjectedReef", "Injection", "estimate_pings", "inject", "ping_origins",
           "read_pile_file", "read_reef_file"]


@dataclass(frozen=True)
class InjectedPile:
    """A pile to inject, in the survey's coordinates (m, elevation up).

    ``top`` is the top centre's elevation; ``height``, when ``top`` is None, the top's
    height above the survey's seabed at the pile (the median elevation around it).
    """

    id: int
    x: float
    y: float
    radius: float
    top: float | None = None
    height: float | None = None
    tilt_deg: float = 0.0
    tilt_azimuth_deg: float = 0.0
    group: int = 1


@dataclass(frozen=True)
class InjectedReef:
    """A reef to inject: a built-in design (``cross2``, ``cross1``, ``hollow``, ``triangle``, ``cube``)
    at (x, y) in the survey's coordinates, turned by ``bearing_deg``, built ``scale`` times
    the design's size, its base ``burial`` m below the survey's seabed there (sunk)."""

    id: int
    x: float
    y: float
    kind: str
    bearing_deg: float = 0.0
    scale: float = 1.0
    burial: float = 0.1
    group: int = 1


@dataclass(frozen=True, eq=False)
class Injection:
    """An injected survey and its truth.

    Attributes
    ----------
    xyz : ndarray, shape (N, 3)
        The soundings, those on piles moved.
    labels, ident : ndarray (N,)
        What each sounding now hits (:data:`mbinspect.simulate.LABELS`) and the pile or
        reef id.
    truth : dict
        ``piles``, ``spacings`` and ``reefs`` as :func:`mbinspect.simulate.simulate` writes
        them, the counts, and the pings whose geometry could not be estimated.
    """

    xyz: np.ndarray
    labels: np.ndarray
    ident: np.ndarray
    truth: dict[str, Any]

    def to_dict(self) -> dict[str, Any]:
        """The truth (JSON-ready)."""
        return dict(self.truth)


def ping_origins(points: np.ndarray, ping: np.ndarray, beam_angle: np.ndarray, *, min_beams: int = 5
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Each sounding's transducer position, estimated from its ping's soundings.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
    ping : ndarray of int, shape (N,)
    beam_angle : ndarray, shape (N,)
        Degrees from vertical (+ starboard).
    min_beams : int
        Fewest soundings, spread over at least 10° of angle, for a ping's estimate.

    Returns
    -------
    origins : ndarray, shape (N, 3)
        NaN for the soundings of pings that cannot be estimated.
    ok : ndarray of bool, shape (N,)

    Examples
    --------
    >>> ang = np.linspace(-60, 60, 41)
    >>> across = 20 * np.tan(np.radians(ang))
    >>> pts = np.column_stack([100 + across, np.full(41, 50.0), np.full(41, -20.0)])
    >>> o, ok = ping_origins(pts, np.zeros(41, int), ang)
    >>> (np.round(o[0], 6) + 0.0).tolist(), bool(ok.all())
    ([100.0, 50.0, 0.0], True)
    """
    pts = np.asarray(points, float)
    origins = np.full_like(pts, np.nan)
    tan = np.tan(np.radians(np.clip(beam_angle, -85, 85)))
    order = np.argsort(ping, kind="stable")
    bounds = np.flatnonzero(np.diff(ping[order])) + 1
    for rows in np.split(order, bounds):
        if len(rows) < min_beams or np.ptp(beam_angle[rows]) < 10:
            continue
        a = np.column_stack([np.ones(len(rows)), tan[rows]])
        (x0, sx), *_ = np.linalg.lstsq(a, pts[rows, 0], rcond=None)
        (y0, sy), *_ = np.linalg.lstsq(a, pts[rows, 1], rcond=None)
        h = math.hypot(sx, sy)
        if not h > 0:
            continue
        near = rows[np.argsort(np.abs(tan[rows]))[:3]]
        origins[rows] = [x0, y0, float(np.median(pts[near, 2])) + h]
    return origins, np.isfinite(origins[:, 0])


def estimate_pings(points: np.ndarray, *, jump: float = 20.0) -> tuple[np.ndarray, np.ndarray]:
    """Pings and beam angles of soundings that lost them (an XYZ or LAS export), from their order.

    Exports keep each ping's soundings together, beam after beam across the swath: a step
    from one sounding to the next of more than ``jump`` times the median step starts a new
    ping. Each ping's transducer is taken above the middle of its swath (along the ping's
    principal axis, beams running port to starboard in the file's order) at the water
    surface (z = 0), which gives each sounding's beam angle.
    Both are assumptions; :func:`inject` says so in a warning.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        In file order, z elevation (depths negative).
    jump : float

    Returns
    -------
    ping : ndarray of int, shape (N,)
    beam_angle : ndarray, shape (N,)
        Degrees from vertical.

    Raises
    ------
    InputError
        No ping structure in the order (fewer than 3 pings of at least 5 soundings), or
        soundings above the surface.

    Examples
    --------
    >>> ang = np.radians(np.linspace(-60, 60, 21))
    >>> pings = [np.column_stack([20 * np.tan(ang), np.full(21, 0.5 * k), np.full(21, -20.0)])
    ...          for k in range(4)]
    >>> ping, angle = estimate_pings(np.vstack(pings))
    >>> ping[[0, 20, 21, 83]].tolist(), round(float(angle[0]), 1), round(float(angle[10]), 1)
    ([0, 0, 1, 3], -60.0, 0.0)
    """
    pts = np.asarray(points, float)
    step = np.hypot(*np.diff(pts[:, :2], axis=0).T)
    typical = float(np.median(step)) if len(step) else 0.0
    ping = np.concatenate([[0], np.cumsum(step > jump * max(typical, 1e-6))]).astype(np.int64)
    sizes = np.bincount(ping)
    if (sizes >= 5).sum() < 3:
        raise InputError("the soundings' order shows no pings (expected each ping's soundings together, "
                         "beam after beam); give a survey with ping and beam_angle fields")
    if np.median(pts[:, 2]) >= 0:
        raise InputError("the soundings lie above z = 0; expected elevations below the water surface "
                         "(negative depths) to place the transducers")
    angle = np.zeros(len(pts))
    order = np.argsort(ping, kind="stable")
    for rows in np.split(order, np.flatnonzero(np.diff(ping[order])) + 1):
        if len(rows) < 2:
            continue
        xy = pts[rows, :2] - pts[rows, :2].mean(axis=0)
        axis = np.linalg.svd(xy, full_matrices=False)[2][0]
        s = xy @ axis
        if np.corrcoef(s, np.arange(len(s)))[0, 1] < 0:  # beams run port to starboard in the order
            s = -s
        s -= 0.5 * (s.min() + s.max())
        angle[rows] = np.degrees(np.arctan2(s, np.maximum(-pts[rows, 2], 1e-3)))
    return ping, angle


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
                    reef_boxes(r.kind, x, y, r.bearing_deg, level - r.burial, r.scale), group=r.group)
        record = reef_truth(reef, Seabed(z0=level, roughness=0.0), (float(origin[0]), float(origin[1])))
        if not record["height"] > 0:
            raise InputError(f"reef {r.id}: buried {r.burial} m, deeper than its own height; "
                             "expected part of it above the seabed")
        scene.append(reef)
        truth.append(record)
    return scene, truth


def inject(xyz: np.ndarray, fields: dict[str, np.ndarray], *, piles: Sequence[InjectedPile] = (),
           reefs: Sequence[InjectedReef] = ()) -> Injection:
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

    Returns
    -------
    Injection

    Raises
    ------
    InputError
        No ping structure to estimate, an object outside the survey, objects that
        overlap, a reef kind that is not a built-in design or buried deeper than its height.
    """
    if not piles and not reefs:
        raise InputError("nothing to inject; expected piles or reefs")
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
    o, ok = ping_origins(local, ping, angle)
    for r in reefs:
        if r.kind not in BUILTIN_DESIGNS:
            raise InputError(f"reef {r.id}: kind {r.kind!r}; expected one of {', '.join(BUILTIN_DESIGNS)}")
    _check_apart(piles, reefs)
    scene_piles, truth_piles = _scene_piles(pts, origin, piles)
    scene_reefs, truth_reefs = _scene_reefs(pts, origin, reefs)
    labels = np.zeros(len(pts), np.int8)
    ident = np.zeros(len(pts), np.int32)
    out = pts.copy()
    if "extra_detection" in fields:
        ok = ok & ~np.asarray(fields["extra_detection"], bool)
    rows = np.flatnonzero(ok)
    if len(rows):
        ray = local[rows] - o[rows]
        length = np.linalg.norm(ray, axis=1)
        d = ray / length[:, None]
        scene = Scene(Seabed(z0=float(np.median(pts[:, 2]))), piles=tuple(scene_piles),
                      reefs=tuple(scene_reefs))
        t, lab, idn = hit_objects(scene, o[rows], d, length)
        hit = lab != LABELS["seabed"]
        if hit.any():
            resid = seabed_residuals(pts, ping=ping)[rows[hit]]
            dz = np.minimum(d[hit, 2], -0.1)  # a vertical offset as a range offset along the beam
            moved = o[rows[hit]] + (t[hit] + resid / dz)[:, None] * d[hit]
            out[rows[hit]] = moved + [origin[0], origin[1], 0.0]
            labels[rows[hit]] = lab[hit]
            ident[rows[hit]] = idn[hit]
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
             "reefs": truth_reefs}
    return Injection(out, labels, ident, truth)


def _check_apart(piles: Sequence[InjectedPile], reefs: Sequence[InjectedReef]) -> None:
    """Objects must not overlap (a reef's reach is half its design's length times its scale)."""
    reach = [(f"pile {p.id}", p.x, p.y, p.radius) for p in piles] + [
        (f"reef {r.id}", r.x, r.y, BUILTIN_DESIGNS[r.kind].radius * r.scale) for r in reefs]
    for a, b in itertools.combinations(reach, 2):
        if math.hypot(a[1] - b[1], a[2] - b[2]) < a[3] + b[3] + 0.2:
            raise InputError(f"{a[0]} and {b[0]} overlap; expected objects apart")


_PILE_COLUMNS = ("id", "x", "y", "radius", "top", "height", "tilt_deg", "tilt_azimuth_deg", "group")
_REEF_COLUMNS = ("id", "x", "y", "kind", "bearing_deg", "scale", "burial", "group")
_POSITIVE = ("radius", "scale")


def _read_rows(path: str | Path, columns: Sequence[str], required: Sequence[str], what: str
               ) -> list[tuple[int, dict[str, Any]]]:
    """The rows of an object CSV, typed (``id`` and ``group`` integers, ``kind`` text, the
    rest numbers), each with its line number; every missing or bad value named by file,
    line and column."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8-sig")
    except OSError as exc:
        raise InputError(f"{p}: cannot read ({exc.strerror})") from None
    reader = csv.DictReader(text.splitlines())
    names = [n.strip().lower() for n in reader.fieldnames or []]
    if set(required) - set(names):
        optional = [c for c in columns if c not in required]
        raise InputError(f"{p}: columns {','.join(names) or '(none)'}; expected {','.join(required)} "
                         f"(optional {','.join(optional)})")
    rows = []
    for line, row in enumerate(reader, start=2):
        vals = {k.strip().lower(): (v or "").strip() for k, v in row.items() if k}
        parsed: dict[str, Any] = {}
        for key in columns:
            raw = vals.get(key, "")
            if raw == "":
                if key in required:
                    raise InputError(f"{p}: line {line}, column {key}: empty; expected a value")
                continue
            try:
                parsed[key] = raw if key == "kind" else int(raw) if key in ("id", "group") else float(raw)
            except ValueError:
                raise InputError(f"{p}: line {line}, column {key}: {raw!r}; expected "
                                 f"{'an integer' if key in ('id', 'group') else 'a number'}") from None
            wrong = _value_problem(key, parsed[key])
            if wrong:
                raise InputError(f"{p}: line {line}, column {key}: {raw!r}; expected {wrong}")
        rows.append((line, parsed))
    if not rows:
        raise InputError(f"{p}: no {what}s; expected a row per {what}")
    return rows


def _value_problem(key: str, value: Any) -> str | None:
    """What a parsed value should have been, or None when it is fine."""
    if isinstance(value, float) and not math.isfinite(value):
        return "a finite number"
    if key in _POSITIVE and not value > 0:
        return "a positive number"
    if key == "burial" and not value >= 0:
        return "a number >= 0 (m sunk)"
    return None


def read_pile_file(path: str | Path) -> list[InjectedPile]:
    """Piles to inject from a CSV: ``id,x,y,radius`` and ``top`` (elevation, m) or ``height``
    (above the seabed, m); optional ``tilt_deg``, ``tilt_azimuth_deg``, ``group``.

    Raises
    ------
    InputError
        A missing column or a bad value, naming the file, line and column.
    """
    piles = []
    for line, parsed in _read_rows(path, _PILE_COLUMNS, ("id", "x", "y", "radius"), "pile"):
        if "top" not in parsed and "height" not in parsed:
            raise InputError(f"{path}: line {line}: no top or height; expected one of them")
        piles.append(InjectedPile(**parsed))
    return piles


def read_reef_file(path: str | Path) -> list[InjectedReef]:
    """Reefs to inject from a CSV: ``id,x,y,kind`` (a built-in design: cross2, cross1,
    hollow, triangle); optional ``bearing_deg``, ``scale`` (as built / design), ``burial``
    (m sunk below the seabed, default 0.1) and ``group``.

    Raises
    ------
    InputError
        A missing column or a bad value, naming the file, line and column.
    """
    reefs = []
    for line, parsed in _read_rows(path, _REEF_COLUMNS, ("id", "x", "y", "kind"), "reef"):
        if parsed["kind"] not in BUILTIN_DESIGNS:
            raise InputError(f"{path}: line {line}, column kind: {parsed['kind']!r}; expected one of "
                             f"{', '.join(BUILTIN_DESIGNS)}")
        reefs.append(InjectedReef(**parsed))
    return reefs
