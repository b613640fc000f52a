"""Known piles put into a real survey, carrying the survey's own noise and shadows.

Each sounding is a ray from its ping's transducer. A sounding whose ray meets an injected
pile before its own seabed point is moved to the hit point, then along its beam by its own
seabed residual (the survey's real noise for that beam: :func:`mbinspect.noise.seabed_residuals`,
turned from a vertical offset into a range offset), so the pile carries the sonar's real
errors and the seabed behind it is shadowed as the real geometry shadows it. Soundings
whose ray misses every pile are left exactly as they were.

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
from .simulate import LABELS, Pile, Scene, Seabed, hit_objects, truth_spacings

__all__ = ["InjectedPile", "Injection", "inject_piles", "ping_origins", "read_pile_file"]


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


@dataclass(frozen=True, eq=False)
class Injection:
    """An injected survey and its truth.

    Attributes
    ----------
    xyz : ndarray, shape (N, 3)
        The soundings, those on piles moved.
    labels, ident : ndarray (N,)
        What each sounding now hits (:data:`mbinspect.simulate.LABELS`) and the pile id.
    truth : dict
        ``piles`` and ``spacings`` as :func:`mbinspect.simulate.simulate` writes them, the
        counts, and the pings whose geometry could not be estimated.
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
    >>> np.round(o[0], 6).tolist(), bool(ok.all())
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


def _seabed_at(xyz: np.ndarray, x: float, y: float, radius: float) -> float:
    d = np.hypot(xyz[:, 0] - x, xyz[:, 1] - y)
    for r in (radius + 1.0, radius + 3.0, radius + 10.0):
        near = xyz[d < r, 2]
        if len(near) >= 5:
            return float(np.median(near))
    raise InputError(f"pile at ({x:.2f}, {y:.2f}): no soundings within {radius + 10:.0f} m; "
                     "expected a pile inside the survey")


def inject_piles(xyz: np.ndarray, fields: dict[str, np.ndarray], piles: Sequence[InjectedPile]) -> Injection:
    """Put ``piles`` into a survey's soundings (see the module's notes).

    Parameters
    ----------
    xyz : ndarray, shape (N, 3)
        The survey (m, z up), with its ``fields``.
    fields : dict of ndarray (N,)
        ``ping`` and ``beam_angle`` are needed (native sonar formats give them).
    piles : sequence of InjectedPile

    Returns
    -------
    Injection

    Raises
    ------
    InputError
        No ``ping`` or ``beam_angle`` field, a pile outside the survey, or piles that overlap.
    """
    missing = [k for k in ("ping", "beam_angle") if k not in fields]
    if missing:
        raise InputError(f"the survey has no {' or '.join(missing)} per sounding; expected a sonar file "
                         "(GSF, KMALL, .all) or a cloud that keeps them")
    pts = np.asarray(xyz, float)
    ping = np.asarray(fields["ping"], np.int64)
    origin = pts[:, :2].mean(axis=0)  # a local frame
    local = pts - [origin[0], origin[1], 0.0]
    o, ok = ping_origins(local, ping, np.asarray(fields["beam_angle"], float))
    for a, b in itertools.combinations(piles, 2):
        if math.hypot(a.x - b.x, a.y - b.y) < a.radius + b.radius + 0.2:
            raise InputError(f"piles {a.id} and {b.id} overlap; expected piles apart")
    scene_piles, truth_piles = [], []
    for p in piles:
        seabed = _seabed_at(pts, p.x, p.y, p.radius)
        top = p.top if p.top is not None else seabed + float(p.height or 0.0)
        if not top > seabed:
            raise InputError(f"pile {p.id}: top {top:.2f} m is not above the seabed ({seabed:.2f} m)")
        scene_piles.append(Pile(p.x - origin[0], p.y - origin[1], top, p.radius, p.tilt_deg,
                                p.tilt_azimuth_deg, bottom_z=seabed - 5.0))
        truth_piles.append({"id": p.id, "x": p.x, "y": p.y, "z": top, "radius": p.radius,
                            "tilt_deg": p.tilt_deg, "tilt_azimuth_deg": p.tilt_azimuth_deg % 360.0,
                            "group": p.group,
                            "seabed_z": seabed})
    labels = np.zeros(len(pts), np.int8)
    ident = np.zeros(len(pts), np.int32)
    out = pts.copy()
    rows = np.flatnonzero(ok)
    if len(rows):
        ray = local[rows] - o[rows]
        length = np.linalg.norm(ray, axis=1)
        d = ray / length[:, None]
        scene = Scene(Seabed(z0=float(np.median(pts[:, 2]))), piles=tuple(scene_piles))
        t, lab, idn = hit_objects(scene, o[rows], d, length)
        hit = lab != LABELS["seabed"]
        if hit.any():
            resid = seabed_residuals(pts, ping=ping)[rows[hit]]
            dz = np.minimum(d[hit, 2], -0.1)  # a vertical offset as a range offset along the beam
            moved = o[rows[hit]] + (t[hit] + resid / dz)[:, None] * d[hit]
            out[rows[hit]] = moved + [origin[0], origin[1], 0.0]
            labels[rows[hit]] = lab[hit]
            ident[rows[hit]] = idn[hit]
    spacings = truth_spacings(truth_piles)
    counts = {"soundings": int(len(pts)), "on_piles": int((labels == LABELS["pile"]).sum()),
              "per_pile": {str(p["id"]): int((ident == p["id"]).sum()) for p in truth_piles},
              "without_ping_geometry": int((~ok).sum())}
    truth = {"preset": "inject", "piles": truth_piles, "spacings": spacings, "counts": counts,
             "design": [{"group": p["group"], "id": p["id"], "x": p["x"], "y": p["y"]} for p in truth_piles],
             "reefs": []}
    return Injection(out, labels, ident, truth)


_PILE_COLUMNS = ("id", "x", "y", "radius", "top", "height", "tilt_deg", "tilt_azimuth_deg", "group")


def read_pile_file(path: str | Path) -> list[InjectedPile]:
    """Piles to inject from a CSV: ``id,x,y,radius`` and ``top`` (elevation, m) or ``height``
    (above the seabed, m); optional ``tilt_deg``, ``tilt_azimuth_deg``, ``group``.

    Raises
    ------
    InputError
        A missing column or a bad value, naming the file, line and column.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8-sig")
    except OSError as exc:
        raise InputError(f"{p}: cannot read ({exc.strerror})") from None
    reader = csv.DictReader(text.splitlines())
    names = [n.strip().lower() for n in reader.fieldnames or []]
    need = {"id", "x", "y", "radius"} - set(names)
    if need or not ({"top", "height"} & set(names)):
        raise InputError(f"{p}: columns {','.join(names) or '(none)'}; expected id,x,y,radius and top "
                         f"or height (optional {','.join(_PILE_COLUMNS[6:])})")
    piles = []
    for line, row in enumerate(reader, start=2):
        vals = {k.strip().lower(): (v or "").strip() for k, v in row.items() if k}
        parsed: dict[str, Any] = {}
        for key in _PILE_COLUMNS:
            raw = vals.get(key, "")
            if raw == "":
                continue
            try:
                parsed[key] = int(raw) if key in ("id", "group") else float(raw)
            except ValueError:
                raise InputError(f"{p}: line {line}, column {key}: {raw!r}; expected "
                                 f"{'an integer' if key in ('id', 'group') else 'a number'}") from None
        for key in ("id", "x", "y", "radius"):
            if key not in parsed:
                raise InputError(f"{p}: line {line}, column {key}: empty; expected a value")
        if not parsed["radius"] > 0:
            raise InputError(f"{p}: line {line}, column radius: {parsed['radius']}; "
                             "expected a positive number")
        if "top" not in parsed and "height" not in parsed:
            raise InputError(f"{p}: line {line}: no top or height; expected one of them")
        piles.append(InjectedPile(**parsed))
    if not piles:
        raise InputError(f"{p}: no piles; expected a row per pile")
    return piles
