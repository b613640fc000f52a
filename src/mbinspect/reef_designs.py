"""Reef designs: each a union of boxes in its own frame (base at z = 0, bearing 0 = north),
its plan footprint, outline and signed distance at any pose; the built-in designs and
designs read from JSON files.

Artificial reefs are deployed from a handful of known designs (the reef paper's field holds
double- and single-layer crosses). Fitting a design's pose and size to a reef's soundings is
:func:`mbinspect.reefs.pose.fit_design`.

Examples
--------
>>> import numpy as np
>>> from mbinspect.reef_designs import BUILTIN_DESIGNS
>>> d = BUILTIN_DESIGNS["cross1"]
>>> round(d.area, 2), d.height
(4.16, 1.2)
>>> d.signed_distance(np.array([[0.0, 0.0], [3.0, 3.0]]), 0.0, 0.0, 0.0).round(2).tolist()
[-0.4, 3.0]
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from .errors import FileAccessError, InputError, ParameterError
from .geometry import bearing_to_vector
from .outputs import to_jsonable

__all__ = [
    "DesignBox",
    "ReefDesign",
    "BUILTIN_DESIGNS",
    "parse_designs",
    "read_design",
    "box_distances",
    "Grow",
    "rotate",
]

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


def rotate(v: np.ndarray, bearing_deg: float) -> np.ndarray:
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
            o = rotate(np.array([b.dx, b.dy]) * scale, bearing_deg)
            out.append((x + float(o[0]), y + float(o[1]), z_base + b.dz * scale, b.length * scale,
                        b.width * scale, b.height * scale, (bearing_deg + b.bearing_deg) % 360.0))
        return out

    def signed_distance(self, xy: np.ndarray, x: float, y: float, bearing_deg: float,
                        scale: float = 1.0) -> np.ndarray:
        """Signed plan distance (m) of points (N, 2) to the footprint at a pose: < 0 inside."""
        return box_distances(self, np.asarray(xy, np.float64), x, y, bearing_deg, scale)[0].min(axis=1)

    @cached_property
    def plan_boxes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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
        return rotate(self._outline * scale, bearing_deg) + np.array([x, y])

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


@dataclass(frozen=True, eq=False)
class Grow:
    """How far (m) each side of a footprint is moved out for each of N soundings, by the
    side's outward plan normal: ``reaches`` (D,) or each sounding's own (N, D), for normals
    turned in equal steps from the sounding's ``outward`` (N, 2) plan unit vector toward its
    left, times its ``factor`` (N,). A wide beam's bloom (:mod:`mbinspect.reefs.beam`): each
    sounding heard from its own side and at its own range."""

    reaches: np.ndarray
    outward: np.ndarray
    factor: np.ndarray

    def __call__(self, normals: np.ndarray) -> np.ndarray:
        """The reach at outward unit normals (K, 2), for every sounding: (N, K)."""
        ox, oy = self.outward[:, 0:1], self.outward[:, 1:2]
        nx, ny = normals[None, :, 0], normals[None, :, 1]
        phi = np.arctan2(ny * ox - nx * oy, nx * ox + ny * oy)
        n_dir = self.reaches.shape[-1]
        k = (phi % (2 * np.pi)) / (2 * np.pi) * n_dir
        k0 = np.floor(k).astype(np.int64)
        w = k - k0
        k0 %= n_dir
        k1 = (k0 + 1) % n_dir
        if self.reaches.ndim == 1:
            r0, r1 = self.reaches[k0], self.reaches[k1]
        else:
            r0, r1 = np.take_along_axis(self.reaches, k0, 1), np.take_along_axis(self.reaches, k1, 1)
        return ((1 - w) * r0 + w * r1) * self.factor[:, None]

    def subset(self, rows: np.ndarray) -> Grow:
        """The same for the soundings ``rows``."""
        return Grow(self.reaches if self.reaches.ndim == 1 else self.reaches[rows], self.outward[rows],
                    self.factor[rows])


def box_distances(design: ReefDesign, p: np.ndarray, x: float, y: float, bearing_deg: float,
                   scale: float, *, grad: bool = False, grow: Grow | None = None
                   ) -> tuple[np.ndarray, np.ndarray | None]:
    """Signed plan distance of points (N, 2) to each box's rectangle at a pose: (N, B).

    With ``grad``, also its derivatives by (x, y, bearing in degrees, log scale): (N, B, 4);
    else None. ``grow`` moves each side of every rectangle out by its value at the side's
    outward plan normal (m; a wide beam's bloom, which does not scale with the design): its
    change with the bearing is left out of the derivatives.
    """
    off, half, ang = design.plan_boxes
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
    ha, hb = scale * half[:, 0], scale * half[:, 1]
    if grow is not None:
        # the sides facing +a, -a, +b, -b moved out: each rectangle's centre and half-sides
        ga = grow(np.column_stack([ux, uy])), grow(np.column_stack([-ux, -uy]))
        gb = grow(np.column_stack([uy, -ux])), grow(np.column_stack([-uy, ux]))
        pa, pb = pa - (ga[0] - ga[1]) / 2, pb - (gb[0] - gb[1]) / 2
        ha, hb = ha + (ga[0] + ga[1]) / 2, hb + (gb[0] + gb[1]) / 2
    qa = np.abs(pa) - ha
    qb = np.abs(pb) - hb
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
