"""Rays against the scene: the first surface each beam meets (seabed, cylinders, boxes,
spheres) and the heavy-tailed noise the error model draws from."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..geometry import ray_cylinder
from ..solids import ray_box
from .scene import LABELS, Boulder, Box, Pile, Scene, Seabed


def heavy_noise(rng: np.random.Generator, n: int, dof: float) -> np.ndarray:
    """Unit noise: normal, or Student-t of ``dof`` degrees of freedom with the normal's MAD."""
    if dof <= 0:
        return rng.normal(0.0, 1.0, n)
    from scipy.special import stdtrit

    return rng.standard_t(dof, n) * (0.6744897501960817 / float(stdtrit(dof, 0.75)))


def _seabed_hits(seabed: Seabed, o: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Ray parameter t of the first seabed crossing (Newton on the height field)."""
    t = (seabed.z0 - o[:, 2]) / d[:, 2]
    for _ in range(12):
        p = o + t[:, None] * d
        z, gx, gy = seabed.surface(p[:, 0], p[:, 1])
        g = p[:, 2] - z
        dg = d[:, 2] - gx * d[:, 0] - gy * d[:, 1]
        step = g / np.minimum(dg, -0.05)
        t = np.maximum(t - step, 0.0)
        if np.max(np.abs(g)) < 1e-6:
            break
    return t


def _hit_cylinder(pile: Pile, o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = pile.axis
    length = (pile.top_z - pile.bottom_z) / max(a[2], 1e-6)
    return ray_cylinder(np.array([pile.x, pile.y, pile.top_z]), a, pile.radius, length, o, d)


def _hit_box(box: Box, o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return ray_box(*box.solid(), o, d)


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
class Target:
    kind: int
    ident: int
    material: str
    bbox: tuple[float, float, float, float]  # xmin, xmax, ymin, ymax
    top: float
    hit: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


def targets(scene: Scene) -> list[Target]:
    out: list[Target] = []
    for i, p in enumerate(scene.piles):
        a = p.axis
        length = (p.top_z - p.bottom_z) / max(a[2], 1e-6)
        bottom = np.array([p.x, p.y]) - a[:2] * length
        xs = [p.x, bottom[0]]
        ys = [p.y, bottom[1]]
        r = p.radius
        out.append(Target(LABELS["pile"], i + 1, p.material,
                           (min(xs) - r, max(xs) + r, min(ys) - r, max(ys) + r),
                           p.top_z + r, _bind(_hit_cylinder, p)))
    for reef in scene.reefs:
        for box in reef.boxes:
            out.append(_box_target(box, LABELS["reef"], reef.id, reef.material))
    for i, b in enumerate(scene.boulders):
        reach = float(b.axes[:2].max())
        out.append(Target(LABELS["boulder"], b.rock or i + 1, b.material,
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


def _box_target(box: Box, kind: int, ident: int, material: str) -> Target:
    c = box.corners2d()
    lo, hi = c.min(axis=0), c.max(axis=0)
    return Target(kind, ident, material, (lo[0], hi[0], lo[1], hi[1]), box.top,
                   _bind(_hit_box, box))


def _spans(targets: list[Target], o: np.ndarray, d: np.ndarray, t: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each ray's plan extent between the highest target's top and ``t``: x0, x1, y0, y1."""
    ztop = max(tg.top for tg in targets)
    t_top = np.clip((ztop - o[:, 2]) / d[:, 2], 0.0, None)
    tq = np.minimum(t_top, t)
    out = []
    for k in (0, 1):  # plan only: the same arithmetic as o + t * d, column by column
        p, q = o[:, k] + t * d[:, k], o[:, k] + tq * d[:, k]
        out += [np.minimum(q, p), np.maximum(q, p)]
    return out[0], out[1], out[2], out[3]


def rays_near(targets: list[Target], o: np.ndarray, d: np.ndarray, t: np.ndarray, spread: float
              ) -> np.ndarray:
    """Which rays pass within ``spread`` × range of a target's plan box before ``t``: the
    beams whose cone (of that tangent half-width) may meet an object."""
    near = np.zeros(len(t), bool)
    if not targets or not len(t):
        return near
    sx0, sx1, sy0, sy1 = _spans(targets, o, d, t)
    reach = np.where(np.isfinite(t), t, 0.0) * spread
    x0, x1, y0, y1 = sx0 - reach, sx1 + reach, sy0 - reach, sy1 + reach
    within = _WestEdges(x0, x1)
    for tg in targets:
        xmin, xmax, ymin, ymax = tg.bbox
        cand = within.candidates(xmin, xmax)
        near[cand[(x0[cand] <= xmax) & (x1[cand] >= xmin) & (y0[cand] <= ymax) & (y1[cand] >= ymin)]] = True
    return near


class _WestEdges:
    """Rays' plan spans ``x0 <= x <= x1`` sorted by their west edge: the rays whose span may
    meet ``[xmin, xmax]`` are those starting within one widest span west of it (the same ones
    as a scan of every ray, found without it: a reef field has hundreds of targets). A ray
    with no finite span is always a candidate."""

    def __init__(self, x0: np.ndarray, x1: np.ndarray) -> None:
        span = x1 - x0
        odd = ~np.isfinite(span)
        self.widest = float(span[~odd].max()) + 1e-6 if (~odd).any() else 0.0
        self.order = np.flatnonzero(~odd)[np.argsort(x0[~odd], kind="stable")]
        self.west = x0[self.order]
        self.extra = np.flatnonzero(odd)

    def candidates(self, xmin: float, xmax: float) -> np.ndarray:
        """Rows of the rays that may meet ``[xmin, xmax]``, in west-edge order."""
        cand = self.order[np.searchsorted(self.west, xmin - self.widest, side="left"):
                          np.searchsorted(self.west, xmax, side="right")]
        return np.concatenate([cand, self.extra]) if len(self.extra) else cand


def first_object_hits(targets: list[Target], o: np.ndarray, d: np.ndarray, t: np.ndarray
                       ) -> Iterator[tuple[Target, np.ndarray, np.ndarray, np.ndarray]]:
    """For each target, the rays that meet it before ``t`` (updated in place as they do):
    yields the target, those rays' indices, their ray parameters and surface normals."""
    if not targets:
        return
    sx0, sx1, sy0, sy1 = _spans(targets, o, d, t)
    within = _WestEdges(sx0, sx1)
    for tg in targets:
        xmin, xmax, ymin, ymax = tg.bbox
        cand = within.candidates(xmin, xmax)
        cand = cand[(sx0[cand] <= xmax) & (sx1[cand] >= xmin) & (sy0[cand] <= ymax) & (sy1[cand] >= ymin)]
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
    for tg, idx, _, _ in first_object_hits(targets(scene), o, d, t):
        label[idx] = tg.kind
        ident[idx] = tg.ident
    return t, label, ident


@dataclass(frozen=True)
class Hits:
    """The first hit of every ray: its ray parameter, what it hit (:data:`LABELS` code and
    object id), the surface normal there, the materials met (sediment first),
    and where the ray met the seabed (parameter and normal) whatever stood before it."""

    t: np.ndarray
    label: np.ndarray
    ident: np.ndarray
    normal: np.ndarray
    materials: list[str]
    seabed_t: np.ndarray
    seabed_normal: np.ndarray


def cast(scene: Scene, targets: list[Target], o: np.ndarray, d: np.ndarray) -> Hits:
    """The first hit of every ray (origins ``o``, unit directions ``d``) on the scene."""
    t = _seabed_hits(scene.seabed, o, d)
    seabed_t = t.copy()
    p = o + t[:, None] * d
    gx, gy = scene.seabed.gradient(p[:, 0], p[:, 1])
    normal = np.column_stack([-gx, -gy, np.ones_like(gx)])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    seabed_normal = normal.copy()
    label = np.full(len(t), LABELS["seabed"], dtype=np.int8)
    ident = np.zeros(len(t), dtype=np.int32)
    materials = ["sediment"]
    for tg, idx, _, nn in first_object_hits(targets, o, d, t):
        normal[idx] = nn
        label[idx] = tg.kind
        ident[idx] = tg.ident
        if tg.material not in materials:
            materials.append(tg.material)
    return Hits(t, label, ident, normal, materials, seabed_t, seabed_normal)
