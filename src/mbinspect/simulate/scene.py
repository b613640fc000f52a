"""The scene a simulated survey sails over: the seabed height field, piles, reef boxes,
boulders, and the truth labels."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..design_solids import design_solids
from ..errors import ParameterError
from ..geometry import (
    bearing_to_vector,
    convex_hull,
    polygon_distance,
    rectangle_corners,
    vector_to_bearing,
)
from ..reef_designs import BUILTIN_DESIGNS
from ..solids import box_corners

#: Meaning of the per-sounding truth label.
LABELS = {"seabed": 0, "pile": 1, "reef": 2, "boulder": 3, "debris": 4, "outlier": 5}


#: Backscatter strength at normal incidence (dB) by material.
MATERIAL_BS = {"sediment": -30.0, "concrete": -12.0, "rock": -16.0, "steel": -10.0}


@dataclass(frozen=True)
class Seabed:
    """A seabed height field ``z = f(x, y)`` in local coordinates.

    Parameters
    ----------
    z0 : float
        Elevation at the local origin, m (negative below the datum).
    slope_deg, slope_bearing_deg : float
        Plane slope and the bearing it dips toward.
    sand_wave_amplitude, sand_wave_length, sand_wave_bearing_deg : float
        Crest-to-trough half height (m), wavelength (m) and crest-normal bearing.
    roughness, roughness_length : float
        RMS (m) and correlation length (m) of random roughness.
    shore_start, shore_width, shore_slope_deg, shore_roughness : float
        North of local ``y = shore_start`` the seabed rises at ``shore_slope_deg`` over
        ``shore_width`` m, then levels off, and grows rocky (RMS ``shore_roughness`` m): the
        uneven near-shore terrain the reef paper cut away by hand. None (default): no shore.
    pits : tuple of (x, y, depth, radius)
        Scour pits: the seabed lowered by ``depth`` (m) at local ``(x, y)``, a cosine bell
        out to ``radius`` (m). None by default.
    extent : float
        Half-size (m) of the square where roughness is defined (flat beyond).
    seed : int
        Seed of the roughness field.
    """

    z0: float = -21.0
    slope_deg: float = 0.0
    slope_bearing_deg: float = 0.0
    sand_wave_amplitude: float = 0.0
    sand_wave_length: float = 20.0
    sand_wave_bearing_deg: float = 0.0
    roughness: float = 0.03
    roughness_length: float = 2.0
    extent: float = 200.0
    seed: int = 0
    shore_start: float | None = None
    shore_width: float = 30.0
    shore_slope_deg: float = 20.0
    shore_roughness: float = 0.4
    pits: tuple[tuple[float, float, float, float], ...] = ()
    _grid: np.ndarray = field(init=False, repr=False, compare=False)
    _cell: float = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        cell = max(self.roughness_length / 4.0, 0.25)
        n = int(math.ceil(2 * self.extent / cell)) + 2
        grid = np.zeros((n, n))
        if self.roughness > 0 or self.shore_start is not None:
            from scipy.ndimage import gaussian_filter

            rng = np.random.default_rng(self.seed)
            grid = gaussian_filter(rng.standard_normal((n, n)), self.roughness_length / cell,
                                   mode="wrap")
            grid /= max(grid.std(), 1e-12)  # unit RMS; scaled where it is used
        object.__setattr__(self, "_grid", grid)
        object.__setattr__(self, "_cell", cell)

    def _plane_and_waves(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, ...]:
        g = math.tan(math.radians(self.slope_deg))
        sx, sy = -g * bearing_to_vector(self.slope_bearing_deg)
        a = self.sand_wave_amplitude
        if a == 0:  # no sand waves: the plane alone (most scenes; their sines cost as much as all the rest)
            return self.z0 + sx * x + sy * y, np.full(np.shape(x), sx), np.full(np.shape(x), sy)
        k = bearing_to_vector(self.sand_wave_bearing_deg) * (2 * math.pi / self.sand_wave_length)
        phase = k[0] * x + k[1] * y
        z = self.z0 + sx * x + sy * y + a * np.sin(phase)
        gx = sx + a * k[0] * np.cos(phase)
        gy = sy + a * k[1] * np.cos(phase)
        return z, gx, gy

    def _rough(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, ...]:
        c = self._cell
        n = self._grid.shape[0]
        u = np.clip((x + self.extent) / c, 0, n - 1.000001)
        v = np.clip((y + self.extent) / c, 0, n - 1.000001)
        i, j = u.astype(np.intp), v.astype(np.intp)
        fu, fv = u - i, v - j
        g = self._grid
        z00, z10, z01, z11 = g[i, j], g[i + 1, j], g[i, j + 1], g[i + 1, j + 1]
        z = (z00 * (1 - fu) + z10 * fu) * (1 - fv) + (z01 * (1 - fu) + z11 * fu) * fv
        gx = ((z10 - z00) * (1 - fv) + (z11 - z01) * fv) / c
        gy = ((z01 - z00) * (1 - fu) + (z11 - z10) * fu) / c
        return z, gx, gy

    def _shore(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Shore rise, its y-derivative, and the roughness scale with its y-derivative."""
        if self.shore_start is None:
            zero = np.zeros_like(y)
            return zero, zero, np.full_like(y, self.roughness), zero
        u = np.maximum(y - self.shore_start, 0.0)
        g = math.tan(math.radians(self.shore_slope_deg))
        ramp = np.clip(u / 5.0, 0.0, 1.0)
        dramp = np.where((u > 0) & (u < 5.0), 1 / 5.0, 0.0)
        scale = self.roughness + (self.shore_roughness - self.roughness) * ramp
        rising = (u > 0) & (u < self.shore_width)
        return (g * np.minimum(u, self.shore_width), np.where(rising, g, 0.0), scale,
                (self.shore_roughness - self.roughness) * dramp)

    def elevation(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        """Seabed elevation (m) at local ``x, y``."""
        x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
        rise, _, scale, _ = self._shore(y)
        z = self._plane_and_waves(x, y)[0] + scale * self._rough(x, y)[0] + rise
        return z - self._pits(x, y)[0] if self.pits else z

    def gradient(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Partial derivatives dz/dx and dz/dy at local ``x, y``."""
        return self.surface(x, y)[1:]

    def surface(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Elevation (m) and its partial derivatives dz/dx, dz/dy at local ``x, y``, each
        part of the seabed evaluated once for all three (a ray's seabed crossing needs both)."""
        x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
        z1, gx1, gy1 = self._plane_and_waves(x, y)
        r, gx2, gy2 = self._rough(x, y)
        rise, drise, scale, dscale = self._shore(y)
        z = z1 + scale * r + rise
        gx, gy = gx1 + scale * gx2, gy1 + scale * gy2 + dscale * r + drise
        if self.pits:
            low, px, py = self._pits(x, y)
            z, gx, gy = z - low, gx - px, gy - py
        return z, gx, gy

    def _pits(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """How far the pits lower the seabed at ``x, y``, and that lowering's gradient."""
        low, gx, gy = np.zeros(np.broadcast(x, y).shape), np.zeros(np.broadcast(x, y).shape), \
            np.zeros(np.broadcast(x, y).shape)
        for px, py, depth, radius in self.pits:
            dx, dy = x - px, y - py
            r = np.hypot(dx, dy)
            inside = r < radius
            low = low + np.where(inside, depth * (1 + np.cos(np.pi * r / radius)) / 2, 0.0)
            slope = np.where(inside, -depth * np.pi / (2 * radius) * np.sin(np.pi * r / radius), 0.0)
            gx = gx + slope * dx / np.maximum(r, 1e-12)
            gy = gy + slope * dy / np.maximum(r, 1e-12)
        return low, gx, gy

    def to_dict(self) -> dict[str, Any]:
        d = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.init}
        if not self.pits:  # the truth of a scene without pits as it always was
            d.pop("pits")
        return d


@dataclass(frozen=True)
class Pile:
    """A capped cylinder: top centre (local x, y, top_z), radius, tilt and its bearing.

    The axis leans toward ``tilt_bearing_deg`` (clockwise from north) by ``tilt_deg``
    from vertical; the top face is perpendicular to the axis; the pile runs down to
    ``bottom_z`` (below the seabed).
    """

    x: float
    y: float
    top_z: float
    radius: float
    tilt_deg: float = 0.0
    tilt_bearing_deg: float = 0.0
    bottom_z: float = -40.0
    material: str = "concrete"

    @property
    def axis(self) -> np.ndarray:
        """Unit axis vector pointing up, shape (3,)."""
        t = math.radians(self.tilt_deg)
        h = bearing_to_vector(self.tilt_bearing_deg) * math.sin(t)
        return np.array([h[0], h[1], math.cos(t)])


@dataclass(frozen=True)
class Box:
    """An oriented box: base centre (local cx, cy, z0), length along ``bearing_deg``.

    ``axes`` (9 numbers: the length, width and height directions as rows) turns it any way
    in space (a unit on its side or tilted); empty, it stands upright at its bearing.
    """

    cx: float
    cy: float
    z0: float
    length: float
    width: float
    height: float
    bearing_deg: float = 0.0
    axes: tuple[float, ...] = ()

    def frame(self) -> np.ndarray:
        """The box's axes as rows (3, 3), world frame."""
        if self.axes:
            return np.asarray(self.axes, np.float64).reshape(3, 3)
        u = bearing_to_vector(self.bearing_deg)
        return np.array([[u[0], u[1], 0.0], [u[1], -u[0], 0.0], [0.0, 0.0, 1.0]])

    def solid(self) -> tuple[np.ndarray, np.ndarray, tuple[float, float, float]]:
        """(base, axes, size) as :mod:`mbinspect.solids` takes a box."""
        return np.array([self.cx, self.cy, self.z0]), self.frame(), (self.length, self.width, self.height)

    @property
    def top(self) -> float:
        """The highest corner's elevation (m)."""
        return float(box_corners(*self.solid())[:, 2].max()) if self.axes else self.z0 + self.height

    def corners2d(self) -> np.ndarray:
        """The plan outline (corners counter-clockwise), made once per box: placing a field's
        reefs apart asks each box for it thousands of times."""
        made = self.__dict__.get("_outline")
        if made is None:
            made = convex_hull(box_corners(*self.solid())[:, :2]) if self.axes else \
                rectangle_corners(self.cx, self.cy, self.length, self.width, self.bearing_deg)
            object.__setattr__(self, "_outline", made)
        return made.copy()


@dataclass(frozen=True)
class Reef:
    """An artificial reef: a union of boxes placed at (x, y) with a bearing, at rest in an
    orientation (:data:`mbinspect.design_solids.ORIENTATIONS`) and leaning ``tilt_deg``
    toward ``tilt_bearing_deg``."""

    id: int
    kind: str
    x: float
    y: float
    bearing_deg: float
    boxes: tuple[Box, ...]
    group: int = 0
    material: str = "concrete"
    orientation: str = "upright"
    tilt_deg: float = 0.0
    tilt_bearing_deg: float = 0.0


@dataclass(frozen=True)
class Boulder:
    """A rounded rock partly buried in the seabed (a distractor): a sphere of ``radius``, or
    an ellipsoid of semi-axes ``radius`` (along ``bearing_deg``), ``ry`` and ``rz`` when
    they are given. Lobes of one rock share its ``rock`` number (0: a rock of its own)."""

    x: float
    y: float
    z: float
    radius: float
    material: str = "rock"
    ry: float = 0.0
    rz: float = 0.0
    bearing_deg: float = 0.0
    rock: int = 0

    @property
    def axes(self) -> np.ndarray:
        """Semi-axes (along the bearing, across it, vertical), m."""
        return np.array([self.radius, self.ry or self.radius, self.rz or self.radius])


@dataclass(frozen=True)
class Scene:
    """Everything a survey can hit; coordinates are local, ``origin`` is added on output."""

    seabed: Seabed
    piles: tuple[Pile, ...] = ()
    reefs: tuple[Reef, ...] = ()
    boulders: tuple[Boulder, ...] = ()
    debris: tuple[Box, ...] = ()
    origin: tuple[float, float] = (0.0, 0.0)


def reef_boxes(kind: str, x: float, y: float, bearing_deg: float, z_base: float, scale: float = 1.0,
               orientation: str = "upright", tilt_deg: float = 0.0, tilt_bearing_deg: float = 0.0
               ) -> tuple[Box, ...]:
    """The boxes of one reef design placed at local (x, y) with its base at ``z_base``.

    ``kind`` names one of :data:`mbinspect.reef_designs.BUILTIN_DESIGNS` (``cross2``,
    ``cross1``, ``hollow``, ``triangle``, ``cube``); ``scale`` is the as-built size relative to the
    design (every dimension).

    Parameters
    ----------
    kind : str
    x, y : float
        Local position (m).
    bearing_deg : float
    z_base : float
        Base elevation (m).
    scale : float
    orientation, tilt_deg, tilt_bearing_deg
        How the unit came to rest (:func:`mbinspect.design_solids.design_solids`); the
        base is then its lowest corner.

    Returns
    -------
    tuple of Box
    """
    if kind not in BUILTIN_DESIGNS:
        raise ParameterError(
            f"reef kind {kind!r} is unknown; expected {', '.join(BUILTIN_DESIGNS)}"
        )
    if orientation == "upright" and not tilt_deg:
        return tuple(Box(*b) for b in BUILTIN_DESIGNS[kind].placed(x, y, bearing_deg, z_base, scale))
    solids = design_solids(BUILTIN_DESIGNS[kind], orientation, x, y, bearing_deg, z_base, scale,
                           tilt_deg, tilt_bearing_deg)
    return tuple(Box(float(b[0]), float(b[1]), float(b[2]), *size,
                     bearing_deg=vector_to_bearing(a[0, :2]) if np.hypot(*a[0, :2]) > 1e-9 else 0.0,
                     axes=tuple(float(v) for v in a.ravel())) for b, a, size in solids)


def reef_gap(a: Reef, b: Reef) -> float:
    return min(polygon_distance(p.corners2d(), q.corners2d()) for p in a.boxes for q in b.boxes)
