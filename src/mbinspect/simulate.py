"""A ray-cast multibeam survey over a scene whose piles and reefs are known exactly.

Every accuracy figure mbinspect quotes is measured against this module, so it models
what makes field data hard rather than sprinkling points on shapes:

* **Geometry**: every beam of every ping is a ray from the transducer (draft below the
  surface, heave, roll and pitch steering it) across the track; the *first* surface it
  meets makes the sounding, so faces hidden from every line get no points.
* **Scene**: a seabed height field (plane, slope, sand waves, random roughness), piles
  as finite capped cylinders (radius, top elevation, tilt and tilt bearing), reefs as
  unions of oriented boxes (cross-shaped single and double layer, hollow square,
  triangular) and distractors (boulders as spheres, debris as small boxes).
* **Errors**: range noise growing with range and beam angle, beam-pointing noise growing
  as 1/cos(beam angle), both heavy-tailed, per-ping position and heave noise (RTK grade),
  residual roll per ping, per-line height offsets and refraction "smiles", per-beam range
  biases, grazing-angle dropouts, multipath spikes below the seabed and water-column
  noise. Named sonars (:data:`SONARS`) set them: ``shallow`` (the default, calibrated
  against real files), ``deep`` and the idealised ``classic``.
* **Backscatter**: by material (concrete and rock brighter than sediment), with a
  Lambertian fall-off, a near-specular peak, speckle and (uncalibrated, as stored by
  real systems) a gain and an angular fall that change from line to line; exported as ``intensity``
  = backscatter strength in dB + 100.

Coordinates are local to the scene during ray casting and shifted by the scene's
``origin`` (a projected easting/northing) on output, as a real export would be.

Examples
--------
>>> from mbinspect.simulate import simulate
>>> sim = simulate("jacket", seed=1, ping_spacing=0.5)   # a sparse, quick survey
>>> len(sim.truth["piles"])
4
>>> sim.cloud.xyz.shape[1]
3
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .checks import fail, integer
from .designs import BUILTIN_DESIGNS
from .errors import ParameterError
from .geometry import (
    bearing_to_vector,
    convex_hull,
    min_area_rectangle,
    polygon_area,
    polygon_distance,
    rectangle_corners,
)
from .io import PointCloud, write

__all__ = [
    "Seabed",
    "simulate_lines",
    "reef_reference_rows",
    "Pile",
    "Box",
    "Reef",
    "Boulder",
    "Scene",
    "Sonar",
    "Line",
    "Survey",
    "Simulation",
    "JacketOptions",
    "ReefFieldOptions",
    "PRESETS",
    "SONARS",
    "named_sonar",
    "default_options",
    "reef_boxes",
    "reef_truth",
    "survey",
    "simulate",
    "LABELS",
]

#: Meaning of the per-sounding truth label.
LABELS = {"seabed": 0, "pile": 1, "reef": 2, "boulder": 3, "debris": 4, "outlier": 5}

#: Backscatter strength at normal incidence (dB) by material.
MATERIAL_BS = {"sediment": -30.0, "concrete": -12.0, "rock": -16.0, "steel": -10.0}


# ---------------------------------------------------------------------------- scene


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
        k = bearing_to_vector(self.sand_wave_bearing_deg) * (2 * math.pi / self.sand_wave_length)
        phase = k[0] * x + k[1] * y
        a = self.sand_wave_amplitude
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
        return self._plane_and_waves(x, y)[0] + scale * self._rough(x, y)[0] + rise

    def gradient(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Partial derivatives dz/dx and dz/dy at local ``x, y``."""
        _, gx1, gy1 = self._plane_and_waves(x, y)
        r, gx2, gy2 = self._rough(x, y)
        _, drise, scale, dscale = self._shore(np.asarray(y, np.float64))
        return gx1 + scale * gx2, gy1 + scale * gy2 + dscale * r + drise

    def to_dict(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.init}


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
    """An oriented box: base centre (local cx, cy, z0), length along ``bearing_deg``."""

    cx: float
    cy: float
    z0: float
    length: float
    width: float
    height: float
    bearing_deg: float = 0.0

    def corners2d(self) -> np.ndarray:
        return rectangle_corners(self.cx, self.cy, self.length, self.width, self.bearing_deg)


@dataclass(frozen=True)
class Reef:
    """An artificial reef: a union of boxes placed at (x, y) with a bearing."""

    id: int
    kind: str
    x: float
    y: float
    bearing_deg: float
    boxes: tuple[Box, ...]
    group: int = 0
    material: str = "concrete"


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


# ---------------------------------------------------------------------------- survey


@dataclass(frozen=True)
class Sonar:
    """Multibeam system and error model. All sigmas are 1-sigma; ``noise_scale`` scales them.

    Parameters
    ----------
    swath_deg : float
        Full swath opening angle, degrees (beams from -swath/2 to +swath/2).
    n_beams : int
        Beams per ping.
    spacing : {"equidistant", "equiangular"}
        Beam distribution across the swath.
    draft : float
        Transducer depth below the surface (m).
    range_sigma, range_sigma_rel : float
        Range noise: constant part (m) plus a fraction of the range.
    angle_sigma_deg : float
        Beam-pointing noise at nadir (deg), growing as 1/cos(beam angle).
    position_sigma, vertical_sigma : float
        Per-ping horizontal and vertical positioning noise (m): RTK, heave.
    attitude_sigma_deg : float
        Per-ping residual roll error (deg), common to every beam of the ping.
    refraction_bias_deg : float
        Systematic depression-angle error at the outermost beam (deg), growing as
        (angle / max angle)^2 toward the outer beams (sound-speed error).
    roll_amplitude_deg, pitch_amplitude_deg, heave_amplitude : float
        Vessel motion (compensated) that steers the beams.
    spike_rate, water_column_rate : float
        Fractions of soundings that are multipath spikes (long ranges) and
        water-column returns (short ranges).
    noise_scale : float
        Multiplies every noise sigma and outlier rate (1 = default).
    tail_dof : float
        Heavy tails: the range and pointing noise are Student-t with this many degrees of
        freedom, scaled so that their robust σ (1.4826 × median absolute value) is the
        sigma given; 0 (default) keeps them normal. Real shallow files show p99/σ of
        3.7–5.6 (``benchmarks/real_noise.py``); with the simulator's per-ping errors, 2.5
        gives 3.9 and 3 gives 3.5.
    speckle_db : float
        Backscatter speckle, 1σ (dB); real files show 1.3–12 dB within an angle bin.
    range_angle_growth : float
        Range noise grows off nadir by the factor 1 + growth·|sin θ| / sin 60°: the
        bottom detection worsens as the footprint lengthens (0: no growth).
    line_offset_sigma : float
        Per-line vertical offset, 1σ (m): tide, draft and heave errors that make
        overlapping strips disagree.
    refraction_sigma_deg : float
        Per-line random sound-speed error: a depression-angle bias at the outermost beam
        (deg, 1σ), drawn for each line and shaped like ``refraction_bias_deg`` (the
        across-swath "smile").
    beam_bias_sigma : float
        Per-line, per-beam range offset, 1σ (m): the stripes along track that a beam's
        own detection bias leaves.
    bs_line_sigma_db : float
        Per-line backscatter gain offset, 1σ (dB): uncalibrated levels.
    bs_angle_db : float
        Uncalibrated angular response: the stored backscatter falls by this many dB
        (× a per-line factor drawn in [0.5, 1.5]) from nadir to the outermost beam.
    """

    swath_deg: float = 120.0
    n_beams: int = 256
    spacing: str = "equidistant"
    draft: float = 0.5
    range_sigma: float = 0.01
    range_sigma_rel: float = 0.0005
    angle_sigma_deg: float = 0.03
    position_sigma: float = 0.015
    vertical_sigma: float = 0.02
    attitude_sigma_deg: float = 0.01
    refraction_bias_deg: float = 0.0
    roll_amplitude_deg: float = 2.0
    pitch_amplitude_deg: float = 1.0
    heave_amplitude: float = 0.2
    spike_rate: float = 0.001
    water_column_rate: float = 0.0005
    noise_scale: float = 1.0
    tail_dof: float = 0.0
    speckle_db: float = 2.5
    range_angle_growth: float = 0.0
    line_offset_sigma: float = 0.0
    refraction_sigma_deg: float = 0.0
    beam_bias_sigma: float = 0.0
    bs_line_sigma_db: float = 0.0
    bs_angle_db: float = 0.0

    def beam_angles(self) -> np.ndarray:
        """Nominal beam angles (radians, + to starboard), shape (n_beams,)."""
        half = math.radians(self.swath_deg / 2.0)
        if self.spacing == "equiangular":
            return np.linspace(-half, half, self.n_beams)
        if self.spacing == "equidistant":
            return np.arctan(np.linspace(-math.tan(half), math.tan(half), self.n_beams))
        raise ParameterError(
            f"spacing: {self.spacing!r} is not 'equidistant' or 'equiangular'"
        )


@dataclass(frozen=True)
class Line:
    """A survey line: a polyline of local (x, y) vertices sailed at ``ping_spacing``."""

    vertices: tuple[tuple[float, float], ...]
    ping_spacing: float = 0.1
    speed: float = 2.0

    def pings(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Ping positions (P, 2), headings as unit vectors (P, 2), along-line distance (P,)."""
        v = np.asarray(self.vertices, dtype=np.float64)
        seg = np.diff(v, axis=0)
        seglen = np.hypot(seg[:, 0], seg[:, 1])
        cum = np.concatenate([[0.0], np.cumsum(seglen)])
        s = np.arange(0.0, cum[-1] + 1e-9, self.ping_spacing)
        k = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(seg) - 1)
        frac = (s - cum[k]) / np.maximum(seglen[k], 1e-12)
        pos = v[k] + frac[:, None] * seg[k]
        heading = seg[k] / np.maximum(seglen[k], 1e-12)[:, None]
        return pos, heading, s


@dataclass(frozen=True)
class Survey:
    """The lines sailed and the system used."""

    lines: tuple[Line, ...]
    sonar: Sonar = Sonar()

    def estimated_soundings(self) -> int:
        """Beams times pings over every line: the most soundings the survey can make."""
        pings = 0
        for line in self.lines:
            v = np.asarray(line.vertices, np.float64)
            length = float(np.hypot(*np.diff(v, axis=0).T).sum())
            pings += int(length / line.ping_spacing) + 1
        return pings * self.sonar.n_beams


# ---------------------------------------------------------------------------- ray casting


def _noise(rng: np.random.Generator, n: int, dof: float) -> np.ndarray:
    """Unit noise: normal, or Student-t of ``dof`` degrees of freedom with the normal's MAD."""
    if dof <= 0:
        return rng.normal(0.0, 1.0, n)
    from scipy.stats import t as student_t

    return rng.standard_t(dof, n) * (0.6744897501960817 / float(student_t.ppf(0.75, dof)))


def _seabed_hits(seabed: Seabed, o: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Ray parameter t of the first seabed crossing (Newton on the height field)."""
    t = (seabed.z0 - o[:, 2]) / d[:, 2]
    for _ in range(12):
        p = o + t[:, None] * d
        z = seabed.elevation(p[:, 0], p[:, 1])
        gx, gy = seabed.gradient(p[:, 0], p[:, 1])
        g = p[:, 2] - z
        dg = d[:, 2] - gx * d[:, 0] - gy * d[:, 1]
        step = g / np.minimum(dg, -0.05)
        t = np.maximum(t - step, 0.0)
        if np.max(np.abs(g)) < 1e-6:
            break
    return t


def _hit_cylinder(pile: Pile, o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = pile.axis
    c = np.array([pile.x, pile.y, pile.top_z])
    length = (pile.top_z - pile.bottom_z) / max(a[2], 1e-6)
    w = o - c
    wa, da = w @ a, d @ a
    wp = w - wa[:, None] * a
    dp = d - da[:, None] * a
    A = np.einsum("ij,ij->i", dp, dp)
    B = 2 * np.einsum("ij,ij->i", wp, dp)
    C = np.einsum("ij,ij->i", wp, wp) - pile.radius**2
    disc = B * B - 4 * A * C
    with np.errstate(invalid="ignore", divide="ignore"):
        ts = (-B - np.sqrt(disc)) / (2 * A)
    s = wa + ts * da
    side_ok = (disc >= 0) & (ts > 0) & (s <= 0) & (s >= -length)
    with np.errstate(invalid="ignore", divide="ignore"):
        tc = -wa / da
    rc = wp + tc[:, None] * dp
    cap_ok = (da < 0) & (tc > 0) & (np.einsum("ij,ij->i", rc, rc) <= pile.radius**2)
    t = np.where(side_ok, ts, np.inf)
    t = np.where(cap_ok & (tc < t), tc, t)
    use_cap = cap_ok & (tc <= t)
    radial = (wp + ts[:, None] * dp) / pile.radius
    normal = np.where(use_cap[:, None], a[None, :], radial)
    return t, normal


def _hit_box(box: Box, o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    u = bearing_to_vector(box.bearing_deg)
    w = np.array([u[1], -u[0]])
    rot = np.array([[u[0], u[1], 0.0], [w[0], w[1], 0.0], [0.0, 0.0, 1.0]])
    ol = (o - np.array([box.cx, box.cy, box.z0])) @ rot.T
    dl = d @ rot.T
    lo = np.array([-box.length / 2, -box.width / 2, 0.0])
    hi = np.array([box.length / 2, box.width / 2, box.height])
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (lo - ol) / dl
        t2 = (hi - ol) / dl
    tmin = np.fmin(t1, t2)
    tmax = np.fmax(t1, t2)
    tmin = np.where(np.isnan(tmin), -np.inf, tmin)
    tmax = np.where(np.isnan(tmax), np.inf, tmax)
    near_axis = np.argmax(tmin, axis=1)
    tnear = tmin[np.arange(len(ol)), near_axis]
    tfar = tmax.min(axis=1)
    ok = (tnear <= tfar) & (tnear > 0)
    t = np.where(ok, tnear, np.inf)
    nl = np.zeros_like(ol)
    nl[np.arange(len(ol)), near_axis] = -np.sign(dl[np.arange(len(ol)), near_axis])
    return t, nl @ rot


def _hit_sphere(b: Boulder, o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First hit on an ellipsoid (a sphere when its axes agree): the ray is carried into the
    frame where the ellipsoid is the unit sphere, which keeps the ray parameter ``t``."""
    if not (b.ry or b.rz):
        w = o - np.array([b.x, b.y, b.z])
        bb = np.einsum("ij,ij->i", w, d)
        disc = bb * bb - (np.einsum("ij,ij->i", w, w) - b.radius**2)
        with np.errstate(invalid="ignore"):
            t = -bb - np.sqrt(disc)
        t = np.where((disc >= 0) & (t > 0), t, np.inf)
        return t, (w + np.where(np.isfinite(t), t, 0.0)[:, None] * d) / b.radius
    c, s = math.cos(math.radians(b.bearing_deg)), math.sin(math.radians(b.bearing_deg))
    rot = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])  # world -> ellipsoid axes
    ax = b.axes
    w = ((o - np.array([b.x, b.y, b.z])) @ rot.T) / ax
    v = (d @ rot.T) / ax
    aa = np.einsum("ij,ij->i", v, v)
    bb = np.einsum("ij,ij->i", w, v)
    cc = np.einsum("ij,ij->i", w, w) - 1.0
    disc = bb * bb - aa * cc
    with np.errstate(invalid="ignore"):
        t = (-bb - np.sqrt(disc)) / aa
    t = np.where((disc >= 0) & (t > 0), t, np.inf)
    p = w + np.where(np.isfinite(t), t, 0.0)[:, None] * v
    n = (p / ax) @ rot  # the gradient of |x / axes|^2, back in the world frame
    return t, n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)


@dataclass(frozen=True)
class _Target:
    kind: int
    ident: int
    material: str
    bbox: tuple[float, float, float, float]  # xmin, xmax, ymin, ymax
    top: float
    hit: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


def _targets(scene: Scene) -> list[_Target]:
    out: list[_Target] = []
    for i, p in enumerate(scene.piles):
        a = p.axis
        length = (p.top_z - p.bottom_z) / max(a[2], 1e-6)
        bottom = np.array([p.x, p.y]) - a[:2] * length
        xs = [p.x, bottom[0]]
        ys = [p.y, bottom[1]]
        r = p.radius
        out.append(_Target(LABELS["pile"], i + 1, p.material,
                           (min(xs) - r, max(xs) + r, min(ys) - r, max(ys) + r),
                           p.top_z + r, _bind(_hit_cylinder, p)))
    for reef in scene.reefs:
        for box in reef.boxes:
            out.append(_box_target(box, LABELS["reef"], reef.id, reef.material))
    for i, b in enumerate(scene.boulders):
        reach = float(b.axes[:2].max())
        out.append(_Target(LABELS["boulder"], b.rock or i + 1, b.material,
                           (b.x - reach, b.x + reach, b.y - reach, b.y + reach),
                           b.z + float(b.axes[2]), _bind(_hit_sphere, b)))
    for i, box in enumerate(scene.debris):
        out.append(_box_target(box, LABELS["debris"], i + 1, "steel"))
    return out


_HitFn = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


def _bind(fn: Callable[[Any, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]],
          obj: Any) -> _HitFn:
    def hit(o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return fn(obj, o, d)

    return hit


def _box_target(box: Box, kind: int, ident: int, material: str) -> _Target:
    c = box.corners2d()
    lo, hi = c.min(axis=0), c.max(axis=0)
    return _Target(kind, ident, material, (lo[0], hi[0], lo[1], hi[1]), box.z0 + box.height,
                   _bind(_hit_box, box))


def _first_object_hits(targets: list[_Target], o: np.ndarray, d: np.ndarray, t: np.ndarray
                       ) -> Iterator[tuple[_Target, np.ndarray, np.ndarray, np.ndarray]]:
    """For each target, the rays that meet it before ``t`` (updated in place as they do):
    yields the target, those rays' indices, their ray parameters and surface normals."""
    if not targets:
        return
    p = o + t[:, None] * d
    ztop = max(tg.top for tg in targets)
    t_top = np.clip((ztop - o[:, 2]) / d[:, 2], 0.0, None)
    q = o + np.minimum(t_top, t)[:, None] * d
    sx0 = np.minimum(q[:, 0], p[:, 0])
    sx1 = np.maximum(q[:, 0], p[:, 0])
    sy0 = np.minimum(q[:, 1], p[:, 1])
    sy1 = np.maximum(q[:, 1], p[:, 1])
    order = np.argsort(sx0)
    sx0s = sx0[order]
    widest = float((sx1 - sx0).max()) if len(sx0) else 0.0
    for tg in targets:
        xmin, xmax, ymin, ymax = tg.bbox
        # only rays whose x-span can meet the box: those starting within one widest span
        # west of it (the same candidates in the same order, found without a full scan)
        start = np.searchsorted(sx0s, xmin - widest, side="left")
        stop = np.searchsorted(sx0s, xmax, side="right")
        cand = order[start:stop]
        cand = cand[(sx1[cand] >= xmin) & (sy0[cand] <= ymax) & (sy1[cand] >= ymin)]
        if len(cand) == 0:
            continue
        tt, nn = tg.hit(o[cand], d[cand])
        better = tt < t[cand]
        if not better.any():
            continue
        idx = cand[better]
        t[idx] = tt[better]
        yield tg, idx, tt[better], nn[better]


def hit_objects(scene: Scene, o: np.ndarray, d: np.ndarray, t_max: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The first hit of each ray on the scene's objects (piles, reefs, boulders, debris) before ``t_max``.

    The scene's seabed is not used: ``t_max`` is where each ray meets the seabed (a real
    sounding, for :mod:`mbinspect.inject`).

    Parameters
    ----------
    scene : Scene
        The objects, in the same coordinates as ``o``.
    o, d : ndarray, shape (N, 3)
        Ray origins and unit directions.
    t_max : ndarray, shape (N,)
        Ray parameter of the seabed.

    Returns
    -------
    t : ndarray, shape (N,)
        Ray parameter of the first hit (``t_max`` where no object is hit first).
    label : ndarray of int8
        :data:`LABELS` code of what was hit (0: the seabed).
    ident : ndarray of int32
        The object's id (1-based pile index, reef id, ...), 0 for the seabed.

    Examples
    --------
    >>> scene = Scene(Seabed(z0=-10.0), piles=(Pile(0.0, 0.0, -5.0, 1.0),))
    >>> o = np.array([[0.0, 0.0, 0.0], [5.0, 0.0, 0.0]]); d = np.array([[0.0, 0.0, -1.0]] * 2)
    >>> t, label, ident = hit_objects(scene, o, d, np.array([10.0, 10.0]))
    >>> t.tolist(), label.tolist()
    ([5.0, 10.0], [1, 0])
    """
    t = np.array(t_max, dtype=float)
    label = np.full(len(t), LABELS["seabed"], dtype=np.int8)
    ident = np.zeros(len(t), dtype=np.int32)
    for tg, idx, _, _ in _first_object_hits(_targets(scene), o, d, t):
        label[idx] = tg.kind
        ident[idx] = tg.ident
    return t, label, ident


def _cast(scene: Scene, targets: list[_Target], o: np.ndarray, d: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """First hit of every ray: t, label, object id, surface normal, material index."""
    t = _seabed_hits(scene.seabed, o, d)
    p = o + t[:, None] * d
    gx, gy = scene.seabed.gradient(p[:, 0], p[:, 1])
    normal = np.column_stack([-gx, -gy, np.ones_like(gx)])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    label = np.full(len(t), LABELS["seabed"], dtype=np.int8)
    ident = np.zeros(len(t), dtype=np.int32)
    materials = ["sediment"]
    mat = np.zeros(len(t), dtype=np.int8)
    for tg, idx, _, nn in _first_object_hits(targets, o, d, t):
        normal[idx] = nn
        label[idx] = tg.kind
        ident[idx] = tg.ident
        if tg.material not in materials:
            materials.append(tg.material)
        mat[idx] = materials.index(tg.material)
    return t, label, ident, normal, materials


def survey(scene: Scene, plan: Survey, *, seed: int | None = 0,
           progress: Callable[[float], None] | None = None
           ) -> tuple[PointCloud, np.ndarray, np.ndarray]:
    """Sail ``plan`` over ``scene`` and return the soundings with their truth labels.

    Parameters
    ----------
    scene : Scene
    plan : Survey
    seed : int, optional
        Seed of every random error; the same seed gives the same soundings.
    progress : callable, optional
        Called with the fraction done (0..1) after each batch of pings.

    Returns
    -------
    cloud : PointCloud
        World coordinates (``scene.origin`` added) with fields ``intensity``,
        ``beam_angle`` (deg, + starboard), ``line`` (1-based) and ``ping``.
    label : ndarray of int8, shape (N,)
        What each sounding hit (:data:`LABELS`).
    ident : ndarray of int32, shape (N,)
        Which pile (1-based), reef id, boulder or debris item it hit (0 = none).
    """
    sonar = plan.sonar
    ns = sonar.noise_scale
    if ns < 0:
        raise ParameterError(f"noise_scale: {ns} is negative; expected >= 0")
    rng = np.random.default_rng(seed)
    beams = sonar.beam_angles()
    pos_l, head_l, dist_l, line_l = [], [], [], []
    for k, line in enumerate(plan.lines):
        pos, head, s = line.pings()
        pos_l.append(pos)
        head_l.append(head)
        dist_l.append(s / line.speed)
        line_l.append(np.full(len(pos), k + 1, dtype=np.int32))
    pos = np.concatenate(pos_l)
    head = np.concatenate(head_l)
    time = np.concatenate(dist_l)
    line_id = np.concatenate(line_l)
    n_ping = len(pos)
    # vessel motion (known and compensated: it only steers where the beams go)
    roll = math.radians(sonar.roll_amplitude_deg) * np.sin(2 * np.pi * time / 7.0 + 0.3)
    pitch = math.radians(sonar.pitch_amplitude_deg) * np.sin(2 * np.pi * time / 5.0 + 1.1)
    heave = sonar.heave_amplitude * np.sin(2 * np.pi * time / 6.0)
    # per-ping errors
    dpos = rng.normal(0.0, 1.0, (n_ping, 3)) * (
        np.array([sonar.position_sigma, sonar.position_sigma, sonar.vertical_sigma]) * ns
    )
    droll = rng.normal(0.0, math.radians(sonar.attitude_sigma_deg) * ns, n_ping)
    # per-line errors, from their own stream so that a model without them draws as before
    lrng = np.random.default_rng(np.random.SeedSequence(seed).spawn(1)[0])
    n_lines = len(plan.lines)
    line_dz = lrng.normal(0.0, sonar.line_offset_sigma * ns, n_lines)
    line_refr = math.radians(sonar.refraction_bias_deg) + lrng.normal(
        0.0, math.radians(sonar.refraction_sigma_deg) * ns, n_lines)
    beam_bias = lrng.normal(0.0, sonar.beam_bias_sigma * ns, (n_lines, len(beams)))
    bs_gain = lrng.normal(0.0, sonar.bs_line_sigma_db, n_lines)
    bs_fall = sonar.bs_angle_db * lrng.uniform(0.5, 1.5, n_lines)
    growth = 1.0 + sonar.range_angle_growth * np.abs(np.sin(beams)) / math.sin(math.radians(60.0))
    targets = _targets(scene)
    out_xyz, out_int, out_ang, out_line, out_ping, out_lab, out_id = [], [], [], [], [], [], []
    batch = max(1, 400_000 // len(beams))
    for start in range(0, n_ping, batch):
        sl = slice(start, min(start + batch, n_ping))
        m = sl.stop - sl.start
        hd = head[sl]
        along = np.column_stack([hd, np.zeros(m)])
        across = np.column_stack([hd[:, 1], -hd[:, 0], np.zeros(m)])  # starboard
        down = np.array([0.0, 0.0, -1.0])
        theta = beams[None, :] + roll[sl, None]  # (m, B)
        dirs = (np.cos(theta)[..., None] * down + np.sin(theta)[..., None] * across[:, None, :]
                + np.sin(pitch[sl])[:, None, None] * along[:, None, :])
        dirs /= np.linalg.norm(dirs, axis=2, keepdims=True)
        orig = np.column_stack([pos[sl], -sonar.draft + heave[sl]])
        o = np.repeat(orig, len(beams), axis=0)
        d = dirs.reshape(-1, 3)
        t, label, ident, normal, materials = _cast(scene, _within(targets, orig, scene.seabed, sonar), o, d)
        pi = np.repeat(np.arange(sl.start, sl.stop), len(beams))
        li = line_id[pi] - 1
        bi = np.tile(np.arange(len(beams)), m)
        beam = beams[bi]
        # detection: grazing incidences return nothing
        cos_inc = np.clip(-np.einsum("ij,ij->i", d, normal), 0.0, 1.0)
        keep = rng.random(len(t)) < np.clip((cos_inc - 0.03) / 0.12, 0.0, 1.0)
        # measurement errors: range and pointing, growing with range and angle
        sig_r = (sonar.range_sigma + sonar.range_sigma_rel * t) * ns * growth[bi]
        sig_a = math.radians(sonar.angle_sigma_deg) * ns / np.cos(beam)
        bias = line_refr[li] * (beam / beams.max()) ** 2 * np.sign(beam)
        dang = _noise(rng, len(t), sonar.tail_dof) * sig_a + droll[pi] + bias
        rng_meas = t + _noise(rng, len(t), sonar.tail_dof) * sig_r + beam_bias[li, bi]
        # derivative of the beam direction with respect to its angle (in the swath plane)
        th = theta.reshape(-1)
        dtheta = (-np.sin(th)[:, None] * down
                  + np.cos(th)[:, None] * np.repeat(across, len(beams), axis=0))
        xyz = o + rng_meas[:, None] * d + (t * dang)[:, None] * dtheta + dpos[pi]
        xyz[:, 2] += line_dz[li]
        # outliers
        u = rng.random(len(t))
        spike = u < sonar.spike_rate * ns
        wcol = (u >= sonar.spike_rate * ns) & (u < (sonar.spike_rate + sonar.water_column_rate) * ns)
        xyz[spike] = o[spike] + (t[spike] + rng.uniform(1.0, 6.0, spike.sum()))[:, None] * d[spike]
        xyz[wcol] = o[wcol] + (t[wcol] * rng.uniform(0.15, 0.9, wcol.sum()))[:, None] * d[wcol]
        label = np.where(spike | wcol, LABELS["outlier"], label).astype(np.int8)
        ident = np.where(spike | wcol, 0, ident)
        # backscatter (dB): material, Lambert, specular peak, speckle
        mat_bs = np.array([MATERIAL_BS[mm] for mm in materials])
        inc = np.arccos(cos_inc)
        bs = (mat_bs[_material_of(label, ident, scene, materials)]
              + 10 * np.log10(np.maximum(cos_inc**2, 1e-3))
              + 8.0 * np.exp(-((inc / math.radians(8.0)) ** 2))
              + rng.normal(0.0, sonar.speckle_db, len(t))
              + bs_gain[li] - bs_fall[li] * np.abs(beam) / beams.max())
        bs = np.where(label == LABELS["outlier"], rng.normal(-45.0, 5.0, len(t)), bs)
        keep &= np.isfinite(t)
        out_xyz.append(xyz[keep])
        out_int.append(np.round(bs[keep] + 100.0, 1))
        out_ang.append(np.round(np.degrees(beam[keep]), 3))
        out_line.append(line_id[pi][keep])
        out_ping.append(pi[keep].astype(np.int32) + 1)
        out_lab.append(label[keep])
        out_id.append(ident[keep])
        if progress is not None:
            progress(sl.stop / n_ping)
    xyz = np.concatenate(out_xyz)
    xyz[:, 0] += scene.origin[0]
    xyz[:, 1] += scene.origin[1]
    cloud = PointCloud(
        xyz,
        {
            "intensity": np.concatenate(out_int),
            "beam_angle": np.concatenate(out_ang),
            "line": np.concatenate(out_line),
            "ping": np.concatenate(out_ping),
        },
    )
    return cloud, np.concatenate(out_lab), np.concatenate(out_id)


def _within(targets: list[_Target], origins: np.ndarray, seabed: Seabed, sonar: Sonar) -> list[_Target]:
    """The targets a batch of pings can reach: within the widest beam's reach (20 m below
    the deepest seabed under the transducers, 10° past the swath) of their plan extent;
    the others cannot be hit (the same hits, found without testing every object of a
    large scene)."""
    if len(targets) < 50:
        return targets
    depth = float(np.max(origins[:, 2] - seabed.elevation(origins[:, 0], origins[:, 1]))) + 20.0
    angle = min(math.radians(sonar.swath_deg / 2 + 10.0), math.radians(85.0))
    reach = depth * math.tan(angle) + 10.0
    x0, y0 = origins[:, :2].min(axis=0) - reach
    x1, y1 = origins[:, :2].max(axis=0) + reach
    return [tg for tg in targets
            if not (tg.bbox[1] < x0 or tg.bbox[0] > x1 or tg.bbox[3] < y0 or tg.bbox[2] > y1)]


def _material_of(label: np.ndarray, ident: np.ndarray, scene: Scene,
                 materials: list[str]) -> np.ndarray:
    """Index into ``materials`` of what each sounding hit."""
    out = np.zeros(len(label), dtype=np.intp)
    kinds = {LABELS["pile"]: [p.material for p in scene.piles],
             LABELS["boulder"]: [b.material for b in scene.boulders]}
    reef_mat = {r.id: r.material for r in scene.reefs}
    for kind, mats in kinds.items():
        sel = label == kind
        if sel.any():
            idx = np.array([materials.index(m) if m in materials else 0 for m in mats])
            out[sel] = idx[ident[sel] - 1]
    sel = label == LABELS["reef"]
    if sel.any():
        for rid in np.unique(ident[sel]):
            m = reef_mat.get(int(rid), "concrete")
            out[sel & (ident == rid)] = materials.index(m) if m in materials else 0
    sel = label == LABELS["debris"]
    if sel.any() and "steel" in materials:
        out[sel] = materials.index("steel")
    return out



# ---------------------------------------------------------------------------- reefs


def reef_boxes(kind: str, x: float, y: float, bearing_deg: float, z_base: float, scale: float = 1.0
               ) -> tuple[Box, ...]:
    """The boxes of one reef design placed at local (x, y) with its base at ``z_base``.

    ``kind`` names one of :data:`mbinspect.designs.BUILTIN_DESIGNS` (``cross2``,
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

    Returns
    -------
    tuple of Box
    """
    if kind not in BUILTIN_DESIGNS:
        raise ParameterError(
            f"reef kind {kind!r} is unknown; expected {', '.join(BUILTIN_DESIGNS)}"
        )
    return tuple(Box(*b) for b in BUILTIN_DESIGNS[kind].placed(x, y, bearing_deg, z_base, scale))


def _reef_gap(a: Reef, b: Reef) -> float:
    return min(polygon_distance(p.corners2d(), q.corners2d()) for p in a.boxes for q in b.boxes)


def reef_truth(reef: Reef, seabed: Seabed, origin: tuple[float, float], cell: float = 0.02
               ) -> dict[str, Any]:
    """A reef's truth record as ``truth.json`` holds it: centre, seabed and top elevations,
    exposed height, footprint area, rectangle, volume, outline and boxes.

    Measured on a ``cell`` m raster of the boxes' union; the height is the top above the
    seabed at the footprint's centre, so a sunk reef has its exposed height. Local
    coordinates, ``origin`` added on output.
    """
    corners = np.concatenate([bx.corners2d() for bx in reef.boxes])
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    gx = np.arange(lo[0] + cell / 2, hi[0], cell)
    gy = np.arange(lo[1] + cell / 2, hi[1], cell)
    X, Y = np.meshgrid(gx, gy)
    pts = np.column_stack([X.ravel(), Y.ravel()])
    top = np.full(len(pts), -np.inf)
    for bx in reef.boxes:
        u = bearing_to_vector(bx.bearing_deg)
        rel = pts - np.array([bx.cx, bx.cy])
        inside = (np.abs(rel @ u) <= bx.length / 2) & (np.abs(rel @ np.array([u[1], -u[0]]))
                                                       <= bx.width / 2)
        top = np.where(inside, np.maximum(top, bx.z0 + bx.height), top)
    covered = np.isfinite(top)
    fp = pts[covered]
    sea = seabed.elevation(fp[:, 0], fp[:, 1])
    area = covered.sum() * cell * cell
    centre = fp.mean(axis=0)
    z_sea = float(seabed.elevation(centre[0], centre[1]))
    z_top = float(max(bx.z0 + bx.height for bx in reef.boxes))
    rect = min_area_rectangle(corners)
    hull = convex_hull(corners)
    height = z_top - z_sea
    return {
        "id": reef.id, "group": reef.group, "kind": reef.kind,
        "x": float(centre[0] + origin[0]), "y": float(centre[1] + origin[1]),
        "z_seabed": z_sea, "z_top": z_top, "height": height, "area": float(area),
        "length": rect.length, "width": rect.width, "orientation_deg": rect.bearing_deg,
        "volume": float(np.sum(np.maximum(top[covered] - sea, 0.0)) * cell * cell),
        "envelope_volume": rect.length * rect.width * height,
        "bearing_deg": reef.bearing_deg % 360.0,
        "outline": (hull + np.array(origin)).round(4).tolist(),
        "boxes": [dict(dataclasses.asdict(bx), cx=bx.cx + origin[0], cy=bx.cy + origin[1])
                  for bx in reef.boxes],
    }


# ---------------------------------------------------------------------------- presets


@dataclass(frozen=True)
class JacketOptions:
    """The ``jacket`` preset, after the pile paper: a four-pile jacket, 22 m sides.

    Every field can be overridden (``simulate("jacket", radius=1.0)`` or
    ``mbinspect simulate jacket --radius 1.0``). Lengths in m, angles in degrees.
    """

    side: float = 22.0  #: design side of the square of piles
    radius: float = 0.75  #: pile radius
    top: float = -16.0  #: design top elevation
    seabed: float = -21.0  #: seabed elevation at the jacket centre
    slope_deg: float = 0.5  #: seabed slope
    sand_wave_amplitude: float = 0.0  #: sand wave half height
    roughness: float = 0.03  #: seabed roughness RMS
    position_scatter: float = 0.03  #: as-built deviation of each pile from design (1 sigma)
    top_scatter: float = 0.02  #: as-built deviation of each top elevation (1 sigma)
    tilt_max_deg: float = 1.0  #: tilts drawn uniformly in [0, tilt_max]
    lines: str = "west,east,south,north,tops"  #: which survey lines to sail
    line_offset: float = 12.5  #: distance of the '#' lines outside the piles
    line_extent: float = 36.0  #: half-length of every line from the jacket centre
    ping_spacing: float = 0.05  #: along-track ping spacing
    boulders: int = 2  #: distractor boulders near the jacket
    origin_x: float = 512300.0  #: easting of the jacket centre
    origin_y: float = 3456700.0  #: northing of the jacket centre


@dataclass(frozen=True)
class ReefFieldOptions:
    """The ``reef-field`` preset, after the reef paper: groups of 25 reefs at -17.3 m.

    ``groups`` lists the reef kind of each group (``cross2``, ``cross1``, ``hollow``,
    ``triangle``, ``cube`` or ``mixed``). Lengths in m, angles in degrees.
    """

    groups: str = "cross2,cross2,cross2,cross1"  #: reef kind per group
    per_group: int = 25  #: reefs per group (a square grid, jittered)
    grid_spacing: float = 6.0  #: nominal spacing of reefs in a group
    jitter: float = 0.8  #: placement scatter of each reef (1 sigma)
    reef_scale: float = 1.0  #: as-built size of every reef relative to its design
    group_spacing: float = 55.0  #: spacing of group centres
    seabed: float = -17.3  #: seabed elevation at the field centre
    slope_deg: float = 0.3  #: seabed slope
    sand_wave_amplitude: float = 0.0  #: sand wave half height
    sand_wave_length: float = 25.0  #: sand wave length
    roughness: float = 0.04  #: seabed roughness RMS
    close_pairs: int = 6  #: pairs moved to 0.3-0.9 m apart
    touching_pairs: int = 0  #: pairs moved until they touch
    boulders: int = 8  #: distractor boulders (r 0.25-0.5 m)
    rocks: int = 0  #: rounded rocks of reef size (1.2-2.6 m across, 0.4-1.5 m proud, some two-lobed)
    burial_max: float = 0.0  #: reefs sunk a further 0 to this many m into the seabed
    debris: int = 4  #: distractor debris items (< 1 m^2)
    shore_width: float = 0.0  #: a steep rocky shore rising over this width north of the reefs (0 = none)
    line_spacing: float = 22.0  #: spacing of the parallel survey lines
    ping_spacing: float = 0.55  #: along-track ping spacing
    origin_x: float = 402500.0  #: easting of the field centre
    origin_y: float = 3372800.0  #: northing of the field centre


@dataclass(frozen=True)
class WharfOptions:
    """The ``wharf`` preset: a row of four-pile jackets along a wharf, some of battered piles.

    ``rakes`` gives each jacket's pile rake 1:N (one horizontal over N vertical): ``0`` for
    vertical piles, ``6`` for 1:6 (9.5 deg), ``4`` for 1:4 (14 deg); battered piles lean
    outward from their jacket's centre. Lengths in m, angles in degrees.
    """

    rakes: str = "0,6,4"  #: per jacket, the rake 1:N of its piles (0: vertical)
    side: float = 14.0  #: design side of each jacket's square of piles
    gap: float = 26.0  #: clear distance between neighbouring jackets' nearest piles
    radius: float = 0.6  #: pile radius
    top: float = -8.0  #: design top elevation
    seabed: float = -14.0  #: seabed elevation at the wharf centre
    slope_deg: float = 0.5  #: seabed slope
    roughness: float = 0.03  #: seabed roughness RMS
    position_scatter: float = 0.03  #: as-built deviation of each pile from design (1 sigma)
    top_scatter: float = 0.02  #: as-built deviation of each top elevation (1 sigma)
    line_offset: float = 10.0  #: distance of the lines along the wharf outside the piles
    ping_spacing: float = 0.08  #: along-track ping spacing
    origin_x: float = 402800.0  #: easting of the wharf centre
    origin_y: float = 3372900.0  #: northing of the wharf centre


#: Named sonars: the error model a simulation starts from (its fields stay overridable).
#: ``shallow`` (the default) is calibrated against the real files of 4–58 m in
#: ``benchmarks/real_noise.py``; ``classic`` is the idealised model the first studies used.
SONARS: dict[str, Sonar] = {
    # a 400 kHz shallow-water system at 10-30 m: heavy tails, noise growing off nadir,
    # strips that disagree, uncalibrated backscatter
    "shallow": Sonar(angle_sigma_deg=0.02, tail_dof=3.5, speckle_db=5.0, range_angle_growth=1.2,
                     line_offset_sigma=0.03,
                     refraction_sigma_deg=0.03, beam_bias_sigma=0.003, bs_line_sigma_db=3.0,
                     bs_angle_db=10.0),
    # a 30 kHz deep-water system at 100-1000 m: wider beams, coarser detection, no RTK
    "deep": Sonar(swath_deg=130.0, n_beams=288, range_sigma=0.015, range_sigma_rel=0.0001,
                  angle_sigma_deg=0.015, position_sigma=0.05, vertical_sigma=0.025,
                  tail_dof=3.5, speckle_db=5.0, range_angle_growth=0.8, line_offset_sigma=0.05,
                  refraction_sigma_deg=0.03, beam_bias_sigma=0.005, bs_line_sigma_db=3.0,
                  bs_angle_db=10.0),
    # the first studies' idealised model: normal noise, no line errors, calibrated backscatter
    "classic": Sonar(),
}

#: The sonar a simulation uses unless told.
DEFAULT_SONAR = "shallow"


@dataclass(frozen=True)
class SonarChoice:
    """The one simulation option that is not a field of :class:`Sonar`."""

    sonar: str = DEFAULT_SONAR  #: named sonar (SONARS) whose fields the sonar options override


#: Preset name -> options class.
PRESETS: dict[str, type] = {
    "jacket": JacketOptions,
    "wharf": WharfOptions,
    "reef-field": ReefFieldOptions,
}


def _jacket(opt: JacketOptions, rng: np.random.Generator, sonar: Sonar
            ) -> tuple[Scene, Survey, dict[str, Any]]:
    h = opt.side / 2
    seabed = Seabed(z0=opt.seabed, slope_deg=opt.slope_deg, slope_bearing_deg=rng.uniform(0, 360),
                    sand_wave_amplitude=opt.sand_wave_amplitude, roughness=opt.roughness,
                    extent=opt.line_extent + opt.line_offset + 60, seed=int(rng.integers(2**31)))
    design = [(-h, -h), (h, -h), (-h, h), (h, h)]  # ids 1..4: SW, SE, NW, NE
    piles = []
    for dx, dy in design:
        off = rng.normal(0.0, opt.position_scatter, 2)
        piles.append(Pile(dx + off[0], dy + off[1], opt.top + rng.normal(0, opt.top_scatter),
                          opt.radius, tilt_deg=rng.uniform(0, opt.tilt_max_deg),
                          tilt_bearing_deg=rng.uniform(0, 360), bottom_z=opt.seabed - 15))
    boulders = []
    for _ in range(opt.boulders):
        while True:
            p = rng.uniform(-h - 8, h + 8, 2)
            if min(math.hypot(p[0] - q.x, p[1] - q.y) for q in piles) > 4:
                break
        r = rng.uniform(0.3, 0.6)
        boulders.append(Boulder(p[0], p[1], float(seabed.elevation(p[0], p[1])) - 0.3 * r, r))
    e, o = opt.line_extent, h + opt.line_offset
    catalogue = {
        "west": [((-o, -e), (-o, e))], "east": [((o, e), (o, -e))],
        "south": [((e, -o), (-e, -o))], "north": [((-e, o), (e, o))],
        "tops": [((-h, -e), (-h, e)), ((h, e), (h, -e))],
    }
    lines = []
    for name in [s.strip() for s in opt.lines.split(",") if s.strip()]:
        if name not in catalogue:
            raise fail("lines", name, f"one of {', '.join(catalogue)}")
        lines += [Line(v, ping_spacing=opt.ping_spacing) for v in catalogue[name]]
    scene = Scene(seabed, tuple(piles), boulders=tuple(boulders),
                  origin=(opt.origin_x, opt.origin_y))
    extra = {"design": [{"id": i + 1, "x": dx + opt.origin_x, "y": dy + opt.origin_y}
                        for i, (dx, dy) in enumerate(design)]}
    return scene, Survey(tuple(lines), sonar), extra


def _rakes(text: str) -> list[float]:
    try:
        rakes = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise fail("rakes", text, "pile rakes 1:N per jacket, comma-separated (0 for vertical)") from None
    if not rakes or any(r != 0 and r < 1 for r in rakes):
        raise fail("rakes", text, "at least one jacket, each rake 0 (vertical) or N >= 1 for 1:N")
    return rakes


def _wharf(opt: WharfOptions, rng: np.random.Generator, sonar: Sonar
           ) -> tuple[Scene, Survey, dict[str, Any]]:
    rakes = _rakes(opt.rakes)
    pitch = opt.side + opt.gap
    h = opt.side / 2
    half = (len(rakes) - 1) * pitch / 2 + h
    seabed = Seabed(z0=opt.seabed, slope_deg=opt.slope_deg, slope_bearing_deg=rng.uniform(0, 360),
                    roughness=opt.roughness, extent=half + opt.line_offset + 60,
                    seed=int(rng.integers(2**31)))
    piles: list[Pile] = []
    design: list[dict[str, Any]] = []
    for g, rake in enumerate(rakes):
        cx = -(len(rakes) - 1) * pitch / 2 + g * pitch
        tilt = math.degrees(math.atan(1.0 / rake)) if rake else 0.0
        for dx, dy in ((-h, -h), (h, -h), (-h, h), (h, h)):
            off = rng.normal(0.0, opt.position_scatter, 2)
            outward = math.degrees(math.atan2(dx, dy)) % 360.0
            piles.append(Pile(cx + dx + off[0], dy + off[1], opt.top + rng.normal(0, opt.top_scatter),
                              opt.radius, tilt_deg=tilt, tilt_bearing_deg=outward, bottom_z=opt.seabed - 15))
            design.append({"group": g + 1, "id": len(design) + 1, "x": cx + dx + opt.origin_x,
                           "y": dy + opt.origin_y})
    e, o = half + 25.0, h + opt.line_offset
    lines = [Line(((-e, -o), (e, -o)), ping_spacing=opt.ping_spacing),
             Line(((e, o), (-e, o)), ping_spacing=opt.ping_spacing),
             Line(((-e, -h), (e, -h)), ping_spacing=opt.ping_spacing),
             Line(((e, h), (-e, h)), ping_spacing=opt.ping_spacing)]
    scene = Scene(seabed, tuple(piles), origin=(opt.origin_x, opt.origin_y))
    jackets = [{"group": g + 1, "rake": r} for g, r in enumerate(rakes)]
    return scene, Survey(tuple(lines), sonar), {"design": design, "jackets": jackets}


def _reef_field(opt: ReefFieldOptions, rng: np.random.Generator, sonar: Sonar
                ) -> tuple[Scene, Survey, dict[str, Any]]:
    kinds = [s.strip() for s in opt.groups.split(",") if s.strip()]
    if not kinds:
        raise ParameterError("groups: no reef group given; expected e.g. cross2,cross1")
    ng = len(kinds)
    cols = int(math.ceil(math.sqrt(ng)))
    rows = int(math.ceil(ng / cols))
    seabed = Seabed(z0=opt.seabed, slope_deg=opt.slope_deg, slope_bearing_deg=rng.uniform(0, 360),
                    sand_wave_amplitude=opt.sand_wave_amplitude,
                    sand_wave_length=opt.sand_wave_length,
                    sand_wave_bearing_deg=rng.uniform(0, 180), roughness=opt.roughness,
                    extent=opt.group_spacing * max(rows, cols) / 2 + 90,
                    seed=int(rng.integers(2**31)))
    side = int(math.ceil(math.sqrt(opt.per_group)))
    reefs: list[Reef] = []

    # one sink per reef id, drawn up front so that a reef rebuilt for the shore (below) keeps
    # its own; the table's size bounds the ids, not the field (ids stay in the hundreds)
    sunk = rng.uniform(0.0, opt.burial_max, 10_000) if opt.burial_max > 0 else np.zeros(10_000)

    def make(rid: int, kind: str, x: float, y: float, b: float, g: int) -> Reef:
        z = float(seabed.elevation(x, y)) - 0.1 - float(sunk[rid % len(sunk)])
        return Reef(rid, kind, x, y, b, reef_boxes(kind, x, y, b, z, opt.reef_scale), group=g)

    for g, kind in enumerate(kinds):
        gx = (g % cols - (cols - 1) / 2) * opt.group_spacing
        gy = ((rows - 1) / 2 - g // cols) * opt.group_spacing
        for k in range(opt.per_group):
            nominal = (gx + (k % side - (side - 1) / 2) * opt.grid_spacing,
                       gy + (k // side - (side - 1) / 2) * opt.grid_spacing)
            kk = kind if kind != "mixed" else ("cross2", "cross1", "hollow", "triangle")[k % 4]
            for _ in range(200):
                x, y = np.asarray(nominal) + rng.normal(0.0, opt.jitter, 2)
                cand = make(len(reefs) + 1, kk, x, y, rng.uniform(0, 90), g + 1)
                if all(_reef_gap(cand, r) > 1.2 for r in reefs
                       if math.hypot(r.x - x, r.y - y) < 8):
                    break
            reefs.append(cand)
    # bring chosen neighbour pairs close together or into contact
    targets = [(rng.uniform(0.3, 0.9)) for _ in range(opt.close_pairs)]
    targets += [0.0] * opt.touching_pairs
    moved: set[int] = set()
    for target in targets:
        order = rng.permutation(len(reefs))
        for i in order:
            if i in moved:
                continue
            a = reefs[i]
            near = [j for j in range(len(reefs)) if j != i and j not in moved
                    and reefs[j].group == a.group
                    and math.hypot(reefs[j].x - a.x, reefs[j].y - a.y) < opt.grid_spacing * 1.5]
            if not near:
                continue
            j = min(near, key=lambda j: math.hypot(reefs[j].x - a.x, reefs[j].y - a.y))
            b = reefs[j]
            v = np.array([a.x - b.x, a.y - b.y])
            dist = float(np.hypot(*v))
            v /= dist

            def at(s: float, b: Reef = b, v: np.ndarray = v) -> Reef:
                return make(b.id, b.kind, b.x + s * v[0], b.y + s * v[1], b.bearing_deg, b.group)

            lo, hi = 0.0, dist
            for _ in range(40):
                mid = (lo + hi) / 2
                if _reef_gap(a, at(mid)) > target:
                    lo = mid
                else:
                    hi = mid
            new = at(lo if target > 0 else hi)
            others = [r for k2, r in enumerate(reefs) if k2 not in (i, j)
                      and math.hypot(r.x - new.x, r.y - new.y) < 8]
            if all(_reef_gap(new, r) > 1.0 for r in others):
                reefs[j] = new
                moved.update((i, j))
                break
    xy = np.array([[r.x, r.y] for r in reefs])
    lo, hi = xy.min(axis=0) - 12, xy.max(axis=0) + 12
    if opt.shore_width > 0:
        seabed = dataclasses.replace(seabed, shore_start=float(hi[1]) + 3.0,
                                     shore_width=opt.shore_width)
        reefs = [make(r.id, r.kind, r.x, r.y, r.bearing_deg, r.group) for r in reefs]
    survey_hi = hi + np.array([0.0, opt.shore_width])
    boulders: list[Boulder] = []
    debris: list[Box] = []
    for n_items, is_boulder in ((opt.boulders, True), (opt.debris, False)):
        for _ in range(n_items):
            for _ in range(500):
                p = rng.uniform(lo, hi)
                if np.min(np.hypot(*(xy - p).T)) > 4.5:
                    break
            z = float(seabed.elevation(p[0], p[1]))
            if is_boulder:
                r = rng.uniform(0.25, 0.5)
                boulders.append(Boulder(p[0], p[1], z - 0.3 * r, r))
            else:
                debris.append(Box(p[0], p[1], z - 0.05, rng.uniform(0.5, 1.2),
                                  rng.uniform(0.3, 0.6), rng.uniform(0.2, 0.5),
                                  rng.uniform(0, 180)))
    boulders += _rocks(opt.rocks, rng, seabed, lo, hi, xy, first=len(boulders) + 1)
    lines = []
    y0, y1 = lo[1] - 10, survey_hi[1] + 10
    n_lines = int(math.ceil((y1 - y0) / opt.line_spacing)) + 1
    for k in range(n_lines):
        y = y0 + k * opt.line_spacing
        xs = (lo[0] - 15, hi[0] + 15) if k % 2 == 0 else (hi[0] + 15, lo[0] - 15)
        lines.append(Line(((xs[0], y), (xs[1], y)), ping_spacing=opt.ping_spacing))
    scene = Scene(seabed, reefs=tuple(reefs), boulders=tuple(boulders), debris=tuple(debris),
                  origin=(opt.origin_x, opt.origin_y))
    return scene, Survey(tuple(lines), sonar), {}


def _rocks(n: int, rng: np.random.Generator, seabed: Seabed, lo: np.ndarray, hi: np.ndarray,
           reefs_xy: np.ndarray, first: int) -> list[Boulder]:
    """``n`` rounded rocks of reef size, each an ellipsoid sunk so that 0.4-1.5 m shows, a
    third of them with a second, smaller lobe (numbered ``first``, ``first + 1``, ...)."""
    if n == 0:
        return []
    rng = np.random.default_rng(rng.integers(2**63))  # its own stream: other scenes stay as they were
    out: list[Boulder] = []
    for k in range(n):
        for _ in range(500):
            p = rng.uniform(lo, hi)
            if np.min(np.hypot(*(reefs_xy - p).T)) > 4.5 and all(
                    math.hypot(b.x - p[0], b.y - p[1]) > 4.0 for b in out):
                break
        a = rng.uniform(0.6, 1.3)
        proud = rng.uniform(0.4, 1.5)
        rz = proud / rng.uniform(0.6, 0.9)
        bearing = rng.uniform(0, 180)
        z = float(seabed.elevation(p[0], p[1])) + proud - rz
        out.append(Boulder(p[0], p[1], z, a, ry=a * rng.uniform(0.6, 1.0), rz=rz, bearing_deg=bearing,
                           rock=first + k))
        if rng.random() < 1 / 3:
            u = bearing_to_vector(bearing) * a * rng.uniform(0.7, 1.0)
            s = rng.uniform(0.6, 0.8)
            out.append(Boulder(p[0] + u[0], p[1] + u[1], z - rz * (1 - s) * 0.5, a * s, ry=a * s * 0.8,
                               rz=rz * s, bearing_deg=bearing + rng.uniform(-40, 40), rock=first + k))
    return out


@dataclass(frozen=True, eq=False)
class Simulation:
    """A simulated survey: the soundings, what each one hit, and the exact truth.

    Attributes
    ----------
    cloud : PointCloud
    labels, ident : ndarray
        Per-sounding truth (see :func:`survey`).
    truth : dict
        JSON-ready truth: piles and spacings, reefs and groups, distractors, seabed.
    scene : Scene
    plan : Survey
    """

    cloud: PointCloud
    labels: np.ndarray
    ident: np.ndarray
    truth: dict[str, Any]
    scene: Scene
    plan: Survey

    def reference_rows(self, *, sigma: float = 0.15, seed: int = 0) -> list[tuple[float, float, int]]:
        """Reef positions as a surveyor would digitise them (x, y, id), with ``sigma`` m scatter."""
        return reef_reference_rows(self.truth, sigma=sigma, seed=seed)


def reef_reference_rows(truth: dict[str, Any], *, sigma: float = 0.15, seed: int = 0
                        ) -> list[tuple[float, float, int]]:
    """A truth's reef positions as a surveyor would digitise them (x, y, id), with ``sigma`` m
    scatter."""
    rng = np.random.default_rng(seed)
    return [(r["x"] + rng.normal(0, sigma), r["y"] + rng.normal(0, sigma), r["id"]) for r in truth["reefs"]]


def _option_names(preset: str) -> type:
    if preset not in PRESETS:
        raise ParameterError(f"preset: {preset!r}; expected one of {', '.join(PRESETS)}", option="preset")
    return PRESETS[preset]


def named_sonar(name: str) -> Sonar:
    """The :class:`Sonar` of a name in :data:`SONARS`.

    Raises
    ------
    ParameterError
        An unknown name.

    Examples
    --------
    >>> named_sonar("classic").tail_dof
    0.0
    """
    if name not in SONARS:
        raise ParameterError(f"sonar: {name!r}; expected one of {', '.join(SONARS)}", option="sonar")
    return SONARS[name]


def default_options(preset: str, sonar: str = DEFAULT_SONAR) -> dict[str, Any]:
    """Every option of a preset with its value before overrides (``--show-options``)."""
    return {**dataclasses.asdict(_option_names(preset)()), "sonar": sonar,
            **dataclasses.asdict(named_sonar(sonar))}


#: Most soundings a simulation makes unless ``force`` (about 5 GB of memory at this size).
MAX_SOUNDINGS = 50_000_000

#: The survey lines the ``jacket`` preset can sail.
JACKET_LINES = ("west", "east", "south", "north", "tops")


def simulate(preset: str, *, seed: int = 0, progress: Callable[[float], None] | None = None,
             force: bool = False, **overrides: Any) -> Simulation:
    """Simulate a preset survey with exact truth.

    Parameters
    ----------
    preset : {"jacket", "reef-field"}
    seed : int
        Seeds the scene (as-built deviations, reef placement) and, independently,
        the measurement errors. The same seed gives the same soundings and truth.
    progress : callable, optional
        Called with the fraction of pings done.
    force : bool
        Simulate even when the survey would make more than :data:`MAX_SOUNDINGS`.
    **overrides
        Any field of the preset's options (:class:`JacketOptions`,
        :class:`ReefFieldOptions`) or of :class:`Sonar`.

    Returns
    -------
    Simulation

    Raises
    ------
    ParameterError
        An unknown or bad option (named by its library name), a negative seed, or a survey
        of more than :data:`MAX_SOUNDINGS` without ``force``.

    Examples
    --------
    >>> sim = simulate("jacket", seed=1, ping_spacing=1.0)
    >>> len(sim.truth["piles"]), sim.truth["spacings"][0]["a"]
    (4, 1)
    """
    setup = _setup(preset, seed, overrides)
    estimate = setup.plan.estimated_soundings()
    if estimate > MAX_SOUNDINGS and not force:
        raise ParameterError(
            f"ping_spacing: {setup.opt.ping_spacing} m makes about {estimate / 1e6:,.0f} million soundings; "
            f"expected at most {MAX_SOUNDINGS / 1e6:,.0f} million (give `force` to simulate it anyway)",
            option="ping_spacing")
    cloud, labels, ident = survey(setup.scene, setup.plan, seed=int(setup.noise_seed.generate_state(1)[0]),
                                  progress=progress)
    truth = _truth(preset, seed, setup.opt, setup.sonar, setup.scene, labels, setup.extra)
    truth["sonar"] = {"name": setup.sonar_name, **truth["sonar"]}
    return Simulation(cloud, labels, ident, truth, setup.scene, setup.plan)


@dataclass(frozen=True)
class _Setup:
    opt: Any
    sonar: Sonar
    sonar_name: str
    scene: Scene
    plan: Survey
    extra: dict[str, Any]
    noise_seed: np.random.SeedSequence


def _setup(preset: str, seed: int, overrides: dict[str, Any]) -> _Setup:
    """The preset's options checked, its scene built and its lines planned."""
    integer("seed", seed, minimum=0, maximum=2**63 - 1)
    opt_cls = _option_names(preset)
    overrides = dict(overrides)
    sonar_name = overrides.pop("sonar", DEFAULT_SONAR)
    sonar = named_sonar(sonar_name)
    opt_fields = {f.name for f in dataclasses.fields(opt_cls)}
    sonar_fields = {f.name for f in dataclasses.fields(Sonar)}
    unknown = set(overrides) - opt_fields - sonar_fields
    if unknown:
        raise ParameterError(
            f"{sorted(unknown)[0]}: not an option of the {preset} preset; "
            f"expected one of {', '.join(sorted(opt_fields | sonar_fields | {'sonar'}))}",
            option=sorted(unknown)[0]
        )
    opt = opt_cls(**{k: v for k, v in overrides.items() if k in opt_fields})
    sonar = dataclasses.replace(sonar, **{k: v for k, v in overrides.items() if k in sonar_fields})
    _check_options(opt, sonar)
    scene_seed, noise_seed = np.random.SeedSequence(seed).spawn(2)
    builders: dict[str, Callable[..., tuple[Scene, Survey, dict[str, Any]]]] = {
        "jacket": _jacket, "wharf": _wharf, "reef-field": _reef_field}
    scene, plan, extra = builders[preset](opt, np.random.default_rng(scene_seed), sonar)
    return _Setup(opt, sonar, sonar_name, scene, plan, extra, noise_seed)


def simulate_lines(preset: str, out: str | Path, *, seed: int = 0, suffix: str = ".laz",
                   progress: Callable[[float], None] | None = None, workers: int = 1,
                   **overrides: Any) -> dict[str, Any]:
    """Simulate a preset survey as one file per line, streaming line by line: memory
    follows one line, not the survey (no :data:`MAX_SOUNDINGS` limit).

    Each line is sailed on its own (its errors drawn from its own seed, spawned from
    ``seed``) over the objects within reach of its swath; ``line_NNN<suffix>`` holds its
    soundings (fields ``intensity``, ``beam_angle``, ``line``, ``ping`` from 1 per line,
    ``label``), and ``truth.json`` the truth as :func:`simulate` writes it. The files do
    not depend on ``workers``.

    Parameters
    ----------
    preset : {"jacket", "wharf", "reef-field"}
    out : path-like
        A folder (created).
    seed : int
    suffix : str
        The files' format, by extension (``.laz``, ``.las``, ``.npz``, ``.xyz``).
    progress : callable, optional
        Called with the fraction of lines written.
    workers : int
        Lines simulated at once, in as many processes.
    **overrides
        As :func:`simulate`.

    Returns
    -------
    dict
        The truth (also in ``truth.json``), with ``files``.
    """
    from concurrent.futures import ProcessPoolExecutor

    from .outputs import write_json

    setup = _setup(preset, seed, overrides)
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    n = len(setup.plan.lines)
    jobs = [(preset, seed, tuple(sorted(overrides.items())), k, str(folder), suffix) for k in range(n)]
    counts: dict[str, int] = {}
    files = []
    total = 0
    if workers > 1:
        with ProcessPoolExecutor(workers) as pool:
            done = pool.map(_line_job, jobs)
            results = []
            for k, r in enumerate(done):
                results.append(r)
                if progress is not None:
                    progress((k + 1) / n)
    else:
        results = []
        for k, job in enumerate(jobs):
            results.append(_line_job(job, setup))
            if progress is not None:
                progress((k + 1) / n)
    for name, line_counts in results:
        files.append(name)
        for label, c in line_counts.items():
            counts[label] = counts.get(label, 0) + c
            total += c
    truth = _truth(preset, seed, setup.opt, setup.sonar, setup.scene, np.zeros(0, np.int8), setup.extra)
    truth.update(sonar={"name": setup.sonar_name, **truth["sonar"]}, counts=counts, n_soundings=total,
                 files=files)
    write_json(truth, folder / "truth.json")
    return truth


#: The scene a worker process of :func:`simulate_lines` last built, by its job's preset,
#: seed and options.
_SETUPS: dict[tuple[Any, ...], _Setup] = {}


def _line_job(job: tuple[str, int, tuple[tuple[str, Any], ...], int, str, str], setup: _Setup | None = None
              ) -> tuple[str, dict[str, int]]:
    """Sail line ``k`` of a preset and write its file; its name and label counts."""
    preset, seed, overrides, k, folder, suffix = job
    if setup is None:  # in a worker process: build the scene once for all its lines
        key = (preset, seed, overrides)
        if key not in _SETUPS:
            _SETUPS.clear()
            _SETUPS[key] = _setup(preset, seed, dict(overrides))
        setup = _SETUPS[key]
    line = setup.plan.lines[k]
    sonar = setup.sonar
    line_seed = setup.noise_seed.spawn(len(setup.plan.lines))[k]
    reach = (sonar.draft + abs(float(setup.scene.seabed.z0)) + 15.0) * math.tan(
        math.radians(min(sonar.swath_deg, 170.0) / 2)) + 10.0
    v = np.asarray(line.vertices, np.float64)
    box = (v[:, 0].min() - reach, v[:, 0].max() + reach, v[:, 1].min() - reach, v[:, 1].max() + reach)
    cloud, labels, _ = survey(_near(setup.scene, box), Survey((line,), sonar),
                              seed=int(line_seed.generate_state(1)[0]))
    fields = {**cloud.fields, "line": np.full(len(cloud), k + 1, np.int32), "label": labels.astype(np.int32)}
    name = Path(folder) / f"line_{k + 1:03d}{suffix}"
    write(PointCloud(cloud.xyz, fields), name)
    return name.name, {label: int(np.sum(labels == code)) for label, code in LABELS.items()}


def _near(scene: Scene, box: tuple[float, float, float, float]) -> Scene:
    """The scene with only the objects whose plan extent meets ``box`` (local metres)."""
    x0, x1, y0, y1 = box

    def meets(b: tuple[float, float, float, float]) -> bool:
        return not (b[1] < x0 or b[0] > x1 or b[3] < y0 or b[2] > y1)

    piles = tuple(p for p in scene.piles if meets((p.x - 5, p.x + 5, p.y - 5, p.y + 5)))
    reefs = tuple(r for r in scene.reefs if meets((r.x - 10, r.x + 10, r.y - 10, r.y + 10)))
    boulders = tuple(b for b in scene.boulders if meets((b.x - 5, b.x + 5, b.y - 5, b.y + 5)))
    debris = tuple(d for d in scene.debris if meets((d.cx - 5, d.cx + 5, d.cy - 5, d.cy + 5)))
    return dataclasses.replace(scene, piles=piles, reefs=reefs, boulders=boulders, debris=debris)


def _check_options(opt: Any, sonar: Sonar) -> None:
    positive = {"side", "radius", "ping_spacing", "grid_spacing", "group_spacing",
                "line_spacing", "per_group", "line_extent", "swath_deg", "n_beams", "reef_scale"}
    for obj in (opt, sonar):
        for f in dataclasses.fields(obj):
            v = getattr(obj, f.name)
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                if not math.isfinite(v):
                    raise fail(f.name, v, "a finite number")
                if f.name in positive and v <= 0:
                    raise fail(f.name, v, "a positive number")
                if v < 0 and f.name not in ("top", "seabed", "origin_x", "origin_y"):
                    raise fail(f.name, v, "a number >= 0")
    if 0 < sonar.tail_dof <= 2:
        raise fail("tail_dof", sonar.tail_dof, "0 (normal noise) or more than 2 degrees of freedom")
    if sonar.swath_deg >= 170:
        raise fail("swath_deg", sonar.swath_deg, "a swath below 170 deg")
    if isinstance(opt, JacketOptions):
        names = [s.strip() for s in opt.lines.split(",") if s.strip()]
        bad = [n for n in names if n not in JACKET_LINES]
        if not names or bad:
            raise fail("lines", bad[0] if bad else opt.lines,
                       f"survey lines from {', '.join(JACKET_LINES)}, comma-separated")
        if opt.top < opt.seabed + 0.5:
            raise fail("top", opt.top, f"a pile top at least 0.5 m above the seabed ({opt.seabed} m)")
    if isinstance(opt, WharfOptions):
        _rakes(opt.rakes)
        if opt.top < opt.seabed + 0.5:
            raise fail("top", opt.top, f"a pile top at least 0.5 m above the seabed ({opt.seabed} m)")
    if isinstance(opt, ReefFieldOptions):
        kinds = [s.strip() for s in opt.groups.split(",") if s.strip()]
        bad = [k for k in kinds if k not in BUILTIN_DESIGNS and k != "mixed"]
        if not kinds or bad:
            raise fail("groups", bad[0] if bad else opt.groups,
                       f"reef kinds from {', '.join(BUILTIN_DESIGNS)}, mixed, comma-separated")
        most = opt.per_group * len(kinds) // 2
        if opt.close_pairs + opt.touching_pairs > most:
            raise fail("touching_pairs" if opt.touching_pairs else "close_pairs",
                       opt.touching_pairs or opt.close_pairs,
                       f"close_pairs + touching_pairs at most {most} (half the {2 * most} reefs)")


def truth_spacings(piles: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Every pair's plan distance, as truth files hold it: ``{"a", "b", "distance"}``.

    Examples
    --------
    >>> truth_spacings([{"id": 1, "x": 0.0, "y": 0.0}, {"id": 2, "x": 3.0, "y": 4.0}])
    [{'a': 1, 'b': 2, 'distance': 5.0}]
    """
    return [{"a": a["id"], "b": b["id"], "distance": math.hypot(a["x"] - b["x"], a["y"] - b["y"])}
            for a, b in itertools.combinations(piles, 2)]


def _truth(preset: str, seed: int, opt: Any, sonar: Sonar, scene: Scene, labels: np.ndarray,
           extra: dict[str, Any]) -> dict[str, Any]:
    ox, oy = scene.origin
    piles = []
    groups_of = {d["id"]: d.get("group", 1) for d in extra.get("design", [])}
    for i, p in enumerate(scene.piles):
        piles.append({"id": i + 1, "x": p.x + ox, "y": p.y + oy, "z": p.top_z,
                      "radius": p.radius, "tilt_deg": p.tilt_deg,
                      "tilt_azimuth_deg": p.tilt_bearing_deg % 360.0, "group": groups_of.get(i + 1, 1),
                      "seabed_z": float(scene.seabed.elevation(p.x, p.y))})
    spacings = truth_spacings(piles)
    reefs = [reef_truth(r, scene.seabed, scene.origin) for r in scene.reefs]
    groups = []
    for g in sorted({r.group for r in scene.reefs}):
        members = [t for t in reefs if t["group"] == g]
        outline = convex_hull(np.concatenate([np.asarray(t["outline"]) for t in members]))
        groups.append({"id": g, "count": len(members),
                       "x": float(np.mean([t["x"] for t in members])),
                       "y": float(np.mean([t["y"] for t in members])),
                       "area": polygon_area(outline), "kind": members[0]["kind"]})
    close = []
    for a, b in itertools.combinations(scene.reefs, 2):
        if math.hypot(a.x - b.x, a.y - b.y) < 6:
            gap = _reef_gap(a, b)
            if gap < 1.0:
                close.append({"a": a.id, "b": b.id, "gap": gap})
    distractors = (
        [{"kind": "boulder", "x": b.x + ox, "y": b.y + oy, "z_top": b.z + b.radius,
          "radius": b.radius} for b in scene.boulders if not b.rock]
        + _rock_truth(scene)
        + [{"kind": "debris", "x": d.cx + ox, "y": d.cy + oy, "z_top": d.z0 + d.height,
            "length": d.length, "width": d.width} for d in scene.debris]
    )
    counts = {name: int(np.sum(labels == code)) for name, code in LABELS.items()}
    return {
        "preset": preset, "seed": seed,
        "options": dataclasses.asdict(opt), "sonar": dataclasses.asdict(sonar),
        "origin": [ox, oy], "n_soundings": int(len(labels)), "counts": counts,
        "seabed": scene.seabed.to_dict(),
        "piles": piles, "spacings": spacings, **extra,
        "reefs": reefs, "groups": groups, "close_pairs": close, "distractors": distractors,
    }


def _rock_truth(scene: Scene) -> list[dict[str, Any]]:
    """One record per rock (its lobes together): centre of its lobes, top, plan size, proud height."""
    ox, oy = scene.origin
    out = []
    for rid in sorted({b.rock for b in scene.boulders if b.rock}):
        lobes = [b for b in scene.boulders if b.rock == rid]
        top = max(b.z + float(b.axes[2]) for b in lobes)
        main = lobes[0]
        out.append({"kind": "rock", "id": rid, "x": main.x + ox, "y": main.y + oy, "z_top": top,
                    "height": top - float(scene.seabed.elevation(main.x, main.y)),
                    "size": 2 * max(float(b.axes[:2].max()) + math.hypot(b.x - main.x, b.y - main.y)
                                    for b in lobes), "lobes": len(lobes)})
    return out


def option_fields(preset: str) -> list[dataclasses.Field[Any]]:
    """Every overridable option of a preset (its own fields, then the sonar's)."""
    return (list(dataclasses.fields(_option_names(preset))) + list(dataclasses.fields(SonarChoice))
            + list(dataclasses.fields(Sonar)))

