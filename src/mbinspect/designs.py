"""Reef designs, and fitting a design's pose and size to one reef's soundings.

Artificial reefs are deployed from a handful of known designs (the reef paper's field holds
double- and single-layer crosses). Where the user names the designs, each reef found by
:func:`mbinspect.reefs.extract_reefs` is also fitted by the design that explains its
soundings best: position, bearing and an as-built size factor (one scale on every
dimension, free, so the footprint area is measured, not copied from the design).

A design is a union of boxes in its own frame (base at z = 0, bearing 0 = north). The fit
classifies the soundings near the reef: a reef sounding must fall inside the plan footprint
of the boxes that reach its height, a seabed sounding (or another reef's) outside every
box, and a sounding on a side wall (its height near no box top) on the edge. Each costs its
squared distance on the wrong side, capped; nothing pulls a sounding on its right side, so
an edge facing an acoustic shadow does not drift outward (a symmetric soft cost did: +4 %
area on 0.55 m pings). A free-form outline is limited by the soundings near each edge; a
design shares its few parameters over every edge, which is what brings the footprint area
within a few percent on a survey whose pings are as far apart as a reef arm is wide.

Examples
--------
>>> import numpy as np
>>> from mbinspect.designs import BUILTIN_DESIGNS, fit_design
>>> d = BUILTIN_DESIGNS["cross1"]
>>> g = np.mgrid[-2:2:0.1, -2:2:0.1].reshape(2, -1).T + 0.05
>>> inside = d.signed_distance(g, 0.3, -0.2, 20.0, 1.0) < 0
>>> f = fit_design(g, inside, ~inside, d, x0=0.0, y0=0.0)
>>> bool(abs(f.x - 0.3) < 0.05 and abs(f.y + 0.2) < 0.05 and abs(f.scale - 1) < 0.05)
True
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from .errors import FileAccessError, InputError, ParameterError
from .geometry import bearing_to_vector
from .outputs import to_jsonable

__all__ = [
    "DesignBox",
    "ReefDesign",
    "DesignFit",
    "BUILTIN_DESIGNS",
    "parse_designs",
    "read_design",
    "fit_design",
    "SCALE_BOUNDS",
    "scale_at_bound",
]

#: The as-built size factor a design fit may take (smallest, largest).
SCALE_BOUNDS: tuple[float, float] = (0.6, 1.6)

#: A fitted size factor within this ratio of a bound is taken as held by it: the soundings
#: wanted a size outside the range, so the fit explains another kind of object.
BOUND_MARGIN = 1.03


def scale_at_bound(scale: float, bounds: tuple[float, float] = SCALE_BOUNDS) -> bool:
    """Whether a fitted size factor sits at (within 3 % of) a bound of the fit.

    Parameters
    ----------
    scale : float
        The fitted as-built size factor.
    bounds : (float, float)
        The fit's bounds.

    Returns
    -------
    bool

    Examples
    --------
    >>> scale_at_bound(1.0), scale_at_bound(0.61), scale_at_bound(1.58)
    (False, True, True)
    """
    return not bounds[0] * BOUND_MARGIN < scale < bounds[1] / BOUND_MARGIN


@dataclass(frozen=True)
class DesignBox:
    """One box of a design: base centre offset (dx east, dy north, dz up) from the reef's
    centre at bearing 0, its length along ``bearing_deg``, width and height (m)."""

    dx: float
    dy: float
    dz: float
    length: float
    width: float
    height: float
    bearing_deg: float = 0.0


def _rotate(v: np.ndarray, bearing_deg: float) -> np.ndarray:
    """Turn (east, north) vectors clockwise by a bearing."""
    b = math.radians(bearing_deg)
    c, s = math.cos(b), math.sin(b)
    v = np.asarray(v, np.float64)
    return np.stack([v[..., 0] * c + v[..., 1] * s, -v[..., 0] * s + v[..., 1] * c], axis=-1)


@dataclass(frozen=True)
class ReefDesign:
    """A reef design: a union of boxes, and the order of its plan rotational symmetry."""

    name: str
    boxes: tuple[DesignBox, ...]
    symmetry: int = 1

    def __post_init__(self) -> None:
        if not self.boxes:
            raise ParameterError(f"design {self.name!r}: no boxes")
        for k, b in enumerate(self.boxes):
            if not (b.length > 0 and b.width > 0 and b.height > 0):
                raise ParameterError(f"design {self.name!r}, box {k + 1}: length, width and height "
                                     f"must be > 0, got {b.length}, {b.width}, {b.height}")
        if self.symmetry < 1:
            raise ParameterError(f"design {self.name!r}: symmetry {self.symmetry} must be >= 1")

    def placed(self, x: float, y: float, bearing_deg: float, z_base: float, scale: float = 1.0
               ) -> list[tuple[float, float, float, float, float, float, float]]:
        """Boxes at a pose: (cx, cy, z0, length, width, height, bearing_deg) each."""
        out = []
        for b in self.boxes:
            o = _rotate(np.array([b.dx, b.dy]) * scale, bearing_deg)
            out.append((x + float(o[0]), y + float(o[1]), z_base + b.dz * scale, b.length * scale,
                        b.width * scale, b.height * scale, (bearing_deg + b.bearing_deg) % 360.0))
        return out

    def signed_distance(self, xy: np.ndarray, x: float, y: float, bearing_deg: float,
                        scale: float = 1.0) -> np.ndarray:
        """Signed plan distance (m) of points (N, 2) to the footprint at a pose: < 0 inside."""
        return _box_distances(self, np.asarray(xy, np.float64), x, y, bearing_deg, scale)[0].min(axis=1)

    @cached_property
    def _plan(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Box offsets (B, 2), half length and width (B, 2) and bearings (B,, radians)."""
        off = np.array([[b.dx, b.dy] for b in self.boxes], np.float64)
        half = np.array([[b.length / 2, b.width / 2] for b in self.boxes], np.float64)
        return off, half, np.radians([b.bearing_deg for b in self.boxes])

    @cached_property
    def _raster(self) -> tuple[np.ndarray, float, float, float]:
        """Signed distance to the footprint at bearing 0 on a 1 cm grid: field, x0, y0, cell."""
        cell = 0.01
        n = 2 * int(math.ceil(self.radius / cell)) + 4  # even: edges fall between nodes
        g = (np.arange(n) - (n - 1) / 2) * cell
        xx, yy = np.meshgrid(g, g)
        sdf = self.signed_distance(np.column_stack([xx.ravel(), yy.ravel()]), 0.0, 0.0, 0.0)
        return sdf.reshape(n, n), float(g[0] - cell / 2), float(g[0] - cell / 2), cell

    @cached_property
    def _outline(self) -> np.ndarray:
        """The footprint's outer boundary at bearing 0, corners only, shape (K, 2)."""
        import contourpy

        f, x0, y0, c = self._raster
        lines = contourpy.contour_generator(z=f, name="serial").lines(0.0)
        line = np.asarray(max(lines, key=lambda ln: len(ln)), np.float64)
        xy = np.column_stack([x0 + (line[:, 0] + 0.5) * c, y0 + (line[:, 1] + 0.5) * c])
        step = np.hypot(*(np.roll(xy, -1, axis=0) - xy).T)
        xy = xy[step > 1e-9]  # repeated vertices (contour through grid nodes, closing point)
        # the distance field is linear along straight edges: keep only the corners
        keep = np.ones(len(xy), dtype=bool)
        for _ in range(2):
            q = xy[keep]
            a, b = np.roll(q, 1, axis=0) - q, np.roll(q, -1, axis=0) - q
            turn = np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]) / np.maximum(
                np.hypot(*a.T) * np.hypot(*b.T), 1e-12)
            idx = np.flatnonzero(keep)
            keep[idx[turn < 0.02]] = False
        return xy[keep]

    @property
    def area(self) -> float:
        """Plan footprint area at scale 1 (m²)."""
        f, _, _, c = self._raster
        return float((f <= 0).sum() * c * c)

    @property
    def centroid(self) -> np.ndarray:
        """Footprint centroid in the design frame (m), shape (2,)."""
        f, x0, y0, c = self._raster
        j, i = np.nonzero(f <= 0)
        return np.array([x0 + (i.mean() + 0.5) * c, y0 + (j.mean() + 0.5) * c])

    @property
    def height(self) -> float:
        """Top of the design above its base (m)."""
        return max(b.dz + b.height for b in self.boxes)

    @property
    def radius(self) -> float:
        """Largest plan distance of the footprint from the design centre (m)."""
        return max(math.hypot(b.dx, b.dy) + math.hypot(b.length, b.width) / 2 for b in self.boxes)

    def outline(self, x: float, y: float, bearing_deg: float, scale: float = 1.0) -> np.ndarray:
        """The footprint's outer boundary at a pose, a polygon (K, 2)."""
        return _rotate(self._outline * scale, bearing_deg) + np.array([x, y])

    def to_dict(self) -> dict[str, Any]:
        return to_jsonable({"name": self.name, "symmetry": self.symmetry, "area": self.area,
                            "height": self.height,
                            "boxes": [b.__dict__ for b in self.boxes]})


def _cross(length: float, width: float, height: float) -> tuple[DesignBox, ...]:
    return (DesignBox(0, 0, 0, length, width, height, 0.0), DesignBox(0, 0, 0, length, width, height, 90.0))


def _builtin() -> dict[str, ReefDesign]:
    def ring(n: int, r: float, length: float, width: float, height: float) -> tuple[DesignBox, ...]:
        # n bars, each square to the bearing of its offset r m from the centre
        out = []
        for k in range(n):
            o = bearing_to_vector(360.0 * k / n) * r
            out.append(DesignBox(float(o[0]), float(o[1]), 0.0, length, width, height, 360.0 * k / n + 90.0))
        return tuple(out)

    hollow = ring(4, 1.35, 3.0, 0.3, 1.5)
    tri = ring(3, 3.0 / (2 * math.sqrt(3)) - 0.2, 3.0, 0.4, 1.2)
    upper = (DesignBox(0, 0, 1.0, 2.6, 0.6, 1.0, 45.0), DesignBox(0, 0, 1.0, 2.6, 0.6, 1.0, 135.0))
    return {
        "cross1": ReefDesign("cross1", _cross(3.0, 0.8, 1.2), 4),
        "cross2": ReefDesign("cross2", _cross(3.0, 0.8, 1.0) + upper, 4),
        "hollow": ReefDesign("hollow", hollow, 4),
        "triangle": ReefDesign("triangle", tri, 3),
        "cube": ReefDesign("cube", (DesignBox(0, 0, 0, 2.0, 2.0, 2.0, 0.0),), 4),
    }


#: The built-in designs (after the reef paper's Fig. 4 and common Chinese reef types):
#: ``cross2`` a double-layer cross (3.0 x 0.8 x 1.0 m bars, and on them 2.6 x 0.6 x 1.0 m
#: bars turned 45 degrees, 2.0 m tall); ``cross1`` a single-layer cross of 3.0 x 0.8 x 1.2 m
#: bars; ``hollow`` a hollow square 3.0 x 3.0 m with 0.3 m walls, 1.5 m tall; ``triangle``
#: three 3.0 x 0.4 x 1.2 m bars in an equilateral triangle; ``cube`` a solid 2.0 m concrete
#: cube (the flat top and vertical walls the shape test for rocks must not take for a dome).
BUILTIN_DESIGNS: dict[str, ReefDesign] = _builtin()


def read_design(path: str | Path) -> ReefDesign:
    """A design from a JSON file.

    ``{"name": "cube3", "symmetry": 4, "boxes": [{"dx": 0, "dy": 0, "dz": 0, "length": 3,
    "width": 3, "height": 3, "bearing_deg": 0}, ...]}``: box base centres relative to the
    reef's centre, lengths along the box bearing (degrees clockwise from north), metres.
    ``symmetry`` (the order of plan rotational symmetry) defaults to 1.

    Parameters
    ----------
    path : path-like

    Returns
    -------
    ReefDesign

    Raises
    ------
    FileAccessError
        The file cannot be read.
    InputError
        Not a design file; the message says what is wrong.
    """
    p = Path(path)
    try:
        doc = json.loads(p.read_text(encoding="utf-8"))
    except OSError as e:
        raise FileAccessError(f"{p}: cannot read the design file ({e.strerror})") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise InputError(f"{p}: not a JSON design file ({e})") from None
    if not isinstance(doc, dict) or not isinstance(doc.get("boxes"), list) or not doc["boxes"]:
        raise InputError(f"{p}: expected an object with a non-empty list 'boxes'")
    boxes = []
    for k, b in enumerate(doc["boxes"]):
        try:
            boxes.append(DesignBox(float(b.get("dx", 0.0)), float(b.get("dy", 0.0)),
                                   float(b.get("dz", 0.0)), float(b["length"]), float(b["width"]),
                                   float(b["height"]), float(b.get("bearing_deg", 0.0))))
        except (KeyError, TypeError, ValueError, AttributeError):
            raise InputError(f"{p}: box {k + 1}: expected numbers length, width, height "
                             f"(and optional dx, dy, dz, bearing_deg), got {b!r}") from None
    try:
        return ReefDesign(str(doc.get("name", p.stem)), tuple(boxes), int(doc.get("symmetry", 1)))
    except ParameterError as e:
        raise InputError(f"{p}: {e}") from None
    except (TypeError, ValueError):
        raise InputError(f"{p}: symmetry {doc.get('symmetry')!r} is not an integer") from None


def parse_designs(spec: str | Sequence[str | ReefDesign] | None) -> tuple[ReefDesign, ...]:
    """Designs from ``"cross2,cross1"``-style names of built-ins and/or JSON design files.

    Parameters
    ----------
    spec : str or sequence of (str or ReefDesign), optional
        Names and JSON files, comma-separated in a string.

    Returns
    -------
    tuple of ReefDesign
        Empty for None or an empty string.

    Raises
    ------
    ParameterError
        A name that is neither built in nor a ``.json`` file (``option="design"``).

    Examples
    --------
    >>> [d.name for d in parse_designs("cross2, hollow")]
    ['cross2', 'hollow']
    """
    if spec is None:
        return ()
    items = [s.strip() for s in spec.split(",")] if isinstance(spec, str) else list(spec)
    out: list[ReefDesign] = []
    for s in items:
        if isinstance(s, ReefDesign):
            out.append(s)
        elif not s:
            continue
        elif s in BUILTIN_DESIGNS:
            out.append(BUILTIN_DESIGNS[s])
        elif s.lower().endswith(".json"):
            out.append(read_design(s))
        else:
            raise ParameterError(f"design: {s!r}; expected a built-in design "
                                 f"({', '.join(BUILTIN_DESIGNS)}) or a .json design file", option="design")
    return tuple(out)


@dataclass(frozen=True)
class DesignFit:
    """A design fitted to one reef: pose, as-built size factor and how well it fits.

    ``x, y`` are the fitted footprint's centroid; ``area`` the design's footprint area
    times ``scale``²; ``misfit`` the share of the soundings within 0.5 m of the fitted edge
    that lie more than 0.1 m on its wrong side (reef outside, seabed inside); ``origin``
    the design frame's origin at the fitted pose (for :meth:`ReefDesign.signed_distance`).
    """

    design: str
    x: float
    y: float
    bearing_deg: float
    scale: float
    area: float
    misfit: float
    n_edge: int
    loss: float
    outline: np.ndarray = field(repr=False, compare=False)
    origin: tuple[float, float] = field(default=(math.nan, math.nan), repr=False, compare=False)

    def to_dict(self) -> dict[str, Any]:
        return to_jsonable({k: getattr(self, k) for k in ("design", "x", "y", "bearing_deg", "scale",
                                                           "area", "misfit", "n_edge")})


def _box_distances(design: ReefDesign, p: np.ndarray, x: float, y: float, bearing_deg: float,
                   scale: float, *, grad: bool = False) -> tuple[np.ndarray, np.ndarray | None]:
    """Signed plan distance of points (N, 2) to each box's rectangle at a pose: (N, B).

    With ``grad``, also its derivatives by (x, y, bearing in degrees, log scale): (N, B, 4);
    else None.
    """
    off, half, ang = design._plan
    t = math.radians(bearing_deg)
    ct, st = math.cos(t), math.sin(t)
    # box centres turned clockwise by the bearing (relative to the pose), and box axes
    ccx = scale * (off[:, 0] * ct + off[:, 1] * st)
    ccy = scale * (-off[:, 0] * st + off[:, 1] * ct)
    ux, uy = np.sin(ang + t), np.cos(ang + t)
    rx = p[:, 0:1] - (x + ccx)
    ry = p[:, 1:2] - (y + ccy)
    pa = rx * ux + ry * uy
    pb = rx * uy - ry * ux
    qa = np.abs(pa) - scale * half[:, 0]
    qb = np.abs(pb) - scale * half[:, 1]
    oa, ob = np.maximum(qa, 0.0), np.maximum(qb, 0.0)
    out = np.hypot(oa, ob)
    d = out + np.minimum(np.maximum(qa, qb), 0.0)
    if not grad:
        return d, None
    # d(d)/d(qa), d(d)/d(qb): outside along the corner normal, inside the nearer side
    inner = out == 0.0
    safe = np.where(inner, 1.0, out)
    da = np.where(inner, (qa >= qb).astype(np.float64), oa / safe)
    db = np.where(inner, (qb > qa).astype(np.float64), ob / safe)
    sa, sb = np.sign(pa), np.sign(pb)
    wx, wy = ccx + rx, ccy + ry  # point relative to the pose origin
    dpa = (-ux, -uy, uy * wx - ux * wy, -(ccx * ux + ccy * uy))
    dpb = (-uy, ux, -ux * wx - uy * wy, -(ccx * uy - ccy * ux))
    dha = (0.0, 0.0, 0.0, scale * half[:, 0])
    dhb = (0.0, 0.0, 0.0, scale * half[:, 1])
    g = np.empty(d.shape + (4,))
    for k in range(4):
        g[..., k] = da * (sa * dpa[k] - dha[k]) + db * (sb * dpb[k] - dhb[k])
    g[..., 2] *= math.pi / 180.0
    return d, g


def _roles(design: ReefDesign, inside: np.ndarray, height: np.ndarray | None, band: float
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Which boxes each sounding is judged against (N, B), which lie on a side wall, and
    which lie higher than the design reaches.

    A reef sounding at height h lies on a box that reaches above h - ``band``; one whose
    height is within ``band`` of no box top lies on a side wall, so on the footprint's
    edge at that height. A seabed sounding must lie outside the boxes standing on the
    base (the seabed under an overhanging upper box can be seen).
    """
    tops = np.array([b.dz + b.height for b in design.boxes])
    n = len(inside)
    use = np.ones((n, len(tops)), dtype=bool)
    wall = np.zeros(n, dtype=bool)
    above = np.zeros(n, dtype=bool)
    if height is not None:
        h = np.asarray(height, np.float64)[inside]
        q = tops[None, :] >= h[:, None] - band
        above[inside] = ~q.any(axis=1)
        q[~q.any(axis=1)] = True  # above the design's top: judged against every box
        use[inside] = q
        wall[inside] = (np.abs(h[:, None] - tops[None, :]) > band).all(axis=1) & (h < tops.max())
    return use, wall, above


def fit_design(xy: np.ndarray, inside: np.ndarray, outside: np.ndarray, design: ReefDesign, *,
               x0: float, y0: float, height: np.ndarray | None = None, sigma: float = 0.03,
               cap: float = 0.12, band: float = 0.25, size_prior: float = 0.1,
               scale_range: tuple[float, float] = SCALE_BOUNDS) -> DesignFit:
    """Fit a design's pose (x, y, bearing) and size factor to the soundings around a reef.

    Costs, each ``(distance / sigma)²`` up to ``(cap / sigma)²``: a reef sounding outside
    the footprint of the boxes that reach its height, a seabed sounding inside any box,
    and a reef sounding on a side wall (its height within ``band`` of no box top, heights
    taken relative to the reef's own top set on the design's) away from that footprint's
    edge either way. Nothing pulls a sounding that is on its right side, so an edge facing
    an acoustic shadow (reef soundings and no seabed beyond) does not drift outward;
    side-wall soundings pin the edges they were measured on. The bearing is scanned over
    one symmetry period; from the best start (and the best one 20 degrees or more from
    it) Levenberg-Marquardt runs twice, with four times the tolerance and cap first.

    Parameters
    ----------
    xy : ndarray (N, 2)
        Plan positions of the soundings near the reef (m).
    inside, outside : ndarray of bool (N,)
        Reef soundings, and seabed soundings; others are ignored.
    design : ReefDesign
    x0, y0 : float
        Starting position (the free-form centroid).
    height : ndarray (N,), optional
        Height of each sounding above the seabed (m); without it every reef sounding is
        only required inside the footprint.
    sigma, cap, band : float
        Edge tolerance, largest cost of one sounding (m), and the tolerance (m) on box-top
        heights (settlement into the seabed, noise).
    size_prior : float
        Prior 1-sigma of the log size factor around 1: it only decides where the soundings
        leave the size free (no side wall seen, pings far apart); wherever they fix it,
        they win.
    scale_range : (float, float)
        Bounds of the size factor.

    Returns
    -------
    DesignFit
    """
    p = np.asarray(xy, np.float64)
    inside = np.asarray(inside, bool)
    sel = inside | np.asarray(outside, bool)
    if sel.sum() < 10 or not inside.any():
        raise ParameterError(f"design {design.name!r}: too few soundings to fit ({int(sel.sum())})")
    if height is not None:
        # heights relative to the reef's own top, set on the design's: a reef sunk into the
        # sediment, or a seabed estimate a little off under it, moves every height alike
        h = np.asarray(height, np.float64)
        h_in = h[inside]
        hi = np.percentile(h_in, 98)
        height = h - (float(np.median(h_in[h_in >= hi - 0.25])) - design.height)
    use, wall, above = _roles(design, inside, height, band)
    p, ins, use, wall, above = p[sel], inside[sel], use[sel], wall[sel], above[sel]
    c = np.array([x0, y0])
    p = p - c  # work near the origin
    period = 360.0 / design.symmetry
    lo, hi = math.log(scale_range[0]), math.log(scale_range[1])

    def distances(v: np.ndarray) -> np.ndarray:
        db, _ = _box_distances(design, p, v[0], v[1], v[2], math.exp(min(max(v[3], lo), hi)))
        return np.where(use, db, np.inf).min(axis=1)

    def wrong_side(d: np.ndarray) -> np.ndarray:
        return np.where(wall, np.abs(d), np.where(ins, np.maximum(d, 0.0), np.maximum(-d, 0.0)))

    def residual(v: np.ndarray, sigma: float = sigma, cap: float = cap) -> np.ndarray:
        r = np.where(above, cap, np.minimum(wrong_side(distances(v)), cap)) / sigma
        return np.append(r, v[3] / size_prior)

    def jacobian(v: np.ndarray, sigma: float = sigma, cap: float = cap) -> np.ndarray:
        ls = min(max(v[3], lo), hi)
        db, g = _box_distances(design, p, v[0], v[1], v[2], math.exp(ls), grad=True)
        assert g is not None
        if ls != v[3]:
            g[..., 3] = 0.0
        k = np.where(use, db, np.inf).argmin(axis=1)
        rows = np.arange(len(p))
        d, gd = db[rows, k], g[rows, k]
        w = wrong_side(d)
        sign = np.where(wall, np.sign(d), np.where(ins, (d > 0).astype(float), -(d < 0).astype(float)))
        live = ~above & (w < cap)
        prior = np.array([[0.0, 0.0, 0.0, 1.0 / size_prior]])
        return np.vstack([gd * (np.where(live, sign, 0.0) / sigma)[:, None], prior])

    # the bearing from a scan over one symmetry period, then least squares on all four
    # parameters from the best bearing and the best one at least 20 degrees from it
    ctr = -design.centroid
    step = period / 12
    scan = np.arange(0.0, period, step)
    costs = np.array([float(np.sum(residual(np.array([*_rotate(ctr, b), b, 0.0])) ** 2)) for b in scan])
    order = np.argsort(costs)
    starts = [order[0]]
    far = [k for k in order[1:] if min((scan[k] - scan[order[0]]) % period,
                                       (scan[order[0]] - scan[k]) % period) >= 20.0]
    if far and costs[far[0]] <= 1.5 * costs[order[0]] + 5.0:
        starts.append(far[0])
    best = None
    for k in starts:
        b = float(scan[k])
        start = np.array([*_rotate(ctr, b), b, 0.0])
        # the first trust region scales with the start: a start of round-off, not of zero,
        # would make it vanish
        start[np.abs(start) < 1e-9] = 0.0
        # coarse to fine: a wide tolerance first smooths away the local minima that thin
        # arms make, then the edge tolerance proper
        for s_k, c_k in ((4 * sigma, 4 * cap), (sigma, cap)):
            r = least_squares(residual, start, method="lm", jac=jacobian, args=(s_k, c_k),
                              x_scale=np.array([0.05, 0.05, 2.0, 0.02]), xtol=1e-4, max_nfev=60)
            r.x[3] = min(max(r.x[3], lo), hi)
            start = r.x
        if best is None or r.cost < best.cost:
            best = r
    assert best is not None
    x, y, bearing, ls = best.x
    scale = math.exp(ls)
    d = distances(best.x)
    edge = np.abs(d) <= 0.5
    wrong = (np.where(wall, np.abs(d) > 0.1, np.where(ins, d > 0.1, d < -0.1)) | above) & edge
    centroid = _rotate(design.centroid * scale, bearing) + np.array([x, y]) + c
    return DesignFit(design.name, float(centroid[0]), float(centroid[1]), float(bearing % period),
                     scale, design.area * scale * scale, float(wrong.sum() / max(edge.sum(), 1)),
                     int(edge.sum()), float(2 * best.cost),
                     design.outline(float(x + c[0]), float(y + c[1]), float(bearing), scale),
                     (float(x + c[0]), float(y + c[1])))
